// DART 6 as a peer for time stepping: our model in a DART world (its semi-implicit Euler step,
// World::step), with the state converted between its coordinates and ours.
//
// The skeleton is loaded from model_to_urdf(ours) (so base inertias, locked joints and merged
// links are ours exactly), links without <inertial> massless (DART's default would give them
// mass 1), joint limits not enforced, no collision geometry, every joint force-driven, damping
// kept or removed as asked. DART's free joint uses the same velocity as ours: the base twist
// [w; v] in the base frame; its positions are (log R, p).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "se3_sim/dynamics/dynamics.h"

namespace se3::peers {

class DartRobot {
 public:
  /// Throws std::runtime_error when DART cannot load the model or its dofs do not match.
  DartRobot(const Model& ours, bool keep_damping);
  ~DartRobot();
  DartRobot(const DartRobot&) = delete;
  DartRobot& operator=(const DartRobot&) = delete;

  void set_state(const State& x);
  void get_state(State& x) const;
  /// One World::step of h (semi-implicit Euler: velocities, then positions with the new ones).
  /// Returns false when the state is no longer finite or a rate exceeds 1e6: DART itself does
  /// not notice, and its next transform update would stop the program on an assertion.
  bool step(double h);
  /// DART's own mass matrix and inverse mass matrix at the state set, in our coordinates.
  MatX mass_matrix() const;
  MatX inverse_mass_matrix() const;

 private:
  struct Impl;
  const Model& ours_;
  std::unique_ptr<Impl> impl_;
};

/// DART's inverse mass matrix against its own mass matrix, for a URDF loaded as it is (fixed
/// links kept as welded bodies, which is where DART 6.12's getInvMassMatrix goes wrong).
struct DartMinvCheck {
  double self = 0;  ///< max |getInvMassMatrix - getMassMatrix^-1| / max |getMassMatrix^-1|
  double mass = 0;  ///< DART's mass matrix against ours (crba), relative
  double ours = 0;  ///< ours: max |minv - crba^-1| / max |crba^-1|
  int welded = 0;   ///< DART bodies on fixed (weld) joints with moving descendants
};
/// At state x of ours (our model of urdf_text, built with floating as given; no locked joints).
DartMinvCheck dart_minv_check(const Model& ours, const std::string& urdf_text, const State& x);

}  // namespace se3::peers
