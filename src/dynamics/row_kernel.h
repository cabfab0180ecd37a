// The SIMD-paired kernel of the mass matrix (crba's world-frame evaluation, deep chains): a row
// segment of D is six axpys over the rows of the joint axes, two entries per register, where the
// pairing pays (measured: docs/performance.md). The scalar loop is kept beside it as its
// reference (test/gtest_dynamics.cpp: identical bits); v2d falls back to scalar pairs where the
// compiler has no vector extension (lie/simd.h). Internal header.
#pragma once

#include <cstddef>

#include "../lie/simd.h"

namespace se3 {
namespace detail {

/// x_c = F0 J[0][c] + ... + F5 J[5][c] for c in [c0, c1): written to up[c] and to
/// left[c * stride] (a column and a row of a symmetric matrix).
inline void row_segment(const double (&F)[6], const double* const (&J)[6], int c0, int c1,
                        double* up, double* left, std::ptrdiff_t stride) {
  const double F0 = F[0], F1 = F[1], F2 = F[2], F3 = F[3], F4 = F[4], F5 = F[5];
  int c = c0;
  for (; c + 2 <= c1; c += 2) {
    const v2d x = F0 * load2(J[0] + c) + F1 * load2(J[1] + c) + F2 * load2(J[2] + c) +
                  F3 * load2(J[3] + c) + F4 * load2(J[4] + c) + F5 * load2(J[5] + c);
    store2(up + c, x);
    left[c * stride] = x[0];
    left[(c + 1) * stride] = x[1];
  }
  if (c < c1) {
    const double x =
        F0 * J[0][c] + F1 * J[1][c] + F2 * J[2][c] + F3 * J[3][c] + F4 * J[4][c] + F5 * J[5][c];
    up[c] = x;
    left[c * stride] = x;
  }
}

/// row_segment one entry at a time: its scalar reference.
inline void row_segment_reference(const double (&F)[6], const double* const (&J)[6], int c0, int c1,
                                  double* up, double* left, std::ptrdiff_t stride) {
  for (int c = c0; c < c1; ++c) {
    const double x = F[0] * J[0][c] + F[1] * J[1][c] + F[2] * J[2][c] + F[3] * J[3][c] +
                     F[4] * J[4][c] + F[5] * J[5][c];
    up[c] = x;
    left[c * stride] = x;
  }
}

}  // namespace detail
}  // namespace se3
