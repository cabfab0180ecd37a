// Typed parameters (params.h).
#include "se3_sim/ros/params.h"

#include <ros/console.h>
#include <ros/param.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "se3_sim/model/gazebo_tags.h"

namespace se3_ros {
namespace {

using XmlRpc::XmlRpcValue;

// XmlRpcValue's conversions are non-const; a copy is cheap for parameters.
XmlRpcValue copy(const XmlRpcValue& v) {
  return v;
}

std::string type_name(XmlRpcValue::Type t) {
  switch (t) {
    case XmlRpcValue::TypeBoolean:
      return "a boolean";
    case XmlRpcValue::TypeInt:
      return "an integer";
    case XmlRpcValue::TypeDouble:
      return "a number";
    case XmlRpcValue::TypeString:
      return "a string";
    case XmlRpcValue::TypeArray:
      return "a list";
    case XmlRpcValue::TypeStruct:
      return "a map";
    default:
      return "an unusable value";
  }
}

std::string print(double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

}  // namespace

std::optional<double> to_double(const XmlRpcValue& value, const std::string& name) {
  XmlRpcValue v = copy(value);
  double x = 0;
  switch (v.getType()) {
    case XmlRpcValue::TypeDouble:
      x = static_cast<double>(v);
      break;
    case XmlRpcValue::TypeInt:
      x = static_cast<int>(v);
      break;
    case XmlRpcValue::TypeString: {
      const std::string s = static_cast<std::string>(v);
      if (s.empty()) return std::nullopt;
      char* end = nullptr;
      x = std::strtod(s.c_str(), &end);
      if (*end != '\0') throw ParamError(name + " needs a number, got '" + s + "'");
      break;
    }
    default:
      throw ParamError(name + " needs a number, got " + type_name(v.getType()));
  }
  if (!std::isfinite(x)) throw ParamError(name + " needs a finite number, got " + print(x));
  return x;
}

std::optional<bool> to_bool(const XmlRpcValue& value, const std::string& name) {
  XmlRpcValue v = copy(value);
  switch (v.getType()) {
    case XmlRpcValue::TypeBoolean:
      return static_cast<bool>(v);
    case XmlRpcValue::TypeInt: {
      const int i = static_cast<int>(v);
      if (i == 0 || i == 1) return i == 1;
      break;
    }
    case XmlRpcValue::TypeString: {
      const std::string s = static_cast<std::string>(v);
      if (s.empty()) return std::nullopt;
      if (s == "true" || s == "True" || s == "1") return true;
      if (s == "false" || s == "False" || s == "0") return false;
      throw ParamError(name + " needs true or false, got '" + s + "'");
    }
    default:
      break;
  }
  throw ParamError(name + " needs true or false, got " + type_name(v.getType()));
}

std::optional<std::string> to_text(const XmlRpcValue& value, const std::string& name) {
  XmlRpcValue v = copy(value);
  if (v.getType() != XmlRpcValue::TypeString) {
    throw ParamError(name + " needs a name, got " + type_name(v.getType()));
  }
  const std::string s = static_cast<std::string>(v);
  if (s.empty()) return std::nullopt;
  return s;
}

std::vector<std::string> to_names(const XmlRpcValue& value, const std::string& name) {
  XmlRpcValue v = copy(value);
  std::vector<std::string> out;
  if (v.getType() == XmlRpcValue::TypeArray) {
    for (int k = 0; k < v.size(); ++k) {
      if (v[k].getType() != XmlRpcValue::TypeString) {
        throw ParamError(name + " needs a list of names, item " + std::to_string(k) + " is " +
                         type_name(v[k].getType()));
      }
      out.push_back(static_cast<std::string>(v[k]));
    }
    return out;
  }
  if (v.getType() != XmlRpcValue::TypeString) {
    throw ParamError(name + " needs names, got " + type_name(v.getType()));
  }
  const std::string s = static_cast<std::string>(v);
  std::string cur;
  for (char c : s + " ") {
    if (c == ' ' || c == ',' || c == '\t' || c == '\n') {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  return out;
}

namespace {

template <class T, class F>
T from_server(const ros::NodeHandle& nh, const std::string& name, F convert) {
  XmlRpcValue v;
  if (!nh.getParam(name, v)) return T();
  return convert(v, nh.resolveName(name));
}

}  // namespace

std::optional<double> get_double(const ros::NodeHandle& nh, const std::string& name) {
  return from_server<std::optional<double>>(nh, name, to_double);
}
std::optional<bool> get_bool(const ros::NodeHandle& nh, const std::string& name) {
  return from_server<std::optional<bool>>(nh, name, to_bool);
}
std::optional<std::string> get_text(const ros::NodeHandle& nh, const std::string& name) {
  return from_server<std::optional<std::string>>(nh, name, to_text);
}
std::vector<std::string> get_names(const ros::NodeHandle& nh, const std::string& name) {
  return from_server<std::vector<std::string>>(nh, name, to_names);
}

YAML::Node to_yaml(const XmlRpcValue& value) {
  XmlRpcValue v = copy(value);
  switch (v.getType()) {
    case XmlRpcValue::TypeBoolean:
      return YAML::Node(static_cast<bool>(v) ? "true" : "false");
    case XmlRpcValue::TypeInt:
      return YAML::Node(std::to_string(static_cast<int>(v)));
    case XmlRpcValue::TypeDouble:
      return YAML::Node(print(static_cast<double>(v)));
    case XmlRpcValue::TypeString:
      return YAML::Node(static_cast<std::string>(v));
    case XmlRpcValue::TypeArray: {
      YAML::Node n(YAML::NodeType::Sequence);
      for (int k = 0; k < v.size(); ++k) n.push_back(to_yaml(v[k]));
      return n;
    }
    case XmlRpcValue::TypeStruct: {
      YAML::Node n(YAML::NodeType::Map);
      for (auto it = v.begin(); it != v.end(); ++it) n[it->first] = to_yaml(it->second);
      return n;
    }
    default:
      return YAML::Node();
  }
}

std::vector<se3::ControllerSpec> controllers_from_xmlrpc(const std::vector<std::string>& names,
                                                         const std::vector<XmlRpcValue>& configs,
                                                         const std::string& where) {
  std::vector<se3::ControllerSpec> out;
  for (size_t k = 0; k < names.size() && k < configs.size(); ++k) {
    out.push_back(se3::parse_controller(names[k], to_yaml(configs[k]), where));
  }
  return out;
}

std::vector<se3::ControllerSpec> controllers_from_params(const ros::NodeHandle& nh,
                                                         const std::vector<std::string>& names,
                                                         std::vector<std::string>* errors) {
  std::vector<se3::ControllerSpec> out;
  const std::string where = "parameter server (" + nh.getNamespace() + ")";
  for (const std::string& name : names) {
    try {
      // Checked before the parameter server is asked: roscpp throws for a name it cannot
      // resolve.
      if (const std::string why = se3::controller_name_problem(name); !why.empty()) {
        throw se3::ControllerError("~controllers: " + why);
      }
      XmlRpcValue v;
      if (!nh.getParam(name, v)) {
        throw se3::ControllerError(
            "no controller '" + name + "' on the parameter server: looked for " +
            nh.resolveName(name) + "/type, and for NAMESPACE/" + name +
            "/type in every namespace (none, or more than one): load its YAML first (sim.launch "
            "controller_config:=FILE), or give controller_namespace:=");
      }
      out.push_back(controllers_from_xmlrpc({name}, {v}, where).at(0));
    } catch (const se3::ControllerError& e) {
      if (!errors) throw;
      errors->push_back(e.what());
    }
  }
  return out;
}

std::string declared_controller_namespace(const ros::NodeHandle& nh,
                                          const std::vector<std::string>& names) {
  std::vector<std::string> missing;
  for (const std::string& name : names) {
    if (!se3::controller_name_problem(name).empty()) return "";  // its own error follows
    if (!nh.hasParam(name + "/type")) missing.push_back(name);
  }
  std::vector<std::string> all;
  if (missing.empty() || !ros::param::getParamNames(all)) return "";
  // Candidates: the namespaces holding the first missing controller.
  const std::string tail = "/" + missing[0] + "/type";
  std::vector<std::string> found;
  for (const std::string& p : all) {
    if (p.size() > tail.size() && p.compare(p.size() - tail.size(), tail.size(), tail) == 0) {
      const std::string ns = p.substr(0, p.size() - tail.size());
      bool all_there = true;
      for (const std::string& name : names) {
        all_there = all_there && ros::param::has(ns + "/" + name + "/type");
      }
      if (all_there && !ns.empty()) found.push_back(ns);
    }
  }
  return found.size() == 1 ? found[0] : "";
}

// The controllers' namespace when ~controller_namespace is empty: the URDF's gazebo_ros_control
// <robotNamespace> (where Gazebo runs them) when the named controllers are there, else the one
// namespace the loaded YAML declares them under (rrbot's `rrbot: {...}`), else this node's.
std::string controllers_namespace(const ros::NodeHandle& nh, const std::string& urdf_text,
                                  const se3::Model& model, const std::vector<std::string>& names) {
  std::vector<std::string> links, joints;
  for (const se3::LinkFrame& lf : model.links) {
    links.push_back(lf.name);
    if (!lf.joint.empty()) joints.push_back(lf.joint);
  }
  const std::string robot_ns =
      urdf_text.empty() ? std::string()
                        : se3::read_gazebo_tags(urdf_text, links, joints).robot_namespace;
  if (!robot_ns.empty()) {
    try {
      const ros::NodeHandle there_nh(nh, robot_ns);
      bool there = true;
      for (const std::string& n : names) {
        there = there && se3::controller_name_problem(n).empty() && there_nh.hasParam(n + "/type");
      }
      if (there) return robot_ns;
    } catch (const ros::InvalidNameException& e) {
      ROS_WARN(
          "simulator: the URDF's gazebo_ros_control robotNamespace '%s' is not a ROS name: "
          "ignored",
          robot_ns.c_str());
    }
  }
  const std::string ns = declared_controller_namespace(nh, names);
  if (!ns.empty())
    ROS_INFO("simulator: controllers under %s, where their YAML declares them", ns.c_str());
  return ns;
}

}  // namespace se3_ros
