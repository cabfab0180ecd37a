// The polynomial segments of a joint trajectory, as ros_controllers' joint_trajectory_controller
// interpolates between two points: linear from positions only, cubic from positions and
// velocities (Hermite), quintic from positions, velocities and accelerations. A segment is
// q(s) = c0 + c1 s + ... + c5 s^5 for s in [0, T] from its start.
#pragma once

namespace se3 {

struct Spline {
  double c[6] = {0, 0, 0, 0, 0, 0};
  double T = 0;                 ///< duration (s); 0 holds c0
  bool ends_trajectory = true;  ///< past T: hold the end position (zero velocity, acceleration)
};

/// From q0 at s = 0 to q1 at s = T (T > 0; T <= 0 holds q1).
Spline linear_spline(double q0, double q1, double T);
/// Positions and velocities at both ends.
Spline cubic_spline(double q0, double v0, double q1, double v1, double T);
/// Positions, velocities and accelerations at both ends.
Spline quintic_spline(double q0, double v0, double a0, double q1, double v1, double a1, double T);

/// Position, velocity, acceleration at s (s < 0: the start; s > T: the end, with zero velocity
/// and acceleration when the segment ends its trajectory, else the polynomial's at T).
void sample_spline(const Spline& sp, double s, double& q, double& v, double& a);

}  // namespace se3
