// The simulation layer: scene files (every shipped scene loads and runs; malformed ones are
// refused with the line), the headless run behind `se3_dyn simulate`, the URDF writer for
// generated robots, and the Simulator's commands and reset.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "../src/sim/scene_reader.h"
#include "se3_sim/sim/sim.h"
#include "source_paths.h"
#include "test_util.h"

using namespace se3;

namespace {

const std::string kSource = se3_sim_test::source_dir();
const std::string kScenes = kSource + "/config/scenes/";

std::string scene_error(const std::string& text) {
  try {
    parse_scene(text, kScenes, "test.yaml");
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Scene, EveryShippedSceneLoadsBuildsAndRuns) {
  for (const char* name : {"satellite_arm", "fixed_panda", "fixed_arm", "chain20", "pendulum"}) {
    SCOPED_TRACE(name);
    const Scene s = load_scene(kScenes + name + ".yaml");
    EXPECT_EQ(s.name, name);
    auto sim = make_simulator(s);
    const Model& m = sim->model();
    EXPECT_EQ(m.floating, s.floating);
    EXPECT_EQ(m.gravity, s.gravity);
    // The initial joint values of the scene are in the state.
    for (const auto& kv : s.initial_positions) {
      EXPECT_EQ(sim->state().q[m.joint_index(kv.first) - 1], kv.second) << kv.first;
    }
    EXPECT_TRUE(sim->state().base.isApprox(s.base_pose, 1e-12));
    const State x0 = sim->state();
    EXPECT_EQ(sim->step_n(200), 200) << sim->failure();
    EXPECT_NEAR(sim->time(), 0.2, 1e-12);
    EXPECT_GT((sim->state().q - x0.q).norm() + (sim->state().v - x0.v).norm(), 1e-6)
        << "the scene does not move";
  }
}

TEST(Scene, SatelliteArmIsTheFreeFloatingPandaWithLockedFingersAndABus) {
  const Scene s = load_scene(kScenes + "satellite_arm.yaml");
  EXPECT_TRUE(s.floating);
  EXPECT_EQ(s.gravity.norm(), 0.0);
  const Model m = scene_model(s);
  EXPECT_EQ(m.n, 7);
  EXPECT_EQ(m.joint_index("panda_finger_joint1"), -1);
  // The bus adds its 50 kg to the base.
  UrdfOptions o;
  o.floating = true;
  o.locked = s.locked_joints;
  const Model bare = model_from_urdf_file(s.robot_path, o);
  EXPECT_NEAR(m.inertia[0].m - bare.inertia[0].m, 50.0, 1e-12);
  // ... and is drawn: a 0.6 m box centred 0.3 m below the base link (it is not in the URDF).
  ASSERT_TRUE(s.has_base_visual);
  EXPECT_EQ(s.base_visual_box, Vec3(0.6, 0.6, 0.6));
  EXPECT_EQ(s.base_visual_origin, Vec3(0, 0, -0.3));
  EXPECT_EQ(s.base_visual_origin, s.base_com);
  // Torques on the arm make the satellite counter-rotate: a shoulder torque about z spins the
  // base the other way about z, with zero total angular momentum.
  auto sim = make_simulator(s);
  State still = sim->state();
  still.v.setZero();
  sim->set_initial_state(still);
  sim->reset();
  sim->set_joint_effort(m.joint_index("panda_joint1"), 5.0);
  ASSERT_EQ(sim->step_n(300), 300) << sim->failure();
  const Vec3 w_base_world = sim->state().base.R * sim->state().v.head<3>();
  EXPECT_GT(sim->state().v[6], 0.1);        // joint 1 turns positively
  EXPECT_LT(w_base_world.z(), -1e-3);       // the bus turns the other way
  EXPECT_LT(sim->momentum().norm(), 1e-9);  // and nothing was gained overall
}

TEST(Scene, FixedPandaIsTheSevenDofArmOnAFixedBaseUnderGravity) {
  const Scene s = load_scene(kScenes + "fixed_panda.yaml");
  EXPECT_FALSE(s.floating);
  EXPECT_EQ(s.gravity, Vec3(0, 0, -9.81));
  EXPECT_EQ(s.integrator, "semi_implicit_euler");
  EXPECT_EQ(s.dt, 1e-3);
  auto sim = make_simulator(s);
  const Model& m = sim->model();
  EXPECT_EQ(m.n, 7);
  EXPECT_EQ(m.nv, 7);
  EXPECT_EQ(m.joint_index("panda_finger_joint1"), -1);
  EXPECT_EQ(sim->integrator(), "semi_implicit_euler");
  // Released from rest, it falls: kinetic energy grows from zero, potential energy drops.
  EXPECT_EQ(sim->kinetic_energy(), 0.0);
  ASSERT_EQ(sim->step_n(100), 100) << sim->failure();
  EXPECT_GT(sim->kinetic_energy(), 1e-3);
  EXPECT_LT(sim->potential_energy(), -1e-3);
}

TEST(Scene, RelativeRobotPathsResolveAgainstTheSceneOrThePackage) {
  const Scene a = parse_scene("robot: data/robots/ur5_robot.urdf\nbase: fixed\n", kScenes);
  EXPECT_EQ(a.robot_path, kSource + "/data/robots/ur5_robot.urdf");  // the package root
  const Scene b = parse_scene("robot: ../../data/robots/ur5_robot.urdf\n", kScenes);
  EXPECT_EQ(b.robot_path, kScenes + "/../../data/robots/ur5_robot.urdf");
  const Scene c = parse_scene("robot: chain:3\n", kScenes);
  EXPECT_EQ(c.robot_path, "chain:3");
  EXPECT_EQ(scene_model(c).n, 3);
}

// Files named the ROS way: $(find PKG)/..., package://PKG/... (PKG's folder on ROS_PACKAGE_PATH)
// and file:///...; an unknown package is one line naming the key and the package.
TEST(Scene, RosStyleReferencesToRobotsAndSrdfs) {
  const std::string src = se3_sim_test::source_dir();
  setenv("ROS_PACKAGE_PATH", src.c_str(), 1);
  const std::string ur5 = src + "/data/robots/ur5_robot.urdf";
  for (const std::string& robot :
       {std::string("$(find se3_sim)/data/robots/ur5_robot.urdf"),
        std::string("package://se3_sim/data/robots/ur5_robot.urdf"), "file://" + ur5}) {
    const Scene s = parse_scene("robot: \"" + robot + "\"\nbase: fixed\n", "/nonexistent");
    EXPECT_EQ(s.robot_path.substr(s.robot_path.size() - 14), "ur5_robot.urdf") << robot;
    EXPECT_TRUE(std::ifstream(s.robot_path).good()) << s.robot_path;
  }
  const Scene with_srdf = parse_scene(
      "srdf: \"$(find se3_sim)/data/meshes/example-robot-data/robots/ur_description/srdf/"
      "ur5.srdf\"\n",
      "/nonexistent");
  EXPECT_TRUE(std::ifstream(with_srdf.srdf).good()) << with_srdf.srdf;
  try {
    parse_scene("robot: \"$(find no_such_package_here)/r.urdf\"\n", "/nonexistent", "x.yaml");
    ADD_FAILURE() << "no error";
  } catch (const SceneError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("x.yaml"), std::string::npos) << m;
    EXPECT_NE(m.find("no_such_package_here"), std::string::npos) << m;
  }
}

TEST(Scene, MalformedScenesAreRefusedWithTheLine) {
  EXPECT_NE(scene_error("robot: chain:2\nbsae: free\n").find("test.yaml:2: unknown key 'bsae'"),
            std::string::npos)
      << scene_error("robot: chain:2\nbsae: free\n");
  EXPECT_NE(scene_error("robot: chain:2\ndt: fast\n").find("'dt' needs a finite number"),
            std::string::npos);
  EXPECT_NE(scene_error("robot: chain:2\ndt: -1\n").find("positive"), std::string::npos);
  EXPECT_NE(scene_error("robot: chain:2\ngravity: [0, 0]\n").find("3 numbers"), std::string::npos);
  EXPECT_NE(scene_error("robot: chain:2\nbase: wobbly\n").find("free or fixed"), std::string::npos);
  EXPECT_NE(scene_error("robot: chain:2\nintegrator: leapfrog9\n").find("unknown integrator"),
            std::string::npos);
  EXPECT_NE(scene_error("robot: chain:0\n").find("chain:N"), std::string::npos);
  EXPECT_NE(scene_error("robot: nowhere.urdf\n").find("not found"), std::string::npos);
  EXPECT_NE(scene_error("robot: chain:2\nbase_pose:\n  orientation: [0, 0, 0, 2]\n")
                .find("unit quaternion"),
            std::string::npos);
  // YAML errors (yaml-cpp's words) with the line.
  EXPECT_NE(scene_error("robot: chain:2\ngravity: [0, 0,\n").find("test.yaml:3: end of sequence"),
            std::string::npos)
      << scene_error("robot: chain:2\ngravity: [0, 0,\n");
  EXPECT_NE(scene_error("robot: chain:2\n\tdt: 1\n").find("test.yaml:2: illegal tab"),
            std::string::npos)
      << scene_error("robot: chain:2\n\tdt: 1\n");
  EXPECT_NE(scene_error("robot: chain:2\ndt: 1\ndt: 2\n").find("test.yaml:3: duplicate key 'dt'"),
            std::string::npos);
  EXPECT_NE(scene_error("robot: chain:2\nbase_pose: {position: [0, 0, 1], position: [1, 1, 1]}\n")
                .find("duplicate key 'position' in 'base_pose'"),
            std::string::npos);
  EXPECT_NE(scene_error("- robot: chain:2\n").find("the top level of a scene must be a map"),
            std::string::npos);
  EXPECT_NE(scene_error("robot: chain:2\n---\ndt: 1\n").find("one YAML document"),
            std::string::npos);
  EXPECT_NE(scene_error("robot: chain:2\ndt: *nothing\n").find("test.yaml:2:"), std::string::npos);
  EXPECT_NE(scene_error("robot: chain:2\n? [a, b]\n: 1\n").find("is not a name"),
            std::string::npos);
  EXPECT_NE(scene_error("robot: chain:2\ndt: [1]\n").find("test.yaml:2: 'dt' needs a number"),
            std::string::npos);
  EXPECT_NE(scene_error("robot: chain:2\ndt:\ngravity: [0, 0, 0]\n").find("test.yaml:2: 'dt'"),
            std::string::npos);
  EXPECT_NE(scene_error("robot: chain:2\njoint_limits: maybe\n").find("needs true or false"),
            std::string::npos);
  EXPECT_NE(scene_error("robot: chain:2\nbase_pose:\n  position: [0, 0, .inf]\n")
                .find("test.yaml:3: 'base_pose.position[2]' needs a finite number, got '.inf'"),
            std::string::npos);
  EXPECT_NE(scene_error("robot: chain:2\nconstraints:\n  c: {type: hinge, link_a: base}\n")
                .find("test.yaml:3: 'constraints.c.type' is point_world"),
            std::string::npos)
      << scene_error("robot: chain:2\nconstraints:\n  c: {type: hinge, link_a: base}\n");
  EXPECT_NE(scene_error("robot: chain:2\nground: {mu: -1}\n").find("'ground.mu' must be >= 0"),
            std::string::npos);
  EXPECT_NE(scene_error("robot: chain:2\nbase_inertia: {mass: 1, inertia: [1, 1, 5]}\n")
                .find("not a physical inertia"),
            std::string::npos);
  EXPECT_NE(scene_error("robot: chain:2\nbase_visual: {origin: [0, 0, 1]}\n").find("needs box"),
            std::string::npos);
  EXPECT_NE(
      scene_error("robot: chain:2\nbase_visual: {box: [1, 0, 1]}\n").find("three positive extents"),
      std::string::npos);
  EXPECT_NE(scene_error("robot: chain:2\nbase_visual: {box: [1, 1, 1], color: [1, 2, 0]}\n")
                .find("in [0, 1]"),
            std::string::npos);
  EXPECT_NE(scene_error("robot: chain:2\nbase_visual: {box: [1, 1, 1], size: 2}\n").find("size"),
            std::string::npos);
  // A joint the model does not have: the error names the scene and the joint.
  const Scene s = parse_scene("robot: chain:2\ninitial_positions: {j9: 1}\n", kScenes, "t.yaml");
  const Model m = scene_model(s);
  try {
    scene_state(s, m);
    ADD_FAILURE() << "no error for joint j9";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("t.yaml: initial_positions names joint 'j9'"),
              std::string::npos)
        << e.what();
  }
}

// A scene keeps robot: optional (the robot may come from outside: robot_description or
// `simulate MODEL --scene`); scenes name joints only where they mean them; a joint the robot
// lacks is an error naming the scene and the joint, and a scene without joints fits any robot.
TEST(Scene, TheRobotMayComeFromOutsideAndAJointlessSceneFitsAnyRobot) {
  const Scene s =
      parse_scene("name: generic\nbase: fixed\ngravity: [0, 0, -9.81]\n", kScenes, "generic.yaml");
  EXPECT_TRUE(s.robot.empty());
  EXPECT_TRUE(s.robot_path.empty());
  EXPECT_TRUE(s.base_given);
  EXPECT_EQ(scene_error("name: nothing\n"), "");  // parses
  try {
    scene_model(s);
    ADD_FAILURE() << "a scene without a robot built a model";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("generic.yaml: no robot"), std::string::npos) << e.what();
  }
  int robots = 0;
  for (const auto& r : se3_test::robot_files()) {
    SCOPED_TRACE(r.file);
    std::ifstream in(se3_test::robot_path(r.file));
    std::stringstream xml;
    xml << in.rdbuf();
    const Model m = scene_model(s, xml.str());
    EXPECT_FALSE(m.floating);
    const State x = scene_state(s, m);
    EXPECT_EQ(x.q.size(), m.n);
    EXPECT_EQ(x.q.norm(), 0.0);
    ++robots;
  }
  EXPECT_GE(robots, 5);
  // A scene's joint the robot lacks, in each key that names joints: the scene and the joint.
  const std::string ur5 = kSource + "/data/robots/ur5_robot.urdf";
  std::ifstream in(ur5);
  std::stringstream xml;
  xml << in.rdbuf();
  for (const char* key : {"initial_positions", "initial_velocities", "locked_joints"}) {
    SCOPED_TRACE(key);
    const Scene t =
        parse_scene(std::string(key) + ": {panda_joint1: 0.1}\n", kScenes, "panda_only.yaml");
    try {
      const Model m = scene_model(t, xml.str());
      scene_state(t, m);
      ADD_FAILURE() << "no error";
    } catch (const SceneError& e) {
      const std::string w = e.what();
      EXPECT_NE(w.find("panda_only.yaml: "), std::string::npos) << w;
      EXPECT_NE(w.find(std::string(key) + " names joint 'panda_joint1'"), std::string::npos) << w;
    }
  }
  // The headless run takes the robot from the command line and the rest from the scene.
  SimulateOptions o;
  o.scene = ::testing::TempDir() + "se3_generic_" + std::to_string(::getpid()) + ".yaml";
  std::ofstream(o.scene) << "base: fixed\ngravity: [0, 0, 0]\ndt: 0.002\n";
  o.model = ur5;
  o.duration = 0.01;
  const SimulateResult r = simulate_headless(o);
  EXPECT_EQ(r.steps, 5u);
  EXPECT_EQ(r.dt, 0.002);
  std::remove(o.scene.c_str());
}

TEST(Scene, YamlParsesNestingFlowAndComments) {
  const Scene s = parse_scene(
      "# comment\n"
      "name: 'my scene # not a comment'\n"
      "robot: chain:4   # trailing comment\n"
      "base: free\n"
      "base_pose:\n"
      "  position: [1, 2,\n"
      "             3]\n"
      "  orientation: [0, 0, 0.7071067811865476, 0.7071067811865476]\n"
      "chain:\n"
      "  length: 0.5\n"
      "  masses: [2, 1]\n"
      "initial_positions: {j1: 0.25, j3: -0.5}\n"
      "initial_velocities:\n"
      "  j2: 1.5\n"
      "base_twist: [0, 0, 1, 0, 0, 0]\n"
      "gravity: [0, 0, 0]\n"
      "dt: 2e-3\n",
      kScenes);
  EXPECT_EQ(s.name, "my scene # not a comment");
  EXPECT_EQ(s.base_pose.p, Vec3(1, 2, 3));
  EXPECT_NEAR((s.base_pose.R * Vec3::UnitX() - Vec3::UnitY()).norm(), 0.0, 1e-12);
  EXPECT_EQ(s.chain_length, 0.5);
  EXPECT_EQ(s.dt, 2e-3);
  const Model m = scene_model(s);
  EXPECT_EQ(m.inertia[1].m, 1.0);
  EXPECT_EQ(m.inertia[2].m, 2.0);
  const State x = scene_state(s, m);
  EXPECT_EQ(x.q[0], 0.25);
  EXPECT_EQ(x.q[2], -0.5);
  EXPECT_EQ(x.v[6 + 1], 1.5);
  EXPECT_EQ(x.v[2], 1.0);
}

// Scenes are standard YAML (yaml-cpp): block lists of maps, anchors and aliases, quoting,
// comments, and the typed reader with the line of every value (what objects: and controllers:
// build on).
TEST(Scene, StandardYamlBlockListsAnchorsQuotingComments) {
  const std::string text =
      "# a scene of the future\n"
      "defaults: &box {mass: 2.0, size: [0.1, 0.2, 0.3]}\n"
      "objects:\n"
      "  - name: \"first # not a comment\"\n"
      "    shape: *box\n"
      "  - name: 'it''s second'\n"
      "    shape:\n"
      "      mass: 1e-1   # a comment\n"
      "      size: [1, 2, 3]\n"
      "flag: yes\n";
  const SceneReader r("future.yaml");
  const SceneReader::Field root = r.document(text);
  const auto top = r.fields(root, {"defaults", "objects", "flag"});
  ASSERT_EQ(top.size(), 3u);
  EXPECT_EQ(top[1].key, "objects");
  EXPECT_EQ(top[1].line, 4);
  const auto objects = r.items(top[1]);
  ASSERT_EQ(objects.size(), 2u);
  EXPECT_EQ(objects[1].key, "objects[1]");
  EXPECT_EQ(objects[1].line, 6);
  const auto first = r.fields(objects[0], {"name", "shape"});
  EXPECT_EQ(r.text(first[0]), "first # not a comment");
  const auto shape = r.fields(first[1], {"mass", "size"});
  EXPECT_EQ(r.positive(shape[0]), 2.0);  // through the alias
  EXPECT_EQ(r.vec3(shape[1]), Vec3(0.1, 0.2, 0.3));
  const auto second = r.fields(objects[1], {"name", "shape"});
  EXPECT_EQ(r.text(second[0]), "it's second");
  const auto shape2 = r.fields(second[1]);
  EXPECT_EQ(shape2[0].key, "objects[1].shape.mass");
  EXPECT_EQ(shape2[0].line, 8);
  EXPECT_EQ(r.number(shape2[0]), 0.1);
  EXPECT_TRUE(r.boolean(top[2]));
  // Errors name the file, the line and the whole key.
  try {
    r.fields(second[1], {"mass"});
    ADD_FAILURE() << "no error for an unknown key";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("future.yaml:9: unknown key 'size' in objects[1].shape"),
              std::string::npos)
        << e.what();
  }
  try {
    r.integer(shape2[0], 0, 10);
    ADD_FAILURE() << "no error for 0.1 as a whole number";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("future.yaml:8: 'objects[1].shape.mass' needs a whole"),
              std::string::npos)
        << e.what();
  }
  // A scene key in block style where flow style was the only way before.
  const Scene s = parse_scene(
      "robot: chain:3\n"
      "base_pose:\n"
      "  position:\n"
      "    - 0.0\n"
      "    - 0.0\n"
      "    - 2.0\n"
      "initial_positions: &q\n"
      "  j1: 0.5\n"
      "initial_velocities: *q\n"
      "name: \"quoted: yes\"\n",
      kScenes);
  EXPECT_EQ(s.base_pose.p, Vec3(0, 0, 2));
  EXPECT_EQ(s.initial_velocities, s.initial_positions);
  EXPECT_EQ(s.name, "quoted: yes");
}

TEST(Headless, SatelliteSceneConservesEnergyAndMomentum) {
  SimulateOptions o;
  o.scene = kScenes + "satellite_arm.yaml";
  o.duration = 2.0;
  const SimulateResult r = simulate_headless(o);
  EXPECT_EQ(r.integrator, "rkmk4");
  EXPECT_EQ(r.steps, 2000u);
  EXPECT_NEAR(r.sim_s, 2.0, 1e-9);
  EXPECT_GT(r.wall_s, 0.0);
  EXPECT_FALSE(r.diverged);
  // The Panda's joint damping (0.003 N m s) is the only loss: small, but not zero.
  EXPECT_LT(r.energy_drift_rel, 5e-2);
  EXPECT_GT(r.energy_drift_rel, 1e-6);
  EXPECT_LT(r.momentum_drift_rel, 1e-9);
  EXPECT_LT(r.com_drift_max, 1e-9);
  // The Panda's joint limits are on (the scene default): never reached, so no error.
  EXPECT_EQ(r.constraint_error_max, 0.0);
  const std::string json = simulate_result_json(r);
  EXPECT_NE(json.find("\"integrator\": \"rkmk4\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"steps\": 2000"), std::string::npos) << json;
  EXPECT_NE(json.find("\"constraint_error_max\": 0"), std::string::npos) << json;
}

TEST(Headless, RandomStatesAreReproducibleAndIntegratorsRankByAccuracy) {
  SimulateOptions o;
  o.model = "chain:5";
  o.floating = true;
  o.has_gravity = true;
  o.gravity = Vec3::Zero();
  o.duration = 1.0;
  o.dt = 1e-3;
  double drift[3];
  const char* names[3] = {"euler", "semi_implicit_euler", "rkmk4"};
  for (int k = 0; k < 3; ++k) {
    o.integrator = names[k];
    const SimulateResult a = simulate_headless(o);
    const SimulateResult b = simulate_headless(o);
    EXPECT_EQ(a.energy_drift_rel, b.energy_drift_rel) << "same seed, same run";
    drift[k] = a.energy_drift_rel;
    EXPECT_FALSE(std::isnan(a.momentum_drift_rel));
  }
  EXPECT_GT(drift[0], 100 * drift[2]);  // first-order methods drift O(h), RKMK4 O(h^4)
  EXPECT_GT(drift[1], 100 * drift[2]);
  EXPECT_LT(drift[2], 1e-8);
  o.seed = 2;
  o.integrator = "rkmk4";
  EXPECT_NE(simulate_headless(o).energy_drift_rel, drift[2]) << "another seed, another state";
  // Under gravity there is no momentum figure.
  o.has_gravity = false;
  EXPECT_TRUE(std::isnan(simulate_headless(o).momentum_drift_rel));
}

TEST(Headless, WritesTheTrajectoryAndRejectsBadInput) {
  const std::string path = ::testing::TempDir() + "se3_traj.csv";
  SimulateOptions o;
  o.model = kSource + "/data/robots/double_pendulum_simple.urdf";
  o.duration = 0.01;
  o.dt = 1e-3;
  o.integrator = "rkmk45";
  o.out_csv = path;
  const SimulateResult r = simulate_headless(o);
  EXPECT_EQ(r.steps, 10u);
  EXPECT_TRUE(std::isnan(r.momentum_drift_rel));
  std::ifstream in(path);
  std::string header, line;
  std::getline(in, header);
  EXPECT_EQ(header,
            "t,base_x,base_y,base_z,base_qx,base_qy,base_qz,base_qw,q:joint1,q:joint2,v:joint1,"
            "v:joint2,kinetic,potential");
  int rows = 0;
  while (std::getline(in, line)) ++rows;
  EXPECT_EQ(rows, 11);
  std::remove(path.c_str());
  o.out_csv.clear();
  o.integrator = "nope";
  EXPECT_THROW(simulate_headless(o), std::invalid_argument);
  o.integrator = "rkmk4";
  o.duration = -1;
  EXPECT_THROW(simulate_headless(o), std::invalid_argument);
  o.duration = 1;
  o.model = "chain:0";
  EXPECT_THROW(simulate_headless(o), std::invalid_argument);
  o.model = "/no/such.urdf";
  EXPECT_THROW(simulate_headless(o), ModelError);
  o.scene = "/no/such.yaml";
  EXPECT_THROW(simulate_headless(o), SceneError);
}

TEST(UrdfWriter, GeneratedChainRoundTripsThroughUrdf) {
  const Model a = make_chain(5, true, {1.0, 2.0}, 0.4);
  const Model b = model_from_urdf_string(model_to_urdf(a), UrdfOptions{true, {}});
  ASSERT_EQ(b.n, a.n);
  Data da(a), db(b);
  const State x = random_state(a, 4);
  VecX tau = VecX::Zero(a.nv);
  for (int i = 0; i < a.nv; ++i) tau[i] = 0.1 * (i + 1);
  const VecX acc_a = aba(a, da, x.base, x.q, x.v, tau);
  const VecX acc_b = aba(b, db, x.base, x.q, x.v, tau);
  EXPECT_LT((acc_a - acc_b).norm(), 1e-9 * (1 + acc_a.norm()));
  EXPECT_EQ(b.links.size(), a.links.size());
}

// The divergence guard's kinetic-energy bound is never below the energy: every robot fixed and
// free (Panda's prismatic fingers included) and chains up to 200 bodies, at random states, at
// high rates, with long prismatic strokes, and with each rate alone (which makes a missing term
// show: a lone prismatic rate on a fixed base is even met with equality).
TEST(Guard, KineticEnergyBoundIsNeverBelowTheEnergy) {
  std::mt19937_64 rng(31);
  double tightest = 1e300, loosest = 0;
  int checked = 0;
  for (const se3_test::Case& c : se3_test::all_cases()) {
    SCOPED_TRACE(c.label);
    const Model& m = c.model;
    Data d(m);
    KineticEnergyBound bound(m);
    auto check = [&](const se3_test::RandomState& s, const VecX& v) {
      const double T = kinetic_energy(m, d, s.base, s.q, v);
      const double B = bound(s.q, v);
      EXPECT_GE(B, T * (1 - 1e-12)) << "v = " << v.transpose();
      if (T > 0) {
        tightest = std::min(tightest, B / T);
        loosest = std::max(loosest, B / T);
      }
      ++checked;
    };
    for (int k = 0; k < 20; ++k) {
      se3_test::RandomState s = se3_test::random_state(m, rng);
      if (k % 4 == 1) {
        for (int i = 1; i <= m.n; ++i) {
          if (m.joints[i].type == JointType::Prismatic) s.q[i - 1] = se3_test::uniform(rng, -2, 2);
        }
      }
      check(s, k % 4 == 2 ? VecX(1e3 * s.v) : s.v);
    }
    const se3_test::RandomState s = se3_test::random_state(m, rng);
    for (int k = 0; k < m.nv && k < 40; ++k) {
      VecX v = VecX::Zero(m.nv);
      v[k] = k % 2 ? 2.0 : -0.5;
      check(s, v);
    }
  }
  std::printf("kinetic energy bound / energy over %d states: %.3g to %.3g\n", checked, tightest,
              loosest);
  EXPECT_LT(tightest, 1 + 1e-9) << "a lone prismatic rate on a fixed base is met exactly";
}

// A contact scene run twice from a reset with the same commands gives the same bits: nothing
// that a step leaves behind (warm starts, the broad phase's tree, caches) outlives the reset.
TEST(Simulator, ContactSceneAfterAResetRepeatsBitForBit) {
  for (const char* name : {"panda_push.yaml", "box_stack.yaml", "quadruped_ground.yaml"}) {
    SCOPED_TRACE(name);
    auto sim = make_simulator(load_scene(kScenes + name));
    auto run = [&] {
      std::vector<VecX> out;
      for (int k = 0; k < 60; ++k) {
        for (int i = 1; i <= sim->model().n; ++i)
          sim->set_joint_effort(i, 0.5 * std::sin(0.1 * k + i));
        EXPECT_EQ(sim->step_n(10), 10) << sim->failure();
        VecX x(sim->state().q.size() + sim->state().v.size() + 12);
        x << sim->state().q, sim->state().v, sim->state().base.p,
            Eigen::Map<const VecX>(sim->state().base.R.data(), 9);
        out.push_back(x);
        for (const auto& o : sim->objects()) {
          VecX y(x.size() + 3);
          y << x, o.pose.p;
          out.back() = y;
          x = y;
        }
      }
      return out;
    };
    const auto a = run();
    sim->reset();
    const auto b = run();
    for (size_t k = 0; k < a.size(); ++k) {
      ASSERT_TRUE(a[k] == b[k]) << "parted at step " << 10 * (k + 1) << ": "
                                << (a[k] - b[k]).norm();
    }
  }
}

TEST(Simulator, ResetStepAndCommands) {
  const Scene s = load_scene(kScenes + "pendulum.yaml");
  auto sim = make_simulator(s);
  const State x0 = sim->state();
  ASSERT_EQ(sim->step_n(50), 50);
  EXPECT_EQ(sim->steps(), 50u);
  EXPECT_GT((sim->state().q - x0.q).norm(), 1e-4);
  sim->set_joint_effort(1, 0.3);
  sim->reset();
  EXPECT_EQ(sim->steps(), 0u);
  EXPECT_EQ(sim->time(), 0.0);
  EXPECT_EQ(sim->state().q, x0.q);
  EXPECT_EQ(sim->command().norm(), 0.0);
  // Applied effort = command - damping * qdot (the double pendulum's joints have damping).
  State moving = x0;
  moving.v << 1.0, -2.0;
  sim->set_state(moving);
  // A non-finite state or a rotation that is not one is refused, and the state kept.
  State bad = moving;
  bad.base.p.x() = std::nan("");
  EXPECT_THROW(sim->set_state(bad), std::invalid_argument);
  bad = moving;
  bad.base.R(0, 1) += 1e-3;
  EXPECT_THROW(sim->set_state(bad), std::invalid_argument);
  EXPECT_EQ(sim->state().v, moving.v);
  EXPECT_TRUE(sim->state().finite());
  sim->set_joint_effort(2, 0.1);
  VecX eff;
  sim->applied_joint_efforts(eff);
  const Model& m = sim->model();
  EXPECT_NEAR(eff[0], -m.damping[1] * 1.0, 1e-15);
  EXPECT_NEAR(eff[1], 0.1 + m.damping[2] * 2.0, 1e-15);
  EXPECT_GT(m.damping[1], 0.0);
  // Link poses: one per URDF link, the root at the base pose.
  std::vector<SE3> poses;
  sim->link_poses(poses);
  ASSERT_EQ(poses.size(), m.links.size());
  EXPECT_TRUE(poses[0].isApprox(s.base_pose * m.links[0].offset, 1e-12));
  // A different integrator keeps the state; the former name symplectic_euler is an alias of
  // semi_implicit_euler.
  sim->set_integrator("symplectic_euler");
  EXPECT_EQ(sim->integrator(), "semi_implicit_euler");
  EXPECT_EQ(sim->state().v, moving.v);
  EXPECT_THROW(sim->set_integrator("nope"), std::invalid_argument);
  EXPECT_EQ(sim->integrator(), "semi_implicit_euler");
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
