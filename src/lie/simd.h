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

// Loops over the short vectors of a time step (a few to a few hundred entries), two entries per
// register and no set-up beyond the loop: Eigen's dynamic-size expressions and memcpy cost more in
// set-up than in arithmetic at these sizes. Outputs may alias inputs entry for entry.

/// y = x.
inline void copy(int n, const double* x, double* y) {
  int k = 0;
  for (; k + 2 <= n; k += 2) store2(y + k, load2(x + k));
  if (k < n) y[k] = x[k];
}
/// y += c x.
inline void axpy(int n, double c, const double* x, double* y) {
  int k = 0;
  for (; k + 2 <= n; k += 2) store2(y + k, load2(y + k) + c * load2(x + k));
  if (k < n) y[k] += c * x[k];
}

/// Whether all n entries are finite: x - x is 0 for a finite x and NaN for an infinity or a NaN,
/// and a sum with a NaN in it is NaN (no early exit).
inline bool all_finite(int n, const double* x) {
  v2d s = {0.0, 0.0};
  int k = 0;
  for (; k + 2 <= n; k += 2) {
    const v2d a = load2(x + k);
    s += a - a;
  }
  double r = s[0] + s[1];
  if (k < n) r += x[k] - x[k];
  return r == 0;
}
/// y = x + sum_t c[t] z[t] over the M < 5 terms t, in one pass.
template <int M>
inline void add_terms(int n, const double* x, const double* c, const double* const* z, double* y) {
  int k = 0;
  for (; k + 2 <= n; k += 2) {
    v2d s = load2(x + k);
    for (int t = 0; t < M; ++t) s += c[t] * load2(z[t] + k);
    store2(y + k, s);
  }
  if (k < n) {
    double s = x[k];
    for (int t = 0; t < M; ++t) s += c[t] * z[t][k];
    y[k] = s;
  }
}
/// y = x + sum_t c[t] z[t] over T >= 1 terms, in passes of up to four terms.
inline void add_terms(int n, const double* x, int T, const double* c, const double* const* z,
                      double* y) {
  for (int t = 0; t < T; t += 4, x = y) {
    switch (T - t) {
      case 1:
        add_terms<1>(n, x, c + t, z + t, y);
        break;
      case 2:
        add_terms<2>(n, x, c + t, z + t, y);
        break;
      case 3:
        add_terms<3>(n, x, c + t, z + t, y);
        break;
      default:
        add_terms<4>(n, x, c + t, z + t, y);
        break;
    }
  }
}

}  // namespace detail
}  // namespace se3
