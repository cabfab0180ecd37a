// Reads typed values from the scene YAML (yaml_lite) with errors that name the file and line;
// shared by the scene keys (scene.cpp) and the constraint keys (contact_scene.cpp).
#pragma once

#include <cmath>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include "se3_sim/sim.h"
#include "yaml_lite.h"

namespace se3 {

class SceneReader {
 public:
  explicit SceneReader(const std::string& file) : file_(file) {}

  [[noreturn]] void fail(const yaml_lite::Node& n, const std::string& what) const {
    throw SceneError(file_ + ":" + std::to_string(n.line) + ": " + what);
  }

  double number(const yaml_lite::Node& n, const std::string& key) const {
    if (!n.is_scalar() || n.value.empty()) fail(n, "'" + key + "' needs a number");
    char* end = nullptr;
    const double x = std::strtod(n.value.c_str(), &end);
    if (*end != '\0' || !std::isfinite(x)) {
      fail(n, "'" + key + "' needs a finite number, got '" + n.value + "'");
    }
    return x;
  }

  std::string text(const yaml_lite::Node& n, const std::string& key) const {
    if (!n.is_scalar() || n.value.empty()) fail(n, "'" + key + "' needs a value");
    return n.value;
  }

  std::vector<double> numbers(const yaml_lite::Node& n, const std::string& key, size_t min_size,
                              size_t max_size) const {
    if (!n.is_list()) fail(n, "'" + key + "' needs a list [a, b, ...]");
    if (n.list.size() < min_size || n.list.size() > max_size) {
      fail(n, "'" + key + "' needs " + std::to_string(min_size) +
                  (min_size == max_size ? "" : " to " + std::to_string(max_size)) + " numbers");
    }
    std::vector<double> v;
    for (const auto& x : n.list) v.push_back(number(x, key));
    return v;
  }

  Vec3 vec3(const yaml_lite::Node& n, const std::string& key) const {
    const auto v = numbers(n, key, 3, 3);
    return Vec3(v[0], v[1], v[2]);
  }

  std::vector<std::pair<std::string, double>> joint_map(const yaml_lite::Node& n,
                                                        const std::string& key) const {
    std::vector<std::pair<std::string, double>> out;
    if (n.is_scalar() && n.value.empty()) return out;
    if (!n.is_map()) fail(n, "'" + key + "' needs a map {joint: value, ...}");
    for (const auto& kv : n.map) out.emplace_back(kv.first, number(kv.second, key));
    return out;
  }

  bool boolean(const yaml_lite::Node& n, const std::string& key) const {
    const std::string v = text(n, key);
    if (v == "true" || v == "True" || v == "yes" || v == "on") return true;
    if (v == "false" || v == "False" || v == "no" || v == "off") return false;
    fail(n, "'" + key + "' needs true or false, got '" + v + "'");
  }

  const yaml_lite::Node& map(const yaml_lite::Node& n, const std::string& key) const {
    if (!n.is_map()) fail(n, "'" + key + "' needs a map {key: value, ...}");
    return n;
  }

  void only_keys(const yaml_lite::Node& n, const std::string& where,
                 const std::vector<std::string>& keys) const {
    for (const auto& kv : n.map) {
      bool known = false;
      for (const auto& k : keys) known = known || k == kv.first;
      if (!known) {
        std::string list;
        for (const auto& k : keys) list += (list.empty() ? "" : ", ") + k;
        fail(kv.second, "unknown key '" + kv.first + "' in " + where + " (known: " + list + ")");
      }
    }
  }

 private:
  std::string file_;
};

}  // namespace se3
