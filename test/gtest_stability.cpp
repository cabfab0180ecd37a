// Stability tests that show where each method fails and that the default survives (issue 6).
// Each test asserts both sides: the weak method fails in the stated way, the other does not.
//   - explicit Euler gains energy on a pendulum; symplectic Euler and the variational
//     integrator keep it bounded;
//   - RK4 on ZYX Euler angles loses accuracy through pitch = 90 deg (gimbal lock); the SE(3)
//     steppers (rkmk4, variational) and the quaternion baseline do not;
//   - strong joint damping beyond explicit Euler's stability limit diverges and the simulator's
//     divergence guard catches it; rkmk45 keeps its tolerance; the variational integrator
//     (damping implicit) stays stable at a 10x larger step;
//   - the log map and the integrators through rotation angle pi;
//   - long chains with link masses spanning 1e8: ABA and mass matrix + Cholesky against a
//     long-double ABA (the measured outcome is asserted).
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "../tools/charts/aba_long_double.h"
#include "se3_sim/integrate/integrate.h"
#include "se3_sim/sim/sim.h"
#include "source_paths.h"

using namespace se3;

namespace {

Model free_body(const Vec3& principal) {
  Model m;
  m.name = "body";
  m.floating = true;
  m.start_with_base("body", Inertia::from_com(2.0, Vec3::Zero(), principal.asDiagonal()));
  m.links.push_back({"body", 0, SE3()});
  m.gravity.setZero();
  m.finalize();
  m.validate();
  return m;
}

/// Torque-free axisymmetric body (I1 = I2) at its centre of mass: the closed-form attitude.
Mat3 axisymmetric_attitude(const Model& m, const State& x0, double t) {
  const Mat3& I = m.inertia[0].I;
  const double I1 = I(0, 0), I3 = I(2, 2);
  const Vec3 Lb = I * x0.v.head<3>();
  const Vec3 Ls = x0.base.R * Lb;
  const double c = (1.0 / I3 - 1.0 / I1) * Lb.z();
  return exp_so3(Ls * (t / I1)) * x0.base.R * exp_so3(Vec3(0, 0, c * t));
}

State run(const Model& m, const std::string& name, State x, double h, double T,
          const StepperOptions& opt = {}) {
  auto st = make_stepper(name, m, opt);
  const VecX zero = VecX::Zero(m.nv);
  const long n = std::lround(T / h);
  for (long k = 0; k < n; ++k) {
    const StepInfo info = st->step(x, zero, h);
    EXPECT_TRUE(info.ok) << name << ": " << info.reason;
    if (!info.ok) break;
  }
  return x;
}

double energy(const Model& m, Data& d, const State& x) {
  return kinetic_energy(m, d, x.base, x.q, x.v) + potential_energy(m, d, x.base, x.q);
}

}  // namespace

TEST(Registry, IssueSixSteppersAreRegistered) {
  for (const char* n : {"variational", "rk4_euler_angles", "rk4_quaternion"}) {
    EXPECT_FALSE(stepper_description(n).empty()) << n;
  }
  const Model m = make_chain(3, true);
  EXPECT_EQ(make_stepper("variational", m)->order(), 2);
  EXPECT_EQ(make_stepper("rk4_quaternion", m)->order(), 4);
}

// A single pendulum (chain:1, fixed base, gravity, no damping) released at 1 rad from the
// vertical, dt = 0.01 s for 100 s (about 80 swings).
TEST(Energy, ExplicitEulerGainsEnergySymplecticMethodsStayBounded) {
  Model m = make_chain(1, false);
  State x0(m);
  x0.q[0] = M_PI / 2 + 1.0;  // q = pi/2 hangs straight down (gtest_integrate)
  Data d(m);
  const double E0 = energy(m, d, x0);
  const double scale = 1.0 * 9.81 * 0.15;  // m g (L/2): the energy scale of the swing
  const double h = 0.01, T = 100;
  auto drift = [&](const std::string& name, double* final_gain) {
    auto st = make_stepper(name, m);
    State x = x0;
    const VecX zero = VecX::Zero(m.nv);
    double worst = 0;
    for (int k = 0; k < std::lround(T / h); ++k) {
      EXPECT_TRUE(st->step(x, zero, h).ok);
      worst = std::max(worst, std::abs(energy(m, d, x) - E0) / scale);
    }
    if (final_gain) *final_gain = (energy(m, d, x) - E0) / scale;
    return worst;
  };
  double gain = 0;
  const double euler = drift("euler", &gain);
  EXPECT_GT(gain, 0.5) << "explicit Euler should gain energy";
  EXPECT_GT(euler, 0.5);
  const double symp = drift("semi_implicit_euler", nullptr);
  const double var = drift("variational", nullptr);
  EXPECT_LT(symp, 0.05) << "symplectic Euler: bounded O(h) energy error";
  EXPECT_LT(var, 1e-3) << "variational: bounded O(h^2) energy error";
  std::printf(
      "  energy error over %g s at dt %g: euler %.3g (final gain %+.3g), semi_implicit_euler "
      "%.3g, variational %.3g (units of m g L/2)\n",
      T, h, euler, gain, symp, var);
}

// A body with equal principal moments turns steadily (constant body rates w): R(t) = R0 exp(t w).
// At t* = 1.013 s it sits at pitch = 90 deg - 1 mrad with roll = yaw = 0 and body rates
// w = (0, 1, 0.5), so the yaw rate (sin(roll) w_y + cos(roll) w_z) / cos(pitch) reaches 500 rad/s
// there: the path passes within 1 mrad of gimbal lock. (A path through the pole itself
// reaches it along the one direction the chart represents, where the angles stay smooth.)
TEST(GimbalLock, EulerAnglesLoseAccuracyThroughPitch90TheSe3SteppersDoNot) {
  const Model m = free_body(Vec3(0.3, 0.3, 0.3));
  const Vec3 w(0, 1, 0.5);
  const double t_pole = 1.013, miss = 1e-3;
  State x0(m);
  x0.base.R = exp_so3(Vec3(0, M_PI / 2 - miss, 0)) * exp_so3(-t_pole * w);
  x0.v.head<3>() = w;
  const double h = 0.02, T = 3.0;
  const Mat3 exact = x0.base.R * exp_so3(T * w);
  ASSERT_NEAR(-(x0.base.R * exp_so3(t_pole * w))(2, 0), std::cos(miss), 1e-12);
  auto err = [&](const std::string& name) {
    return log_so3(exact.transpose() * run(m, name, x0, h, T).base.R).norm();
  };
  const double e_euler = err("rk4_euler_angles");
  const double e_rkmk4 = err("rkmk4");
  const double e_quat = err("rk4_quaternion");
  const double e_var = err("variational");
  std::printf(
      "  attitude error after %g s at dt %g: rk4_euler_angles %.3g, rkmk4 %.3g, "
      "rk4_quaternion %.3g, variational %.3g\n",
      T, h, e_euler, e_rkmk4, e_quat, e_var);
  EXPECT_GT(e_euler, 1e-4);
  EXPECT_GT(e_euler, 1e3 * e_rkmk4);
  EXPECT_LT(e_rkmk4, 1e-9);
  EXPECT_LT(e_quat, 1e-6);
  EXPECT_LT(e_var, 1e-9);  // a steady rotation is an exact solution of the discrete equations
  // Away from the singularity (spin about z, pitch stays 0) the Euler-angle baseline is fine.
  State y0(m);
  y0.v << 0.0, 0.0, 1.0, 0, 0, 0;
  const Mat3 ex2 = exp_so3(Vec3(0, 0, T));
  EXPECT_LT(log_so3(ex2.transpose() * run(m, "rk4_euler_angles", y0, h, T).base.R).norm(), 1e-9);
}

// chain:2 on a fixed base with joint damping 100 N m s: the damping rate d / I is about 3000/s,
// so explicit Euler's limit is near h = 6e-4; at h = 2e-3 it diverges.
TEST(Stiff, DampingBeyondEulersLimitDivergesTheGuardCatchesItTheAdaptiveMethodKeepsItsTolerance) {
  Model m = make_chain(2, false);
  for (int i = 1; i <= m.n; ++i) m.damping[i] = 100.0;
  State x0(m);
  x0.q << M_PI / 2 + 0.5, 0.3;
  x0.v << 2.0, -1.0;
  const double h = 2e-3, T = 1.0;

  SimConfig cfg;
  cfg.integrator = "euler";
  cfg.dt = h;
  Simulator sim(m, x0, cfg);
  const int taken = sim.step_n(static_cast<int>(T / h));
  EXPECT_LT(taken, static_cast<int>(T / h)) << "explicit Euler should diverge";
  EXPECT_FALSE(sim.failure().empty());
  EXPECT_TRUE(sim.state().finite()) << "the guard rolls back to a good state";
  std::printf("  euler at dt %g: stopped after %d steps: %s\n", h, taken, sim.failure().c_str());

  // Reference: rkmk4 far inside its stability limit.
  const State ref = run(m, "rkmk4", x0, 1e-5, T);
  for (double tol : {1e-4, 1e-6, 1e-8}) {
    StepperOptions opt;
    opt.tol = tol;
    const State x = run(m, "rkmk45", x0, h, T, opt);
    const double e = (x.q - ref.q).norm() + (x.v - ref.v).norm();
    std::printf("  rkmk45 tol %g at dt %g: error %.3g\n", tol, h, e);
    EXPECT_LT(e, 10 * tol) << "rkmk45 keeps its tolerance (tol " << tol << ")";
  }
  SimConfig cv = cfg;
  cv.integrator = "variational";
  cv.dt = 10 * h;
  Simulator simv(m, x0, cv);
  EXPECT_EQ(simv.step_n(static_cast<int>(T / cv.dt)), static_cast<int>(T / cv.dt))
      << simv.failure();
  const double ev = (simv.state().q - ref.q).norm();
  std::printf("  variational at dt %g (damping implicit): q error %.3g\n", cv.dt, ev);
  EXPECT_LT(ev, 1e-2);
}

TEST(AnglePi, LogMapAndStepsThroughPi) {
  const Vec3 axis = Vec3(1, -2, 0.5).normalized();
  for (double a : {M_PI - 1e-3, M_PI - 1e-8, M_PI, M_PI + 1e-8, M_PI + 1e-3}) {
    const Mat3 R = exp_so3(a * axis);
    const Vec3 w = log_so3(R);
    EXPECT_LE(w.norm(), M_PI + 1e-12);
    EXPECT_LT((exp_so3(w) - R).norm(), 1e-12) << "angle " << a;
    // The rotation angle is min(a, 2 pi - a).
    EXPECT_NEAR(w.norm(), std::min(a, 2 * M_PI - a), 1e-9) << "angle " << a;
    Vec6 xi;
    xi << a * axis, 0.3, -0.2, 0.1;
    const SE3 f = exp_se3(xi);
    EXPECT_TRUE(exp_se3(log_se3(f)).isApprox(f, 1e-11)) << "angle " << a;
  }
  // Steady spin about a principal axis, one step turning by 3.1 and by 3.2 rad (through pi):
  // the exact motion, which every Lie-group stepper reproduces.
  const Model m = free_body(Vec3(0.2, 0.3, 0.5));
  for (double turn : {3.1, 3.2}) {
    State x0(m);
    x0.v << 0, 0, turn, 0, 0, 0;
    const Mat3 exact = exp_so3(Vec3(0, 0, turn));
    for (const char* name : {"euler", "semi_implicit_euler", "rkmk4", "rkmk45", "variational"}) {
      const State x = run(m, name, x0, 1.0, 1.0);
      EXPECT_LT(log_so3(exact.transpose() * x.base.R).norm(), 1e-9) << name << " turn " << turn;
    }
  }
  // Tumbling through many half turns (angle of R passing pi again and again): rkmk4 and
  // variational against the closed form, the error measured with the log map.
  const Model ax = free_body(Vec3(0.2, 0.2, 0.5));
  State x0(ax);
  x0.v << 1.0, 0.5, 2.0, 0, 0, 0;
  const double T = 10;
  const Mat3 exact = axisymmetric_attitude(ax, x0, T);
  EXPECT_LT(log_so3(exact.transpose() * run(ax, "rkmk4", x0, 0.01, T).base.R).norm(), 1e-6);
  EXPECT_LT(log_so3(exact.transpose() * run(ax, "variational", x0, 0.01, T).base.R).norm(), 1e-3);
}

// 30-link free chain, link masses growing geometrically from 1e-4 to 1e4 along the chain
// (span 1e8), random states.
TEST(MassRatio, AbaAgainstMassMatrixCholeskyWithMassesSpanning1e8) {
  std::vector<double> masses(31);
  for (int i = 0; i <= 30; ++i) masses[i] = std::pow(1e8, i / 30.0 - 0.5);
  const Model m = make_chain(30, true, masses);
  Data d(m);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(-1, 1);
  double e_aba = 0, e_chol = 0, e_minv = 0;
  for (int t = 0; t < 20; ++t) {
    VecX q(m.n), v(m.nv), tau(m.nv);
    for (int i = 0; i < m.n; ++i) q[i] = M_PI * U(rng);
    for (int i = 0; i < m.nv; ++i) v[i] = U(rng), tau[i] = U(rng);
    const SE3 base(exp_so3(Vec3(U(rng), U(rng), U(rng))), Vec3::Zero());
    const VecX ref = reference::aba_long_double(m, base, q, v, tau).cast<double>();
    e_aba = std::max(e_aba, (aba(m, d, base, q, v, tau) - ref).norm() / ref.norm());
    const VecX rhs = tau - bias(m, d, base, q, v);
    e_chol = std::max(e_chol, (crba(m, d, base, q).llt().solve(rhs) - ref).norm() / ref.norm());
    e_minv = std::max(e_minv, (minv(m, d, base, q) * rhs - ref).norm() / ref.norm());
  }
  std::printf("  max relative error, masses 1e-4..1e4: aba %.2g, crba+cholesky %.2g, minv %.2g\n",
              e_aba, e_chol, e_minv);
  // Measured (charts_data, dyn_mass_ratio.csv): every route loses digits as the span grows, the
  // mass matrix + Cholesky route the most (about 1e-4 at span 1e8, against 1e-6 for ABA and
  // 1e-5 for D^-1): ABA wins by more than an order of magnitude.
  EXPECT_LT(e_aba, 1e-5);
  EXPECT_GT(e_chol, 20 * e_aba);
  EXPECT_GT(e_chol, 1e-7);
  // Unit masses: all three agree to near machine precision.
  const Model u = make_chain(30, true);
  Data du(u);
  VecX q = VecX::Constant(u.n, 0.4), v = VecX::Constant(u.nv, 0.3), tau = VecX::Constant(u.nv, 0.2);
  const VecX ref = reference::aba_long_double(u, SE3(), q, v, tau).cast<double>();
  EXPECT_LT((aba(u, du, SE3(), q, v, tau) - ref).norm() / ref.norm(), 1e-12);
  EXPECT_LT(
      (crba(u, du, SE3(), q).llt().solve(tau - bias(u, du, SE3(), q, v)) - ref).norm() / ref.norm(),
      1e-10);
}

// The variational stepper conserves the spatial momentum of a free chain (zero gravity)
// exactly, up to its solver tolerance, over a long run (rates reach ~20 rad/s on the light links).
TEST(Variational, ConservesMomentumAndKeepsEnergyBounded) {
  Model m = make_chain(5, true);
  m.gravity.setZero();
  const State x0 = random_state(m, 4);
  Data d(m);
  const Vec6 h0 = spatial_momentum(m, d, x0.base, x0.q, x0.v);
  const double E0 = energy(m, d, x0);
  auto st = make_stepper("variational", m);
  State x = x0;
  const VecX zero = VecX::Zero(m.nv);
  double emax = 0;
  for (int k = 0; k < 10000; ++k) {
    const StepInfo info = st->step(x, zero, 0.005);
    ASSERT_TRUE(info.ok) << "step " << k << ": " << info.reason << " |v| " << x.v.norm();
    emax = std::max(emax, std::abs(energy(m, d, x) - E0) / E0);
  }
  EXPECT_LT((spatial_momentum(m, d, x.base, x.q, x.v) - h0).norm() / h0.norm(), 1e-8);
  EXPECT_LT(emax, 0.2);  // measured 0.083: O(h^2) at h |w|max ~ 0.13, bounded (no drift)
  std::printf(
      "  variational, free 5-chain, 50 s at dt 0.005: momentum drift %.2g, max energy "
      "error %.2g\n",
      (spatial_momentum(m, d, x.base, x.q, x.v) - h0).norm() / h0.norm(), emax);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}

// The energy balance (issue 16): with joint damping, friction and a command the energy changes
// by the work W done on the system; the Simulator accumulates W (Simulator::work), and
// E(t) - E(0) - W(t) is what the integrator itself drifts. Double pendulum with damping 0.02 and
// friction 0.01 (regularized over 0.1 rad/s) on both joints, a constant torque on the first,
// from 0.5 / -0.3 rad with rates, dt = 1 ms for 5 s.
TEST(EnergyBalance, WorkOfDampingFrictionAndCommandsLeavesOnlyTheIntegratorsDrift) {
  const Scene scene = load_scene(se3_sim_test::source_dir() + "/config/scenes/pendulum.yaml");
  Model m = scene_model(scene);
  for (int i = 1; i <= m.n; ++i) m.damping[i] = 0.02, m.friction[i] = 0.01;
  State x0 = scene_state(scene, m);
  x0.v << 2.0, -1.0;
  for (const std::string name : {"rkmk4", "symplectic_euler"}) {
    SimConfig cfg;
    cfg.integrator = name;
    cfg.dt = 1e-3;
    cfg.stepper.friction_eps = 0.1;
    Simulator sim(m, x0, cfg);
    sim.set_joint_effort(1, 0.05);
    const double T0 = sim.initial_kinetic_energy();
    double drift = 0, balance = 0;
    for (int k = 0; k < 5000; ++k) {
      ASSERT_TRUE(sim.step()) << sim.failure();
      const double dE = sim.kinetic_energy() + sim.potential_energy() - T0;
      drift = std::max(drift, std::abs(dE) / T0);
      balance = std::max(balance, std::abs(dE - sim.work()) / T0);
    }
    std::printf(
        "  %-16s T0 = %.3g J: max |E - E0| / T0 = %.3g, max |E - E0 - W| / T0 = %.3g, W = %.4g J\n",
        name.c_str(), T0, drift, balance, sim.work());
    EXPECT_GT(drift, 10) << "damping and the command change the energy by much more than T0";
    EXPECT_LT(sim.work(), -0.5) << "damping and friction remove more than the command adds";
    // Against the energy exchanged |W|: rkmk4's own drift is ~1e-12 here, what is left is the
    // trapezoidal rule's O(dt^2) on W (1.3e-6 |W|); semi-implicit Euler's O(dt) energy error
    // is in its figure (2.8e-3 |W|).
    EXPECT_LT(balance * T0, (name == "rkmk4" ? 1e-5 : 1e-2) * std::abs(sim.work()));
    EXPECT_LT(balance, 1e-2 * drift);
    sim.reset();
    EXPECT_EQ(sim.work(), 0.0);
  }
  // The headless run reports both figures.
  SimulateOptions o;
  o.scene = se3_sim_test::source_dir() + "/config/scenes/pendulum.yaml";
  o.duration = 2.0;
  const SimulateResult r = simulate_headless(o);
  EXPECT_GT(r.energy_drift_rel, 1e-3) << "the URDF's damping removes energy";
  EXPECT_LT(r.energy_balance_rel, 1e-5);  // 3.2e-6: the trapezoidal rule's O(dt^2)
  EXPECT_NE(simulate_result_json(r).find("\"energy_balance_rel\": "), std::string::npos);
}
