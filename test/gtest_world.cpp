// The Simulator's world interface (world.h, src/sim/world.cpp): models, spawn and delete between
// steps, model and link states, reset of the world.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>

#include "se3_sim/sim/sim.h"
#include "se3_sim/sim/world.h"
#include "source_paths.h"

using namespace se3;

namespace {

const std::string kRoot = se3_sim_test::source_dir();

std::unique_ptr<Simulator> sim_of(const std::string& text) {
  return make_simulator(parse_scene(text, kRoot, "w.yaml"));
}

// A free-base chain with the ground and a table: contact through the collision layer.
const char* kScene =
    "robot: chain:3\nbase: free\nbase_pose: {position: [0, 0, 2]}\n"
    "integrator: contact_semi_implicit\ndt: 0.001\n"
    "ground: {normal: [0, 0, 1], offset: 0.0, mu: 0.8}\n"
    "objects:\n"
    "  - {name: table, shape: {box: [1, 1, 0.1]}, pose: {position: [3, 0, 0.05]}}\n"
    "  - {name: box, shape: {box: [0.1, 0.1, 0.1]}, mass: 1, pose: {position: [3, 0, 0.15]}}\n";

const char* kBall =
    "name: ball\nshape: {sphere: 0.05}\nmass: 0.5\n"
    "pose: {position: [-2, 1, 3]}\ntwist: [0, 0, 0, 0.5, 0, 1]\n";

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

SE3 pose_of(double x, double y, double z, const Vec3& axis, double angle) {
  return SE3(Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix(), Vec3(x, y, z));
}

}  // namespace

TEST(World, ListsTheRobotAndTheObjects) {
  auto sim = sim_of(kScene);
  const auto models = sim->world_models();
  ASSERT_EQ(models.size(), 3u);
  EXPECT_EQ(models[0].kind, "robot");
  EXPECT_EQ(models[0].name, sim->robot_name());
  EXPECT_FALSE(models[0].name.empty());
  EXPECT_EQ(models[1].name, "table");
  EXPECT_TRUE(models[1].is_static);
  EXPECT_EQ(models[2].name, "box");
  EXPECT_EQ(models[2].kind, "object");
  EXPECT_FALSE(models[2].is_static);
  // A scene of objects alone has no robot model.
  auto objects = sim_of("ground: true\nobjects:\n  - {name: a, shape: {sphere: 0.1}, mass: 1}\n");
  ASSERT_EQ(objects->world_models().size(), 1u);
  EXPECT_EQ(objects->world_models()[0].name, "a");
}

TEST(World, ParsesAnObjectFromTheSceneKeys) {
  const SceneObject o = parse_scene_object(kBall, kRoot);
  EXPECT_EQ(o.name, "ball");
  EXPECT_FALSE(o.is_static);
  EXPECT_DOUBLE_EQ(o.mass, 0.5);
  EXPECT_DOUBLE_EQ(o.pose.p.z(), 3);
  const std::string e = error_of([] { parse_scene_object("name: x\nshape: {sphere: -1}\n", "."); });
  EXPECT_NE(e.find("<object>:2:"), std::string::npos) << e;
  EXPECT_NE(e.find("shape.sphere"), std::string::npos) << e;
  EXPECT_NE(error_of([] {
              parse_scene_object("name: x\nshape: {sphere: 1}\nwings: 2\n", ".");
            }).find("wings"),
            std::string::npos);
}

// A spawned object falls as the same object in the scene from the start does: the same
// trajectory (its own closed-form free flight, the same step), and as a free body should.
TEST(World, SpawnedObjectFallsAsAFreeBody) {
  const std::string base = "robot: chain:2\ndt: 0.001\ngravity: [0, 0, -9.81]\n";
  auto spawned = sim_of(base);
  auto scened = sim_of(base + "objects:\n  - {" +
                       "name: ball, shape: {sphere: 0.05}, mass: 0.5, pose: {position: [-2, 1, "
                       "3]}, twist: [0, 0, 0, 0.5, 0, 1]}\n");
  ASSERT_EQ(spawned->step_n(50), 50);
  const double t0 = spawned->time();
  EXPECT_EQ(spawned->spawn_object(parse_scene_object(kBall, kRoot)), "");
  EXPECT_EQ(spawned->spawned(), 1u);
  EXPECT_EQ(spawned->world_models().back().name, "ball");
  // At once: the state it was spawned with.
  const ModelState s0 = spawned->model_state("ball");
  EXPECT_NEAR((s0.pose.p - Vec3(-2, 1, 3)).norm(), 0, 1e-15);
  EXPECT_NEAR((s0.twist.tail<3>() - Vec3(0.5, 0, 1)).norm(), 0, 1e-15);
  const int N = 300;
  ASSERT_EQ(spawned->step_n(N), N) << spawned->failure();
  ASSERT_EQ(scened->step_n(N), N) << scened->failure();
  EXPECT_NEAR(spawned->time() - t0, N * 0.001, 1e-12);
  const ModelState a = spawned->model_state("ball"), b = scened->model_state("ball");
  EXPECT_NEAR((a.pose.p - b.pose.p).norm(), 0, 1e-12);
  EXPECT_NEAR((a.twist - b.twist).norm(), 0, 1e-12);
  // Free flight: v = v0 + g t exactly, p within the step's O(dt) of p0 + v0 t + g t^2 / 2.
  const double t = N * 0.001;
  EXPECT_NEAR(a.twist[5], 1 - 9.81 * t, 1e-9);
  EXPECT_NEAR(a.twist[3], 0.5, 1e-12);
  EXPECT_NEAR(a.pose.p.x(), -2 + 0.5 * t, 1e-9);
  EXPECT_NEAR(a.pose.p.z(), 3 + t - 0.5 * 9.81 * t * t, 0.5 * 9.81 * t * 0.001 + 1e-9);
  EXPECT_LT(a.pose.p.z(), 3 + t - 0.5 * 9.81 * t * t + 0.5 * 9.81 * t * 0.001 + 1e-9);
}

// A spawned object lands on the ground and a static one, and on the robot's shapes.
TEST(World, SpawnedObjectTouchesTheWorld) {
  auto sim = sim_of(kScene);
  SceneObject o = parse_scene_object(
      "name: cube\nshape: {box: [0.1, 0.1, 0.1]}\nmass: 0.2\npose: {position: [3.2, 0.2, 0.4]}\n",
      kRoot);
  sim->spawn_object(o);
  ASSERT_EQ(sim->step_n(1500), 1500) << sim->failure();
  // On the table (top at 0.1): the cube's centre 0.05 above it.
  EXPECT_NEAR(sim->model_state("cube").pose.p.z(), 0.15, 5e-3);
  EXPECT_LT(sim->model_state("cube").twist.norm(), 1e-2);
}

TEST(World, DeleteKeepsTheOthersStates) {
  auto sim = sim_of(kScene);
  sim->spawn_object(parse_scene_object(kBall, kRoot));
  ASSERT_EQ(sim->step_n(100), 100) << sim->failure();
  const ModelState ball = sim->model_state("ball");
  const ModelState robot = sim->model_state(sim->robot_name());
  sim->delete_model("box");
  EXPECT_EQ(sim->deleted(), 1u);
  ASSERT_EQ(sim->world_models().size(), 3u);
  EXPECT_EQ(sim->world_models()[2].name, "ball");
  EXPECT_EQ((sim->model_state("ball").pose.p - ball.pose.p).norm(), 0);
  EXPECT_EQ((sim->model_state(sim->robot_name()).q - robot.q).norm(), 0);
  EXPECT_NE(error_of([&] { sim->model_state("box"); }).find("'box': no such model"),
            std::string::npos);
  ASSERT_EQ(sim->step_n(100), 100) << sim->failure();
  EXPECT_LT(sim->model_state("ball").pose.p.z(), ball.pose.p.z());
  // A static object too; then the last free one.
  sim->delete_model("table");
  sim->delete_model("ball");
  EXPECT_EQ(sim->world_models().size(), 1u);
  EXPECT_TRUE(sim->objects().empty());
  ASSERT_EQ(sim->step_n(100), 100) << sim->failure();
}

// Prepared off the step, committed between steps; a stale edit is refused.
TEST(World, PrepareThenCommitBetweenSteps) {
  auto sim = sim_of(kScene);
  WorldEditPtr e = sim->prepare_spawn(parse_scene_object(kBall, kRoot));
  EXPECT_EQ(sim->world_models().size(), 3u);  // nothing yet
  ASSERT_EQ(sim->step_n(20), 20);
  sim->commit(std::move(e));
  EXPECT_EQ(sim->world_models().size(), 4u);
  WorldEditPtr stale = sim->prepare_delete("ball");
  sim->delete_model("box");
  const std::uint64_t g = sim->world_generation();
  EXPECT_NE(error_of([&] { sim->commit(std::move(stale)); }).find("changed"), std::string::npos);
  EXPECT_EQ(sim->world_generation(), g);
  EXPECT_EQ(sim->world_models().size(), 3u);
}

TEST(World, ModelStateRoundTrips) {
  auto sim = sim_of(kScene);
  const std::string robot = sim->robot_name();
  ModelState r = sim->model_state(robot);
  ASSERT_EQ(r.q.size(), 3);
  ASSERT_EQ(r.v.size(), 3);
  r.pose = pose_of(0.3, -0.2, 1.5, Vec3(1, 2, 3), 0.7);
  r.twist << 0.1, -0.2, 0.3, 0.4, 0.5, -0.6;
  r.q << 0.1, -0.5, 0.9;
  r.v << 1, -2, 3;
  sim->set_model_state(robot, r);
  const ModelState r2 = sim->model_state(robot);
  EXPECT_LT((r2.pose.p - r.pose.p).norm(), 1e-12);
  EXPECT_LT((r2.pose.R - r.pose.R).norm(), 1e-12);
  EXPECT_LT((r2.twist - r.twist).norm(), 1e-12);
  EXPECT_LT((r2.q - r.q).norm(), 1e-12);
  EXPECT_LT((r2.v - r.v).norm(), 1e-12);
  ModelState b;
  b.pose = pose_of(2, 2, 1, Vec3(0, 1, 1), -1.1);
  b.twist << 1, 0, -1, 0.2, 0.3, 0.4;
  EXPECT_EQ(sim->set_model_state("box", b), "");
  const ModelState b2 = sim->model_state("box");
  EXPECT_LT((b2.pose.p - b.pose.p).norm(), 1e-12);
  EXPECT_LT((b2.pose.R - b.pose.R).norm(), 1e-12);
  EXPECT_LT((b2.twist - b.twist).norm(), 1e-12);
  // A static object moves to its new place.
  ModelState t;
  t.pose = pose_of(-3, 0, 0.05, Vec3(0, 0, 1), 0.5);
  sim->set_model_state("table", t);
  EXPECT_LT((sim->model_state("table").pose.p - t.pose.p).norm(), 1e-15);
  ASSERT_EQ(sim->step_n(10), 10) << sim->failure();
  // Link states: the object's is its model's; a relative one of a link to itself is zero.
  const LinkState lb = sim->link_state("box");
  EXPECT_LT((lb.pose.p - sim->model_state("box").pose.p).norm(), 1e-15);
  const auto links = sim->link_names();
  ASSERT_GE(links.size(), 4u);
  const LinkState self = sim->link_state(links[1], links[1]);
  EXPECT_LT(self.pose.p.norm() + (self.pose.R - Mat3::Identity()).norm(), 1e-12);
  EXPECT_LT(self.twist.norm(), 1e-12);
  EXPECT_LT(
      (sim->link_state(robot + "::" + links[1]).pose.p - sim->link_state(links[1]).pose.p).norm(),
      1e-15);
}

// A link's twist: with the joints at rest, the robot moves rigidly with its base; and a link
// relative to another is the relative pose and its derivative.
TEST(World, LinkStatesAreTheRigidMotion) {
  auto sim = sim_of(kScene);
  const std::string robot = sim->robot_name();
  ModelState r = sim->model_state(robot);
  r.pose = pose_of(0.3, -0.2, 1.5, Vec3(1, 2, 3), 0.7);
  r.twist << 0.1, -0.2, 0.3, 0.4, 0.5, -0.6;
  r.q << 0.1, -0.5, 0.9;
  r.v.setZero();
  sim->set_model_state(robot, r);
  const std::vector<std::string> links = sim->link_names();
  const LinkState base = sim->link_state(links[0]);
  EXPECT_LT((base.twist - r.twist).norm(), 1e-12);
  const Vec3 w = r.twist.head<3>(), v0 = r.twist.tail<3>();
  for (int k = 1; k < 4; ++k) {
    const LinkState L = sim->link_state(links[k]);
    EXPECT_LT((L.twist.head<3>() - w).norm(), 1e-12) << links[k];
    EXPECT_LT((L.twist.tail<3>() - (v0 + w.cross(L.pose.p - r.pose.p))).norm(), 1e-12) << links[k];
    // Rigid: nothing moves relative to the base.
    const LinkState rel = sim->link_state(links[k], links[0]);
    EXPECT_LT(rel.twist.norm(), 1e-12) << links[k];
    EXPECT_LT((rel.pose.p - (base.pose.inverse() * L.pose).p).norm(), 1e-12);
  }
  // Only the joints move: the last link relative to the base, by a finite difference of the
  // relative pose over a small joint motion.
  ModelState j = r;
  j.twist.setZero();
  j.v << 0.3, -0.2, 0.5;
  sim->set_model_state(robot, j);
  const LinkState rel = sim->link_state(links[3], links[0]);
  const double h = 1e-6;
  ModelState jh = j;
  jh.q += h * j.v;
  sim->set_model_state(robot, jh);
  const LinkState relh = sim->link_state(links[3], links[0]);
  EXPECT_LT(((relh.pose.p - rel.pose.p) / h - rel.twist.tail<3>()).norm(), 1e-5);
  // The root link is settable; another link is not.
  LinkState root = base;
  root.pose.p.z() += 1;
  sim->set_link_state(links[0], root);
  EXPECT_NEAR(sim->model_state(robot).pose.p.z(), base.pose.p.z() + 1, 1e-15);
  EXPECT_NE(error_of([&] { sim->set_link_state(links[2], root); }).find("root link"),
            std::string::npos);
}

TEST(World, InterpenetratingStateIsAcceptedAndReported) {
  auto sim = sim_of(kScene);
  ModelState b = sim->model_state("box");
  b.pose.p = Vec3(3, 0, 0.13);  // 0.02 into the table
  const std::string report = sim->set_model_state("box", b);
  EXPECT_NE(report.find("'table'"), std::string::npos) << report;
  EXPECT_NE(report.find("'box'"), std::string::npos) << report;
  EXPECT_NE(report.find("interpenetrate by 0.02"), std::string::npos) << report;
  EXPECT_EQ(sim->model_state("box").pose.p.z(), 0.13);
  ASSERT_EQ(sim->step_n(500), 500) << sim->failure();
  EXPECT_GT(sim->model_state("box").pose.p.z(), 0.14);  // pushed out
  // A spawn into the table is accepted and reported too.
  SceneObject o = parse_scene_object(kBall, kRoot);
  o.pose.p = Vec3(3.3, 0.3, 0.1);
  const std::string spawned = sim->spawn_object(o);
  EXPECT_NE(spawned.find("'ball'"), std::string::npos) << spawned;
  EXPECT_NE(spawned.find("interpenetrate by 0.05"), std::string::npos) << spawned;
}

TEST(World, BadRequestsChangeNothing) {
  auto sim = sim_of(kScene);
  ASSERT_EQ(sim->step_n(10), 10);
  const std::uint64_t g = sim->world_generation();
  const ModelState robot = sim->model_state(sim->robot_name());
  const ModelState box = sim->model_state("box");
  const SceneObject ball = parse_scene_object(kBall, kRoot);
  auto refused = [&](const std::function<void()>& f, const std::string& why) {
    const std::string e = error_of(f);
    EXPECT_NE(e.find(why), std::string::npos) << "'" << e << "' lacks '" << why << "'";
  };
  SceneObject o = ball;
  o.name = "box";
  refused([&] { sim->spawn_object(o); }, "'box' is already a model's");
  o.name = sim->robot_name();
  refused([&] { sim->spawn_object(o); }, "is already a model's");
  o.name = "a/b";
  refused([&] { sim->spawn_object(o); }, "not a frame name");
  o = ball;
  o.pose.p.x() = std::nan("");
  refused([&] { sim->spawn_object(o); }, "object 'ball'.pose is not finite");
  o = ball;
  o.pose.R(0, 0) = 2;
  refused([&] { sim->spawn_object(o); }, "orientation is not a rotation");
  o = ball;
  o.pose.p.x() = 1e9;
  refused([&] { sim->spawn_object(o); }, "pose.position is 1e+09 m");
  o = ball;
  o.twist[3] = 1e9;
  refused([&] { sim->spawn_object(o); }, "object 'ball'.twist has a rate of 1e+09");
  o = ball;
  o.mass = -1;
  refused([&] { sim->spawn_object(o); }, ".mass must be positive");
  refused([&] { sim->delete_model("nothing"); }, "'nothing': no such model");
  refused([&] { sim->delete_model(sim->robot_name()); }, "cannot be deleted");
  ModelState s = robot;
  s.q.resize(2);
  refused([&] { sim->set_model_state(sim->robot_name(), s); }, "joint positions: 2 given");
  s = robot;
  s.v.resize(5);
  refused([&] { sim->set_model_state(sim->robot_name(), s); }, "joint velocities: 5 given");
  s = robot;
  s.q[0] = INFINITY;
  refused([&] { sim->set_model_state(sim->robot_name(), s); }, "not finite");
  s = robot;
  s.twist[0] = std::nan("");
  refused([&] { sim->set_model_state(sim->robot_name(), s); }, ".twist is not finite");
  ModelState t = sim->model_state("table");
  t.twist[5] = 1;
  refused([&] { sim->set_model_state("table", t); }, "the object is static");
  refused([&] { sim->set_model_state("nothing", box); }, "no such model");
  ModelState bq = box;
  bq.q = VecX::Zero(1);
  refused([&] { sim->set_model_state("box", bq); }, "an object has no joints");
  refused([&] { sim->link_state("nothing"); }, "link 'nothing': no such link");
  refused([&] { sim->link_state("box", "nothing"); }, "reference 'nothing': no such link");
  refused([&] { sim->link_state("table::box"); }, "no such link");
  // Nothing changed.
  EXPECT_EQ(sim->world_generation(), g);
  EXPECT_EQ(sim->world_models().size(), 3u);
  EXPECT_EQ((sim->model_state(sim->robot_name()).q - robot.q).norm(), 0);
  EXPECT_EQ((sim->model_state("box").pose.p - box.pose.p).norm(), 0);
  EXPECT_EQ(sim->spawned() + sim->deleted(), 0u);
  ASSERT_EQ(sim->step_n(10), 10) << sim->failure();
}

// Reset of the world: states back (a spawned object to its spawn state), time runs on; reset():
// time 0 too.
TEST(World, ResetWorldKeepsTheTime) {
  auto sim = sim_of(kScene);
  sim->spawn_object(parse_scene_object(kBall, kRoot));
  ASSERT_EQ(sim->step_n(200), 200) << sim->failure();
  const double t = sim->time();
  sim->reset_world();
  EXPECT_EQ(sim->time(), t);
  EXPECT_EQ(sim->steps(), 200u);
  EXPECT_EQ((sim->model_state("ball").pose.p - Vec3(-2, 1, 3)).norm(), 0);
  EXPECT_EQ((sim->model_state("box").pose.p - Vec3(3, 0, 0.15)).norm(), 0);
  ASSERT_EQ(sim->step_n(10), 10) << sim->failure();
  EXPECT_NEAR(sim->time(), t + 0.01, 1e-12);
  sim->reset();
  EXPECT_EQ(sim->time(), 0);
  EXPECT_EQ(sim->world_models().size(), 4u);  // the spawned object stays, as in Gazebo
  EXPECT_EQ((sim->model_state("ball").pose.p - Vec3(-2, 1, 3)).norm(), 0);
}

// The same sets, spawns and steps after a reset give bit-identical states (what lockstep relies
// on): nothing of a set or an edit is left behind in warm starts or workspaces.
TEST(World, SetStateAndSpawnAreDeterministic) {
  auto sim = sim_of(kScene);
  auto run = [&](bool spawn) {
    ASSERT_EQ(sim->step_n(50), 50) << sim->failure();
    ModelState b = sim->model_state("box");
    b.pose.p = Vec3(3.05, 0.02, 0.3);
    b.twist << 0.5, 0, 0, 0, 0, -1;
    sim->set_model_state("box", b);
    if (spawn) sim->spawn_object(parse_scene_object(kBall, kRoot));
    ASSERT_EQ(sim->step_n(200), 200) << sim->failure();
  };
  run(true);
  const ModelState box = sim->model_state("box"), ball = sim->model_state("ball");
  const State robot = sim->state();
  sim->reset();
  sim->delete_model("ball");
  run(true);
  EXPECT_EQ(sim->model_state("box").pose.p, box.pose.p);
  EXPECT_EQ(sim->model_state("box").twist, box.twist);
  EXPECT_EQ(sim->model_state("ball").pose.p, ball.pose.p);
  EXPECT_EQ(sim->state().q, robot.q);
  EXPECT_EQ(sim->state().v, robot.v);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
