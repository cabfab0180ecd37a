// Contact through the Simulator with free scene objects (single-body free systems stepped with
// the robot by the contact scheme), against closed forms: a ball dropped with restitution e
// rebounds to e^2 h; a box sliding at v0 on mu stops after v0^2 / (2 mu g) (deceleration mu g);
// a box on an incline of angle theta sticks when tan(theta) < mu and otherwise accelerates at
// g (sin - mu cos); a box resting on the ground stays at its height; free objects keep their
// momentum between impacts.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "same_bits.h"
#include "se3_sim/sim/scene_collision.h"
#include "se3_sim/sim/sim.h"
#include "source_paths.h"

using namespace se3;

namespace {

const std::string kScenes = se3_sim_test::source_dir() + "/config/scenes/";
constexpr double kG = 9.81;

SceneObject free_object(const std::string& name, const Shape& shape, double mass,
                        const Vec3& position) {
  SceneObject o;
  o.name = name;
  o.shape = shape;
  o.is_static = false;
  o.mass = mass;
  Mat3 I = Mat3::Identity();
  if (shape.type == ShapeType::Sphere) {
    I *= 0.4 * mass * shape.radius * shape.radius;
  } else {
    const Vec3& e = shape.box;
    I = Vec3(e.y() * e.y() + e.z() * e.z(), e.x() * e.x() + e.z() * e.z(),
             e.x() * e.x() + e.y() * e.y())
            .asDiagonal();
    I *= mass / 12;
  }
  o.inertia = Inertia::from_com(mass, Vec3::Zero(), I);
  o.pose.p = position;
  return o;
}

// A fixed two-link chain out of the way (the robot), the ground with the given options.
std::unique_ptr<Simulator> ground_scene(const std::string& ground, const std::string& extra = "",
                                        const Vec3& gravity = Vec3(0, 0, -kG)) {
  const std::string text =
      "robot: chain:2\nbase: fixed\nbase_pose: {position: [0, 0, 5]}\n"
      "dt: 0.001\ngravity: [" +
      std::to_string(gravity.x()) + ", " + std::to_string(gravity.y()) + ", " +
      std::to_string(gravity.z()) + "]\nground: " + ground + "\n" + extra;
  return make_simulator(parse_scene(text, kScenes, "contact.yaml"));
}

}  // namespace

TEST(Contact, BallReboundsToESquaredTimesTheDropHeight) {
  const double e = 0.6, drop = 0.5, r = 0.05;
  auto sim = ground_scene("{mu: 0.5, restitution: 0.6}",
                          "constraint_options: {restitution_velocity: 0.05}\n");
  sim->set_objects({free_object("ball", make_sphere(r), 0.2, Vec3(0, 0, r + drop))});
  // Fall, bounce, and find the top of the first rebound.
  bool bounced = false;
  double top = 0;
  for (int k = 0; k < 3000; ++k) {
    ASSERT_TRUE(sim->step()) << sim->failure();
    const ObjectState& b = sim->objects()[0];
    if (!bounced && b.twist[5] > 0) bounced = true;
    if (bounced) {
      top = std::max(top, b.pose.p.z() - r);
      if (b.twist[5] < 0) break;
    }
  }
  ASSERT_TRUE(bounced);
  std::printf("rebound %.5f m, e^2 h = %.5f m\n", top, e * e * drop);
  // First order in dt: the impact happens within a step of the touch, 1% of the height.
  EXPECT_NEAR(top, e * e * drop, 0.01 * drop);
  EXPECT_LT(sim->penetration_max(), 0.02);
}

TEST(Contact, SlidingBoxDeceleratesAtMuGAndStops) {
  const double mu = 0.3, v0 = 2.0;
  auto sim = ground_scene("{mu: 0.3}");
  SceneObject box = free_object("box", make_box(Vec3(0.2, 0.2, 0.1)), 1.0, Vec3(0, 0, 0.05));
  box.twist[3] = v0;
  box.mu = mu;  // a pair's mu is the larger of the two
  sim->set_objects({box});
  const double t_stop = v0 / (mu * kG);
  const int steps = static_cast<int>(0.5 * t_stop / sim->dt());
  ASSERT_EQ(sim->step_n(steps), steps) << sim->failure();
  const double t = steps * sim->dt();
  EXPECT_NEAR(sim->objects()[0].twist[3], v0 - mu * kG * t, 2e-3);
  ASSERT_EQ(sim->step_n(2 * steps), 2 * steps) << sim->failure();
  const double x_stop = v0 * v0 / (2 * mu * kG);
  std::printf("slid %.5f m, v0^2/(2 mu g) = %.5f m\n", sim->objects()[0].pose.p.x(), x_stop);
  EXPECT_NEAR(sim->objects()[0].pose.p.x(), x_stop, 0.01 * x_stop);
  EXPECT_LT(std::abs(sim->objects()[0].twist[3]), 1e-6);
  EXPECT_NEAR(sim->objects()[0].pose.p.z(), 0.05, 1e-3);
}

TEST(Contact, BoxOnAnInclineSticksBelowAtanMuAndSlidesAbove) {
  const double theta = 20 * M_PI / 180;
  // The slope as the ground plane z = 0 with gravity turned by theta (along -x down the slope).
  const Vec3 g(-kG * std::sin(theta), 0, -kG * std::cos(theta));
  for (double mu : {0.5, 0.2}) {
    SCOPED_TRACE(mu);
    auto sim = ground_scene("{mu: " + std::to_string(mu) + "}", "", g);
    SceneObject box = free_object("box", make_box(Vec3(0.2, 0.2, 0.1)), 1.0, Vec3(0, 0, 0.05));
    box.mu = mu;
    sim->set_objects({box});
    ASSERT_EQ(sim->step_n(1000), 1000) << sim->failure();
    const double x = sim->objects()[0].pose.p.x();
    if (mu > std::tan(theta)) {
      EXPECT_LT(std::abs(x), 1e-6);
    } else {
      const double a = kG * (std::sin(theta) - mu * std::cos(theta));
      EXPECT_NEAR(x, -0.5 * a * 1.0, 0.01 * 0.5 * a);
    }
  }
}

// A box spawned with its bottom 0.3 m under the ground (issue 35): the position correction
// asked for erp 0.3 m / dt = 60 m/s and launched it to 136 m. It rises at no more than
// max_correction_velocity, lands and rests on the ground, and the start is reported.
TEST(Contact, DeepPenetrationRisesSlowlyAndRests) {
  const Scene scene = parse_scene(
      "gravity: [0, 0, -9.81]\nintegrator: contact_semi_implicit\ndt: 0.001\n"
      "ground: {normal: [0, 0, 1]}\n"
      "objects:\n"
      "  - {name: box, shape: {box: [1, 1, 1]}, mass: 1, pose: {position: [0, 0, 0.2]}}\n",
      kScenes, "deep.yaml");
  auto sim = make_simulator(scene);
  const std::string warning = sim->deep_penetration_warning();
  EXPECT_NE(warning.find("'box'"), std::string::npos) << warning;
  EXPECT_NE(warning.find("0.3 m deep"), std::string::npos) << warning;
  EXPECT_NE(warning.find("max_correction_velocity"), std::string::npos) << warning;
  double fastest = 0, highest = 0;
  for (int k = 0; k < 3000; ++k) {
    ASSERT_TRUE(sim->step()) << sim->failure();
    const ObjectState& b = sim->objects()[0];
    fastest = std::max(fastest, b.twist.tail<3>().norm());
    highest = std::max(highest, b.pose.p.z());
  }
  const ObjectState& b = sim->objects()[0];
  std::printf("deep start: fastest %.3g m/s, highest centre %.4g m, final z %.6g m\n", fastest,
              highest, b.pose.p.z());
  EXPECT_LT(fastest, 0.5 * 1.01);  // max_correction_velocity
  EXPECT_LT(highest, 0.5 + 0.5 * 0.5 / (2 * kG) + 1e-3);
  EXPECT_NEAR(b.pose.p.z(), 0.5, 2e-3);  // resting on the ground
  EXPECT_LT(b.twist.norm(), 1e-3);
  // A scene that starts in resting contact says nothing.
  const Scene rest = parse_scene(
      "ground: true\ndt: 0.001\n"
      "objects: [{name: box, shape: {box: [1, 1, 1]}, mass: 1, pose: {position: [0, 0, 0.5]}}]\n",
      kScenes, "rest.yaml");
  EXPECT_EQ(make_simulator(rest)->deep_penetration_warning(), "");
}

// A 2 cm ball at 1000 m/s toward a 1 cm wall passes through it between two steps (contact is
// found at the steps' ends: here at x = 1 and 2, the wall at 1.5); the simulator counts each step
// in which an object moved farther than its own size and describes the first (issue 35).
TEST(Contact, FastSmallObjectIsReportedAsPossiblyTunnelling) {
  const Scene scene = parse_scene(
      "gravity: [0, 0, 0]\nintegrator: contact_semi_implicit\ndt: 0.001\n"
      "objects:\n"
      "  - {name: wall, shape: {box: [0.01, 1, 1]}, pose: {position: [1.5, 0, 0]}}\n"
      "  - {name: ball, shape: {sphere: 0.01}, mass: 0.01, twist: [0, 0, 0, 1000, 0, 0]}\n",
      kScenes, "tunnel.yaml");
  auto sim = make_simulator(scene);
  EXPECT_EQ(sim->fast_steps(), 0u);
  ASSERT_EQ(sim->step_n(5), 5) << sim->failure();
  EXPECT_GT(sim->objects()[1].pose.p.x(), 4.9);  // through the wall
  EXPECT_EQ(sim->fast_steps(), 5u);
  const std::string w = sim->fast_step_warning();
  EXPECT_NE(w.find("object 'ball' moved 1 m in one step"), std::string::npos) << w;
  EXPECT_NE(w.find("its size (0.02 m)"), std::string::npos) << w;
  EXPECT_NE(w.find("tunnelling"), std::string::npos) << w;
  sim->reset();
  EXPECT_EQ(sim->fast_steps(), 0u);
  EXPECT_EQ(sim->fast_step_warning(), "");
  // In the report (--json) too; a slow ball is not counted.
  const std::string path = testing::TempDir() + "/tunnel.yaml";
  {
    std::ofstream out(path);
    out << "gravity: [0, 0, 0]\nintegrator: contact_semi_implicit\ndt: 0.001\nobjects:\n"
           "  - {name: wall, shape: {box: [0.01, 1, 1]}, pose: {position: [1.5, 0, 0]}}\n"
           "  - {name: ball, shape: {sphere: 0.01}, mass: 0.01, twist: [0, 0, 0, 1000, 0, 0]}\n"
           "  - {name: slow, shape: {sphere: 0.01}, mass: 0.01, pose: {position: [0, 2, 0]},"
           " twist: [0, 0, 0, 10, 0, 0]}\n";
  }
  SimulateOptions o;
  o.scene = path;
  o.duration = 0.01;
  const SimulateResult r = simulate_headless(o);
  EXPECT_EQ(r.fast_steps, 10u);
  EXPECT_NE(simulate_result_json(r).find("\"fast_steps\": 10"), std::string::npos);
  std::remove(path.c_str());
}

TEST(Contact, RestingBoxStaysAndFreeObjectsKeepMomentumInFlight) {
  auto sim = ground_scene("{mu: 0.8}");
  SceneObject rest = free_object("rest", make_box(Vec3(0.3, 0.2, 0.1)), 3.0, Vec3(0, 0, 0.05));
  SceneObject fly = free_object("fly", make_box(Vec3(0.1, 0.2, 0.3)), 1.5, Vec3(2, 0, 3.0));
  fly.twist << 1.0, -2.0, 0.5, 0.3, 0.1, 4.0;
  sim->set_objects({rest, fly});
  auto momentum = [&](const ObjectState& s, const SceneObject& o) {
    const Vec6 h = o.inertia * s.twist;  // body frame [angular; linear] about the centre
    Vec6 w;
    w.tail<3>() = s.pose.R * h.tail<3>();
    w.head<3>() = s.pose.R * h.head<3>() + s.pose.p.cross(w.tail<3>());
    return w;
  };
  const Vec6 h0 = momentum(sim->objects()[1], fly);
  ASSERT_EQ(sim->step_n(500), 500) << sim->failure();
  const ObjectState& f = sim->objects()[1];
  const Vec6 h1 = momentum(f, fly);
  const double t = 500 * sim->dt();
  // Linear momentum changes by gravity's impulse only, the angular momentum about the centre
  // not at all (the free-body step keeps both exactly in flight).
  EXPECT_NEAR(h1[3], h0[3], 1e-12);
  EXPECT_NEAR(h1[4], h0[4], 1e-12);
  EXPECT_NEAR(h1[5], h0[5] - fly.mass * kG * t, 1e-9);
  const Vec3 L_centre0 = fly.pose.R * (fly.inertia * fly.twist).head<3>();
  const Vec3 L_centre1 = f.pose.R * (fly.inertia * f.twist).head<3>();
  EXPECT_LT((L_centre1 - L_centre0).norm(), 1e-12 * L_centre0.norm());
  EXPECT_NEAR(sim->objects()[0].pose.p.z(), 0.05, 2e-4);
  EXPECT_LT(sim->objects()[0].twist.norm(), 1e-6);
  EXPECT_LT(sim->penetration_max(), 1e-3);
}

// The shipped stack (three boxes, no robot, the active-set solver) stays stacked for 20 s: no
// box moves by more than 0.1 mm or turns by 1e-4 rad; projected Gauss-Seidel at 5 sweeps,
// warm-started from the last step's impulses, neither within 2 s.
TEST(Contact, StackOfThreeStaysStackedFor20s) {
  for (const char* solver : {"active_set", "pgs"}) {
    SCOPED_TRACE(solver);
    Scene sc = load_scene(kScenes + "box_stack.yaml");
    const bool exact = std::string(solver) == "active_set";
    if (!exact) {
      sc.constraints.options.solver = ContactSolver::PGS;
      sc.constraints.options.pgs_iterations = 5;
    }
    auto sim = make_simulator(sc);
    ASSERT_EQ(sim->objects().size(), 3u);
    const double seconds = exact ? 20.0 : 2.0;
    const int steps = static_cast<int>(seconds / sim->dt());
    ASSERT_EQ(sim->step_n(steps), steps) << sim->failure();
    double moved = 0, turned = 0;
    for (size_t j = 0; j < 3; ++j) {
      const ObjectState& o = sim->objects()[j];
      const SceneObject& o0 = sc.objects[j];
      moved = std::max(moved, (o.pose.p - o0.pose.p).norm());
      turned = std::max(turned, log_so3(o0.pose.R.transpose() * o.pose.R).norm());
    }
    std::printf("stack, %s, %.0f s: moved %.3g m, turned %.3g rad, deepest %.3g m\n", solver,
                seconds, moved, turned, sim->penetration_max());
    if (exact) {
      EXPECT_LT(moved, 1e-4);
      EXPECT_LT(turned, 1e-4);
      EXPECT_LT(sim->penetration_max(), 1e-4);
    } else {  // warm-started from the last step's normal impulses, PGS at 5 sweeps holds too
      EXPECT_LT(moved, 1e-4);  // (cold, as before 2026-12-02, it moved more than that)
      EXPECT_LT(sim->penetration_max(), 1e-4);
    }
  }
}

// The top box of the stack pushed along x slides on the middle one and stops after
// v0^2 / (2 mu g), with either solver; the two boxes below stay. The active-set solver's guesses
// for a sliding contact used to cycle without settling, and the iterate it was left with threw
// all three boxes kilometres away within a second (fixed by its PGS fallback).
TEST(Contact, TopBoxOfTheStackSlidesToItsStoppingDistance) {
  for (const char* solver : {"active_set", "pgs"}) {
    SCOPED_TRACE(solver);
    Scene sc = load_scene(kScenes + "box_stack.yaml");
    if (std::string(solver) == "pgs") sc.constraints.options.solver = ContactSolver::PGS;
    const double v0 = 0.5, mu = sc.objects[2].mu;  // the boxes' mu (the pair's is the larger)
    ASSERT_EQ(sc.objects[1].mu, mu);
    sc.objects[2].twist[3] = v0;
    auto sim = make_simulator(sc);
    ASSERT_EQ(sim->step_n(1000), 1000) << sim->failure();
    const double x_stop = v0 * v0 / (2 * mu * kG);
    const Vec3 moved = sim->objects()[2].pose.p - sc.objects[2].pose.p;
    std::printf("top box, %s: slid %.5f m, v0^2/(2 mu g) = %.5f m\n", solver, moved.x(), x_stop);
    EXPECT_NEAR(moved.x(), x_stop, 0.05 * x_stop);
    EXPECT_LT(std::abs(moved.y()) + std::abs(moved.z()), 1e-3);
    EXPECT_LT(sim->objects()[2].twist.norm(), 1e-3);
    for (int j = 0; j < 2; ++j) {
      EXPECT_LT((sim->objects()[j].pose.p - sc.objects[j].pose.p).norm(), 1e-3) << j;
    }
    EXPECT_LT(sim->penetration_max(), 1e-4);
  }
}

// The contact study's pile (docs/peers.md): the stack's top box thrown sideways and spinning, so
// that it slides off, tumbles and lands, at steps of 4, 2 and 1 ms. At 4 ms the active-set
// solver once accepted a settled guess with frozen two-cycle rows that was no solution
// (impulses of 1e6 N s): the box left at 2 km/s. Now no box ever moves faster than the throw and
// the fall allow, and the top box ends near the stack.
TEST(Contact, TumblingTopBoxOfTheStackLandsAtLargeSteps) {
  for (const double dt : {0.004, 0.002, 0.001}) {
    SCOPED_TRACE(dt);
    Scene sc = load_scene(kScenes + "box_stack.yaml");
    sc.dt = dt;
    sc.objects[2].twist << 0, 0, 5, 2, 0, 0;  // body frame [w; v]
    auto sim = make_simulator(sc);
    double fastest = 0;
    const int steps = static_cast<int>(std::lround(1.0 / dt));
    for (int k = 0; k < steps; ++k) {
      ASSERT_TRUE(sim->step()) << sim->failure();
      for (const ObjectState& o : sim->objects()) fastest = std::max(fastest, o.twist.norm());
    }
    const Vec3 moved = sim->objects()[2].pose.p - sc.objects[2].pose.p;
    std::printf("tumbling top box, dt %g: fastest twist %.3g, moved %.3f m\n", dt, fastest,
                moved.norm());
    EXPECT_LT(fastest,
              50.0);  // thrown at 5.4 (rad/s, m/s), spun up to about 14 by landing on an edge
    EXPECT_LT(moved.norm(), 2.0);
    EXPECT_LT(sim->penetration_max(), 1e-3);
  }
}

// Every shipped scene starts without a deep interpenetration and runs for 1.5 s simulated (a
// scene of several robots, whose arms may touch each other, 5 s): finite, no divergence,
// penetration below 5 mm.
TEST(Contact, EveryShippedSceneRuns) {
  for (const auto& e : std::filesystem::directory_iterator(kScenes)) {
    if (e.path().extension() != ".yaml") continue;
    SCOPED_TRACE(e.path().filename().string());
    const Scene sc = load_scene(e.path().string());
    std::string urdf;  // a scene for any robot (robot_description): the UR5
    if (sc.robot_path.empty() && sc.objects.empty()) {
      std::ifstream in(se3_sim_test::source_dir() + "/data/robots/ur5_robot.urdf");
      std::stringstream text;
      text << in.rdbuf();
      urdf = text.str();
    }
    std::unique_ptr<Simulator> sim;
    try {
      sim = make_simulator(sc, urdf);
    } catch (const std::exception& ex) {
      ADD_FAILURE() << e.path() << ": " << ex.what();
      continue;
    }
    EXPECT_EQ(sim->deep_penetration_warning(), "");
    const double seconds = sim->robot_count() > 1 ? 5.0 : 1.5;
    const int steps = static_cast<int>(seconds / sim->dt());
    ASSERT_EQ(sim->step_n(steps), steps) << sim->failure();
    EXPECT_TRUE(sim->state().finite());
    for (int k = 1; k < sim->robot_count(); ++k) {
      EXPECT_TRUE(sim->robot_state(k).finite()) << sim->robot_name(k);
    }
    for (const ObjectState& o : sim->objects()) {
      EXPECT_TRUE(o.pose.p.allFinite() && o.twist.allFinite()) << o.name;
    }
    EXPECT_LT(sim->penetration_max(), 5e-3);
  }
}

// The UR5 thrown into itself (ur5_self_collision.yaml): with self_collision on its links never
// interpenetrate by more than a few millimetres; with it off they pass through each other
// (measured with the self-colliding model at the states of that run).
TEST(Contact, ArmWithSelfCollisionNeverInterpenetrates) {
  const Scene on = load_scene(kScenes + "ur5_self_collision.yaml");
  Scene off = on;
  off.self_collision = false;
  SceneCollision probe = scene_collision(on, nullptr);  // replaced below with the robot's
  auto run = [&](const Scene& sc) {
    auto sim = make_simulator(sc);
    probe = scene_collision(on, &sim->model());
    CollisionData data;
    std::vector<SE3> frames, none;
    double deepest = 0;
    for (int k = 0; k < 1500; ++k) {
      EXPECT_TRUE(sim->step()) << sim->failure();
      sim->link_poses(frames);  // fills body_poses()
      scene_frame_poses(sim->body_poses(), none, frames);
      collide(probe.model, data, frames);
      for (const Contact& c : data.contacts) deepest = std::max(deepest, c.depth);
    }
    return deepest;
  };
  const double with = run(on), without = run(off);
  std::printf(
      "UR5 thrown into itself: deepest self-penetration %.4g m with self_collision, "
      "%.4g m without\n",
      with, without);
  EXPECT_LT(with, 5e-3);
  EXPECT_GT(without, 2e-2);
}

// Solo12 dropped onto the ground on its own collision meshes (solo12_meshes.yaml, no contact
// spheres) lands and stands: shallow contact, the base held up, at rest after 3 s. Without the
// robot's geometry in the collision model it would fall through (checked: 10.9 m deep in 2 s).
TEST(Contact, MeshRobotStandsOnItsMeshFeet) {
  auto sim = make_simulator(load_scene(kScenes + "solo12_meshes.yaml"));
  ASSERT_EQ(sim->step_n(3000), 3000) << sim->failure();
  std::printf("solo12 on its meshes: base z %.4f m, deepest %.3g m, T %.3g J\n",
              sim->state().base.p.z(), sim->penetration_max(), sim->kinetic_energy());
  EXPECT_LT(sim->penetration_max(), 3e-3);
  EXPECT_GT(sim->state().base.p.z(), 0.15);
  EXPECT_LT(sim->kinetic_energy(), 1e-3);
}

// solo12_meshes pools each leg's two hulls (its lower leg and its foot, one body) against the
// ground (`contact: {ground_per_body: true}`, the default): at most max_contacts_per_pair = 4
// contacts a leg, 16 in all, in every step of 2 s, where each hull on its own gave up to 8 a leg.
// The robot lands and stands on its feet no deeper than with the hulls apart (7.8e-7 m both).
TEST(Contact, MeshRobotPoolsEachLegsHullsOnTheGround) {
  const Scene scene = load_scene(kScenes + "solo12_meshes.yaml");
  ASSERT_TRUE(scene.ground_per_body);
  const Model model = scene_model(scene);
  const SceneCollision sc = scene_collision(scene, &model);  // the simulator's objects, in order
  double deepest[2] = {0, 0};
  for (bool per_body : {true, false}) {
    Scene s = scene;
    s.ground_per_body = per_body;
    auto sim = make_simulator(s);
    std::size_t most = 0;
    int most_per_body = 0;
    for (int k = 0; k < 2000; ++k) {
      ASSERT_EQ(sim->step_n(1), 1) << sim->failure();
      std::vector<int> per(model.n + 1, 0);
      for (const Contact& c : sim->contacts()) {
        ASSERT_GE(sc.body[c.b], 0);
        most_per_body = std::max(most_per_body, ++per[sc.body[c.b]]);
      }
      most = std::max(most, sim->contacts().size());
    }
    deepest[per_body] = sim->penetration_max();
    std::printf(
        "solo12_meshes, ground_per_body %d: at most %zu contacts, %d a body; deepest %.3g m, "
        "base z %.4f m\n",
        int(per_body), most, most_per_body, sim->penetration_max(), sim->state().base.p.z());
    EXPECT_GT(sim->state().base.p.z(), 0.2);  // standing (0.238 m), not on its knees or belly
    if (per_body) {
      EXPECT_EQ(most_per_body, 4);
      EXPECT_LE(most, 16u);
    } else {
      EXPECT_EQ(most_per_body, 8);
    }
  }
  EXPECT_LT(deepest[1], 1e-6);
  EXPECT_LE(deepest[1], deepest[0]);
}

// A contact scene that names another integrator (rkmk4) keeps that integrator's steps while no
// limit or contact is within reach (bit for bit the same states as without the ground), and
// takes the steps with contact by the contact scheme (counted as velocity steps).
TEST(Contact, AnotherIntegratorKeepsItsStepsAwayFromContact) {
  Scene with = load_scene(kScenes + "quadruped_ground.yaml");
  with.integrator = "rkmk4";
  with.controllers.clear();
  Scene without = with;
  without.constraints.ground = false;
  without.constraints.contacts.clear();
  auto a = make_simulator(with);
  auto b = make_simulator(without);
  ASSERT_EQ(a->integrator(), "rkmk4");
  ASSERT_EQ(a->step_n(100), 100) << a->failure();  // falling: the feet 0.15 m above the ground
  ASSERT_EQ(b->step_n(100), 100) << b->failure();
  EXPECT_EQ(a->state().q, b->state().q);
  EXPECT_EQ(a->state().v, b->state().v);
  EXPECT_EQ(a->constraints()->report().velocity_steps, 0u);
  ASSERT_EQ(a->step_n(400), 400) << a->failure();
  EXPECT_GT(a->constraints()->report().velocity_steps, 100u);
  EXPECT_LT(a->penetration_max(), 5e-3);
}

// The hot loops of a contact step run four lanes at a time with AVX where the CPU has it (the
// hull scan, the candidates' gather and sampling, the Delassus block's fused loops, the active
// set's LU), two with SSE2 otherwise (SE3_SIM_NO_AVX=1): the same products and sums, so whole
// runs give the same bits. This binary runs itself with the variable set and compares a hash of
// the robot's and the objects' final states over 0.6 s of three scenes.
TEST(Contact, ScenesStepTheSameBitsOnTheSse2Path) {
  se3_test::BitsHash h;
  for (const char* name : {"solo12_meshes", "box_stack", "panda_push"}) {
    auto sim = make_simulator(load_scene(kScenes + name + ".yaml"));
    ASSERT_EQ(sim->step_n(600), 600) << name << ": " << sim->failure();
    const State& x = sim->state();
    h.add(x.q);
    h.add(x.v);
    h.add(x.base.R);
    h.add(x.base.p);
    for (const ObjectState& o : sim->objects()) {
      h.add(o.pose.p);
      h.add(o.twist);
    }
    EXPECT_GT(sim->contacts().size(), 0u) << name << ": no contact to compare";
  }
  se3_test::expect_same_bits_on_the_sse2_path("Contact.ScenesStepTheSameBitsOnTheSse2Path", h.h);
}

int main(int argc, char** argv) {
  se3_test::self() = argv[0];
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}

// panda_push.yaml: joint 1 swings the arm round at 1.2 rad/s and the finger hulls sweep into the
// 1 kg box on the table. The arm is held smoothly (no joint's velocity flips from step to step, as
// the wrist's did when d = 40 passed the step's bound of gain_check.h; the arm then sagged onto the
// table under p = 400 and stopped there, and the box moved 3.5 cm). The box is pushed along an
// arc (about 0.2 m), stays on the table top upright (z at its half height), and comes to rest
// (mu 0.4): no tunnelling, no flight.
TEST(Contact, PandaPushesTheBoxAlongTheTableAndItComesToRest) {
  const Scene sc = load_scene(kScenes + "panda_push.yaml");
  auto sim = make_simulator(sc);
  ASSERT_EQ(sim->objects()[1].name, "box");
  const Vec3 start = sim->objects()[1].pose.p;
  double fastest = 0, deepest = 0, flip = 0;
  VecX v1 = sim->state().v, v2 = v1;
  for (int k = 0; k < 5; ++k) {
    for (int s = 0; s < 1000; ++s) {
      ASSERT_TRUE(sim->step()) << sim->failure();
      if (k == 0 && s >= 2 && s < 100) {  // before the fingers reach the box
        flip = std::max(flip, (sim->state().v - 2 * v1 + v2).cwiseAbs().maxCoeff());
      }
      v2 = v1;
      v1 = sim->state().v;
      fastest = std::max(fastest, sim->objects()[1].twist.tail<3>().norm());
      deepest = std::max(deepest, sim->penetration_max());
    }
    const Vec3 p = sim->objects()[1].pose.p;
    std::printf("panda_push t = %d s: box at (%.4f, %.4f, %.4f), |v| %.3g, joint 1 %.3f rad\n",
                k + 1, p.x(), p.y(), p.z(), sim->objects()[1].twist.tail<3>().norm(),
                sim->state().q(0));
  }
  const ObjectState& box = sim->objects()[1];
  const Vec3 moved = box.pose.p - start;
  std::printf("panda_push: largest step-to-step velocity flip %.3g rad/s, box moved %.4f m\n", flip,
              moved.head<2>().norm());
  EXPECT_LT(flip, 0.05);                                      // rad/s (it was 4 at d = 40)
  EXPECT_GT(moved.head<2>().norm(), 0.1);                     // pushed
  EXPECT_NEAR(box.pose.p.z(), 0.05 + 0.04, 2e-3);             // on the table top, on a face
  EXPECT_GT(box.pose.R.row(2).cwiseAbs().maxCoeff(), 0.999);  // one face axis vertical
  EXPECT_LT(std::abs(box.pose.p.x() - 0.6), 0.3);             // within the table's extent
  EXPECT_LT(std::abs(box.pose.p.y()), 0.6);
  EXPECT_LT(fastest, 2.0);  // never thrown faster than the fingers sweep
  EXPECT_LT(deepest, 3e-3);
  EXPECT_LT(box.twist.norm(), 1e-2);  // at rest after the push
}
