// SO(3) and SE(3) for rigid-body dynamics: hat/vee, exp/log (eqs. 6-11 of Reuss 2002),
// the adjoint actions Ad, Ad^-1, ad, ad* (eqs. 17-22), dexp and its inverse, spatial inertia
// (eq. 23) and the Newton-Euler wrench (eq. 24).
//
// Conventions (docs/design.md): a twist is V = [w; v] (angular first) in the body's own frame, a
// wrench is F = [N; F] (torque first). A pose f = (R, p) maps body coordinates to the parent's.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace se3 {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using Mat4 = Eigen::Matrix4d;

/// A rigid displacement f = (Θ, b) of SE(3), eq. (3): x_parent = R x_child + p.
struct SE3 {
  Mat3 R = Mat3::Identity();
  Vec3 p = Vec3::Zero();

  SE3() = default;
  SE3(const Mat3& r, const Vec3& t) : R(r), p(t) {}
  static SE3 Identity() { return SE3(); }

  SE3 operator*(const SE3& o) const { return SE3(R * o.R, R * o.p + p); }
  /// Eq. (4).
  SE3 inverse() const { return SE3(R.transpose(), -(R.transpose() * p)); }
  /// this^-1 * o without forming the inverse.
  SE3 inverse_times(const SE3& o) const {
    return SE3(R.transpose() * o.R, R.transpose() * (o.p - p));
  }
  Vec3 act(const Vec3& x) const { return R * x + p; }
  Vec3 act_inv(const Vec3& x) const { return R.transpose() * (x - p); }
  /// The 4x4 homogeneous matrix of eq. (3), acting on RP^3.
  Mat4 matrix() const;
  bool isApprox(const SE3& o, double tol = 1e-12) const {
    return (R - o.R).cwiseAbs().maxCoeff() <= tol && (p - o.p).cwiseAbs().maxCoeff() <= tol;
  }
};

/// Hat map: hat(a) b = a x b.
inline Mat3 hat(const Vec3& a) {
  Mat3 m;
  m << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return m;
}
/// Inverse of hat on the skew part of m.
inline Vec3 vee(const Mat3& m) {
  return Vec3(m(2, 1) - m(1, 2), m(0, 2) - m(2, 0), m(1, 0) - m(0, 1)) * 0.5;
}
/// 4x4 element of se(3) for xi = [a; l].
Mat4 hat6(const Vec6& xi);
Vec6 vee6(const Mat4& m);

// ---------------------------------------------------------------- SO(3)
/// Rodrigues' formula, eq. (8), with series near theta = 0.
Mat3 exp_so3(const Vec3& a);
/// Eq. (9) in a form that is exact near 0 and near pi (the paper divides by sin theta).
/// Returns a with |a| in [0, pi].
Vec3 log_so3(const Mat3& R);
/// Left Jacobian of SO(3): the matrix of eq. (10), V(a) = I + (1-cos)/t^2 hat(a) + (t-sin)/t^3
/// hat(a)^2.
Mat3 left_jacobian_so3(const Vec3& a);
/// Inverse of the left Jacobian: the matrix of eq. (11), stable near 0 and up to (not at) 2pi.
Mat3 left_jacobian_inv_so3(const Vec3& a);

// ---------------------------------------------------------------- SE(3)
/// Eqs. (6), (8), (10): exp([a; l]) = (exp(a), V(a) l).
SE3 exp_se3(const Vec6& xi);
/// Eqs. (7), (9), (11), stable at theta = 0 and theta = pi.
Vec6 log_se3(const SE3& f);

/// Eq. (17): V_1 = Ad_f V_2 (twist of frame 2 expressed in frame 1, f = f_{1,2}).
Mat6 Ad(const SE3& f);
/// Eq. (18): Ad_{f^-1}.
Mat6 Ad_inv(const SE3& f);
/// Eq. (21): ad_V, the Lie bracket [V, .].
Mat6 ad(const Vec6& V);
/// Eq. (22): ad*_V = ad_V^T (acting on wrenches).
Mat6 ad_star(const Vec6& V);
/// dexp of SE(3): the series sum_k ad_xi^k / (k+1)!, in closed form. For f(t) = exp(xi(t)),
/// fdot f^-1 = hat6(dexp_se3(xi) xidot) (space-frame velocity) and
/// f^-1 fdot = hat6(dexp_se3(-xi) xidot) (body-frame twist, as RKMK on body twists needs).
Mat6 dexp_se3(const Vec6& xi);
/// Inverse of dexp_se3, in closed form (no matrix inversion).
Mat6 dexp_inv_se3(const Vec6& xi);
/// dexp_inv_se3(xi) V without forming the matrix (cross products only; RKMK's hot path).
Vec6 dexp_inv_se3_times(const Vec6& xi, const Vec6& V);
/// The series of dexp_inv_se3(xi) V cut after its ad^2 term, V - [xi, V] / 2 + [xi, [xi, V]] / 12:
/// within O(|xi|^4 |V|) of dexp_inv_se3_times, since the ad^3 coefficient (B_3 / 3!) is zero.
/// Defined after cross_motion below.
inline Vec6 dexp_inv_se3_times_series(const Vec6& xi, const Vec6& V);

// ------------------------------------------------- fast matrix-free actions (hot paths)
/// Ad_f V.
inline Vec6 act_motion(const SE3& f, const Vec6& V) {
  Vec6 r;
  r.head<3>() = f.R * V.head<3>();
  r.tail<3>() = f.R * V.tail<3>() + f.p.cross(r.head<3>());
  return r;
}
/// Ad_{f^-1} V.
inline Vec6 act_inv_motion(const SE3& f, const Vec6& V) {
  Vec6 r;
  r.head<3>() = f.R.transpose() * V.head<3>();
  r.tail<3>() = f.R.transpose() * (V.tail<3>() - f.p.cross(V.head<3>()));
  return r;
}
/// Ad*_{f^-1} F = Ad_f^-T F: a wrench given in frame 2 expressed in frame 1, eq. (19).
inline Vec6 act_force(const SE3& f, const Vec6& F) {
  Vec6 r;
  r.tail<3>() = f.R * F.tail<3>();
  r.head<3>() = f.R * F.head<3>() + f.p.cross(r.tail<3>());
  return r;
}
/// The inverse of act_force, eq. (20) with f^-1 (the paper's eq. (20) misses the inverse).
inline Vec6 act_inv_force(const SE3& f, const Vec6& F) {
  Vec6 r;
  r.tail<3>() = f.R.transpose() * F.tail<3>();
  r.head<3>() = f.R.transpose() * (F.head<3>() - f.p.cross(F.tail<3>()));
  return r;
}
/// ad_V U, eq. (21).
inline Vec6 cross_motion(const Vec6& V, const Vec6& U) {
  Vec6 r;
  r.head<3>() = V.head<3>().cross(U.head<3>());
  r.tail<3>() = V.tail<3>().cross(U.head<3>()) + V.head<3>().cross(U.tail<3>());
  return r;
}
inline Vec6 dexp_inv_se3_times_series(const Vec6& xi, const Vec6& V) {
  const Vec6 b = cross_motion(xi, V);
  return V - 0.5 * b + (1.0 / 12.0) * cross_motion(xi, b);
}
/// -ad*_V F = -ad_V^T F (Featherstone's v x* f), eq. (22) with the sign folded in.
inline Vec6 cross_force(const Vec6& V, const Vec6& F) {
  Vec6 r;
  r.head<3>() = V.head<3>().cross(F.head<3>()) + V.tail<3>().cross(F.tail<3>());
  r.tail<3>() = V.head<3>().cross(F.tail<3>());
  return r;
}

// ---------------------------------------------------------------- inertia
/// A rigid body's inertia about its frame origin: mass m, first moment h = m c (c the centre
/// of mass) and rotational inertia I_O about the origin (I_O = I_G - m hat(c)^2).
struct Inertia {
  double m = 0;
  Vec3 h = Vec3::Zero();
  Mat3 I = Mat3::Zero();

  static Inertia from_com(double mass, const Vec3& com, const Mat3& I_com);
  /// Eq. (23) as a 6x6 matrix.
  Mat6 matrix() const {
    Mat6 J;
    to_matrix(J);
    return J;
  }
  /// Eq. (23) written into J (no temporary: hot paths fill preallocated matrices).
  void to_matrix(Mat6& J) const {
    J.topLeftCorner<3, 3>() = I;
    J(0, 3) = 0, J(0, 4) = -h.z(), J(0, 5) = h.y();
    J(1, 3) = h.z(), J(1, 4) = 0, J(1, 5) = -h.x();
    J(2, 3) = -h.y(), J(2, 4) = h.x(), J(2, 5) = 0;
    J.bottomLeftCorner<3, 3>() = -J.topRightCorner<3, 3>();
    J.bottomRightCorner<3, 3>() = m * Mat3::Identity();
  }
  /// J V (the momentum), without forming the matrix.
  Vec6 operator*(const Vec6& V) const {
    Vec6 r;
    r.head<3>() = I * V.head<3>() + h.cross(V.tail<3>());
    r.tail<3>() = m * V.tail<3>() - h.cross(V.head<3>());
    return r;
  }
  Inertia& operator+=(const Inertia& o) {
    m += o.m;
    h += o.h;
    I += o.I;
    return *this;
  }
  /// The same inertia expressed in the parent frame of f (body placed at f): with g = R h,
  /// h' = g + m p and I' = R I R^T + (2 p.g + m p.p) 1 - (w p^T + p w^T), w = g + m p / 2.
  Inertia transformed(const SE3& f) const;
  /// out += transformed(f), without the temporary (composite-inertia sums).
  void add_transformed(const SE3& f, Inertia& out) const;
  Vec3 com() const { return m > 0 ? Vec3(h / m) : Vec3::Zero(); }
};

/// Eq. (23): J = [I_G - m hat(r)^2, m hat(r); -m hat(r), m 1].
Mat6 spatial_inertia(double m, const Vec3& r, const Mat3& I_G);
/// Eq. (24): F = J Vdot - ad*_V (J V).
Vec6 newton_euler_wrench(const Mat6& J, const Vec6& V, const Vec6& Vdot);

/// Whether every entry of R^T R - 1 is below tol in magnitude (false for a non-finite R: inf or
/// NaN reaches the diagonal).
bool is_rotation(const Mat3& R, double tol = 1e-6);
/// Closest rotation to m (for renormalization after many products).
Mat3 orthonormalize(const Mat3& m);
/// One Newton-Schulz step toward the closest rotation, R (3 1 - R^T R) / 2: for R orthonormal to
/// e (|R^T R - 1| <= e) the result is orthonormal to O(e^2) plus rounding. For a pose kept
/// orthonormal step after step (f exp(xi) is off by a few ulp); orthonormalize() otherwise.
Mat3 reorthonormalize(const Mat3& R);
/// Rotation from a unit quaternion (x, y, z, w), ROS order.
Mat3 rotation_from_quaternion(double x, double y, double z, double w);
/// Unit quaternion (x, y, z, w) of a rotation, w >= 0.
Eigen::Vector4d quaternion_from_rotation(const Mat3& R);

}  // namespace se3
