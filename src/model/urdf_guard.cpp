// Guards around urdfdom (urdf_guard.h).
#include "urdf_guard.h"

#include <console_bridge/console.h>
#include <tinyxml2.h>
#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <unordered_map>
#include <vector>

#include "se3_sim/model/limits.h"
#include "se3_sim/model/model.h"

namespace se3 {
namespace {

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r';
}

// tinyxml's test for the first character of an element name: a letter, '_', or any byte of a
// multi-byte UTF-8 sequence.
bool element_start(char ch) {
  const auto c = static_cast<unsigned char>(ch);
  return c >= 127 || c == '_' || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z');
}

// Collects urdfdom's console_bridge messages so a rejection becomes one clear line.
class CaptureHandler : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level < console_bridge::CONSOLE_BRIDGE_LOG_ERROR) return;
    if (first_error.empty()) first_error = text;
    if (errors.size() < 20) errors.push_back(text);
  }
  std::string first_error;
  std::vector<std::string> errors;
};

std::mutex g_console_mutex;

// urdf::parseURDF with `handler` as console_bridge's output (nullptr: none at all, and the log
// level above every message, so that console_bridge formats nothing).
urdf::ModelInterfaceSharedPtr parse_with(const std::string& xml,
                                         console_bridge::OutputHandler* handler,
                                         std::string& exception_text) {
  std::lock_guard<std::mutex> lock(g_console_mutex);
  console_bridge::OutputHandler* previous = console_bridge::getOutputHandler();
  const console_bridge::LogLevel previous_level = console_bridge::getLogLevel();
  if (handler) {
    console_bridge::useOutputHandler(handler);
  } else {
    console_bridge::noOutputHandler();
    console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_NONE);
  }
  urdf::ModelInterfaceSharedPtr u;
  try {
    u = urdf::parseURDF(xml);
  } catch (const std::exception& e) {
    exception_text = e.what();
    u.reset();
  }
  console_bridge::setLogLevel(previous_level);
  console_bridge::useOutputHandler(previous);
  return u;
}

[[noreturn]] void too_much(const std::string& what, int line) {
  throw ModelError("URDF: " + what + (line > 0 ? " (line " + std::to_string(line) + ")" : "") +
                   "; see docs/robustness.md");
}

}  // namespace

XmlShape xml_shape(const std::string& s) {
  XmlShape shape;
  const size_t n = s.size();
  int depth = 0, line = 1;
  size_t i = 0;
  // Advances i to just past the first occurrence of `end` (or to n), counting lines.
  auto skip_past = [&](const char* end) {
    const size_t len = std::strlen(end);
    while (i < n && s.compare(i, len, end) != 0) {
      if (s[i] == '\n') ++line;
      ++i;
    }
    i = std::min(n, i + len);
  };
  while (i < n) {
    if (s[i] != '<') {
      if (s[i] == '\n') ++line;
      ++i;
      continue;
    }
    if (s.compare(i, 4, "<!--") == 0) {
      i += 4;
      skip_past("-->");
    } else if (s.compare(i, 9, "<![CDATA[") == 0) {
      i += 9;
      skip_past("]]>");
    } else if (s.compare(i, 2, "</") == 0) {
      depth = std::max(0, depth - 1);
      skip_past(">");
    } else if (i + 1 < n && element_start(s[i + 1])) {
      // A start tag: its name, then attributes (name = value, the value quoted or not) up to
      // '>' (one level deeper) or "/>" (an empty element).
      size_t k = i + 1;
      while (k < n && !is_space(s[k]) && s[k] != '/' && s[k] != '>') ++k;
      const std::string name = s.substr(i + 1, k - i - 1);
      if (name == "link") ++shape.links;
      if (name == "joint") ++shape.joints;
      const int tag_line = line;
      int attributes = 0;
      bool open = false;
      while (k < n) {
        const char c = s[k];
        if (c == '\n') ++line;
        if (c == '>') {
          open = true;
          ++k;
          break;
        }
        if (c == '/' && k + 1 < n && s[k + 1] == '>') {
          k += 2;
          break;
        }
        if (c == '=') {
          ++attributes;
          ++k;
          while (k < n && is_space(s[k])) {
            if (s[k] == '\n') ++line;
            ++k;
          }
          if (k < n && (s[k] == '"' || s[k] == '\'')) {
            const char q = s[k++];
            while (k < n && s[k] != q) {
              if (s[k] == '\n') ++line;
              ++k;
            }
            ++k;
          }
          continue;
        }
        ++k;
      }
      i = std::min(n, k);
      if (attributes > shape.max_attributes) {
        shape.max_attributes = attributes;
        shape.max_attributes_line = tag_line;
      }
      // tinyxml parses an empty element one level down too, so it counts as a level.
      if (depth + 1 > shape.max_depth) {
        shape.max_depth = depth + 1;
        shape.max_depth_line = tag_line;
      }
      if (open) ++depth;
    } else {
      // "<?...>" (tinyxml reads the declaration's quoted values: stopping at the first '>'
      // skips no more than it does), "<!DOCTYPE ...>" and other unknown tags end at '>'.
      ++i;
      skip_past(">");
    }
  }
  return shape;
}

void check_urdf_text(const std::string& xml) {
  if (xml.size() > limits::kMaxUrdfBytes) {
    too_much(std::to_string(xml.size()) + " bytes, more than the " +
                 std::to_string(limits::kMaxUrdfBytes) + " a URDF may have",
             0);
  }
  // tinyxml reads a UTF-8 lead byte and the next one to three bytes as one character, whatever
  // they are: a '<' or the end of the text. Valid UTF-8 has only continuation bytes there.
  const std::size_t bad = first_invalid_utf8(xml);
  if (bad < xml.size()) {
    char byte[8];
    std::snprintf(byte, sizeof byte, "0x%02x", static_cast<unsigned char>(xml[bad]));
    too_much(std::string("byte ") + byte + " is not UTF-8 (XML text is UTF-8)",
             1 + static_cast<int>(std::count(xml.begin(), xml.begin() + bad, '\n')));
  }
  const XmlShape shape = xml_shape(xml);
  if (shape.max_depth > limits::kMaxXmlDepth) {
    too_much("elements nested more than " + std::to_string(limits::kMaxXmlDepth) + " deep",
             shape.max_depth_line);
  }
  if (shape.max_attributes > limits::kMaxXmlAttributes) {
    too_much(
        "an element with more than " + std::to_string(limits::kMaxXmlAttributes) + " attributes",
        shape.max_attributes_line);
  }
  if (shape.links > static_cast<size_t>(limits::kMaxBodies) ||
      shape.joints > static_cast<size_t>(limits::kMaxBodies)) {
    too_much("more than " + std::to_string(limits::kMaxBodies) + " links or joints", 0);
  }
}

// The joints' link graph, read before urdfdom sees it: a joint whose parent is its child, or
// joints whose links form a loop, make urdfdom's link tree hold itself through shared pointers
// (it then leaks it, accepted or not). One line naming the joints; "" when there is none (or
// when tinyxml2 cannot read the text: urdfdom then refuses it with its own reason).
std::string link_loop(const std::string& xml) {
  tinyxml2::XMLDocument doc;
  if (doc.Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS) return "";
  const tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
  if (!robot) return "";
  std::map<std::string, std::pair<std::string, std::string>> up;  // child -> (parent, joint)
  for (const tinyxml2::XMLElement* j = robot->FirstChildElement("joint"); j;
       j = j->NextSiblingElement("joint")) {
    const tinyxml2::XMLElement* p = j->FirstChildElement("parent");
    const tinyxml2::XMLElement* c = j->FirstChildElement("child");
    const char* name = j->Attribute("name");
    const char* parent = p ? p->Attribute("link") : nullptr;
    const char* child = c ? c->Attribute("link") : nullptr;
    if (!name || !parent || !child) continue;  // urdfdom's own error
    if (std::strcmp(parent, child) == 0) {
      return std::string("joint '") + name + "': its parent and child are the same link '" + child +
             "'";
    }
    up.emplace(child, std::make_pair(parent, name));  // a second parent: urdfdom's own error
  }
  // Walk up from every link; a walk longer than the number of joints is a loop.
  for (const auto& kv : up) {
    std::string at = kv.first, joints;
    for (std::size_t k = 0; k <= up.size(); ++k) {
      const auto it = up.find(at);
      if (it == up.end()) break;
      if (k < 8) joints += (joints.empty() ? "'" : " -> '") + it->second.second + "'";
      at = it->second.first;
      if (at == kv.first) return "the joints " + joints + " form a loop of links";
    }
  }
  return "";
}

urdf::ModelInterfaceSharedPtr parse_urdf(const std::string& xml, std::string& error,
                                         std::vector<std::string>* messages) {
  error.clear();
  error = link_loop(xml);
  if (!error.empty()) return nullptr;
  std::string thrown;
  auto keep = [&](const CaptureHandler& h, char stand_in) {
    for (std::string m : h.errors) {
      for (char& c : m) {
        if (stand_in != 0 && c == stand_in) c = '%';
      }
      if (messages) messages->push_back(m);
    }
  };
  if (xml.find('%') == std::string::npos) {
    // No '%' anywhere: nothing urdfdom quotes can be a conversion; keep its messages.
    CaptureHandler h;
    urdf::ModelInterfaceSharedPtr u = parse_with(xml, &h, thrown);
    if (!u) error = !h.first_error.empty() ? h.first_error : thrown;
    if (!u && error.empty()) error = "parse error";
    if (u) keep(h, 0);
    return u;
  }
  // The text holds '%': parse it with console_bridge silent, so that it formats nothing.
  urdf::ModelInterfaceSharedPtr u = parse_with(xml, nullptr, thrown);
  // urdfdom's messages come from a copy whose '%' are replaced by a byte the text does not hold
  // (then put back): the reason of a rejection, the complaints of an acceptance.
  char stand_in = '\x01';
  while (xml.find(stand_in) != std::string::npos && stand_in < '\x1f') ++stand_in;
  if (xml.find(stand_in) == std::string::npos) {
    std::string copy = xml;
    for (char& c : copy) {
      if (c == '%') c = stand_in;
    }
    CaptureHandler h;
    std::string thrown_copy;
    const urdf::ModelInterfaceSharedPtr v = parse_with(copy, &h, thrown_copy);
    if (u) {
      keep(h, stand_in);
    } else {
      error = !h.first_error.empty() ? h.first_error : thrown_copy;
      for (char& c : error) {
        if (c == stand_in) c = '%';
      }
    }
  }
  if (!u && error.empty()) error = !thrown.empty() ? thrown : "parse error";
  return u;
}

void check_urdf_joints(const urdf::ModelInterface& u) {
  auto bad = [](const urdf::Joint& j, const std::string& what) {
    throw ModelError("joint '" + j.name + "': " + what);
  };
  std::unordered_map<std::string, const urdf::Joint*> parent_of;
  for (const auto& kv : u.joints_) {
    if (!kv.second) continue;
    const urdf::Joint& j = *kv.second;
    if (j.dynamics) {
      if (!std::isfinite(j.dynamics->damping) || !std::isfinite(j.dynamics->friction)) {
        bad(j, "dynamics has a non-finite number");
      }
      if (j.dynamics->damping < 0) bad(j, "negative damping");
      if (j.dynamics->friction < 0) bad(j, "negative friction");
    }
    if (j.limits) {
      if (std::isnan(j.limits->lower) || std::isnan(j.limits->upper) ||
          std::isnan(j.limits->effort) || std::isnan(j.limits->velocity)) {
        bad(j, "limit has a NaN");
      }
      if (j.limits->effort < 0) bad(j, "negative effort limit");
      if (j.limits->velocity < 0) bad(j, "negative velocity limit");
    }
    const auto o = j.parent_to_joint_origin_transform;
    if (!std::isfinite(o.position.x) || !std::isfinite(o.position.y) ||
        !std::isfinite(o.position.z) || !std::isfinite(o.rotation.x) ||
        !std::isfinite(o.rotation.y) || !std::isfinite(o.rotation.z) ||
        !std::isfinite(o.rotation.w)) {
      bad(j, "origin has a non-finite number");
    }
    const auto ins = parent_of.emplace(j.child_link_name, &j);
    if (!ins.second) {
      bad(j, "link '" + j.child_link_name + "' is already the child of joint '" +
                 ins.first->second->name + "' (a URDF is a tree)");
    }
  }
  // Every link hangs from the root (urdfdom finds the one link without a parent; links on a
  // loop of joints all have one, and would be left out without a word).
  const urdf::LinkConstSharedPtr root = u.getRoot();
  if (!root) return;
  std::size_t reached = 0;
  std::vector<const urdf::Link*> todo = {root.get()};
  while (!todo.empty()) {
    const urdf::Link* l = todo.back();
    todo.pop_back();
    ++reached;
    if (reached > u.links_.size()) break;
    for (const auto& c : l->child_links) {
      if (c) todo.push_back(c.get());
    }
  }
  if (reached != u.links_.size()) {
    for (const auto& kv : u.joints_) {
      if (kv.second && kv.second->parent_link_name == kv.second->child_link_name) {
        bad(*kv.second, "its parent and child are the same link");
      }
    }
    throw ModelError(
        "URDF: " + std::to_string(u.links_.size() - std::min(reached, u.links_.size())) +
        " link(s) do not hang from the root link '" + root->name + "' (a loop of joints?)");
  }
}

UrdfRelease::~UrdfRelease() {
  if (!u_) return;
  for (auto& kv : u_->links_) {
    if (!kv.second) continue;
    kv.second->child_links.clear();
    kv.second->child_joints.clear();
    kv.second->parent_joint.reset();
  }
  u_->root_link_.reset();
  u_.reset();
}

}  // namespace se3
