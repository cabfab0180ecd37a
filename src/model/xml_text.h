// The text of a URDF's extension elements (<gazebo>, <transmission>, a sensor's elements), read
// with tinyxml2 by the model and sim layers: one rule for whitespace and numbers.
#pragma once

#include <cmath>
#include <cstdlib>
#include <string>

namespace se3 {
namespace xml_text {

/// The text without leading and trailing whitespace ("" for none).
inline std::string trimmed(const char* s) {
  const std::string t = s ? s : "";
  const auto a = t.find_first_not_of(" \t\r\n");
  if (a == std::string::npos) return "";
  return t.substr(a, t.find_last_not_of(" \t\r\n") - a + 1);
}

/// True, with `out` set, when the whole (trimmed) text is one finite number.
inline bool finite_number(const std::string& t, double& out) {
  if (t.empty()) return false;
  char* end = nullptr;
  const double v = std::strtod(t.c_str(), &end);
  if (*end != '\0' || !std::isfinite(v)) return false;
  out = v;
  return true;
}

}  // namespace xml_text
}  // namespace se3
