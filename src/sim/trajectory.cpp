// Trajectory segments (trajectory.h).
#include "se3_sim/sim/trajectory.h"

namespace se3 {

Spline linear_spline(double q0, double q1, double T) {
  Spline s;
  if (!(T > 0)) {
    s.c[0] = q1;
    return s;
  }
  s.T = T;
  s.c[0] = q0;
  s.c[1] = (q1 - q0) / T;
  return s;
}

Spline cubic_spline(double q0, double v0, double q1, double v1, double T) {
  Spline s;
  if (!(T > 0)) {
    s.c[0] = q1;
    return s;
  }
  s.T = T;
  const double h = q1 - q0, T2 = T * T;
  s.c[0] = q0;
  s.c[1] = v0;
  s.c[2] = (3 * h - (2 * v0 + v1) * T) / T2;
  s.c[3] = (-2 * h + (v0 + v1) * T) / (T2 * T);
  return s;
}

Spline quintic_spline(double q0, double v0, double a0, double q1, double v1, double a1, double T) {
  Spline s;
  if (!(T > 0)) {
    s.c[0] = q1;
    return s;
  }
  s.T = T;
  const double h = q1 - q0, T2 = T * T, T3 = T2 * T;
  s.c[0] = q0;
  s.c[1] = v0;
  s.c[2] = 0.5 * a0;
  s.c[3] = (20 * h - (8 * v1 + 12 * v0) * T - (3 * a0 - a1) * T2) / (2 * T3);
  s.c[4] = (-30 * h + (14 * v1 + 16 * v0) * T + (3 * a0 - 2 * a1) * T2) / (2 * T3 * T);
  s.c[5] = (12 * h - 6 * (v1 + v0) * T + (a1 - a0) * T2) / (2 * T3 * T2);
  return s;
}

void sample_spline(const Spline& sp, double s, double& q, double& v, double& a) {
  bool hold = false;
  if (s < 0) s = 0;
  if (s > sp.T) {
    s = sp.T;
    hold = sp.ends_trajectory;
  }
  const double* c = sp.c;
  // Horner's rule for q, q', q''.
  q = ((((c[5] * s + c[4]) * s + c[3]) * s + c[2]) * s + c[1]) * s + c[0];
  if (hold) {
    v = a = 0;
    return;
  }
  v = (((5 * c[5] * s + 4 * c[4]) * s + 3 * c[3]) * s + 2 * c[2]) * s + c[1];
  a = ((20 * c[5] * s + 12 * c[4]) * s + 6 * c[3]) * s + 2 * c[2];
}

}  // namespace se3
