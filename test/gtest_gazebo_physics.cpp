// The <gazebo> tags that change the physics (docs/gazebo.md): gravity per link.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "se3_sim/sim/controllers.h"
#include "se3_sim/sim/sim.h"

using namespace se3;

namespace {

// A fixed base with a 0.5 m arm held horizontal (revolute about y), its point mass at the tip;
// `tag`: <gazebo> text.
std::string arm(const std::string& tag) {
  return "<robot name='arm'><link name='base'/>"
         "<link name='arm'><inertial><origin xyz='0.5 0 0'/><mass value='1'/><inertia "
         "ixx='1e-3' iyy='1e-3' izz='1e-3' ixy='0' ixz='0' iyz='0'/></inertial></link>"
         "<joint name='j' type='continuous'><parent link='base'/><child link='arm'/><axis "
         "xyz='0 1 0'/></joint>" +
         tag + "</robot>";
}

// A free box (1 kg), `tag`: <gazebo> text.
std::string box(const std::string& tag) {
  return "<robot name='box'><link name='box'><inertial><mass value='1'/><inertia ixx='0.01' "
         "iyy='0.01' izz='0.01' ixy='0' ixz='0' iyz='0'/></inertial></link>" +
         tag + "</robot>";
}

double after(const Scene& scene, const std::string& urdf, double seconds, bool base_z) {
  auto sim = make_simulator(scene, urdf);
  for (int k = 0; k < int(std::lround(seconds / sim->dt())); ++k) EXPECT_TRUE(sim->step());
  return base_z ? sim->state().base.p.z() : sim->state().q[0];
}

}  // namespace

TEST(GazeboGravity, ALinkWithoutGravityFeelsNone) {
  const Scene fixed = parse_scene("name: t\nbase: fixed\njoint_limits: false\n", ".");
  const std::string off = "<gazebo reference='arm'><gravity>false</gravity></gazebo>";
  // Untagged, the arm falls (about y: positive angle lowers +x); without gravity it stays.
  EXPECT_GT(std::abs(after(fixed, arm(""), 0.3, false)), 0.3);
  EXPECT_NEAR(after(fixed, arm(off), 0.3, false), 0.0, 1e-9);
  EXPECT_NEAR(
      after(fixed, arm("<gazebo reference='arm'><gravity>true</gravity></gazebo>"), 0.3, false),
      after(fixed, arm(""), 0.3, false), 1e-12);
  // A free body: falls g t^2 / 2 = 4.905 m in 1 s, or not at all.
  const Scene free = parse_scene("name: t\nbase: free\n", ".");
  EXPECT_NEAR(after(free, box(""), 1.0, true), -4.905, 1e-3);
  EXPECT_NEAR(after(free, box("<gazebo reference='box'><gravity>0</gravity></gazebo>"), 1.0, true),
              0.0, 1e-9);
}

TEST(GazeboGravity, KeptThroughReset) {
  const Scene free = parse_scene("name: t\nbase: free\n", ".");
  auto sim = make_simulator(free, box("<gazebo reference='box'><gravity>false</gravity></gazebo>"));
  for (int k = 0; k < 100; ++k) ASSERT_TRUE(sim->step());
  sim->reset();
  sim->clear_link_wrenches();
  for (int k = 0; k < 500; ++k) ASSERT_TRUE(sim->step());
  EXPECT_NEAR(sim->state().base.p.z(), 0.0, 1e-9);
}

namespace {

// A free 0.1 m box (collision) with its bottom `depth` m into the ground, no gravity: the
// contact pushes it out at the scene's or the link's correction; returns its upward speed after
// one step.
double push_out(const std::string& tag, double depth) {
  const Scene scene = parse_scene(
      "name: t\nbase: free\ngravity: [0, 0, 0]\nground: {from_collisions: true}\n"
      "constraint_options: {max_correction_velocity: 10}\n"
      "base_pose: {position: [0, 0, " +
          std::to_string(0.05 - depth) + "]}\n",
      ".");
  const std::string urdf =
      "<robot name='box'><link name='box'><inertial><mass value='1'/><inertia ixx='0.01' "
      "iyy='0.01' izz='0.01' ixy='0' ixz='0' iyz='0'/></inertial><collision><geometry><box "
      "size='0.1 0.1 0.1'/></geometry></collision></link>" +
      tag + "</robot>";
  auto sim = make_simulator(scene, urdf);
  EXPECT_TRUE(sim->step());
  return sim->state().v[5];  // the base twist [w; v] in its frame (unrotated here)
}

}  // namespace

TEST(GazeboContact, KpKdMinDepthMaxVelSetTheCorrection) {
  const double h = 0.001;
  auto tag = [](const std::string& body) {
    return "<gazebo reference='box'>" + body + "</gazebo>";
  };
  // The scene's: erp 0.2, slop 1e-4.
  EXPECT_NEAR(push_out("", 0.004), 0.2 * (0.004 - 1e-4) / h, 1e-6);
  // kp 1e5, kd 900 at h = 1 ms: ERP = 100 / (100 + 900) = 0.1.
  EXPECT_NEAR(push_out(tag("<kp>1e5</kp><kd>900</kd>"), 0.004), 0.1 * (0.004 - 1e-4) / h, 1e-6);
  // minDepth: penetration left alone.
  EXPECT_NEAR(push_out(tag("<minDepth>0.001</minDepth>"), 0.004), 0.2 * (0.004 - 0.001) / h, 1e-6);
  // maxVel: the push-out speed at most.
  EXPECT_NEAR(push_out(tag("<maxVel>0.05</maxVel>"), 0.004), 0.05, 1e-6);
}

TEST(GazeboControlPeriod, ControllersUpdateEveryControlPeriod) {
  const Scene fixed = parse_scene("name: t\nbase: fixed\njoint_limits: false\n", ".");
  const std::string plugin =
      "<gazebo><plugin name='gazebo_ros_control' filename='libgazebo_ros_control.so'>"
      "<controlPeriod>0.005</controlPeriod></plugin></gazebo>";
  const std::vector<ControllerSpec> pd = parse_controllers_text(
      "hold:\n  type: effort_controllers/JointPositionController\n  joint: j\n"
      "  pid: {p: 50, d: 5}\n");
  auto run = [&](const std::string& tag, std::vector<double>& efforts) {
    auto sim = make_simulator(fixed, arm(tag));
    sim->set_controllers(pd);
    for (int k = 0; k < 10; ++k) {
      EXPECT_TRUE(sim->step());
      efforts.push_back(sim->actuation()[0]);
    }
    return sim->control_every();
  };
  std::vector<double> every, held;
  EXPECT_EQ(run("", every), 1);
  EXPECT_EQ(run(plugin, held), 5);
  // Held over five steps (dt 1 ms), updated on the sixth; without the tag every step differs.
  for (int k = 1; k < 5; ++k) EXPECT_EQ(held[k], held[0]);
  EXPECT_NE(held[5], held[4]);
  EXPECT_NE(every[1], every[0]);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
