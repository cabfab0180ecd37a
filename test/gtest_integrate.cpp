// Time steppers against closed-form solutions and conservation laws: a pendulum in the
// small-angle regime, a torque-free axisymmetric rigid body (Euler's equations), momentum and
// centre of mass of a free-floating chain under internal torques, orders of convergence,
// the divergence guard, damping and friction, effort limits.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "se3_sim/integrate/integrate.h"
#include "se3_sim/sim/sim.h"
#include "source_paths.h"

using namespace se3;

namespace {

double rot_err(const Mat3& A, const Mat3& B) {
  return log_so3(A.transpose() * B).norm();
}

/// Distance between two states: base pose (rotation angle + position), q and v.
double state_err(const State& a, const State& b) {
  double e = rot_err(a.base.R, b.base.R) + (a.base.p - b.base.p).norm();
  e += (a.q - b.q).norm() + (a.v - b.v).norm();
  return e;
}

State run(const Model& m, const std::string& integrator, const State& x0, double h, double T,
          const VecX* tau = nullptr, const StepperOptions& opt = {}) {
  auto st = make_stepper(integrator, m, opt);
  State x = x0;
  const VecX zero = VecX::Zero(m.nv);
  const int n = static_cast<int>(std::llround(T / h));
  for (int k = 0; k < n; ++k) {
    const StepInfo info = st->step(x, tau ? *tau : zero, h);
    EXPECT_TRUE(info.ok) << info.reason;
  }
  return x;
}

/// A free rigid body whose frame sits at its centre of mass with principal axes.
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

}  // namespace

TEST(Stepper, RegistryKnowsTheBuiltInsAndRejectsUnknownNames) {
  // Every built-in is in the one registry without any registration call by the program.
  const auto names = stepper_names();
  const Model m = make_chain(2, true);
  for (const char* n : {"euler", "semi_implicit_euler", "rkmk4", "rkmk45", "variational",
                        "rk4_euler_angles", "rk4_quaternion"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), n), names.end()) << n;
    EXPECT_FALSE(stepper_description(n).empty());
    EXPECT_EQ(stepper_canonical_name(n), n);
    EXPECT_EQ(make_stepper(n, m)->name(), n);
  }
  // symplectic_euler, the former name, is an alias: accepted, listed as an alias, and the
  // stepper it makes is semi_implicit_euler.
  EXPECT_NE(std::find(names.begin(), names.end(), "symplectic_euler"), names.end());
  EXPECT_EQ(stepper_canonical_name("symplectic_euler"), "semi_implicit_euler");
  EXPECT_EQ(stepper_description("symplectic_euler"), "alias of semi_implicit_euler");
  EXPECT_EQ(make_stepper("symplectic_euler", m)->name(), "semi_implicit_euler");
  EXPECT_EQ(stepper_canonical_name("nope"), "");
  const std::string help = stepper_help();
  std::printf("%s", help.c_str());
  EXPECT_NE(help.find("  semi_implicit_euler "), std::string::npos);
  EXPECT_NE(help.find("[alias: symplectic_euler]"), std::string::npos);
  EXPECT_EQ(help.find("  symplectic_euler "), std::string::npos);  // not a line of its own
  for (const auto& n : names) {
    if (stepper_canonical_name(n) == n) {
      EXPECT_NE(help.find("  " + n + " "), std::string::npos);
    }
  }
  EXPECT_THROW(register_stepper_alias("x", "nope"), std::invalid_argument);
  EXPECT_THROW(make_stepper("rk_nonsense", m), std::invalid_argument);
  EXPECT_EQ(make_stepper("rkmk45", m)->adaptive(), true);
  EXPECT_EQ(make_stepper("rkmk4", m)->order(), 4);
  // A registered stepper is found by name.
  register_stepper("rkmk4_copy", "test entry", [](const Model& mm, const StepperOptions& o) {
    return make_rkmk_stepper(tableau_rk4(), mm, o);
  });
  EXPECT_EQ(make_stepper("rkmk4_copy", m)->order(), 4);
}

// chain:1 on a fixed base: one slender box of length L hanging on a joint along world y
// (make_chain turns the first axis by -90 deg about x). It hangs straight down at q = pi/2;
// small oscillations theta(t) = theta0 cos(w t), w^2 = m g c / I_pivot.
TEST(Pendulum, MatchesTheSmallAngleSolution) {
  Model m = make_chain(1, false);
  const Vec3 axis_world = m.X_tree[1].R.col(2);
  ASSERT_NEAR(std::abs(axis_world.y()), 1.0, 1e-12);
  const double mass = m.inertia[1].m, c = m.inertia[1].com().x(), I = m.inertia[1].I(2, 2);
  const double g = 9.81;
  const double w = std::sqrt(mass * g * c / I);
  const double theta0 = 1e-3;
  // Find the hanging angle from the model itself: the com straight below the pivot.
  Data d(m);
  State x(m);
  x.q[0] = M_PI / 2;
  const double z_plus = center_of_mass(m, d, x.base, x.q).z();
  const double q_hang = z_plus < 0 ? M_PI / 2 : -M_PI / 2;
  x.q[0] = q_hang;
  const Vec3 com = center_of_mass(m, d, x.base, x.q);
  ASSERT_NEAR(com.x(), m.X_tree[1].p.x(), 1e-12);
  ASSERT_LT(com.z(), -0.1);
  for (const char* integ : {"rkmk4", "rkmk45"}) {
    StepperOptions opt;
    opt.tol = 1e-10;
    auto st = make_stepper(integ, m, opt);
    State y = x;
    y.q[0] = q_hang + theta0;
    const VecX tau = VecX::Zero(m.nv);
    const double h = 1e-3;
    double max_err = 0;
    for (int k = 1; k <= 3000; ++k) {
      ASSERT_TRUE(st->step(y, tau, h).ok);
      const double t = k * h;
      max_err = std::max(max_err, std::abs((y.q[0] - q_hang) - theta0 * std::cos(w * t)));
    }
    // Nonlinearity shifts the frequency by theta0^2/16 (relative): ~1e-6 theta0 over 3 s.
    EXPECT_LT(max_err, 2e-5 * theta0) << integ;
    // And the error is not trivially small: the pendulum really swung by about theta0.
    EXPECT_NEAR(std::abs(y.q[0] - q_hang), std::abs(theta0 * std::cos(w * 3.0)), 1e-7);
  }
}

// Torque-free axisymmetric body (I1 about e1, I2 = I3 = Ip): body rates precess,
// omega_23(t) = omega_23(0) e^{i Omega t} with Omega = (I1 - Ip) / Ip * omega_1, and
// R(t) = exp(t hat(L_w) / Ip) R0 exp(-t Omega hat(e1)).
TEST(FreeBody, FollowsEulersEquationsTorqueFree) {
  const double I1 = 0.3, Ip = 1.0;
  const Model m = free_body(Vec3(I1, Ip, Ip));
  State x0(m);
  x0.base = SE3(exp_so3(Vec3(0.2, -0.4, 0.1)), Vec3(1, 2, 3));
  const Vec3 w0(2.0, 0.5, -0.3), v0(0.1, -0.2, 0.3);
  x0.v << w0, v0;
  const double T = 5.0;
  const double Om = (I1 - Ip) / Ip * w0.x();
  const Vec3 Lw = x0.base.R * Vec3(I1 * w0.x(), Ip * w0.y(), Ip * w0.z());
  const Mat3 R_exact = exp_so3(T * Lw / Ip) * x0.base.R * exp_so3(Vec3(-T * Om, 0, 0));
  const Vec3 w_exact(w0.x(), w0.y() * std::cos(Om * T) - w0.z() * std::sin(Om * T),
                     w0.y() * std::sin(Om * T) + w0.z() * std::cos(Om * T));
  const Vec3 p_exact = x0.base.p + T * (x0.base.R * v0);
  struct Case {
    const char* name;
    double h, tol;
  };
  for (const Case& c : {Case{"rkmk4", 1e-3, 1e-9}, Case{"rkmk45", 1e-2, 1e-8},
                        Case{"semi_implicit_euler", 1e-4, 3e-2}}) {
    StepperOptions opt;
    opt.tol = 1e-11;
    const State x = run(m, c.name, x0, c.h, T, nullptr, opt);
    EXPECT_LT(rot_err(x.base.R, R_exact), c.tol) << c.name;
    EXPECT_LT((x.v.head<3>() - w_exact).norm(), c.tol) << c.name;
    EXPECT_LT((x.base.p - p_exact).norm(), c.tol) << c.name;
    // The body frame sits at the centre of mass: its linear velocity is R^T (R0 v0).
    EXPECT_LT((x.v.tail<3>() - x.base.R.transpose() * (x0.base.R * v0)).norm(), c.tol) << c.name;
  }
}

// A free-floating chain in zero gravity driven by internal joint torques only: the total
// spatial momentum stays what it was and the centre of mass drifts only with the initial
// linear momentum.
TEST(FreeChain, InternalTorquesKeepMomentumAndCentreOfMass) {
  Model m = make_chain(6, true, {2.0, 1.0, 0.5});
  m.gravity.setZero();
  Data d(m);
  VecX tau = VecX::Zero(m.nv);
  // Torques of a size that moves the joints by radians within the 2 s.
  for (int i = 0; i < m.n; ++i) tau[6 + i] = (i % 2 ? -0.01 : 0.015);
  for (const bool moving : {false, true}) {
    State x0 = moving ? random_state(m, 7) : State(m);
    if (!moving) x0.q.setConstant(0.3);
    const Vec6 h0 = spatial_momentum(m, d, x0.base, x0.q, x0.v);
    const Vec3 c0 = center_of_mass(m, d, x0.base, x0.q);
    const double mass = m.total_mass();
    auto st = make_stepper("rkmk4", m);
    State x = x0;
    const double h = 5e-4;
    double dh = 0, dc = 0;
    double travelled = 0;  // how far the chain's joints moved: the test is not vacuous
    for (int k = 1; k <= 4000; ++k) {
      ASSERT_TRUE(st->step(x, tau, h).ok);
      const Vec6 hk = spatial_momentum(m, d, x.base, x.q, x.v);
      const Vec3 ck = center_of_mass(m, d, x.base, x.q);
      dh = std::max(dh, (hk - h0).norm());
      dc = std::max(dc, (ck - (c0 + k * h * h0.tail<3>() / mass)).norm());
      travelled = std::max(travelled, (x.q - x0.q).cwiseAbs().maxCoeff());
    }
    EXPECT_GT(travelled, 0.5);
    EXPECT_LT(dh, 1e-9 * std::max(1.0, h0.norm())) << "moving " << moving;
    EXPECT_LT(dc, 1e-9) << "moving " << moving;
  }
}

namespace {

/// Error at T of an integrator with step h against a fine RKMK4 reference.
double global_error(const Model& m, const State& x0, const std::string& name, double h, double T,
                    const State& ref) {
  return state_err(run(m, name, x0, h, T), ref);
}

}  // namespace

TEST(Convergence, Rkmk4IsFourthOrderAndSymplecticEulerFirstOrder) {
  Model m = make_chain(3, true, {3.0, 1.0});
  m.gravity.setZero();
  const State x0 = random_state(m, 3);
  const double T = 1.0;
  const State ref = run(m, "rkmk4", x0, 1.0 / 2560, T);
  const double e1 = global_error(m, x0, "rkmk4", 1.0 / 40, T, ref);
  const double e2 = global_error(m, x0, "rkmk4", 1.0 / 80, T, ref);
  const double e3 = global_error(m, x0, "rkmk4", 1.0 / 160, T, ref);
  EXPECT_GT(e1, 1e-9);  // well above the reference's own error
  EXPECT_NEAR(e1 / e2, 16.0, 3.0) << e1 << " " << e2;
  EXPECT_NEAR(e2 / e3, 16.0, 2.0) << e2 << " " << e3;
  for (const char* first : {"semi_implicit_euler", "euler"}) {
    const double s1 = global_error(m, x0, first, 1.0 / 400, T, ref);
    const double s2 = global_error(m, x0, first, 1.0 / 800, T, ref);
    const double s3 = global_error(m, x0, first, 1.0 / 1600, T, ref);
    EXPECT_NEAR(s1 / s2, 2.0, 0.25) << first;
    EXPECT_NEAR(s2 / s3, 2.0, 0.15) << first;
  }
}

// rkmk4's step (each stage's slope fed into the running sum and the next stage point at once)
// against RKMK4 written out here stage by stage: the same numbers up to rounding, on a fixed base
// (plain RK4 on q and v) and on a free base (with dexp_inv by its series, as RKMK4 uses it), with
// damping and friction in play.
TEST(Rkmk4, StepEqualsRkmk4WrittenOutStageByStage) {
  for (const bool floating : {false, true}) {
    Model m = make_chain(5, floating, {2.0, 1.0, 0.5});
    for (int i = 1; i <= m.n; ++i) {
      m.damping[i] = 0.1 * i;
      m.friction[i] = i % 2 ? 0.05 : 0.0;
    }
    const State x0 = random_state(m, 11);
    VecX tau = VecX::Zero(m.nv);
    for (int k = 0; k < m.nv; ++k) tau[k] = 0.1 * std::sin(k + 1.0);
    const double h = 0.01;
    auto st = make_stepper("rkmk4", m);
    State x = x0;
    ASSERT_TRUE(st->step(x, tau, h).ok);

    // By hand: stage points, slopes, then the b-weighted sum.
    auto probe = make_stepper("rkmk4", m);  // only for its acceleration() (ABA + passive forces)
    const int n = m.n;
    const double c[4] = {0, 0.5, 0.5, 1}, b[4] = {1.0 / 6, 1.0 / 3, 1.0 / 3, 1.0 / 6};
    VecX kv[4], kq[4];
    Vec6 kxi[4], xi = Vec6::Zero();
    VecX q = x0.q, v = x0.v;
    for (int i = 0; i < 4; ++i) {
      if (i > 0) {
        q = x0.q + c[i] * h * kq[i - 1];
        v = x0.v + c[i] * h * kv[i - 1];
        xi = c[i] * h * kxi[i - 1];
      }
      const SE3 f = floating ? x0.base * exp_se3(xi) : x0.base;
      kv[i] = probe->acceleration(f, q, v, tau);
      kq[i] = v.tail(n);
      if (floating) kxi[i] = dexp_inv_se3_times_series(-xi, v.head<6>());
    }
    VecX q1 = x0.q, v1 = x0.v;
    Vec6 xi1 = Vec6::Zero();
    for (int i = 0; i < 4; ++i) {
      q1 += h * b[i] * kq[i];
      v1 += h * b[i] * kv[i];
      if (floating) xi1 += h * b[i] * kxi[i];
    }
    const SE3 f1 = x0.base * exp_se3(xi1);
    EXPECT_LE((x.q - q1).cwiseAbs().maxCoeff(), 1e-14) << floating;
    EXPECT_LE((x.v - v1).cwiseAbs().maxCoeff(), 1e-13) << floating;
    EXPECT_LE((x.base.R - f1.R).cwiseAbs().maxCoeff(), 1e-15) << floating;
    EXPECT_LE((x.base.p - f1.p).cwiseAbs().maxCoeff(), 1e-15) << floating;
    // Not vacuous: the step moved everything it integrates.
    EXPECT_GT((x.v - x0.v).norm(), 1e-3);
    if (floating) {
      EXPECT_GT(xi1.norm(), 1e-3);
    }
  }
}

// Classical RK4 runs through its one-pass fast path (step_chain) by default and through the
// general tableau path on request: both read the same tableau, and give the same steps to
// rounding (fixed and free base, gravity, damping and friction, commands).
TEST(Rkmk4, FastPathAndGeneralPathRunTheSameTableau) {
  for (const bool floating : {false, true}) {
    Model m = make_chain(6, floating, {2.0, 1.0, 0.5});
    for (int i = 1; i <= m.n; ++i) {
      m.damping[i] = 0.1 * i;
      m.friction[i] = i % 2 ? 0.05 : 0.0;
    }
    State fast = random_state(m, 12), general = fast;
    VecX tau = VecX::Zero(m.nv);
    for (int k = 0; k < m.nv; ++k) tau[k] = 0.2 * std::cos(k + 1.0);
    ButcherTableau t = tableau_rk4();
    auto a = make_rkmk_stepper(t, m, {});
    t.fast_path = false;
    auto b = make_rkmk_stepper(t, m, {});
    for (int k = 0; k < 200; ++k) {
      ASSERT_TRUE(a->step(fast, tau, 0.005).ok);
      ASSERT_TRUE(b->step(general, tau, 0.005).ok);
    }
    EXPECT_GT(state_err(fast, random_state(m, 12)), 0.1);  // it moved
    EXPECT_LE(state_err(fast, general), 1e-13) << floating;
  }
}

// A tableau whose stages read more than the previous stage (Kutta's 3/8 rule) takes the general
// RKMK path; it too is fourth order on a free-floating chain.
TEST(Convergence, ThreeEighthsRuleThroughTheGeneralTableauPathIsFourthOrder) {
  Model m = make_chain(3, true, {3.0, 1.0});
  m.gravity.setZero();
  const State x0 = random_state(m, 3);
  ButcherTableau t;
  t.name = "rkmk38";
  t.order = 4;
  t.a = {{}, {1.0 / 3}, {-1.0 / 3, 1.0}, {1.0, -1.0, 1.0}};
  t.b = {1.0 / 8, 3.0 / 8, 3.0 / 8, 1.0 / 8};
  const auto run38 = [&](double h) {
    auto st = make_rkmk_stepper(t, m, {});
    State x = x0;
    for (int k = 0; k < static_cast<int>(std::llround(1.0 / h)); ++k) {
      EXPECT_TRUE(st->step(x, VecX::Zero(m.nv), h).ok);
    }
    return x;
  };
  const State ref = run(m, "rkmk4", x0, 1.0 / 2560, 1.0);
  const double e1 = state_err(run38(1.0 / 40), ref);
  const double e2 = state_err(run38(1.0 / 80), ref);
  const double e3 = state_err(run38(1.0 / 160), ref);
  EXPECT_GT(e1, 1e-9);
  EXPECT_NEAR(e1 / e2, 16.0, 3.0) << e1 << " " << e2;
  EXPECT_NEAR(e2 / e3, 16.0, 2.0) << e2 << " " << e3;
}

TEST(Convergence, Rkmk45MeetsItsToleranceAndRejectsSteps) {
  Model m = make_chain(4, true);
  m.gravity.setZero();
  const State x0 = random_state(m, 5);
  const double T = 1.0;
  const State ref = run(m, "rkmk4", x0, 1.0 / 4000, T);
  double prev = 1;
  for (double tol : {1e-5, 1e-7, 1e-9}) {
    StepperOptions opt;
    opt.tol = tol;
    auto st = make_stepper("rkmk45", m, opt);
    State x = x0;
    const VecX zero = VecX::Zero(m.nv);
    StepInfo one = st->step(x, zero, T);  // one big step covered by internal steps
    ASSERT_TRUE(one.ok) << one.reason;
    EXPECT_GT(one.substeps, 1);
    const double e = state_err(x, ref);
    EXPECT_LT(e, 200 * tol) << tol;
    EXPECT_LT(e, prev);
    prev = e;
  }
  // Asked for a step far too long, it must reject at least once.
  StepperOptions opt;
  opt.tol = 1e-9;
  auto st = make_stepper("rkmk45", m, opt);
  State x = x0;
  const StepInfo info = st->step(x, VecX::Zero(m.nv), 0.5);
  EXPECT_TRUE(info.ok);
  EXPECT_GT(info.rejected, 0);
}

TEST(State, FiniteMeansEveryNumberFiniteAndTheRotationOrthonormal) {
  const Model m = make_chain(3, true);
  const State good = random_state(m, 7);
  State x = good;
  x.base.R = exp_so3(Vec3(0.3, -1.2, 2.0));
  EXPECT_TRUE(x.finite());
  x.base.R(0, 1) += 1e-9;  // orthonormal to 1e-6
  EXPECT_TRUE(x.finite());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (double bad : {nan, inf, -inf}) {
    x = good;
    x.q[2] = bad;
    EXPECT_FALSE(x.finite()) << "q " << bad;
    x = good;
    x.v[8] = bad;
    EXPECT_FALSE(x.finite()) << "v " << bad;
    x = good;
    x.base.p[1] = bad;
    EXPECT_FALSE(x.finite()) << "p " << bad;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) {
        x = good;
        x.base.R(r, c) = bad;
        EXPECT_FALSE(x.finite()) << "R(" << r << ", " << c << ") " << bad;
      }
    }
  }
  x = good;
  x.base.R *= 1 + 1e-5;  // not orthonormal
  EXPECT_FALSE(x.finite());
  x = good;
  x.base.R(2, 0) += 1e-5;
  EXPECT_FALSE(x.finite());
  x = good;
  x.q.setConstant(1e300);  // large but finite
  EXPECT_TRUE(x.finite());
}

TEST(Guard, DivergenceRollsBackAndReports) {
  Model m = make_chain(8, true);
  m.gravity.setZero();
  const State x0 = random_state(m, 11);
  SimConfig cfg;
  cfg.integrator = "euler";
  cfg.dt = 0.5;  // far beyond stability for explicit Euler
  Simulator sim(m, x0, cfg);
  int ok_steps = 0;
  State before = sim.state();
  bool failed = false;
  for (int k = 0; k < 2000; ++k) {
    before = sim.state();
    if (!sim.step()) {
      failed = true;
      break;
    }
    ++ok_steps;
  }
  ASSERT_TRUE(failed);
  EXPECT_FALSE(sim.failure().empty());
  EXPECT_NE(sim.failure().find("diverged"), std::string::npos) << sim.failure();
  EXPECT_TRUE(sim.state().finite());
  EXPECT_LE(sim.state().v.cwiseAbs().maxCoeff(), cfg.guard.max_rate);
  // Rolled back to the last good state: the one before the failing step (or, for the energy
  // check, the last checked one a few steps earlier); time and step count agree with it.
  EXPECT_LE(sim.steps(), static_cast<std::uint64_t>(ok_steps));
  EXPECT_NEAR(sim.time(), sim.steps() * cfg.dt, 1e-9);
  if (sim.steps() == static_cast<std::uint64_t>(ok_steps)) {
    EXPECT_EQ(state_err(sim.state(), before), 0.0);
  }
  EXPECT_FALSE(sim.step());  // stays stopped until reset
  sim.reset();
  EXPECT_TRUE(sim.failure().empty());
  EXPECT_EQ(sim.time(), 0.0);
  EXPECT_EQ(state_err(sim.state(), x0), 0.0);
}

// The energy check runs every energy_check_every steps; a failed one rolls back to the state
// of the last check (the states since were never checked), with its time and step count.
TEST(Guard, EnergyAboveTheLimitRollsBackToTheLastCheckedState) {
  Model m = make_chain(3, true);
  m.gravity.setZero();
  const State x0 = random_state(m, 5);
  SimConfig cfg;
  cfg.integrator = "rkmk4";
  cfg.guard.energy_check_every = 4;
  Simulator probe(m, x0, cfg);
  const double T0 = probe.initial_kinetic_energy();
  const double E_ref = std::max(T0, 0.5 * m.total_mass());  // zero gravity (sim.h)
  cfg.guard.energy_growth = 1.1 * T0 / E_ref;               // limit: T0 + 10 %
  Simulator sim(m, x0, cfg);
  sim.set_joint_effort(1, 2.0);  // pumps energy in
  std::vector<State> states = {sim.state()};
  while (sim.step()) states.push_back(sim.state());
  const std::uint64_t failed_at = states.size();  // the step that failed the check
  ASSERT_GT(failed_at, 8u);                       // a check passed before
  ASSERT_LT(failed_at, 1000u);
  EXPECT_EQ(failed_at % 4, 0u) << "only check steps test the energy";
  EXPECT_NE(sim.failure().find("kinetic energy"), std::string::npos) << sim.failure();
  EXPECT_EQ(sim.steps(), failed_at - 4);
  EXPECT_NEAR(sim.time(), (failed_at - 4) * cfg.dt, 1e-12);
  EXPECT_EQ(state_err(sim.state(), states[failed_at - 4]), 0.0);
  EXPECT_LE(sim.kinetic_energy(), 1.1 * T0);
  // Below the limit all the way: a torque-free run at a limit 10 % above its (kept) energy.
  Simulator free(m, x0, cfg);
  EXPECT_EQ(free.step_n(400), 400) << free.failure();
}

TEST(Guard, StiffDampingWithExplicitEulerIsCaught) {
  Model m = make_chain(2, false);
  m.damping[2] = 1e3;  // time constant I/d ~ 1e-5 s
  State x0(m);
  x0.v[1] = 1.0;
  SimConfig cfg;
  cfg.integrator = "euler";
  cfg.dt = 1e-2;
  Simulator sim(m, x0, cfg);
  State last(m);
  bool failed = false;
  for (int k = 0; k < 500 && !failed; ++k) {
    last = sim.state();
    failed = !sim.step();
  }
  ASSERT_TRUE(failed);
  EXPECT_TRUE(sim.state().finite());
  EXPECT_TRUE(sim.state().v.allFinite());
  // The same system is stable with a step below the damping time scale.
  cfg.dt = 1e-6;
  Simulator fine(m, x0, cfg);
  EXPECT_EQ(fine.step_n(200), 200) << fine.failure();
}

TEST(Passive, DampingAndFrictionDissipateEnergy) {
  Model m = make_chain(3, false);
  m.gravity = Vec3(0, 0, -9.81);
  State x0(m);
  x0.q << 0.4, -0.3, 0.8;
  x0.v << 1.0, -0.5, 0.7;
  for (int variant = 0; variant < 3; ++variant) {
    Model mv = m;
    for (int i = 1; i <= mv.n; ++i) {
      mv.damping[i] = variant == 1 ? 0.05 : 0.0;
      mv.friction[i] = variant == 2 ? 0.05 : 0.0;
    }
    SimConfig cfg;
    cfg.dt = 1e-3;
    Simulator sim(mv, x0, cfg);
    const double E0 = sim.kinetic_energy() + sim.potential_energy();
    double prev = E0, max_rise = 0;
    for (int k = 0; k < 3000; ++k) {
      ASSERT_TRUE(sim.step()) << sim.failure();
      const double E = sim.kinetic_energy() + sim.potential_energy();
      max_rise = std::max(max_rise, E - prev);
      prev = E;
    }
    if (variant == 0) {
      EXPECT_NEAR(prev, E0, 1e-6 * std::abs(E0) + 1e-8) << "no damping: energy kept";
    } else {
      EXPECT_LT(prev, E0 - 0.02 * std::abs(E0)) << "variant " << variant;
      EXPECT_LT(max_rise, 1e-9) << "energy never rises, variant " << variant;
    }
  }
}

// The passive forces a stepper applies: damping -d qdot and friction -f tanh(qdot / eps) on
// exactly the joints that have them, nothing on the base, nothing when switched off; and the
// acceleration is ABA's under command plus passive forces.
TEST(Passive, ForcesActOnTheDampedAndRubbingJointsOnly) {
  Model m = make_chain(4, true);
  m.damping[1] = 0.5;   // damping only
  m.friction[2] = 0.3;  // friction only
  m.damping[3] = 0.2;   // both
  m.friction[3] = 0.7;  // joint 4: neither
  const State x = random_state(m, 21);
  VecX tau = VecX::Zero(m.nv);
  for (int k = 0; k < m.nv; ++k) tau[k] = 0.1 * (k + 1);
  StepperOptions opt;
  opt.friction_eps = 0.05;
  auto st = make_stepper("semi_implicit_euler", m, opt);
  VecX expected = VecX::Zero(m.nv);
  for (int i = 1; i <= m.n; ++i) {
    const double qd = x.v[5 + i];
    expected[5 + i] = -(m.damping[i] * qd + m.friction[i] * std::tanh(qd / opt.friction_eps));
  }
  VecX passive(m.nv);
  st->passive_forces(x.v, passive);
  EXPECT_LE((passive - expected).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(passive.head<6>().norm(), 0.0);
  EXPECT_EQ(passive[5 + 4], 0.0);  // joint 4
  EXPECT_NE(passive[5 + 1], 0.0);
  EXPECT_NE(passive[5 + 2], 0.0);
  EXPECT_NE(passive[5 + 3], 0.0);
  Data d(m);
  const VecX total = tau + passive;
  const VecX a_ref = aba(m, d, x.base, x.q, x.v, total);
  EXPECT_LE((st->acceleration(x.base, x.q, x.v, tau) - a_ref).cwiseAbs().maxCoeff(), 1e-12);
  // Switched off: no passive force, the plain ABA acceleration.
  opt.passive_forces = false;
  auto off = make_stepper("semi_implicit_euler", m, opt);
  off->passive_forces(x.v, passive);
  EXPECT_EQ(passive.norm(), 0.0);
  EXPECT_EQ(off->acceleration(x.base, x.q, x.v, tau), aba(m, d, x.base, x.q, x.v, tau));
}

TEST(Effort, CommandsAreClampedToTheUrdfLimits) {
  const std::string panda = se3_sim_test::source_dir() + "/data/robots/panda.urdf";
  UrdfOptions o;
  o.locked = {{"panda_finger_joint1", 0.02}, {"panda_finger_joint2", 0.02}};
  Model m = model_from_urdf_file(panda, o);
  ASSERT_EQ(m.n, 7);
  SimConfig cfg;
  Simulator sim(m, State(m), cfg);
  const int j1 = m.joint_index("panda_joint1"), j7 = m.joint_index("panda_joint7");
  EXPECT_DOUBLE_EQ(sim.set_joint_effort(j1, 1000.0), 87.0);
  EXPECT_DOUBLE_EQ(sim.set_joint_effort(j7, -50.0), -12.0);
  EXPECT_DOUBLE_EQ(sim.set_joint_effort(j7, 5.0), 5.0);
  EXPECT_DOUBLE_EQ(sim.command()[j1 - 1], 87.0);
  // The acceleration is that of the clamped torque, not of the requested one.
  Model m2 = m;
  Simulator clamped(m, State(m), cfg);
  clamped.set_joint_effort(j1, 1000.0);
  Simulator exact(m2, State(m2), cfg);
  exact.set_joint_effort(j1, 87.0);
  clamped.step();
  exact.step();
  EXPECT_EQ((clamped.state().v - exact.state().v).norm(), 0.0);
  EXPECT_GT(clamped.state().v[j1 - 1], 0.0);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
