// Robots spawned and deleted at run time (Simulator::prepare_spawn_robot, prepare_delete,
// commit; src/sim/world.cpp, docs/multi_robot.md): the spawned robot steps from the next step,
// the others run on untouched, a delete removes it, and every bad request is refused with the
// field named and nothing changed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>

#include "se3_sim/sim/sim.h"
#include "se3_sim/sim/world.h"
#include "source_paths.h"

using namespace se3;

namespace {

const std::string kRoot = se3_sim_test::source_dir();

std::string text_of(const std::string& path) {
  std::string text, why;
  EXPECT_TRUE(read_file(kRoot + "/" + path, text, &why)) << why;
  return text;
}

// The UR5 (fixed, under gravity) alone: robot 0.
std::unique_ptr<Simulator> ur5_sim() {
  return make_simulator(
      parse_scene("robot: data/robots/ur5_robot.urdf\nbase: fixed\n"
                  "initial_positions: {shoulder_lift_joint: -1.2}\n",
                  kRoot, "ur5.yaml"));
}

RobotSpawn panda(const std::string& name = "panda") {
  RobotSpawn s;
  s.urdf = text_of("data/robots/panda.urdf");
  s.name = name;
  s.pose.p = Vec3(1.0, 0.5, 0.2);
  s.pose.R = Eigen::AngleAxisd(0.7, Vec3::UnitZ()).toRotationMatrix();
  return s;
}

// The refusal of f: its kind and message (Kind::Invalid and "" when it was accepted).
std::pair<WorldError::Kind, std::string> refusal(const std::function<void()>& f) {
  try {
    f();
  } catch (const WorldError& e) {
    return {e.kind, e.what()};
  }
  return {WorldError::Kind::Invalid, ""};
}

bool same_state(const State& a, const State& b) {
  return a.q == b.q && a.v == b.v && a.base.p == b.base.p && a.base.R == b.base.R;
}

}  // namespace

// A Panda spawned into a running UR5 simulation: listed as a robot with its namespace, at the
// pose asked, its joints at 0 within their limits, its links MODEL::LINK; it falls under
// gravity from the next step (free base: its URDF has no world link), while the UR5 steps
// exactly as it does without the spawn. Deleting it removes it and the UR5 runs on.
TEST(SpawnRobot, SpawnedRobotStepsAndDeleteRemovesIt) {
  auto sim = ur5_sim();
  auto twin = ur5_sim();
  sim->step_n(20);
  twin->step_n(20);
  const State before = sim->state();
  RobotSpawn s = panda();
  s.ns = "arm2";
  WorldEditPtr edit = sim->prepare_spawn_robot(s);
  const WorldEditInfo info = edit_info(edit);
  EXPECT_TRUE(info.robot);
  EXPECT_EQ(info.spawned, "panda");
  ASSERT_NE(info.robot_model, nullptr);
  EXPECT_TRUE(info.robot_model->floating);
  EXPECT_EQ(sim->robot_count(), 1);  // prepared, not committed
  EXPECT_EQ(sim->commit(std::move(edit)), "");
  ASSERT_EQ(sim->robot_count(), 2);
  EXPECT_EQ(sim->spawned(), 1u);
  EXPECT_TRUE(same_state(sim->state(), before));
  const int k = sim->robot_index("panda");
  ASSERT_EQ(k, 1);
  EXPECT_EQ(sim->robot_namespace(k), "arm2");
  bool listed = false;
  for (const WorldModel& m : sim->world_models()) {
    if (m.name == "panda") {
      listed = true;
      EXPECT_EQ(m.kind, "robot");
      EXPECT_EQ(m.ns, "arm2");
      EXPECT_FALSE(m.is_static);
    }
  }
  EXPECT_TRUE(listed);
  const Model& m = sim->robot_model(k);
  const State& x = sim->robot_state(k);
  EXPECT_TRUE(x.base.p.isApprox(s.pose.p, 0));
  EXPECT_TRUE(x.base.R.isApprox(s.pose.R, 0));
  for (int i = 1; i <= m.n; ++i) {
    EXPECT_GE(x.q[m.idx_q(i)], m.lower[i]) << m.joint_name[i];
    EXPECT_LE(x.q[m.idx_q(i)], m.upper[i]) << m.joint_name[i];
  }
  const LinkState root = sim->link_state("panda::panda_link0");
  EXPECT_LT((root.pose.p - s.pose.p).norm(), 1e-12);
  bool hand = false;
  for (const std::string& l : sim->link_names()) hand = hand || l == "panda::panda_hand";
  EXPECT_TRUE(hand);

  ASSERT_EQ(sim->step_n(100), 100);
  ASSERT_EQ(twin->step_n(100), 100);
  EXPECT_TRUE(same_state(sim->state(), twin->state()));  // the UR5 steps as without the spawn
  const ModelState fell = sim->model_state("panda");
  // Free fall, g t^2 / 2 (its joint at a limit makes the steps velocity-level ones: O(g t dt)).
  EXPECT_NEAR(fell.pose.p.z(), 0.2 - 0.5 * 9.81 * 0.1 * 0.1, 1e-3);
  EXPECT_LT(fell.pose.p.z(), 0.2 - 0.5 * 9.81 * 0.1 * 0.1 + 1e-6);

  // set_model_state works on it.
  ModelState put = fell;
  put.pose.p = Vec3(2, 0, 1);
  put.twist.setZero();
  EXPECT_EQ(sim->set_model_state("panda", put), "");
  EXPECT_LT((sim->model_state("panda").pose.p - Vec3(2, 0, 1)).norm(), 1e-15);

  sim->commit(sim->prepare_delete("panda"));
  EXPECT_EQ(sim->robot_count(), 1);
  EXPECT_EQ(sim->deleted(), 1u);
  EXPECT_EQ(refusal([&] { sim->model_state("panda"); }).first, WorldError::Kind::NotFound);
  for (const std::string& l : sim->link_names()) EXPECT_EQ(l.find("panda::"), std::string::npos);
  ASSERT_EQ(sim->step_n(50), 50);
  ASSERT_EQ(twin->step_n(50), 50);
  EXPECT_TRUE(same_state(sim->state(), twin->state()));
  // Robot 0 is not deletable; the name is free again.
  EXPECT_NE(refusal([&] { sim->prepare_delete(sim->robot_name()); }).second, "");
  EXPECT_EQ(sim->spawn_robot(panda()), "panda");
}

// A robot spawned beside robots 1.. leaves them where they are (they are not reset); a fixed
// base stays at its pose; the name defaults to the URDF's.
TEST(SpawnRobot, SpawnKeepsTheOtherRobotsStates) {
  auto sim = ur5_sim();
  RobotSpawn a = panda("");
  a.base = RobotSpawn::Base::Fixed;
  EXPECT_EQ(sim->spawn_robot(a), "panda");
  ASSERT_EQ(sim->step_n(200), 200);
  const State moved = sim->robot_state(1);
  EXPECT_GT(moved.v.norm(), 0);  // it swings under gravity
  RobotSpawn b = panda("panda_b");
  b.pose.p.x() = -1;
  sim->spawn_robot(b);
  EXPECT_TRUE(same_state(sim->robot_state(1), moved));
  EXPECT_TRUE(sim->robot_state(1).base.p.isApprox(a.pose.p, 0));
  EXPECT_FALSE(sim->robot_model(1).floating);
  // Deleting the first moves the second down to index 1.
  sim->delete_model("panda");
  EXPECT_EQ(sim->robot_index("panda_b"), 1);
  ASSERT_EQ(sim->step_n(10), 10);
}

// Every bad request is refused naming the field, nothing changes and the simulation runs on.
TEST(SpawnRobot, BadRequestsAreRefusedAndChangeNothing) {
  auto sim = ur5_sim();
  sim->spawn_robot(panda());
  sim->step_n(10);
  const std::uint64_t gen = sim->world_generation();
  const State x0 = sim->state(), x1 = sim->robot_state(1);
  auto expect_refused = [&](const RobotSpawn& s, WorldError::Kind kind, const std::string& field) {
    const auto r = refusal([&] { sim->prepare_spawn_robot(s); });
    EXPECT_EQ(r.first, kind) << r.second;
    EXPECT_NE(r.second.find(field), std::string::npos) << r.second;
    EXPECT_EQ(sim->robot_count(), 2);
    EXPECT_EQ(sim->world_generation(), gen);
    EXPECT_TRUE(same_state(sim->state(), x0));
    EXPECT_TRUE(same_state(sim->robot_state(1), x1));
  };
  RobotSpawn bad = panda("p2");
  bad.urdf = "<robot name='x'><link name='a'></robot>";
  expect_refused(bad, WorldError::Kind::Resource, "urdf");
  bad.urdf = "";
  expect_refused(bad, WorldError::Kind::Resource, "urdf");
  bad.urdf = "not xml at all";
  expect_refused(bad, WorldError::Kind::Resource, "urdf");
  expect_refused(panda("panda"), WorldError::Kind::NameInUse, "name 'panda'");
  expect_refused(panda(sim->robot_name()), WorldError::Kind::NameInUse, "name");
  expect_refused(panda("a b"), WorldError::Kind::NameInvalid, "name");
  RobotSpawn ns = panda("p3");
  ns.ns = "panda";  // robot 1's namespace (its name)
  expect_refused(ns, WorldError::Kind::NameInUse, "namespace 'panda'");
  ns.ns = "bad ns";
  expect_refused(ns, WorldError::Kind::NameInvalid, "namespace");
  RobotSpawn pose = panda("p4");
  pose.pose.p.x() = std::numeric_limits<double>::quiet_NaN();
  expect_refused(pose, WorldError::Kind::InvalidPose, "pose");
  pose = panda("p4");
  pose.pose.R(0, 0) = std::numeric_limits<double>::infinity();
  expect_refused(pose, WorldError::Kind::InvalidPose, "pose");
  pose = panda("p4");
  pose.pose.R *= 2;
  expect_refused(pose, WorldError::Kind::InvalidPose, "pose.orientation");
  EXPECT_EQ(refusal([&] { sim->prepare_delete("nobody"); }).first, WorldError::Kind::NotFound);
  // An edit prepared before another commit is stale.
  WorldEditPtr late = sim->prepare_spawn_robot(panda("p5"));
  sim->spawn_robot(panda("p6"));
  EXPECT_EQ(refusal([&] { sim->commit(std::move(late)); }).first, WorldError::Kind::Stale);
  EXPECT_EQ(sim->robot_count(), 3);
  EXPECT_EQ(sim->step_n(20), 20);
  EXPECT_EQ(sim->failure(), "");
}

namespace {

// A scene of robot "a" (the double pendulum, free base, 0.2 m above the ground at x = 0), a
// static block 0.2 m high at x = 2, the ground, and `robots` (YAML robots: entries) after "a".
std::unique_ptr<Simulator> pendulums(const std::string& robots = "") {
  const std::string text =
      "gravity: [0, 0, -9.81]\nintegrator: contact_semi_implicit\ndt: 0.001\nground: true\n"
      "objects: [{name: block, shape: {box: [0.6, 0.6, 0.2]}, pose: {position: [2, 0, 0.1]}}]\n"
      "robots:\n"
      "  - {name: a, urdf: data/robots/double_pendulum_simple.urdf, base: free,"
      " base_pose: {position: [0, 0, 0.2]}}\n" +
      robots;
  return make_simulator(parse_scene(text, kRoot, "pendulums.yaml"));
}

RobotSpawn pendulum(const std::string& name, double x, double z) {
  RobotSpawn s;
  s.urdf = text_of("data/robots/double_pendulum_simple.urdf");
  s.name = name;
  s.pose.p = Vec3(x, 0, z);
  s.base = RobotSpawn::Base::Free;
  return s;
}

// The contacts at the current state as text (the pair's names, depth, point and normal), one
// a line, sorted: the same contacts whatever their order.
std::vector<std::string> contact_lines(const Simulator& sim) {
  std::vector<std::string> out;
  const std::vector<CollisionObject>& o = *sim.contact_objects();
  for (const Contact& c : sim.contacts()) {
    char buf[256];
    std::snprintf(buf, sizeof buf, " %.12f %.12f %.12f %.12f %.9f %.9f %.9f", c.depth, c.point.x(),
                  c.point.y(), c.point.z(), c.normal.x(), c.normal.y(), c.normal.z());
    out.push_back(o[c.a].name + " " + o[c.b].name + buf);
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

// Robots spawned into a scene with collision collide as the scene's own robots 1.. do: their
// shapes join the scene collision (a group of their own), so "b" dropped on the ground and "c"
// dropped on the block come to rest on them, step for step as the same robots listed in the
// scene's robots: do.
TEST(SpawnRobot, SpawnedRobotsCollideAsSceneRobots) {
  const std::string b =
      "  - {name: b, urdf: data/robots/double_pendulum_simple.urdf, base: free,"
      " base_pose: {position: [1, 0, 0.2]}}\n";
  const std::string c =
      "  - {name: c, urdf: data/robots/double_pendulum_simple.urdf, base: free,"
      " base_pose: {position: [2, 0, 0.45]}}\n";
  auto scene = pendulums(b + c);
  auto sim = pendulums();
  EXPECT_EQ(sim->spawn_robot(pendulum("b", 1, 0.2)), "b");
  EXPECT_EQ(sim->spawn_robot(pendulum("c", 2, 0.45)), "c");
  ASSERT_EQ(sim->robot_count(), 3);
  int shapes = 0;
  for (const CollisionObject& o : *sim->contact_objects()) {
    shapes += o.name.compare(0, 2, "c/") == 0;
  }
  EXPECT_EQ(shapes, 3);  // c's three links
  double worst = 0;
  for (int k = 0; k < 1500; ++k) {
    ASSERT_TRUE(sim->step()) << sim->failure();
    ASSERT_TRUE(scene->step()) << scene->failure();
    for (int r = 0; r < 3; ++r) {
      const State &x = sim->robot_state(r), &y = scene->robot_state(r);
      worst =
          std::max({worst, (x.base.p - y.base.p).norm(), (x.q - y.q).norm(), (x.v - y.v).norm()});
    }
  }
  EXPECT_LT(worst, 1e-9) << "a spawned robot does not step as the same robot of the scene";
  // At rest on the ground (b) and on the block's top at z = 0.2 (c): not fallen through.
  EXPECT_GT(sim->robot_state(1).base.p.z(), 0.0);
  EXPECT_LT(sim->robot_state(1).base.p.z(), 0.1);
  EXPECT_GT(sim->robot_state(2).base.p.z(), 0.2);
  EXPECT_LT(sim->robot_state(2).base.p.z(), 0.3);
  EXPECT_LT(sim->penetration_max(), 5e-3);
}

// Deleting a robot from a scene with collision removes its shapes: the others' contacts at the
// same state are the same (the robots after it keep theirs though their frames move down), and
// they stay on their supports (their free joints swing on); a new spawn lands as the first did.
TEST(SpawnRobot, DeleteFromASceneWithCollisionKeepsTheOthersContacts) {
  auto sim = pendulums(
      "  - {name: b, urdf: data/robots/double_pendulum_simple.urdf, base: free,"
      " base_pose: {position: [1, 0, 0.2]}}\n");
  sim->spawn_robot(pendulum("c", 2, 0.45));
  ASSERT_EQ(sim->step_n(1500), 1500) << sim->failure();
  auto without = [](std::vector<std::string> lines, const std::string& robot) {
    lines.erase(std::remove_if(lines.begin(), lines.end(),
                               [&](const std::string& l) {
                                 return l.compare(0, robot.size() + 1, robot + "/") == 0 ||
                                        l.find(" " + robot + "/") != std::string::npos;
                               }),
                lines.end());
    return lines;
  };
  const std::vector<std::string> before = contact_lines(*sim);
  ASSERT_FALSE(without(before, "b").empty());
  // Robot k's base on its support: above the ground (z = 0) or the block's top (z = 0.2), not
  // through it.
  auto on = [&](int k, double support) {
    const double z = sim->robot_state(k).base.p.z() - support;
    return z > 0 && z < 0.1;
  };
  WorldEditPtr edit = sim->prepare_delete("b");  // the scene's robot between a and c
  EXPECT_EQ(sim->robot_count(), 3);
  sim->commit(std::move(edit));
  ASSERT_EQ(sim->robot_count(), 2);
  EXPECT_EQ(sim->robot_index("c"), 1);
  EXPECT_EQ(contact_lines(*sim), without(before, "b"));
  for (const CollisionObject& o : *sim->contact_objects()) {
    EXPECT_NE(o.name.compare(0, 2, "b/"), 0) << o.name;
  }
  ASSERT_EQ(sim->step_n(500), 500) << sim->failure();
  EXPECT_TRUE(on(0, 0));
  EXPECT_TRUE(on(1, 0.2));
  // Objects spawn and go in a scene whose robots touch each other: the robots' frames after the
  // free objects' move with their count, and c stays on the block.
  sim->spawn_object(parse_scene_object(
      "{name: ball, shape: {sphere: 0.05}, mass: 0.5, pose: {position: [-1, 0, 0.3]}}", kRoot));
  ASSERT_EQ(sim->step_n(500), 500) << sim->failure();
  EXPECT_NEAR(sim->model_state("ball").pose.p.z(), 0.05, 5e-3);
  EXPECT_TRUE(on(0, 0));
  EXPECT_TRUE(on(1, 0.2));
  sim->delete_model("ball");
  ASSERT_EQ(sim->step_n(200), 200) << sim->failure();
  EXPECT_TRUE(on(1, 0.2));
  sim->delete_model("c");
  EXPECT_EQ(sim->robot_count(), 1);
  sim->spawn_robot(pendulum("d", 1, 0.2));
  ASSERT_EQ(sim->step_n(1000), 1000) << sim->failure();
  EXPECT_TRUE(on(1, 0));
}

// The Panda's collision meshes load off the step (as convex hulls) when it is spawned into a
// scene with collision.
TEST(SpawnRobot, SpawnedMeshesBecomeHulls) {
  auto sim = pendulums();
  RobotSpawn p = panda();
  p.base = RobotSpawn::Base::Fixed;
  p.geometry.paths.package_path = {kRoot + "/data/meshes"};
  WorldEditPtr edit = sim->prepare_spawn_robot(p);
  sim->commit(std::move(edit));
  int hulls = 0;
  const std::vector<CollisionObject>& objects = *sim->contact_objects();
  for (size_t i = 0; i < objects.size(); ++i) {
    const Shape& s = objects[i].shape;
    if (objects[i].name.compare(0, 6, "panda/") == 0 && s.type == ShapeType::Mesh) {
      EXPECT_TRUE(s.mesh && s.mesh->triangle_count() > 0) << objects[i].name;
      ++hulls;
    }
  }
  EXPECT_GE(hulls, 8);
  ASSERT_EQ(sim->step_n(100), 100) << sim->failure();
  // A mesh that cannot be found is refused with the link named, nothing changed.
  RobotSpawn lost = panda("lost");
  lost.geometry.paths.package_path.clear();
  lost.geometry.paths.use_ros_package_path = false;
  const auto r = refusal([&] { sim->prepare_spawn_robot(lost); });
  EXPECT_EQ(r.first, WorldError::Kind::Resource) << r.second;
  EXPECT_NE(r.second.find("link"), std::string::npos) << r.second;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
