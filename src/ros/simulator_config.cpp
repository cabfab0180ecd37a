// The simulator node's configuration (simulator_config.h).
#include "se3_sim/ros/simulator_config.h"

#include <ros/node_handle.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "se3_sim/model/limits.h"

namespace se3_ros {

bool NodeParams::get(const std::string& name, XmlRpc::XmlRpcValue& value) const {
  return nh_.getParam(name, value);
}

std::string NodeParams::shown(const std::string& name) const {
  return nh_.resolveName(name);
}

bool StructParams::get(const std::string& name, XmlRpc::XmlRpcValue& value) const {
  if (params_.getType() != XmlRpc::XmlRpcValue::TypeStruct || !params_.hasMember(name)) {
    return false;
  }
  value = params_[name];
  return true;
}

se3::Vec3 parse_vec3(std::string text, const std::string& name) {
  for (char& c : text) {
    if (c == '[' || c == ']' || c == ',') c = ' ';
  }
  std::istringstream in(text);
  se3::Vec3 v;
  std::string rest;
  if (!(in >> v.x() >> v.y() >> v.z()) || (in >> rest) || !v.allFinite()) {
    throw ParamError(name + " needs three numbers, e.g. \"0 0 -9.81\" (got '" + text + "')");
  }
  return v;
}

std::vector<std::pair<std::string, double>> joint_values(const std::string& text,
                                                         const std::string& name) {
  std::vector<std::pair<std::string, double>> out;
  if (text.empty()) return out;
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ParamError(name + ": " + e.what());
  }
  if (root.IsNull()) return out;
  if (!root.IsMap()) {
    throw ParamError(name + " needs a map joint: value, e.g. \"{joint1: 0.5}\" (got '" + text +
                     "')");
  }
  for (const auto& kv : root) {
    const std::string joint = kv.first.as<std::string>();
    double value = 0;
    try {
      value = kv.second.as<double>();
    } catch (const YAML::Exception&) {
      throw ParamError(name + ": joint '" + joint + "' needs a number");
    }
    if (!std::isfinite(value)) throw ParamError(name + ": joint '" + joint + "' is not finite");
    out.emplace_back(joint, value);
  }
  return out;
}

namespace {

// One parameter: nullopt when unset (or ""), else converted by `to` (to_double, ...), which
// throws ParamError naming it.
template <class F>
auto param(const ParamSource& p, const std::string& name, F to)
    -> decltype(to(XmlRpc::XmlRpcValue(), name)) {
  XmlRpc::XmlRpcValue v;
  if (!p.get(name, v)) return {};
  return to(v, p.shown(name));
}

void require(bool ok, const ParamSource& p, const std::string& name, const std::string& rule) {
  if (!ok) throw ParamError(p.shown(name) + " " + rule);
}

}  // namespace

SimulatorConfig read_simulator_config(const ParamSource& p) {
  SimulatorConfig c;
  c.urdf_file = param(p, "urdf_file", to_text).value_or("");
  c.scene = param(p, "scene", to_text).value_or("");
  c.scene_dir = param(p, "scene_dir", to_text).value_or("");
  c.cwd = param(p, "cwd", to_text).value_or("");
  if (!c.urdf_file.empty() && c.urdf_file[0] != '/' && !c.cwd.empty()) {
    c.urdf_file = c.cwd + "/" + c.urdf_file;  // relative to where roslaunch runs
  }
  c.floating = param(p, "floating", to_bool);
  c.joint_limits = param(p, "joint_limits", to_bool);
  if (auto g = param(p, "gravity", to_text)) c.gravity = parse_vec3(*g, p.shown("gravity"));
  c.integrator = param(p, "integrator", to_text);
  c.dt = param(p, "dt", to_double);
  if (c.dt) {
    const std::string why = se3::dt_problem(*c.dt);
    require(why.empty(), p, "dt", se3::three_figures(*c.dt) + " s " + why);
  }
  c.tol = param(p, "tol", to_double);
  require(!c.tol || *c.tol > 0, p, "tol", "must be > 0");
  c.real_time_factor = param(p, "real_time_factor", to_double);
  require(!c.real_time_factor || *c.real_time_factor >= 0, p, "real_time_factor",
          "must be >= 0 (0: as fast as possible)");
  c.publish_rate = param(p, "publish_rate", to_double);
  require(!c.publish_rate || *c.publish_rate > 0, p, "publish_rate", "must be > 0");
  c.initial_positions = joint_values(param(p, "initial_positions", to_text).value_or(""),
                                     p.shown("initial_positions"));
  c.command_timeout = param(p, "command_timeout", to_double).value_or(0.5);
  require(c.command_timeout >= 0, p, "command_timeout", "must be >= 0 (0: never)");
  // tf2 frame names have no leading '/'.
  c.world_frame = se3::frame_name(param(p, "world_frame", to_text).value_or("world"));
  require(!c.world_frame.empty(), p, "world_frame", "must name a frame");
  c.lockstep = param(p, "lockstep", to_bool).value_or(false);
  c.control_period = param(p, "control_period", to_double);
  require(!c.control_period || *c.control_period > 0, p, "control_period", "must be > 0");
  c.max_wrench = param(p, "max_wrench", to_double).value_or(1e4);
  require(c.max_wrench > 0, p, "max_wrench", "must be > 0");
  c.max_effort = param(p, "max_effort", to_double).value_or(1e4);
  require(c.max_effort > 0, p, "max_effort", "must be > 0");
  c.controller_namespace = param(p, "controller_namespace", to_text).value_or("");
  XmlRpc::XmlRpcValue names;
  if (p.get("controllers", names)) c.controllers = to_names(names, p.shown("controllers"));
  return c;
}

void apply_scene_overrides(const SimulatorConfig& c, se3::Scene& scene) {
  if (!scene.base_given) scene.floating = false;
  if (c.floating) scene.floating = *c.floating;
  if (c.joint_limits) scene.constraints.joint_limits = *c.joint_limits;
  if (c.gravity) scene.gravity = *c.gravity;
  if (c.integrator) scene.integrator = *c.integrator;
  if (c.dt) scene.dt = *c.dt;
  if (c.tol) scene.tol = *c.tol;
  if (c.real_time_factor) scene.real_time_factor = *c.real_time_factor;
  if (c.publish_rate) scene.publish_rate = *c.publish_rate;
}

int lockstep_steps(const SimulatorConfig& c, double dt) {
  const double period = c.control_period.value_or(dt);
  return static_cast<int>(std::max(1.0, std::min(1e6, std::round(period / dt))));
}

std::string scene_file(const SimulatorConfig& c, bool robot_given) {
  const std::string& arg = c.scene;
  std::string name = arg;
  if (name == "auto") name = robot_given ? "generic" : "satellite_arm";
  if (name.find('/') == std::string::npos) {
    std::string file = name;
    if (file.size() < 5 || file.compare(file.size() - 5, 5, ".yaml") != 0) file += ".yaml";
    const std::string in_dir = c.scene_dir + "/" + file;
    if (!c.scene_dir.empty() && se3::not_a_regular_file(in_dir).empty()) return in_dir;
    if (se3::not_a_regular_file(file).empty()) return file;
    throw ParamError("scene '" + arg + "' is neither a scene of " +
                     (c.scene_dir.empty() ? std::string("config/scenes") : c.scene_dir) +
                     " (generic, satellite_arm, fixed_panda, ...) nor a file");
  }
  if (name[0] != '/' && !c.cwd.empty()) return c.cwd + "/" + name;
  return name;
}

}  // namespace se3_ros
