// Two doubles in one SSE2 register, for the hot paths that carry pairs of numbers through the
// same arithmetic (GCC/Clang vector extension: plain SSE2, no -march needed). Internal header.
#pragma once

#include <cstring>

namespace se3 {
namespace detail {

typedef double v2d __attribute__((vector_size(16)));

/// Two consecutive doubles, any alignment.
inline v2d load2(const double* p) {
  v2d r;
  std::memcpy(&r, p, sizeof r);
  return r;
}
inline void store2(double* p, v2d x) {
  std::memcpy(p, &x, sizeof x);
}

}  // namespace detail
}  // namespace se3
