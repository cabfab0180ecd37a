// The simulator node's configuration without a master (simulator_config.h): its private
// parameters as an XmlRpc struct, read into SimulatorConfig with the defaults, and each bad value
// refused by one line that names the parameter.
#include <gtest/gtest.h>

#include <string>

#include "se3_sim/ros/simulator_config.h"
#include "source_paths.h"

using XmlRpc::XmlRpcValue;

namespace {

const std::string kSource = se3_sim_test::source_dir();

// The parameters {name: value, ...} as roslaunch leaves them (strings, or typed values).
XmlRpcValue params(std::initializer_list<std::pair<const char*, XmlRpcValue>> kv) {
  XmlRpcValue s;
  s.begin();  // an empty struct
  for (const auto& p : kv) s[p.first] = p.second;
  return s;
}

se3_ros::SimulatorConfig read(const XmlRpcValue& p) {
  return se3_ros::read_simulator_config(se3_ros::StructParams(p));
}

// The ParamError's line for one parameter set to `value` ("" if it is taken).
std::string error_for(const char* name, const XmlRpcValue& value) {
  try {
    read(params({{name, value}}));
  } catch (const se3_ros::ParamError& e) {
    return e.what();
  }
  return "";
}

XmlRpcValue str(const char* s) {
  return XmlRpcValue(std::string(s));
}

}  // namespace

TEST(RosConfig, DefaultsWithoutParameters) {
  for (const XmlRpcValue& p : {XmlRpcValue(), params({})}) {
    const se3_ros::SimulatorConfig c = read(p);
    EXPECT_EQ(c.urdf_file, "");
    EXPECT_EQ(c.scene, "");
    EXPECT_FALSE(c.floating || c.joint_limits || c.gravity || c.integrator);
    EXPECT_FALSE(c.dt || c.tol || c.real_time_factor || c.publish_rate || c.control_period);
    EXPECT_TRUE(c.initial_positions.empty());
    EXPECT_EQ(c.command_timeout, 0.5);
    EXPECT_EQ(c.world_frame, "world");
    EXPECT_FALSE(c.lockstep);
    EXPECT_EQ(c.max_wrench, 1e4);
    EXPECT_EQ(c.max_effort, 1e4);
    EXPECT_EQ(c.controller_namespace, "");
    EXPECT_TRUE(c.controllers.empty());
  }
}

TEST(RosConfig, ValuesAsRoslaunchPassesThem) {
  // sim.launch sets every override; "" means "the scene's".
  const se3_ros::SimulatorConfig c = read(params({{"urdf_file", str("robots/arm.urdf")},
                                                  {"cwd", str("/home/me")},
                                                  {"scene", str("auto")},
                                                  {"floating", str("true")},
                                                  {"joint_limits", str("")},
                                                  {"gravity", str("[0, 0, -1.62]")},
                                                  {"integrator", str("rk4")},
                                                  {"dt", str("0.0005")},
                                                  {"tol", XmlRpcValue(1e-9)},
                                                  {"real_time_factor", XmlRpcValue(0)},
                                                  {"publish_rate", str("")},
                                                  {"initial_positions", str("{j1: 0.5, j2: -1}")},
                                                  {"command_timeout", XmlRpcValue(0.0)},
                                                  {"world_frame", str("/map")},
                                                  {"lockstep", XmlRpcValue(true)},
                                                  {"control_period", str("0.01")},
                                                  {"max_wrench", XmlRpcValue(50)},
                                                  {"max_effort", str("80")},
                                                  {"controllers", str("arm, gripper")}}));
  EXPECT_EQ(c.urdf_file, "/home/me/robots/arm.urdf");  // relative to where roslaunch runs
  EXPECT_EQ(c.scene, "auto");
  ASSERT_TRUE(c.floating);
  EXPECT_TRUE(*c.floating);
  EXPECT_FALSE(c.joint_limits);
  ASSERT_TRUE(c.gravity);
  EXPECT_EQ(*c.gravity, se3::Vec3(0, 0, -1.62));
  EXPECT_EQ(c.integrator.value_or(""), "rk4");
  EXPECT_EQ(c.dt.value_or(0), 0.0005);
  EXPECT_EQ(c.tol.value_or(0), 1e-9);
  EXPECT_EQ(c.real_time_factor.value_or(-1), 0.0);
  EXPECT_FALSE(c.publish_rate);
  ASSERT_EQ(c.initial_positions.size(), 2u);
  EXPECT_EQ(c.initial_positions[1].first, "j2");
  EXPECT_EQ(c.initial_positions[1].second, -1.0);
  EXPECT_EQ(c.command_timeout, 0.0);
  EXPECT_EQ(c.world_frame, "map");  // tf2 frames have no leading '/'
  EXPECT_TRUE(c.lockstep);
  EXPECT_EQ(c.max_wrench, 50.0);
  EXPECT_EQ(c.max_effort, 80.0);
  EXPECT_EQ(c.controllers, (std::vector<std::string>{"arm", "gripper"}));
  EXPECT_EQ(se3_ros::lockstep_steps(c, 0.0005), 20);
  EXPECT_EQ(se3_ros::lockstep_steps(se3_ros::SimulatorConfig(), 0.001), 1);  // one step
  se3_ros::SimulatorConfig slow;
  slow.control_period = 1e9;
  EXPECT_EQ(se3_ros::lockstep_steps(slow, 1e-3), 1000000);
}

// Every bad value: one line that names the parameter and says what it needs.
TEST(RosConfig, BadParameterNamedInTheError) {
  struct Case {
    const char* name;
    XmlRpcValue value;
    const char* says;
  };
  const Case cases[] = {
      {"dt", str("fast"), "~dt needs a number, got 'fast'"},
      {"dt", XmlRpcValue(0.0), "~dt 0 s"},
      {"dt", XmlRpcValue(-0.001), "~dt -0.001 s"},
      {"dt", XmlRpcValue(1e-12), "~dt 1e-12 s"},  // below the minimum
      {"tol", XmlRpcValue(0.0), "~tol must be > 0"},
      {"real_time_factor", XmlRpcValue(-1.0), "~real_time_factor must be >= 0"},
      {"publish_rate", str("0"), "~publish_rate must be > 0"},
      {"command_timeout", XmlRpcValue(-0.1), "~command_timeout must be >= 0"},
      {"control_period", XmlRpcValue(0.0), "~control_period must be > 0"},
      {"max_wrench", XmlRpcValue(0.0), "~max_wrench must be > 0"},
      {"max_effort", str("-5"), "~max_effort must be > 0"},
      {"gravity", str("0 -9.81"), "~gravity needs three numbers"},
      {"gravity", str("0 0 nan"), "~gravity needs three numbers"},
      {"floating", str("maybe"), "~floating needs true or false, got 'maybe'"},
      {"lockstep", XmlRpcValue(2.5), "~lockstep needs true or false"},
      {"initial_positions", str("[1, 2]"), "~initial_positions needs a map joint: value"},
      {"initial_positions", str("{j1: up}"), "~initial_positions: joint 'j1' needs a number"},
      {"initial_positions", str("{j1: .inf}"), "~initial_positions: joint 'j1' is not finite"},
      {"initial_positions", str("{j1: [}"), "~initial_positions: "},
      {"world_frame", str("/"), "~world_frame must name a frame"},
      {"scene", XmlRpcValue(3), "~scene needs a name"},
      {"controllers", XmlRpcValue(1.5), "~controllers needs names"},
  };
  for (const Case& c : cases) {
    const std::string e = error_for(c.name, c.value);
    EXPECT_NE(e.find(c.says), std::string::npos) << c.name << ": '" << e << "'";
    EXPECT_EQ(e.find('\n'), std::string::npos) << e;
  }
  // Good values of the same parameters are taken.
  EXPECT_EQ(error_for("dt", str("1e-3")), "");
  EXPECT_EQ(error_for("real_time_factor", XmlRpcValue(0.0)), "");
  EXPECT_EQ(error_for("command_timeout", XmlRpcValue(0.0)), "");
  EXPECT_EQ(error_for("initial_positions", str("{}")), "");
}

TEST(RosConfig, OverridesOnTheScene) {
  se3::Scene s = se3::parse_scene("robot: chain:2\ndt: 0.002\ngravity: [0, 0, -9.81]\n", ".");
  s.floating = true;
  se3::Scene kept = s;
  se3_ros::apply_scene_overrides(se3_ros::SimulatorConfig(), kept);
  EXPECT_FALSE(kept.floating);  // no `base:` in the scene: fixed (the generic defaults)
  EXPECT_EQ(kept.dt, 0.002);
  EXPECT_EQ(kept.gravity, se3::Vec3(0, 0, -9.81));
  const se3_ros::SimulatorConfig c = read(params({{"floating", str("true")},
                                                  {"dt", XmlRpcValue(0.001)},
                                                  {"gravity", str("0 0 0")},
                                                  {"joint_limits", str("false")},
                                                  {"real_time_factor", XmlRpcValue(2)},
                                                  {"publish_rate", XmlRpcValue(25)}}));
  se3_ros::apply_scene_overrides(c, s);
  EXPECT_TRUE(s.floating);
  EXPECT_EQ(s.dt, 0.001);
  EXPECT_EQ(s.gravity, se3::Vec3::Zero());
  EXPECT_FALSE(s.constraints.joint_limits);
  EXPECT_EQ(s.real_time_factor, 2.0);
  EXPECT_EQ(s.publish_rate, 25.0);
}

TEST(RosConfig, SceneArgumentToFile) {
  se3_ros::SimulatorConfig c;
  c.scene_dir = kSource + "/config/scenes";
  c.cwd = "/home/me";
  c.scene = "auto";
  EXPECT_EQ(se3_ros::scene_file(c, true), c.scene_dir + "/generic.yaml");
  EXPECT_EQ(se3_ros::scene_file(c, false), c.scene_dir + "/satellite_arm.yaml");
  c.scene = "fixed_panda.yaml";
  EXPECT_EQ(se3_ros::scene_file(c, false), c.scene_dir + "/fixed_panda.yaml");
  c.scene = "mine/world.yaml";  // a path: from where roslaunch runs
  EXPECT_EQ(se3_ros::scene_file(c, false), "/home/me/mine/world.yaml");
  c.scene = "/abs/world.yaml";
  EXPECT_EQ(se3_ros::scene_file(c, false), "/abs/world.yaml");
  c.scene = "no_such_scene";
  try {
    se3_ros::scene_file(c, false);
    ADD_FAILURE() << "no error";
  } catch (const se3_ros::ParamError& e) {
    EXPECT_NE(
        std::string(e.what()).find("scene 'no_such_scene' is neither a scene of " + c.scene_dir),
        std::string::npos)
        << e.what();
  }
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
