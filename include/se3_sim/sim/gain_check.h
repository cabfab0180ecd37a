// Controller gains a time step cannot carry. A PD joint of effective inertia M = 1 / (D^-1)_ii
// under the semi-implicit (symplectic Euler) step v+ = v + dt (-p e - d v) / M, q+ = q + dt v+
// is stable only when dt d / M + dt^2 p / (2 M) < 2; past it the joint's velocity flips sign from
// step to step, held in check only by the effort limit. A velocity controller's p is the damping
// (dt p / M < 2). Gazebo-tuned gains on a light wrist at 1 kHz pass it easily (panda_push's old
// d = 40 on the Panda's joint 7 did: M = 0.0055 kg m^2 there, the bound d < 10.8).
//
// The check is per joint at one state, M the joint's inertia with the others free, as they are
// within a step (every torque is held over it); coupling between controlled joints and contact
// are ignored. A warning, not an error: a posture change or a lower dt can cure it.
#pragma once

#include <string>
#include <vector>

#include "se3_sim/dynamics/dynamics.h"
#include "se3_sim/sim/controllers.h"

namespace se3 {

/// One line per PID joint of `specs` past the bound at state x with step dt, naming the
/// controller, the joint, its gains, its effective inertia 1 / (D^-1)_ii and the largest stable
/// d (or p); empty when every joint is within it. Joints the model lacks are skipped (ControllerSet
/// refuses them).
std::vector<std::string> gain_stability_warnings(const Model& model, const State& x,
                                                 const std::vector<ControllerSpec>& specs,
                                                 double dt);

}  // namespace se3
