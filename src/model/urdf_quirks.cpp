// Quirks of real URDFs (urdf_quirks.h).
#include "urdf_quirks.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <functional>
#include <map>
#include <regex>
#include <set>

#include "se3_sim/model/model.h"

namespace se3 {
namespace {

// Stand-in the text pass writes for an infinite lower or upper limit; the model pass reads it.
constexpr double kInfLimit = 1e300;

std::string join(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

// The name of the <joint> element that holds text position `pos` ("?" if none).
std::string enclosing_joint(const std::string& xml, std::size_t pos) {
  const std::size_t j = xml.rfind("<joint", pos);
  if (j == std::string::npos) return "?";
  static const std::regex name_re(R"re(^<joint\b[^>]*?\bname\s*=\s*(["'])(.*?)\1)re");
  std::smatch m;
  const std::string head = xml.substr(j, std::min<std::size_t>(xml.find('>', j) - j + 1, 4096));
  if (std::regex_search(head, m, name_re)) return m[2];
  return "?";
}

}  // namespace

std::string urdf_text_quirks(const std::string& xml, std::vector<std::string>& warnings) {
  if (xml.find("<xacro:") !=
      std::string::npos) {  // unexpanded macros (xmlns:xacro alone stays in expanded files)
    throw ModelError(
        "this is a xacro file, not a URDF: expand it first (xacro robot.urdf.xacro > robot.urdf; "
        "Debian 12 has no xacro package, pip has), or load xacro's output into "
        "robot_description");
  }
  // <limit ... attr="inf" ...>: urdfdom refuses the value. effort and velocity: 0 (= none,
  // urdf_model.cpp); lower and upper: the stand-in kInfLimit with its sign.
  static const std::regex attr_re(
      R"re(\b(lower|upper|effort|velocity)(\s*=\s*)(["'])\s*([+-]?)(inf|infinity)\s*\3)re",
      std::regex::icase);
  std::string out;
  std::vector<std::string> joints;
  std::size_t done = 0;
  for (std::size_t at = xml.find("<limit"); at != std::string::npos;
       at = xml.find("<limit", at + 1)) {
    const std::size_t end = xml.find('>', at);
    if (end == std::string::npos) break;
    const std::string tag = xml.substr(at, end - at + 1);
    if (!std::regex_search(tag, attr_re)) continue;
    std::string fixed;
    auto it = std::sregex_iterator(tag.begin(), tag.end(), attr_re);
    std::size_t last = 0;
    for (; it != std::sregex_iterator(); ++it) {
      const std::smatch& m = *it;
      const std::string attr = m[1];
      std::string value = "0";
      if (attr == "lower" || attr == "upper") {
        value = std::string(m[4] == "-" ? "-" : "") + "1e300";
      }
      fixed += tag.substr(last, m.position(0) - last) + attr + std::string(m[2]) +
               std::string(m[3]) + value + std::string(m[3]);
      last = m.position(0) + m.length(0);
    }
    fixed += tag.substr(last);
    out += xml.substr(done, at - done) + fixed;
    done = end + 1;
    joints.push_back(enclosing_joint(xml, at));
  }
  if (joints.empty()) return xml;
  out += xml.substr(done);
  warnings.push_back("URDF quirk: 'inf' in the <limit> of joint" +
                     std::string(joints.size() > 1 ? "s " : " ") + join(joints) +
                     " (urdfdom refuses it): read as no limit");
  return out;
}

void urdf_model_quirks(urdf::ModelInterface& u, std::vector<std::pair<std::string, double>>& lock,
                       std::vector<std::string>& warnings) {
  std::vector<std::string> no_range, no_effort, massless;
  // Mass below each link (its own and its descendants'), without recursion: a URDF may be a
  // chain of thousands of links (urdf_guard.h bounds them, not the stack).
  std::map<std::string, double> below;
  if (u.getRoot()) {
    std::vector<const urdf::Link*> order = {u.getRoot().get()};  // parents before children
    for (std::size_t k = 0; k < order.size(); ++k) {
      for (const auto& c : order[k]->child_links) {
        if (c) order.push_back(c.get());
      }
    }
    for (auto it = order.rbegin(); it != order.rend(); ++it) {
      const urdf::Link& l = **it;
      double m = l.inertial ? std::max(0.0, l.inertial->mass) : 0.0;
      for (const auto& c : l.child_links) {
        if (c) m += below[c->name];
      }
      below[l.name] = m;
    }
  }
  for (auto& kv : u.joints_) {
    urdf::Joint& j = *kv.second;
    const bool moving = j.type == urdf::Joint::REVOLUTE || j.type == urdf::Joint::CONTINUOUS ||
                        j.type == urdf::Joint::PRISMATIC;
    if (!moving) continue;
    if (j.limits) {
      urdf::JointLimits& L = *j.limits;
      if (L.lower <= -kInfLimit && L.upper >= kInfLimit) L.lower = L.upper = 0;  // none
      if (j.type != urdf::Joint::CONTINUOUS && !(L.lower < L.upper)) no_range.push_back(j.name);
      if (!(L.effort > 0) || !std::isfinite(L.effort)) no_effort.push_back(j.name);
    } else {
      no_effort.push_back(j.name);
    }
    const auto b = below.find(j.child_link_name);
    const bool already =
        std::any_of(lock.begin(), lock.end(), [&](const auto& kv) { return kv.first == j.name; });
    if (b != below.end() && !(b->second > 0) && !already) {
      double q = 0;
      if (j.limits && j.type != urdf::Joint::CONTINUOUS && j.limits->lower < j.limits->upper) {
        q = std::clamp(0.0, j.limits->lower, j.limits->upper);
      }
      lock.emplace_back(j.name, q);
      massless.push_back(j.name);
    }
  }
  auto plural = [](const std::vector<std::string>& v) { return v.size() > 1 ? "s " : " "; };
  if (!no_range.empty()) {
    warnings.push_back("URDF quirk: joint" + std::string(plural(no_range)) + join(no_range) +
                       " with lower >= upper (a CAD exporter's 0 0): no position limits");
  }
  if (!no_effort.empty()) {
    warnings.push_back("URDF quirk: joint" + std::string(plural(no_effort)) + join(no_effort) +
                       " without a positive finite effort limit: efforts not clamped");
  }
  if (!massless.empty()) {
    warnings.push_back("URDF quirk: joint" + std::string(plural(massless)) + join(massless) +
                       " moving only links without mass (no inertial): locked (no dynamics)");
  }
}

void group_quirk_warnings(std::vector<std::string>& warnings) {
  // "link 'NAME': principal moments ... break the triangle inequality ...", one per link.
  static const std::string kTriangle = "break the triangle inequality";
  std::vector<std::string> links, rest;
  for (const auto& w : warnings) {
    const std::size_t a = w.find("link '");
    const std::size_t b = a == std::string::npos ? a : w.find("'", a + 6);
    if (w.find(kTriangle) != std::string::npos && a == 0 && b != std::string::npos) {
      links.push_back(w.substr(6, b - 6));
    } else {
      rest.push_back(w);
    }
  }
  if (links.size() < 2) return;
  rest.push_back("URDF quirk: the inertials of links " + join(links) +
                 " break the triangle inequality (physically inconsistent, or a thin rod's "
                 "rounding): kept as given");
  warnings = rest;
}

}  // namespace se3
