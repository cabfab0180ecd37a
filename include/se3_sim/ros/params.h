// Typed ROS parameters for the nodes: values read from XmlRpc as they are (a double stays the
// double it was; a string is parsed with full precision), so no ~dt or ~tol is rounded on the
// way. roslaunch passes `type="str"` parameters and args as strings, and an empty string means
// "not set" (sim.launch always sets its overrides, empty meaning "keep the scene's value").
// Plus the controllers of ros_control's YAML as loaded onto the parameter server.
#pragma once

#include <ros/node_handle.h>
#include <xmlrpcpp/XmlRpcValue.h>

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "se3_sim/sim/controllers.h"

namespace YAML {
class Node;
}

namespace se3_ros {

/// Thrown for a parameter that is set but cannot be used; the message names it.
struct ParamError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// A number: a double or int value, or a string holding a finite number. nullopt for the empty
/// string; ParamError (naming `name`) for anything else.
std::optional<double> to_double(const XmlRpc::XmlRpcValue& v, const std::string& name);
/// A boolean: bool, int 0 / 1, or the strings true/false/True/False/1/0. nullopt for "".
std::optional<bool> to_bool(const XmlRpc::XmlRpcValue& v, const std::string& name);
/// A string (a number is refused: a name is expected). nullopt for "".
std::optional<std::string> to_text(const XmlRpc::XmlRpcValue& v, const std::string& name);
/// A list of names: an array of strings, or one string of names separated by spaces or commas
/// (roslaunch's controllers:="a b"). Empty for "".
std::vector<std::string> to_names(const XmlRpc::XmlRpcValue& v, const std::string& name);

/// The same from the parameter server: nullopt (empty) when the parameter is not set.
std::optional<double> get_double(const ros::NodeHandle& nh, const std::string& name);
std::optional<bool> get_bool(const ros::NodeHandle& nh, const std::string& name);
std::optional<std::string> get_text(const ros::NodeHandle& nh, const std::string& name);
std::vector<std::string> get_names(const ros::NodeHandle& nh, const std::string& name);

/// An XmlRpc value as a YAML tree (doubles printed with 17 digits, so they read back exactly).
YAML::Node to_yaml(const XmlRpc::XmlRpcValue& v);

/// Controllers `names` from XmlRpc structs (`configs[k]` is what the parameter server holds
/// under NAME: {type, joints, ...}), parsed with se3::parse_controller. Throws
/// se3::ControllerError naming `where` and the controller.
std::vector<se3::ControllerSpec> controllers_from_xmlrpc(
    const std::vector<std::string>& names, const std::vector<XmlRpc::XmlRpcValue>& configs,
    const std::string& where);
/// The controllers `names`, read from the parameter server under nh's namespace (NAME/type,
/// NAME/joints, ...: a controller_config YAML loaded with rosparam). With `errors` null a
/// controller that cannot be read (missing, unsupported type, bad keys) is an error; else it is
/// left out and its one-line error appended there (as Gazebo's spawner fails that controller
/// and starts the others).
std::vector<se3::ControllerSpec> controllers_from_params(
    const ros::NodeHandle& nh, const std::vector<std::string>& names,
    std::vector<std::string>* errors = nullptr);
/// Where controllers `names` not under nh are declared: the one namespace N of the parameter
/// server with N/NAME/type for each of them (rrbot's YAML `rrbot: {joint1_position_controller:
/// ...}` loaded at the root declares /rrbot). "" when each is under nh, or no one namespace
/// holds them all (the error of controllers_from_params then says where it looked).
std::string declared_controller_namespace(const ros::NodeHandle& nh,
                                          const std::vector<std::string>& names);
/// The controllers' namespace when ~controller_namespace is empty: the URDF's gazebo_ros_control
/// <robotNamespace> (where Gazebo runs them) when the named controllers are there, else
/// declared_controller_namespace (an info line says so), else "" (nh's).
std::string controllers_namespace(const ros::NodeHandle& nh, const std::string& urdf_text,
                                  const se3::Model& model, const std::vector<std::string>& names);

}  // namespace se3_ros
