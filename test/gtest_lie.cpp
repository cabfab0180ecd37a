// SO(3) / SE(3) maps of lie.h against independent references: long-double power series of the
// matrix exponential and of dexp, finite differences, and the defining identities of Ad, ad, ad*.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "test_util.h"

using namespace se3;
using se3_test::random_pose;
using se3_test::random_unit;
using se3_test::random_vec;
using se3_test::uniform;

namespace {

using Mat4L = Eigen::Matrix<long double, 4, 4>;
using Mat6L = Eigen::Matrix<long double, 6, 6>;
using Mat3L = Eigen::Matrix<long double, 3, 3>;

// exp of a 4x4 matrix by scaling and squaring of its Taylor series, in long double.
Mat4L expm_ld(const Mat4L& A) {
  const long double norm = A.cwiseAbs().rowwise().sum().maxCoeff();
  int s = 0;
  while (std::ldexp(norm, -s) > 0.25L) ++s;
  const Mat4L B = A / std::ldexp(1.0L, s);
  Mat4L term = Mat4L::Identity(), sum = Mat4L::Identity();
  for (int k = 1; k < 40; ++k) {
    term = term * B / static_cast<long double>(k);
    sum += term;
  }
  for (int i = 0; i < s; ++i) sum = sum * sum;
  return sum;
}

SE3 exp_reference(const Vec6& xi) {
  const Mat4L E = expm_ld(hat6(xi).cast<long double>());
  return SE3(E.topLeftCorner<3, 3>().cast<double>(), E.topRightCorner<3, 1>().cast<double>());
}

// sum_k X^k / (k+1)! in long double (the series of dexp, eq. of the Baker-Campbell-Hausdorff
// derivative), for X = ad_xi (6x6) or hat(a) (3x3).
template <class M>
M phi1_series(const M& X) {
  M term = M::Identity(), sum = M::Identity();
  for (int k = 1; k < 80; ++k) {
    term = term * X / static_cast<long double>(k + 1);
    sum += term;
  }
  return sum;
}

Mat6 dexp_reference(const Vec6& xi) {
  return phi1_series<Mat6L>(ad(xi).cast<long double>()).cast<double>();
}

double max_abs(const Eigen::Ref<const Eigen::MatrixXd>& m) {
  return m.cwiseAbs().maxCoeff();
}

// The rotation angles of the hard cases: 0, the smallest, where closed forms such as
// (t - sin t)/t^3 cancel most (0.1 to 0.5), the series switch at 1 from both sides, and the
// approach to pi.
const std::vector<double> kHardAngles = {0.0,         1e-12,       1e-8,        1e-4, 0.1,
                                         0.3,         0.5,         1.0 - 1e-9,  1.0,  1.0 + 1e-9,
                                         M_PI - 1e-4, M_PI - 1e-8, M_PI - 1e-12};

std::vector<Vec6> hard_twists(std::mt19937_64& rng) {
  std::vector<Vec6> out;
  for (double t : kHardAngles) {
    for (int k = 0; k < 20; ++k) {
      Vec6 xi;
      xi.head<3>() = t * random_unit(rng);
      xi.tail<3>() = random_vec(rng, 3, 2.0);
      out.push_back(xi);
    }
  }
  return out;
}

// Fourth-order central difference of a vector function of one variable at 0.
template <class F>
Vec6 central_diff4(F&& g, double h) {
  return (-g(2 * h) + 8 * g(h) - 8 * g(-h) + g(-2 * h)) / (12 * h);
}

}  // namespace

TEST(Lie, HatVee) {
  std::mt19937_64 rng(1);
  for (int k = 0; k < 100; ++k) {
    const Vec3 a = random_vec(rng, 3, 2.0), b = random_vec(rng, 3, 2.0);
    EXPECT_LE((hat(a) * b - a.cross(b)).norm(), 1e-15);
    EXPECT_EQ(vee(hat(a)), a);
    Vec6 xi;
    xi << a, b;
    EXPECT_EQ(vee6(hat6(xi)), xi);
  }
}

TEST(Lie, ExpMatchesMatrixExponentialSeries) {
  std::mt19937_64 rng(2);
  std::vector<Vec6> xs = hard_twists(rng);
  for (int k = 0; k < 1000; ++k) {
    Vec6 xi;
    xi.head<3>() = uniform(rng, 0.0, M_PI) * random_unit(rng);
    xi.tail<3>() = random_vec(rng, 3, 2.0);
    xs.push_back(xi);
  }
  double worst_R = 0, worst_p = 0;
  for (const Vec6& xi : xs) {
    const SE3 f = exp_se3(xi), g = exp_reference(xi);
    worst_R = std::max(worst_R, max_abs(f.R - g.R));
    worst_p = std::max(worst_p, max_abs(f.p - g.p) / std::max(1.0, g.p.norm()));
    EXPECT_LE(max_abs(exp_so3(xi.head<3>()) - f.R), 1e-15 * 4) << xi.transpose();
  }
  std::printf("exp_se3 vs long-double series: max |dR| %.3g, max |dp|/|p| %.3g\n", worst_R,
              worst_p);
  RecordProperty("exp_R_err", std::to_string(worst_R));
  EXPECT_LE(worst_R, 1e-15 * 4);
  EXPECT_LE(worst_p, 1e-15 * 8);
}

TEST(Lie, ExpIsARigidMotion) {
  std::mt19937_64 rng(3);
  for (const Vec6& xi : hard_twists(rng)) {
    const Mat3 R = exp_se3(xi).R;
    EXPECT_LE(max_abs(R.transpose() * R - Mat3::Identity()), 1e-15 * 4) << xi.transpose();
    EXPECT_NEAR(R.determinant(), 1.0, 1e-15 * 4);
  }
}

TEST(Lie, LogOfExpIsIdentityBelowPi) {
  std::mt19937_64 rng(4);
  std::vector<Vec6> xs = hard_twists(rng);
  for (int k = 0; k < 1000; ++k) {
    Vec6 xi;
    xi.head<3>() = uniform(rng, 0.0, M_PI) * random_unit(rng);
    xi.tail<3>() = random_vec(rng, 3, 2.0);
    xs.push_back(xi);
  }
  double worst = 0;
  for (const Vec6& xi : xs) {
    const Vec6 back = log_se3(exp_se3(xi));
    const double err = (back - xi).cwiseAbs().maxCoeff() / std::max(1.0, xi.norm());
    worst = std::max(worst, err);
    EXPECT_LE(err, 1e-12) << "xi = " << xi.transpose() << "\nlog(exp(xi)) = " << back.transpose();
    EXPECT_LE((log_so3(exp_so3(xi.head<3>())) - xi.head<3>()).cwiseAbs().maxCoeff(),
              1e-12 * std::max(1.0, xi.head<3>().norm()));
  }
  std::printf("log(exp(xi)) = xi: max relative error %.3g over %zu samples\n", worst, xs.size());
  RecordProperty("log_exp_err", std::to_string(worst));
}

TEST(Lie, ExpOfLogIsIdentity) {
  std::mt19937_64 rng(5);
  std::vector<SE3> fs;
  for (int k = 0; k < 1000; ++k) fs.push_back(random_pose(rng, 2.0));
  for (double t : kHardAngles) {
    for (int k = 0; k < 20; ++k) {
      fs.emplace_back(exp_so3(t * random_unit(rng)), random_vec(rng, 3, 2.0));
    }
  }
  double worst = 0;
  for (const SE3& f : fs) {
    const SE3 g = exp_se3(log_se3(f));
    const double err = std::max(max_abs(g.R - f.R), max_abs(g.p - f.p) / std::max(1.0, f.p.norm()));
    worst = std::max(worst, err);
    EXPECT_LE(err, 1e-12);
    const Vec3 a = log_so3(f.R);
    EXPECT_LE(a.norm(), M_PI * (1 + 1e-15));
  }
  std::printf("exp(log(f)) = f: max error %.3g over %zu samples\n", worst, fs.size());
}

// A rotation by exactly pi (built without rounding in the angle: R = 2 u u^T - 1) has two logs,
// +-pi u; either must come back with |a| = pi and exp(a) = R.
TEST(Lie, RotationByPi) {
  std::mt19937_64 rng(6);
  std::vector<Vec3> axes = {Vec3::UnitX(),
                            Vec3::UnitY(),
                            Vec3::UnitZ(),
                            -Vec3::UnitX(),
                            Vec3(1, 1, 0).normalized(),
                            Vec3(1, 1, 1).normalized()};
  for (int k = 0; k < 200; ++k) axes.push_back(random_unit(rng));
  for (const Vec3& u : axes) {
    const Mat3 R = 2.0 * u * u.transpose() - Mat3::Identity();
    const Vec3 a = log_so3(R);
    EXPECT_NEAR(a.norm(), M_PI, 1e-12 * M_PI) << u.transpose();
    EXPECT_NEAR(std::abs(a.normalized().dot(u)), 1.0, 1e-12) << u.transpose();
    EXPECT_LE(max_abs(exp_so3(a) - R), 1e-12) << u.transpose();
    EXPECT_LE(max_abs(exp_so3(M_PI * u) - R), 1e-15 * 4);
    const SE3 f(R, random_vec(rng, 3, 2.0));
    const Vec6 xi = log_se3(f);
    const SE3 g = exp_se3(xi);
    EXPECT_LE(max_abs(g.R - f.R), 1e-12);
    EXPECT_LE(max_abs(g.p - f.p), 1e-12 * std::max(1.0, f.p.norm())) << u.transpose();
  }
}

TEST(Lie, AdjointOfProductIsProductOfAdjoints) {
  std::mt19937_64 rng(7);
  for (int k = 0; k < 500; ++k) {
    const SE3 f = random_pose(rng, 2.0), g = random_pose(rng, 2.0);
    EXPECT_LE(max_abs(Ad(f * g) - Ad(f) * Ad(g)), 1e-14);
    EXPECT_LE(max_abs(Ad_inv(f) * Ad(f) - Mat6::Identity()), 1e-14);
    EXPECT_LE(max_abs(Ad_inv(f) - Ad(f.inverse())), 1e-14);
    // Definition, eq. (17): hat6(Ad_f V) = f hat6(V) f^-1.
    const Vec6 V = random_vec(rng, 6, 1.0);
    const Mat4 F = f.matrix();
    EXPECT_LE(max_abs(hat6(Ad(f) * V) - F * hat6(V) * F.inverse()), 1e-14);
    EXPECT_LE(max_abs((f * f.inverse()).matrix() - Mat4::Identity()), 1e-14);
    EXPECT_TRUE(f.inverse_times(g).isApprox(f.inverse() * g, 1e-15));
    const Vec3 x = random_vec(rng, 3, 1.0);
    EXPECT_LE((f.act_inv(f.act(x)) - x).norm(), 1e-15 * 4);
    EXPECT_LE((f.act(x) - (F * x.homogeneous()).head<3>()).norm(), 1e-15 * 4);
  }
}

TEST(Lie, SmallAdjointAndCoadjoint) {
  std::mt19937_64 rng(8);
  for (int k = 0; k < 500; ++k) {
    const Vec6 V = random_vec(rng, 6, 1.0), U = random_vec(rng, 6, 1.0);
    // Eq. (21): ad_V U is the matrix commutator [hat6 V, hat6 U].
    const Mat4 A = hat6(V), B = hat6(U);
    EXPECT_LE(max_abs(hat6(ad(V) * U) - (A * B - B * A)), 1e-15);
    EXPECT_EQ(ad_star(V), ad(V).transpose());
    // ad is the derivative of Ad at the identity: d/dt Ad(exp(t V)) at 0 = ad_V.
    const double h = 1e-3;
    const Mat6 dAd = (-Ad(exp_se3(2 * h * V)) + 8 * Ad(exp_se3(h * V)) - 8 * Ad(exp_se3(-h * V)) +
                      Ad(exp_se3(-2 * h * V))) /
                     (12 * h);
    EXPECT_LE(max_abs(dAd - ad(V)), 1e-10);
  }
}

TEST(Lie, MatrixFreeActionsEqualMatrices) {
  std::mt19937_64 rng(9);
  for (int k = 0; k < 500; ++k) {
    const SE3 f = random_pose(rng, 2.0);
    const Vec6 V = random_vec(rng, 6, 1.0), F = random_vec(rng, 6, 1.0);
    EXPECT_LE(max_abs(act_motion(f, V) - Ad(f) * V), 1e-14);
    EXPECT_LE(max_abs(act_inv_motion(f, V) - Ad_inv(f) * V), 1e-14);
    EXPECT_LE(max_abs(act_force(f, F) - Ad_inv(f).transpose() * F), 1e-14);
    EXPECT_LE(max_abs(act_inv_force(f, F) - Ad(f).transpose() * F), 1e-14);
    EXPECT_LE(max_abs(cross_motion(V, F) - ad(V) * F), 1e-15);
    EXPECT_LE(max_abs(cross_force(V, F) + ad_star(V) * F), 1e-15);
    // Power is frame invariant: (Ad_f V) . (act_force(f, F)) = V . F.
    EXPECT_NEAR(act_motion(f, V).dot(act_force(f, F)), V.dot(F), 1e-14);
  }
}

TEST(Lie, LeftJacobianSO3MatchesSeries) {
  std::mt19937_64 rng(10);
  double worst = 0, worst_inv = 0;
  for (double t : kHardAngles) {
    for (int k = 0; k < 20; ++k) {
      const Vec3 a = t * random_unit(rng);
      const Mat3 ref = phi1_series<Mat3L>(hat(a).cast<long double>()).cast<double>();
      worst = std::max(worst, max_abs(left_jacobian_so3(a) - ref));
      worst_inv = std::max(
          worst_inv, max_abs(left_jacobian_inv_so3(a) * left_jacobian_so3(a) - Mat3::Identity()));
    }
  }
  std::printf("left Jacobian SO(3) vs series: %.3g; J^-1 J - I: %.3g\n", worst, worst_inv);
  EXPECT_LE(worst, 1e-15 * 2);
  EXPECT_LE(worst_inv, 1e-14);
}

TEST(Lie, DexpMatchesSeries) {
  std::mt19937_64 rng(11);
  double worst = 0, worst_inv = 0;
  for (const Vec6& xi : hard_twists(rng)) {
    const Mat6 ref = dexp_reference(xi);
    // Relative to the largest entry: the coupling block grows with |l| (up to ~5 here).
    const double err = max_abs(dexp_se3(xi) - ref) / std::max(1.0, max_abs(ref));
    worst = std::max(worst, err);
    EXPECT_LE(err, 2e-15) << xi.transpose();
    const Mat6 ref_inv = ref.cast<long double>().inverse().cast<double>();
    const double err_inv = max_abs(dexp_inv_se3(xi) - ref_inv) / std::max(1.0, max_abs(ref_inv));
    worst_inv = std::max(worst_inv, err_inv);
    EXPECT_LE(err_inv, 2e-15) << xi.transpose();
  }
  std::printf("dexp_se3 vs long-double series: max error %.3g; dexp_inv_se3: %.3g\n", worst,
              worst_inv);
  RecordProperty("dexp_series_err", std::to_string(worst));
}

// d/de log(exp(xi + e d) exp(xi)^-1) at e = 0 is dexp(xi) d (space-frame velocity), and
// d/de log(exp(xi)^-1 exp(xi + e d)) is dexp(-xi) d (body twist).
TEST(Lie, DexpMatchesFiniteDifferences) {
  std::mt19937_64 rng(12);
  double worst = 0;
  std::vector<Vec6> xs = hard_twists(rng);
  for (int k = 0; k < 200; ++k) {
    Vec6 xi;
    xi.head<3>() = uniform(rng, 0.0, 3.0) * random_unit(rng);
    xi.tail<3>() = random_vec(rng, 3, 2.0);
    xs.push_back(xi);
  }
  for (const Vec6& xi : xs) {
    const Vec6 d = random_vec(rng, 6, 1.0);
    const SE3 f = exp_se3(xi);
    const SE3 finv = f.inverse();
    const double h = 1e-3;
    const Vec6 space =
        central_diff4([&](double e) { return log_se3(exp_se3(xi + e * d) * finv); }, h);
    const Vec6 body =
        central_diff4([&](double e) { return log_se3(finv * exp_se3(xi + e * d)); }, h);
    const double e1 = max_abs(space - dexp_se3(xi) * d);
    const double e2 = max_abs(body - dexp_se3(-xi) * d);
    worst = std::max({worst, e1, e2});
    EXPECT_LE(e1, 1e-9) << xi.transpose();
    EXPECT_LE(e2, 1e-9) << xi.transpose();
  }
  std::printf("dexp vs 4th-order central differences: max error %.3g\n", worst);
  RecordProperty("dexp_fd_err", std::to_string(worst));
}

TEST(Lie, DexpInverse) {
  std::mt19937_64 rng(13);
  double worst = 0;
  std::vector<Vec6> xs = hard_twists(rng);
  for (int k = 0; k < 20; ++k) {
    Vec6 xi;
    xi << M_PI * random_unit(rng), random_vec(rng, 3, 2.0);  // exactly at pi
    xs.push_back(xi);
  }
  for (const Vec6& xi : xs) {
    const Mat6 P = dexp_inv_se3(xi) * dexp_se3(xi);
    const Mat6 Q = dexp_se3(xi) * dexp_inv_se3(xi);
    const double err = std::max(max_abs(P - Mat6::Identity()), max_abs(Q - Mat6::Identity()));
    worst = std::max(worst, err);
    EXPECT_LE(err, 1e-12) << xi.transpose();
  }
  std::printf("dexp_inv dexp - I: max %.3g\n", worst);
}

// The matrix-free action (RKMK's hot path) against the matrix, and against the long-double
// series, on the hard angles and at pi.
TEST(Lie, DexpInverseTimesEqualsTheMatrix) {
  std::mt19937_64 rng(16);
  double worst = 0, worst_ref = 0;
  std::vector<Vec6> xs = hard_twists(rng);
  for (int k = 0; k < 20; ++k) {
    Vec6 xi;
    xi << M_PI * random_unit(rng), random_vec(rng, 3, 2.0);
    xs.push_back(xi);
  }
  for (const Vec6& xi : xs) {
    const Vec6 V = random_vec(rng, 6, 1.0);
    const Vec6 Mv = dexp_inv_se3(xi) * V;
    const double err = max_abs(dexp_inv_se3_times(xi, V) - Mv) / std::max(1.0, max_abs(Mv));
    worst = std::max(worst, err);
    EXPECT_LE(err, 1e-14) << xi.transpose();
    const Mat6 ref_inv = dexp_reference(xi).cast<long double>().inverse().cast<double>();
    const Vec6 ref = ref_inv * V;
    const double err_ref = max_abs(dexp_inv_se3_times(xi, V) - ref) / std::max(1.0, max_abs(ref));
    worst_ref = std::max(worst_ref, err_ref);
    EXPECT_LE(err_ref, 1e-13) << xi.transpose();
  }
  std::printf("dexp_inv_se3_times vs the matrix: %.3g; vs the long-double series: %.3g\n", worst,
              worst_ref);
}

// The series cut after ad^2 (RKMK4's dexp_inv) against the closed form: the gap shrinks like
// |xi|^4 (halving xi divides it by 16: the ad^3 term is zero), so it could not hide a wrong sign
// or coefficient in either term kept (those would leave |xi| or |xi|^2 gaps).
TEST(Lie, DexpInverseSeriesIsWithinXiToTheFourthOfTheClosedForm) {
  std::mt19937_64 rng(21);
  for (int k = 0; k < 20; ++k) {
    const Vec6 dir = random_vec(rng, 6, 1.0);
    const Vec6 V = random_vec(rng, 6, 1.0);
    double prev = 0;
    for (const double s : {0.2, 0.1, 0.05, 0.025}) {
      const Vec6 xi = s * dir;
      const double gap = max_abs(dexp_inv_se3_times_series(xi, V) - dexp_inv_se3_times(xi, V));
      EXPECT_LE(gap, 0.01 * std::pow(s * dir.norm(), 4) * V.norm()) << s;
      if (prev > 0) {
        EXPECT_NEAR(prev / gap, 16.0, 1.5) << s << " " << dir.transpose();
      }
      prev = gap;
    }
  }
  // Exact at xi = 0 and for V along xi (all brackets vanish).
  const Vec6 V = random_vec(rng, 6, 1.0);
  EXPECT_EQ(dexp_inv_se3_times_series(Vec6::Zero(), V), V);
  EXPECT_LE(max_abs(dexp_inv_se3_times_series(0.3 * V, V) - V), 1e-16);
}

// One Newton-Schulz step squares the distance to a rotation and lands on the closest one (the
// polar factor U V^T of the singular value decomposition).
TEST(Lie, ReorthonormalizeSquaresTheOrthonormalityError) {
  std::mt19937_64 rng(22);
  for (int k = 0; k < 20; ++k) {
    const Mat3 R = random_pose(rng).R;
    for (const double e : {1e-4, 1e-6, 1e-8}) {
      Mat3 P = R;
      for (int i = 0; i < 9; ++i) P.data()[i] += e * random_vec(rng, 1, 1.0)[0];
      const double before = max_abs(P.transpose() * P - Mat3::Identity());
      const Mat3 O = reorthonormalize(P);
      const double after = max_abs(O.transpose() * O - Mat3::Identity());
      EXPECT_GT(before, 0.1 * e);
      EXPECT_LE(after, 3 * before * before + 1e-15) << e;
      const Eigen::JacobiSVD<Mat3> svd(P, Eigen::ComputeFullU | Eigen::ComputeFullV);
      const Mat3 polar = svd.matrixU() * svd.matrixV().transpose();
      EXPECT_LE(max_abs(O - polar), 3 * before * before + 1e-15) << e;
    }
  }
  // A rotation that is orthonormal to rounding stays so, step after step (no drift).
  Mat3 R = exp_so3(Vec3(0.3, -0.2, 0.9));
  const Mat3 step = exp_so3(Vec3(1e-3, 2e-3, -1e-3));
  for (int k = 0; k < 100000; ++k) R = reorthonormalize(R * step);
  EXPECT_LE(max_abs(R.transpose() * R - Mat3::Identity()), 1e-15);
}

TEST(Lie, SpatialInertiaEq23) {
  std::mt19937_64 rng(14);
  for (int k = 0; k < 200; ++k) {
    const double m = uniform(rng, 0.1, 10.0);
    const Vec3 r = random_vec(rng, 3, 1.0);
    const Mat3 Q = se3_test::random_rotation(rng);
    const Vec3 d(uniform(rng, 0.1, 1.0), uniform(rng, 0.1, 1.0), uniform(rng, 0.1, 1.0));
    const Mat3 IG = Q * d.asDiagonal() * Q.transpose();
    Mat6 J;
    J << IG - m * hat(r) * hat(r), m * hat(r), -m * hat(r), m * Mat3::Identity();
    EXPECT_LE(max_abs(spatial_inertia(m, r, IG) - J), 1e-14);
    const Inertia in = Inertia::from_com(m, r, IG);
    EXPECT_LE(max_abs(in.matrix() - J), 1e-14);
    EXPECT_LE((in.com() - r).norm(), 1e-15 * 4);
    const Vec6 V = random_vec(rng, 6, 1.0);
    EXPECT_LE(max_abs(in * V - J * V), 1e-14);
    // Kinetic energy 1/2 V^T J V = 1/2 m |v_c|^2 + 1/2 w^T I_G w, v_c the velocity of the centre.
    const Vec3 w = V.head<3>(), vc = V.tail<3>() + w.cross(r);
    EXPECT_NEAR(V.dot(J * V), m * vc.squaredNorm() + w.dot(IG * w), 1e-13);
    // Expressed in another frame: J' = Ad_{f^-1}^T J Ad_{f^-1}.
    const SE3 f = random_pose(rng, 2.0);
    const Mat6 Ai = Ad_inv(f);
    EXPECT_LE(max_abs(in.transformed(f).matrix() - Ai.transpose() * J * Ai), 1e-13);
    Inertia sum = in;
    sum += in.transformed(f);
    EXPECT_LE(max_abs(sum.matrix() - (J + Ai.transpose() * J * Ai)), 1e-13);
  }
}

// Eq. (24) against the rate of the world-frame momentum of a body moving along
// f(t) = f0 exp(t V0 + t^2/2 W) (body twist V0, its derivative W at t = 0).
TEST(Lie, NewtonEulerWrench) {
  std::mt19937_64 rng(15);
  double worst = 0;
  for (int k = 0; k < 100; ++k) {
    const Mat6 J =
        spatial_inertia(uniform(rng, 0.5, 3.0), random_vec(rng, 3, 0.5), Mat3::Identity() * 0.3);
    const Vec6 V = random_vec(rng, 6, 1.0), W = random_vec(rng, 6, 1.0);
    EXPECT_LE(max_abs(newton_euler_wrench(J, V, W) - (J * W - ad(V).transpose() * (J * V))), 1e-14);
    const SE3 f0 = random_pose(rng);
    auto momentum = [&](double t) {
      const Vec6 xi = t * V + 0.5 * t * t * W;
      const Vec6 body_twist = dexp_se3(-xi) * (V + t * W);
      return Vec6(act_force(f0 * exp_se3(xi), J * body_twist));
    };
    const Vec6 rate = central_diff4(momentum, 1e-3);
    const double err = max_abs(rate - act_force(f0, newton_euler_wrench(J, V, W)));
    worst = std::max(worst, err);
    EXPECT_LE(err, 1e-9);
  }
  std::printf("Newton-Euler wrench vs momentum rate: max error %.3g\n", worst);
}

TEST(Lie, QuaternionRoundTrip) {
  std::mt19937_64 rng(16);
  std::normal_distribution<double> g;
  for (int k = 0; k < 1000; ++k) {
    Eigen::Vector4d q(g(rng), g(rng), g(rng), g(rng));
    if (k < 4) q = Eigen::Vector4d::Unit(k);  // rotations by pi (w = 0) and the identity
    q.normalize();
    if (q[3] < 0) q = -q;
    const Mat3 R = rotation_from_quaternion(q[0], q[1], q[2], q[3]);
    // The textbook formula for (x, y, z, w).
    const double x = q[0], y = q[1], z = q[2], w = q[3];
    Mat3 ref;
    ref << 1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w), 2 * (x * y + z * w),
        1 - 2 * (x * x + z * z), 2 * (y * z - x * w),  //
        2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y);
    EXPECT_LE(max_abs(R - ref), 1e-15 * 4);
    const Eigen::Vector4d back = quaternion_from_rotation(R);
    EXPECT_GE(back[3], 0.0);
    const double err = std::min((back - q).cwiseAbs().maxCoeff(), (back + q).cwiseAbs().maxCoeff());
    EXPECT_LE(err, 1e-15 * 4) << q.transpose();
    if (q[3] > 1e-3) {
      EXPECT_LE((back - q).cwiseAbs().maxCoeff(), 1e-15 * 4);
    }
    // The quaternion's rotation vector is the log.
    const double angle = 2 * std::atan2(q.head<3>().norm(), q[3]);
    if (angle < M_PI - 1e-6) {
      EXPECT_LE((log_so3(R) - angle * q.head<3>().normalized()).norm(), 1e-14);
    }
  }
  // Orthonormalizing a slightly perturbed rotation returns a rotation close to it.
  const Mat3 R = exp_so3(Vec3(0.3, -0.2, 0.9));
  Mat3 P = R;
  P(0, 1) += 1e-9;
  const Mat3 O = orthonormalize(P);
  EXPECT_LE(max_abs(O.transpose() * O - Mat3::Identity()), 1e-15 * 4);
  EXPECT_LE(max_abs(O - R), 1e-9);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
