// The <gazebo> extension tags of a URDF (gazebo_tags.h).
#include "se3_sim/model/gazebo_tags.h"

#include <tinyxml2.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <set>
#include <utility>

#include "xml_text.h"

namespace se3 {
namespace {

using xml_text::trimmed;

bool number(const std::string& t, double& out) {
  return xml_text::finite_number(t, out);
}

bool boolean(const std::string& t, int& out) {
  if (t == "true" || t == "1") {
    out = 1;
  } else if (t == "false" || t == "0") {
    out = 0;
  } else {
    return false;
  }
  return true;
}

// Gazebo classic's stock colours by name (their diffuse colour, rounded).
const std::map<std::string, std::array<float, 4>>& stock_colours() {
  static const std::map<std::string, std::array<float, 4>> c = {
      {"White", {1.0f, 1.0f, 1.0f, 1}},
      {"Black", {0.0f, 0.0f, 0.0f, 1}},
      {"FlatBlack", {0.1f, 0.1f, 0.1f, 1}},
      {"Grey", {0.7f, 0.7f, 0.7f, 1}},
      {"Gray", {0.7f, 0.7f, 0.7f, 1}},
      {"DarkGrey", {0.175f, 0.175f, 0.175f, 1}},
      {"LightGrey", {0.8f, 0.8f, 0.8f, 1}},
      {"Red", {1.0f, 0.0f, 0.0f, 1}},
      {"RedBright", {0.87f, 0.26f, 0.07f, 1}},
      {"Green", {0.0f, 1.0f, 0.0f, 1}},
      {"Blue", {0.0f, 0.0f, 1.0f, 1}},
      {"SkyBlue", {0.53f, 0.81f, 0.92f, 1}},
      {"Yellow", {1.0f, 1.0f, 0.0f, 1}},
      {"ZincYellow", {0.97f, 0.95f, 0.21f, 1}},
      {"DarkYellow", {0.7f, 0.7f, 0.0f, 1}},
      {"Purple", {1.0f, 0.0f, 1.0f, 1}},
      {"Turquoise", {0.0f, 1.0f, 1.0f, 1}},
      {"Orange", {1.0f, 0.5f, 0.05f, 1}},
      {"Gold", {0.8f, 0.64f, 0.2f, 1}},
      {"Indigo", {0.33f, 0.0f, 0.5f, 1}},
      {"Wood", {0.55f, 0.35f, 0.2f, 1}},
      {"WhiteGlow", {1.0f, 1.0f, 1.0f, 1}},
      {"BlueGlow", {0.0f, 0.0f, 1.0f, 1}},
      {"GreenGlow", {0.0f, 1.0f, 0.0f, 1}},
      {"RedGlow", {1.0f, 0.0f, 0.0f, 1}},
      {"PurpleGlow", {1.0f, 0.0f, 1.0f, 1}},
      {"BlueTransparent", {0.0f, 0.0f, 1.0f, 0.5f}},
      {"GreenTransparent", {0.0f, 1.0f, 0.0f, 0.5f}},
      {"RedTransparent", {1.0f, 0.0f, 0.0f, 0.5f}},
  };
  return c;
}

}  // namespace

double GazeboLink::mu() const {
  if (std::isnan(mu1)) return mu2;
  if (std::isnan(mu2)) return mu1;
  return std::min(mu1, mu2);
}

const GazeboLink* GazeboTags::link(const std::string& name) const {
  for (const GazeboLink& l : links) {
    if (l.link == name) return &l;
  }
  return nullptr;
}

const GazeboJoint* GazeboTags::joint(const std::string& name) const {
  for (const GazeboJoint& j : joints) {
    if (j.joint == name) return &j;
  }
  return nullptr;
}

bool gazebo_material_rgba(const std::string& name, std::array<float, 4>& rgba) {
  if (name.compare(0, 7, "Gazebo/") != 0) return false;
  const auto it = stock_colours().find(name.substr(7));
  if (it == stock_colours().end()) return false;
  rgba = it->second;
  return true;
}

GazeboTags read_gazebo_tags(const std::string& urdf_xml, const std::vector<std::string>& links,
                            const std::vector<std::string>& joints) {
  GazeboTags out;
  tinyxml2::XMLDocument doc;
  if (doc.Parse(urdf_xml.c_str(), urdf_xml.size()) != tinyxml2::XML_SUCCESS) return out;
  const tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
  if (!robot) return out;
  const std::set<std::string> link_set(links.begin(), links.end());
  const std::set<std::string> joint_set(joints.begin(), joints.end());
  // Unknown tags by name, with their lines: one warning for all.
  std::map<std::string, std::vector<int>> unknown;
  auto bad_value = [&](const tinyxml2::XMLElement* e, const std::string& what) {
    out.warnings.push_back("URDF line " + std::to_string(e->GetLineNum()) + ": <gazebo> <" +
                           e->Name() + "> '" + trimmed(e->GetText()) + "' is not " + what +
                           "; ignored");
  };
  auto num = [&](const tinyxml2::XMLElement* e, double& v, bool non_negative) {
    double x = 0;
    if (!number(trimmed(e->GetText()), x) || (non_negative && x < 0)) {
      bad_value(e, non_negative ? "a number >= 0" : "a number");
    } else {
      v = x;
    }
  };
  auto flag = [&](const tinyxml2::XMLElement* e, int& v) {
    if (!boolean(trimmed(e->GetText()), v)) bad_value(e, "true or false");
  };
  for (const auto* g = robot->FirstChildElement("gazebo"); g; g = g->NextSiblingElement("gazebo")) {
    const char* ref_attr = g->Attribute("reference");
    const std::string ref = ref_attr ? trimmed(ref_attr) : "";
    GazeboLink* L = nullptr;
    GazeboJoint* J = nullptr;
    if (ref_attr) {
      if (link_set.count(ref)) {
        auto it = std::find_if(out.links.begin(), out.links.end(),
                               [&](const GazeboLink& l) { return l.link == ref; });
        if (it == out.links.end()) {
          out.links.push_back({});
          out.links.back().link = ref;
          out.links.back().line = g->GetLineNum();
          it = out.links.end() - 1;
        }
        L = &*it;
      } else if (joint_set.count(ref)) {
        auto it = std::find_if(out.joints.begin(), out.joints.end(),
                               [&](const GazeboJoint& j) { return j.joint == ref; });
        if (it == out.joints.end()) {
          out.joints.push_back({});
          out.joints.back().joint = ref;
          out.joints.back().line = g->GetLineNum();
          it = out.joints.end() - 1;
        }
        J = &*it;
      } else {
        out.warnings.push_back("URDF line " + std::to_string(g->GetLineNum()) +
                               ": <gazebo reference=\"" + ref +
                               "\"> names no link or joint of the URDF; ignored");
        continue;
      }
    }
    for (const auto* e = g->FirstChildElement(); e; e = e->NextSiblingElement()) {
      const std::string tag = e->Name();
      if (tag == "sensor") continue;  // the sensors' (sensor_reader.cpp)
      if (tag == "plugin") {
        const std::string file = e->Attribute("filename") ? e->Attribute("filename") : "";
        if (file != "libgazebo_ros_control.so" || L || J) continue;  // sensors' plugins
        out.control_plugin = true;
        if (const auto* ns = e->FirstChildElement("robotNamespace")) {
          out.robot_namespace = trimmed(ns->GetText());
        }
        if (const auto* p = e->FirstChildElement("controlPeriod")) {
          double v = 0;
          if (number(trimmed(p->GetText()), v) && v > 0) {
            out.control_period = v;
          } else {
            bad_value(p, "a positive number of seconds");
          }
        }
        continue;
      }
      bool known = true;
      if (L) {
        if (tag == "mu1") {
          num(e, L->mu1, true);
        } else if (tag == "mu2") {
          num(e, L->mu2, true);
        } else if (tag == "kp") {
          num(e, L->kp, true);
        } else if (tag == "kd") {
          num(e, L->kd, true);
        } else if (tag == "minDepth") {
          num(e, L->min_depth, true);
        } else if (tag == "maxVel") {
          num(e, L->max_vel, true);
        } else if (tag == "selfCollide") {
          flag(e, L->self_collide);
        } else if (tag == "gravity") {
          flag(e, L->gravity);
        } else if (tag == "turnGravityOff") {  // the old name, inverted
          int off = -1;
          flag(e, off);
          if (off >= 0) L->gravity = 1 - off;
        } else if (tag == "material") {
          L->material = trimmed(e->GetText());
          std::array<float, 4> rgba;
          if (!gazebo_material_rgba(L->material, rgba)) {
            out.warnings.push_back("URDF line " + std::to_string(e->GetLineNum()) +
                                   ": <gazebo> material '" + L->material +
                                   "' is not one of Gazebo's stock colours; the URDF's is drawn");
          }
        } else {
          known = false;
        }
      } else if (J) {
        if (tag == "provideFeedback") {
          flag(e, J->provide_feedback);
        } else if (tag == "implicitSpringDamper") {
          flag(e, J->implicit_spring_damper);
        } else {
          known = false;
        }
      } else if (tag == "static") {
        flag(e, out.is_static);
      } else {
        known = false;
      }
      if (!known) unknown[tag].push_back(e->GetLineNum());
    }
  }
  if (!unknown.empty()) {
    std::string list;
    for (const auto& kv : unknown) {
      list += (list.empty() ? "" : ", ") + kv.first + " (line";
      list += kv.second.size() > 1 ? "s " : " ";
      for (size_t k = 0; k < kv.second.size() && k < 5; ++k) {
        list += (k ? ", " : "") + std::to_string(kv.second[k]);
      }
      list += kv.second.size() > 5 ? ", ...)" : ")";
    }
    out.warnings.push_back("URDF: <gazebo> tags se3_sim does not use, ignored: " + list +
                           " (docs/gazebo.md lists the ones it maps)");
  }
  return out;
}

}  // namespace se3
