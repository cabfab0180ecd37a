// Dynamics on every robot of data/robots and on generated chains, fixed and floating, at random
// states with fixed seeds: the algorithms against each other (RNEA, ABA, CRBA, D^-1), against
// the paper's route to D (unit-acceleration RNEA), and against physics (power balance, momentum
// conservation, gravity as the gradient of the potential), plus D^-1 against a long-double
// inverse on ill-conditioned chains.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <Eigen/SVD>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <type_traits>

#include "../src/dynamics/joint.h"
#include "../src/dynamics/row_kernel.h"
#include "test_util.h"

using namespace se3;
using se3_test::Case;
using se3_test::max_abs;
using se3_test::RandomState;
using se3_test::rel_err;

namespace {

const std::vector<Case>& cases() {
  static const std::vector<Case> c = se3_test::all_cases();
  return c;
}

constexpr int kStates = 3;

// Fourth-order central difference at 0 of a function of one variable.
template <class F>
auto central_diff4(F&& g, double h) {
  using R = std::decay_t<decltype(g(h))>;
  const R a = g(2 * h), b = g(h), c = g(-h), e = g(-2 * h);
  return R((-a + 8 * b - 8 * c + e) / (12 * h));
}

// The state moved along a curve through s whose first derivatives are the true ones:
// base f0 exp(t V0) (body twist V0), q + t qdot, v + t a. Any quantity depending on (pose, q, v)
// has, at t = 0, the time derivative it has along the true motion with acceleration a.
struct Curve {
  const Model& m;
  const RandomState& s;
  const VecX& a;
  SE3 base(double t) const {
    if (!m.floating) return s.base;
    return s.base * exp_se3(t * Vec6(s.v.head<6>()));
  }
  VecX q(double t) const { return s.q + t * s.v.tail(m.n); }
  VecX v(double t) const { return s.v + t * a; }
};

Model without_gravity(const Model& m) {
  Model z = m;
  z.gravity.setZero();
  return z;
}

}  // namespace

TEST(Dynamics, RneaOfAbaIsTau) {
  double worst = 0;
  for (const Case& c : cases()) {
    const Model& m = c.model;
    Data d(m);
    std::mt19937_64 rng(101);
    for (int k = 0; k < kStates; ++k) {
      const RandomState s = se3_test::random_state(m, rng);
      const VecX a = aba(m, d, s.base, s.q, s.v, s.u);
      const VecX tau = rnea(m, d, s.base, s.q, s.v, a);
      const VecX H = bias(m, d, s.base, s.q, s.v);
      // The terms that cancel in RNEA(ABA(tau)) are of the size of tau, H and D a (large for
      // light bodies).
      const double Dmax = max_abs(crba(m, d, s.base, s.q));
      const double scale = std::max({max_abs(s.u), max_abs(H), Dmax * max_abs(a)});
      const double err = max_abs(tau - s.u) / scale;
      worst = std::max(worst, err);
      EXPECT_LE(err, 1e-12) << c.label;
      // A free base with no wrench moves freely: rnea's base wrench is zero.
      if (m.floating) {
        VecX u = s.u;
        u.head<6>().setZero();
        const VecX a0 = aba(m, d, s.base, s.q, s.v, u);
        EXPECT_LE(max_abs(rnea(m, d, s.base, s.q, s.v, a0).head<6>()), 1e-12 * scale) << c.label;
        // ABA's external base wrench acts as the base's generalized force.
        const Vec6 fe = s.u.head<6>();
        const VecX a1 = aba(m, d, s.base, s.q, s.v, u, &fe);
        EXPECT_LE(max_abs(a1 - a), 1e-12 * std::max(1.0, max_abs(a))) << c.label;
        // ... and rnea's f_ext_base is subtracted from the wrench the base needs.
        const VecX t1 = rnea(m, d, s.base, s.q, s.v, a, &fe);
        EXPECT_LE(max_abs(t1 - u), 1e-12 * scale) << c.label;
      }
    }
  }
  std::printf("RNEA(ABA(tau)) - tau: max relative error %.3g\n", worst);
  RecordProperty("rnea_aba_err", std::to_string(worst));
}

TEST(Dynamics, EquationsOfMotion) {
  double worst_eom = 0, worst_inv = 0, worst_sym = 0, worst_minv = 0, worst_cols = 0;
  for (const Case& c : cases()) {
    const Model& m = c.model;
    Data d(m);
    std::mt19937_64 rng(102);
    for (int k = 0; k < kStates; ++k) {
      const RandomState s = se3_test::random_state(m, rng);
      const MatX D = crba(m, d, s.base, s.q);
      const MatX Di = minv(m, d, s.base, s.q);
      const VecX H = bias(m, d, s.base, s.q, s.v);
      const VecX a = aba(m, d, s.base, s.q, s.v, s.u);
      // D a + H = tau.
      // Rounding in D a is relative to |D| |a| (large for light bodies).
      const double scale = std::max({max_abs(s.u), max_abs(H), max_abs(D) * max_abs(a)});
      const double eom = max_abs(D * a + H - s.u) / scale;
      worst_eom = std::max(worst_eom, eom);
      EXPECT_LE(eom, 1e-12) << c.label;
      // D symmetric positive definite.
      const double sym = max_abs(D - D.transpose()) / max_abs(D);
      worst_sym = std::max(worst_sym, sym);
      EXPECT_LE(sym, 1e-14) << c.label;
      const Eigen::LLT<MatX> llt(D);
      ASSERT_EQ(llt.info(), Eigen::Success) << c.label;
      EXPECT_GT(llt.matrixL().toDenseMatrix().diagonal().minCoeff(), 0.0) << c.label;
      // D D^-1 = I; minv equals D's Cholesky inverse and is symmetric.
      const MatX I = MatX::Identity(m.nv, m.nv);
      const Eigen::JacobiSVD<MatX> svd(D);
      const double cond = svd.singularValues()(0) / svd.singularValues()(m.nv - 1);
      const double inv = max_abs(D * Di - I);
      worst_inv = std::max(worst_inv, inv / cond);
      EXPECT_LE(inv, std::max(1e-12, 1e-15 * 20 * cond)) << c.label << " cond " << cond;
      const MatX Dinv_llt = llt.solve(I);
      const double mi = rel_err(Di, Dinv_llt);
      worst_minv = std::max(worst_minv, mi / cond);
      EXPECT_LE(mi, std::max(1e-12, 1e-15 * 20 * cond)) << c.label << " cond " << cond;
      EXPECT_LE(max_abs(Di - Di.transpose()), 1e-14 * max_abs(Di)) << c.label;
      // The paper's route to D (section 6.1): column j is RNEA with unit acceleration e_j, no
      // velocity and no gravity.
      const Model mz = without_gravity(m);
      Data dz(mz);
      const VecX zero = VecX::Zero(m.nv);
      double cols = 0;
      for (int j = 0; j < m.nv; ++j) {
        const VecX e = VecX::Unit(m.nv, j);
        cols = std::max(cols, max_abs(rnea(mz, dz, s.base, s.q, zero, e) - D.col(j)));
      }
      cols /= max_abs(D);
      worst_cols = std::max(worst_cols, cols);
      EXPECT_LE(cols, 1e-13) << c.label;
      // ABA without velocity, gravity or torque but one unit torque is a column of D^-1.
      const int j = static_cast<int>(rng() % m.nv);
      const VecX aj = aba(mz, dz, s.base, s.q, zero, VecX::Unit(m.nv, j));
      EXPECT_LE(rel_err(aj, Di.col(j)), std::max(1e-12, 1e-15 * 20 * cond)) << c.label;
    }
  }
  std::printf(
      "D a + H - tau: %.3g rel; D D^-1 - I: %.3g x cond; minv vs LLT inverse: %.3g x cond; "
      "asymmetry %.3g; CRBA vs unit-acceleration RNEA: %.3g rel\n",
      worst_eom, worst_inv, worst_minv, worst_sym, worst_cols);
  RecordProperty("eom_err", std::to_string(worst_eom));
}

TEST(Dynamics, KineticEnergy) {
  for (const Case& c : cases()) {
    const Model& m = c.model;
    Data d(m);
    std::mt19937_64 rng(103);
    for (int k = 0; k < kStates; ++k) {
      const RandomState s = se3_test::random_state(m, rng);
      const MatX D = crba(m, d, s.base, s.q);
      const double T = kinetic_energy(m, d, s.base, s.q, s.v);
      EXPECT_NEAR(T, 0.5 * s.v.dot(D * s.v), 1e-13 * T) << c.label;
      EXPECT_GT(T, 0.0);
      // The momentum is D v, seen as a wrench: h . V0 ... checked through its own power below;
      // here: sum of body momenta in the world equals the base-frame momentum D.topRows(6) v.
      if (m.floating) {
        const Vec6 h = spatial_momentum(m, d, s.base, s.q, s.v);
        const Vec6 hb = D.topRows<6>() * s.v;
        EXPECT_LE(max_abs(h - act_force(s.base, hb)), 1e-13 * std::max(1.0, max_abs(h))) << c.label;
      }
    }
  }
}

// d(T + V)/dt = v^T tau (no damping), by a 4th-order central difference of the energy along the
// curve through the state with the ABA acceleration.
TEST(Dynamics, PowerBalance) {
  double worst = 0;
  for (const Case& c : cases()) {
    const Model& m = c.model;
    Data d(m);
    std::mt19937_64 rng(104);
    for (int k = 0; k < kStates; ++k) {
      const RandomState s = se3_test::random_state(m, rng);
      const VecX a = aba(m, d, s.base, s.q, s.v, s.u);
      const Curve cv{m, s, a};
      auto energy = [&](double t) {
        const SE3 f = cv.base(t);
        const VecX q = cv.q(t);
        return kinetic_energy(m, d, f, q, cv.v(t)) + potential_energy(m, d, f, q);
      };
      const double dEdt = central_diff4(energy, 1e-4);
      const double power = s.v.dot(s.u);
      // Scale: the sizes of the powers that have to cancel.
      const VecX H = bias(m, d, s.base, s.q, s.v);
      const double scale = s.v.cwiseAbs().dot(s.u.cwiseAbs() + H.cwiseAbs());
      const double err = std::abs(dEdt - power) / scale;
      worst = std::max(worst, err);
      EXPECT_LE(err, 1e-7) << c.label << ": dE/dt " << dEdt << " v.tau " << power;
    }
  }
  std::printf("power balance d(T+V)/dt - v.tau: max relative error %.3g\n", worst);
  RecordProperty("power_balance_err", std::to_string(worst));
}

// Gravity: at rest and without acceleration, RNEA gives the gradient of the potential energy
// (joint coordinates and the base's body-frame motions f0 exp(e E_k)).
TEST(Dynamics, GravityIsTheGradientOfThePotential) {
  double worst = 0;
  for (const Case& c : cases()) {
    const Model& m = c.model;
    Data d(m);
    std::mt19937_64 rng(105);
    const RandomState s = se3_test::random_state(m, rng);
    const VecX zero = VecX::Zero(m.nv);
    const VecX G = rnea(m, d, s.base, s.q, zero, zero);
    VecX grad(m.nv);
    const int off = m.nv_base();
    for (int k = 0; k < m.nv; ++k) {
      auto V = [&](double e) {
        if (k < off) return potential_energy(m, d, s.base * exp_se3(e * Vec6::Unit(k)), s.q);
        return potential_energy(m, d, s.base, s.q + e * VecX::Unit(m.n, k - off));
      };
      grad[k] = central_diff4(V, 1e-3);
    }
    const double err = max_abs(G - grad) / std::max(1e-3, max_abs(G));
    worst = std::max(worst, err);
    EXPECT_LE(err, 1e-9) << c.label;
  }
  std::printf("gravity vs gradient of the potential: max relative error %.3g\n", worst);
}

// Total spatial momentum of a free-floating system: its rate is the external wrench. Without
// gravity and base wrench it is conserved whatever the joint torques.
TEST(Dynamics, MomentumConservation) {
  double worst_exact = 0, worst_fd = 0;
  for (const Case& c : cases()) {
    if (!c.model.floating) continue;
    const Model m = without_gravity(c.model);
    Data d(m);
    std::mt19937_64 rng(106);
    for (int k = 0; k < kStates; ++k) {
      RandomState s = se3_test::random_state(m, rng);
      for (bool with_wrench : {false, true}) {
        if (!with_wrench) s.u.head<6>().setZero();
        const Vec6 Fb = s.u.head<6>();
        const VecX a = aba(m, d, s.base, s.q, s.v, s.u);
        // Exact: dh/dt = sum_i Ad*_{oMb_i^-1} (I_i A_i - ad*_{V_i} I_i V_i), with the body
        // twists V_i and accelerations A_i recomputed here from ABA's generalized accelerations
        // (eqs. 33-35, body frames, written independently of the library's Data).
        std::vector<SE3> oMb(m.n + 1);
        std::vector<Vec6> V(m.n + 1), A(m.n + 1);
        oMb[0] = s.base;
        V[0] = s.v.head<6>();
        A[0] = a.head<6>();
        for (int i = 1; i <= m.n; ++i) {
          const double qi = s.q[i - 1], qd = s.v[5 + i], qdd = a[5 + i];
          Vec6 S = Vec6::Zero();
          SE3 J;
          if (m.joints[i].type == JointType::Revolute) {
            S[2] = 1;
            J.R = Eigen::AngleAxisd(qi, Vec3::UnitZ()).toRotationMatrix();
          } else {
            S[5] = 1;
            J.p = Vec3(0, 0, qi);
          }
          const SE3 X = m.X_tree[i] * J;
          oMb[i] = oMb[m.parent[i]] * X;
          V[i] = act_inv_motion(X, V[m.parent[i]]) + S * qd;
          A[i] = act_inv_motion(X, A[m.parent[i]]) + S * qdd + cross_motion(V[i], S * qd);
        }
        Vec6 rate = Vec6::Zero();
        double scale = 0;
        for (int i = 0; i <= m.n; ++i) {
          const Inertia& I = m.inertia[i];
          const Vec6 w = act_force(oMb[i], I * A[i] + cross_force(V[i], I * V[i]));
          rate += w;
          scale = std::max(scale, max_abs(w));
        }
        const Vec6 expected = act_force(s.base, Fb);
        scale = std::max(scale, max_abs(expected));
        const double e1 = max_abs(rate - expected) / scale;
        worst_exact = std::max(worst_exact, e1);
        EXPECT_LE(e1, 1e-11) << c.label;
        // Finite differences of spatial_momentum along the motion.
        const Curve cv{m, s, a};
        auto h = [&](double t) {
          return Vec6(spatial_momentum(m, d, cv.base(t), cv.q(t), cv.v(t)));
        };
        const Vec6 hdot = central_diff4(h, 1e-4);
        const double e2 = max_abs(hdot - expected) / scale;
        worst_fd = std::max(worst_fd, e2);
        EXPECT_LE(e2, 1e-7) << c.label;
      }
    }
  }
  std::printf("momentum rate - external wrench: exact %.3g, finite differences %.3g (relative)\n",
              worst_exact, worst_fd);
  RecordProperty("momentum_err", std::to_string(worst_exact));
}

// With gravity the momentum changes by the weight: dh/dt = [c x M g; M g] + base wrench.
TEST(Dynamics, MomentumRateUnderGravity) {
  for (const Case& c : cases()) {
    if (!c.model.floating) continue;
    const Model& m = c.model;
    Data d(m);
    std::mt19937_64 rng(107);
    const RandomState s = se3_test::random_state(m, rng);
    const VecX a = aba(m, d, s.base, s.q, s.v, s.u);
    const Curve cv{m, s, a};
    auto h = [&](double t) { return Vec6(spatial_momentum(m, d, cv.base(t), cv.q(t), cv.v(t))); };
    const Vec6 hdot = central_diff4(h, 1e-4);
    const double M = m.total_mass();
    const Vec3 com = center_of_mass(m, d, s.base, s.q);
    Vec6 expected = act_force(s.base, Vec6(s.u.head<6>()));
    expected.head<3>() += com.cross(M * m.gravity);
    expected.tail<3>() += M * m.gravity;
    EXPECT_LE(max_abs(hdot - expected), 1e-7 * std::max(max_abs(expected), M * 9.81)) << c.label;
  }
}

namespace {

using LD = long double;
using MatXL = Eigen::Matrix<LD, Eigen::Dynamic, Eigen::Dynamic>;
using Mat3L = Eigen::Matrix<LD, 3, 3>;
using Vec3L = Eigen::Matrix<LD, 3, 1>;
using Mat6L = Eigen::Matrix<LD, 6, 6>;

Mat3L hat_ld(const Vec3L& a) {
  Mat3L m;
  m << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return m;
}

// The mass matrix assembled in long double straight from the model, independently of crba:
// D = sum_i J_i^T I_i J_i with world-frame body Jacobians J_i and world-frame inertias I_i.
MatXL mass_matrix_long_double(const Model& m, const SE3& base, const VecX& q) {
  const int off = m.nv_base();
  std::vector<Mat3L> R(m.n + 1);
  std::vector<Vec3L> p(m.n + 1);
  R[0] = base.R.cast<LD>();
  p[0] = base.p.cast<LD>();
  for (int i = 1; i <= m.n; ++i) {
    const int a = m.parent[i];
    const Mat3L Rt = m.X_tree[i].R.cast<LD>();
    const Vec3L pt = m.X_tree[i].p.cast<LD>();
    Mat3L Rj = Mat3L::Identity();
    Vec3L pj = Vec3L::Zero();
    const LD qi = q[i - 1];
    if (m.joints[i].type == JointType::Revolute) {
      Rj << std::cos(qi), -std::sin(qi), 0, std::sin(qi), std::cos(qi), 0, 0, 0, 1;
    } else {
      pj << 0, 0, qi;
    }
    R[i] = R[a] * Rt * Rj;
    p[i] = R[a] * (Rt * pj + pt) + p[a];
  }
  MatXL D = MatXL::Zero(m.nv, m.nv);
  for (int i = m.floating ? 0 : 1; i <= m.n; ++i) {
    const Inertia& I = m.inertia[i];
    const Mat3L H = hat_ld(I.h.cast<LD>());
    Mat6L Jb;
    Jb << I.I.cast<LD>(), H, -H, static_cast<LD>(I.m) * Mat3L::Identity();
    Mat6L Adinv;
    Adinv << R[i].transpose(), Mat3L::Zero(), -R[i].transpose() * hat_ld(p[i]), R[i].transpose();
    const Mat6L Iw = Adinv.transpose() * Jb * Adinv;
    Eigen::Matrix<LD, 6, Eigen::Dynamic> J = Eigen::Matrix<LD, 6, Eigen::Dynamic>::Zero(6, m.nv);
    if (m.floating) {
      J.leftCols<6>() << R[0], Mat3L::Zero(), hat_ld(p[0]) * R[0], R[0];
    }
    for (int j = i; j >= 1; j = m.parent[j]) {
      const Vec3L z = R[j].col(2);
      if (m.joints[j].type == JointType::Revolute) {
        J.col(off + j - 1) << z, p[j].cross(z);
      } else {
        J.col(off + j - 1) << Vec3L::Zero(), z;
      }
    }
    D += J.transpose() * Iw * J;
  }
  return D;
}

struct MinvAccuracy {
  double cond = 0;       ///< largest cond(D) seen
  double err_exact = 0;  ///< minv vs the long-double inverse of the long-double D
  double err_crba = 0;   ///< minv vs the long-double inverse of crba's D
  double err_llt = 0;    ///< double LLT inverse of crba's D vs the long-double inverse of it
};

// minv on a model against D^-1 computed in long double, at a few random states.
MinvAccuracy minv_vs_long_double(const Model& m, const std::string& label) {
  Data d(m);
  std::mt19937_64 rng(108);
  MinvAccuracy acc;
  for (int k = 0; k < kStates; ++k) {
    const RandomState s = se3_test::random_state(m, rng);
    const MatX D = crba(m, d, s.base, s.q);
    const MatX Di = minv(m, d, s.base, s.q);
    const MatXL DL = mass_matrix_long_double(m, s.base, s.q);
    const MatX exact_inv = MatXL(DL.fullPivLu().inverse()).cast<double>();
    const MatX crba_inv = MatXL(D.cast<LD>().fullPivLu().inverse()).cast<double>();
    const Eigen::JacobiSVD<MatXL> svd(DL);
    const double cond =
        static_cast<double>(svd.singularValues()(0) / svd.singularValues()(m.nv - 1));
    const double crba_err =
        static_cast<double>((D.cast<LD>() - DL).cwiseAbs().maxCoeff() / DL.cwiseAbs().maxCoeff());
    const double e_exact = rel_err(Di, exact_inv);
    const double e_crba = rel_err(Di, crba_inv);
    const double e_llt =
        rel_err(MatX(Eigen::LLT<MatX>(D).solve(MatX::Identity(m.nv, m.nv))), crba_inv);
    std::printf(
        "%-34s nv %3d  cond(D) %.3e  minv vs long-double D^-1: %.3e;  vs long-double "
        "inverse of crba's D: %.3e (double LLT of it: %.3e; crba's D rel. error "
        "%.1e)\n",
        label.c_str(), m.nv, cond, e_exact, e_crba, e_llt, crba_err);
    EXPECT_LE(crba_err, 1e-14) << label;
    acc.cond = std::max(acc.cond, cond);
    acc.err_exact = std::max(acc.err_exact, e_exact);
    acc.err_crba = std::max(acc.err_crba, e_crba);
    acc.err_llt = std::max(acc.err_llt, e_llt);
  }
  return acc;
}

// The reference's own rounding: crba's D carries relative errors of a few eps, which an
// inverse amplifies by up to cond(D); minv cannot agree with crba's D^-1 better than that.
void expect_accurate(const MinvAccuracy& a, const std::string& label) {
  EXPECT_LE(a.err_exact, 1e-9) << label << " cond " << a.cond;
  EXPECT_LE(a.err_crba, std::max(1e-9, 1e-15 * a.cond)) << label << " cond " << a.cond;
}

}  // namespace

// Link masses spanning four orders of magnitude (1e-2 .. 1e2 kg).
TEST(Dynamics, MinvAccuracyMassesOverFourDecades) {
  for (bool floating : {false, true}) {
    const std::string label =
        std::string("chain44 {1e-2,1,1e2} ") + (floating ? "floating" : "fixed");
    const MinvAccuracy a = minv_vs_long_double(make_chain(44, floating, {1e-2, 1, 100}), label);
    expect_accurate(a, label);
    const std::string key = floating ? "_floating" : "_fixed";
    RecordProperty("cond_4dec" + key, std::to_string(a.cond));
    RecordProperty("minv_err_4dec" + key, std::to_string(a.err_exact));
  }
}

// cond(D) about 1e7, as for the 50-dof humanoid the issue cites.
TEST(Dynamics, MinvAccuracyCond1e7) {
  const std::string label = "chain20 {1e-2,1,1e2} floating";
  const MinvAccuracy a = minv_vs_long_double(make_chain(20, true, {1e-2, 1, 100}), label);
  EXPECT_GE(a.cond, 5e6);
  EXPECT_LE(a.cond, 1e8);
  expect_accurate(a, label);
  RecordProperty("cond_1e7", std::to_string(a.cond));
  RecordProperty("minv_err_1e7", std::to_string(a.err_exact));
}

// The long-double mass matrix of this file agrees with crba on every model (so it is a fair
// reference above), in both of crba's evaluations (local frames and world frame), whichever
// the model's Data picks by default.
TEST(Dynamics, LongDoubleMassMatrixMatchesCrba) {
  for (const Case& c : cases()) {
    const Model& m = c.model;
    Data d(m);
    std::mt19937_64 rng(109);
    const RandomState s = se3_test::random_state(m, rng);
    const MatX DL = mass_matrix_long_double(m, s.base, s.q).cast<double>();
    for (const bool local : {true, false}) {
      Data dv(m);
      dv.crba_local = local;
      EXPECT_LE(rel_err(crba(m, dv, s.base, s.q), DL), 1e-13)
          << c.label << (local ? " (local frames)" : " (world frame)");
    }
    EXPECT_LE(rel_err(crba(m, d, s.base, s.q), DL), 1e-13) << c.label;
  }
}

// The default evaluation is the cheaper one: local frames for shallow trees, world frame for
// long chains.
TEST(Dynamics, CrbaPicksItsEvaluationByDepth) {
  EXPECT_TRUE(Data(make_chain(6, false)).crba_local);
  EXPECT_TRUE(Data(make_chain(6, true)).crba_local);
  EXPECT_FALSE(Data(make_chain(200, false)).crba_local);
  for (const Case& c : cases()) {
    if (c.label.find("solo12") != std::string::npos || c.label.find("ur5") != std::string::npos) {
      EXPECT_TRUE(Data(c.model).crba_local) << c.label;
    }
  }
}

// minv's two routes (the recursion of eqs. 55-63 and the factorization of crba's D) on every
// model: each equals D's Cholesky inverse to the conditioning's accuracy and the other route,
// both are exactly symmetric, and the factor route's pivots are the recursion's 1 / (S^T IA S).
TEST(Dynamics, MinvRoutesAgree) {
  std::vector<Case> all = cases();
  all.push_back({"chain8 {1e-2,1,1e2} fixed", make_chain(8, false, {1e-2, 1, 100})});
  all.push_back({"chain4 {1e-2,1,1e2} floating", make_chain(4, true, {1e-2, 1, 100})});
  double worst = 0;
  for (const Case& c : all) {
    const Model& m = c.model;
    Data fac(m), rec(m);
    fac.minv_by_factor = true;
    rec.minv_by_factor = false;
    std::mt19937_64 rng(110);
    for (int k = 0; k < kStates; ++k) {
      const RandomState s = se3_test::random_state(m, rng);
      const MatX D = crba(m, rec, s.base, s.q);
      const MatX Dl = D.llt().solve(MatX::Identity(m.nv, m.nv));
      const Eigen::JacobiSVD<MatX> svd(D);
      const double cond = svd.singularValues()(0) / svd.singularValues()(m.nv - 1);
      const double tol = std::max(1e-12, 1e-15 * 20 * cond);
      const MatX Df = minv(m, fac, s.base, s.q);
      const MatX Dr = minv(m, rec, s.base, s.q);
      EXPECT_LE(rel_err(Df, Dl), tol) << c.label << " cond " << cond;
      EXPECT_LE(rel_err(Dr, Dl), tol) << c.label << " cond " << cond;
      EXPECT_LE(rel_err(Df, Dr), tol) << c.label << " cond " << cond;
      worst = std::max(worst, rel_err(Df, Dr) / cond);
      EXPECT_EQ(Df, Df.transpose()) << c.label;
      EXPECT_EQ(Dr, Dr.transpose()) << c.label;
      for (int i = m.nv_base(); i < m.nv; ++i) {
        EXPECT_LE(std::abs(fac.Dinv[i] - rec.Dinv[i]), tol * std::abs(rec.Dinv[i]))
            << c.label << " dof " << i;
      }
    }
  }
  std::printf("minv factor route vs recursion: %.3g x cond\n", worst);
}

// D's factor along the tree (mass_matrix_ltdl) on every model and two ill-conditioned chains:
// L^T Diag L rebuilds D, L has no entry off the dofs' ancestors (no fill-in: what lets the
// Delassus products walk ancestors alone), the pivots are the recursion's 1 / (S^T IA S), and
// the two triangular solves apply D^-1 (L^-1 Diag^-1 L^-T b = D^-1 b).
TEST(Dynamics, MassMatrixFactorAlongTheTree) {
  std::vector<Case> all = cases();
  all.push_back({"chain20 {1e-2,1,1e2} floating", make_chain(20, true, {1e-2, 1, 100})});
  all.push_back({"chain44 {1e-2,1,1e2} fixed", make_chain(44, false, {1e-2, 1, 100})});
  for (const Case& c : all) {
    const Model& m = c.model;
    Data data(m), rec(m);
    rec.minv_by_factor = false;
    std::mt19937_64 rng(55);
    for (int k = 0; k < kStates; ++k) {
      const RandomState s = se3_test::random_state(m, rng);
      const MatX D = crba(m, rec, s.base, s.q);
      const MatX& LD = mass_matrix_ltdl(m, data, s.base, s.q);
      MatX L = MatX::Identity(m.nv, m.nv);
      VecX diag(m.nv);
      for (int i = 0; i < m.nv; ++i) {
        diag[i] = LD(i, i);
        EXPECT_EQ(data.Dinv[i], 1.0 / diag[i]) << c.label;
        for (int j = 0; j < i; ++j) {
          bool ancestor = false;
          for (int a = data.v_parent[i]; a >= 0; a = data.v_parent[a]) ancestor |= a == j;
          if (ancestor) {
            L(i, j) = LD(i, j);
          } else {
            ASSERT_EQ(LD(i, j), 0.0) << c.label << ": fill-in at " << i << ", " << j;
          }
        }
      }
      const MatX rebuilt = L.transpose() * diag.asDiagonal() * L;
      EXPECT_LT(rel_err(rebuilt, D), 1e-14) << c.label;
      minv(m, rec, s.base, s.q);
      for (int i = m.nv_base(); i < m.nv; ++i) {
        EXPECT_LT(std::abs(data.Dinv[i] - rec.Dinv[i]), 1e-9 * std::abs(rec.Dinv[i]))
            << c.label << " dof " << i;
      }
      const VecX b = VecX::Random(m.nv);
      VecX x = b;
      ltdl_solve_lt(data, x.data());
      for (int i = 0; i < m.nv; ++i) x[i] *= data.Dinv[i];
      ltdl_solve_l(data, x.data());
      const VecX ref = D.llt().solve(b);
      const Eigen::JacobiSVD<MatX> svd(D);
      const double cond = svd.singularValues()(0) / svd.singularValues()(m.nv - 1);
      EXPECT_LT(rel_err(x, ref), std::max(1e-12, 1e-15 * 20 * cond)) << c.label;
    }
  }
}

// The default route is the cheaper one (docs/performance.md): the factorization for small
// shallow trees (the arms, short chains), the recursion for the quadrupeds and long chains.
TEST(Dynamics, MinvPicksItsRouteBySize) {
  EXPECT_TRUE(Data(make_chain(2, false)).minv_by_factor);
  EXPECT_TRUE(Data(make_chain(8, false)).minv_by_factor);
  EXPECT_FALSE(Data(make_chain(10, false)).minv_by_factor);
  EXPECT_TRUE(Data(make_chain(4, true)).minv_by_factor);
  EXPECT_FALSE(Data(make_chain(6, true)).minv_by_factor);
  EXPECT_FALSE(Data(make_chain(200, false)).minv_by_factor);
  for (const Case& c : cases()) {
    const bool arm = c.label.find("ur5") != std::string::npos ||
                     c.label.find("panda") != std::string::npos ||
                     c.label.find("iiwa") != std::string::npos;
    if (arm && !c.model.floating) {
      EXPECT_TRUE(Data(c.model).minv_by_factor) << c.label;
    }
    if (c.label.find("solo12") != std::string::npos && c.model.floating) {
      EXPECT_FALSE(Data(c.model).minv_by_factor) << c.label;
    }
  }
}

// ABA's documented contract, which RKMK's stage poses rely on (rkmk.cpp, stage_pose): the base
// pose enters only through its rotation (gravity's direction in the base frame), and not at all
// without gravity. Bit-identical accelerations, fixed and free base.
TEST(Dynamics, AbaReadsTheBasePoseOnlyThroughGravity) {
  for (bool floating : {false, true}) {
    Model m = make_chain(7, floating, {2.0, 1.0});
    Data d(m);
    std::mt19937_64 rng(31);
    const RandomState s = se3_test::random_state(m, rng);
    const SE3 moved(s.base.R, s.base.p + Vec3(3.0, -1.0, 2.5));
    const VecX a = aba(m, d, s.base, s.q, s.v, s.u);
    EXPECT_EQ(aba(m, d, moved, s.q, s.v, s.u), a) << floating;
    const SE3 turned(exp_so3(Vec3(0.4, -0.3, 1.1)) * s.base.R, s.base.p);
    EXPECT_NE(aba(m, d, turned, s.q, s.v, s.u), a) << floating;  // gravity turned
    m.gravity.setZero();
    const VecX a0 = aba(m, d, s.base, s.q, s.v, s.u);
    EXPECT_EQ(aba(m, d, turned, s.q, s.v, s.u), a0) << floating;
    EXPECT_EQ(aba(m, d, moved, s.q, s.v, s.u), a0) << floating;
  }
}

// Data holds what its fields say: rnea and aba both leave the body twists V (those of
// forward_kinematics with v) and the accelerations A with gravity folded in; for the same motion
// (a = ABA(tau)) the two recursions agree on A, and D^-1 and crba leave their matrices.
TEST(Dynamics, DataFieldsAreFilledAsDocumented) {
  for (bool floating : {false, true}) {
    const Model m = make_chain(9, floating, {1.5, 0.7});
    Data fk(m), r(m), ab(m);
    std::mt19937_64 rng(57);
    const RandomState s = se3_test::random_state(m, rng);
    forward_kinematics(m, fk, s.base, s.q, s.v);
    const VecX a = aba(m, ab, s.base, s.q, s.v, s.u);
    rnea(m, r, s.base, s.q, s.v, a);
    for (int i = 0; i <= m.n; ++i) {
      EXPECT_LE((r.V[i] - fk.V[i]).cwiseAbs().maxCoeff(), 1e-14) << i;
      EXPECT_LE((ab.V[i] - fk.V[i]).cwiseAbs().maxCoeff(), 1e-14) << i;
      EXPECT_LE((r.A[i] - ab.A[i]).cwiseAbs().maxCoeff(), 1e-11 * (1 + ab.A[i].norm())) << i;
    }
    EXPECT_GT(fk.V[m.n].norm(), 0.1);
    EXPECT_GT(ab.A[m.n].norm(), 0.1);
    EXPECT_EQ(r.M.size(), 0);  // no mass matrix until crba is called
    crba(m, r, s.base, s.q);
    EXPECT_EQ(r.M.rows(), m.nv);
  }
}

// crba's paired row kernel against its scalar reference: identical bits for every segment start
// and length (odd and even, so the paired loop and its tail both run) and both output strides.
TEST(Dynamics, PairedRowKernelEqualsItsScalarReference) {
  std::mt19937_64 rng(77);
  std::uniform_real_distribution<double> u(-1, 1);
  constexpr int n = 41;
  std::vector<double> rows[6];
  for (auto& r : rows) {
    r.resize(n);
    for (double& x : r) x = u(rng);
  }
  const double* const J[6] = {rows[0].data(), rows[1].data(), rows[2].data(),
                              rows[3].data(), rows[4].data(), rows[5].data()};
  long compared = 0;
  for (int c0 = 0; c0 < n; ++c0) {
    for (int c1 = c0; c1 <= n; ++c1) {
      const double F[6] = {u(rng), u(rng), u(rng), u(rng), u(rng), u(rng)};
      for (std::ptrdiff_t stride : {1, n}) {
        std::vector<double> up(n, 0.0), left(n * n, 0.0), up_ref(up), left_ref(left);
        detail::row_segment(F, J, c0, c1, up.data(), left.data(), stride);
        detail::row_segment_reference(F, J, c0, c1, up_ref.data(), left_ref.data(), stride);
        ASSERT_EQ(0, std::memcmp(up.data(), up_ref.data(), n * sizeof(double))) << c0 << " " << c1;
        ASSERT_EQ(0, std::memcmp(left.data(), left_ref.data(), n * n * sizeof(double)))
            << c0 << " " << c1;
        compared += c1 - c0;
      }
    }
  }
  EXPECT_GT(compared, 20000);
}

// detail::newton_euler (RNEA's own-body wrench, rearranged by Jacobi's identity) against the
// direct J A + V x* (J V) of inertia_times and bias_force, to rounding, on random inertias and
// motions.
TEST(Dynamics, NewtonEulerWrenchEqualsItsDirectForm) {
  std::mt19937_64 rng(79);
  std::uniform_real_distribution<double> u(-1, 1);
  double worst = 0;
  for (int trial = 0; trial < 1000; ++trial) {
    const Mat3 L = Mat3::Random();
    const Inertia I = Inertia::from_com(0.1 + 3 * (u(rng) + 1), Vec3(u(rng), u(rng), u(rng)),
                                        L * L.transpose() + 0.1 * Mat3::Identity());
    double V[6], A[6], F[6], G[6], B[6];
    for (int r = 0; r < 6; ++r) V[r] = 3 * u(rng), A[r] = 3 * u(rng);
    detail::newton_euler(I, V, A, F);
    detail::inertia_times(I, A, G);
    detail::bias_force(I, V, B);
    double scale = 0, err = 0;
    for (int r = 0; r < 6; ++r) {
      scale = std::max(scale, std::abs(G[r]) + std::abs(B[r]));
      err = std::max(err, std::abs(F[r] - (G[r] + B[r])));
    }
    worst = std::max(worst, err / scale);
  }
  EXPECT_LT(worst, 1e-14);
}

// force_to_parent_component (crba's last row) gives force_to_parent's component to the bit.
template <bool Z, int PM>
void expect_wrench_component_equals_full_transform(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 100; ++trial) {
    SE3 X(exp_so3(Vec3(u(rng), u(rng), u(rng))), Vec3(u(rng), u(rng), u(rng)));
    if (Z) X.R = Eigen::AngleAxisd(3 * u(rng), Vec3::UnitZ()).toRotationMatrix();
    double x[6], full[6];
    for (int r = 0; r < 6; ++r) full[r] = x[r] = u(rng);
    detail::force_to_parent<Z, PM>(X.R.data(), X.p.data(), full);
    ASSERT_EQ(full[2], (detail::force_to_parent_component<Z, PM, 2>(X.R.data(), X.p.data(), x)));
    ASSERT_EQ(full[5], (detail::force_to_parent_component<Z, PM, 5>(X.R.data(), X.p.data(), x)));
  }
}

TEST(Dynamics, WrenchComponentToParentEqualsTheFullTransform) {
  std::mt19937_64 rng(80);
  expect_wrench_component_equals_full_transform<false, 7>(rng);
  expect_wrench_component_equals_full_transform<true, 7>(rng);
  expect_wrench_component_equals_full_transform<false, 3>(rng);
  expect_wrench_component_equals_full_transform<true, 6>(rng);
  expect_wrench_component_equals_full_transform<false, 1>(rng);
}

// The joint forms (detail::kZ, detail::kAxisRow + k) skip only products with exact zeros (and
// kZ's exact one), in the general kernels' order: on every robot and chain, ABA, RNEA, CRBA and
// forward kinematics give the same numbers as with every joint in the general form (whose
// kinematics is the plain SE3 product).
TEST(Dynamics, JointFormsGiveTheGeneralFormsNumbers) {
  int row_forms = 0;
  for (const Case& c : cases()) {
    SCOPED_TRACE(c.label);
    Model general = c.model;
    for (int i = 1; i <= general.n; ++i) {
      general.joints[i].z_rotation = false;
      general.joints[i].axis_row = -1;
      general.joints[i].kind = general.joints[i].dispatch_kind();
      row_forms += c.model.joints[i].axis_row >= 0;
    }
    Data d(c.model), dg(general);
    std::mt19937_64 rng(90);
    for (int k = 0; k < kStates; ++k) {
      const RandomState s = se3_test::random_state(c.model, rng);
      const VecX ddq = aba(c.model, d, s.base, s.q, s.v, s.u);
      const VecX ddq_g = aba(general, dg, s.base, s.q, s.v, s.u);
      for (int r = 0; r < ddq.size(); ++r) ASSERT_EQ(ddq[r], ddq_g[r]) << "aba " << r;
      const VecX tau = rnea(c.model, d, s.base, s.q, s.v, ddq);
      const VecX tau_g = rnea(general, dg, s.base, s.q, s.v, ddq);
      for (int r = 0; r < tau.size(); ++r) ASSERT_EQ(tau[r], tau_g[r]) << "rnea " << r;
      const MatX M = crba(c.model, d, s.base, s.q);
      const MatX M_g = crba(general, dg, s.base, s.q);
      ASSERT_TRUE((M.array() == M_g.array()).all()) << "crba";
      forward_kinematics(c.model, d, s.base, s.q);
      forward_kinematics(general, dg, s.base, s.q);
      for (int i = 1; i <= c.model.n; ++i) {
        ASSERT_TRUE((d.oMb[i].R.array() == dg.oMb[i].R.array()).all()) << "fk " << i;
        ASSERT_TRUE((d.oMb[i].p.array() == dg.oMb[i].p.array()).all()) << "fk " << i;
        // and the general form is the plain product, but for the order of Eigen's sums (a few
        // ulp of entries of size 1, of the position's size)
        const SE3 f = dg.oMb[c.model.parent[i]] * dg.Xup[i];
        ASSERT_LT((f.R - dg.oMb[i].R).cwiseAbs().maxCoeff(), 1e-15) << "fk product " << i;
        ASSERT_LT((f.p - dg.oMb[i].p).cwiseAbs().maxCoeff(), 1e-15 * (1 + f.p.norm()))
            << "fk product " << i;
      }
    }
  }
  EXPECT_GT(row_forms, 20);  // the forms under test are there (the arms, Solo12, the chains)
}

// The forms the robots' joints get once X_tree's few-ulp entries are snapped (Model::finalize):
// the joint axis onto the parent's y on UR5's shoulder_lift, wrist_2 and wrist_3 and on the
// Panda's joints 2-7; UR5's base, elbow and wrist_1 joints turn about z.
TEST(Dynamics, RobotJointsGetTheirForms) {
  auto forms = [](const std::string& file) {
    const Model m = model_from_urdf_file(se3_test::robot_path(file), UrdfOptions());
    std::string f;
    for (int i = 1; i <= m.n; ++i) {
      f += m.joints[i].z_rotation      ? 'z'
           : m.joints[i].axis_row >= 0 ? char('0' + m.joints[i].axis_row)
                                       : '-';
    }
    return f;
  };
  EXPECT_EQ(forms("ur5_robot.urdf"), "z1zz11");
  EXPECT_EQ(forms("panda.urdf").substr(0, 7), "z111111");
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
