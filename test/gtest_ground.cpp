// The generic scene's ground (ground.h, config/scenes/generic.yaml): a robot given by robot:=
// stands on a ground that touches its collision shapes, as in Gazebo's empty world; a fixed
// base is placed on it unless the scene says base_pose; a free robot lands on it; a ground that
// ignores the robot's shapes says so.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "se3_sim/sim/ground.h"
#include "se3_sim/sim/scene_collision.h"
#include "se3_sim/sim/sim.h"
#include "source_paths.h"

using namespace se3;

namespace {

const std::string kSource = se3_sim_test::source_dir();

// A base box (0.2 m) with an arm hanging 0.5 m below it on a revolute joint (a cylinder along
// the link), its tip 0.6 m under the base's origin at zero; extra: more URDF text.
std::string hanging_arm(const std::string& extra = "") {
  return "<robot name='hanging'>"
         "<link name='base'><inertial><mass value='2'/><inertia ixx='0.01' iyy='0.01' "
         "izz='0.01' ixy='0' ixz='0' iyz='0'/></inertial><collision><geometry><box "
         "size='0.2 0.2 0.2'/></geometry></collision></link>"
         "<link name='arm'><inertial><origin xyz='0 0 -0.25'/><mass value='1'/><inertia "
         "ixx='0.02' iyy='0.02' izz='0.001' ixy='0' ixz='0' iyz='0'/></inertial><collision>"
         "<origin xyz='0 0 -0.25'/><geometry><cylinder radius='0.05' length='0.5'/></geometry>"
         "</collision></link>"
         "<joint name='j' type='revolute'><parent link='base'/><child link='arm'/><origin "
         "xyz='0 0 -0.1'/><axis xyz='0 1 0'/><limit lower='-1' upper='1' effort='10' "
         "velocity='2'/></joint>" +
         extra + "</robot>";
}

Scene generic() {
  Scene s = load_scene(kSource + "/config/scenes/generic.yaml");
  s.floating = false;  // the node's default for a scene without base:
  return s;
}

double lowest(const Simulator& sim, const Scene& scene, const std::string& urdf) {
  return lowest_collision_point(sim.model(), scene_robot_geometry(scene, sim.model(), urdf),
                                sim.state(), Vec3::UnitZ());
}

}  // namespace

TEST(Ground, LowestPointOfPrimitives) {
  const Scene scene = generic();
  const Model m = scene_model(scene, hanging_arm());
  State x(m);
  const GeometryModel g = scene_robot_geometry(scene, m, hanging_arm());
  EXPECT_NEAR(lowest_collision_point(m, g, x, Vec3::UnitZ()), -0.6, 1e-12);
  // Turned 90 degrees about y, the arm lies along x: its side (radius 0.05) at -0.15 under the
  // joint, lower than the box's -0.1.
  x.q[0] = M_PI / 2;
  EXPECT_NEAR(lowest_collision_point(m, g, x, Vec3::UnitZ()), -0.15, 1e-12);
}

TEST(Ground, GenericSceneStandsAFixedArmOnTheGround) {
  const Scene scene = generic();
  auto sim = make_simulator(scene, hanging_arm());
  EXPECT_NEAR(sim->state().base.p.z(), 0.6, 1e-12);
  EXPECT_NEAR(lowest(*sim, scene, hanging_arm()), 0.0, 1e-12);
  // Swung by gravity from a tilt, the arm stays above the ground (it would pass 0.6 m below).
  State x = sim->state();
  x.q[0] = 0.5;
  sim->set_initial_state(x);
  sim->reset();
  double low = 1;
  for (int k = 0; k < 1000; ++k) {
    ASSERT_TRUE(sim->step());
    low = std::min(low, lowest(*sim, scene, hanging_arm()));
  }
  EXPECT_GT(low, -0.01);
}

TEST(Ground, GenericSceneLandsAFreeRobot) {
  Scene scene = generic();
  scene.floating = true;
  auto sim = make_simulator(scene, hanging_arm());
  for (int k = 0; k < 2000; ++k) ASSERT_TRUE(sim->step());
  // Fallen over onto the ground, not through it.
  EXPECT_GT(lowest(*sim, scene, hanging_arm()), -0.01);
  EXPECT_GT(sim->state().base.p.z(), 0.0);
}

TEST(Ground, BasePoseSaysWhereTheBaseGoes) {
  Scene scene = generic();
  scene.base_pose.p = Vec3(0, 0, 2);
  scene.base_pose_given = true;
  auto sim = make_simulator(scene, hanging_arm());
  EXPECT_EQ(sim->state().base.p.z(), 2.0);
}

TEST(Ground, MissingCollisionMeshIsLeftOutOnTheGenericGround) {
  const std::string mesh =
      "<link name='tool'><inertial><mass value='0.1'/><inertia ixx='1e-4' iyy='1e-4' "
      "izz='1e-4' ixy='0' ixz='0' iyz='0'/></inertial><collision><geometry><mesh "
      "filename='package://no_such_package_here/tool.stl'/></geometry></collision></link>"
      "<joint name='t' type='fixed'><parent link='arm'/><child link='tool'/></joint>";
  const Scene scene = generic();
  auto sim = make_simulator(scene, hanging_arm(mesh));
  EXPECT_NEAR(lowest(*sim, scene, hanging_arm(mesh)), 0.0, 1e-12);
}

TEST(Ground, WarnsWhenTheGroundIgnoresTheRobot) {
  const Scene plain = parse_scene("name: t\nground: true\n", ".");
  EXPECT_NE(ground_ignores_robot_warning(plain, true).find("from_collisions"), std::string::npos);
  EXPECT_EQ(ground_ignores_robot_warning(plain, false), "");
  EXPECT_EQ(ground_ignores_robot_warning(generic(), true), "");
  const Scene points =
      parse_scene("name: t\nground: true\ncontacts: {a: {link: base, position: [0, 0, 0]}}\n", ".");
  EXPECT_EQ(ground_ignores_robot_warning(points, true), "");
}

TEST(MeshWarnings, OneLinePerMissingPackage) {
  const Scene scene = generic();
  std::string links;
  for (const char* name : {"a", "b", "c"}) {
    links += std::string("<link name='") + name +
             "'><inertial><mass value='1'/><inertia ixx='0.01' iyy='0.01' izz='0.01' ixy='0' "
             "ixz='0' iyz='0'/></inertial><visual><geometry><mesh "
             "filename='package://no_such_mesh_package/" +
             name +
             ".stl'/></geometry></visual><collision><geometry><mesh "
             "filename='package://no_such_mesh_package/" +
             name + ".stl'/></geometry></collision></link>";
  }
  const std::string urdf =
      "<robot name='r'>" + links +
      "<joint name='ab' type='fixed'><parent link='a'/><child link='b'/></joint>"
      "<joint name='bc' type='fixed'><parent link='b'/><child link='c'/></joint></robot>";
  const Model m = scene_model(scene, urdf);
  GeometryModel g = scene_robot_geometry(scene, m, urdf);
  g.warnings.insert(g.warnings.begin(), "another warning");
  ASSERT_EQ(g.warnings.size(), 7u);  // a visual and a collision line per link
  const std::vector<std::string> out = summarize_mesh_warnings(g.warnings);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0], "another warning");
  EXPECT_NE(out[1].find("package 'no_such_mesh_package' not found: 6 meshes of 3 links (a, b, c)"),
            std::string::npos)
      << out[1];
  EXPECT_NE(out[1].find("ROS_PACKAGE_PATH"), std::string::npos);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
