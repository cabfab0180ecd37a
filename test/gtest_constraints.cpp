// Constraints and contact (constraints.h): Jacobians and bias terms against finite differences,
// loop closure and energy of the four-bar over 100 s, the pinned chain, the sign of the
// multipliers, redundant constraints, joint limits under large torques, a box on a slope
// (sticking and sliding at g (sin a - mu cos a)) and a quadruped dropped on the ground.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <new>
#include <random>
#include <string>

#include "se3_sim/sim/sim.h"
#include "se3_sim/solver/constraints.h"
#include "source_paths.h"

using namespace se3;

namespace {

const std::string kRoot = se3_sim_test::source_dir();

std::string path(const std::string& rel) {
  return kRoot + "/" + rel;
}

// A free box of full extents (a, b, c) and mass m, its frame at the centre of mass, with
// collision box (for contact points from the collision geometry).
std::string box_urdf(double a, double b, double c, double m) {
  char buf[1024];
  std::snprintf(buf, sizeof buf,
                "<robot name=\"box\"><link name=\"box\"><inertial><origin xyz=\"0 0 0\"/>"
                "<mass value=\"%g\"/><inertia ixx=\"%g\" ixy=\"0\" ixz=\"0\" iyy=\"%g\" iyz=\"0\" "
                "izz=\"%g\"/></inertial><collision><geometry><box size=\"%g %g %g\"/></geometry>"
                "</collision></link></robot>",
                m, m * (b * b + c * c) / 12, m * (a * a + c * c) / 12, m * (a * a + b * b) / 12, a,
                b, c);
  return buf;
}

// Moves x by eps along the generalized direction d (base: f exp(eps d_0)).
State moved(const Model& m, const State& x, const VecX& d, double eps) {
  State y = x;
  if (m.floating) y.base = x.base * exp_se3(eps * Vec6(d.head<6>()));
  y.q += eps * d.tail(m.n);
  return y;
}

State random_state_near(const Model& m, const State& x0, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  State x = x0;
  for (int k = 0; k < m.n; ++k) x.q[k] += 0.3 * u(rng);
  for (int k = 0; k < m.nv; ++k) x.v[k] = u(rng);
  if (m.floating) {
    Vec6 xi;
    for (int k = 0; k < 6; ++k) xi[k] = 0.3 * u(rng);
    x.base = x.base * exp_se3(xi);
  }
  return x;
}

void check_derivatives(const std::string& scene_file) {
  const Scene sc = load_scene(path(scene_file));
  const Model m = scene_model(sc);
  ConstraintSystem cs(m, sc.constraints);
  const State x0 = scene_state(sc, m);
  cs.anchor(x0);
  for (unsigned seed = 1; seed <= 3; ++seed) {
    const State x = random_state_near(m, x0, seed);
    MatX Psi;
    VecX phi, gamma;
    cs.bilateral(x.base, x.q, Psi, phi);
    cs.bilateral_bias(x.base, x.q, x.v, gamma);
    ASSERT_EQ(Psi.rows(), cs.bilateral_rows());
    ASSERT_EQ(Psi.cols(), m.nv);
    const double eps = 1e-6;
    MatX P1, P2;
    VecX f1, f2;
    for (int k = 0; k < m.nv; ++k) {
      const VecX e = VecX::Unit(m.nv, k);
      const State a = moved(m, x, e, eps), b = moved(m, x, e, -eps);
      cs.bilateral(a.base, a.q, P1, f1);
      cs.bilateral(b.base, b.q, P2, f2);
      const VecX fd = (f1 - f2) / (2 * eps);
      EXPECT_LT((fd - Psi.col(k)).cwiseAbs().maxCoeff(), 1e-7) << scene_file << " column " << k;
    }
    // Psi_dot w: the derivative of Psi(q(t)) w along the motion with w held.
    const State a = moved(m, x, x.v, eps), b = moved(m, x, x.v, -eps);
    cs.bilateral(a.base, a.q, P1, f1);
    cs.bilateral(b.base, b.q, P2, f2);
    const VecX fd = (P1 * x.v - P2 * x.v) / (2 * eps);
    EXPECT_LT((fd - gamma).cwiseAbs().maxCoeff(), 1e-6) << scene_file << "\n"
                                                        << fd.transpose() << "\n"
                                                        << gamma.transpose();
  }
}

struct RunStats {
  double err_max = 0;
  double energy_drift = 0;  // max |E - E0| / T0
  bool ok = true;
};

/// Steps sim for duration seconds; each (if given) sees the simulator after every step.
RunStats run(Simulator& sim, double duration,
             const std::function<void(const Simulator&)>& each = nullptr) {
  RunStats s;
  const double T0 = sim.kinetic_energy();
  const double E0 = T0 + sim.potential_energy();
  s.err_max = sim.constraint_error();
  const long steps = std::lround(duration / sim.dt());
  for (long k = 0; k < steps; ++k) {
    if (!sim.step()) {
      s.ok = false;
      ADD_FAILURE() << sim.failure();
      break;
    }
    s.err_max = std::max(s.err_max, sim.constraint_error());
    if (each) each(sim);
    if (k % 50 == 0) {
      const double E = sim.kinetic_energy() + sim.potential_energy();
      s.energy_drift = std::max(s.energy_drift, std::abs(E - E0) / T0);
    }
  }
  return s;
}

}  // namespace

TEST(Constraints, JacobianAndBiasMatchFiniteDifferencesFourbar) {
  check_derivatives("config/scenes/fourbar.yaml");
}

TEST(Constraints, JacobianAndBiasMatchFiniteDifferencesFreeBasePinAndAxis) {
  check_derivatives("config/scenes/pinned_chain.yaml");
}

TEST(Constraints, FourbarLoopClosedFor100s) {
  const Scene sc = load_scene(path("config/scenes/fourbar.yaml"));
  auto sim = make_simulator(sc);
  ASSERT_TRUE(sim->constraints());
  const RunStats s = run(*sim, 100.0);
  EXPECT_TRUE(s.ok);
  EXPECT_NEAR(sim->time(), 100.0, 1e-6);
  std::printf("four-bar 100 s: loop error max %.3g m, energy drift %.3g\n", s.err_max,
              s.energy_drift);
  EXPECT_LT(s.err_max, 1e-6);
  // The loop force does no work: the energy of the closed chain is conserved.
  EXPECT_LT(s.energy_drift, 1e-4);
  EXPECT_TRUE(sim->constraints()->lambda().allFinite());
  EXPECT_EQ(sim->constraints()->report().singular_solves, 0u);
}

TEST(Constraints, FourbarDriftWithoutProjection) {
  // Baumgarte alone holds the loop; with no stabilization at all the error grows.
  Scene sc = load_scene(path("config/scenes/fourbar.yaml"));
  sc.constraints.options.project = false;
  auto baum = make_simulator(sc);
  const RunStats with = run(*baum, 20.0);
  sc.constraints.options.baumgarte_omega = 0;
  auto raw = make_simulator(sc);
  const RunStats without = run(*raw, 20.0);
  std::printf("four-bar 20 s without projection: Baumgarte %.3g m, none %.3g m\n", with.err_max,
              without.err_max);
  EXPECT_LT(with.err_max, 1e-6);
  EXPECT_GT(without.err_max, 10 * with.err_max);
}

TEST(Constraints, PinnedChainPinAndAxisHold) {
  const Scene sc = load_scene(path("config/scenes/pinned_chain.yaml"));
  auto sim = make_simulator(sc);
  const Vec3 pin0 = sim->state().base.p;
  double turned = 0;  // the largest turn of the base's x axis away from its start
  const RunStats s = run(*sim, 20.0, [&](const Simulator& m) {
    turned = std::max(turned, (m.state().base.R.col(0) - Vec3::UnitX()).norm());
  });
  EXPECT_TRUE(s.ok);
  EXPECT_LT(s.err_max, 1e-9);
  EXPECT_LT((sim->state().base.p - pin0).norm(), 1e-9);
  EXPECT_LT((sim->state().base.R.col(2) - Vec3::UnitZ()).norm(), 1e-9);
  EXPECT_LT(s.energy_drift, 1e-4);
  // The chain moved: the hinge turned (during the run: where it ends after 20 s, chaotic
  // swinging decides, and 2 pi multiples look like no turn at all).
  EXPECT_GT(turned, 1.0);
  std::printf("pinned chain 20 s: error max %.3g, energy drift %.3g\n", s.err_max, s.energy_drift);
}

TEST(Constraints, PinForceOnABodyAtRestIsItsWeight) {
  // Sign convention: D wdot + H = tau + Psi^T lambda; a body pinned at its centre of mass
  // hangs still with lambda = +m g (upward) and no acceleration, even while it spins about z.
  const double mass = 2.5;
  const Model m = [&] {
    UrdfOptions o;
    o.floating = true;
    return model_from_urdf_string(box_urdf(0.3, 0.2, 0.1, mass), o);
  }();
  ASSERT_EQ(m.n, 0);
  ConstraintSpec spec;
  BilateralConstraint pin;
  pin.type = ConstraintType::PointWorld;
  pin.link_a = "box";
  pin.point_b = Vec3(0.1, -0.2, 1.0);
  spec.bilateral.push_back(pin);
  ConstraintSystem cs(m, spec);
  State x(m);
  x.base.p = pin.point_b;
  x.v[2] = 1.5;  // spin about the (principal) z axis
  const VecX tau = VecX::Zero(m.nv);
  const VecX a = cs.acceleration(x.base, x.q, x.v, tau);
  EXPECT_LT(a.cwiseAbs().maxCoeff(), 1e-12) << a.transpose();
  ASSERT_EQ(cs.lambda().size(), 3);
  EXPECT_NEAR(cs.lambda()[0], 0, 1e-12);
  EXPECT_NEAR(cs.lambda()[1], 0, 1e-12);
  EXPECT_NEAR(cs.lambda()[2], mass * 9.81, 1e-9);
}

TEST(Constraints, RedundantConstraintsGiveFiniteMultipliersAndAReport) {
  // The pin given twice: Psi D^-1 Psi^T is singular (rank 5 of 8 rows); the pseudo-inverse
  // gives the same motion as the single pin.
  Scene sc = load_scene(path("config/scenes/pinned_chain.yaml"));
  auto once = make_simulator(sc);
  BilateralConstraint twice = sc.constraints.bilateral[0];
  twice.name = "pin_again";
  sc.constraints.bilateral.push_back(twice);
  auto dup = make_simulator(sc);
  ASSERT_EQ(dup->constraints()->bilateral_rows(), 8);
  for (int k = 0; k < 2000; ++k) {
    ASSERT_TRUE(once->step());
    ASSERT_TRUE(dup->step());
    ASSERT_TRUE(dup->constraints()->lambda().allFinite());
  }
  const ConstraintReport& r = dup->constraints()->report();
  EXPECT_GT(r.singular_solves, 0u);
  EXPECT_EQ(r.rank, 5);
  EXPECT_EQ(once->constraints()->report().singular_solves, 0u);
  EXPECT_LT((once->state().q - dup->state().q).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LT((once->state().v - dup->state().v).cwiseAbs().maxCoeff(), 1e-7);
  EXPECT_LT(dup->constraint_error(), 1e-9);

  // A planar loop with all three point rows: the out-of-plane row is identically zero.
  Scene fb = load_scene(path("config/scenes/fourbar.yaml"));
  fb.constraints.bilateral[0].directions.clear();
  auto sim = make_simulator(fb);
  const RunStats s = run(*sim, 5.0);
  EXPECT_TRUE(s.ok);
  EXPECT_LT(s.err_max, 1e-6);
  EXPECT_GT(sim->constraints()->report().singular_solves, 0u);
  EXPECT_EQ(sim->constraints()->report().rank, 2);
  EXPECT_TRUE(sim->constraints()->lambda().allFinite());
}

TEST(Constraints, JointLimitsHoldUnderLargeTorques) {
  const Model m = model_from_urdf_file(path("data/robots/panda.urdf"));
  ConstraintSpec spec;
  spec.joint_limits = true;
  ConstraintSystem cs(m, spec);
  auto stepper = make_stepper("semi_implicit_euler", m);
  State x(m);
  for (int i = 1; i <= m.n; ++i) {
    x.q[i - 1] = 0.5 * (m.lower[i] + m.upper[i]);
  }
  double worst = 0;
  int hits_lower = 0, hits_upper = 0;
  const double h = 1e-3;
  for (int k = 0; k < 3000; ++k) {
    VecX tau = VecX::Zero(m.nv);
    const double sgn = k < 1500 ? 1.0 : -1.0;
    for (int i = 0; i < m.nv; ++i) tau[i] = sgn * ((i % 2) ? 300.0 : -300.0);
    ASSERT_TRUE(constrained_step(cs, *stepper, x, tau, h).ok);
    worst = std::max(worst, cs.report().limit_violation);
    for (int i = 1; i <= m.n; ++i) {
      hits_lower += x.q[i - 1] < m.lower[i] + 1e-3;
      hits_upper += x.q[i - 1] > m.upper[i] - 1e-3;
    }
  }
  std::printf("panda limits under 300 N m: worst excursion %.3g rad\n", worst);
  EXPECT_GT(hits_lower, 0);
  EXPECT_GT(hits_upper, 0);
  EXPECT_LT(worst, 1e-4);
  // Forces at a limit push away from it.
  for (const ConstraintForce& f : cs.forces()) {
    if (f.kind != ConstraintForce::Limit || !f.active) continue;
    const int i = f.body;
    if (x.q[i - 1] < m.lower[i] + 1e-3) {
      EXPECT_GT(f.joint_force, 0) << f.name;
    }
    if (x.q[i - 1] > m.upper[i] - 1e-3) {
      EXPECT_LT(f.joint_force, 0) << f.name;
    }
  }
}

namespace {

// A 0.3 x 0.2 x 0.1 box released at rest on a plane tilted by angle a about y (downhill +x).
// Returns the downhill displacement and velocity after `duration`.
void slope_run(double mu, double duration, double& disp, double& vel, double& pen) {
  const double a = 20.0 * M_PI / 180.0;
  UrdfOptions o;
  o.floating = true;
  const Model m = model_from_urdf_string(box_urdf(0.3, 0.2, 0.1, 1.0), o);
  ConstraintSpec spec;
  spec.ground = true;
  spec.ground_normal = Vec3(std::sin(a), 0, std::cos(a));
  spec.mu = mu;
  spec.contacts_from_collisions = true;
  spec.geometry =
      std::make_shared<GeometryModel>(geometry_from_urdf_string(m, box_urdf(0.3, 0.2, 0.1, 1.0)));
  ConstraintSystem cs(m, spec);
  StepperOptions so;
  auto stepper = make_stepper("semi_implicit_euler", m, so);
  State x(m);
  x.base.R = Eigen::AngleAxisd(a, Vec3::UnitY()).toRotationMatrix();
  x.base.p = 0.05 * spec.ground_normal;
  const Vec3 down(std::cos(a), 0, -std::sin(a));
  const Vec3 p0 = x.base.p;
  const VecX tau = VecX::Zero(m.nv);
  pen = 0;
  const long steps = std::lround(duration / 1e-3);
  for (long k = 0; k < steps; ++k) {
    ASSERT_TRUE(constrained_step(cs, *stepper, x, tau, 1e-3).ok);
    pen = std::max(pen, cs.report().penetration);
  }
  disp = down.dot(x.base.p - p0);
  vel = down.dot(x.base.R * x.v.segment<3>(3));
}

}  // namespace

TEST(Contact, BoxOnTwentyDegreeSlopeSticksWithMuHalf) {
  double disp = 0, vel = 0, pen = 0;
  slope_run(0.5, 2.0, disp, vel, pen);
  std::printf("slope mu 0.5: displacement %.3g m, velocity %.3g m/s, penetration %.3g m\n", disp,
              vel, pen);
  EXPECT_LT(std::abs(disp), 1e-5);
  EXPECT_LT(std::abs(vel), 1e-5);
  EXPECT_LT(pen, 2e-4);
}

TEST(Contact, BoxOnTwentyDegreeSlopeSlidesWithMuPointTwo) {
  const double a = 20.0 * M_PI / 180.0, g = 9.81, mu = 0.2, T = 1.0;
  const double acc = g * (std::sin(a) - mu * std::cos(a));
  double disp = 0, vel = 0, pen = 0;
  slope_run(mu, T, disp, vel, pen);
  std::printf("slope mu 0.2: acceleration %.6g m/s^2 (analytic %.6g), from distance %.6g\n",
              vel / T, acc, 2 * disp / (T * T));
  EXPECT_NEAR(vel / T, acc, 1e-3 * acc);
  EXPECT_NEAR(2 * disp / (T * T), acc, 5e-3 * acc);  // first-order stepping: O(h) in distance
  EXPECT_LT(pen, 2e-4);
}

TEST(Contact, Solo12DroppedStandsStillWithoutDeepPenetration) {
  // Stated depth: 1 mm (slop 0.1 mm plus the landing transient). The legs locked in the scene's
  // standing posture (the scene holds them with a position controller instead).
  Scene sc = load_scene(path("config/scenes/quadruped_ground.yaml"));
  sc.locked_joints = sc.initial_positions;
  sc.initial_positions.clear();
  sc.controllers.clear();
  auto sim = make_simulator(sc);
  const RunStats s = run(*sim, 3.0);
  EXPECT_TRUE(s.ok);
  const ConstraintSystem& cs = *sim->constraints();
  std::printf("solo12 drop (locked legs): max error %.3g m, base height %.4g m, T %.3g J\n",
              s.err_max, sim->state().base.p.z(), sim->kinetic_energy());
  EXPECT_LT(s.err_max, 1e-3);
  EXPECT_LT(sim->kinetic_energy(), 1e-8);
  EXPECT_GE(cs.report().active_contacts, 4);
  // Standing on its four feet: the foot forces carry the weight; knees and base are free.
  double fz = 0;
  for (const ConstraintForce& f : cs.forces()) {
    if (f.kind != ConstraintForce::Contact) continue;
    if (f.name.find("foot") != std::string::npos) {
      EXPECT_GT(f.force.z(), 0) << f.name;
      EXPECT_LE(f.force.head<2>().norm(), sc.constraints.mu * f.force.z() * (1 + 1e-9));
    } else {
      EXPECT_EQ(f.force.norm(), 0) << f.name;
    }
    fz += f.force.z();
  }
  EXPECT_NEAR(fz, sim->model().total_mass() * 9.81, 1e-6 * fz);
}

TEST(Contact, Solo12WithFreeJointsFallsAndComesToRest) {
  // Joints free (zero torque): the legs fold, knees and base corners land; friction and the
  // inelastic impacts take the energy out. Stated depth: 2 mm.
  Scene sc = load_scene(path("config/scenes/quadruped_ground.yaml"));
  sc.controllers.clear();  // from the standing posture, nothing holding the joints
  auto sim = make_simulator(sc);
  EXPECT_EQ(sim->model().n, 12);
  const RunStats s = run(*sim, 4.0);
  EXPECT_TRUE(s.ok);
  std::printf("solo12 drop (free joints): max error %.3g m, base height %.4g m, T %.3g J\n",
              s.err_max, sim->state().base.p.z(), sim->kinetic_energy());
  EXPECT_LT(s.err_max, 2e-3);
  EXPECT_LT(sim->kinetic_energy(), 1e-4);
  EXPECT_GT(sim->state().base.p.z(), 0.0);
}

// Constraint and contact steps allocate nothing after the first: gtest_alloc.cpp (malloc too).

TEST(Constraints, SceneErrorsNameTheProblem) {
  EXPECT_THROW(
      parse_scene("robot: chain:2\nconstraints:\n  c: {type: glue, link_a: link1}\n", kRoot, "<t>"),
      SceneError);
  EXPECT_THROW(parse_scene("robot: chain:2\nground: {mu: -1}\n", kRoot, "<t>"), SceneError);
  const Scene sc = parse_scene(
      "robot: chain:2\nconstraints:\n  c: {type: point_world, link_a: nolink}\n", kRoot, "<t>");
  EXPECT_THROW(make_simulator(sc), ModelError);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
