// Batched sin/cos: two lanes per register (GCC/Clang vector extensions: SSE2 on x86-64, NEON on
// arm64; no FMA), without branches except one "both lanes in range" test per pair. The kernel is
// written once for a lane type: the pair (v2d, v2i) or a single double (sincos_reference, the
// scalar reference and the portable fallback of a build without vector extensions).
//
// Method, for a lane with |x| <= B = 2^20. The kernel works on |x| (so k >= 0) and gives sin
// the sign of x at the end (sin is odd, cos even).
//
// 1. k = nearest integer to |x| 2/pi (add and subtract 1.5 2^52), |x| = k pi/2 + r,
//    |r| <= pi/4 + 2^-31, k <= 667544 < 2^20.
// 2. r as a double-double rh + rl, with pi/2 = P1 + P2 + P3 + P4: P1 holds the bits 2^0..2^-32
//    of pi/2, P2 the bits 2^-33..2^-53, P3 the bits 2^-54..2^-85, P4 the rest rounded to a
//    double. k P1, k P2 and k P3 are exact (33, 20 and 32 bits times a 20-bit k).
//    s = (|x| - k P1) - k P2 is exact: for k >= 1, |x| > 1/2 is a multiple of 2^-53, so are
//    both products, and |s| < 1. (rh, e) = Fast2Sum(s, -k P3) is exact: if |s| >= |k P3| by
//    the usual condition, else |s - k P3| < 2^-32 is a multiple of 2^-85, so s - k P3 is
//    exact and e = 0. rl = e - k P4. |rh + rl - r| < 2^-118 (rounding of k P4 and the
//    2^-141.8 tail of pi/2, times k < 2^20). Over the doubles next to k pi/2 for every
//    k < 2^20 the smallest |r| is 2^-60.5 (x = 45.553093477052, k = 29), and in every binade
//    of k it is large enough that r is known to 2^-66 relative or better.
// 3. Split rh = A + (rh - A), A with 26 bits (Veltkamp), B = (rh - A) + rl: |B| <= 2^-26 |A|
//    and z = A^2 is exact. With S = sin A, C = cos A (|B|^3 terms are below 2^-78 |A|):
//      sin r = S + B (C - B/2 S),  cos r = C - B (S + B/2 C).
// 4. Kernels on |A| <= pi/4 with my own weighted minimax fits in z (rounded to doubles one
//    coefficient at a time, refitting the rest; relative error 2^-57.9 for sin, 2^-63.9 cos).
//    tools/sincos/derive_constants.py derives them, the pi/2 parts and the |r| scan of 2.
//      S = A + A z P(z),  C = 1 - z/2 + z^2 Q(z),  P, Q of degree 5.
//    cos: w = fl(1 - z/2) plus its exact rounding error (1 - w) - z/2; z being exact, nothing
//    of the size of an ulp of r^2 is lost (with z = fl(r^2) that alone costs up to 0.25 ulp).
//    sin: the final A + tail goes through Fast2Sum, so the tail's own rounding does not count.
//    Error budget at |r| = pi/4 (the worst place), in ulps of the result: sin 0.5 (final
//    rounding) + 0.0625 (rounding of A z P) + 0.063 (of P) + 0.04 (of A z) + 0.024 (fit)
//    < 0.70; cos 0.5 + 0.05 = 0.55. B terms, reduction and the dropped B^3 terms: < 0.001.
// 5. Quadrant k mod 4 (the low bits of 1.5 2^52 + k): swap sin/cos for odd k and flip signs,
//    with bit masks.
//
// Measured against long double sinl/cosl (test/gtest_sincos.cpp): max error 0.67 ulp.
#include "sincos.h"

#include <cmath>
#include <cstdint>
#include <cstring>

#include "lie/simd.h"

#if defined(__SSE2__) && !defined(SE3_SIM_PAIRS_ARE_SCALAR)
#include <emmintrin.h>
#endif

// The error-free transformations (Fast2Sum, Veltkamp split) must not be contracted into FMAs
// if this file is ever built for a CPU that has them.
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

namespace se3 {
namespace detail {
namespace {

constexpr std::int64_t kSign = INT64_MIN;

/// The constants, as lanes of D (double or v2d) and I (std::int64_t or v2i).
template <class D, class I>
struct alignas(16) Consts {
  D two_over_pi, shift, p1, p2, p3, p4, split, half, one, bound;
  D s1, s2, s3, s4, s5, s6, c1, c2, c3, c4, c5, c6;
  I sign;
};

template <class D, class I, class Dup, class DupI>
constexpr Consts<D, I> make_consts(Dup dup, DupI dupi) {
  return {
      dup(0x1.45f306dc9c883p-1),   // 2/pi
      dup(0x1.8p52),               // 1.5 2^52: adding and subtracting it rounds to an integer
      dup(0x1.921fb54400000p+0),   // P1: pi/2 = P1 + P2 + P3 + P4 (step 2)
      dup(0x1.0b46000000000p-34),  // P2
      dup(0x1.1a62633000000p-54),  // P3
      dup(0x1.45c06e0e68948p-86),  // P4
      dup(134217729.0),            // Veltkamp splitter 2^27 + 1
      dup(0.5),
      dup(1.0),
      dup(kSinCosBound),
      dup(-0x1.5555555555548p-3),   // S1: sin A = A + A z (S1 + S2 z + ... + S6 z^5), z = A^2
      dup(0x1.111111110f730p-7),    // S2
      dup(-0x1.a01a019be9217p-13),  // S3
      dup(0x1.71de35552b52cp-19),   // S4
      dup(-0x1.ae5e4b83e46f4p-26),  // S5
      dup(0x1.5d8b55946df43p-33),   // S6
      dup(0x1.555555555554bp-5),    // C1: cos A = 1 - z/2 + z^2 (C1 + C2 z + ... + C6 z^5)
      dup(-0x1.6c16c16c15015p-10),  // C2
      dup(0x1.a01a019c8f254p-16),   // C3
      dup(-0x1.27e4f7f19148bp-22),  // C4
      dup(0x1.1ee9dbcefbddep-29),   // C5
      dup(-0x1.8fa684877410cp-37),  // C6
      dupi(kSign),                  // sign bit
  };
}

// Bit casts between the lanes of D and I.
inline std::int64_t bits(double x) {
  std::int64_t r;
  std::memcpy(&r, &x, sizeof r);
  return r;
}
inline double from_bits(std::int64_t x) {
  double r;
  std::memcpy(&r, &x, sizeof r);
  return r;
}
/// x shifted left by n bits as unsigned (a left shift into or past the sign bit of a signed
/// integer is undefined).
inline std::int64_t shift_left(std::int64_t x, int n) {
  return static_cast<std::int64_t>(static_cast<std::uint64_t>(x) << n);
}
/// All ones where the lowest bit of x is set (an arithmetic shift of bit 63 through the lane).
inline std::int64_t spread_sign(std::int64_t x) {
  return x >> 63;
}

#ifndef SE3_SIM_PAIRS_ARE_SCALAR
typedef long long v2i __attribute__((vector_size(16)));
inline v2i bits(v2d x) {
  return (v2i)x;
}
inline v2d from_bits(v2i x) {
  return (v2d)x;
}
typedef unsigned long long v2u __attribute__((vector_size(16)));
inline v2i shift_left(v2i x, int n) {
  return (v2i)((v2u)x << n);
}
inline v2i spread_sign(v2i x) {
#if defined(__SSE2__)
  // SSE2 has no 64-bit arithmetic shift: shift the high 32-bit halves, copied to both halves.
  return (v2i)_mm_srai_epi32(_mm_shuffle_epi32((__m128i)x, 0xF5), 31);
#else
  return x >> 63;
#endif
}
#endif

/// sin and cos of every lane; correct only for lanes with |x| <= B (others: garbage, no traps).
template <class D, class I>
__attribute__((always_inline)) inline void kernel(const Consts<D, I>& K, D x, D& so, D& co) {
  const D ax = from_bits(bits(x) & ~K.sign);
  // 1. k = round(|x| 2/pi); y holds k in its low mantissa bits.
  const D y = ax * K.two_over_pi + K.shift;
  const D k = y - K.shift;
  // 2. r = rh + rl = |x| - k pi/2.
  const D s = (ax - k * K.p1) - k * K.p2;
  const D kp3 = k * K.p3;
  const D rh = s - kp3;
  const D rl = ((s - rh) - kp3) - k * K.p4;
  // 3. r = a + b, a with 26 bits.
  const D t = rh * K.split;
  const D a = t - (t - rh);
  const D b = (rh - a) + rl;
  // 4. Kernels at a, then the first and second order terms in b.
  const D z = a * a;
  const D hz = K.half * z;
  const D w = K.one - hz;
  const D corr = (K.one - w) - hz;
  const D p = K.s1 + z * (K.s2 + z * (K.s3 + z * (K.s4 + z * (K.s5 + z * K.s6))));
  const D q = K.c1 + z * (K.c2 + z * (K.c3 + z * (K.c4 + z * (K.c5 + z * K.c6))));
  const D sp = (a * z) * p;         // sin a - a
  const D cp = corr + (z * z) * q;  // cos a - w
  const D sa = a + sp;              // sin a, rounded
  const D ca = w + cp;              // cos a, rounded
  const D hb = K.half * b;
  const D sr = sa + (((a - sa) + sp) + b * (ca - hb * a));  // Fast2Sum(a, sp) + b terms
  const D cr = w + (cp - b * (sa + hb * ca));
  // 5. Quadrant: sin x = (S, C, -S, -C)[k & 3], cos x = (C, -S, -C, S)[k & 3].
  const I qk = bits(y);
  const I neg = shift_left(qk, 62) & K.sign;  // bit 1 of k
  const I odd = shift_left(qk, 63);           // bit 0 of k
  const I swap = spread_sign(odd);
  const I sv = bits(sr) ^ (neg ^ odd);  // sin out for even k, cos out for odd k
  const I cv = bits(cr) ^ neg;          // cos out for even k, sin out for odd k
  const I d = (sv ^ cv) & swap;
  so = from_bits(sv ^ d ^ (bits(x) & K.sign));
  co = from_bits(cv ^ d);
}

const Consts<double, std::int64_t> kScalar =
    make_consts<double, std::int64_t>([](double a) { return a; }, [](std::int64_t a) { return a; });

#ifndef SE3_SIM_PAIRS_ARE_SCALAR
const Consts<v2d, v2i> kPairs = make_consts<v2d, v2i>([](double a) { return pair(a, a); },
                                                      [](std::int64_t a) {
                                                        return v2i{a, a};
                                                      });

/// The constants through a pointer the compiler cannot see through. Otherwise GCC 12 (SSE2)
/// builds every uniform vector constant from a scalar (movsd + unpcklpd, two instructions)
/// instead of using it as a memory operand of the arithmetic.
inline const Consts<v2d, v2i>& consts() {
  const Consts<v2d, v2i>* k = &kPairs;
  asm("" : "+r"(k));
  return *k;
}

/// Bit i set where lane i has |x| <= B (not for NaN).
inline int in_range(const Consts<v2d, v2i>& K, v2d x) {
  const v2i le = (v2i)(from_bits(bits(x) & ~K.sign) <= K.bound);  // -1 where true
#if defined(__SSE2__)
  return _mm_movemask_pd((__m128d)le);
#else
  return static_cast<int>(le[0] & 1) | static_cast<int>(le[1] & 2);
#endif
}

/// The general loop from element i on: lanes outside the fast path get std::sin/std::cos, or
/// x - x (NaN, as they return) for NaN/Inf, which leaves errno alone.
__attribute__((noinline, cold)) void sincos_from(const double* x, int n, double* s, double* c,
                                                 int i) {
  for (; i < n; ++i) sincos_reference(x[i], s + i, c + i);
}
#endif

}  // namespace

void sincos_reference(double x, double* s, double* c) {
  if (std::fabs(x) <= kSinCosBound) {
    double so, co;
    kernel(kScalar, x, so, co);
    *s = so;
    *c = co;
  } else if (std::isfinite(x)) {
    *s = std::sin(x);
    *c = std::cos(x);
  } else {
    *s = *c = x - x;
  }
}

#ifdef SE3_SIM_PAIRS_ARE_SCALAR
void sincos_n(const double* x, int n, double* s, double* c) {
  for (int i = 0; i < n; ++i) sincos_reference(x[i], s + i, c + i);
}
#else
void sincos_n(const double* x, int n, double* s, double* c) {
  // A loop without calls, so without registers to save. At the first pair with a lane outside
  // the fast path, before anything of that pair is stored (s or c may be x), the general loop
  // takes over.
  const Consts<v2d, v2i>& K = consts();
  int i = 0;
  for (; i + 2 <= n; i += 2) {
    const v2d x0 = load2(x + i);
    v2d s0, c0;
    kernel(K, x0, s0, c0);
    if (__builtin_expect(in_range(K, x0) != 3, 0)) return sincos_from(x, n, s, c, i);
    store2(s + i, s0);
    store2(c + i, c0);
  }
  if (i < n) {
    const v2d x0 = pair(x[i], 0.0);
    v2d s0, c0;
    kernel(K, x0, s0, c0);
    if (__builtin_expect(!(in_range(K, x0) & 1), 0)) return sincos_from(x, n, s, c, i);
    s[i] = s0[0];
    c[i] = c0[0];
  }
}
#endif

}  // namespace detail
}  // namespace se3
