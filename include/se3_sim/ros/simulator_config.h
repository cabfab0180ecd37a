// The simulator node's configuration (docs/ros.md, "Parameters"): its private parameters read and
// checked into a plain struct, with the defaults, without a ROS master. Each bad value is one
// line that names the parameter (ParamError). The node (simulator_node.cpp) reads it from the
// parameter server; a test reads it from an XmlRpc struct.
#pragma once

#include <xmlrpcpp/XmlRpcValue.h>

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "se3_sim/ros/params.h"
#include "se3_sim/sim/sim.h"

namespace ros {
class NodeHandle;
}

namespace se3_ros {

/// Where parameters come from: the parameter server (NodeParams) or a struct (StructParams).
class ParamSource {
 public:
  virtual ~ParamSource() = default;
  /// Private parameter `name` (without "~"); false when it is not set.
  virtual bool get(const std::string& name, XmlRpc::XmlRpcValue& value) const = 0;
  /// `name` as an error line shows it ("/simulator/dt" from the server, "~dt" from a struct).
  virtual std::string shown(const std::string& name) const = 0;
};

/// The parameters under a node handle's namespace (normally "~").
class NodeParams : public ParamSource {
 public:
  explicit NodeParams(const ros::NodeHandle& nh) : nh_(nh) {}
  bool get(const std::string& name, XmlRpc::XmlRpcValue& value) const override;
  std::string shown(const std::string& name) const override;

 private:
  const ros::NodeHandle& nh_;
};

/// The members of an XmlRpc struct (as getParam of a namespace returns it); anything else holds
/// no parameters.
class StructParams : public ParamSource {
 public:
  explicit StructParams(XmlRpc::XmlRpcValue params) : params_(std::move(params)) {}
  bool get(const std::string& name, XmlRpc::XmlRpcValue& value) const override;
  std::string shown(const std::string& name) const override { return "~" + name; }

 private:
  mutable XmlRpc::XmlRpcValue params_;  // XmlRpcValue's lookups are not const
};

/// The simulator node's private parameters. An override left unset (or "") keeps the scene's.
struct SimulatorConfig {
  std::string urdf_file;  ///< ~urdf_file (robot:=), resolved against ~cwd; "" none
  std::string scene;      ///< ~scene: "auto", a shipped scene's name or a file; "" none
  std::string scene_dir;  ///< ~scene_dir: the shipped scenes
  std::string cwd;        ///< ~cwd: where roslaunch was started ("" unknown)
  // Scene overrides.
  std::optional<bool> floating, joint_limits;
  std::optional<se3::Vec3> gravity;
  std::optional<std::string> integrator;
  std::optional<double> dt, tol, real_time_factor, publish_rate;
  std::vector<std::pair<std::string, double>> initial_positions;  ///< joint: position
  // The node's own.
  double command_timeout = 0.5;  ///< s; 0: never
  std::string world_frame = "world";
  bool lockstep = false;
  std::optional<double> control_period;  ///< s (lockstep); unset: one step
  double max_wrench = 1e4, max_effort = 1e4;
  std::string controller_namespace;      ///< "" this node's (or where the controllers are)
  std::vector<std::string> controllers;  ///< ~controllers: from the parameter server
};

/// Reads and checks the parameters; ParamError naming the first bad one.
SimulatorConfig read_simulator_config(const ParamSource& params);

/// The overrides of `config` onto `scene`; a scene without `base:` gets a fixed base first (the
/// generic defaults, docs/design.md "Launch files").
void apply_scene_overrides(const SimulatorConfig& config, se3::Scene& scene);

/// Physics steps per command in lockstep: ~control_period / dt, rounded, in [1, 1e6].
int lockstep_steps(const SimulatorConfig& config, double dt);

/// The file of the ~scene argument: "auto" is the generic scene when a robot comes from outside
/// (robot_given), else the satellite demo; a name is config/scenes/NAME.yaml (from ~scene_dir)
/// or a file of that name; a relative path is taken from ~cwd. Throws naming the argument.
std::string scene_file(const SimulatorConfig& config, bool robot_given);

/// "gx gy gz", "[gx, gy, gz]" or "gx,gy,gz": three finite numbers; ParamError naming `name`.
se3::Vec3 parse_vec3(std::string text, const std::string& name);
/// A YAML map of joint names to finite numbers ("{j1: 0.5, j2: -1}"); "" or "{}" for none.
std::vector<std::pair<std::string, double>> joint_values(const std::string& text,
                                                         const std::string& name);

}  // namespace se3_ros
