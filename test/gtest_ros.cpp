// The ros layer without a master: typed parameters (no precision lost, the ~dt below 5e-7 that
// std::to_string turned into 0), controllers from XmlRpc, message conversions, the checks of
// torque commands, and TF as robot_state_publisher computes it from the URDF.
#include <gtest/gtest.h>
#include <urdf_parser/urdf_parser.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "se3_sim/ros/convert.h"
#include "se3_sim/ros/params.h"
#include "se3_sim/ros/robot_interfaces.h"
#include "se3_sim/sim/sim.h"
#include "source_paths.h"

using XmlRpc::XmlRpcValue;

namespace {

const std::string kSource = se3_sim_test::source_dir();

std::string read(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

template <class F>
std::string error_of(F f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

}  // namespace

// ------------------------------------------------------------------ parameters

TEST(Params, NumbersKeepEveryDigit) {
  // A double stays that double; a string is parsed with full precision.
  for (double x : {1e-7, 4.9e-7, 1e-12, 0.001, 123456.789012345678, -2.5e-9}) {
    EXPECT_EQ(*se3_ros::to_double(XmlRpcValue(x), "~dt"), x);
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", x);
    EXPECT_EQ(*se3_ros::to_double(XmlRpcValue(std::string(buf)), "~dt"), x);
  }
  // (The old reader printed the double with std::to_string first: "0.000000" for 1e-7.)
  EXPECT_EQ(std::stod(std::to_string(1e-7)), 0.0);
  EXPECT_EQ(*se3_ros::to_double(XmlRpcValue(3), "~rate"), 3.0);
  EXPECT_FALSE(se3_ros::to_double(XmlRpcValue(std::string()), "~dt").has_value());
  EXPECT_NE(error_of([] {
              se3_ros::to_double(XmlRpcValue(std::string("1e-3x")), "~dt");
            }).find("~dt needs a number, got '1e-3x'"),
            std::string::npos);
  EXPECT_NE(
      error_of([] { se3_ros::to_double(XmlRpcValue(std::string("nan")), "~dt"); }).find("finite"),
      std::string::npos);
  EXPECT_NE(error_of([] { se3_ros::to_double(XmlRpcValue(true), "~dt"); }).find("a boolean"),
            std::string::npos);
}

TEST(Params, BoolsTextAndNames) {
  EXPECT_TRUE(*se3_ros::to_bool(XmlRpcValue(true), "b"));
  EXPECT_FALSE(*se3_ros::to_bool(XmlRpcValue(std::string("false")), "b"));
  EXPECT_TRUE(*se3_ros::to_bool(XmlRpcValue(1), "b"));
  EXPECT_FALSE(se3_ros::to_bool(XmlRpcValue(std::string()), "b").has_value());
  EXPECT_THROW(se3_ros::to_bool(XmlRpcValue(std::string("yes please")), "b"), se3_ros::ParamError);
  EXPECT_EQ(*se3_ros::to_text(XmlRpcValue(std::string("rkmk4")), "i"), "rkmk4");
  EXPECT_THROW(se3_ros::to_text(XmlRpcValue(2.0), "i"), se3_ros::ParamError);
  EXPECT_EQ(se3_ros::to_names(XmlRpcValue(std::string(" arm  wrist,legs ")), "c"),
            (std::vector<std::string>{"arm", "wrist", "legs"}));
  XmlRpcValue list;
  list[0] = std::string("a");
  list[1] = std::string("b");
  EXPECT_EQ(se3_ros::to_names(list, "c"), (std::vector<std::string>{"a", "b"}));
  list[2] = 3;
  EXPECT_THROW(se3_ros::to_names(list, "c"), se3_ros::ParamError);
  EXPECT_TRUE(se3_ros::to_names(XmlRpcValue(std::string()), "c").empty());
}

// A controller YAML as rosparam loads it (XmlRpc structs) reads as the same spec as from the
// YAML text itself.
TEST(Params, ControllersFromTheParameterServerMatchTheYaml) {
  const std::string yaml = R"(
arm:
  type: effort_controllers/JointGroupPositionController
  joints: [j1, j2]
  pid: {p: 600, i: 0.5, d: 30, i_clamp: 2}
  j2: {pid: {p: 1e-7, antiwindup: true}}
wrist: {type: effort_controllers/JointEffortController, joint: j3}
)";
  const auto from_text = se3::parse_controllers_text(yaml, {"arm", "wrist"});
  XmlRpcValue arm, wrist;
  arm["type"] = std::string("effort_controllers/JointGroupPositionController");
  arm["joints"][0] = std::string("j1");
  arm["joints"][1] = std::string("j2");
  arm["pid"]["p"] = 600;  // rosparam gives an int for 600
  arm["pid"]["i"] = 0.5;
  arm["pid"]["d"] = 30.0;
  arm["pid"]["i_clamp"] = 2;
  arm["j2"]["pid"]["p"] = 1e-7;
  arm["j2"]["pid"]["antiwindup"] = true;
  wrist["type"] = std::string("effort_controllers/JointEffortController");
  wrist["joint"] = std::string("j3");
  const auto from_xml = se3_ros::controllers_from_xmlrpc({"arm", "wrist"}, {arm, wrist}, "test");
  ASSERT_EQ(from_xml.size(), 2u);
  for (size_t c = 0; c < 2; ++c) {
    EXPECT_EQ(from_xml[c].name, from_text[c].name);
    EXPECT_EQ(from_xml[c].kind, from_text[c].kind);
    EXPECT_EQ(from_xml[c].joints, from_text[c].joints);
    ASSERT_EQ(from_xml[c].gains.size(), from_text[c].gains.size());
    for (size_t j = 0; j < from_xml[c].gains.size(); ++j) {
      const se3::PidGains &a = from_xml[c].gains[j], &b = from_text[c].gains[j];
      EXPECT_EQ(a.p, b.p);
      EXPECT_EQ(a.i, b.i);
      EXPECT_EQ(a.d, b.d);
      EXPECT_EQ(a.i_clamp_min, b.i_clamp_min);
      EXPECT_EQ(a.i_clamp_max, b.i_clamp_max);
      EXPECT_EQ(a.antiwindup, b.antiwindup);
    }
  }
  EXPECT_EQ(from_xml[0].gains[1].p, 1e-7);  // not rounded on the way
  XmlRpcValue bad = wrist;
  bad["type"] = std::string("diff_drive_controller/DiffDriveController");
  EXPECT_NE(error_of([&] {
              se3_ros::controllers_from_xmlrpc({"w"}, {bad}, "params");
            }).find("controller 'w': type 'diff_drive_controller/DiffDriveController'"),
            std::string::npos);
}

// ------------------------------------------------------------------ conversions

TEST(Convert, PosesRoundTripAndBadQuaternionsAreRefused) {
  const se3::SE3 f(se3::exp_so3(se3::Vec3(0.3, -1.2, 2.0)), se3::Vec3(1, -2, 3));
  se3::SE3 g;
  EXPECT_EQ(se3_ros::from_pose(se3_ros::to_pose(f), g), "");
  EXPECT_LT((g.R - f.R).norm(), 1e-15);
  EXPECT_EQ(g.p, f.p);
  geometry_msgs::Pose p = se3_ros::to_pose(f);
  p.orientation.w *= 1.0005;  // within 1e-3: normalized
  EXPECT_EQ(se3_ros::from_pose(p, g), "");
  EXPECT_TRUE(se3::is_rotation(g.R));
  p.orientation.w = 3;
  EXPECT_NE(se3_ros::from_pose(p, g).find("not a unit quaternion"), std::string::npos);
  p = se3_ros::to_pose(f);
  p.position.y = std::nan("");
  EXPECT_NE(se3_ros::from_pose(p, g).find("non-finite"), std::string::npos);
  se3::Vec6 w;
  w << 1, 2, 3, 4, 5, 6;
  geometry_msgs::Wrench m;
  m.torque.x = 1, m.torque.y = 2, m.torque.z = 3, m.force.x = 4, m.force.y = 5, m.force.z = 6;
  EXPECT_EQ(se3_ros::from_wrench(m), w);
  EXPECT_EQ(se3_ros::from_twist(se3_ros::to_twist(w)), w);
}

// A trajectory message as the trajectory controllers take it: every point's fields as sent.
TEST(Convert, TrajectoryMessagesKeepEveryPointsFields) {
  trajectory_msgs::JointTrajectory msg;
  msg.joint_names = {"a", "b"};
  msg.points.resize(2);
  msg.points[0].positions = {0.1, 0.2};
  msg.points[0].time_from_start = ros::Duration(0.5);
  msg.points[1].positions = {0.3, -0.4};
  msg.points[1].velocities = {1.0, 2.0};
  msg.points[1].accelerations = {-3.0, 4.0};
  msg.points[1].time_from_start = ros::Duration(1, 250000000);
  const se3::TrajectoryCommand cmd = se3_ros::from_trajectory(msg);
  EXPECT_EQ(cmd.joint_names, msg.joint_names);
  ASSERT_EQ(cmd.points.size(), 2u);
  EXPECT_EQ(cmd.points[0].time_from_start, 0.5);
  EXPECT_EQ(cmd.points[0].positions, msg.points[0].positions);
  EXPECT_TRUE(cmd.points[0].velocities.empty());
  EXPECT_EQ(cmd.points[1].time_from_start, 1.25);
  EXPECT_EQ(cmd.points[1].velocities, msg.points[1].velocities);
  EXPECT_EQ(cmd.points[1].accelerations, msg.points[1].accelerations);
}

TEST(Convert, TorqueCommandsAreCheckedJointByJoint) {
  const se3::Scene s = se3::load_scene(kSource + "/config/scenes/satellite_arm.yaml");
  const se3::Model m = se3::scene_model(s);
  const se3_ros::JointTable joints = se3_ros::joint_table(m, s.locked_joints);
  ASSERT_EQ(joints.names.size(), 9u);  // 7 moving, then the two locked fingers
  EXPECT_EQ(joints.names[7], "panda_finger_joint1");
  se3_ros::TorqueCommand out;
  auto check = [&](const std::vector<std::string>& names, const std::vector<double>& e,
                   bool wrench = false, se3::Vec6 w = se3::Vec6::Zero()) {
    se3_sim::JointTorques msg;
    msg.name = names;
    msg.effort = e;
    msg.has_base_wrench = wrench;
    msg.base_wrench.torque.x = w[0], msg.base_wrench.torque.y = w[1];
    msg.base_wrench.torque.z = w[2], msg.base_wrench.force.x = w[3];
    msg.base_wrench.force.y = w[4], msg.base_wrench.force.z = w[5];
    return se3_ros::check_torque_command(m, joints, msg, 1e4, 1e4, out);
  };
  EXPECT_EQ(check({"panda_joint7", "panda_finger_joint1"}, {1.0, 2.0}), "");
  ASSERT_EQ(out.efforts.size(), 2u);
  EXPECT_EQ(out.efforts[0], (std::pair<int, double>(m.joint_index("panda_joint7"), 1.0)));
  EXPECT_EQ(out.efforts[1].first, 0);  // locked: known, no effect
  EXPECT_FALSE(out.has_base_wrench);
  EXPECT_NE(check({"panda_joint7"}, {1.0, 2.0}).find("lengths differ: 1 vs 2"), std::string::npos);
  EXPECT_NE(check({"nope"}, {1.0}).find("unknown joint 'nope'"), std::string::npos);
  EXPECT_NE(check({"panda_joint4", "panda_joint4"}, {1.0, 2.0})
                .find("joint 'panda_joint4' is named twice"),
            std::string::npos);
  EXPECT_NE(check({"panda_joint4"}, {std::numeric_limits<double>::infinity()})
                .find("non-finite effort for 'panda_joint4'"),
            std::string::npos);
  EXPECT_EQ(check({"panda_joint4"}, {1e300}), "");  // a URDF limit clamps it (87 N m)
  se3::Vec6 w = se3::Vec6::Zero();
  w[4] = 20;
  EXPECT_EQ(check({}, {}, true, w), "");
  EXPECT_TRUE(out.has_base_wrench);
  EXPECT_EQ(out.base_wrench[4], 20);
  w[4] = 1e300;  // finite, and it would end the simulation
  EXPECT_NE(check({}, {}, true, w).find("exceeds ~max_wrench"), std::string::npos);
  // Numbers in messages as %g: std::to_string(1e300) wrote all 301 digits.
  EXPECT_NE(check({}, {}, true, w).find("|force| 1e+300)"), std::string::npos)
      << check({}, {}, true, w);
  EXPECT_LT(check({}, {}, true, w).size(), 120u);
  w[4] = std::nan("");
  EXPECT_NE(check({}, {}, true, w).find("non-finite base wrench"), std::string::npos);
  // A joint without a URDF effort limit (chain:N) is bounded by ~max_effort.
  const se3::Model chain = se3::make_chain(2, false);
  const se3_ros::JointTable cj = se3_ros::joint_table(chain, {});
  se3_sim::JointTorques msg;
  msg.name = {"j1"};
  msg.effort = {2e4};
  EXPECT_NE(se3_ros::check_torque_command(chain, cj, msg, 1e4, 1e4, out).find("~max_effort"),
            std::string::npos);
}

TEST(Convert, JointStateListsMovingThenLockedJoints) {
  const se3::Scene s = se3::load_scene(kSource + "/config/scenes/satellite_arm.yaml");
  const se3::Model m = se3::scene_model(s);
  const se3_ros::JointTable joints = se3_ros::joint_table(m, s.locked_joints);
  const se3::State x = se3::scene_state(s, m);
  se3::VecX eff = se3::VecX::Zero(m.n);
  eff[3] = 2.5;
  eff[4] = std::nan("");
  sensor_msgs::JointState js;
  se3_ros::fill_joint_state(m, joints, x, eff, js);
  ASSERT_EQ(js.name.size(), 9u);
  EXPECT_EQ(js.position[3], -2.356);
  EXPECT_EQ(js.velocity[0], 0.3);
  EXPECT_EQ(js.effort[3], 2.5);
  EXPECT_EQ(js.effort[4], 0.0);  // never NaN on the wire
  EXPECT_EQ(js.position[7], 0.02);
  se3_sim::ChainState cs;
  se3_ros::fill_chain_state(m, js, x, 1.0, std::nan(""), cs);
  EXPECT_EQ(cs.base_pose.position.z, 1.0);
  EXPECT_EQ(cs.potential_energy, 0.0);
  EXPECT_EQ(cs.name, js.name);
}

// ------------------------------------------------------------------ TF

namespace {

// robot_state_publisher's transform of a URDF joint at position q: origin * motion(q).
se3::SE3 joint_transform(const urdf::Joint& j, double q) {
  const urdf::Pose& o = j.parent_to_joint_origin_transform;
  double x, y, z, w;
  o.rotation.getQuaternion(x, y, z, w);
  const se3::SE3 origin(se3::rotation_from_quaternion(x, y, z, w),
                        se3::Vec3(o.position.x, o.position.y, o.position.z));
  const se3::Vec3 a(j.axis.x, j.axis.y, j.axis.z);
  switch (j.type) {
    case urdf::Joint::REVOLUTE:
    case urdf::Joint::CONTINUOUS:
      return origin * se3::SE3(se3::exp_so3(q * a), se3::Vec3::Zero());
    case urdf::Joint::PRISMATIC:
      return origin * se3::SE3(se3::Mat3::Identity(), q * a);
    default:
      return origin;
  }
}

}  // namespace

// Every URDF joint is one edge parent link -> child link (a tree: one parent per frame), fixed
// joints on /tf_static and the rest (locked ones too) on /tf, each with the transform
// robot_state_publisher computes from the joint's origin and position; world -> root on /tf.
// Scene objects: a /tf frame each under the world, and markers of their shapes.
TEST(Tf, SceneObjectsAsFramesAndMarkers) {
  const se3::Scene sc = se3::parse_scene(
      "objects:\n  - {name: crate, shape: {box: [0.1, 0.2, 0.3]}, mass: 1, color: [1, 0, 0]}\n"
      "  - {name: pill, shape: {capsule: [0.05, 0.4]}}\n",
      ".", "s.yaml");
  std::vector<se3::ObjectState> states(2);
  states[0].pose.p = se3::Vec3(1, 2, 3);
  states[1].pose.p = se3::Vec3(0, 0, 1);
  std::vector<geometry_msgs::TransformStamped> tfs(1);  // e.g. the robot's, kept
  se3_ros::append_object_transforms(sc.objects, states, "world", ros::Time(2.0), tfs);
  ASSERT_EQ(tfs.size(), 3u);
  EXPECT_EQ(tfs[1].header.frame_id, "world");
  EXPECT_EQ(tfs[1].child_frame_id, "crate");
  EXPECT_DOUBLE_EQ(tfs[1].transform.translation.y, 2);
  EXPECT_EQ(tfs[2].child_frame_id, "pill");
  EXPECT_DOUBLE_EQ(tfs[2].header.stamp.toSec(), 2.0);
  visualization_msgs::MarkerArray ma;
  se3_ros::append_object_markers(sc.objects, states, "world", ros::Time(2.0), ma);
  ASSERT_EQ(ma.markers.size(), 4u);  // a cube; a cylinder and two caps
  EXPECT_EQ(ma.markers[0].type, visualization_msgs::Marker::CUBE);
  EXPECT_EQ(ma.markers[0].ns, "objects");
  EXPECT_DOUBLE_EQ(ma.markers[0].scale.z, 0.3);
  EXPECT_FLOAT_EQ(ma.markers[0].color.r, 1.0f);
  EXPECT_DOUBLE_EQ(ma.markers[0].pose.position.z, 3);
  EXPECT_EQ(ma.markers[1].type, visualization_msgs::Marker::CYLINDER);
  EXPECT_EQ(ma.markers[2].type, visualization_msgs::Marker::SPHERE);
  EXPECT_NEAR(ma.markers[2].pose.position.z, 1 - 0.2, 1e-12);
  EXPECT_NEAR(ma.markers[3].pose.position.z, 1 + 0.2, 1e-12);
  std::set<int> ids;
  for (const auto& m : ma.markers) ids.insert(m.id);
  EXPECT_EQ(ids.size(), 4u);
}

TEST(Tf, TreeAsRobotStatePublisher) {
  for (const char* scene_file : {"satellite_arm.yaml", "quadruped_ground.yaml", "fixed_arm.yaml"}) {
    SCOPED_TRACE(scene_file);
    const se3::Scene s = se3::load_scene(kSource + "/config/scenes/" + scene_file);
    auto sim = se3::make_simulator(s);
    const se3::Model& m = sim->model();
    const urdf::ModelInterfaceSharedPtr u = urdf::parseURDF(read(s.robot_path));
    ASSERT_TRUE(u);
    // A moved state: positions off the scene's, the base turned.
    se3::State x = sim->state();
    for (int k = 0; k < m.n; ++k) x.q[k] += 0.1 * (k + 1);
    x.base = se3::SE3(se3::exp_so3(se3::Vec3(0.2, 0.3, -0.4)), se3::Vec3(0.5, -0.5, 1.5));
    sim->set_state(x);
    std::vector<se3::SE3> poses;
    sim->link_poses(poses);
    const se3_ros::TfTree tree = se3_ros::tf_tree(m, "world");
    std::vector<geometry_msgs::TransformStamped> dyn;
    se3_ros::tf_transforms(m, tree, poses, "world", ros::Time(1.5), dyn);
    const auto fixed = se3_ros::tf_static_transforms(m, tree, ros::Time(0));
    std::map<std::string, std::string> parent_of;
    std::map<std::string, geometry_msgs::TransformStamped> edge;
    const std::vector<geometry_msgs::TransformStamped>* lists[] = {&dyn, &fixed};
    for (const auto* list : lists) {
      for (const auto& t : *list) {
        EXPECT_TRUE(parent_of.emplace(t.child_frame_id, t.header.frame_id).second)
            << t.child_frame_id << " has two parents";
        edge[t.child_frame_id] = t;
      }
    }
    for (const auto& t : dyn) EXPECT_EQ(t.header.stamp, ros::Time(1.5));
    // world -> root at the base pose (unless the root is the world itself).
    const bool world_root = u->getRoot()->name == "world";
    EXPECT_EQ(tree.world_edge, !world_root);
    if (!world_root) {
      ASSERT_TRUE(parent_of.count(u->getRoot()->name));
      EXPECT_EQ(parent_of[u->getRoot()->name], "world");
      const geometry_msgs::Transform& b = edge[u->getRoot()->name].transform;
      EXPECT_NEAR(b.translation.z, x.base.p.z(), 1e-15);
    }
    // One edge per URDF joint, where robot_state_publisher would put it.
    std::map<std::string, double> q;
    for (int i = 1; i <= m.n; ++i) q[m.joint_name[i]] = x.q[i - 1];
    for (const auto& kv : s.locked_joints) q[kv.first] = kv.second;
    for (const auto& jv : u->joints_) {
      const urdf::Joint& j = *jv.second;
      SCOPED_TRACE(j.name);
      ASSERT_TRUE(edge.count(j.child_link_name));
      EXPECT_EQ(parent_of[j.child_link_name], j.parent_link_name);
      const bool is_fixed = j.type == urdf::Joint::FIXED;
      bool on_static = false;
      for (const auto& t : fixed) on_static = on_static || t.child_frame_id == j.child_link_name;
      EXPECT_EQ(on_static, is_fixed);
      const se3::SE3 want = joint_transform(j, is_fixed ? 0.0 : q.at(j.name));
      const geometry_msgs::Transform& got = edge[j.child_link_name].transform;
      EXPECT_NEAR(got.translation.x, want.p.x(), 1e-12);
      EXPECT_NEAR(got.translation.y, want.p.y(), 1e-12);
      EXPECT_NEAR(got.translation.z, want.p.z(), 1e-12);
      const se3::Mat3 R = se3::rotation_from_quaternion(got.rotation.x, got.rotation.y,
                                                        got.rotation.z, got.rotation.w);
      EXPECT_LT((R - want.R).norm(), 1e-12);
    }
    EXPECT_EQ(edge.size(), u->joints_.size() + (world_root ? 0 : 1));
  }
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}

// simulator/apply_wrench's link names: the first robot's bare, another robot's as its TF frame
// NS/LINK (its namespace, else its name).
TEST(Tf, LinksOfEveryRobotByTheirFrameNames) {
  const se3::Scene sc = se3::parse_scene(
      "gravity: [0, 0, 0]\nrobots:\n"
      "  - {name: ur5, urdf: data/robots/ur5_robot.urdf, base: fixed}\n"
      "  - {name: panda, urdf: data/robots/panda.urdf, namespace: right, base: fixed,"
      " base_pose: {position: [1, 0, 0]}}\n"
      "  - {name: p2, urdf: data/robots/double_pendulum_simple.urdf, base: fixed,"
      " base_pose: {position: [-1, 0, 0]}}\n",
      kSource, "three.yaml");
  auto sim = se3::make_simulator(sc);
  ASSERT_EQ(sim->robot_count(), 3);
  int robot = -2, link = -2;
  ASSERT_TRUE(se3_ros::find_robot_link(*sim, "tool0", robot, link));
  EXPECT_EQ(robot, 0);
  EXPECT_EQ(link, sim->model().link_index("tool0"));
  ASSERT_TRUE(se3_ros::find_robot_link(*sim, "right/panda_link4", robot, link));
  EXPECT_EQ(robot, 1);
  EXPECT_EQ(link, sim->robot_model(1).link_index("panda_link4"));
  ASSERT_TRUE(se3_ros::find_robot_link(*sim, "p2/link2", robot, link));  // no namespace: name
  EXPECT_EQ(robot, 2);
  EXPECT_EQ(link, sim->robot_model(2).link_index("link2"));
  for (const char* bad : {"panda_link4", "panda/panda_link4", "right/", "right/tool0", "p2/",
                          "nobody/link2", "", "/right/panda_link4"}) {
    EXPECT_FALSE(se3_ros::find_robot_link(*sim, bad, robot, link)) << bad;
    EXPECT_EQ(robot, -1) << bad;
    EXPECT_EQ(link, -1) << bad;
  }
}
