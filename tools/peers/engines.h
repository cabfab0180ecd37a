// Time-stepping engines behind one interface, for the charts and the study of issue 16: our
// steppers (any registry name) and the peers' own integrators, each on the same model.
//
//   mujoco_euler      mj_step, mjINT_EULER: semi-implicit Euler, joint damping implicit
//   mujoco_rk4        mj_step, mjINT_RK4: classical 4th-order Runge-Kutta
//   mujoco_implicit   mj_step, mjINT_IMPLICIT: implicit in velocity (linearized)
//   dart_euler        DART World::step: semi-implicit Euler, joint damping implicit
//
// MuJoCo and DART see our model through model_to_urdf (tools/peers/*_peer.h), without contact
// or limits; with `passive` the joint damping is kept on every side (MuJoCo and DART have no
// regularized Coulomb friction, so models with friction are run with it removed everywhere).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "se3_sim/dynamics/dynamics.h"

namespace se3::peers {

class Engine {
 public:
  virtual ~Engine() = default;
  virtual void set_state(const State& x) = 0;
  /// One step of h under zero commands; false when the engine reports a failure (MuJoCo's
  /// "Nan, Inf or huge value in QACC", a stepper's failed step, a non-finite state).
  virtual bool step(double h) = 0;
  virtual void get_state(State& x) = 0;
  /// Dynamics evaluations of the last step (ABA calls for ours, forward passes for MuJoCo).
  virtual int evaluations() const = 0;
};

/// An engine by name (ours: a stepper registry name). Throws std::invalid_argument for a name
/// this build lacks, std::runtime_error when a peer cannot load the model.
/// `limits`: the model's finite joint limits are on (MuJoCo's limit constraints, at their
/// default softness); an engine of this build without them throws std::invalid_argument.
std::unique_ptr<Engine> make_engine(const std::string& name, const Model& model, bool passive,
                                    double tol = 1e-6, bool limits = false);
/// The peers' engine names available in this build (MuJoCo's, then DART's).
std::vector<std::string> peer_engine_names();
/// Display name: "MuJoCo Euler", "DART semi-implicit Euler", ours as it is.
std::string engine_label(const std::string& name);

}  // namespace se3::peers
