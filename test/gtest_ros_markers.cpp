// The simulator node's markers without a master (sim_markers.h): sim_markers and
// constraint_forces of known states, checked for their namespaces, ids, frames, poses and colours.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "se3_sim/ros/sim_markers.h"

namespace {

std_msgs::Header world_header(double t) {
  std_msgs::Header h;
  h.frame_id = "world";
  h.stamp = ros::Time(t);
  return h;
}

se3::Vec3 vec(const geometry_msgs::Point& p) {
  return se3::Vec3(p.x, p.y, p.z);
}

// A free chain:2 with the scene's box on its base and one object (a crate).
const char* kScene =
    "robot: chain:2\n"
    "base: free\n"
    "gravity: [0, 0, 0]\n"
    "base_visual: {box: [0.4, 0.6, 0.8], origin: [1, 0, 0], color: [0.1, 0.2, 0.3]}\n"
    "objects:\n"
    "  - {name: crate, shape: {box: [0.1, 0.2, 0.3]}, pose: {position: [2, 0, 0.15]},"
    " color: [0, 1, 0]}\n";

}  // namespace

TEST(RosMarkers, CentreOfMassSphere) {
  const visualization_msgs::Marker m = se3_ros::com_marker(se3::Vec3(1, -2, 3), world_header(4));
  EXPECT_EQ(m.ns, "com");
  EXPECT_EQ(m.id, 0);
  EXPECT_EQ(m.header.frame_id, "world");
  EXPECT_DOUBLE_EQ(m.header.stamp.toSec(), 4.0);
  EXPECT_EQ(m.type, visualization_msgs::Marker::SPHERE);
  EXPECT_EQ(m.action, visualization_msgs::Marker::ADD);
  EXPECT_EQ(vec(m.pose.position), se3::Vec3(1, -2, 3));
  EXPECT_EQ(m.pose.orientation.w, 1.0);
  EXPECT_EQ(m.scale.x, 0.05);
  EXPECT_EQ(m.scale.z, 0.05);
  EXPECT_FLOAT_EQ(m.color.r, 1.0f);
  EXPECT_FLOAT_EQ(m.color.g, 0.8f);
  EXPECT_FLOAT_EQ(m.color.b, 0.0f);
  EXPECT_FLOAT_EQ(m.color.a, 1.0f);
}

// The whole array of a known scene: its base turned a quarter about z and moved.
TEST(RosMarkers, KnownSceneInOrder) {
  const se3::Scene scene = se3::parse_scene(kScene, ".", "known.yaml");
  auto sim = se3::make_simulator(scene);
  const se3::Model& model = sim->model();
  ASSERT_TRUE(model.floating);
  ASSERT_EQ(model.n, 2);
  se3::State x = sim->state();
  x.base.R = Eigen::AngleAxisd(M_PI / 2, se3::Vec3::UnitZ()).toRotationMatrix();
  x.base.p = se3::Vec3(0, 0, 1);
  sim->set_state(x);
  sim->set_joint_effort(1, 5.0);  // joint 2: none
  visualization_msgs::MarkerArray out;
  se3_ros::sim_markers(*sim, scene, world_header(0.5), out);
  // com, the crate, the bus, two torque arrows.
  ASSERT_EQ(out.markers.size(), 5u);
  for (const auto& m : out.markers) {
    EXPECT_EQ(m.header.frame_id, "world") << m.ns;
    EXPECT_DOUBLE_EQ(m.header.stamp.toSec(), 0.5) << m.ns;
  }
  EXPECT_EQ(out.markers[0].ns, "com");
  EXPECT_TRUE(vec(out.markers[0].pose.position).isApprox(sim->center_of_mass(), 1e-12));

  const visualization_msgs::Marker& crate = out.markers[1];
  EXPECT_EQ(crate.ns, "objects");
  EXPECT_EQ(crate.type, visualization_msgs::Marker::CUBE);
  EXPECT_NEAR((vec(crate.pose.position) - se3::Vec3(2, 0, 0.15)).norm(), 0, 1e-12);
  EXPECT_FLOAT_EQ(crate.color.g, 1.0f);

  const visualization_msgs::Marker& bus = out.markers[2];
  EXPECT_EQ(bus.ns, "base_visual");
  EXPECT_EQ(bus.id, 0);
  EXPECT_EQ(bus.type, visualization_msgs::Marker::CUBE);
  // Its centre 1 m along the base's x, which the quarter turn points along the world's y.
  EXPECT_NEAR((vec(bus.pose.position) - se3::Vec3(0, 1, 1)).norm(), 0, 1e-12);
  EXPECT_NEAR(bus.pose.orientation.z, std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(bus.pose.orientation.w, std::sqrt(0.5), 1e-12);
  EXPECT_EQ(bus.scale.y, 0.6);
  EXPECT_FLOAT_EQ(bus.color.r, 0.1f);
  EXPECT_FLOAT_EQ(bus.color.g, 0.2f);
  EXPECT_FLOAT_EQ(bus.color.b, 0.3f);

  // Joint 1's effort: an arrow from its body's origin along its z axis, red; joint 2: DELETE.
  const visualization_msgs::Marker& a1 = out.markers[3];
  EXPECT_EQ(a1.ns, "torque");
  EXPECT_EQ(a1.id, 1);
  EXPECT_EQ(a1.type, visualization_msgs::Marker::ARROW);
  EXPECT_EQ(a1.action, visualization_msgs::Marker::ADD);
  ASSERT_EQ(a1.points.size(), 2u);
  const se3::SE3& body1 = sim->body_poses()[1];
  const double lim = std::isfinite(model.effort[1]) && model.effort[1] > 0 ? model.effort[1] : 10;
  const double len = 0.05 + 0.25 * std::min(1.0, 5.0 / lim);
  EXPECT_NEAR((vec(a1.points[0]) - body1.p).norm(), 0, 1e-12);
  EXPECT_NEAR((vec(a1.points[1]) - (body1.p + len * body1.R.col(2))).norm(), 0, 1e-12);
  EXPECT_FLOAT_EQ(a1.color.r, 1.0f);
  EXPECT_FLOAT_EQ(a1.color.b, 0.2f);
  EXPECT_EQ(out.markers[4].ns, "torque");
  EXPECT_EQ(out.markers[4].id, 2);
  EXPECT_EQ(out.markers[4].action, visualization_msgs::Marker::DELETE);

  // Without a base_visual: no bus.
  se3::Scene plain = scene;
  plain.has_base_visual = false;
  visualization_msgs::MarkerArray out2;
  se3_ros::sim_markers(*sim, plain, world_header(0.5), out2);
  EXPECT_EQ(out2.markers.size(), 4u);
  for (const auto& m : out2.markers) EXPECT_NE(m.ns, "base_visual");
}

TEST(RosMarkers, TorqueArrowsPointWithTheEffortsSign) {
  const se3::Scene scene = se3::parse_scene("robot: chain:1\nbase: fixed\n", ".");
  auto sim = se3::make_simulator(scene);
  const se3::Model& m = sim->model();
  std::vector<se3::SE3> oMb(m.n + 1);
  oMb[1].p = se3::Vec3(1, 2, 3);
  se3::VecX act = se3::VecX::Zero(m.nv);
  act[m.idx_v(1)] = -1e6;  // far above any limit: the longest arrow, 0.3 m
  visualization_msgs::MarkerArray out;
  se3_ros::append_torque_markers(m, oMb, act, world_header(0), out);
  ASSERT_EQ(out.markers.size(), 1u);
  const visualization_msgs::Marker& a = out.markers[0];
  EXPECT_EQ(a.id, 1);
  EXPECT_NEAR((vec(a.points[1]) - se3::Vec3(1, 2, 3 - 0.3)).norm(), 0, 1e-12);  // along -z
  EXPECT_FLOAT_EQ(a.color.r, 0.2f);
  EXPECT_FLOAT_EQ(a.color.b, 1.0f);
}

TEST(RosMarkers, ConstraintForcesMessageAndArrows) {
  const se3::Scene scene = se3::parse_scene("robot: chain:2\nbase: fixed\n", ".");
  auto sim = se3::make_simulator(scene);
  const se3::Model& m = sim->model();
  const double weight = m.total_mass() * 9.81;
  std::vector<se3::ConstraintForce> forces(4);
  forces[0].kind = se3::ConstraintForce::Contact;  // half the weight, up: 0.15 m
  forces[0].name = "contact:foot";
  forces[0].body = 2;
  forces[0].point = se3::Vec3(1, 0, 0);
  forces[0].force = se3::Vec3(0, 0, 0.5 * weight);
  forces[0].active = true;
  forces[1].kind = se3::ConstraintForce::Limit;  // inactive
  forces[1].name = "limit:j1";
  forces[1].body = 1;
  forces[1].gap = 0.1;
  forces[2].kind = se3::ConstraintForce::Bilateral;  // non-finite: zeros, not active
  forces[2].body = 1;
  forces[2].force = se3::Vec3(NAN, 0, 0);
  forces[2].active = true;
  forces[3].kind = se3::ConstraintForce::Bilateral;  // 100 weights: capped at 0.6 m
  forces[3].body = 99;                               // no such body: no link name
  forces[3].force = se3::Vec3(-100 * weight, 0, 0);
  forces[3].active = true;
  se3_sim::ConstraintForces cf;
  visualization_msgs::MarkerArray out;
  se3_ros::append_constraint_forces(m, forces, world_header(1), cf, out);
  ASSERT_EQ(cf.name.size(), 4u);
  EXPECT_EQ(cf.header.frame_id, "world");
  EXPECT_EQ(cf.name[0], "contact:foot");
  EXPECT_EQ(cf.kind[0], se3::ConstraintForce::Contact);
  EXPECT_EQ(cf.link[0], m.body_name[2]);
  EXPECT_EQ(cf.link[3], "");
  EXPECT_TRUE(cf.active[0]);
  EXPECT_FALSE(cf.active[1]);
  EXPECT_FALSE(cf.active[2]);
  EXPECT_EQ(cf.force[2].x, 0.0);
  EXPECT_DOUBLE_EQ(cf.gap[1], 0.1);
  ASSERT_EQ(out.markers.size(), 4u);
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(out.markers[k].ns, "constraint");
    EXPECT_EQ(out.markers[k].id, k);
    EXPECT_EQ(out.markers[k].header.frame_id, "world");
  }
  const visualization_msgs::Marker& c = out.markers[0];
  EXPECT_EQ(c.action, visualization_msgs::Marker::ADD);
  EXPECT_NEAR((vec(c.points[0]) - se3::Vec3(1, 0, 0)).norm(), 0, 1e-12);
  EXPECT_NEAR((vec(c.points[1]) - se3::Vec3(1, 0, 0.15)).norm(), 0, 1e-12);
  EXPECT_FLOAT_EQ(c.color.g, 0.9f);
  EXPECT_FLOAT_EQ(c.color.b, 0.2f);  // contact
  EXPECT_EQ(out.markers[1].action, visualization_msgs::Marker::DELETE);
  EXPECT_EQ(out.markers[2].action, visualization_msgs::Marker::DELETE);
  EXPECT_NEAR((vec(out.markers[3].points[1]) - se3::Vec3(-0.6, 0, 0)).norm(), 0, 1e-12);
  EXPECT_FLOAT_EQ(out.markers[3].color.b, 0.9f);  // not contact
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
