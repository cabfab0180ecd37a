// Joint controllers with ros_control's conventions (controllers.h).
#include "se3_sim/controllers.h"

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
};
const TypeName kTypes[] = {
    {"effort_controllers/JointGroupEffortController", ControllerKind::GroupEffort},
    {"effort_controllers/JointGroupPositionController", ControllerKind::GroupPosition},
    {"effort_controllers/JointEffortController", ControllerKind::Effort},
    {"effort_controllers/JointPositionController", ControllerKind::Position},
    {"effort_controllers/JointVelocityController", ControllerKind::Velocity},
    {"joint_state_controller/JointStateController", ControllerKind::JointState},
};

}  // namespace

ControllerKind controller_kind(const std::string& type, const std::string& controller) {
  for (const TypeName& t : kTypes) {
    if (type == t.name) return t.kind;
  }
  std::string known;
  for (const TypeName& t : kTypes) known += std::string(known.empty() ? "" : ", ") + t.name;
  throw ControllerError("controller '" + controller + "': type '" + type +
                        "' is not one this simulator runs (" + known + ")");
}

bool single_joint(ControllerKind kind) {
  return kind == ControllerKind::Effort || kind == ControllerKind::Position ||
         kind == ControllerKind::Velocity;
}

bool uses_pid(ControllerKind kind) {
  return kind == ControllerKind::GroupPosition || kind == ControllerKind::Position ||
         kind == ControllerKind::Velocity;
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

class Reader {
 public:
  Reader(const std::string& where, const std::string& name) : where_(where), name_(name) {}

  [[noreturn]] void fail(const YAML::Node& n, const std::string& what) const {
    std::string at = where_;
    const YAML::Mark m = n.Mark();
    if (m.line >= 0) at += ":" + std::to_string(m.line + 1);
    throw ControllerError(at + ": controller '" + name_ + "': " + what);
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

ControllerSpec parse_controller(const std::string& name, const YAML::Node& node,
                                const std::string& where) {
  const Reader r(where, name);
  if (const std::string why = controller_name_problem(name); !why.empty()) {
    throw ControllerError(where + ": " + why);
  }
  if (!node.IsMap()) r.fail(node, "needs a map {type: ..., joints: [...], ...}");
  ControllerSpec s;
  s.name = name;
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
  } else {
    if (!node["joints"]) r.fail(node, "needs 'joints: [a, b, ...]'");
    if (node["joint"]) r.fail(node["joint"], "takes a list 'joints', not 'joint'");
    const YAML::Node j = node["joints"];
    if (!j.IsSequence() || j.size() == 0) r.fail(j, "'joints' needs a list of joint names");
    for (const auto& e : j) s.joints.push_back(r.text(e, "joints"));
  }
  std::set<std::string> seen;
  for (const auto& j : s.joints) {
    if (!seen.insert(j).second) r.fail(node, "joint '" + j + "' is listed twice");
  }

  // Keys: type, joint(s), pid, gains, one per joint; ros_control's extras are tolerated.
  for (const auto& kv : node) {
    const std::string k = kv.first.IsScalar() ? kv.first.Scalar() : std::string();
    if (k == "type" || k == "joint" || k == "joints" || k == "pid" || k == "gains" ||
        seen.count(k) || k == "publish_rate") {
      continue;
    }
    r.fail(kv.first, "unknown key '" + k + "'");
  }
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

// ------------------------------------------------------------------ ControllerSet

ControllerSet::ControllerSet(const Model& model, const std::vector<ControllerSpec>& specs)
    : model_(model), owner_(model.n + 1, -1) {
  std::set<std::string> names;
  for (const ControllerSpec& s : specs) {
    if (const std::string why = controller_name_problem(s.name); !why.empty()) {
      throw ControllerError(why);
    }
    if (!names.insert(s.name).second) {
      throw ControllerError("controller '" + s.name + "' is given twice");
    }
    if (s.kind == ControllerKind::JointState) continue;  // nothing to run
    if (uses_pid(s.kind) && s.gains.size() != s.joints.size()) {
      throw ControllerError("controller '" + s.name + "': gains for every joint needed");
    }
    Ctl c;
    c.spec = s;
    for (size_t k = 0; k < s.joints.size(); ++k) {
      const int i = model.joint_index(s.joints[k]);
      if (i < 1) {
        throw ControllerError("controller '" + s.name + "': joint '" + s.joints[k] +
                              "' is not a moving joint of the model (unknown, fixed or locked)");
      }
      if (owner_[i] >= 0) {
        throw ControllerError("controller '" + s.name + "': joint '" + s.joints[k] +
                              "' is already driven by controller '" + ctl_[owner_[i]].spec.name +
                              "'");
      }
      owner_[i] = static_cast<int>(ctl_.size());
      c.joint.push_back(i);
      c.pid.emplace_back(uses_pid(s.kind) ? s.gains[k] : PidGains());
    }
    c.command.assign(c.joint.size(), 0.0);
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

void ControllerSet::update(const State& x, double dt, VecX& tau) {
  for (Ctl& c : ctl_) {
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
          u = c.pid[j].compute(position_error(i, c.command[j], x.q[i - 1]), dt);
          break;
        case ControllerKind::Velocity:
          u = c.pid[j].compute(c.command[j] - x.v[iv], dt);
          break;
        case ControllerKind::JointState:
          break;
      }
      u += tau[iv];
      const double lim = model_.effort[i];
      if (std::isfinite(lim) && lim > 0) u = std::min(lim, std::max(-lim, u));
      tau[iv] = u;
    }
  }
}

void ControllerSet::reset(const State& x) {
  for (Ctl& c : ctl_) {
    for (size_t j = 0; j < c.joint.size(); ++j) {
      c.pid[j].reset();
      const bool position =
          c.spec.kind == ControllerKind::GroupPosition || c.spec.kind == ControllerKind::Position;
      c.command[j] = position ? x.q[c.joint[j] - 1] : 0.0;
    }
  }
}

}  // namespace se3
