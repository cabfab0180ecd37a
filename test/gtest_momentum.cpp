// Free-floating systems keep their momentum in every scheme: the velocity-level step's free base
// (FreeBaseStep: the momentum about the step's first base frame, re-expressed about the new
// one) against the tossed free body's closed forms, the satellite arm striking its joint limits
// under every momentum-conserving integrator, a free Solo12 thrown onto the ground (its momentum
// changes by gravity's and the ground's impulses only), and joint limits under rkmk4 with the
// impacts located inside the step (order 4 between impacts, the impact instant exact).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "se3_sim/sim/sim.h"
#include "se3_sim/solver/constraints.h"
#include "source_paths.h"

using namespace se3;

namespace {

const std::string kScenes = se3_sim_test::source_dir() + "/config/scenes/";

// A single free link: 4 kg, principal inertia (0.3, 0.2, izz) kg m^2 about its centre, which is
// its frame's origin. The issue's reproducer has izz = 0.05, which the URDF reader takes although
// it breaks the triangle inequality (scene objects refuse it).
std::string free_link_urdf(double izz = 0.05) {
  const std::string path =
      (std::filesystem::temp_directory_path() / "se3_sim_free_link.urdf").string();
  std::ofstream(path) << R"(<robot name="free_link"><link name="body"><inertial>
    <origin xyz="0 0 0"/><mass value="4"/>
    <inertia ixx="0.3" iyy="0.2" izz=")"
                      << izz << R"(" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>)";
  return path;
}

const char* kTwist = "[0.2, 4.0, -0.1, 1.0, -3.0, 6.0]";

std::unique_ptr<Simulator> tossed_link(const std::string& integrator, double g, double izz = 0.05) {
  const std::string text = "robot: " + free_link_urdf(izz) + "\nbase: free\nbase_twist: " + kTwist +
                           "\ngravity: [0, 0, " + std::to_string(g) +
                           "]\nintegrator: " + integrator + "\ndt: 0.001\n";
  return make_simulator(parse_scene(text, kScenes, "tossed.yaml"));
}

// The same body as a free scene object (no robot).
std::unique_ptr<Simulator> tossed_object(double g) {
  const std::string text =
      std::string("objects:\n  - {name: body, shape: {sphere: 0.1}, mass: 4, ") +
      "inertia: [0.3, 0.2, 0.15], twist: " + kTwist + "}\ngravity: [0, 0, " + std::to_string(g) +
      "]\nintegrator: contact_semi_implicit\ndt: 0.001\n";
  return make_simulator(parse_scene(text, kScenes, "tossed_object.yaml"));
}

double rel(const Vec6& a, const Vec6& b) {
  return (a - b).norm() / b.norm();
}

}  // namespace

// Zero gravity: the world momentum stays what it was to rounding (1.2e-12 relative after 10^4
// steps) and the centre moves on its straight line exactly, (1, -3, 6) m/s for 10 s; the energy
// stays bounded (the body-frame momentum turns on its sphere). Before: momentum drift 1.10,
// position (10.41, -30.23, 62.80).
TEST(FreeBase, TossedLinkKeepsItsMomentumInZeroGravity) {
  for (const char* integrator : {"semi_implicit_euler", "contact_semi_implicit"}) {
    SCOPED_TRACE(integrator);
    auto sim = tossed_link(integrator, 0.0);
    const Vec6 h0 = sim->momentum();
    const double T0 = sim->kinetic_energy();
    double drift = 0, T_max = T0, T_min = T0;
    for (int k = 0; k < 10; ++k) {
      ASSERT_EQ(sim->step_n(1000), 1000) << sim->failure();
      drift = std::max(drift, rel(sim->momentum(), h0));
      T_max = std::max(T_max, sim->kinetic_energy());
      T_min = std::min(T_min, sim->kinetic_energy());
    }
    EXPECT_LT(drift, 2e-12);
    EXPECT_LT((sim->state().base.p - Vec3(10, -30, 60)).norm(), 1e-9);
    EXPECT_LT(T_max, 1.2 * T0);
    EXPECT_GT(T_min, 0.8 * T0);
  }
}

// Gravity: the linear momentum gains m g t exactly, the angular momentum about the centre stays,
// x and y are exact and z is within the first-order error h t g of the parabola (before: z =
// -443.2 m against the exact -430.5 m, energy drift 11.3 T(0)).
TEST(FreeBase, TossedLinkFallsOnItsParabola) {
  const double g = -9.81, t = 10.0, m = 4.0;
  for (const char* integrator : {"semi_implicit_euler", "contact_semi_implicit"}) {
    SCOPED_TRACE(integrator);
    auto sim = tossed_link(integrator, g);
    const Vec6 h0 = sim->momentum();
    const Vec3 L0 = h0.head<3>();  // about the centre at the origin
    ASSERT_EQ(sim->step_n(10000), 10000) << sim->failure();
    const Vec6 h = sim->momentum();
    const Vec3 p = sim->state().base.p;
    EXPECT_NEAR(h[3], h0[3], 1e-10 * h0.norm());
    EXPECT_NEAR(h[4], h0[4], 1e-10 * h0.norm());
    EXPECT_NEAR(h[5], h0[5] + m * g * t, 1e-10 * h0.norm());
    const Vec3 L_centre = h.head<3>() - p.cross(h.tail<3>());
    EXPECT_LT((L_centre - L0).norm(), 1e-11 * L0.norm());
    EXPECT_NEAR(p.x(), 10.0, 1e-9);
    EXPECT_NEAR(p.y(), -30.0, 1e-9);
    const double z_exact = 60.0 + 0.5 * g * t * t;
    EXPECT_LT(std::abs(p.z() - z_exact), 0.001 * t * std::abs(g));
    // The energy (kinetic + potential) changes by the first-order error only.
    const double E = sim->kinetic_energy() + sim->potential_energy();
    EXPECT_LT(std::abs(E - sim->initial_kinetic_energy()), 0.02 * sim->initial_kinetic_energy());
  }
}

// The robot's free base and a scene object follow one law: the same body as either gives the
// same trajectory.
TEST(FreeBase, TossedLinkAndTheSameSceneObjectMoveAlike) {
  for (double g : {0.0, -9.81}) {
    SCOPED_TRACE(g);
    auto robot = tossed_link("contact_semi_implicit", g, 0.15);
    auto object = tossed_object(g);
    ASSERT_EQ(robot->step_n(2000), 2000) << robot->failure();
    ASSERT_EQ(object->step_n(2000), 2000) << object->failure();
    const ObjectState& o = object->objects().at(0);
    EXPECT_LT((robot->state().base.p - o.pose.p).norm(), 1e-9);
    EXPECT_LT((robot->state().base.R - o.pose.R).norm(), 1e-9);
    EXPECT_LT((robot->state().v - o.twist).norm(), 1e-9);
  }
}

// The default scene with its joint limits on: the arm strikes panda_joint4's lower limit (and
// others) and the satellite's momentum stays what it was, with every integrator that conserves
// it (before: 9.5e-4 with rkmk4, whose steps near a limit were the contact scheme's).
TEST(FreeBase, SatelliteArmStrikingItsLimitsKeepsItsMomentum) {
  for (const char* integrator :
       {"rkmk4", "rkmk45", "variational", "semi_implicit_euler", "contact_semi_implicit"}) {
    SCOPED_TRACE(integrator);
    Scene scene = load_scene(kScenes + "satellite_arm.yaml");
    scene.integrator = integrator;
    auto sim = make_simulator(scene);
    ASSERT_TRUE(sim->constraints() && sim->constraints()->spec().joint_limits);
    const Vec6 h0 = sim->momentum();
    double drift = 0;
    for (int k = 0; k < 20; ++k) {
      ASSERT_EQ(sim->step_n(1000), 1000) << sim->failure();
      drift = std::max(drift, rel(sim->momentum(), h0));
    }
    EXPECT_LT(drift, 1e-12);
    EXPECT_GT(sim->events() + sim->velocity_level_steps(), 0u) << "no limit was struck";
  }
}

// A free Solo12 thrown spinning onto the ground (contact spheres, its PD controller on): in
// flight its momentum changes by gravity's impulse alone; with contact by the ground's impulses
// too, summed over the steps from the constraint forces (impulse = force h, at the contact point).
TEST(FreeBase, ThrownSolo12ChangesMomentumByExternalImpulsesOnly) {
  Scene scene = load_scene(kScenes + "quadruped_ground.yaml");
  scene.base_pose.p.z() = 0.6;
  scene.base_twist << 2.0, -1.5, 3.0, 0.5, 0.2, 1.0;
  auto sim = make_simulator(scene);
  const double h = sim->dt(), m = sim->model().total_mass();
  const Vec3 g = sim->model().gravity;
  Vec6 predicted = sim->momentum();
  int contact_steps = 0;
  for (int k = 0; k < 800; ++k) {
    const Vec3 c = sim->center_of_mass();
    ASSERT_TRUE(sim->step()) << sim->failure();
    predicted.tail<3>() += h * m * g;
    predicted.head<3>() += h * c.cross(m * g);
    bool touched = false;
    for (const ConstraintForce& f : sim->constraints()->forces()) {
      if (f.kind != ConstraintForce::Contact || !f.active) continue;
      predicted.tail<3>() += h * f.force;
      predicted.head<3>() += h * f.point.cross(f.force);
      touched = true;
    }
    contact_steps += touched;
    const Vec6 now = sim->momentum();
    ASSERT_LT((now - predicted).norm(), 1e-9 * (1 + predicted.norm())) << "step " << k;
  }
  EXPECT_GT(contact_steps, 100);
}

namespace {

// A fixed-base pendulum with one hinge limited to [-0.5, 0.5] rad: a 1 kg point 0.5 m out along
// x, its axis z; gravity along -y swings it.
std::string limited_pendulum_urdf() {
  const std::string path =
      (std::filesystem::temp_directory_path() / "se3_sim_limited_pendulum.urdf").string();
  std::ofstream(path) << R"(<robot name="limited"><link name="base"/>
  <link name="arm"><inertial><origin xyz="0.5 0 0"/><mass value="1"/>
    <inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-0.5" upper="0.5" effort="10" velocity="10"/></joint>
</robot>)";
  return path;
}

std::unique_ptr<Simulator> limited_pendulum(const std::string& integrator, double dt, double g,
                                            double qdot0, double restitution = 0.5) {
  const std::string text =
      "robot: " + limited_pendulum_urdf() + "\nbase: fixed\njoint_limits: true\ngravity: [0, " +
      std::to_string(g) + ", 0]\nintegrator: " + integrator + "\ndt: " + std::to_string(dt) +
      "\ninitial_velocities: {hinge: " + std::to_string(qdot0) +
      "}\nconstraint_options: {limit_restitution: " + std::to_string(restitution) +
      ", restitution_velocity: 0.01}\n";
  return make_simulator(parse_scene(text, kScenes, "limited.yaml"));
}

}  // namespace

// Without gravity the hinge turns at 2 rad/s, strikes 0.5 at t = 0.25 s, comes back at 1 rad/s,
// strikes -0.5 at t = 1.25 s and leaves at 0.5 rad/s: at t = 1.5 s it is at -0.375 rad. The
// impacts fall inside steps of 3 ms and are located there.
TEST(LimitEvents, ImpactInstantsAreLocatedInsideTheStep) {
  auto sim = limited_pendulum("rkmk4", 0.003, 0.0, 2.0);
  ASSERT_EQ(sim->step_n(500), 500) << sim->failure();
  EXPECT_NEAR(sim->time(), 1.5, 1e-12);
  EXPECT_NEAR(sim->state().q[0], -0.375, 1e-10);
  EXPECT_NEAR(sim->state().v[0], 0.5, 1e-10);
  EXPECT_EQ(sim->events(), 2u);
  EXPECT_EQ(sim->velocity_level_steps(), 0u);
  EXPECT_EQ(sim->schemes_used(), "rkmk4");
}

// With gravity the pendulum swings into its limits and bounces (e = 0.5) several times in 1 s:
// rkmk4 keeps order 4 between the impacts (errors at the final instant against a run at 0.25 ms
// fall 16-fold per halving of dt).
TEST(LimitEvents, Rkmk4KeepsItsOrderAcrossImpacts) {
  auto run = [](double dt) {
    auto sim = limited_pendulum("rkmk4", dt, -9.81, 3.0);
    const int n = static_cast<int>(std::lround(0.8 / dt));
    EXPECT_EQ(sim->step_n(n), n) << sim->failure();
    EXPECT_GE(sim->events(), 2u);
    EXPECT_EQ(sim->velocity_level_steps(), 0u);
    return std::array<double, 2>{sim->state().q[0], sim->state().v[0]};
  };
  const auto ref = run(0.00025);
  std::vector<double> err;
  for (double dt : {0.004, 0.002, 0.001}) {
    const auto r = run(dt);
    err.push_back(std::abs(r[0] - ref[0]) + 0.1 * std::abs(r[1] - ref[1]));
  }
  for (size_t k = 0; k + 1 < err.size(); ++k) {
    const double order = std::log2(err[k] / err[k + 1]);
    EXPECT_GT(order, 3.5) << "dt halving " << k << ": errors " << err[k] << " -> " << err[k + 1];
  }
}

// A plastic impact (e = 0): the pendulum swings up into its upper limit, stops there, and
// gravity pulls it back. The instant after the impact it touches the limit at rest, but its
// free acceleration leaves it: rkmk4 goes on (no step of the contact scheme), keeping order 4
// (before: one first-order step after each impact, order 2).
TEST(LimitEvents, Rkmk4KeepsItsOrderAfterAPlasticImpact) {
  auto run = [](double dt) {
    auto sim = limited_pendulum("rkmk4", dt, -9.81, 5.0, 0.0);
    const int n = static_cast<int>(std::lround(0.4 / dt));
    EXPECT_EQ(sim->step_n(n), n) << sim->failure();
    EXPECT_EQ(sim->events(), 1u);
    EXPECT_EQ(sim->velocity_level_steps(), 0u);
    EXPECT_GT(sim->state().q[0], -0.5);  // not yet at the lower limit
    EXPECT_LT(sim->state().v[0], 0.0);   // falling back
    return std::array<double, 2>{sim->state().q[0], sim->state().v[0]};
  };
  const auto ref = run(0.00025);
  std::vector<double> err;
  for (double dt : {0.004, 0.002, 0.001}) {
    const auto r = run(dt);
    err.push_back(std::abs(r[0] - ref[0]) + 0.1 * std::abs(r[1] - ref[1]));
  }
  for (size_t k = 0; k + 1 < err.size(); ++k) {
    const double order = std::log2(err[k] / err[k + 1]);
    EXPECT_GT(order, 3.5) << "dt halving " << k << ": errors " << err[k] << " -> " << err[k + 1];
  }
}

// The variational integrator (an SE(3)-arc discretization) under gravity: a free body's angular
// momentum about its centre, which the continuous system keeps, measured over 10 s of a tossed
// link (docs/accuracy.md reports the figures).
TEST(FreeBase, VariationalAngularMomentumAboutTheCentre) {
  for (double g : {0.0, -9.81}) {
    auto sim = tossed_link("variational", g, 0.15);
    const Vec3 L0 = sim->momentum().head<3>();
    double drift = 0;
    for (int k = 0; k < 10; ++k) {
      ASSERT_EQ(sim->step_n(1000), 1000) << sim->failure();
      const Vec6 h = sim->momentum();
      const Vec3 c = sim->state().base.p;
      drift = std::max(drift, (h.head<3>() - c.cross(h.tail<3>()) - L0).norm() / L0.norm());
    }
    std::printf("variational, g = %g: angular momentum about the centre, max drift %.3e\n", g,
                drift);
    RecordProperty(g == 0 ? "drift_zero_g" : "drift_gravity", std::to_string(drift));
    // Measured 1.2e-3 (zero g) and 6.0e-3 (gravity): the continuous momentum about the centre is
    // not the discrete one the integrator keeps, and gravity's coupling through the SE(3) arc
    // adds to it (docs/accuracy.md).
    EXPECT_LT(drift, 1e-2);
  }
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
