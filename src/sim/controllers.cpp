// Joint controllers with ros_control's conventions (controllers.h).
#include "se3_sim/sim/controllers.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "scene_reader.h"

namespace se3 {

// ------------------------------------------------------------------ Pid

void Pid::reset() {
  p_error_last_ = i_error_ = d_error_ = 0;
}

double Pid::compute(double error, double dt) {
  if (!(dt > 0) || !std::isfinite(error)) return 0.0;
  const double error_dot = (error - p_error_last_) / dt;
  p_error_last_ = error;
  return compute(error, error_dot, dt);
}

double Pid::compute(double error, double error_dot, double dt) {
  d_error_ = error_dot;
  if (!(dt > 0) || !std::isfinite(error) || !std::isfinite(error_dot)) return 0.0;
  const PidGains& g = gains_;
  i_error_ += dt * error;
  if (g.antiwindup && g.i != 0) {
    const double a = g.i_clamp_min / g.i, b = g.i_clamp_max / g.i;
    i_error_ = std::min(std::max(i_error_, std::min(a, b)), std::max(a, b));
  }
  double i_term = g.i * i_error_;
  if (!g.antiwindup) i_term = std::min(std::max(i_term, g.i_clamp_min), g.i_clamp_max);
  return g.p * error + i_term + g.d * d_error_;
}

// ------------------------------------------------------------------ types

namespace {

struct TypeName {
  const char* name;
  ControllerKind kind;
  JointInterface iface;
};
const TypeName kTypes[] = {
    {"effort_controllers/JointGroupEffortController", ControllerKind::GroupEffort,
     JointInterface::Effort},
    {"effort_controllers/JointGroupPositionController", ControllerKind::GroupPosition,
     JointInterface::Effort},
    {"effort_controllers/JointEffortController", ControllerKind::Effort, JointInterface::Effort},
    {"effort_controllers/JointPositionController", ControllerKind::Position,
     JointInterface::Effort},
    {"effort_controllers/JointVelocityController", ControllerKind::Velocity,
     JointInterface::Effort},
    {"effort_controllers/JointTrajectoryController", ControllerKind::Trajectory,
     JointInterface::Effort},
    {"velocity_controllers/JointVelocityController", ControllerKind::Velocity,
     JointInterface::Velocity},
    {"velocity_controllers/JointGroupVelocityController", ControllerKind::GroupVelocity,
     JointInterface::Velocity},
    {"velocity_controllers/JointTrajectoryController", ControllerKind::Trajectory,
     JointInterface::Velocity},
    {"position_controllers/JointPositionController", ControllerKind::Position,
     JointInterface::Position},
    {"position_controllers/JointGroupPositionController", ControllerKind::GroupPosition,
     JointInterface::Position},
    {"position_controllers/JointTrajectoryController", ControllerKind::Trajectory,
     JointInterface::Position},
    {"joint_state_controller/JointStateController", ControllerKind::JointState,
     JointInterface::Effort},
};

// The controller's own gains are optional where the interface's PID may supply them: forward
// position and velocity types, and the position trajectory controller.
bool gains_optional(ControllerKind kind, JointInterface iface) {
  return iface == JointInterface::Position ||
         (iface == JointInterface::Velocity && kind != ControllerKind::Trajectory);
}

}  // namespace

const char* interface_name(JointInterface iface) {
  switch (iface) {
    case JointInterface::Effort:
      return "EffortJointInterface";
    case JointInterface::Velocity:
      return "VelocityJointInterface";
    case JointInterface::Position:
      return "PositionJointInterface";
  }
  return "";
}

std::string supported_controller_types() {
  std::string known;
  for (const TypeName& t : kTypes) known += std::string(known.empty() ? "" : ", ") + t.name;
  return known;
}

ControllerKind controller_kind(const std::string& type, const std::string& controller) {
  for (const TypeName& t : kTypes) {
    if (type == t.name) return t.kind;
  }
  throw ControllerError("controller '" + controller + "': type '" + type +
                        "' is not supported; supported types: " + supported_controller_types());
}

JointInterface controller_interface(const std::string& type) {
  for (const TypeName& t : kTypes) {
    if (type == t.name) return t.iface;
  }
  return JointInterface::Effort;
}

bool single_joint(ControllerKind kind) {
  return kind == ControllerKind::Effort || kind == ControllerKind::Position ||
         kind == ControllerKind::Velocity;
}

bool uses_pid(ControllerKind kind) {
  return kind == ControllerKind::GroupPosition || kind == ControllerKind::Position ||
         kind == ControllerKind::Velocity || kind == ControllerKind::GroupVelocity ||
         kind == ControllerKind::Trajectory;
}

const char* status_name(TrajectoryStatus s) {
  switch (s) {
    case TrajectoryStatus::Idle:
      return "idle";
    case TrajectoryStatus::Active:
      return "active";
    case TrajectoryStatus::Succeeded:
      return "succeeded";
    case TrajectoryStatus::PathToleranceViolated:
      return "path tolerance violated";
    case TrajectoryStatus::GoalToleranceViolated:
      return "goal tolerance violated";
  }
  return "";
}

// ------------------------------------------------------------------ names

namespace {
bool ascii_letter(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z');
}
bool ascii_digit(char c) {
  return c >= '0' && c <= '9';
}
}  // namespace

bool is_controller_name(const std::string& name) {
  if (name.empty() || !ascii_letter(name[0]) || name.back() == '/') return false;
  for (size_t k = 1; k < name.size(); ++k) {
    const char c = name[k];
    if (!(ascii_letter(c) || ascii_digit(c) || c == '_' || c == '/')) return false;
    if (c == '/' && name[k - 1] == '/') return false;
  }
  return true;
}

std::string controller_name_problem(const std::string& name) {
  if (is_controller_name(name)) return "";
  std::string shown;
  for (const char c : name.substr(0, 60)) {
    const auto u = static_cast<unsigned char>(c);
    shown += u < 0x20 || u == 0x7f ? '?' : c;
  }
  return "controller name '" + shown + (name.size() > 60 ? "...'" : "'") +
         " is not a ROS name (a letter, then letters, digits, '_' or '/'): its topic is "
         "NAME/command";
}

// ------------------------------------------------------------------ YAML

namespace {

class ControllerReader {
 public:
  ControllerReader(const std::string& where, const std::string& name)
      : where_(where), name_(name) {}

  /// "file:line" of a node ("file" when yaml-cpp has no mark).
  std::string at(const YAML::Node& n) const {
    std::string at = where_;
    const YAML::Mark m = n.Mark();
    if (m.line >= 0) at += ":" + std::to_string(m.line + 1);
    return at;
  }
  [[noreturn]] void fail(const YAML::Node& n, const std::string& what) const {
    throw ControllerError(at(n) + ": controller '" + name_ + "': " + what);
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw ControllerError(where_ + ": controller '" + name_ + "': " + what);
  }

  std::string text(const YAML::Node& n, const std::string& key) const {
    if (!n.IsScalar() || n.Scalar().empty()) fail(n, "'" + key + "' needs a name");
    return n.Scalar();
  }

  double number(const YAML::Node& n, const std::string& key) const {
    if (!n.IsScalar()) fail(n, "'" + key + "' needs a number");
    const std::string& s = n.Scalar();
    char* end = nullptr;
    const double x = std::strtod(s.c_str(), &end);
    if (s.empty() || *end != '\0' || !std::isfinite(x)) {
      fail(n, "'" + key + "' needs a finite number, got '" + s + "'");
    }
    return x;
  }

  bool boolean(const YAML::Node& n, const std::string& key) const {
    if (n.IsScalar()) {
      const std::string& s = n.Scalar();
      if (s == "true" || s == "True" || s == "TRUE" || s == "1") return true;
      if (s == "false" || s == "False" || s == "FALSE" || s == "0") return false;
    }
    fail(n, "'" + key + "' needs true or false");
  }

  /// control_toolbox's Pid::init on a map {p, i, d, i_clamp, i_clamp_min, i_clamp_max,
  /// antiwindup}; `base` supplies what the map does not say.
  PidGains gains(const YAML::Node& n, const std::string& key, const PidGains* base) const {
    if (!n.IsMap()) fail(n, "'" + key + "' needs a map {p: ..., i: ..., d: ...}");
    PidGains g = base ? *base : PidGains();
    bool has_p = base != nullptr;
    for (const auto& kv : n) {
      const std::string k = kv.first.IsScalar() ? kv.first.Scalar() : std::string();
      if (k != "p" && k != "i" && k != "d" && k != "i_clamp" && k != "i_clamp_min" &&
          k != "i_clamp_max" && k != "antiwindup" && k != "publish_state") {
        fail(kv.first, "unknown key '" + k + "' in '" + key +
                           "' (p, i, d, i_clamp, i_clamp_min, i_clamp_max, antiwindup)");
      }
    }
    if (n["p"]) {
      g.p = number(n["p"], key + ".p");
      has_p = true;
    }
    if (!has_p) fail(n, "'" + key + "' needs a p gain");
    if (n["i"]) g.i = number(n["i"], key + ".i");
    if (n["d"]) g.d = number(n["d"], key + ".d");
    if (n["i_clamp"]) {
      const double c = std::abs(number(n["i_clamp"], key + ".i_clamp"));
      g.i_clamp_max = c;
      g.i_clamp_min = -c;
    }
    if (n["i_clamp_min"]) g.i_clamp_min = -std::abs(number(n["i_clamp_min"], key + ".i_clamp_min"));
    if (n["i_clamp_max"]) g.i_clamp_max = std::abs(number(n["i_clamp_max"], key + ".i_clamp_max"));
    if (n["antiwindup"]) g.antiwindup = boolean(n["antiwindup"], key + ".antiwindup");
    return g;
  }

 private:
  std::string where_, name_;
};

}  // namespace

namespace {

// A trajectory controller's keys besides joints and gains (ros_controllers' names).
void parse_trajectory_keys(const ControllerReader& r, const YAML::Node& node, ControllerSpec& s) {
  const size_t n = s.joints.size();
  s.constraints.trajectory.assign(n, 0.0);
  s.constraints.goal.assign(n, 0.0);
  s.velocity_ff.assign(n, 0.0);
  auto joint_of = [&](const YAML::Node& key, const std::string& where) -> int {
    const std::string k = key.IsScalar() ? key.Scalar() : std::string();
    for (size_t j = 0; j < n; ++j) {
      if (s.joints[j] == k) return static_cast<int>(j);
    }
    r.fail(key, "'" + where + "' names '" + k + "', not one of its joints");
  };
  auto nonnegative = [&](const YAML::Node& v, const std::string& key) {
    const double x = r.number(v, key);
    if (x < 0) r.fail(v, "'" + key + "' needs a number >= 0");
    return x;
  };
  if (const YAML::Node c = node["constraints"]) {
    if (!c.IsMap()) r.fail(c, "'constraints' needs a map {goal_time: ..., JOINT: {...}}");
    for (const auto& kv : c) {
      const std::string k = kv.first.IsScalar() ? kv.first.Scalar() : std::string();
      if (k == "goal_time") {
        s.constraints.goal_time = nonnegative(kv.second, "constraints.goal_time");
      } else if (k == "stopped_velocity_tolerance") {
        s.constraints.stopped_velocity_tolerance =
            nonnegative(kv.second, "constraints.stopped_velocity_tolerance");
      } else {
        const int j = joint_of(kv.first, "constraints");
        if (!kv.second.IsMap()) {
          r.fail(kv.second, "'constraints." + k + "' needs {trajectory: ..., goal: ...}");
        }
        for (const auto& t : kv.second) {
          const std::string tk = t.first.IsScalar() ? t.first.Scalar() : std::string();
          const std::string key = "constraints." + k + "." + tk;
          if (tk == "trajectory") {
            s.constraints.trajectory[j] = nonnegative(t.second, key);
          } else if (tk == "goal") {
            s.constraints.goal[j] = nonnegative(t.second, key);
          } else {
            r.fail(t.first, "unknown key '" + key + "' (trajectory, goal)");
          }
        }
      }
    }
  }
  if (const YAML::Node f = node["velocity_ff"]) {
    if (!f.IsMap()) r.fail(f, "'velocity_ff' needs a map {JOINT: number}");
    for (const auto& kv : f) {
      s.velocity_ff[joint_of(kv.first, "velocity_ff")] = r.number(kv.second, "velocity_ff");
    }
  }
  if (node["state_publish_rate"]) {
    s.state_publish_rate = nonnegative(node["state_publish_rate"], "state_publish_rate");
  }
  if (node["action_monitor_rate"]) {
    s.action_monitor_rate = nonnegative(node["action_monitor_rate"], "action_monitor_rate");
  }
  if (node["stop_trajectory_duration"]) {
    s.stop_trajectory_duration =
        nonnegative(node["stop_trajectory_duration"], "stop_trajectory_duration");
  }
  if (node["allow_partial_joints_goal"]) {
    s.allow_partial_joints_goal =
        r.boolean(node["allow_partial_joints_goal"], "allow_partial_joints_goal");
  }
}

}  // namespace

ControllerSpec parse_controller(const std::string& name, const YAML::Node& node,
                                const std::string& where) {
  const ControllerReader r(where, name);
  if (const std::string why = controller_name_problem(name); !why.empty()) {
    throw ControllerError(where + ": " + why);
  }
  if (!node.IsMap()) r.fail(node, "needs a map {type: ..., joints: [...], ...}");
  ControllerSpec s;
  s.name = name;
  s.where = r.at(node);
  if (!node["type"]) r.fail(node, "needs a 'type'");
  s.type = r.text(node["type"], "type");
  try {
    s.kind = controller_kind(s.type, name);
  } catch (const ControllerError& e) {
    r.fail(node["type"], std::string(e.what()).substr(("controller '" + name + "': ").size()));
  }
  if (s.kind == ControllerKind::JointState) return s;  // publish_rate etc. do not matter here

  const bool single = single_joint(s.kind);
  if (single) {
    if (!node["joint"]) r.fail(node, "needs 'joint: NAME'");
    if (node["joints"]) r.fail(node["joints"], "takes one 'joint', not 'joints'");
    s.joints.push_back(r.text(node["joint"], "joint"));
    s.joint_where.push_back(r.at(node["joint"]));
  } else {
    if (!node["joints"]) r.fail(node, "needs 'joints: [a, b, ...]'");
    if (node["joint"]) r.fail(node["joint"], "takes a list 'joints', not 'joint'");
    const YAML::Node j = node["joints"];
    if (!j.IsSequence() || j.size() == 0) r.fail(j, "'joints' needs a list of joint names");
    for (const auto& e : j) {
      s.joints.push_back(r.text(e, "joints"));
      s.joint_where.push_back(r.at(e));
    }
  }
  std::set<std::string> seen;
  for (const auto& j : s.joints) {
    if (!seen.insert(j).second) r.fail(node, "joint '" + j + "' is listed twice");
  }

  s.iface = controller_interface(s.type);
  const bool trajectory = s.kind == ControllerKind::Trajectory;
  // Keys: type, joint(s), pid, gains, one per joint; ros_control's extras are tolerated.
  for (const auto& kv : node) {
    const std::string k = kv.first.IsScalar() ? kv.first.Scalar() : std::string();
    if (k == "type" || k == "joint" || k == "joints" || k == "pid" || k == "gains" ||
        seen.count(k) || k == "publish_rate") {
      continue;
    }
    if (trajectory && (k == "constraints" || k == "state_publish_rate" ||
                       k == "action_monitor_rate" || k == "stop_trajectory_duration" ||
                       k == "allow_partial_joints_goal" || k == "velocity_ff")) {
      continue;
    }
    r.fail(kv.first, "unknown key '" + k + "'");
  }
  if (trajectory) parse_trajectory_keys(r, node, s);
  if (!uses_pid(s.kind)) {
    if (node["pid"] || node["gains"]) r.fail(node, "an effort controller takes no gains");
    for (const auto& j : s.joints) {
      if (node[j]) r.fail(node[j], "an effort controller takes no gains (key '" + j + "')");
    }
    return s;
  }
  PidGains common;
  const bool has_common = static_cast<bool>(node["pid"]);
  if (has_common) common = r.gains(node["pid"], "pid", nullptr);
  const YAML::Node gains = node["gains"];
  if (gains && !gains.IsMap()) r.fail(gains, "'gains' needs a map {joint: {p: ...}, ...}");
  if (gains) {
    for (const auto& kv : gains) {
      const std::string k = kv.first.IsScalar() ? kv.first.Scalar() : std::string();
      if (!seen.count(k)) r.fail(kv.first, "'gains' names '" + k + "', not one of its joints");
    }
  }
  bool any = has_common || gains;
  for (const auto& j : s.joints) any = any || node[j];
  // Position and velocity interfaces: the controller's gains may come from pid_gains instead.
  if (!any && gains_optional(s.kind, s.iface)) return s;
  for (const auto& j : s.joints) {
    const YAML::Node own = node[j];
    const bool in_gains = gains && gains[j];
    if (own && in_gains) r.fail(own, "gains of '" + j + "' given twice ('" + j + "' and 'gains')");
    if (own) {
      if (!own.IsMap() || !own["pid"] || own.size() != 1) {
        r.fail(own, "'" + j + "' needs {pid: {p: ..., i: ..., d: ...}}");
      }
      s.gains.push_back(r.gains(own["pid"], j + ".pid", has_common ? &common : nullptr));
    } else if (in_gains) {
      s.gains.push_back(r.gains(gains[j], "gains." + j, has_common ? &common : nullptr));
    } else if (has_common) {
      s.gains.push_back(common);
    } else if (trajectory) {
      r.fail(node, "no gains for joint '" + j + "' (give 'gains: {" + j + ": {p: ...}}')");
    } else {
      r.fail(node, "no gains for joint '" + j + "' (give 'pid: {p: ...}' or '" + j +
                       ": {pid: {p: ...}}')");
    }
  }
  return s;
}

std::vector<ControllerSpec> parse_controllers(const YAML::Node& map,
                                              const std::vector<std::string>& names,
                                              const std::string& where) {
  if (!map.IsMap()) {
    throw ControllerError(where + ": controllers need a map {NAME: {type: ..., ...}, ...}");
  }
  std::vector<ControllerSpec> out;
  if (names.empty()) {
    for (const auto& kv : map) {
      if (!kv.first.IsScalar()) throw ControllerError(where + ": a controller name is not text");
      if (const std::string why = controller_name_problem(kv.first.Scalar()); !why.empty()) {
        std::string at = where;
        if (kv.first.Mark().line >= 0) at += ":" + std::to_string(kv.first.Mark().line + 1);
        throw ControllerError(at + ": " + why);
      }
      out.push_back(parse_controller(kv.first.Scalar(), kv.second, where));
    }
    return out;
  }
  std::set<std::string> seen;
  for (const auto& name : names) {
    if (!seen.insert(name).second) {
      throw ControllerError(where + ": controller '" + name + "' is named twice");
    }
    const YAML::Node n = map[name];
    if (!n) throw ControllerError(where + ": no controller '" + name + "' in the configuration");
    out.push_back(parse_controller(name, n, where));
  }
  return out;
}

std::vector<ControllerSpec> parse_controllers_text(const std::string& yaml_text,
                                                   const std::vector<std::string>& names,
                                                   const std::string& where) {
  YAML::Node root;
  try {
    check_scene_text(yaml_text, where);  // size and nesting before yaml-cpp (scene_reader.h)
    root = YAML::Load(yaml_text);
  } catch (const SceneError& e) {
    throw ControllerError(e.what());
  } catch (const YAML::Exception& e) {
    throw ControllerError(where + ": " + e.what());
  }
  return parse_controllers(root, names, where);
}

std::map<std::string, PidGains> parse_interface_gains(const YAML::Node& map,
                                                      const std::string& where) {
  std::map<std::string, PidGains> out;
  if (!map || map.IsNull()) return out;
  const ControllerReader r(where, "pid_gains");
  if (!map.IsMap()) r.fail(map, "needs a map {JOINT: {p: ..., i: ..., d: ...}, ...}");
  for (const auto& kv : map) {
    const std::string j = kv.first.IsScalar() ? kv.first.Scalar() : std::string();
    out[j] = r.gains(kv.second, j, nullptr);
  }
  return out;
}

void set_interface_gains(std::vector<ControllerSpec>& specs,
                         const std::map<std::string, PidGains>& by_joint) {
  for (ControllerSpec& s : specs) {
    s.interface_gains.assign(s.joints.size(), std::nullopt);
    if (s.iface == JointInterface::Effort) continue;
    for (size_t k = 0; k < s.joints.size(); ++k) {
      auto it = by_joint.find(s.joints[k]);
      if (it != by_joint.end()) s.interface_gains[k] = it->second;
    }
  }
}

// ------------------------------------------------------------------ ControllerSet

ControllerSet::ControllerSet(const Model& model, const std::vector<ControllerSpec>& specs)
    : model_(model), owner_(model.n + 1, -1) {
  std::set<std::string> names;
  // Binding errors name where the controller (or its joint) was written, when it was read.
  auto at = [](const std::string& where) { return where.empty() ? where : where + ": "; };
  for (const ControllerSpec& s : specs) {
    if (const std::string why = controller_name_problem(s.name); !why.empty()) {
      throw ControllerError(why);
    }
    if (!names.insert(s.name).second) {
      throw ControllerError(at(s.where) + "controller '" + s.name + "' is given twice");
    }
    if (s.kind == ControllerKind::JointState) continue;  // nothing to run
    const bool optional = gains_optional(s.kind, s.iface);
    if (uses_pid(s.kind) && s.gains.size() != s.joints.size() && !(optional && s.gains.empty())) {
      throw ControllerError(at(s.where) + "controller '" + s.name +
                            "': gains for every joint needed");
    }
    const bool trajectory = s.kind == ControllerKind::Trajectory;
    Ctl c;
    c.spec = s;
    const size_t n = s.joints.size();
    if (trajectory) {
      c.spec.constraints.trajectory.resize(n, 0.0);
      c.spec.constraints.goal.resize(n, 0.0);
      c.spec.velocity_ff.resize(n, 0.0);
    }
    for (size_t k = 0; k < n; ++k) {
      const int i = model.joint_index(s.joints[k]);
      const std::string& where = k < s.joint_where.size() ? s.joint_where[k] : s.where;
      if (i < 1) {
        throw ControllerError(at(where) + "controller '" + s.name + "': joint '" + s.joints[k] +
                              "' is not a moving joint of the model (unknown, fixed or locked)");
      }
      if (owner_[i] >= 0) {
        throw ControllerError(at(where) + "controller '" + s.name + "': joint '" + s.joints[k] +
                              "' is already driven by controller '" + ctl_[owner_[i]].spec.name +
                              "'");
      }
      owner_[i] = static_cast<int>(ctl_.size());
      c.joint.push_back(i);
      // The interface's PID: pid_gains, else the controller's own where it has no other use.
      PidGains hw;
      if (s.iface != JointInterface::Effort) {
        const bool own = !s.gains.empty() && (!trajectory || s.iface == JointInterface::Position);
        if (k < s.interface_gains.size() && s.interface_gains[k]) {
          hw = *s.interface_gains[k];
        } else if (own) {
          hw = s.gains[k];
        } else {
          throw ControllerError(
              "controller '" + s.name + "' (" + s.type + "): joint '" + s.joints[k] +
              "' has no gains for its " + interface_name(s.iface) +
              ": set /gazebo_ros_control/pid_gains/" + s.joints[k] + " {p: ..., i: ..., d: ...}" +
              (trajectory ? std::string() : " or give the controller 'pid: {p: ...}'") +
              " (the joint is driven through its effort by that PID)");
        }
      }
      if (trajectory) {
        c.pid.emplace_back(s.iface == JointInterface::Position ? PidGains() : s.gains[k]);
        c.hw.emplace_back(hw);
      } else if (s.iface != JointInterface::Effort) {
        c.pid.emplace_back(hw);  // a forward command through the interface's PID
        c.hw.emplace_back();
      } else {
        c.pid.emplace_back(uses_pid(s.kind) ? s.gains[k] : PidGains());
        c.hw.emplace_back();
      }
    }
    c.command.assign(c.joint.size(), 0.0);
    if (trajectory) {
      c.track.resize(n);
      TrajectoryState& st = c.state;
      for (auto* v : {&st.desired_q, &st.desired_v, &st.desired_a, &st.actual_q, &st.actual_v,
                      &st.error_q, &st.error_v}) {
        v->assign(n, 0.0);
      }
    }
    ctl_.push_back(std::move(c));
  }
}

int ControllerSet::find(const std::string& name) const {
  for (size_t c = 0; c < ctl_.size(); ++c) {
    if (ctl_[c].spec.name == name) return static_cast<int>(c);
  }
  return -1;
}

std::string ControllerSet::set_command(int c, const double* values, size_t n) {
  Ctl& k = ctl_[c];
  if (k.spec.kind == ControllerKind::Trajectory) {
    return "controller '" + k.spec.name + "' takes trajectories (trajectory_msgs/JointTrajectory)";
  }
  if (n != k.joint.size()) {
    return "controller '" + k.spec.name + "' takes " + std::to_string(k.joint.size()) + " value" +
           (k.joint.size() == 1 ? "" : "s") + ", got " + std::to_string(n);
  }
  for (size_t j = 0; j < n; ++j) {
    if (!std::isfinite(values[j])) {
      return "controller '" + k.spec.name + "': non-finite value for '" + k.spec.joints[j] + "'";
    }
  }
  // A position target of a continuous joint as a point of its circle (an angle of 1e15 rad
  // would leave the error target - q no correct digit).
  const bool position =
      k.spec.kind == ControllerKind::Position || k.spec.kind == ControllerKind::GroupPosition;
  for (size_t j = 0; j < n; ++j) {
    k.command[j] = position && model_.continuous(k.joint[j]) ? wrap_angle(values[j]) : values[j];
  }
  return "";
}

double ControllerSet::position_error(int i, double target, double q) const {
  const double lo = model_.lower[i], hi = model_.upper[i];
  const bool limited = std::isfinite(lo) && std::isfinite(hi);
  if (limited) target = std::min(std::max(target, lo), hi);  // enforceJointLimits
  if (model_.joints[i].angular() && !limited) {
    // Continuous: the shortest way round, in [-pi, pi].
    const double two_pi = 2 * M_PI;
    double e = std::fmod(target - q, two_pi);
    if (e > M_PI) e -= two_pi;
    if (e < -M_PI) e += two_pi;
    return e;
  }
  return target - q;
}

// ---- trajectories

namespace {

// The segment of a track at time t (the last one starting at or before t, else the first).
size_t segment_at(const std::vector<double>& t0, double t) {
  const auto it = std::upper_bound(t0.begin(), t0.end(), t);
  return it == t0.begin() ? 0 : static_cast<size_t>(it - t0.begin()) - 1;
}

}  // namespace

void ControllerSet::sample(int c, int j, double t, double& q, double& v, double& a) const {
  const Track& tr = ctl_[c].track[j];
  if (tr.seg.empty()) {
    q = v = a = 0;
    return;
  }
  const size_t k = segment_at(tr.t0, t);
  sample_spline(tr.seg[k], t - tr.t0[k], q, v, a);
}

void ControllerSet::hold(Ctl& c, int j, double q, double t) {
  Track& tr = c.track[j];
  tr.t0.assign(1, t);
  tr.seg.assign(1, linear_spline(q, q, 0.0));
}

// ros_controllers' setHoldPosition: from the current desired state to a stop over
// stop_trajectory_duration (decelerating to q + v T / 2), or at once where it is.
void ControllerSet::stop(Ctl& c, double now) {
  const double T = c.spec.stop_trajectory_duration;
  for (size_t j = 0; j < c.track.size(); ++j) {
    double q, v, a;
    sample(static_cast<int>(&c - ctl_.data()), static_cast<int>(j), now, q, v, a);
    Track& tr = c.track[j];
    tr.t0.assign(1, now);
    tr.seg.assign(
        1, T > 0 ? quintic_spline(q, v, a, q + 0.5 * v * T, 0, 0, T) : linear_spline(q, q, 0.0));
  }
  c.state.end_time = now + T;
}

std::string ControllerSet::set_trajectory(int c, const TrajectoryCommand& cmd, double now) {
  Ctl& k = ctl_[c];
  const ControllerSpec& s = k.spec;
  const std::string who = "controller '" + s.name + "'";
  if (s.kind != ControllerKind::Trajectory) return who + " takes no trajectories";
  if (!std::isfinite(now)) return who + ": no time";
  if (cmd.points.empty()) {  // ros_controllers: an empty trajectory stops
    stop(k, now);
    k.state.status = TrajectoryStatus::Idle;
    k.state.status_joint = -1;
    return "";
  }
  const size_t m = cmd.joint_names.size();
  if (m == 0) return who + ": the trajectory names no joints";
  // Message joint -> controller joint.
  std::vector<int> map(m, -1);
  std::vector<bool> named(s.joints.size(), false);
  for (size_t a = 0; a < m; ++a) {
    for (size_t j = 0; j < s.joints.size(); ++j) {
      if (s.joints[j] == cmd.joint_names[a]) map[a] = static_cast<int>(j);
    }
    if (map[a] < 0) return who + ": joint '" + cmd.joint_names[a] + "' is not one of its joints";
    if (named[map[a]]) return who + ": joint '" + cmd.joint_names[a] + "' is named twice";
    named[map[a]] = true;
  }
  if (m != s.joints.size() && !s.allow_partial_joints_goal) {
    return who + ": the trajectory names " + std::to_string(m) + " of its " +
           std::to_string(s.joints.size()) + " joints (allow_partial_joints_goal is false)";
  }
  // The points: sizes, finite values, strictly increasing times.
  const bool has_v = !cmd.points[0].velocities.empty();
  const bool has_a = !cmd.points[0].accelerations.empty();
  double last = -1;
  for (size_t p = 0; p < cmd.points.size(); ++p) {
    const auto& pt = cmd.points[p];
    const std::string at = who + ": point " + std::to_string(p);
    if (pt.positions.size() != m) {
      return at + " has " + std::to_string(pt.positions.size()) + " positions for " +
             std::to_string(m) + " joints";
    }
    if (pt.velocities.size() != (has_v ? m : 0) || pt.accelerations.size() != (has_a ? m : 0)) {
      return at +
             ": velocities and accelerations need one value per joint in every point, or "
             "none in any";
    }
    if (has_a && !has_v) return at + ": accelerations without velocities";
    for (size_t a = 0; a < m; ++a) {
      if (!std::isfinite(pt.positions[a]) || (has_v && !std::isfinite(pt.velocities[a])) ||
          (has_a && !std::isfinite(pt.accelerations[a]))) {
        return at + ": non-finite value for '" + cmd.joint_names[a] + "'";
      }
    }
    if (!std::isfinite(pt.time_from_start) || !(pt.time_from_start > last)) {
      return at + ": time_from_start " + std::to_string(pt.time_from_start) +
             " is not after the point before";
    }
    last = pt.time_from_start;
  }
  const double start = std::isfinite(cmd.start) ? cmd.start : now;
  const double t_switch = std::max(now, start);
  size_t first = 0;  // the first point after the switch
  while (first < cmd.points.size() && start + cmd.points[first].time_from_start <= t_switch) {
    ++first;
  }
  if (first == cmd.points.size()) {
    return who + ": every point lies at or before the current time (" + std::to_string(now) +
           " s); nothing to follow";
  }
  for (size_t a = 0; a < m; ++a) {
    const int j = map[a];
    const int i = k.joint[j];
    double q0, v0, a0;
    sample(c, j, t_switch, q0, v0, a0);
    // A continuous joint takes the way round nearest to where it stands.
    double offset = 0;
    if (model_.joints[i].angular() &&
        !(std::isfinite(model_.lower[i]) && std::isfinite(model_.upper[i]))) {
      const double two_pi = 2 * M_PI;
      offset = two_pi * std::round((q0 - cmd.points[first].positions[a]) / two_pi);
    }
    Track& tr = k.track[j];
    // Keep the old segments from the one at `now` up to the switch.
    size_t from = segment_at(tr.t0, now);
    size_t to =
        static_cast<size_t>(std::lower_bound(tr.t0.begin(), tr.t0.end(), t_switch) - tr.t0.begin());
    to = std::max(to, from);
    tr.t0.erase(tr.t0.begin() + to, tr.t0.end());
    tr.seg.erase(tr.seg.begin() + to, tr.seg.end());
    tr.t0.erase(tr.t0.begin(), tr.t0.begin() + from);
    tr.seg.erase(tr.seg.begin(), tr.seg.begin() + from);
    // The bridge from the current desired state, then point to point.
    double tp = t_switch, qp = q0, vp = v0, ap = a0;
    for (size_t p = first; p < cmd.points.size(); ++p) {
      const auto& pt = cmd.points[p];
      const double t1 = start + pt.time_from_start, T = t1 - tp;
      const double q1 = pt.positions[a] + offset;
      const double v1 = has_v ? pt.velocities[a] : 0.0;
      const double a1 = has_a ? pt.accelerations[a] : 0.0;
      Spline sp;
      if (p == first) {
        sp = has_a ? quintic_spline(qp, vp, ap, q1, v1, a1, T) : cubic_spline(qp, vp, q1, v1, T);
      } else if (has_a) {
        sp = quintic_spline(qp, vp, ap, q1, v1, a1, T);
      } else if (has_v) {
        sp = cubic_spline(qp, vp, q1, v1, T);
      } else {
        sp = linear_spline(qp, q1, T);
      }
      sp.ends_trajectory = p + 1 == cmd.points.size();
      tr.t0.push_back(tp);
      tr.seg.push_back(sp);
      tp = t1, qp = q1, vp = v1, ap = a1;
    }
  }
  double end = start + cmd.points.back().time_from_start;
  for (size_t j = 0; j < k.track.size(); ++j) {
    if (!named[j] && !k.track[j].seg.empty()) {
      const Spline& b = k.track[j].seg.back();
      end = std::max(end, k.track[j].t0.back() + b.T);
    }
  }
  k.state.end_time = end;
  k.state.status = TrajectoryStatus::Active;
  k.state.status_joint = -1;
  return "";
}

// ros_controllers' checks: a joint beyond its `trajectory` tolerance before the end stops the
// controller; after the end, every joint within its `goal` tolerance and below the stopped
// velocity is success, and still outside goal_time after the end is a failure.
void ControllerSet::check_tolerances(Ctl& c, double t) {
  TrajectoryState& st = c.state;
  if (st.status != TrajectoryStatus::Active) return;
  const TrajectoryConstraints& tol = c.spec.constraints;
  const size_t n = c.joint.size();
  if (t < st.end_time) {
    for (size_t j = 0; j < n; ++j) {
      if (tol.trajectory[j] > 0 && std::abs(st.error_q[j]) > tol.trajectory[j]) {
        st.status = TrajectoryStatus::PathToleranceViolated;
        st.status_joint = static_cast<int>(j);
        stop(c, t);
        return;
      }
    }
    return;
  }
  for (size_t j = 0; j < n; ++j) {
    const bool off = (tol.goal[j] > 0 && std::abs(st.error_q[j]) > tol.goal[j]) ||
                     (tol.stopped_velocity_tolerance > 0 &&
                      std::abs(st.actual_v[j]) > tol.stopped_velocity_tolerance);
    if (off) {
      if (tol.goal_time > 0 && t > st.end_time + tol.goal_time) {
        st.status = TrajectoryStatus::GoalToleranceViolated;
        st.status_joint = static_cast<int>(j);
      }
      return;
    }
  }
  st.status = TrajectoryStatus::Succeeded;
}

void ControllerSet::update(const State& x, double t, double dt, VecX& tau) {
  for (Ctl& c : ctl_) {
    const bool trajectory = c.spec.kind == ControllerKind::Trajectory;
    for (size_t j = 0; j < c.joint.size(); ++j) {
      const int i = c.joint[j];
      const int iv = model_.idx_v(i);
      double u = 0;
      switch (c.spec.kind) {
        case ControllerKind::GroupEffort:
        case ControllerKind::Effort:
          u = c.command[j];
          break;
        case ControllerKind::GroupPosition:
        case ControllerKind::Position:
          u = c.pid[j].compute(position_error(i, c.command[j], x.q[model_.idx_q(i)]), dt);
          break;
        case ControllerKind::Velocity:
        case ControllerKind::GroupVelocity:
          u = c.pid[j].compute(c.command[j] - x.v[iv], dt);
          break;
        case ControllerKind::Trajectory: {
          TrajectoryState& st = c.state;
          double qd, vd, ad;
          const Track& tr = c.track[j];
          const double q = x.q[model_.idx_q(i)], v = x.v[iv];
          if (tr.seg.empty()) {  // never reset: where it stands
            qd = q, vd = ad = 0;
          } else {
            const size_t k = segment_at(tr.t0, t);
            sample_spline(tr.seg[k], t - tr.t0[k], qd, vd, ad);
          }
          const double eq = position_error(i, qd, q), ev = vd - v;
          st.desired_q[j] = qd, st.desired_v[j] = vd, st.desired_a[j] = ad;
          st.actual_q[j] = q, st.actual_v[j] = v;
          st.error_q[j] = eq, st.error_v[j] = ev;
          switch (c.spec.iface) {
            case JointInterface::Effort:
              u = c.pid[j].compute(eq, ev, dt);
              break;
            case JointInterface::Velocity: {
              const double vcmd = c.spec.velocity_ff[j] * vd + c.pid[j].compute(eq, ev, dt);
              u = c.hw[j].compute(vcmd - v, dt);
              break;
            }
            case JointInterface::Position:
              u = c.hw[j].compute(eq, dt);
              break;
          }
          break;
        }
        case ControllerKind::JointState:
          break;
      }
      u += tau[iv];
      const double lim = model_.effort[i];
      if (std::isfinite(lim) && lim > 0) u = std::min(lim, std::max(-lim, u));
      tau[iv] = u;
    }
    if (trajectory) {
      c.state.time = t;
      check_tolerances(c, t);
    }
  }
}

void ControllerSet::reset(const State& x) {
  for (Ctl& c : ctl_) {
    const bool trajectory = c.spec.kind == ControllerKind::Trajectory;
    for (size_t j = 0; j < c.joint.size(); ++j) {
      c.pid[j].reset();
      c.hw[j].reset();
      const bool position =
          c.spec.kind == ControllerKind::GroupPosition || c.spec.kind == ControllerKind::Position;
      c.command[j] = position ? x.q[c.joint[j] - 1] : 0.0;
      if (trajectory) {
        hold(c, static_cast<int>(j), x.q[c.joint[j] - 1], 0.0);
        c.state.desired_q[j] = c.state.actual_q[j] = x.q[c.joint[j] - 1];
        c.state.desired_v[j] = c.state.desired_a[j] = c.state.actual_v[j] = 0;
        c.state.error_q[j] = c.state.error_v[j] = 0;
      }
    }
    if (trajectory) {
      c.state.status = TrajectoryStatus::Idle;
      c.state.status_joint = -1;
      c.state.time = c.state.end_time = 0;
    }
  }
}

}  // namespace se3
