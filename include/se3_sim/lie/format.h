// Numbers in messages: std::to_string(double) and printf's %f print every integer digit (1e300
// became a 310-character message); these print at most 6 significant digits.
#pragma once

#include <cstdio>
#include <string>

namespace se3 {

/// x as printf's %.6g: "0.001", "1e+300", "nan", "inf".
inline std::string num(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", x);
  return buf;
}

}  // namespace se3
