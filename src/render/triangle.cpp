// Triangles: half-space edge functions on sub-pixel integer vertices, Gouraud shade and
// inverse depth as screen-space planes, an SSE2 path four pixels wide and a scalar path that
// computes the same bits.
#include <algorithm>
#include <cmath>
#include <cstring>

#include "se3_sim/render/raster.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#define SE3_RASTER_SSE2 1
#endif
// AVX2 (eight pixels wide) is chosen at run time: its functions carry their own target, the
// build itself stays at the x86-64 baseline.
#if SE3_RASTER_SSE2 && defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define SE3_RASTER_AVX2 1
#define SE3_AVX2 __attribute__((target("avx2")))
#endif

namespace se3 {
namespace render {
namespace {

constexpr int kHalf = kSubpixel / 2;

// floor(a / b) and ceil(a / b) for b > 0.
inline int64_t floor_div(int64_t a, int64_t b) {
  return a >= 0 ? a / b : -((-a + b - 1) / b);
}
inline int64_t ceil_div(int64_t a, int64_t b) {
  return a >= 0 ? (a + b - 1) / b : -((-a) / b);
}

// A triangle ready for the pixel loops: its pixel box, each edge's value at the box's first
// pixel centre with the top-left rule folded in (covered <=> all three >= 0), the edges'
// steps per pixel (x: ex, y: ey), and the planes of inverse depth z and shade k. Integers fit
// in 32 bits: coordinates relative to the box stay below 2^14 + 16 in magnitude (larger
// triangles are split first), so every edge value stays below 2^30.
struct Setup {
  int bx0, by0, bx1, by1;
  int32_t e0[3], ex[3], ey[3];
  float z0, zx, zy, k0, kx, ky;
};

inline float min255(float x) {
  return x < 255.0f ? x : 255.0f;  // as _mm_min_ps(x, 255)
}

inline uint32_t shade(const float rgb[3], float k) {
  const uint32_t r = uint32_t(int32_t(min255(rgb[0] * k)));
  const uint32_t g = uint32_t(int32_t(min255(rgb[1] * k)));
  const uint32_t b = uint32_t(int32_t(min255(rgb[2] * k)));
  return (r << 16) | (g << 8) | b;
}

// The depth test. A fragment wins if it is nearer (larger inverse depth z), and at the same
// depth if its colour is the larger number: the result does not depend on the order the
// triangles come in, so every path may draw them in its own order and still leave the same
// bits. Without colours, the depth alone.
inline void fragment(float z, float k, const float rgb[3], float* d, uint32_t* c, bool paint) {
  if (z > *d) {
    *d = z;
    if (paint) *c = shade(rgb, k);
  } else if (paint && z == *d) {
    const uint32_t s = shade(rgb, k);
    if (s > *c) *c = s;
  }
}

// Columns [i0, i1] of a row (relative to bx0) where every edge value er[k] + i ex[k] >= 0.
// Narrow boxes are scanned whole (three divisions cost more than a few pixel tests).
constexpr int kSpanMin = 12;
inline bool row_span(const int32_t er[3], const int32_t ex[3], int n, int& i0, int& i1) {
  i0 = 0;
  i1 = n - 1;
  if (n < kSpanMin) return true;
  for (int k = 0; k < 3; ++k) {
    if (ex[k] > 0) {
      i0 = std::max(i0, int(ceil_div(-int64_t(er[k]), ex[k])));
    } else if (ex[k] < 0) {
      i1 = std::min(i1, int(floor_div(int64_t(er[k]), -int64_t(ex[k]))));
    } else if (er[k] < 0) {
      return false;
    }
  }
  return i0 <= i1;
}

struct Target {
  int W, H;
  uint32_t* color;
  float* depth;
  RowSet rows;
  bool paint = true;  ///< colours too (else depth only)
};

// The pixel loops. Row by row: edge values step by ey, the planes' row values by zy and ky
// (float additions, the same in both paths); a pixel's z and k are row value + step * column.
void raster_scalar(const Setup& s, const float rgb[3], const Target& T) {
  const int n = s.bx1 - s.bx0 + 1;
  int32_t er[3] = {s.e0[0], s.e0[1], s.e0[2]};
  float zr = s.z0, kr = s.k0;
  for (int y = s.by0; y <= s.by1;
       ++y, er[0] += s.ey[0], er[1] += s.ey[1], er[2] += s.ey[2], zr += s.zy, kr += s.ky) {
    if (!T.rows.has(y)) continue;
    int i0, i1;
    if (!row_span(er, s.ex, n, i0, i1)) continue;
    uint32_t* crow = T.color + std::size_t(y) * T.W + s.bx0;
    float* drow = T.depth + std::size_t(y) * T.W + s.bx0;
    for (int i = i0; i <= i1; ++i) {
      if ((er[0] + i * s.ex[0]) < 0 || (er[1] + i * s.ex[1]) < 0 || (er[2] + i * s.ex[2]) < 0) {
        continue;
      }
      const float fi = float(i);
      fragment(zr + s.zx * fi, kr + s.kx * fi, rgb, drow + i, crow + i, T.paint);
    }
  }
}

#if SE3_RASTER_SSE2
// shade() four lanes wide.
inline __m128i shade_sse2(const __m128 c[3], __m128 k) {
  const __m128 c255 = _mm_set1_ps(255.0f);
  const __m128i r = _mm_cvttps_epi32(_mm_min_ps(_mm_mul_ps(c[0], k), c255));
  const __m128i g = _mm_cvttps_epi32(_mm_min_ps(_mm_mul_ps(c[1], k), c255));
  const __m128i b = _mm_cvttps_epi32(_mm_min_ps(_mm_mul_ps(c[2], k), c255));
  return _mm_or_si128(_mm_or_si128(_mm_slli_epi32(r, 16), _mm_slli_epi32(g, 8)), b);
}
// Lanes where a > b as unsigned numbers (the tie rule of fragment()).
inline __m128 greater_sse2(__m128i a, __m128i b) {
  const __m128i sign = _mm_set1_epi32(int32_t(0x80000000u));
  return _mm_castsi128_ps(_mm_cmpgt_epi32(_mm_xor_si128(a, sign), _mm_xor_si128(b, sign)));
}

// Four pixels at columns x .. x + 3 (relative column ii) of a row: edge lanes e, planes' row
// values zr, kr.
inline void group_sse2(__m128i e0, __m128i e1, __m128i e2, int ii, __m128 zr, __m128 kr, __m128 zx,
                       __m128 kx, const __m128 c[3], uint32_t* crow, float* drow, bool paint) {
  const __m128i outside = _mm_srai_epi32(_mm_or_si128(_mm_or_si128(e0, e1), e2), 31);
  const __m128 fi = _mm_cvtepi32_ps(_mm_add_epi32(_mm_set1_epi32(ii), _mm_setr_epi32(0, 1, 2, 3)));
  const __m128 z = _mm_add_ps(zr, _mm_mul_ps(zx, fi));
  const __m128 d = _mm_loadu_ps(drow);
  const __m128 in = _mm_castsi128_ps(outside);  // set: outside
  __m128 m = _mm_andnot_ps(in, _mm_cmpgt_ps(z, d));
  if (!paint) {
    if (_mm_movemask_ps(m)) _mm_storeu_ps(drow, _mm_or_ps(_mm_and_ps(m, z), _mm_andnot_ps(m, d)));
    return;
  }
  const __m128 tie = _mm_andnot_ps(in, _mm_cmpeq_ps(z, d));
  if (!_mm_movemask_ps(_mm_or_ps(m, tie))) return;
  const __m128 k = _mm_add_ps(kr, _mm_mul_ps(kx, fi));
  const __m128i px = shade_sse2(c, k);
  const __m128i old = _mm_loadu_si128(reinterpret_cast<const __m128i*>(crow));
  if (_mm_movemask_ps(tie)) m = _mm_or_ps(m, _mm_and_ps(tie, greater_sse2(px, old)));
  _mm_storeu_ps(drow, _mm_or_ps(_mm_and_ps(m, z), _mm_andnot_ps(m, d)));
  const __m128i mi = _mm_castps_si128(m);
  _mm_storeu_si128(reinterpret_cast<__m128i*>(crow),
                   _mm_or_si128(_mm_and_si128(mi, px), _mm_andnot_si128(mi, old)));
}

void raster_sse2(const Setup& s, const float rgb[3], const Target& T) {
  const int n = s.bx1 - s.bx0 + 1;
  const int W = T.W;
  const __m128 zx = _mm_set1_ps(s.zx), kx = _mm_set1_ps(s.kx);
  const __m128 c[3] = {_mm_set1_ps(rgb[0]), _mm_set1_ps(rgb[1]), _mm_set1_ps(rgb[2])};
  // Each edge at the row's first four columns, stepped down a row at a time.
  __m128i ev[3], eyv[3], ex4[3];
  for (int k = 0; k < 3; ++k) {
    ev[k] =
        _mm_setr_epi32(s.e0[k], s.e0[k] + s.ex[k], s.e0[k] + 2 * s.ex[k], s.e0[k] + 3 * s.ex[k]);
    eyv[k] = _mm_set1_epi32(s.ey[k]);
    ex4[k] = _mm_set1_epi32(4 * s.ex[k]);
  }
  // Groups of four from the box's left column never pass the image's right border unless
  // the box ends within three columns of it; then a group shifts left (its extra lanes are
  // outside the box and fail the edge test).
  const bool border = s.bx0 + ((n + 3) & ~3) > W;
  const bool all_rows = T.rows.parts == 1;
  int32_t er[3] = {s.e0[0], s.e0[1], s.e0[2]};
  float zrs = s.z0, krs = s.k0;
  for (int y = s.by0; y <= s.by1; ++y, er[0] += s.ey[0], er[1] += s.ey[1], er[2] += s.ey[2],
           zrs += s.zy, krs += s.ky, ev[0] = _mm_add_epi32(ev[0], eyv[0]),
           ev[1] = _mm_add_epi32(ev[1], eyv[1]), ev[2] = _mm_add_epi32(ev[2], eyv[2])) {
    if (!all_rows && !T.rows.has(y)) continue;
    int i0 = 0, i1 = n - 1;
    if (n >= kSpanMin && !row_span(er, s.ex, n, i0, i1)) continue;
    const __m128 zr = _mm_set1_ps(zrs), kr = _mm_set1_ps(krs);
    uint32_t* crow = T.color + std::size_t(y) * W + s.bx0;
    float* drow = T.depth + std::size_t(y) * W + s.bx0;
    if (!border) {
      int i = i0 & ~3;  // groups aligned to the box's left column
      __m128i e0 = ev[0], e1 = ev[1], e2 = ev[2];
      if (i) {
        e0 = _mm_add_epi32(e0, _mm_set1_epi32(i * s.ex[0]));
        e1 = _mm_add_epi32(e1, _mm_set1_epi32(i * s.ex[1]));
        e2 = _mm_add_epi32(e2, _mm_set1_epi32(i * s.ex[2]));
      }
      for (; i <= i1; i += 4, e0 = _mm_add_epi32(e0, ex4[0]), e1 = _mm_add_epi32(e1, ex4[1]),
                              e2 = _mm_add_epi32(e2, ex4[2])) {
        group_sse2(e0, e1, e2, i, zr, kr, zx, kx, c, crow + i, drow + i, T.paint);
      }
    } else {
      for (int i = i0 & ~3; i <= i1; i += 4) {
        const int ii = std::min(i, W - 4 - s.bx0);
        const __m128i e0 = _mm_add_epi32(ev[0], _mm_set1_epi32(ii * s.ex[0]));
        const __m128i e1 = _mm_add_epi32(ev[1], _mm_set1_epi32(ii * s.ex[1]));
        const __m128i e2 = _mm_add_epi32(ev[2], _mm_set1_epi32(ii * s.ex[2]));
        group_sse2(e0, e1, e2, ii, zr, kr, zx, kx, c, crow + ii, drow + ii, T.paint);
      }
    }
  }
}
#endif

#if SE3_RASTER_AVX2
SE3_AVX2 inline __m256i shade_avx2(const __m256 c[3], __m256 k) {
  const __m256 c255 = _mm256_set1_ps(255.0f);
  const __m256i r = _mm256_cvttps_epi32(_mm256_min_ps(_mm256_mul_ps(c[0], k), c255));
  const __m256i g = _mm256_cvttps_epi32(_mm256_min_ps(_mm256_mul_ps(c[1], k), c255));
  const __m256i b = _mm256_cvttps_epi32(_mm256_min_ps(_mm256_mul_ps(c[2], k), c255));
  return _mm256_or_si256(_mm256_or_si256(_mm256_slli_epi32(r, 16), _mm256_slli_epi32(g, 8)), b);
}
SE3_AVX2 inline __m256 greater_avx2(__m256i a, __m256i b) {
  const __m256i sign = _mm256_set1_epi32(int32_t(0x80000000u));
  return _mm256_castsi256_ps(
      _mm256_cmpgt_epi32(_mm256_xor_si256(a, sign), _mm256_xor_si256(b, sign)));
}

// raster_sse2 eight pixels wide (the same operations lane by lane, so the same bits); needs
// W >= 8.
SE3_AVX2 inline void group_avx2(__m256i e0, __m256i e1, __m256i e2, int ii, __m256 zr, __m256 kr,
                                __m256 zx, __m256 kx, const __m256 c[3], uint32_t* crow,
                                float* drow, bool paint) {
  const __m256i outside = _mm256_srai_epi32(_mm256_or_si256(_mm256_or_si256(e0, e1), e2), 31);
  const __m256 fi = _mm256_cvtepi32_ps(
      _mm256_add_epi32(_mm256_set1_epi32(ii), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7)));
  const __m256 z = _mm256_add_ps(zr, _mm256_mul_ps(zx, fi));
  const __m256 d = _mm256_loadu_ps(drow);
  const __m256 in = _mm256_castsi256_ps(outside);  // set: outside
  __m256 m = _mm256_andnot_ps(in, _mm256_cmp_ps(z, d, _CMP_GT_OQ));
  if (!paint) {
    if (_mm256_movemask_ps(m)) _mm256_storeu_ps(drow, _mm256_blendv_ps(d, z, m));
    return;
  }
  const __m256 tie = _mm256_andnot_ps(in, _mm256_cmp_ps(z, d, _CMP_EQ_OQ));
  if (!_mm256_movemask_ps(_mm256_or_ps(m, tie))) return;
  const __m256 k = _mm256_add_ps(kr, _mm256_mul_ps(kx, fi));
  const __m256i px = shade_avx2(c, k);
  const __m256i old = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(crow));
  if (_mm256_movemask_ps(tie)) m = _mm256_or_ps(m, _mm256_and_ps(tie, greater_avx2(px, old)));
  _mm256_storeu_ps(drow, _mm256_blendv_ps(d, z, m));
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(crow),
                      _mm256_blendv_epi8(old, px, _mm256_castps_si256(m)));
}

SE3_AVX2 void raster_avx2(const Setup& s, const float rgb[3], const Target& T) {
  const int n = s.bx1 - s.bx0 + 1;
  const int W = T.W;
  const __m256 zx = _mm256_set1_ps(s.zx), kx = _mm256_set1_ps(s.kx);
  const __m256 c[3] = {_mm256_set1_ps(rgb[0]), _mm256_set1_ps(rgb[1]), _mm256_set1_ps(rgb[2])};
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  __m256i ev[3], eyv[3], ex8[3];
  for (int k = 0; k < 3; ++k) {
    ev[k] = _mm256_add_epi32(_mm256_set1_epi32(s.e0[k]),
                             _mm256_mullo_epi32(lane, _mm256_set1_epi32(s.ex[k])));
    eyv[k] = _mm256_set1_epi32(s.ey[k]);
    ex8[k] = _mm256_set1_epi32(8 * s.ex[k]);
  }
  const bool border = s.bx0 + ((n + 7) & ~7) > W;
  const bool all_rows = T.rows.parts == 1;
  if (n <= 16 && !border && all_rows) {
    // Boxes at most sixteen wide: one or two groups a row from the box's left column, without
    // the row spans (the loop below with nothing to choose; groups the span would skip draw
    // nothing).
    uint32_t* crow = T.color + std::size_t(s.by0) * W + s.bx0;
    float* drow = T.depth + std::size_t(s.by0) * W + s.bx0;
    float zrs = s.z0, krs = s.k0;
    if (n <= 8) {
      for (int y = s.by0; y <= s.by1; ++y, crow += W, drow += W, zrs += s.zy, krs += s.ky,
               ev[0] = _mm256_add_epi32(ev[0], eyv[0]), ev[1] = _mm256_add_epi32(ev[1], eyv[1]),
               ev[2] = _mm256_add_epi32(ev[2], eyv[2])) {
        group_avx2(ev[0], ev[1], ev[2], 0, _mm256_set1_ps(zrs), _mm256_set1_ps(krs), zx, kx, c,
                   crow, drow, T.paint);
      }
      return;
    }
    for (int y = s.by0; y <= s.by1; ++y, crow += W, drow += W, zrs += s.zy, krs += s.ky,
             ev[0] = _mm256_add_epi32(ev[0], eyv[0]), ev[1] = _mm256_add_epi32(ev[1], eyv[1]),
             ev[2] = _mm256_add_epi32(ev[2], eyv[2])) {
      const __m256 zr = _mm256_set1_ps(zrs), kr = _mm256_set1_ps(krs);
      group_avx2(ev[0], ev[1], ev[2], 0, zr, kr, zx, kx, c, crow, drow, T.paint);
      group_avx2(_mm256_add_epi32(ev[0], ex8[0]), _mm256_add_epi32(ev[1], ex8[1]),
                 _mm256_add_epi32(ev[2], ex8[2]), 8, zr, kr, zx, kx, c, crow + 8, drow + 8,
                 T.paint);
    }
    return;
  }
  int32_t er[3] = {s.e0[0], s.e0[1], s.e0[2]};
  float zrs = s.z0, krs = s.k0;
  for (int y = s.by0; y <= s.by1; ++y, er[0] += s.ey[0], er[1] += s.ey[1], er[2] += s.ey[2],
           zrs += s.zy, krs += s.ky, ev[0] = _mm256_add_epi32(ev[0], eyv[0]),
           ev[1] = _mm256_add_epi32(ev[1], eyv[1]), ev[2] = _mm256_add_epi32(ev[2], eyv[2])) {
    if (!all_rows && !T.rows.has(y)) continue;
    int i0 = 0, i1 = n - 1;
    if (n >= kSpanMin && !row_span(er, s.ex, n, i0, i1)) continue;
    const __m256 zr = _mm256_set1_ps(zrs), kr = _mm256_set1_ps(krs);
    uint32_t* crow = T.color + std::size_t(y) * W + s.bx0;
    float* drow = T.depth + std::size_t(y) * W + s.bx0;
    if (!border) {
      int i = i0 & ~7;
      __m256i e0 = ev[0], e1 = ev[1], e2 = ev[2];
      if (i) {
        e0 = _mm256_add_epi32(e0, _mm256_set1_epi32(i * s.ex[0]));
        e1 = _mm256_add_epi32(e1, _mm256_set1_epi32(i * s.ex[1]));
        e2 = _mm256_add_epi32(e2, _mm256_set1_epi32(i * s.ex[2]));
      }
      for (; i <= i1; i += 8, e0 = _mm256_add_epi32(e0, ex8[0]), e1 = _mm256_add_epi32(e1, ex8[1]),
                              e2 = _mm256_add_epi32(e2, ex8[2])) {
        group_avx2(e0, e1, e2, i, zr, kr, zx, kx, c, crow + i, drow + i, T.paint);
      }
    } else {
      for (int i = i0 & ~7; i <= i1; i += 8) {
        const int ii = std::min(i, W - 8 - s.bx0);
        const __m256i e0 = _mm256_add_epi32(ev[0], _mm256_set1_epi32(ii * s.ex[0]));
        const __m256i e1 = _mm256_add_epi32(ev[1], _mm256_set1_epi32(ii * s.ex[1]));
        const __m256i e2 = _mm256_add_epi32(ev[2], _mm256_set1_epi32(ii * s.ex[2]));
        group_avx2(e0, e1, e2, ii, zr, kr, zx, kx, c, crow + ii, drow + ii, T.paint);
      }
    }
  }
}
#endif

// A triangle whose box is at most 4 x 4 pixels (most triangles of a detailed mesh): which
// centres are covered is found first, from the edge values alone; only then the planes, and
// a pixel's z and k come straight from its three edge values (no per-row stepping).
struct Small {
  int bx0, by0, w, h;
  int32_t e[3];          // edge values at the box's first centre
  int32_t t[3];          // the same with the top-left rule folded in (covered <=> all >= 0)
  int32_t ex[3], ey[3];  // steps per pixel
  float z[3], k[3];      // vertices a, b, c (edge i weighs the vertex opposite it)
  int32_t area2;         // twice the area, > 0
};

// The covered pixels (bit 4 j + i: column i, row j of the box) drawn one at a time.
void small_covered(const Small& q, unsigned covered, const float rgb[3], const Target& T) {
  const float inv = 1.0f / float(q.area2);
  const float wa = q.z[0] * inv, wb = q.z[1] * inv, wc = q.z[2] * inv;
  const float ua = q.k[0] * inv, ub = q.k[1] * inv, uc = q.k[2] * inv;
  for (int j = 0; j < q.h; ++j) {
    const int y = q.by0 + j;
    if (!(covered >> (4 * j) & 15u) || !T.rows.has(y)) continue;
    for (int i = 0; i < q.w; ++i) {
      if (!(covered >> (4 * j + i) & 1u)) continue;
      const float ff0 = float(q.e[0] + i * q.ex[0] + j * q.ey[0]);
      const float ff1 = float(q.e[1] + i * q.ex[1] + j * q.ey[1]);
      const float ff2 = float(q.e[2] + i * q.ex[2] + j * q.ey[2]);
      const std::size_t at = std::size_t(y) * T.W + q.bx0 + i;
      fragment(ff0 * wc + ff1 * wa + ff2 * wb, ff0 * uc + ff1 * ua + ff2 * ub, rgb, T.depth + at,
               T.color + at, T.paint);
    }
  }
}

void small_scalar(const Small& q, const float rgb[3], const Target& T) {
  unsigned covered = 0;
  for (int j = 0; j < q.h; ++j) {
    for (int i = 0; i < q.w; ++i) {
      if (((q.t[0] + i * q.ex[0] + j * q.ey[0]) | (q.t[1] + i * q.ex[1] + j * q.ey[1]) |
           (q.t[2] + i * q.ex[2] + j * q.ey[2])) >= 0) {
        covered |= 1u << (4 * j + i);
      }
    }
  }
  if (covered) small_covered(q, covered, rgb, T);
}

#if SE3_RASTER_SSE2
// (0, s, 2 s, 3 s) + v.
inline __m128i ramp_sse2(int32_t v, int32_t s) {
  const __m128i sv = _mm_set1_epi32(s);
  const __m128i r = _mm_add_epi32(_mm_add_epi32(_mm_slli_si128(sv, 4), _mm_slli_si128(sv, 8)),
                                  _mm_slli_si128(sv, 12));
  return _mm_add_epi32(r, _mm_set1_epi32(v));
}

// The same pixels and bits as small_scalar, a row of four at a time (needs bx0 + 4 <= W).
void small_sse2(const Small& q, const float rgb[3], const Target& T) {
  const __m128i s0 = ramp_sse2(q.t[0], q.ex[0]), s1 = ramp_sse2(q.t[1], q.ex[1]),
                s2 = ramp_sse2(q.t[2], q.ex[2]);
  __m128i a0 = s0, a1 = s1, a2 = s2;
  const __m128i y0 = _mm_set1_epi32(q.ey[0]), y1 = _mm_set1_epi32(q.ey[1]),
                y2 = _mm_set1_epi32(q.ey[2]);
  const unsigned wbits = (1u << q.w) - 1;
  unsigned covered = 0;
  for (int j = 0; j < q.h; ++j) {
    const unsigned out =
        unsigned(_mm_movemask_ps(_mm_castsi128_ps(_mm_or_si128(_mm_or_si128(a0, a1), a2))));
    covered |= (~out & wbits) << (4 * j);
    a0 = _mm_add_epi32(a0, y0);
    a1 = _mm_add_epi32(a1, y1);
    a2 = _mm_add_epi32(a2, y2);
  }
  if (!covered) return;
  const float inv = 1.0f / float(q.area2);
  const __m128 wa = _mm_set1_ps(q.z[0] * inv), wb = _mm_set1_ps(q.z[1] * inv),
               wc = _mm_set1_ps(q.z[2] * inv);
  const __m128 ua = _mm_set1_ps(q.k[0] * inv), ub = _mm_set1_ps(q.k[1] * inv),
               uc = _mm_set1_ps(q.k[2] * inv);
  __m128i f0 = _mm_add_epi32(s0, _mm_set1_epi32(q.e[0] - q.t[0])),
          f1 = _mm_add_epi32(s1, _mm_set1_epi32(q.e[1] - q.t[1])),
          f2 = _mm_add_epi32(s2, _mm_set1_epi32(q.e[2] - q.t[2]));
  const __m128i bit = _mm_setr_epi32(1, 2, 4, 8);
  const __m128 c[3] = {_mm_set1_ps(rgb[0]), _mm_set1_ps(rgb[1]), _mm_set1_ps(rgb[2])};
  for (int j = 0; j < q.h;
       ++j, f0 = _mm_add_epi32(f0, y0), f1 = _mm_add_epi32(f1, y1), f2 = _mm_add_epi32(f2, y2)) {
    const int bits = int(covered >> (4 * j) & 15u);
    const int y = q.by0 + j;
    if (!bits || !T.rows.has(y)) continue;
    const __m128 ff0 = _mm_cvtepi32_ps(f0), ff1 = _mm_cvtepi32_ps(f1), ff2 = _mm_cvtepi32_ps(f2);
    const __m128 z =
        _mm_add_ps(_mm_add_ps(_mm_mul_ps(ff0, wc), _mm_mul_ps(ff1, wa)), _mm_mul_ps(ff2, wb));
    const std::size_t at = std::size_t(y) * T.W + q.bx0;
    float* drow = T.depth + at;
    uint32_t* crow = T.color + at;
    const __m128 d = _mm_loadu_ps(drow);
    const __m128 in =
        _mm_castsi128_ps(_mm_cmpeq_epi32(_mm_and_si128(_mm_set1_epi32(bits), bit), bit));
    __m128 m = _mm_and_ps(in, _mm_cmpgt_ps(z, d));
    if (!T.paint) {
      if (_mm_movemask_ps(m)) _mm_storeu_ps(drow, _mm_or_ps(_mm_and_ps(m, z), _mm_andnot_ps(m, d)));
      continue;
    }
    const __m128 tie = _mm_and_ps(in, _mm_cmpeq_ps(z, d));
    if (!_mm_movemask_ps(_mm_or_ps(m, tie))) continue;
    const __m128 k =
        _mm_add_ps(_mm_add_ps(_mm_mul_ps(ff0, uc), _mm_mul_ps(ff1, ua)), _mm_mul_ps(ff2, ub));
    const __m128i px = shade_sse2(c, k);
    const __m128i old = _mm_loadu_si128(reinterpret_cast<const __m128i*>(crow));
    if (_mm_movemask_ps(tie)) m = _mm_or_ps(m, _mm_and_ps(tie, greater_sse2(px, old)));
    _mm_storeu_ps(drow, _mm_or_ps(_mm_and_ps(m, z), _mm_andnot_ps(m, d)));
    const __m128i mi = _mm_castps_si128(m);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(crow),
                     _mm_or_si128(_mm_and_si128(mi, px), _mm_andnot_si128(mi, old)));
  }
}
#endif

#if SE3_RASTER_AVX2
// small_sse2 two rows at a time (rows j and j + 1 in the low and high halves).
SE3_AVX2 inline __m256i pair_avx2(int32_t v, int32_t ex, int32_t ey) {
  const __m256i i = _mm256_setr_epi32(0, 1, 2, 3, 0, 1, 2, 3);
  const __m256i j = _mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1);
  return _mm256_add_epi32(_mm256_set1_epi32(v),
                          _mm256_add_epi32(_mm256_mullo_epi32(i, _mm256_set1_epi32(ex)),
                                           _mm256_mullo_epi32(j, _mm256_set1_epi32(ey))));
}

SE3_AVX2 void small_avx2(const Small& q, const float rgb[3],
                         const Target& T) {  // Edge values with the top-left rule (coverage) and
                                             // without (the planes): they differ by
  // a constant.
  const __m256i s0 = pair_avx2(q.t[0], q.ex[0], q.ey[0]), s1 = pair_avx2(q.t[1], q.ex[1], q.ey[1]),
                s2 = pair_avx2(q.t[2], q.ex[2], q.ey[2]);
  __m256i a0 = s0, a1 = s1, a2 = s2;
  const __m256i y0 = _mm256_set1_epi32(2 * q.ey[0]), y1 = _mm256_set1_epi32(2 * q.ey[1]),
                y2 = _mm256_set1_epi32(2 * q.ey[2]);
  const unsigned wbits = (1u << q.w) - 1;
  // Bits of the box: w columns, h rows.
  const unsigned box = (wbits * 0x1111u) & ((1u << (4 * q.h)) - 1);
  const unsigned out0 = unsigned(
      _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_or_si256(_mm256_or_si256(a0, a1), a2))));
  unsigned covered = ~out0 & 255u;
  if (q.h > 2) {
    a0 = _mm256_add_epi32(a0, y0);
    a1 = _mm256_add_epi32(a1, y1);
    a2 = _mm256_add_epi32(a2, y2);
    const unsigned out1 = unsigned(
        _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_or_si256(_mm256_or_si256(a0, a1), a2))));
    covered |= (~out1 & 255u) << 8;
  }
  covered &= box;
  if (!covered) return;
  const float inv = 1.0f / float(q.area2);
  const __m256 wa = _mm256_set1_ps(q.z[0] * inv), wb = _mm256_set1_ps(q.z[1] * inv),
               wc = _mm256_set1_ps(q.z[2] * inv);
  const __m256 ua = _mm256_set1_ps(q.k[0] * inv), ub = _mm256_set1_ps(q.k[1] * inv),
               uc = _mm256_set1_ps(q.k[2] * inv);
  __m256i f0 = _mm256_add_epi32(s0, _mm256_set1_epi32(q.e[0] - q.t[0])),
          f1 = _mm256_add_epi32(s1, _mm256_set1_epi32(q.e[1] - q.t[1])),
          f2 = _mm256_add_epi32(s2, _mm256_set1_epi32(q.e[2] - q.t[2]));
  const __m256i bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
  const __m256 c[3] = {_mm256_set1_ps(rgb[0]), _mm256_set1_ps(rgb[1]), _mm256_set1_ps(rgb[2])};
  for (int j = 0; j < q.h; j += 2, f0 = _mm256_add_epi32(f0, y0), f1 = _mm256_add_epi32(f1, y1),
           f2 = _mm256_add_epi32(f2, y2)) {
    unsigned bits = covered >> (4 * j) & 255u;
    const int y = q.by0 + j;
    if (!T.rows.has(y)) bits &= 0xf0u;
    if (!T.rows.has(y + 1)) bits &= 0x0fu;  // also no row y + 1 in the box (bits are 0)
    if (!bits) continue;
    const __m256 ff0 = _mm256_cvtepi32_ps(f0), ff1 = _mm256_cvtepi32_ps(f1),
                 ff2 = _mm256_cvtepi32_ps(f2);
    const __m256 z = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ff0, wc), _mm256_mul_ps(ff1, wa)),
                                   _mm256_mul_ps(ff2, wb));
    const std::size_t at = std::size_t(y) * T.W + q.bx0;
    float* d0 = T.depth + at;
    uint32_t* c0 = T.color + at;
    // The second row only where it has pixels to draw (it may lie past the image).
    const bool two = bits > 15u;
    float* d1 = two ? d0 + T.W : d0;
    uint32_t* c1 = two ? c0 + T.W : c0;
    const __m256 d =
        _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(d0)), _mm_loadu_ps(d1), 1);
    const __m256 in = _mm256_castsi256_ps(
        _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(int(bits)), bit), bit));
    __m256 m = _mm256_and_ps(in, _mm256_cmp_ps(z, d, _CMP_GT_OQ));
    if (!T.paint) {
      const unsigned mm = unsigned(_mm256_movemask_ps(m));
      const __m256 dn = _mm256_blendv_ps(d, z, m);
      if (mm & 15u) _mm_storeu_ps(d0, _mm256_castps256_ps128(dn));
      if (mm > 15u) _mm_storeu_ps(d1, _mm256_extractf128_ps(dn, 1));
      continue;
    }
    const __m256 tie = _mm256_and_ps(in, _mm256_cmp_ps(z, d, _CMP_EQ_OQ));
    if (!_mm256_movemask_ps(_mm256_or_ps(m, tie))) continue;
    const __m256 k = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ff0, uc), _mm256_mul_ps(ff1, ua)),
                                   _mm256_mul_ps(ff2, ub));
    const __m256i px = shade_avx2(c, k);
    const __m256i old = _mm256_inserti128_si256(
        _mm256_castsi128_si256(_mm_loadu_si128(reinterpret_cast<const __m128i*>(c0))),
        _mm_loadu_si128(reinterpret_cast<const __m128i*>(c1)), 1);
    if (_mm256_movemask_ps(tie)) m = _mm256_or_ps(m, _mm256_and_ps(tie, greater_avx2(px, old)));
    const unsigned mm = unsigned(_mm256_movemask_ps(m));
    if (!mm) continue;
    const __m256 dn = _mm256_blendv_ps(d, z, m);
    const __m256i cn = _mm256_blendv_epi8(old, px, _mm256_castps_si256(m));
    if (mm & 15u) {
      _mm_storeu_ps(d0, _mm256_castps256_ps128(dn));
      _mm_storeu_si128(reinterpret_cast<__m128i*>(c0), _mm256_castsi256_si128(cn));
    }
    if (mm > 15u) {
      _mm_storeu_ps(d1, _mm256_extractf128_ps(dn, 1));
      _mm_storeu_si128(reinterpret_cast<__m128i*>(c1), _mm256_extracti128_si256(cn, 1));
    }
  }
}
#endif

// One triangle (vertices in sub-pixels, extent at most 2^14): boxes of at most 4 x 4 pixels
// go to the small-triangle path, the rest to the pixel loops.
void draw_any(const RasterVertex& a, const RasterVertex& b, const RasterVertex& c,
              const float rgb[3], const Target& T, int path);
constexpr int32_t kMaxExtent = 1 << 14;

// A triangle ready for the pixel paths: its pixel box (not empty, within the image), each
// edge's value at the box's first centre without (e) and with (t) the top-left rule, the
// edges' steps per pixel, twice its area (> 0), and inverse depth z and shade k at the
// vertices in canonical winding (edge 0 runs a -> b, 1 b -> c, 2 c -> a; edge i weighs the
// vertex opposite it).
struct Edges {
  int bx0, by0, bx1, by1;
  int32_t e[3], t[3], ex[3], ey[3];
  int32_t area2;
  float z[3], k[3];
};

// The small-triangle path for boxes of at most 4 x 4 pixels, the pixel loops for the rest.
template <int kPath>
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
inline void
draw_edges(const Edges& g, const float rgb[3], const Target& T) {
  const int w = g.bx1 - g.bx0 + 1, h = g.by1 - g.by0 + 1;
  if (w <= 4 && h <= 4) {
    const Small q{g.bx0,
                  g.by0,
                  w,
                  h,
                  {g.e[0], g.e[1], g.e[2]},
                  {g.t[0], g.t[1], g.t[2]},
                  {g.ex[0], g.ex[1], g.ex[2]},
                  {g.ey[0], g.ey[1], g.ey[2]},
                  {g.z[0], g.z[1], g.z[2]},
                  {g.k[0], g.k[1], g.k[2]},
                  g.area2};
    // One or two pixels: the scalar loop is cheaper than the vector set-up (same bits).
    if (w * h <= 2) {
      small_scalar(q, rgb, T);
      return;
    }
#if SE3_RASTER_AVX2
    if (kPath == 2 && g.bx0 + 4 <= T.W) {
      small_avx2(q, rgb, T);
      return;
    }
#endif
#if SE3_RASTER_SSE2
    if (kPath >= 1 && g.bx0 + 4 <= T.W) {
      small_sse2(q, rgb, T);
      return;
    }
#endif
    small_scalar(q, rgb, T);
    return;
  }
  const float inv = 1.0f / float(g.area2);
  const float wa = g.z[0] * inv, wb = g.z[1] * inv, wc = g.z[2] * inv;
  const float ua = g.k[0] * inv, ub = g.k[1] * inv, uc = g.k[2] * inv;
  Setup s;
  s.bx0 = g.bx0;
  s.bx1 = g.bx1;
  s.by0 = g.by0;
  s.by1 = g.by1;
  for (int i = 0; i < 3; ++i) {
    s.e0[i] = g.t[i];
    s.ex[i] = g.ex[i];
    s.ey[i] = g.ey[i];
  }
  const float fe0 = float(g.e[0]), fe1 = float(g.e[1]), fe2 = float(g.e[2]);
  const float fx0 = float(s.ex[0]), fx1 = float(s.ex[1]), fx2 = float(s.ex[2]);
  const float fy0 = float(s.ey[0]), fy1 = float(s.ey[1]), fy2 = float(s.ey[2]);
  s.z0 = fe0 * wc + fe1 * wa + fe2 * wb;
  s.zx = fx0 * wc + fx1 * wa + fx2 * wb;
  s.zy = fy0 * wc + fy1 * wa + fy2 * wb;
  s.k0 = fe0 * uc + fe1 * ua + fe2 * ub;
  s.kx = fx0 * uc + fx1 * ua + fx2 * ub;
  s.ky = fy0 * uc + fy1 * ua + fy2 * ub;
#if SE3_RASTER_AVX2
  if (kPath == 2) {
    raster_avx2(s, rgb, T);
    return;
  }
#endif
#if SE3_RASTER_SSE2
  if (kPath >= 1) {
    raster_sse2(s, rgb, T);
    return;
  }
#endif
  raster_scalar(s, rgb, T);
}

// draw_triangle once the pixel box [bx0, bx1] x [by0, by1] (not empty, within the image) is
// known: the edge functions, then draw_edges.
template <int kPath>
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
inline void
draw_boxed(int bx0, int by0, int bx1, int by1, int32_t ax_, int32_t ay_, float az, float ak,
           int32_t bx_, int32_t by_, float bz, float bk, int32_t cx_, int32_t cy_, float cz,
           float ck, const float rgb[3], const Target& T) {
  const int32_t ox = kSubpixel * bx0 + kHalf, oy = kSubpixel * by0 + kHalf;
  // Relative to the box's first centre.
  const int32_t ax = ax_ - ox, ay = ay_ - oy;
  int32_t bx = bx_ - ox, by = by_ - oy, cx = cx_ - ox, cy = cy_ - oy;
  int32_t area = (bx - ax) * (cy - ay) - (cx - ax) * (by - ay);
  if (area == 0) return;
  if (area > 0) {  // canonical winding: every edge function is positive inside
    std::swap(bx, cx);
    std::swap(by, cy);
    std::swap(bz, cz);
    std::swap(bk, ck);
    area = -area;
  }
  const int32_t dx0 = bx - ax, dy0 = by - ay, dx1 = cx - bx, dy1 = cy - by;
  const int32_t dx2 = ax - cx, dy2 = ay - cy;
  const int32_t e0 = ay * dx0 - ax * dy0, e1 = by * dx1 - bx * dy1, e2 = cy * dx2 - cx * dy2;
  // Top-left rule: a pixel centre on an edge belongs to the triangle if the edge is a left
  // edge (dy > 0 here) or a top one (dy == 0, dx < 0).
  const int32_t t0 = e0 - !(dy0 > 0 || (dy0 == 0 && dx0 < 0));
  const int32_t t1 = e1 - !(dy1 > 0 || (dy1 == 0 && dx1 < 0));
  const int32_t t2 = e2 - !(dy2 > 0 || (dy2 == 0 && dx2 < 0));
  const Edges g{bx0,
                by0,
                bx1,
                by1,
                {e0, e1, e2},
                {t0, t1, t2},
                {kSubpixel * dy0, kSubpixel * dy1, kSubpixel * dy2},
                {-kSubpixel * dx0, -kSubpixel * dx1, -kSubpixel * dx2},
                -area,
                {az, bz, cz},
                {ak, bk, ck}};
  draw_edges<kPath>(g, rgb, T);
}

// kPath: 0 scalar, 1 SSE2, 2 AVX2 (RasterPath).
template <int kPath>
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
inline void
draw_triangle(int32_t ax_, int32_t ay_, float az, float ak, int32_t bx_, int32_t by_, float bz,
              float bk, int32_t cx_, int32_t cy_, float cz, float ck, const float rgb[3],
              const Target& T) {
  const int32_t minx = std::min(ax_, std::min(bx_, cx_)), maxx = std::max(ax_, std::max(bx_, cx_));
  const int32_t miny = std::min(ay_, std::min(by_, cy_)), maxy = std::max(ay_, std::max(by_, cy_));
  if (maxx - minx > kMaxExtent || maxy - miny > kMaxExtent) {
    draw_any({ax_, ay_, az, ak}, {bx_, by_, bz, bk}, {cx_, cy_, cz, ck}, rgb, T, kPath);
    return;
  }
  // Pixels whose centre (16 i + 8) lies in [min, max]: arithmetic shifts round down.
  const int bx0 = std::max(0, (minx + kHalf - 1) >> 4);
  const int bx1 = std::min(T.W - 1, (maxx - kHalf) >> 4);
  if (bx0 > bx1) return;
  const int by0 = std::max(0, (miny + kHalf - 1) >> 4);
  const int by1 = std::min(T.H - 1, (maxy - kHalf) >> 4);
  if (by0 > by1) return;
  if (T.rows.parts > 1 && (by0 >> T.rows.shift) == (by1 >> T.rows.shift) && !T.rows.has(by0)) {
    return;  // one band, another thread's
  }
  draw_boxed<kPath>(bx0, by0, bx1, by1, ax_, ay_, az, ak, bx_, by_, bz, bk, cx_, cy_, cz, ck, rgb,
                    T);
}

// Draws a triangle of any extent: one larger than 2^14 sub-pixels (1024 pixels: a big image,
// a near face) is drawn as four, which share their new edges exactly.
void draw_any(const RasterVertex& a, const RasterVertex& b, const RasterVertex& c,
              const float rgb[3], const Target& T, int path) {
  const int64_t ext =
      std::max(int64_t(std::max(a.x, std::max(b.x, c.x))) - std::min(a.x, std::min(b.x, c.x)),
               int64_t(std::max(a.y, std::max(b.y, c.y))) - std::min(a.y, std::min(b.y, c.y)));
  if (ext > int64_t(kMaxExtent)) {
    auto mid = [](const RasterVertex& p, const RasterVertex& q) {
      RasterVertex m;
      m.x = int32_t((int64_t(p.x) + q.x) >> 1);
      m.y = int32_t((int64_t(p.y) + q.y) >> 1);
      m.z = 0.5f * (p.z + q.z);
      m.k = 0.5f * (p.k + q.k);
      return m;
    };
    const RasterVertex ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
    draw_any(a, ab, ca, rgb, T, path);
    draw_any(ab, b, bc, rgb, T, path);
    draw_any(ca, bc, c, rgb, T, path);
    draw_any(ab, bc, ca, rgb, T, path);
    return;
  }
  if (path == 2) {
    draw_triangle<2>(a.x, a.y, a.z, a.k, b.x, b.y, b.z, b.k, c.x, c.y, c.z, c.k, rgb, T);
  } else if (path == 1) {
    draw_triangle<1>(a.x, a.y, a.z, a.k, b.x, b.y, b.z, b.k, c.x, c.y, c.z, c.k, rgb, T);
  } else {
    draw_triangle<0>(a.x, a.y, a.z, a.k, b.x, b.y, b.z, b.k, c.x, c.y, c.z, c.k, rgb, T);
  }
}

// One triangle of the indexed loop: a vertex outside goes to the clip callback (unless all
// three are outside one plane), degenerate and culled back faces are dropped, the rest drawn.
// Returns the triangles counted as drawn.
template <int kPath>
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
inline std::size_t
indexed_one(const VertexArrays& v, uint32_t a, uint32_t b, uint32_t c, const float rgb[3],
            bool cull, bool outward, const Target& T, ClipCallback clip, void* ctx) {
  const uint8_t oa = v.out ? v.out[a] : 0, ob = v.out ? v.out[b] : 0, oc = v.out ? v.out[c] : 0;
  if (oa | ob | oc) {
    if (!(oa & ob & oc) && clip) return clip(ctx, a, b, c);  // rare: clipped in 4-D
    return 0;
  }
  const int32_t ax = v.xy[2 * a], ay = v.xy[2 * a + 1], bx = v.xy[2 * b], by = v.xy[2 * b + 1],
                cx = v.xy[2 * c], cy = v.xy[2 * c + 1];
  const int64_t area = int64_t(bx - ax) * (cy - ay) - int64_t(cx - ax) * (by - ay);
  if (area == 0) return 0;
  // Screen y runs down: a triangle counter-clockwise as seen has area < 0 here.
  const bool front = (area < 0) == outward;
  if (!front && cull) return 0;
  const float* k = front ? v.kf : v.kb;
  draw_triangle<kPath>(ax, ay, v.z[a], k[a], bx, by, v.z[b], k[b], cx, cy, v.z[c], k[c], rgb, T);
  return 1;
}

template <int kPath>
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
inline std::size_t
indexed(const VertexArrays& v, const uint32_t* t, std::size_t count, const float rgb[3], bool cull,
        bool outward, const Target& T, ClipCallback clip, void* ctx) {
  std::size_t drawn = 0;
  for (const uint32_t* end = t + 3 * count; t < end; t += 3) {
    drawn += indexed_one<kPath>(v, t[0], t[1], t[2], rgb, cull, outward, T, clip, ctx);
  }
  return drawn;
}

#if SE3_RASTER_AVX2
// Edge (x0, y0) -> (x1, y1) as draw_boxed sets it up, eight triangles wide: its value at the
// origin without (e) and with (returned) the top-left rule folded in, its steps per pixel ex, ey.
SE3_AVX2 inline __m256i edge_avx2(__m256i x0, __m256i y0, __m256i x1, __m256i y1, __m256i& e,
                                  __m256i& ex, __m256i& ey) {
  const __m256i zero = _mm256_setzero_si256();
  const __m256i dx = _mm256_sub_epi32(x1, x0), dy = _mm256_sub_epi32(y1, y0);
  e = _mm256_sub_epi32(_mm256_mullo_epi32(y0, dx), _mm256_mullo_epi32(x0, dy));
  const __m256i top_left =
      _mm256_or_si256(_mm256_cmpgt_epi32(dy, zero),
                      _mm256_and_si256(_mm256_cmpeq_epi32(dy, zero), _mm256_cmpgt_epi32(zero, dx)));
  ex = _mm256_slli_epi32(dy, 4);
  ey = _mm256_sub_epi32(zero, _mm256_slli_epi32(dx, 4));
  return _mm256_add_epi32(e, _mm256_xor_si256(top_left, _mm256_cmpeq_epi32(zero, zero)));
}

// The pixel boxes of eight triangles (pixels whose centre lies in their extent, clipped to
// the image), as draw_triangle finds them.
SE3_AVX2 inline void pixel_box_avx2(__m256i minx, __m256i maxx, __m256i miny, __m256i maxy,
                                    const Target& T, __m256i& bx0, __m256i& bx1, __m256i& by0,
                                    __m256i& by1) {
  const __m256i zero = _mm256_setzero_si256();
  const __m256i half1 = _mm256_set1_epi32(kHalf - 1), half = _mm256_set1_epi32(kHalf);
  bx0 = _mm256_max_epi32(zero, _mm256_srai_epi32(_mm256_add_epi32(minx, half1), 4));
  bx1 = _mm256_min_epi32(_mm256_set1_epi32(T.W - 1),
                         _mm256_srai_epi32(_mm256_sub_epi32(maxx, half), 4));
  by0 = _mm256_max_epi32(zero, _mm256_srai_epi32(_mm256_add_epi32(miny, half1), 4));
  by1 = _mm256_min_epi32(_mm256_set1_epi32(T.H - 1),
                         _mm256_srai_epi32(_mm256_sub_epi32(maxy, half), 4));
}

// Their edge functions as draw_boxed computes them: relative to the box's first centre, in
// canonical winding (b and c swapped where the area is positive: the lanes returned), each
// edge's value without (E) and with (Tl) the top-left rule and its steps per pixel.
SE3_AVX2 inline __m256i edges_avx2(__m256i ax, __m256i ay, __m256i bx, __m256i by, __m256i cx,
                                   __m256i cy, __m256i area, __m256i bx0, __m256i by0, __m256i E[3],
                                   __m256i Tl[3], __m256i EX[3], __m256i EY[3]) {
  const __m256i half = _mm256_set1_epi32(kHalf);
  const __m256i ox = _mm256_add_epi32(_mm256_slli_epi32(bx0, 4), half);
  const __m256i oy = _mm256_add_epi32(_mm256_slli_epi32(by0, 4), half);
  const __m256i swap = _mm256_cmpgt_epi32(area, _mm256_setzero_si256());
  const __m256i px = _mm256_sub_epi32(ax, ox), py = _mm256_sub_epi32(ay, oy);
  const __m256i qx = _mm256_sub_epi32(_mm256_blendv_epi8(bx, cx, swap), ox);
  const __m256i qy = _mm256_sub_epi32(_mm256_blendv_epi8(by, cy, swap), oy);
  const __m256i rx = _mm256_sub_epi32(_mm256_blendv_epi8(cx, bx, swap), ox);
  const __m256i ry = _mm256_sub_epi32(_mm256_blendv_epi8(cy, by, swap), oy);
  Tl[0] = edge_avx2(px, py, qx, qy, E[0], EX[0], EY[0]);
  Tl[1] = edge_avx2(qx, qy, rx, ry, E[1], EX[1], EY[1]);
  Tl[2] = edge_avx2(rx, ry, px, py, E[2], EX[2], EY[2]);
  return swap;
}

// The x and y of vertices g[0], g[S], ..., g[7 S] in lanes 0 .. 7: eight 8-byte loads of (x, y)
// pairs, split by one shuffle each. (Gathers cost more: 2.27 -> 2.06 ms a 640 x 480 camera
// frame, medians of five interleaved runs, AMD EPYC.)
SE3_AVX2 inline __m128i two_xy(const int32_t* xy, uint32_t i, uint32_t j) {
  return _mm_unpacklo_epi64(
      _mm_loadl_epi64(reinterpret_cast<const __m128i*>(xy + 2 * std::size_t(i))),
      _mm_loadl_epi64(reinterpret_cast<const __m128i*>(xy + 2 * std::size_t(j))));
}
template <int S>
SE3_AVX2 inline void corner_avx2(const int32_t* xy, const uint32_t* g, __m256i& x, __m256i& y) {
  // (t0, t1 | t4, t5) and (t2, t3 | t6, t7), each (x, y).
  const __m256 p = _mm256_castsi256_ps(_mm256_inserti128_si256(
      _mm256_castsi128_si256(two_xy(xy, g[0], g[S])), two_xy(xy, g[4 * S], g[5 * S]), 1));
  const __m256 q = _mm256_castsi256_ps(_mm256_inserti128_si256(
      _mm256_castsi128_si256(two_xy(xy, g[2 * S], g[3 * S])), two_xy(xy, g[6 * S], g[7 * S]), 1));
  x = _mm256_castps_si256(_mm256_shuffle_ps(p, q, _MM_SHUFFLE(2, 0, 2, 0)));
  y = _mm256_castps_si256(_mm256_shuffle_ps(p, q, _MM_SHUFFLE(3, 1, 3, 1)));
}

// Triangles whose pixel box is at most N x N pixels (N = 2: most survivors of a detailed mesh;
// N = 4: most of the rest), queued by the front end and drawn eight at a time: the vertices'
// corners, edges and the centres' coverage, z and colour in vector lanes (the same operations
// as small_covered and small_avx2, so the same bits), then each covered centre's depth test
// one at a time. The queue holds their vertices (a, b, c as listed); drawing them after the
// triangles that followed them is allowed by the order-free depth test (fragment()).
struct BoxQueue {
  alignas(32) uint32_t v[3][8];
  int n = 0;
};
inline void push(BoxQueue& q, const uint32_t* abc) {
  q.v[0][q.n] = abc[0];
  q.v[1][q.n] = abc[1];
  q.v[2][q.n] = abc[2];
  ++q.n;
}

// Lanes whose row y is another thread's (RowSet::has false).
SE3_AVX2 inline __m256i other_band(__m256i y, __m128i shift, __m256i part_mask, __m256i part) {
  const __m256i mine =
      _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_sra_epi32(y, shift), part_mask), part);
  return _mm256_xor_si256(mine, _mm256_cmpeq_epi32(mine, mine));
}

SE3_AVX2 inline __m256 load8(const float* p, const uint32_t* i) {
  return _mm256_setr_ps(p[i[0]], p[i[1]], p[i[2]], p[i[3]], p[i[4]], p[i[5]], p[i[6]], p[i[7]]);
}

// Draws the first n (1..8) queued triangles, boxes of at most N x N pixels (the lanes past n
// repeat the first and draw nothing).
template <int N>
SE3_AVX2 void box_batch(const VertexArrays& v, BoxQueue& q, int n, const float rgb[3], bool outward,
                        const Target& T) {
  for (int j = 0; j < 3; ++j) {
    for (int l = n; l < 8; ++l) q.v[j][l] = q.v[j][0];
  }
  const __m256i zero = _mm256_setzero_si256();
  __m256i ax, ay, bx, by, cx, cy;
  corner_avx2<1>(v.xy, q.v[0], ax, ay);
  corner_avx2<1>(v.xy, q.v[1], bx, by);
  corner_avx2<1>(v.xy, q.v[2], cx, cy);
  // As the front end: area, the box's first centre (the box is within the image), canonical
  // winding.
  const __m256i area =
      _mm256_sub_epi32(_mm256_mullo_epi32(_mm256_sub_epi32(bx, ax), _mm256_sub_epi32(cy, ay)),
                       _mm256_mullo_epi32(_mm256_sub_epi32(cx, ax), _mm256_sub_epi32(by, ay)));
  const __m256i minx = _mm256_min_epi32(ax, _mm256_min_epi32(bx, cx));
  const __m256i maxx = _mm256_max_epi32(ax, _mm256_max_epi32(bx, cx));
  const __m256i miny = _mm256_min_epi32(ay, _mm256_min_epi32(by, cy));
  const __m256i maxy = _mm256_max_epi32(ay, _mm256_max_epi32(by, cy));
  __m256i bx0, bx1, by0, by1;
  pixel_box_avx2(minx, maxx, miny, maxy, T, bx0, bx1, by0, by1);
  __m256i E[3], Tl[3], EX[3], EY[3];
  const __m256i swap = edges_avx2(ax, ay, bx, by, cx, cy, area, bx0, by0, E, Tl, EX, EY);
  // Coverage of the centres (i, j) (centre i + N j): only columns and rows the box has, rows
  // only where they are this thread's, lanes only up to n.
  const __m256i dead =
      _mm256_cmpgt_epi32(_mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 8), _mm256_set1_epi32(n));
  const __m256i wide = _mm256_sub_epi32(bx1, bx0), tall = _mm256_sub_epi32(by1, by0);
  __m128i shift = _mm_setzero_si128();
  __m256i part_mask = zero, part = zero;
  const bool bands = T.rows.parts > 1;
  if (bands) {
    shift = _mm_cvtsi32_si128(T.rows.shift);
    part_mask = _mm256_set1_epi32(T.rows.parts - 1);
    part = _mm256_set1_epi32(T.rows.part);
  }
  unsigned in[N * N];
  unsigned any = 0;
  __m256i u0 = Tl[0], u1 = Tl[1], u2 = Tl[2];  // row j's first centre
  for (int j = 0; j < N; ++j) {
    __m256i skip = _mm256_or_si256(dead, _mm256_cmpgt_epi32(_mm256_set1_epi32(j), tall));
    if (bands) {
      skip = _mm256_or_si256(
          skip, other_band(_mm256_add_epi32(by0, _mm256_set1_epi32(j)), shift, part_mask, part));
    }
    __m256i w0 = u0, w1 = u1, w2 = u2;
    for (int i = 0; i < N; ++i) {
      const __m256i out = _mm256_or_si256(
          _mm256_or_si256(_mm256_or_si256(w0, w1), w2),
          i ? _mm256_or_si256(skip, _mm256_cmpgt_epi32(_mm256_set1_epi32(i), wide)) : skip);
      in[i + N * j] = ~unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(out))) & 255u;
      any |= in[i + N * j];
      w0 = _mm256_add_epi32(w0, EX[0]);
      w1 = _mm256_add_epi32(w1, EX[1]);
      w2 = _mm256_add_epi32(w2, EX[2]);
    }
    u0 = _mm256_add_epi32(u0, EY[0]);
    u1 = _mm256_add_epi32(u1, EY[1]);
    u2 = _mm256_add_epi32(u2, EY[2]);
  }
  if (!any) return;
  // z and shade at the vertices in canonical winding (a, then b and c swapped where the
  // area is positive), the side's shade where the area's sign and the winding say.
  const __m256 swp = _mm256_castsi256_ps(swap);
  const __m256 front = _mm256_castsi256_ps(
      _mm256_xor_si256(_mm256_srai_epi32(area, 31), _mm256_set1_epi32(outward ? 0 : -1)));
  const __m256 za = load8(v.z, q.v[0]), zb = load8(v.z, q.v[1]), zc = load8(v.z, q.v[2]);
  const __m256 ka = _mm256_blendv_ps(load8(v.kb, q.v[0]), load8(v.kf, q.v[0]), front);
  const __m256 kb = _mm256_blendv_ps(load8(v.kb, q.v[1]), load8(v.kf, q.v[1]), front);
  const __m256 kc = _mm256_blendv_ps(load8(v.kb, q.v[2]), load8(v.kf, q.v[2]), front);
  const __m256 inv =
      _mm256_div_ps(_mm256_set1_ps(1.0f), _mm256_cvtepi32_ps(_mm256_abs_epi32(area)));
  const __m256 wa = _mm256_mul_ps(za, inv), wb = _mm256_mul_ps(_mm256_blendv_ps(zb, zc, swp), inv),
               wc = _mm256_mul_ps(_mm256_blendv_ps(zc, zb, swp), inv);
  const __m256 ua = _mm256_mul_ps(ka, inv), ub = _mm256_mul_ps(_mm256_blendv_ps(kb, kc, swp), inv),
               uc = _mm256_mul_ps(_mm256_blendv_ps(kc, kb, swp), inv);
  const __m256 c[3] = {_mm256_set1_ps(rgb[0]), _mm256_set1_ps(rgb[1]), _mm256_set1_ps(rgb[2])};
  alignas(32) float zs[N * N][8];
  alignas(32) uint32_t cs[N * N][8];
  __m256i r0 = E[0], r1 = E[1], r2 = E[2];  // row j's first centre, without the top-left rule
  for (int j = 0; j < N; ++j) {
    __m256i f0 = r0, f1 = r1, f2 = r2;
    for (int i = 0; i < N; ++i) {
      const int k = i + N * j;
      if (in[k]) {
        const __m256 ff0 = _mm256_cvtepi32_ps(f0), ff1 = _mm256_cvtepi32_ps(f1),
                     ff2 = _mm256_cvtepi32_ps(f2);
        _mm256_store_ps(zs[k],
                        _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ff0, wc), _mm256_mul_ps(ff1, wa)),
                                      _mm256_mul_ps(ff2, wb)));
        if (T.paint) {
          const __m256 kk =
              _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ff0, uc), _mm256_mul_ps(ff1, ua)),
                            _mm256_mul_ps(ff2, ub));
          _mm256_store_si256(reinterpret_cast<__m256i*>(cs[k]), shade_avx2(c, kk));
        }
      }
      f0 = _mm256_add_epi32(f0, EX[0]);
      f1 = _mm256_add_epi32(f1, EX[1]);
      f2 = _mm256_add_epi32(f2, EX[2]);
    }
    r0 = _mm256_add_epi32(r0, EY[0]);
    r1 = _mm256_add_epi32(r1, EY[1]);
    r2 = _mm256_add_epi32(r2, EY[2]);
  }
  alignas(32) int32_t base[8];
  _mm256_store_si256(reinterpret_cast<__m256i*>(base),
                     _mm256_add_epi32(_mm256_mullo_epi32(by0, _mm256_set1_epi32(T.W)), bx0));
  for (int k = 0; k < N * N; ++k) {
    const std::size_t step = std::size_t(k % N) + std::size_t(k / N) * std::size_t(T.W);
    for (unsigned m = in[k]; m; m &= m - 1) {
      const int l = __builtin_ctz(m);
      const std::size_t at = std::size_t(base[l]) + step;
      float* d = T.depth + at;
      const float z = zs[k][l];
      if (z > *d) {
        *d = z;
        if (T.paint) T.color[at] = cs[k][l];
      } else if (T.paint && z == *d && cs[k][l] > T.color[at]) {
        T.color[at] = cs[k][l];
      }
    }
  }
}

// The triangle loop for AVX2 with a front end eight triangles wide: the vertices of eight
// triangles are loaded and their signed areas, culling, pixel boxes and the empty-box and
// other-band rejections computed in vector lanes, without a branch per triangle (on a detailed
// mesh most triangles end there: back faces, or boxes without a pixel centre). The survivors
// go to draw_boxed in their order; triangles with a vertex outside or an extent above
// kMaxExtent (where 32-bit areas could overflow) take indexed_one. Compiled as one function
// (VEX encodings, three-operand forms).
SE3_AVX2 __attribute__((flatten)) std::size_t indexed_avx2(const VertexArrays& v, const uint32_t* t,
                                                           std::size_t count, const float rgb[3],
                                                           bool cull, bool outward, const Target& T,
                                                           ClipCallback clip, void* ctx) {
  std::size_t drawn = 0;
  const __m256i zero = _mm256_setzero_si256();
  const __m256i ext = _mm256_set1_epi32(kMaxExtent);
  // Lanes of front faces: the sign of the area, flipped when clockwise faces out.
  const __m256i flip = _mm256_set1_epi32(outward ? 0 : -1);
  const __m256i back_ok = _mm256_set1_epi32(cull ? 0 : -1);
  const bool bands = T.rows.parts > 1;
  const __m128i shift = _mm_cvtsi32_si128(T.rows.shift);
  const __m256i part_mask = _mm256_set1_epi32(T.rows.parts - 1);
  const __m256i part = _mm256_set1_epi32(T.rows.part);
  alignas(32) int32_t lanes[17][8];  // the survivors' Edges, lane by lane
  BoxQueue tq, sq;                   // boxes of at most 2 x 2 and 4 x 4 pixels
  std::size_t i = 0;
  for (; i + 8 <= count; i += 8) {
    const uint32_t* g = t + 3 * i;
    unsigned slow = 0;
    if (v.out) {  // null: every vertex inside, none to clip
      for (int k = 0; k < 8; ++k) {
        slow |= unsigned((v.out[g[3 * k]] | v.out[g[3 * k + 1]] | v.out[g[3 * k + 2]]) != 0) << k;
      }
    }
    __m256i ax, ay, bx, by, cx, cy;
    corner_avx2<3>(v.xy, g, ax, ay);
    corner_avx2<3>(v.xy, g + 1, bx, by);
    corner_avx2<3>(v.xy, g + 2, cx, cy);
    const __m256i minx = _mm256_min_epi32(ax, _mm256_min_epi32(bx, cx));
    const __m256i maxx = _mm256_max_epi32(ax, _mm256_max_epi32(bx, cx));
    const __m256i miny = _mm256_min_epi32(ay, _mm256_min_epi32(by, cy));
    const __m256i maxy = _mm256_max_epi32(ay, _mm256_max_epi32(by, cy));
    const __m256i big = _mm256_or_si256(_mm256_cmpgt_epi32(_mm256_sub_epi32(maxx, minx), ext),
                                        _mm256_cmpgt_epi32(_mm256_sub_epi32(maxy, miny), ext));
    slow |= unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(big)));
    // Exact in 32 bits where the extent is at most 2^14 (|area| <= 2^29).
    const __m256i area =
        _mm256_sub_epi32(_mm256_mullo_epi32(_mm256_sub_epi32(bx, ax), _mm256_sub_epi32(cy, ay)),
                         _mm256_mullo_epi32(_mm256_sub_epi32(cx, ax), _mm256_sub_epi32(by, ay)));
    const __m256i front = _mm256_xor_si256(_mm256_srai_epi32(area, 31), flip);
    const __m256i counted =
        _mm256_andnot_si256(_mm256_cmpeq_epi32(area, zero), _mm256_or_si256(front, back_ok));
    __m256i bx0, bx1, by0, by1;
    pixel_box_avx2(minx, maxx, miny, maxy, T, bx0, bx1, by0, by1);
    __m256i empty = _mm256_or_si256(_mm256_cmpgt_epi32(bx0, bx1), _mm256_cmpgt_epi32(by0, by1));
    if (bands) {  // the box within one band, another thread's
      const __m256i b0 = _mm256_sra_epi32(by0, shift), b1 = _mm256_sra_epi32(by1, shift);
      const __m256i other = _mm256_andnot_si256(
          _mm256_cmpeq_epi32(_mm256_and_si256(b0, part_mask), part), _mm256_cmpeq_epi32(b0, b1));
      empty = _mm256_or_si256(empty, other);
    }
    const unsigned counted_m = unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(counted))) & ~slow;
    drawn += std::size_t(__builtin_popcount(counted_m));
    unsigned pending =
        (counted_m & ~unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(empty)))) | slow;
    if (!pending) continue;
    __m256i E[3], Tl[3], EX[3], EY[3];
    const __m256i swap = edges_avx2(ax, ay, bx, by, cx, cy, area, bx0, by0, E, Tl, EX, EY);
    // Boxes of at most 2 x 2 pixels (most survivors of a detailed mesh) that cover no
    // centre draw nothing. Sign bit set: the centre is outside.
    const __m256i c00 = _mm256_or_si256(_mm256_or_si256(Tl[0], Tl[1]), Tl[2]);
    const __m256i c10 = _mm256_or_si256(
        _mm256_or_si256(_mm256_add_epi32(Tl[0], EX[0]), _mm256_add_epi32(Tl[1], EX[1])),
        _mm256_add_epi32(Tl[2], EX[2]));
    const __m256i u0 = _mm256_add_epi32(Tl[0], EY[0]), u1 = _mm256_add_epi32(Tl[1], EY[1]),
                  u2 = _mm256_add_epi32(Tl[2], EY[2]);
    const __m256i c01 = _mm256_or_si256(_mm256_or_si256(u0, u1), u2);
    const __m256i c11 =
        _mm256_or_si256(_mm256_or_si256(_mm256_add_epi32(u0, EX[0]), _mm256_add_epi32(u1, EX[1])),
                        _mm256_add_epi32(u2, EX[2]));
    const __m256i one_col = _mm256_cmpeq_epi32(bx0, bx1), one_row = _mm256_cmpeq_epi32(by0, by1);
    const __m256i none =
        _mm256_and_si256(_mm256_and_si256(c00, _mm256_or_si256(c10, one_col)),
                         _mm256_and_si256(_mm256_or_si256(c01, one_row),
                                          _mm256_or_si256(c11, _mm256_or_si256(one_col, one_row))));
    const __m256i one = _mm256_set1_epi32(1);
    const __m256i small2 =
        _mm256_or_si256(_mm256_cmpgt_epi32(_mm256_sub_epi32(bx1, bx0), one),
                        _mm256_cmpgt_epi32(_mm256_sub_epi32(by1, by0), one));  // set: larger
    const unsigned tiny =
        ~unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(small2))) & pending & ~slow;
    const __m256i three = _mm256_set1_epi32(3);
    const __m256i small4 =
        _mm256_or_si256(_mm256_cmpgt_epi32(_mm256_sub_epi32(bx1, bx0), three),
                        _mm256_cmpgt_epi32(_mm256_sub_epi32(by1, by0), three));  // set: larger
    const unsigned small =
        ~unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(small4))) & pending & ~slow & ~tiny;
    pending &= ~(tiny | small);
    // Boxes of at most 2 x 2 pixels covering a centre, and of at most 4 x 4, to their queues,
    // drawn eight at a time.
    for (unsigned m = tiny & ~unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(none))); m;
         m &= m - 1) {
      push(tq, g + 3 * __builtin_ctz(m));
      if (tq.n == 8) {
        box_batch<2>(v, tq, 8, rgb, outward, T);
        tq.n = 0;
      }
    }
    for (unsigned m = small; m; m &= m - 1) {
      push(sq, g + 3 * __builtin_ctz(m));
      if (sq.n == 8) {
        box_batch<4>(v, sq, 8, rgb, outward, T);
        sq.n = 0;
      }
    }
    if (!pending) continue;
    const unsigned front_m = unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(front)));
    const unsigned swap_m = unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(swap)));
    _mm256_store_si256(reinterpret_cast<__m256i*>(lanes[0]), bx0);
    _mm256_store_si256(reinterpret_cast<__m256i*>(lanes[1]), by0);
    _mm256_store_si256(reinterpret_cast<__m256i*>(lanes[2]), bx1);
    _mm256_store_si256(reinterpret_cast<__m256i*>(lanes[3]), by1);
    _mm256_store_si256(reinterpret_cast<__m256i*>(lanes[4]), E[0]);
    _mm256_store_si256(reinterpret_cast<__m256i*>(lanes[5]), E[1]);
    _mm256_store_si256(reinterpret_cast<__m256i*>(lanes[6]), E[2]);
    _mm256_store_si256(reinterpret_cast<__m256i*>(lanes[7]), Tl[0]);
    _mm256_store_si256(reinterpret_cast<__m256i*>(lanes[8]), Tl[1]);
    _mm256_store_si256(reinterpret_cast<__m256i*>(lanes[9]), Tl[2]);
    _mm256_store_si256(reinterpret_cast<__m256i*>(lanes[10]), EX[0]);
    _mm256_store_si256(reinterpret_cast<__m256i*>(lanes[11]), EX[1]);
    _mm256_store_si256(reinterpret_cast<__m256i*>(lanes[12]), EX[2]);
    _mm256_store_si256(reinterpret_cast<__m256i*>(lanes[13]), EY[0]);
    _mm256_store_si256(reinterpret_cast<__m256i*>(lanes[14]), EY[1]);
    _mm256_store_si256(reinterpret_cast<__m256i*>(lanes[15]), EY[2]);
    _mm256_store_si256(reinterpret_cast<__m256i*>(lanes[16]), _mm256_abs_epi32(area));
    do {
      const int k = __builtin_ctz(pending);
      pending &= pending - 1;
      const uint32_t a = g[3 * k], b = g[3 * k + 1], c = g[3 * k + 2];
      if (slow >> k & 1u) {
        drawn += indexed_one<2>(v, a, b, c, rgb, cull, outward, T, clip, ctx);
        continue;
      }
      const float* kk = (front_m >> k & 1u) ? v.kf : v.kb;
      const uint32_t q = (swap_m >> k & 1u) ? c : b, r = (swap_m >> k & 1u) ? b : c;
      const Edges eg{lanes[0][k],
                     lanes[1][k],
                     lanes[2][k],
                     lanes[3][k],
                     {lanes[4][k], lanes[5][k], lanes[6][k]},
                     {lanes[7][k], lanes[8][k], lanes[9][k]},
                     {lanes[10][k], lanes[11][k], lanes[12][k]},
                     {lanes[13][k], lanes[14][k], lanes[15][k]},
                     lanes[16][k],
                     {v.z[a], v.z[q], v.z[r]},
                     {kk[a], kk[q], kk[r]}};
      draw_edges<2>(eg, rgb, T);
    } while (pending);
  }
  if (tq.n) box_batch<2>(v, tq, tq.n, rgb, outward, T);
  if (sq.n) box_batch<4>(v, sq, sq.n, rgb, outward, T);
  for (; i < count; ++i) {
    drawn +=
        indexed_one<2>(v, t[3 * i], t[3 * i + 1], t[3 * i + 2], rgb, cull, outward, T, clip, ctx);
  }
  return drawn;
}
#endif

}  // namespace

bool raster_has_simd() {
#if SE3_RASTER_SSE2
  return true;
#else
  return false;
#endif
}

RasterPath raster_best_path() {
#if SE3_RASTER_AVX2
  static const bool avx2 = __builtin_cpu_supports("avx2");
  if (avx2) return RasterPath::Avx2;
#endif
  return raster_has_simd() ? RasterPath::Sse2 : RasterPath::Scalar;
}

// The path a frame of this width can take: the wide ones load whole groups of a row.
int Framebuffer::usable_path() const {
  int p = int(path_);
  if (p == 2 && width_ < 8) p = 1;
  if (p == 1 && width_ < 4) p = 0;
  return p;
}

void Framebuffer::fill_triangle(const RasterVertex& a, const RasterVertex& b, const RasterVertex& c,
                                const float rgb[3], const RowSet& rows) {
  const Target T{width_, height_, color_.data(), depth_.data(), rows, paint_};
  draw_any(a, b, c, rgb, T, usable_path());
}

std::size_t Framebuffer::fill_indexed(const VertexArrays& v, const uint32_t* idx, std::size_t count,
                                      const float rgb[3], bool cull, bool outward,
                                      const RowSet& rows, ClipCallback clip, void* ctx) {
  const Target T{width_, height_, color_.data(), depth_.data(), rows, paint_};
  switch (usable_path()) {
#if SE3_RASTER_AVX2
    case 2:
      return indexed_avx2(v, idx, count, rgb, cull, outward, T, clip, ctx);
#endif
#if SE3_RASTER_SSE2
    case 1:
      return indexed<1>(v, idx, count, rgb, cull, outward, T, clip, ctx);
#endif
    default:
      return indexed<0>(v, idx, count, rgb, cull, outward, T, clip, ctx);
  }
}

void Framebuffer::fill_triangle(const ScreenVertex& a, const ScreenVertex& b, const ScreenVertex& c,
                                uint32_t color) {
  auto snap = [](const ScreenVertex& s) {
    RasterVertex v;
    v.x = int32_t(std::lrint(double(s.x) * kSubpixel));
    v.y = int32_t(std::lrint(double(s.y) * kSubpixel));
    v.z = s.inv_depth;
    v.k = 1.0f;
    return v;
  };
  // Finite and not absurdly far off the image (callers clip to the guard band).
  const float lim = 4.0f * float(width_ + height_) + 2048.0f;
  for (const ScreenVertex* s : {&a, &b, &c}) {
    if (!(std::abs(s->x) < lim) || !(std::abs(s->y) < lim)) return;
  }
  const float rgb[3] = {float((color >> 16) & 0xff), float((color >> 8) & 0xff),
                        float(color & 0xff)};
  fill_triangle(snap(a), snap(b), snap(c), rgb);
}

}  // namespace render
}  // namespace se3
