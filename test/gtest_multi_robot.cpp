// Several robots in one Simulator (src/sim/robots.cpp, docs/multi_robot.md): the scene's
// `robots:` list, each robot's commands moving only it, each free-floating robot's momentum
// untouched by the others, the world interface listing every robot.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <string>

#include "se3_sim/sim/scene_collision.h"
#include "se3_sim/sim/sim.h"
#include "se3_sim/sim/world.h"
#include "source_paths.h"

using namespace se3;

namespace {

const std::string kRoot = se3_sim_test::source_dir();

Scene scene_of(const std::string& text) {
  return parse_scene(text, kRoot, "two.yaml");
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

// The UR5 and the Panda side by side, fixed, without gravity (nothing moves unless driven).
const char* kTwoArms =
    "gravity: [0, 0, 0]\n"
    "robots:\n"
    "  - name: ur5\n"
    "    urdf: data/robots/ur5_robot.urdf\n"
    "    base: fixed\n"
    "    base_pose: {position: [-0.6, 0, 0]}\n"
    "    initial_positions: {shoulder_lift_joint: -1.2, elbow_joint: 1.0}\n"
    "  - name: panda\n"
    "    urdf: data/robots/panda.urdf\n"
    "    namespace: /panda\n"
    "    base: fixed\n"
    "    base_pose: {position: [0.6, 0, 0], orientation: [0, 0, 1, 0]}\n"
    "    initial_positions: {panda_joint2: 0.5, panda_joint4: -2.0, panda_joint6: 2.5}\n";

// Robot b of two_floating(): a free-floating double pendulum at x = 3, tumbling.
std::string robot_b(const std::string& urdf) {
  return "  - name: b\n"
         "    urdf: " +
         urdf +
         "\n"
         "    base: free\n"
         "    joint_limits: false\n"
         "    base_pose: {position: [3, 0, 0]}\n"
         "    base_twist: [0, 0.4, 0, 0, 0.2, 0]\n"
         "    initial_velocities: {joint1: -1.5}\n";
}

// Two free-floating double pendulums in zero gravity, apart, both tumbling.
std::string two_floating(
    const std::string& second_urdf = "data/robots/double_pendulum_simple.urdf") {
  return "gravity: [0, 0, 0]\nintegrator: rkmk4\ndt: 0.001\n"
         "robots:\n"
         "  - name: a\n"
         "    urdf: data/robots/double_pendulum_simple.urdf\n"
         "    base: free\n"
         "    joint_limits: false\n"
         "    base_twist: [0.3, -0.2, 0.5, 0.1, 0, 0]\n"
         "    initial_velocities: {joint1: 2.0, joint2: -1.0}\n" +
         robot_b(second_urdf) + "    namespace: b\n";
}

}  // namespace

TEST(MultiRobot, SceneRobotsListMakesOneSystemPerRobot) {
  const Scene s = scene_of(kTwoArms);
  EXPECT_EQ(s.robot_name, "ur5");
  EXPECT_EQ(s.robot_namespace, "");
  ASSERT_EQ(s.extra_robots.size(), 1u);
  EXPECT_EQ(s.extra_robots[0].robot_namespace, "panda");  // the leading '/' dropped
  auto sim = make_simulator(s);
  ASSERT_EQ(sim->robot_count(), 2);
  EXPECT_EQ(sim->robot_name(0), "ur5");
  EXPECT_EQ(sim->robot_name(1), "panda");
  EXPECT_EQ(sim->robot_namespace(1), "panda");
  EXPECT_EQ(&sim->robot_model(0), &sim->model());
  EXPECT_EQ(sim->robot_model(1).name, "panda");
  EXPECT_EQ(sim->robot_index("panda"), 1);
  EXPECT_EQ(sim->robot_index("nobody"), -1);
  EXPECT_NEAR(sim->robot_state(1).base.p.x(), 0.6, 1e-15);
  const int j4 = sim->robot_model(1).joint_index("panda_joint4");
  EXPECT_NEAR(sim->robot_state(1).q[sim->robot_model(1).idx_q(j4)], -2.0, 1e-15);
  const auto models = sim->world_models();
  ASSERT_EQ(models.size(), 2u);
  EXPECT_EQ(models[1].name, "panda");
  EXPECT_EQ(models[1].kind, "robot");
  EXPECT_EQ(models[1].ns, "panda");
  EXPECT_TRUE(models[1].is_static);
  // The world interface reads and sets robot 1 as a model.
  ModelState m = sim->model_state("panda");
  EXPECT_EQ(m.q.size(), sim->robot_model(1).n);
  m.q[0] = 0.25;
  sim->set_model_state("panda", m);
  EXPECT_EQ(sim->robot_state(1).q[0], 0.25);
  EXPECT_NE(error_of([&] {
              sim->spawn_object(parse_scene_object("shape: {sphere: 0.1}", ".", "<o>", "panda"));
            }),
            "");
  EXPECT_NE(error_of([&] { sim->delete_model("ur5"); }), "");  // robot 0 stays
  sim->delete_model("panda");  // robots 1.. are deleted (gtest_spawn_robot)
  EXPECT_EQ(sim->robot_count(), 1);
}

TEST(MultiRobot, EachCommandMovesOnlyItsRobot) {
  for (int driven = 0; driven < 2; ++driven) {
    auto sim = make_simulator(scene_of(kTwoArms));
    const State a0 = sim->robot_state(0), b0 = sim->robot_state(1);
    sim->set_robot_joint_effort(driven, 1, 5.0);
    ASSERT_EQ(sim->step_n(200), 200) << sim->failure();
    const State& a = sim->robot_state(0);
    const State& b = sim->robot_state(1);
    const State& moved = driven == 0 ? a : b;
    const State& still = driven == 0 ? b : a;
    const State& moved0 = driven == 0 ? a0 : b0;
    const State& still0 = driven == 0 ? b0 : a0;
    EXPECT_GT(std::abs(moved.q[0] - moved0.q[0]), 1e-3) << "robot " << driven;
    EXPECT_EQ(still.q, still0.q) << "robot " << 1 - driven << " moved";
    EXPECT_EQ(still.v, still0.v);
  }
}

// The command timeout holds for every robot: a torque command (and a free base's wrench) to a
// robot after the first stops acting ceil(timeout / dt) steps after it was set, as robot 0's.
TEST(MultiRobot, CommandTimeoutActsOnEveryRobot) {
  auto sim = make_simulator(scene_of(kTwoArms));
  sim->set_command_timeout(0.005);  // 5 steps of 1 ms
  sim->set_robot_joint_effort(0, 1, 5.0);
  sim->set_robot_joint_effort(1, 1, 5.0);
  ASSERT_EQ(sim->step_n(5), 5) << sim->failure();
  EXPECT_EQ(sim->robot_actuation(0)[0], 5.0);
  EXPECT_EQ(sim->robot_actuation(1)[0], 5.0);
  ASSERT_TRUE(sim->step()) << sim->failure();
  EXPECT_EQ(sim->robot_actuation(0)[0], 0.0);
  EXPECT_EQ(sim->robot_actuation(1)[0], 0.0) << "robot 1's stale command still acts";
  // The robot coasts from then on: its joint rate stays as it was.
  const double rate = sim->robot_state(1).v[0];
  ASSERT_EQ(sim->step_n(20), 20) << sim->failure();
  EXPECT_NEAR(sim->robot_state(1).v[0], rate, 1e-3 * std::abs(rate));
  // A free base's wrench runs out the same way.
  auto free = make_simulator(scene_of(two_floating()));
  free->set_command_timeout(0.002);
  Vec6 w = Vec6::Zero();
  w[5] = 1.0;
  free->set_robot_base_wrench(1, w);
  ASSERT_EQ(free->step_n(2), 2);
  EXPECT_EQ(free->robot_actuation(1)[5], 1.0);
  ASSERT_TRUE(free->step());
  EXPECT_EQ(free->robot_actuation(1)[5], 0.0);
}

// Each free-floating robot keeps its own momentum, and steps exactly as it would alone.
TEST(MultiRobot, FreeFloatingRobotsKeepTheirOwnMomentum) {
  auto sim = make_simulator(scene_of(two_floating()));
  ASSERT_EQ(sim->robot_count(), 2);
  const Vec6 ha = sim->robot_momentum(0), hb = sim->robot_momentum(1);
  sim->set_robot_joint_effort(1, 1, 0.5);  // internal: robot b's momentum stays too
  ASSERT_EQ(sim->step_n(1000), 1000) << sim->failure();
  // rkmk4's truncation error at dt = 1 ms (each robot's internal forces conserve it).
  EXPECT_LT((sim->robot_momentum(0) - ha).norm(), 1e-5 * ha.norm());
  EXPECT_LT((sim->robot_momentum(1) - hb).norm(), 1e-5 * hb.norm());
  EXPECT_GT(
      (sim->robot_state(1).v - make_simulator(scene_of(two_floating()))->robot_state(1).v).norm(),
      1e-3);  // b was driven
  // Robot a alone: the same states, to the bit.
  const Scene s = scene_of(two_floating());
  Scene alone = s;
  alone.extra_robots.clear();
  auto one = make_simulator(alone);
  ASSERT_EQ(one->step_n(1000), 1000) << one->failure();
  EXPECT_EQ(one->state().q, sim->robot_state(0).q);
  EXPECT_EQ(one->state().v, sim->robot_state(0).v);
  EXPECT_EQ(one->state().base.p, sim->robot_state(0).base.p);
}

// `robots:` with one robot is `robot:` and its keys, to the bit.
TEST(MultiRobot, OneEntryOfRobotsIsTheRobotKey) {
  auto listed =
      make_simulator(scene_of("robots:\n  - {urdf: data/robots/panda.urdf, base: fixed,"
                              " initial_positions: {panda_joint2: 0.5}}\n"));
  auto plain = make_simulator(scene_of(
      "robot: data/robots/panda.urdf\nbase: fixed\ninitial_positions: {panda_joint2: 0.5}\n"));
  ASSERT_EQ(listed->robot_count(), 1);
  ASSERT_EQ(listed->step_n(300), 300);
  ASSERT_EQ(plain->step_n(300), 300);
  EXPECT_EQ(listed->state().q, plain->state().q);
  EXPECT_EQ(listed->state().v, plain->state().v);
}

TEST(MultiRobot, ResetAndControllersApplyToEveryRobot) {
  const std::string text = std::string(kTwoArms) +
                           "    controllers:\n"
                           "      hold:\n"
                           "        type: effort_controllers/JointGroupPositionController\n"
                           "        joints: [panda_joint1]\n"
                           "        pid: {p: 100.0, d: 10.0}\n";
  auto sim = make_simulator(scene_of(text));
  ASSERT_NE(sim->robot_controllers(1), nullptr);
  EXPECT_EQ(sim->robot_controllers(0), nullptr);
  const double target = 0.3;
  ControllerSet* c = sim->robot_controllers(1);
  EXPECT_EQ(c->set_command(c->find("hold"), &target, 1), "");
  ASSERT_EQ(sim->step_n(2000), 2000) << sim->failure();
  const Model& pm = sim->robot_model(1);
  const int j1 = pm.joint_index("panda_joint1");
  EXPECT_NEAR(sim->robot_state(1).q[pm.idx_q(j1)], 0.3, 0.01);
  sim->reset();
  EXPECT_EQ(sim->robot_state(1).q[pm.idx_q(j1)], 0.0);
  EXPECT_EQ(sim->time(), 0.0);
}

TEST(MultiRobot, BadRobotsKeysNameFileLineAndKey) {
  const std::string a = "robots:\n  - {urdf: data/robots/panda.urdf}\n";
  EXPECT_NE(error_of([&] {
              scene_of("robot: data/robots/ur5_robot.urdf\n" + a);
            }).find("two.yaml:1: 'robot' is a robot's key"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              scene_of("robots:\n  - {urdf: data/robots/panda.urdf, colour: 1}\n");
            }).find("two.yaml:2: unknown key 'colour' in robots[0]"),
            std::string::npos)
      << error_of([&] { scene_of("robots:\n  - {urdf: data/robots/panda.urdf, colour: 1}\n"); });
  EXPECT_NE(error_of([&] {
              scene_of("robots:\n  - {name: x}\n");
            }).find("two.yaml:2: 'robots[0]' needs urdf"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              scene_of(
                  "robots:\n  - {name: x, urdf: data/robots/panda.urdf}\n"
                  "  - {name: x, urdf: data/robots/panda.urdf}\n");
            }).find("two.yaml:3: 'robots[1].name': robot name 'x' is used twice"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              scene_of(
                  "robots:\n  - {namespace: n, urdf: data/robots/panda.urdf}\n"
                  "  - {namespace: /n, urdf: data/robots/panda.urdf}\n");
            }).find("'robots[1].namespace' 'n' is robots[0]'s too"),
            std::string::npos);
  EXPECT_NE(
      error_of([&] { scene_of("robots:\n  - {urdf: data/robots/none.urdf}\n"); }).find("not found"),
      std::string::npos);
  EXPECT_NE(error_of([&] {
              scene_of("robots:\n  - {urdf: data/robots/panda.urdf, base: wobbly}\n");
            }).find("two.yaml:2: 'base' is free or fixed"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              scene_of("robots:\n  - {urdf: data/robots/panda.urdf, namespace: p}\n");
            }).find("two.yaml:2: 'robots[0].namespace': the first robot is the node's own"),
            std::string::npos);
  EXPECT_NE(error_of([&] { scene_of("robots: []\n"); }).find("needs at least one robot"),
            std::string::npos);
  // Two unnamed copies of one URDF: the second's model name is in use.
  EXPECT_NE(error_of([&] {
              make_simulator(
                  scene_of("robots:\n  - {urdf: data/robots/panda.urdf}\n"
                           "  - {urdf: data/robots/panda.urdf, base_pose: "
                           "{position: [1, 0, 0]}}\n"));
            }).find("two.yaml: robots[1]: robot name 'panda' is already a model's"),
            std::string::npos);
  // A joint the robot lacks names the scene.
  EXPECT_NE(error_of([&] {
              make_simulator(
                  scene_of("robots:\n  - {urdf: data/robots/panda.urdf}\n"
                           "  - {name: u, urdf: data/robots/ur5_robot.urdf, initial_positions: "
                           "{panda_joint1: 1}}\n"));
            }),
            "");
}

// Two pendulums (the double pendulum with its second joint locked) side by side in one plane,
// driven towards each other: their links touch
// (contacts between the two robots' shapes, with an impulse), and each one is held back by the
// other: both stop short of where each swings alone.
namespace {

std::string facing(bool a, bool b) {
  std::string s =
      "gravity: [0, 0, 0]\nintegrator: contact_semi_implicit\ndt: 0.001\n"
      "objects: [{name: far, shape: {sphere: 0.01}, pose: {position: [3, 3, 3]}}]\n"
      "robots:\n";
  if (a) {
    s += "  - {name: a, urdf: data/robots/double_pendulum_simple.urdf, base: fixed,"
         " joint_limits: false, locked_joints: {joint2: 0}, base_pose: {position: [0, -0.2, 0]}}\n";
  }
  if (b) {
    s += std::string("  - {name: b, urdf: data/robots/double_pendulum_simple.urdf, base: fixed,") +
         " joint_limits: false, locked_joints: {joint2: 0}, base_pose: {position: [0, 0.2, 0]}}\n";
  }
  return s;
}

}  // namespace

TEST(MultiRobot, RobotsDrivenTogetherTouchWithForcesOnBoth) {
  auto both = make_simulator(scene_of(facing(true, true)));
  ASSERT_EQ(both->robot_count(), 2);
  auto alone_a = make_simulator(scene_of(facing(true, false)));
  auto alone_b = make_simulator(scene_of(facing(false, true)));
  for (Simulator* s : {both.get(), alone_a.get(), alone_b.get()}) {
    const int b = s == alone_b.get() ? 0 : s->robot_count() - 1;
    if (s != alone_b.get()) s->set_robot_joint_effort(0, 1, -0.2);  // a tilts towards +y
    if (s != alone_a.get()) s->set_robot_joint_effort(b, 1, 0.2);   // b towards -y
  }
  bool touched = false;
  double impulse = 0;
  for (int k = 0; k < 1500; ++k) {
    ASSERT_TRUE(both->step()) << both->failure();
    ASSERT_TRUE(alone_a->step()) << alone_a->failure();
    ASSERT_TRUE(alone_b->step()) << alone_b->failure();
    const auto& objs = *both->contact_objects();
    const ConstraintSystem& cs = *both->constraints();
    for (int c = 0; c < cs.external_count(); ++c) {
      const auto& w = cs.external()[c];
      const int ga = objs[w.a].group, gb = objs[w.b].group;
      if ((ga == 0 && gb == 2) || (ga == 2 && gb == 0)) {
        touched = true;
        impulse = std::max(impulse, w.impulse.norm());
      }
    }
  }
  EXPECT_TRUE(touched);
  EXPECT_GT(impulse, 0);
  const double qa = both->robot_state(0).q[0], qb = both->robot_state(1).q[0];
  const double qa_alone = alone_a->robot_state(0).q[0], qb_alone = alone_b->robot_state(0).q[0];
  EXPECT_LT(qa_alone, -1.5);  // alone, each swings well past the other's place
  EXPECT_GT(qb_alone, 1.5);
  EXPECT_GT(qa, -1.2) << "a passed through b";
  EXPECT_LT(qb, 1.2) << "b passed through a";
  EXPECT_LT(qa, -0.3);  // both did move towards each other
  EXPECT_GT(qb, 0.3);
}

// Robots in a contact scene (a static object far away puts the scene's contact in the collision
// layer): free-floating double pendulums in zero gravity, the first `idle` of them far away and
// still, the next two flying into each other along y (their bases and links meet at y = 0).
namespace {

std::string flying_pair(int idle) {
  std::string s =
      "gravity: [0, 0, 0]\nintegrator: contact_semi_implicit\ndt: 0.001\n"
      "objects: [{name: far, shape: {sphere: 0.01}, pose: {position: [3, 3, 3]}}]\n"
      "robots:\n";
  auto robot = [&](const std::string& name, double y, double vy, double w) {
    s += "  - {name: " + name + ", urdf: data/robots/double_pendulum_simple.urdf, base: free," +
         (s.find("  - {") == std::string::npos ? "" : " namespace: " + name + ",") +
         " joint_limits: false, base_pose: {position: [0, " + std::to_string(y) +
         ", 0]}, base_twist: [0, 0, 0, 0, " + std::to_string(vy) +
         ", 0], initial_velocities: {joint1: " + std::to_string(w) + "}}\n";
  };
  for (int k = 0; k < idle; ++k) robot("idle" + std::to_string(k), -2.0 - k, 0, 0);
  robot("a", -0.1, 0.5, 1.0);
  robot("b", 0.1, -0.5, -0.5);
  return s;
}

}  // namespace

// Two robots flying into each other touch: contacts between their shapes with an impulse, and
// what one robot gains the other loses (equal and opposite impulses: each one's momentum
// changes, the pair's does not), whether the pair is robot 0 and robot 1 or robots 1 and 2.
TEST(MultiRobot, RobotsFlyingTogetherTouchWithEqualAndOppositeImpulses) {
  for (int idle = 0; idle < 2; ++idle) {
    SCOPED_TRACE(idle ? "robots 1 and 2" : "robots 0 and 1");
    auto sim = make_simulator(scene_of(flying_pair(idle)));
    ASSERT_EQ(sim->robot_count(), 2 + idle);
    const int a = idle, b = idle + 1;
    const Vec6 ha = sim->robot_momentum(a), hb = sim->robot_momentum(b);
    const double scale = ha.norm() + hb.norm();
    double impulse = 0;
    for (int k = 0; k < 600; ++k) {
      ASSERT_TRUE(sim->step()) << sim->failure();
      const auto& objs = *sim->contact_objects();
      const ConstraintSystem& cs = *sim->constraints();
      for (int c = 0; c < cs.external_count(); ++c) {
        const auto& w = cs.external()[c];
        const int ga = objs[w.a].group, gb = objs[w.b].group;
        // robot 0's shapes are group 0, robot k's group 1 + k (1: the objects)
        auto robot_of = [](int g) { return g == 0 ? 0 : g >= 2 ? g - 1 : -1; };
        if (std::min(robot_of(ga), robot_of(gb)) == a && std::max(robot_of(ga), robot_of(gb)) == b)
          impulse += w.impulse.norm();
      }
      // The pair's momentum is kept in every step (no force from outside the pair).
      ASSERT_LT((sim->robot_momentum(a) + sim->robot_momentum(b) - ha - hb).norm(), 1e-12 * scale)
          << "step " << k;
    }
    EXPECT_GT(impulse, 1e-3);
    // Each one's momentum changed: equal and opposite.
    const Vec6 da = sim->robot_momentum(a) - ha, db = sim->robot_momentum(b) - hb;
    EXPECT_GT(da.tail<3>().norm(), 0.3 * std::abs(ha[4]));
    EXPECT_LT((da + db).norm(), 1e-12 * scale);
    // They did not pass through each other: a stays on its side (-y), b on its.
    EXPECT_LT(sim->robot_state(a).base.p.y(), sim->robot_state(b).base.p.y());
    EXPECT_LT(sim->robot_momentum(a)[4], 0.5 * ha[4]);  // a's push along +y was (mostly) taken
    for (int k = 0; k < idle; ++k) {                    // robots that touch nothing are not moved
      EXPECT_EQ(sim->robot_state(k).v.norm(), 0);
    }
  }
}

// A robot after the first one lies on the ground and on a box (a static object) as the first one
// does: three free-floating double pendulums (joints locked: a rigid L that rocks on its cube's
// edge and its tip), dropped from 0.2 m above their supports side by side, robot 0 and robot 1
// onto the ground, robot 2 onto the box. Each is held up by its support (alone, robots 1 and 2
// would fall 19 m in 2 s); robot 1 moves as robot 0 does, to rounding.
TEST(MultiRobot, RobotsAfterTheFirstRestOnTheGroundAndOnABox) {
  auto robot = [](const std::string& name, const std::string& ns, double x, double z) {
    return "  - {name: " + name + ", urdf: data/robots/double_pendulum_simple.urdf, base: free," +
           ns + " locked_joints: {joint1: 1.5708, joint2: 0}, base_pose: {position: [" +
           std::to_string(x) + ", 0, " + std::to_string(z) + "]}}\n";
  };
  const std::string text =
      "gravity: [0, 0, -9.81]\nintegrator: contact_semi_implicit\ndt: 0.001\nground: true\n"
      "objects: [{name: block, shape: {box: [0.6, 0.6, 0.2]}, pose: {position: [2, 0, 0.1]}}]\n"
      "robots:\n" +
      robot("a", "", 0, 0.2) + robot("b", " namespace: b,", 1, 0.2) +
      robot("c", " namespace: c,", 2, 0.4);
  auto sim = make_simulator(scene_of(text));
  ASSERT_EQ(sim->robot_count(), 3);
  // Over the last 1.5 s: each base's lowest and highest centre above its support.
  double low[3] = {1, 1, 1}, high[3] = {0, 0, 0}, apart = 0;
  const double support[3] = {0, 0, 0.2};
  for (int k = 0; k < 2000; ++k) {
    ASSERT_TRUE(sim->step()) << sim->failure();
    for (int r = 0; r < 3 && k >= 500; ++r) {
      const double z = sim->robot_state(r).base.p.z() - support[r];
      low[r] = std::min(low[r], z);
      high[r] = std::max(high[r], z);
    }
    const SE3 &a = sim->robot_state(0).base, &b = sim->robot_state(1).base;
    apart = std::max(apart, (b.p - a.p - Vec3(1, 0, 0)).norm() + (b.R - a.R).norm());
  }
  for (int r = 0; r < 3; ++r) {
    SCOPED_TRACE("robot " + std::to_string(r));
    EXPECT_GT(low[r], 0.02);  // the base cube's centre 2.5 cm above the support when flat on it
    EXPECT_LT(high[r], 0.1);
  }
  EXPECT_LT(apart, 1e-12) << "robot 1 does not move as robot 0 does";
  EXPECT_LT(sim->penetration_max(), 5e-3);
}

// A robot that a contact holds stops at its joint limits as in its own steps: the Panda (robot 1)
// turns its joint 1 so that its hand presses on a static box, while its joint 4 is driven into
// its upper limit (-0.0698). The box's contact rows touch it in every step, so the limits are
// rows of the same velocity step.
TEST(MultiRobot, ARobotHeldByAContactStopsAtItsJointLimits) {
  const std::string text =
      "gravity: [0, 0, 0]\nintegrator: contact_semi_implicit\ndt: 0.001\n"
      "objects: [{name: wall, shape: {box: [0.1, 0.1, 0.1]}, pose: {position: [0.5, 0.2, 0.65]}}]\n"
      "robots:\n"
      "  - {name: a, urdf: data/robots/double_pendulum_simple.urdf, base: fixed,"
      " base_pose: {position: [-2, 0, 0]}}\n"
      "  - {name: p, namespace: p, urdf: data/robots/panda.urdf, base: fixed,"
      " locked_joints: {panda_finger_joint1: 0.02, panda_finger_joint2: 0.02},"
      " initial_positions: {panda_joint2: 0.8, panda_joint4: -0.15}}\n";
  auto sim = make_simulator(scene_of(text));
  const Model& m = sim->robot_model(1);
  const int j1 = m.joint_index("panda_joint1"), j4 = m.joint_index("panda_joint4");
  ASSERT_GT(j1, 0);
  ASSERT_GT(j4, 0);
  sim->set_robot_joint_effort(1, j1, 5.0);
  sim->set_robot_joint_effort(1, j4, 5.0);
  double q4 = -10, q4_pressed = -10;  // its largest, and its largest while the hand pressed
  int pressed = 0;
  for (int k = 0; k < 1500; ++k) {
    ASSERT_TRUE(sim->step()) << sim->failure();
    const double q = sim->robot_state(1).q[m.idx_q(j4)];
    q4 = std::max(q4, q);
    const auto& objs = *sim->contact_objects();
    const ConstraintSystem& cs = *sim->constraints();
    bool on_wall = false;
    for (int c = 0; c < cs.external_count(); ++c) {
      const auto& w = cs.external()[c];
      on_wall = on_wall ||
                ((objs[w.a].name == "wall" || objs[w.b].name == "wall") && w.impulse.norm() > 0);
    }
    if (on_wall) ++pressed, q4_pressed = std::max(q4_pressed, q);
  }
  EXPECT_GT(pressed, 100);
  EXPECT_GT(q4_pressed, m.upper[j4] - 0.01);  // joint 4 at its limit while the hand pressed
  EXPECT_LT(q4, m.upper[j4] + 1e-3) << "joint 4 passed its limit";
}

// Every robot's collision follows robot 0's rules: the same URDF as robot 0 and robot 1, its links
// carrying Gazebo tags (selfCollide on `lower`, mu1/mu2, kp/kd, minDepth, maxVel on `base`), the
// scene's self_collision off. Robot 1's shapes (links "b/LINK") may collide with each other
// exactly where robot 0's may (`lower` with `base`, by its tag; never adjacent links), and take
// the same surface; robot 0's may collide with robot 1's.
TEST(MultiRobot, EachRobotsCollisionFollowsTheFirstOnesRules) {
  const std::string urdf = testing::TempDir() + "/multi_robot_tagged.urdf";
  {
    std::ofstream out(urdf);
    out << R"(<robot name="tagged">
  <link name="base"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
  <link name="upper"><inertial><origin xyz="0 0 0.2"/><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.2"/><geometry><box size="0.05 0.05 0.4"/></geometry></collision></link>
  <link name="lower"><inertial><origin xyz="0 0 0.2"/><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.2"/><geometry><box size="0.05 0.05 0.4"/></geometry></collision></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/><origin xyz="0 0 0.05"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="50" velocity="5"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="lower"/><origin xyz="0 0 0.4"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="50" velocity="5"/></joint>
  <gazebo reference="base"><mu1>0.3</mu1><mu2>0.5</mu2><kp>1e6</kp><kd>100</kd>
    <minDepth>0.001</minDepth><maxVel>0.1</maxVel></gazebo>
  <gazebo reference="lower"><selfCollide>true</selfCollide></gazebo>
</robot>)";
  }
  const Scene scene = scene_of(
      "ground: {from_collisions: true}\nintegrator: contact_semi_implicit\nrobots:\n"
      "  - {name: a, urdf: " +
      urdf + ", base: fixed}\n  - {name: b, namespace: b, urdf: " + urdf +
      ", base: fixed, base_pose: {position: [1, 0, 0]}}\n");
  auto sim = make_simulator(scene);
  const SceneCollision sc =
      scene_collision(scene, &sim->model(), nullptr, "", sim->extra_robot_models());
  const auto& objs = sc.model.objects();
  auto index = [&](const std::string& link) {
    for (size_t k = 0; k < objs.size(); ++k) {
      if (objs[k].link == link) return static_cast<int>(k);
    }
    return -1;
  };
  const std::vector<std::string> links = {"base", "upper", "lower"};
  for (const std::string& i : links) {
    const int a = index(i), b = index("b/" + i);
    ASSERT_GE(a, 0) << i;
    ASSERT_GE(b, 0) << i;
    EXPECT_EQ(objs[b].group, 2);
    EXPECT_EQ(objs[b].mu, objs[a].mu) << i;
    EXPECT_EQ(objs[b].mu_own, objs[a].mu_own) << i;
    EXPECT_EQ(objs[b].self_collide, objs[a].self_collide) << i;
    auto same = [](double x, double y) { return x == y || (std::isnan(x) && std::isnan(y)); };
    EXPECT_TRUE(same(objs[b].erp, objs[a].erp)) << i;
    EXPECT_TRUE(same(objs[b].slop, objs[a].slop)) << i;
    EXPECT_TRUE(same(objs[b].max_correction_velocity, objs[a].max_correction_velocity)) << i;
    for (const std::string& j : links) {
      if (i == j) continue;
      EXPECT_EQ(sc.model.may_collide(b, index("b/" + j)), sc.model.may_collide(a, index(j)))
          << i << " - " << j;
      EXPECT_TRUE(sc.model.may_collide(a, index("b/" + j))) << i << " - b/" << j;
    }
  }
  EXPECT_TRUE(sc.model.may_collide(index("b/lower"), index("b/base")));    // its selfCollide
  EXPECT_FALSE(sc.model.may_collide(index("b/lower"), index("b/upper")));  // adjacent
  EXPECT_EQ(objs[index("b/base")].mu, 0.3);
}

namespace {

// Robot b of two_floating() alone, as the node's own robot.
std::string b_alone() {
  return "gravity: [0, 0, 0]\nintegrator: rkmk4\ndt: 0.001\nrobots:\n" +
         robot_b("data/robots/double_pendulum_simple.urdf");
}

}  // namespace

// A link wrench on robot k >= 1 acts on robot k's joints and base (J^T w), as the same wrench on
// the same robot alone: robot 0 does not feel it. Without contact each robot steps on its own;
// with contact (the scene collision) through robot 0's velocity step.
TEST(MultiRobot, LinkWrenchesActOnTheirRobot) {
  auto sim = make_simulator(scene_of(two_floating()));
  auto plain = make_simulator(scene_of(two_floating()));
  auto alone = make_simulator(scene_of(b_alone()));
  const int link2 = sim->robot_model(1).link_index("link2");
  ASSERT_GE(link2, 0);
  const Vec3 p(0.01, 0.02, 0.05);
  Vec6 w;
  w << 0.05, -0.02, 0.01, 0.3, -0.1, 0.2;
  sim->apply_robot_link_wrench(1, link2, p, w, 0.1);  // 100 steps
  alone->apply_link_wrench(alone->model().link_index("link2"), p, w, 0.1);
  EXPECT_EQ(sim->link_wrench_count(), 1);
  ASSERT_EQ(sim->step_n(300), 300) << sim->failure();
  ASSERT_EQ(plain->step_n(300), 300) << plain->failure();
  ASSERT_EQ(alone->step_n(300), 300) << alone->failure();
  EXPECT_EQ(sim->link_wrench_count(), 0);  // ran out
  const State &b = sim->robot_state(1), &b1 = alone->state(), &b0 = plain->robot_state(1);
  EXPECT_LT((b.v - b1.v).norm(), 1e-12);
  EXPECT_LT((b.q - b1.q).norm(), 1e-12);
  EXPECT_LT((b.base.p - b1.base.p).norm(), 1e-12);
  EXPECT_GT((b.v - b0.v).norm(), 1e-2) << "the wrench did not move robot 1";
  EXPECT_EQ(sim->robot_state(0).v, plain->robot_state(0).v) << "robot 0 felt robot 1's wrench";
  EXPECT_EQ(sim->robot_state(0).q, plain->robot_state(0).q);
  // Refusals, and clearing.
  EXPECT_THROW(sim->apply_robot_link_wrench(2, 0, p, w, 1), std::invalid_argument);
  EXPECT_THROW(sim->apply_robot_link_wrench(-1, 0, p, w, 1), std::invalid_argument);
  EXPECT_THROW(
      sim->apply_robot_link_wrench(1, static_cast<int>(sim->robot_model(1).links.size()), p, w, 1),
      std::invalid_argument);
  sim->apply_robot_link_wrench(1, link2, p, w, -1);
  sim->clear_link_wrenches(link2);  // robot 0's link of that index: robot 1's stays
  EXPECT_EQ(sim->link_wrench_count(), 1);
  sim->clear_link_wrenches();
  EXPECT_EQ(sim->link_wrench_count(), 0);
  // A deleted robot's wrenches go with it.
  sim->apply_robot_link_wrench(1, link2, p, w, -1);
  sim->delete_model("b");
  EXPECT_EQ(sim->link_wrench_count(), 0);
  ASSERT_TRUE(sim->step()) << sim->failure();

  // In a contact scene: a torque about joint 1's axis on robot 1's link1 is joint 1's effort.
  auto by_effort = make_simulator(scene_of(facing(true, true)));
  auto by_wrench = make_simulator(scene_of(facing(true, true)));
  ASSERT_EQ(by_wrench->robot_count(), 2);
  const int link1 = by_wrench->robot_model(1).link_index("link1");
  ASSERT_GE(link1, 0);
  Vec6 torque = Vec6::Zero();
  torque[0] = 0.2;  // joint1's axis is x, the base unrotated
  for (Simulator* s : {by_effort.get(), by_wrench.get()}) s->set_robot_joint_effort(0, 1, -0.2);
  by_effort->set_robot_joint_effort(1, 1, 0.2);
  by_wrench->apply_robot_link_wrench(1, link1, Vec3::Zero(), torque, -1);
  bool touched = false;
  for (int k = 0; k < 1500; ++k) {
    ASSERT_TRUE(by_effort->step()) << by_effort->failure();
    ASSERT_TRUE(by_wrench->step()) << by_wrench->failure();
    touched = touched || by_wrench->constraints()->external_count() > 0;
  }
  EXPECT_TRUE(touched);
  EXPECT_LT((by_wrench->robot_state(1).q - by_effort->robot_state(1).q).norm(), 1e-9);
  EXPECT_LT((by_wrench->robot_state(0).q - by_effort->robot_state(0).q).norm(), 1e-9);
  EXPECT_GT(std::abs(by_wrench->robot_state(1).q[0]), 0.05);
}

// Robot k's potential energy is measured from its own initial configuration, as robot 0's.
TEST(MultiRobot, EachRobotsPotentialEnergyIsItsOwn) {
  const std::string text =
      "gravity: [0, 0, -9.81]\nintegrator: rkmk4\ndt: 0.001\n"
      "robots:\n"
      "  - {name: a, urdf: data/robots/double_pendulum_simple.urdf, base: fixed,"
      " joint_limits: false, initial_positions: {joint1: 0.5}}\n"
      "  - {name: b, urdf: data/robots/double_pendulum_simple.urdf, base: fixed,"
      " joint_limits: false, initial_positions: {joint1: 0.5}, base_pose: {position: [0, 1, 3]}}\n";
  auto sim = make_simulator(scene_of(text));
  EXPECT_NEAR(sim->robot_potential_energy(1), 0.0, 1e-12);
  ASSERT_EQ(sim->step_n(200), 200) << sim->failure();
  const double U0 = sim->robot_potential_energy(0), U1 = sim->robot_potential_energy(1);
  EXPECT_LT(U0, -1e-3);  // it swung down
  EXPECT_NEAR(U1, U0, 1e-12);
  EXPECT_NEAR(sim->robot_kinetic_energy(1) + U1, sim->kinetic_energy() + U0, 1e-12);
  EXPECT_EQ(sim->robot_potential_energy(0), sim->potential_energy());
  sim->reset();
  EXPECT_NEAR(sim->robot_potential_energy(1), 0.0, 1e-12);
}

// The efforts a robot after the first publishes (NS/joint_states, NS/chain_state) are the first
// robot's kind: its command plus its joints' damping and friction.
TEST(MultiRobot, EachRobotsAppliedEffortsCountItsDamping) {
  auto sim = make_simulator(scene_of(two_floating()));
  auto alone = make_simulator(scene_of(b_alone()));
  sim->set_robot_joint_effort(1, 1, 0.5);
  alone->set_joint_effort(1, 0.5);
  ASSERT_EQ(sim->step_n(10), 10) << sim->failure();
  ASSERT_EQ(alone->step_n(10), 10) << alone->failure();
  VecX e1, e0;
  sim->robot_applied_joint_efforts(1, e1);
  alone->applied_joint_efforts(e0);
  ASSERT_EQ(e1.size(), 2);
  EXPECT_LT((e1 - e0).norm(), 1e-12);
  EXPECT_GT(std::abs(e1[0] - 0.5), 1e-3) << "no damping in robot 1's efforts";
  VecX a;
  sim->robot_applied_joint_efforts(0, a);
  sim->applied_joint_efforts(e0);
  EXPECT_EQ(a, e0);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
