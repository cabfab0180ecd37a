// The mesh pipeline: a vertex stage (clip coordinates, snapped pixels, outcodes, Lambert shade
// of both sides) into the frame's vertex buffers, and a triangle stage (outcode rejection, back
// faces of closed runs culled before setup, clipping in homogeneous coordinates of the few
// triangles that cross the near plane or the guard band) into the rasterizer.
#include <algorithm>
#include <cmath>

#include "impl.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#define SE3_PIPE_SSE2 1
#endif
#if SE3_PIPE_SSE2 && defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define SE3_PIPE_AVX2 1
#endif

namespace se3 {
namespace render {
namespace {

constexpr double kGuard = 64.0;  // pixels around the image inside which vertices need no clip

struct ClipVertex {
  Vec4 c;
  double kf, kb;
};

int clip_polygon_attr(const ClipPlanes& planes, ClipVertex* poly, int n) {
  ClipVertex tmp[16];
  ClipVertex* src = poly;
  ClipVertex* dst = tmp;
  for (int p = 0; p < planes.count && n >= 3; ++p) {
    const Vec4& pl = planes.plane[p];
    int m = 0;
    for (int i = 0; i < n; ++i) {
      const ClipVertex& a = src[i];
      const ClipVertex& b = src[(i + 1) % n];
      const double da = pl.dot(a.c), db = pl.dot(b.c);
      if (da >= 0 && m < 15) dst[m++] = a;
      if ((da >= 0) != (db >= 0) && m < 15) {
        const double t = da / (da - db);
        dst[m++] = {a.c + t * (b.c - a.c), a.kf + t * (b.kf - a.kf), a.kb + t * (b.kb - a.kb)};
      }
    }
    n = m;
    std::swap(src, dst);
  }
  if (src != poly) {
    for (int i = 0; i < n; ++i) poly[i] = src[i];
  }
  return n >= 3 ? n : 0;
}

inline float pos(float x) {
  return x > 0.0f ? x : 0.0f;
}

#if SE3_PIPE_AVX2
// The vertex stage's SSE2 loop eight vertices wide (the same operations lane by lane, so the
// same bits) from i while i + 8 <= v1; returns where it stopped.
__attribute__((target("avx2"))) std::size_t transform_avx2(
    const RenderMesh& mesh, std::size_t i, std::size_t v1, const float* m, float near, float xlo,
    float xhi, float ylo, float yhi, const float L[3], const float H[3], float ka, float kd,
    float kh, int32_t* XY_, float* Z_, float* KF_, float* KB_, uint8_t* O_, uint8_t& any) {
  __m256 M[12];
  for (int k = 0; k < 12; ++k) M[k] = _mm256_set1_ps(m[k]);
  const __m256 vnear = _mm256_set1_ps(near), vsub = _mm256_set1_ps(float(kSubpixel));
  const __m256 vxlo = _mm256_set1_ps(xlo), vxhi = _mm256_set1_ps(xhi);
  const __m256 vylo = _mm256_set1_ps(ylo), vyhi = _mm256_set1_ps(yhi);
  const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps();
  const __m256 Lx = _mm256_set1_ps(L[0]), Ly = _mm256_set1_ps(L[1]), Lz = _mm256_set1_ps(L[2]);
  const __m256 Hx = _mm256_set1_ps(H[0]), Hy = _mm256_set1_ps(H[1]), Hz = _mm256_set1_ps(H[2]);
  const __m256 ka8 = _mm256_set1_ps(ka), kd8 = _mm256_set1_ps(kd), kh8 = _mm256_set1_ps(kh);
  __m256i codes_or = _mm256_setzero_si256();
  for (; i + 8 <= v1; i += 8) {
    const __m256 x = _mm256_loadu_ps(&mesh.px[i]), y = _mm256_loadu_ps(&mesh.py[i]),
                 z = _mm256_loadu_ps(&mesh.pz[i]);
    const __m256 U =
        _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(M[0], x), _mm256_mul_ps(M[1], y)),
                                    _mm256_mul_ps(M[2], z)),
                      M[3]);
    const __m256 V =
        _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(M[4], x), _mm256_mul_ps(M[5], y)),
                                    _mm256_mul_ps(M[6], z)),
                      M[7]);
    const __m256 W =
        _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(M[8], x), _mm256_mul_ps(M[9], y)),
                                    _mm256_mul_ps(M[10], z)),
                      M[11]);
    const __m256 front = _mm256_cmp_ps(W, vnear, _CMP_GE_OQ);  // false for NaN too
    const __m256 inv = _mm256_div_ps(one, _mm256_blendv_ps(one, W, front));
    const __m256 sx = _mm256_mul_ps(U, inv), sy = _mm256_mul_ps(V, inv);
    const __m256i behind =
        _mm256_andnot_si256(_mm256_castps_si256(front), _mm256_set1_epi32(kBehind));
    const __m256i l = _mm256_and_si256(_mm256_castps_si256(_mm256_cmp_ps(sx, vxlo, _CMP_LT_OQ)),
                                       _mm256_set1_epi32(kLeft));
    const __m256i r = _mm256_and_si256(_mm256_castps_si256(_mm256_cmp_ps(sx, vxhi, _CMP_GT_OQ)),
                                       _mm256_set1_epi32(kRight));
    const __m256i t = _mm256_and_si256(_mm256_castps_si256(_mm256_cmp_ps(sy, vylo, _CMP_LT_OQ)),
                                       _mm256_set1_epi32(kTop));
    const __m256i b = _mm256_and_si256(_mm256_castps_si256(_mm256_cmp_ps(sy, vyhi, _CMP_GT_OQ)),
                                       _mm256_set1_epi32(kBottom));
    __m256i code =
        _mm256_or_si256(_mm256_or_si256(_mm256_or_si256(l, r), _mm256_or_si256(t, b)), behind);
    code = _mm256_or_si256(_mm256_and_si256(_mm256_castps_si256(front), code), behind);
    codes_or = _mm256_or_si256(codes_or, code);
    const __m256i none = _mm256_cmpeq_epi32(code, _mm256_setzero_si256());
    const __m256i ix = _mm256_and_si256(none, _mm256_cvtps_epi32(_mm256_mul_ps(sx, vsub)));
    const __m256i iy = _mm256_and_si256(none, _mm256_cvtps_epi32(_mm256_mul_ps(sy, vsub)));
    // Interleaved: (x0 y0 x1 y1 | x4 y4 x5 y5) and (x2 y2 x3 y3 | x6 y6 x7 y7), halves swapped
    // into order.
    const __m256i lo = _mm256_unpacklo_epi32(ix, iy), hi = _mm256_unpackhi_epi32(ix, iy);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(XY_ + 2 * i),
                        _mm256_permute2x128_si256(lo, hi, 0x20));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(XY_ + 2 * i + 8),
                        _mm256_permute2x128_si256(lo, hi, 0x31));
    _mm256_storeu_ps(Z_ + i, _mm256_and_ps(front, inv));
    // The eight codes (at most 31) as bytes: c0..c3 and c4..c7 in the halves' low words.
    const __m256i w16 = _mm256_packs_epi32(code, code);
    const __m256i w8 = _mm256_packus_epi16(w16, w16);
    _mm_storel_epi64(
        reinterpret_cast<__m128i*>(O_ + i),
        _mm_unpacklo_epi32(_mm256_castsi256_si128(w8), _mm256_extracti128_si256(w8, 1)));
    const __m256 nx = _mm256_loadu_ps(&mesh.nx[i]), ny = _mm256_loadu_ps(&mesh.ny[i]),
                 nz = _mm256_loadu_ps(&mesh.nz[i]);
    const __m256 dl = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(Lx, nx), _mm256_mul_ps(Ly, ny)),
                                    _mm256_mul_ps(Lz, nz));
    const __m256 dh = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(Hx, nx), _mm256_mul_ps(Hy, ny)),
                                    _mm256_mul_ps(Hz, nz));
    const __m256 kf = _mm256_add_ps(_mm256_add_ps(ka8, _mm256_mul_ps(kd8, _mm256_max_ps(dl, zero))),
                                    _mm256_mul_ps(kh8, _mm256_max_ps(dh, zero)));
    const __m256 kb = _mm256_add_ps(
        _mm256_add_ps(ka8, _mm256_mul_ps(kd8, _mm256_max_ps(_mm256_sub_ps(zero, dl), zero))),
        _mm256_mul_ps(kh8, _mm256_max_ps(_mm256_sub_ps(zero, dh), zero)));
    _mm256_storeu_ps(KF_ + i, kf);
    _mm256_storeu_ps(KB_ + i, kb);
  }
  alignas(32) int32_t lanes[8];
  _mm256_store_si256(reinterpret_cast<__m256i*>(lanes), codes_or);
  for (int k = 0; k < 8; ++k) any |= uint8_t(lanes[k]);
  return i;
}
#endif

}  // namespace

void Renderer::Impl::reserve(std::size_t n) {
  if (Z.size() >= n) return;
  XY.resize(2 * n);
  Z.resize(n);
  KF.resize(n);
  KB.resize(n);
  out.resize(n);
}

bool Renderer::Impl::prepare(const RenderMesh& mesh, const SE3& pose, const Vec3& scale,
                             const Camera& cam, const ClipPlanes& planes,
                             const Eigen::Vector3d& light, std::size_t vbase, ItemFrame& f) const {
  f.visible = false;
  f.vbase = vbase;
  f.depth = 0;  // a strict weak order for the sort by depth, whatever the item
  if (!pose.R.allFinite() || !pose.p.allFinite() || !scale.allFinite()) return false;
  if (mesh.vertex_count() == 0) return false;
  Mat4 T = Mat4::Identity();
  T.topLeftCorner<3, 3>() = pose.R * scale.asDiagonal();
  T.topRightCorner<3, 1>() = pose.p;
  f.clip = cam.P * T;
  if (!f.clip.allFinite()) return false;
  // Whole mesh outside one plane: nothing to do. Else the pixels its box can cover.
  const Eigen::Vector3d lo = mesh.lower.cast<double>(), hi = mesh.upper.cast<double>();
  Vec4 corner[8];
  for (int c = 0; c < 8; ++c) {
    corner[c] = f.clip * Vec4((c & 1) ? hi.x() : lo.x(), (c & 2) ? hi.y() : lo.y(),
                              (c & 4) ? hi.z() : lo.z(), 1.0);
  }
  for (int p = 0; p < planes.count; ++p) {
    bool all_out = true;
    for (int c = 0; c < 8 && all_out; ++c) all_out = planes.plane[p].dot(corner[c]) < 0;
    if (all_out) return false;
  }
  f.rect = Rect{0, 0, cam.width, cam.height};
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  bool in_front = true;
  for (const Vec4& c : corner) {
    if (!(c.w() >= cam.near)) {
      in_front = false;
      break;
    }
    const double u = c.x() / c.w(), v = c.y() / c.w();
    x0 = std::min(x0, u);
    x1 = std::max(x1, u);
    y0 = std::min(y0, v);
    y1 = std::max(y1, v);
  }
  if (in_front) {
    f.rect = Rect{std::max(0, int(std::floor(x0)) - 1), std::max(0, int(std::floor(y0)) - 1),
                  std::min(cam.width, int(std::ceil(x1)) + 2),
                  std::min(cam.height, int(std::ceil(y1)) + 2)};
  }
  f.depth = (f.clip *
             Vec4(0.5 * (lo.x() + hi.x()), 0.5 * (lo.y() + hi.y()), 0.5 * (lo.z() + hi.z()), 1.0))
                .w();
  if (!std::isfinite(f.depth)) f.depth = 0;
  const int rows[3] = {0, 1, 3};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) f.m[4 * r + c] = float(f.clip(rows[r], c));
  const Vec3 L = pose.R.transpose() * (light.norm() > 0 ? Vec3(light.normalized()) : Vec3::UnitZ());
  const Vec3 H = pose.R.transpose() * (-cam.R_wc.col(2));
  for (int k = 0; k < 3; ++k) {
    f.L[k] = float(L[k]);
    f.H[k] = float(H[k]);
    f.inv_scale[k] = float(scale[k] != 0 ? 1.0 / scale[k] : 0.0);
  }
  f.rescale = !(scale.x() == scale.y() && scale.y() == scale.z() && scale.x() > 0);
  f.visible = true;
  return true;
}

uint8_t Renderer::Impl::transform(const RenderMesh& mesh, std::size_t v0, std::size_t v1,
                                  const ItemFrame& f, const Camera& cam, bool simd) {
  const float* m = f.m;
  const float near = float(cam.near);
  const float xlo = float(-kGuard), xhi = float(cam.width + kGuard);
  const float ylo = float(-kGuard), yhi = float(cam.height + kGuard);
  const float sub = float(kSubpixel);
  int32_t* XY_ = XY.data() + 2 * f.vbase;
  float* Z_ = Z.data() + f.vbase;
  float* KF_ = KF.data() + f.vbase;
  float* KB_ = KB.data() + f.vbase;
  uint8_t* O_ = out.data() + f.vbase;
  std::size_t i = v0;
  uint8_t any = 0;
#if SE3_PIPE_AVX2
  if (simd && !f.rescale && raster_best_path() == RasterPath::Avx2) {
    i = transform_avx2(mesh, i, v1, m, near, xlo, xhi, ylo, yhi, f.L, f.H, ka, kd, kh, XY_, Z_, KF_,
                       KB_, O_, any);
  }
#endif
#if SE3_PIPE_SSE2
  if (simd && !f.rescale) {
    const __m128 m0 = _mm_set1_ps(m[0]), m1 = _mm_set1_ps(m[1]), m2 = _mm_set1_ps(m[2]),
                 m3 = _mm_set1_ps(m[3]), m4 = _mm_set1_ps(m[4]), m5 = _mm_set1_ps(m[5]),
                 m6 = _mm_set1_ps(m[6]), m7 = _mm_set1_ps(m[7]), m8 = _mm_set1_ps(m[8]),
                 m9 = _mm_set1_ps(m[9]), m10 = _mm_set1_ps(m[10]), m11 = _mm_set1_ps(m[11]);
    const __m128 vnear = _mm_set1_ps(near), vsub = _mm_set1_ps(sub);
    const __m128 vxlo = _mm_set1_ps(xlo), vxhi = _mm_set1_ps(xhi);
    const __m128 vylo = _mm_set1_ps(ylo), vyhi = _mm_set1_ps(yhi);
    const __m128 one = _mm_set1_ps(1.0f), zero = _mm_setzero_ps();
    const __m128 Lx = _mm_set1_ps(f.L[0]), Ly = _mm_set1_ps(f.L[1]), Lz = _mm_set1_ps(f.L[2]);
    const __m128 Hx = _mm_set1_ps(f.H[0]), Hy = _mm_set1_ps(f.H[1]), Hz = _mm_set1_ps(f.H[2]);
    const __m128 ka4 = _mm_set1_ps(ka), kd4 = _mm_set1_ps(kd), kh4 = _mm_set1_ps(kh);
    for (; i + 4 <= v1; i += 4) {
      const __m128 x = _mm_loadu_ps(&mesh.px[i]), y = _mm_loadu_ps(&mesh.py[i]),
                   z = _mm_loadu_ps(&mesh.pz[i]);
      // Same operation order as the scalar path below.
      const __m128 U = _mm_add_ps(
          _mm_add_ps(_mm_add_ps(_mm_mul_ps(m0, x), _mm_mul_ps(m1, y)), _mm_mul_ps(m2, z)), m3);
      const __m128 V = _mm_add_ps(
          _mm_add_ps(_mm_add_ps(_mm_mul_ps(m4, x), _mm_mul_ps(m5, y)), _mm_mul_ps(m6, z)), m7);
      const __m128 W = _mm_add_ps(
          _mm_add_ps(_mm_add_ps(_mm_mul_ps(m8, x), _mm_mul_ps(m9, y)), _mm_mul_ps(m10, z)), m11);
      const __m128 front = _mm_cmpge_ps(W, vnear);  // false for NaN too
      const __m128 inv =
          _mm_div_ps(one, _mm_or_ps(_mm_and_ps(front, W), _mm_andnot_ps(front, one)));
      const __m128 sx = _mm_mul_ps(U, inv), sy = _mm_mul_ps(V, inv);
      // Outcode bits as integer masks.
      const __m128i behind = _mm_andnot_si128(_mm_castps_si128(front), _mm_set1_epi32(kBehind));
      const __m128i l =
          _mm_and_si128(_mm_castps_si128(_mm_cmplt_ps(sx, vxlo)), _mm_set1_epi32(kLeft));
      const __m128i r =
          _mm_and_si128(_mm_castps_si128(_mm_cmpgt_ps(sx, vxhi)), _mm_set1_epi32(kRight));
      const __m128i t =
          _mm_and_si128(_mm_castps_si128(_mm_cmplt_ps(sy, vylo)), _mm_set1_epi32(kTop));
      const __m128i b =
          _mm_and_si128(_mm_castps_si128(_mm_cmpgt_ps(sy, vyhi)), _mm_set1_epi32(kBottom));
      __m128i code = _mm_or_si128(_mm_or_si128(_mm_or_si128(l, r), _mm_or_si128(t, b)), behind);
      // Behind the near plane only the behind bit counts (screen coordinates are meaningless).
      code = _mm_or_si128(_mm_and_si128(_mm_castps_si128(front), code), behind);
      const __m128i none = _mm_cmpeq_epi32(code, _mm_setzero_si128());
      const __m128i ix = _mm_and_si128(none, _mm_cvtps_epi32(_mm_mul_ps(sx, vsub)));
      const __m128i iy = _mm_and_si128(none, _mm_cvtps_epi32(_mm_mul_ps(sy, vsub)));
      _mm_storeu_si128(reinterpret_cast<__m128i*>(XY_ + 2 * i), _mm_unpacklo_epi32(ix, iy));
      _mm_storeu_si128(reinterpret_cast<__m128i*>(XY_ + 2 * i + 4), _mm_unpackhi_epi32(ix, iy));
      _mm_storeu_ps(Z_ + i, _mm_and_ps(front, inv));
      alignas(16) int32_t codes[4];
      _mm_store_si128(reinterpret_cast<__m128i*>(codes), code);
      for (int k = 0; k < 4; ++k) {
        O_[i + k] = uint8_t(codes[k]);
        any |= uint8_t(codes[k]);
      }
      const __m128 nx = _mm_loadu_ps(&mesh.nx[i]), ny = _mm_loadu_ps(&mesh.ny[i]),
                   nz = _mm_loadu_ps(&mesh.nz[i]);
      const __m128 dl =
          _mm_add_ps(_mm_add_ps(_mm_mul_ps(Lx, nx), _mm_mul_ps(Ly, ny)), _mm_mul_ps(Lz, nz));
      const __m128 dh =
          _mm_add_ps(_mm_add_ps(_mm_mul_ps(Hx, nx), _mm_mul_ps(Hy, ny)), _mm_mul_ps(Hz, nz));
      const __m128 kf = _mm_add_ps(_mm_add_ps(ka4, _mm_mul_ps(kd4, _mm_max_ps(dl, zero))),
                                   _mm_mul_ps(kh4, _mm_max_ps(dh, zero)));
      const __m128 kb =
          _mm_add_ps(_mm_add_ps(ka4, _mm_mul_ps(kd4, _mm_max_ps(_mm_sub_ps(zero, dl), zero))),
                     _mm_mul_ps(kh4, _mm_max_ps(_mm_sub_ps(zero, dh), zero)));
      _mm_storeu_ps(KF_ + i, kf);
      _mm_storeu_ps(KB_ + i, kb);
    }
  }
#else
  (void)simd;
#endif
  for (; i < v1; ++i) {
    const float x = mesh.px[i], y = mesh.py[i], z = mesh.pz[i];
    const float U = m[0] * x + m[1] * y + m[2] * z + m[3];
    const float V = m[4] * x + m[5] * y + m[6] * z + m[7];
    const float W = m[8] * x + m[9] * y + m[10] * z + m[11];
    const bool front = W >= near;
    const float inv = 1.0f / (front ? W : 1.0f);
    const float sx = U * inv, sy = V * inv;
    uint8_t code = 0;
    if (!front) {
      code = kBehind;
    } else {
      if (sx < xlo) code |= kLeft;
      if (sx > xhi) code |= kRight;
      if (sy < ylo) code |= kTop;
      if (sy > yhi) code |= kBottom;
    }
    XY_[2 * i] = code ? 0 : int32_t(std::lrint(sx * sub));
    XY_[2 * i + 1] = code ? 0 : int32_t(std::lrint(sy * sub));
    Z_[i] = front ? inv : 0.0f;
    O_[i] = code;
    any |= code;
    float nx = mesh.nx[i], ny = mesh.ny[i], nz = mesh.nz[i];
    if (f.rescale) {
      nx *= f.inv_scale[0];
      ny *= f.inv_scale[1];
      nz *= f.inv_scale[2];
      const float len = std::sqrt(nx * nx + ny * ny + nz * nz);
      const float il = len > 0 ? 1.0f / len : 0.0f;
      nx *= il;
      ny *= il;
      nz *= il;
    }
    const float dl = f.L[0] * nx + f.L[1] * ny + f.L[2] * nz;
    const float dh = f.H[0] * nx + f.H[1] * ny + f.H[2] * nz;
    KF_[i] = ka + kd * pos(dl) + kh * pos(dh);
    KB_[i] = ka + kd * pos(0.0f - dl) + kh * pos(0.0f - dh);
  }
  return any;
}

namespace {

// What the clip callback needs to redo a triangle in homogeneous coordinates.
struct ClipContext {
  const RenderMesh* mesh;
  const ItemFrame* f;
  const float* kf;
  const float* kb;
  const ClipPlanes* planes;
  const RowSet* rows;
  Framebuffer* fb;
  const float* rgb;
  bool cull, outward;
};

std::size_t clip_and_draw(void* p, uint32_t a, uint32_t b, uint32_t c) {
  const ClipContext& C = *static_cast<const ClipContext*>(p);
  const RenderMesh& mesh = *C.mesh;
  ClipVertex poly[16];
  const uint32_t id[3] = {a, b, c};
  for (int k = 0; k < 3; ++k) {
    const uint32_t v = id[k];
    poly[k].c = C.f->clip * Vec4(mesh.px[v], mesh.py[v], mesh.pz[v], 1.0);
    poly[k].kf = C.kf[v];
    poly[k].kb = C.kb[v];
  }
  const int n = clip_polygon_attr(*C.planes, poly, 3);
  if (!n) return 0;
  double sx[16], sy[16], area = 0;
  for (int k = 0; k < n; ++k) {
    sx[k] = poly[k].c.x() / poly[k].c.w();
    sy[k] = poly[k].c.y() / poly[k].c.w();
  }
  for (int k = 0; k < n; ++k) {
    const int j = (k + 1) % n;
    area += sx[k] * sy[j] - sx[j] * sy[k];
  }
  if (!(area != 0) || !std::isfinite(area)) return 0;
  const bool front = (area < 0) == C.outward;
  if (!front && C.cull) return 0;
  RasterVertex rv[16];
  for (int k = 0; k < n; ++k) {
    rv[k].x = int32_t(std::lrint(sx[k] * kSubpixel));
    rv[k].y = int32_t(std::lrint(sy[k] * kSubpixel));
    rv[k].z = float(1.0 / poly[k].c.w());
    rv[k].k = float(front ? poly[k].kf : poly[k].kb);
  }
  for (int k = 1; k + 1 < n; ++k) C.fb->fill_triangle(rv[0], rv[k], rv[k + 1], C.rgb, *C.rows);
  return 1;
}

}  // namespace

std::size_t Renderer::Impl::triangles(const RenderMesh& mesh, const ItemFrame& f, const float* rgb,
                                      const ClipPlanes& planes, const RowSet& rows,
                                      Framebuffer& fb) const {
  if (!f.visible) return 0;
  // No outcodes to test where every vertex is inside the guard band and in front.
  const bool inside = (f.outside[0] | f.outside[1]) == 0;
  const VertexArrays v{XY.data() + 2 * f.vbase, Z.data() + f.vbase, KF.data() + f.vbase,
                       KB.data() + f.vbase, inside ? nullptr : out.data() + f.vbase};
  std::size_t drawn = 0;
  for (const RenderMesh::Run& run : mesh.runs) {
    const Eigen::Vector3f c = rgb ? Eigen::Vector3f(rgb[0], rgb[1], rgb[2]) : run.rgb;
    const float c255[3] = {255.0f * c.x(), 255.0f * c.y(), 255.0f * c.z()};
    ClipContext ctx{&mesh, &f, v.kf, v.kb, &planes, &rows, &fb, c255, run.cull, run.outward};
    drawn += fb.fill_indexed(v, mesh.indices.data() + 3 * std::size_t(run.first), run.count, c255,
                             run.cull, run.outward, rows, &clip_and_draw, &ctx);
  }
  return drawn;
}

}  // namespace render
}  // namespace se3
