// Two doubles in one register, for the hot paths that carry pairs of numbers through the same
// arithmetic. With GCC and Clang, v2d is their portable vector extension: SSE2 on x86-64 (no
// -march needed), NEON on arm64, pairs of scalars elsewhere. SE3_SIM_SCALAR_PAIRS (or another
// compiler) makes it a plain struct of two doubles: the same arithmetic lane by lane, the
// portable fallback and the scalar reference the SIMD pairing is measured against
// (docs/performance.md). Internal header.
#pragma once

#include <cstdlib>
#include <cstring>

// Before a loop whose iterations carry no dependency through memory that the compiler cannot rule
// out (arrays that may alias): GCC's `ivdep` lets it vectorize without run-time alias checks.
// Other compilers get nothing: Clang has no `ivdep` and warned about the unknown pragma.
#if defined(__GNUC__) && !defined(__clang__)
#define SE3_SIM_IVDEP _Pragma("GCC ivdep")
#else
#define SE3_SIM_IVDEP
#endif

namespace se3 {
namespace detail {

#if (defined(__GNUC__) || defined(__clang__)) && !defined(SE3_SIM_SCALAR_PAIRS)
typedef double v2d __attribute__((vector_size(16)));
#else
#define SE3_SIM_PAIRS_ARE_SCALAR 1
struct v2d {
  double v[2];
  double operator[](int i) const { return v[i]; }
  double& operator[](int i) { return v[i]; }
  v2d& operator+=(const v2d& o) {
    v[0] += o.v[0], v[1] += o.v[1];
    return *this;
  }
  v2d& operator-=(const v2d& o) {
    v[0] -= o.v[0], v[1] -= o.v[1];
    return *this;
  }
};
inline v2d operator+(v2d a, v2d b) {
  return v2d{{a.v[0] + b.v[0], a.v[1] + b.v[1]}};
}
inline v2d operator-(v2d a, v2d b) {
  return v2d{{a.v[0] - b.v[0], a.v[1] - b.v[1]}};
}
inline v2d operator*(v2d a, v2d b) {
  return v2d{{a.v[0] * b.v[0], a.v[1] * b.v[1]}};
}
inline v2d operator*(double c, v2d a) {
  return v2d{{c * a.v[0], c * a.v[1]}};
}
inline v2d operator*(v2d a, double c) {
  return v2d{{a.v[0] * c, a.v[1] * c}};
}
inline v2d operator-(v2d a) {
  return v2d{{-a.v[0], -a.v[1]}};
}
#endif
/// {a, b} (a vector-extension initializer reads the same).
inline v2d pair(double a, double b) {
  v2d r;
  r[0] = a;
  r[1] = b;
  return r;
}

/// Two consecutive doubles, any alignment.
inline v2d load2(const double* p) {
  v2d r;
  std::memcpy(&r, p, sizeof r);
  return r;
}
inline void store2(double* p, v2d x) {
  std::memcpy(p, &x, sizeof x);
}

// Loops over the short vectors of a time step (a few to a few hundred entries) with no set-up
// beyond the loop: Eigen's dynamic-size expressions and memcpy cost more in set-up than in
// arithmetic at these sizes. Plain scalar loops: pairing their entries in v2d registers saved
// nothing measurable (docs/performance.md). Outputs may alias inputs entry for entry.

/// y = x.
inline void copy(int n, const double* x, double* y) {
  for (int k = 0; k < n; ++k) y[k] = x[k];
}
/// y += c x.
inline void axpy(int n, double c, const double* x, double* y) {
  for (int k = 0; k < n; ++k) y[k] += c * x[k];
}

/// Whether all n entries are finite: x - x is 0 for a finite x and NaN for an infinity or a NaN,
/// and a sum with a NaN in it is NaN (no early exit).
inline bool all_finite(int n, const double* x) {
  double s = 0;
  for (int k = 0; k < n; ++k) s += x[k] - x[k];
  return s == 0;
}
/// y = x + sum_t c[t] z[t] over the M < 5 terms t, in one pass.
template <int M>
inline void add_terms(int n, const double* x, const double* c, const double* const* z, double* y) {
  for (int k = 0; k < n; ++k) {
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

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define SE3_SIM_RUNTIME_AVX 1
// Whether the four-lane AVX loops (chosen at run time, compiled with target("avx")) may run: the
// CPU has AVX and SE3_SIM_NO_AVX is not set in the environment (which keeps the SSE2 loops, to
// test them on an AVX machine). Those loops multiply and add separately (no fused
// multiply-add): each lane computes what the scalar and SSE2 loops compute, to the bit.
inline bool have_avx() {
  static const bool avx = __builtin_cpu_supports("avx") && !std::getenv("SE3_SIM_NO_AVX");
  return avx;
}
#endif

}  // namespace detail
}  // namespace se3
