// SO(3) / SE(3) maps of Reuss 2002, section 2 and 4, in forms that stay exact to machine
// precision at theta -> 0 (series) and theta -> pi (no division by sin theta).
#include "se3_sim/lie/lie.h"

#include <cmath>
#include <cstring>

namespace se3 {
namespace {

// Below t = 1 (t^2 < kSeries2) the trigonometric coefficients are evaluated by their Taylor
// series in t^2, which need neither sqrt nor division and are exact where the closed forms
// cancel: (t - sin t)/t^3 loses about log10(6/t^2) digits, and the closed-form coupling
// coefficients of dexp lose up to 100 ulp of dexp near t = 0.1. From t = 1 on the cancellation
// costs at most two digits of a coefficient that the maps multiply by t^3 or more, and dexp stays
// within 1e-15 (gtest_lie). Each series stops where the next term is below 1e-17 relative at
// t = 1.
constexpr double kSeries2 = 1.0;

// c[0] + c[1] x + ... + c[N-1] x^(N-1) by Horner's rule. The coefficients are constants, so
// there is no division (the compiler keeps x / 6.0 as a division, it cannot use x * (1 / 6.0)).
template <int N>
double horner(const double (&c)[N], double x) {
  double r = c[N - 1];
  for (int i = N - 2; i >= 0; --i) r = r * x + c[i];
  return r;
}

constexpr long double factorial(int n) {
  long double f = 1;
  for (int i = 2; i <= n; ++i) f *= i;
  return f;
}

// The N coefficients (-1)^k w(k) / (2k + m)!, k = 0..N-1, with w(k) = k + 1 when weighted, else 1.
template <int N>
struct Series {
  double c[N];
  constexpr Series(int m, bool weighted) : c() {
    for (int k = 0; k < N; ++k) {
      const long double w = weighted ? k + 1 : 1;
      c[k] = static_cast<double>((k % 2 ? -w : w) / factorial(2 * k + m));
    }
  }
};

constexpr Series<9> kSinc(1, false);   // sin t / t
constexpr Series<9> kVersc(2, false);  // (1 - cos t) / t^2
constexpr Series<9> kC1(3, false);     // (t - sin t) / t^3
constexpr Series<9> kC2(4, false);     // (t^2/2 + cos t - 1) / t^4
constexpr Series<9> kC3(5, true);      // (2t - 3 sin t + t cos t) / (2 t^5)
// (1 - (t/2) cot(t/2)) / t^2 = sum_n |B_2n| / (2n)! t^(2n-2), n >= 1 (Bernoulli numbers B_2n).
constexpr double kJinv[11] = {static_cast<double>(1.0L / 6 / factorial(2)),
                              static_cast<double>(1.0L / 30 / factorial(4)),
                              static_cast<double>(1.0L / 42 / factorial(6)),
                              static_cast<double>(1.0L / 30 / factorial(8)),
                              static_cast<double>(5.0L / 66 / factorial(10)),
                              static_cast<double>(691.0L / 2730 / factorial(12)),
                              static_cast<double>(7.0L / 6 / factorial(14)),
                              static_cast<double>(3617.0L / 510 / factorial(16)),
                              static_cast<double>(43867.0L / 798 / factorial(18)),
                              static_cast<double>(174611.0L / 330 / factorial(20)),
                              static_cast<double>(854513.0L / 138 / factorial(22))};

// sin(t) / t
double sinc(double t) {
  const double t2 = t * t;
  if (t2 < kSeries2) return horner(kSinc.c, t2);
  return std::sin(t) / t;
}

// The coefficients of Rodrigues' formula (8) and of the left Jacobian (10), of t2 = t^2:
// A = sin t / t, B = (1 - cos t) / t^2, C = (t - sin t) / t^3.
struct RodriguesCoeffs {
  double A, B, C;
  explicit RodriguesCoeffs(double t2) {
    if (t2 < kSeries2) {
      A = horner(kSinc.c, t2);
      B = horner(kVersc.c, t2);
      C = horner(kC1.c, t2);
      return;
    }
    const double t = std::sqrt(t2), s = std::sin(t), sh = std::sin(0.5 * t);
    A = s / t;
    B = 2 * sh * sh / t2;  // (1 - cos t)/t^2 = 2 sin^2(t/2)/t^2, no cancellation
    C = (t - s) / (t2 * t);
  }
};

// D = (1 - (t/2) cot(t/2)) / t^2 of t2 = t^2, the u^2 coefficient of eq. (11) divided by t^2.
// The paper's form (1 + cos t) / sin t = cot(t/2) is 0/0 at t = pi; cos(t/2)/sin(t/2) is not.
double left_jacobian_inv_coeff(double t2) {
  if (t2 < kSeries2) return horner(kJinv, t2);
  const double h = 0.5 * std::sqrt(t2);
  return (1.0 - h * std::cos(h) / std::sin(h)) / t2;
}

}  // namespace

Mat4 SE3::matrix() const {
  Mat4 m = Mat4::Identity();
  m.topLeftCorner<3, 3>() = R;
  m.topRightCorner<3, 1>() = p;
  return m;
}

Mat4 hat6(const Vec6& xi) {
  Mat4 m = Mat4::Zero();
  m.topLeftCorner<3, 3>() = hat(xi.head<3>());
  m.topRightCorner<3, 1>() = xi.tail<3>();
  return m;
}

Vec6 vee6(const Mat4& m) {
  Vec6 xi;
  xi.head<3>() = vee(m.topLeftCorner<3, 3>());
  xi.tail<3>() = m.topRightCorner<3, 1>();
  return xi;
}

// Eq. (8).
Mat3 exp_so3(const Vec3& a) {
  const RodriguesCoeffs k(a.squaredNorm());
  const Mat3 A = hat(a);
  return Mat3::Identity() + k.A * A + k.B * A * A;
}

// Eq. (9), made exact everywhere. sin t |u| = |vee(R)| and cos t = (tr R - 1)/2 give t by
// atan2 (well conditioned for all t). Away from pi the axis comes from the skew part, scaled by
// t / sin t; near pi the skew part vanishes, so the axis comes from the symmetric part
// R + R^T - 2 cos t I = 2 (1 - cos t) u u^T and only its sign from the skew part.
Vec3 log_so3(const Mat3& R) {
  const Vec3 s = vee(R);  // sin(t) u
  const double sin_t = s.norm();
  const double cos_t = 0.5 * (R.trace() - 1.0);
  const double t = std::atan2(sin_t, cos_t);
  if (cos_t > -0.7) {
    return s / sinc(t);
  }
  Mat3 B = R + R.transpose();
  B.diagonal().array() -= 2.0 * cos_t;
  int k;
  B.diagonal().maxCoeff(&k);
  Vec3 u = B.col(k).normalized();
  if (u.dot(s) < 0) u = -u;
  return t * u;
}

Mat3 left_jacobian_so3(const Vec3& a) {
  const RodriguesCoeffs k(a.squaredNorm());
  const Mat3 A = hat(a);
  return Mat3::Identity() + k.B * A + k.C * A * A;
}

Mat3 left_jacobian_inv_so3(const Vec3& a) {
  const double D = left_jacobian_inv_coeff(a.squaredNorm());
  const Mat3 A = hat(a);
  return Mat3::Identity() - 0.5 * A + D * A * A;
}

// Eqs. (6), (8), (10), without 3x3 products: hat(a)^2 = a a^T - t^2 1, so
// R = (1 - B t^2) 1 + A hat(a) + B a a^T, and p = l + B a x l + C a x (a x l).
SE3 exp_se3(const Vec6& xi) {
  const Vec3 a = xi.head<3>(), l = xi.tail<3>();
  const double t2 = a.squaredNorm();
  const RodriguesCoeffs k(t2);
  SE3 f;
  const Vec3 Ba = k.B * a, Aa = k.A * a;
  f.R.noalias() = Ba * a.transpose();
  f.R.diagonal().array() += 1.0 - k.B * t2;
  f.R(0, 1) -= Aa.z(), f.R(1, 0) += Aa.z();
  f.R(0, 2) += Aa.y(), f.R(2, 0) -= Aa.y();
  f.R(1, 2) -= Aa.x(), f.R(2, 1) += Aa.x();
  const Vec3 al = a.cross(l);
  f.p = l + k.B * al + k.C * a.cross(al);
  return f;
}

// Eqs. (7), (9), (11).
Vec6 log_se3(const SE3& f) {
  Vec6 xi;
  const Vec3 a = log_so3(f.R);
  xi.head<3>() = a;
  xi.tail<3>() = left_jacobian_inv_so3(a) * f.p;
  return xi;
}

// Eq. (17).
Mat6 Ad(const SE3& f) {
  Mat6 m;
  m.topLeftCorner<3, 3>() = f.R;
  m.topRightCorner<3, 3>().setZero();
  m.bottomLeftCorner<3, 3>() = hat(f.p) * f.R;
  m.bottomRightCorner<3, 3>() = f.R;
  return m;
}

// Eq. (18).
Mat6 Ad_inv(const SE3& f) {
  Mat6 m;
  const Mat3 Rt = f.R.transpose();
  m.topLeftCorner<3, 3>() = Rt;
  m.topRightCorner<3, 3>().setZero();
  m.bottomLeftCorner<3, 3>() = -Rt * hat(f.p);
  m.bottomRightCorner<3, 3>() = Rt;
  return m;
}

// Eq. (21).
Mat6 ad(const Vec6& V) {
  Mat6 m;
  const Mat3 W = hat(V.head<3>());
  m.topLeftCorner<3, 3>() = W;
  m.topRightCorner<3, 3>().setZero();
  m.bottomLeftCorner<3, 3>() = hat(V.tail<3>());
  m.bottomRightCorner<3, 3>() = W;
  return m;
}

// Eq. (22).
Mat6 ad_star(const Vec6& V) {
  return ad(V).transpose();
}

// Left Jacobian of SE(3) in closed form (angular-first ordering):
// dexp([a; l]) = [J(a), 0; Q(a, l), J(a)], Q the coupling block of the series sum ad^k/(k+1)!.
namespace {
// Q(a, l) = 0.5 L + c1 (AL + LA + ALA) + c2 (AAL + LAA - 3 ALA) + c3 (ALAA + AALA), with
// A = hat(a), L = hat(l) and these coefficients of t = |a|.
struct DexpCouplingCoeffs {
  double c1, c2, c3;
  explicit DexpCouplingCoeffs(double t2) {
    if (t2 < kSeries2) {
      // c1 = (t - sin t)/t^3, c2 = (t^2/2 + cos t - 1)/t^4,
      // c3 = (2t - 3 sin t + t cos t) / (2 t^5), by their series (c3 -> 1/120 = 1/5!, the ad^4
      // coefficient).
      c1 = horner(kC1.c, t2);
      c2 = horner(kC2.c, t2);
      c3 = horner(kC3.c, t2);
    } else {
      const double t = std::sqrt(t2), s = std::sin(t), c = std::cos(t);
      c1 = (t - s) / (t2 * t);
      c2 = (0.5 * t2 + c - 1.0) / (t2 * t2);
      c3 = 0.5 * (c2 + 3.0 * (t - s - t2 * t / 6.0) / (t2 * t2 * t));
    }
  }
};

Mat3 dexp_coupling(const Vec3& a, const Vec3& l) {
  const DexpCouplingCoeffs k(a.squaredNorm());
  const Mat3 A = hat(a), L = hat(l);
  const Mat3 AL = A * L, LA = L * A, ALA = AL * A;
  return 0.5 * L + k.c1 * (AL + LA + ALA) + k.c2 * (A * AL + LA * A - 3.0 * ALA) +
         k.c3 * (ALA * A + A * ALA);
}

// Q(a, l) w by cross products (hat(x) y = x cross y), with the terms that start with A
// gathered: Q w = 0.5 Lw + c1 LAw + c2 LAAw + A (c1 Lw + (c1 - 3 c2) LAw + c3 LAAw)
//                 + AA (c2 Lw + c3 LAw).
Vec3 dexp_coupling_times(const DexpCouplingCoeffs& k, const Vec3& a, const Vec3& l, const Vec3& w) {
  const Vec3 aw = a.cross(w);
  const Vec3 lw = l.cross(w), law = l.cross(aw), laaw = l.cross(a.cross(aw));
  const Vec3 u = k.c1 * lw + (k.c1 - 3.0 * k.c2) * law + k.c3 * laaw;
  const Vec3 uu = k.c2 * lw + k.c3 * law;
  return 0.5 * lw + k.c1 * law + k.c2 * laaw + a.cross(u + a.cross(uu));
}
}  // namespace

Mat6 dexp_se3(const Vec6& xi) {
  const Mat3 J = left_jacobian_so3(xi.head<3>());
  Mat6 m;
  m.topLeftCorner<3, 3>() = J;
  m.topRightCorner<3, 3>().setZero();
  m.bottomLeftCorner<3, 3>() = dexp_coupling(xi.head<3>(), xi.tail<3>());
  m.bottomRightCorner<3, 3>() = J;
  return m;
}

Mat6 dexp_inv_se3(const Vec6& xi) {
  const Mat3 Ji = left_jacobian_inv_so3(xi.head<3>());
  Mat6 m;
  m.topLeftCorner<3, 3>() = Ji;
  m.topRightCorner<3, 3>().setZero();
  m.bottomLeftCorner<3, 3>() = -Ji * dexp_coupling(xi.head<3>(), xi.tail<3>()) * Ji;
  m.bottomRightCorner<3, 3>() = Ji;
  return m;
}

// [Ji, 0; -Ji Q Ji, Ji] [w; u] = [Ji w; Ji (u - Q Ji w)], Ji w = w - a x w / 2 + D a x (a x w).
Vec6 dexp_inv_se3_times(const Vec6& xi, const Vec6& V) {
  const Vec3 a = xi.head<3>();
  const double t2 = a.squaredNorm();
  const double D = left_jacobian_inv_coeff(t2);
  const auto Ji = [&](const Vec3& w) -> Vec3 {
    const Vec3 aw = a.cross(w);
    return w - 0.5 * aw + D * a.cross(aw);
  };
  Vec6 r;
  r.head<3>() = Ji(V.head<3>());
  r.tail<3>() =
      Ji(V.tail<3>() - dexp_coupling_times(DexpCouplingCoeffs(t2), a, xi.tail<3>(), r.head<3>()));
  return r;
}

// Eq. (23) from the centre of mass: I_O = I_G - m hat(c)^2.
Inertia Inertia::from_com(double mass, const Vec3& com, const Mat3& I_com) {
  Inertia in;
  in.m = mass;
  in.h = mass * com;
  const Mat3 C = hat(com);
  in.I = I_com - mass * C * C;
  in.I = 0.5 * (in.I + in.I.transpose()).eval();
  return in;
}

// Expressed in the frame where the body sits at f: x' = R x + p. With hat(a) hat(b) =
// b a^T - (a.b) 1, the parallel-axis terms -hat(p) hat(Rh) - hat(Rh) hat(p) - m hat(p)^2 become
// (2 p.Rh + m |p|^2) 1 - (Rh p^T + p Rh^T + m p p^T): no 3x3 products beyond R I R^T, whose
// symmetric result needs only its upper triangle. Z = R I, then I' = Z R^T; the result is written
// (add = false) or added (add = true) to `out` entry by entry. A hot path of crba and minv.
namespace {

template <bool add>
void transform_inertia(const Inertia& in, const SE3& f, Inertia& out) {
  const double m = in.m;
  const Vec3& h = in.h;
  const double* R = f.R.data();  // column-major: R(r, c) = R[r + 3 c]
  const double* J = in.I.data();
  double g[3], Z[3][3];  // g = R h, Z = R I (Z[r][c])
  for (int r = 0; r < 3; ++r) {
    const double r0 = R[r], r1 = R[r + 3], r2 = R[r + 6];
    g[r] = r0 * h[0] + r1 * h[1] + r2 * h[2];
    for (int c = 0; c < 3; ++c) Z[r][c] = r0 * J[3 * c] + r1 * J[3 * c + 1] + r2 * J[3 * c + 2];
  }
  const double px = f.p[0], py = f.p[1], pz = f.p[2];
  const double gx = g[0], gy = g[1], gz = g[2];
  const double d = 2.0 * (px * gx + py * gy + pz * gz) + m * (px * px + py * py + pz * pz);
  const double w0 = gx + 0.5 * m * px, w1 = gy + 0.5 * m * py, w2 = gz + 0.5 * m * pz;
  // (R I R^T)(r, c) = sum_k Z(r, k) R(c, k).
  auto rir = [&](int r, int c) { return Z[r][0] * R[c] + Z[r][1] * R[c + 3] + Z[r][2] * R[c + 6]; };
  auto put = [](double& dst, double v) {
    if (add) {
      dst += v;
    } else {
      dst = v;
    }
  };
  put(out.m, m);
  put(out.h[0], gx + m * px);
  put(out.h[1], gy + m * py);
  put(out.h[2], gz + m * pz);
  double* o = out.I.data();
  const double i01 = rir(0, 1) - (w0 * py + px * w1);
  const double i02 = rir(0, 2) - (w0 * pz + px * w2);
  const double i12 = rir(1, 2) - (w1 * pz + py * w2);
  put(o[0], rir(0, 0) - 2 * w0 * px + d);
  put(o[4], rir(1, 1) - 2 * w1 * py + d);
  put(o[8], rir(2, 2) - 2 * w2 * pz + d);
  put(o[1], i01), put(o[3], i01);
  put(o[2], i02), put(o[6], i02);
  put(o[5], i12), put(o[7], i12);
}

}  // namespace

Inertia Inertia::transformed(const SE3& f) const {
  Inertia out;
  transform_inertia<false>(*this, f, out);
  return out;
}

void Inertia::add_transformed(const SE3& f, Inertia& out) const {
  transform_inertia<true>(*this, f, out);
}

Mat6 spatial_inertia(double m, const Vec3& r, const Mat3& I_G) {
  return Inertia::from_com(m, r, I_G).matrix();
}

// Eq. (24).
Vec6 newton_euler_wrench(const Mat6& J, const Vec6& V, const Vec6& Vdot) {
  return J * Vdot - ad_star(V) * (J * V);
}

// The six distinct entries of the symmetric R^T R - 1.
bool is_rotation(const Mat3& R, double tol) {
  const double e[6] = {R.col(0).squaredNorm() - 1, R.col(1).squaredNorm() - 1,
                       R.col(2).squaredNorm() - 1, R.col(0).dot(R.col(1)),
                       R.col(0).dot(R.col(2)),     R.col(1).dot(R.col(2))};
  bool ok = true;
  for (double x : e) ok &= std::abs(x) < tol;
  return ok;
}

Mat3 orthonormalize(const Mat3& m) {
  Eigen::Quaterniond q(m);
  q.normalize();
  return q.toRotationMatrix();
}

// With columns c_k of R and G = R^T R (G_jk = c_j . c_k), column k of the result is
// 1.5 c_k - 0.5 sum_j c_j G_jk.
Mat3 reorthonormalize(const Mat3& R) {
  const double* r = R.data();  // column-major: column k is r[3k..3k+2]
  double G[3][3];
  for (int j = 0; j < 3; ++j) {
    for (int k = j; k < 3; ++k) {
      G[j][k] = G[k][j] =
          r[3 * j] * r[3 * k] + r[3 * j + 1] * r[3 * k + 1] + r[3 * j + 2] * r[3 * k + 2];
    }
  }
  Mat3 out;
  double* o = out.data();
  for (int k = 0; k < 3; ++k) {
    for (int i = 0; i < 3; ++i) {
      o[3 * k + i] =
          1.5 * r[3 * k + i] - 0.5 * (r[i] * G[0][k] + r[3 + i] * G[1][k] + r[6 + i] * G[2][k]);
    }
  }
  return out;
}

Mat3 rotation_from_quaternion(double x, double y, double z, double w) {
  return Eigen::Quaterniond(w, x, y, z).normalized().toRotationMatrix();
}

Eigen::Vector4d quaternion_from_rotation(const Mat3& R) {
  Eigen::Quaterniond q(R);
  q.normalize();
  if (q.w() < 0) q.coeffs() *= -1.0;
  return Eigen::Vector4d(q.x(), q.y(), q.z(), q.w());
}

}  // namespace se3
