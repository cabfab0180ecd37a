// Camera sensor: the rasterizer's frame turned into rgb8, REP 118 depth and an organized cloud.
#include "se3_sim/render/camera_sensor.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <utility>

#if defined(__SSE2__)
#include <emmintrin.h>
#include <xmmintrin.h>
#endif
#if defined(__SSE2__) && defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define SE3_CAMERA_AVX2 1
#endif

namespace se3 {
namespace render {

namespace {

CameraSensorSpec clamped(CameraSensorSpec s) {
  s.width = std::clamp(s.width, 1, 8192);
  s.height = std::clamp(s.height, 1, 8192);
  if (!(s.hfov > 0 && s.hfov < M_PI)) s.hfov = 1.047;
  if (!(s.near > 0) || !std::isfinite(s.near)) s.near = 0.05;
  if (!(s.far > s.near) || !std::isfinite(s.far)) s.far = std::max(10.0, 2 * s.near);
  return s;
}

#if SE3_CAMERA_AVX2
// One row of the depth and cloud conversion eight pixels at a time, the same float operations
// lane by lane as the loops in render() (so the same bits), from column 0 while i + 8 <= W;
// returns where it stopped. The cloud's four fields of eight pixels by two 4 x 4 transposes.
// rgb8 (when not null, with paint): the row's rgb8 bytes from the colours already loaded, as
// Framebuffer::copy_rgb8 writes them, exactly 24 bytes a step; where nothing was drawn (depth
// 0) the colours are the row's background (bg_left below column split, bg_right from there:
// the renderer did not restore them).
__attribute__((target("avx2"))) int cloud_row_avx2(int W, const float* zr, const float* a,
                                                   const uint32_t* cr, bool paint, float b,
                                                   float gb, float gx, float h, float near,
                                                   float far, float* dr, float* pr, uint8_t* rgb8,
                                                   int split, uint32_t bg_left, uint32_t bg_right) {
  const __m256i to_rgb = _mm256_setr_epi8(2, 1, 0, 6, 5, 4, 10, 9, 8, 14, 13, 12, -1, -1, -1, -1, 2,
                                          1, 0, 6, 5, 4, 10, 9, 8, 14, 13, 12, -1, -1, -1, -1);
  const __m256 vnan = _mm256_set1_ps(std::numeric_limits<float>::quiet_NaN());
  const __m256 vnear = _mm256_set1_ps(near), vfar = _mm256_set1_ps(far);
  const __m256 vzero = _mm256_setzero_ps(), vone = _mm256_set1_ps(1.0f);
  const __m256 vnh = _mm256_set1_ps(-h), vgx = _mm256_set1_ps(gx), vgb = _mm256_set1_ps(gb);
  const __m256 vb = _mm256_set1_ps(b);
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i vsplit = _mm256_set1_epi32(split);
  const __m256 vleft = _mm256_castsi256_ps(_mm256_set1_epi32(int32_t(bg_left)));
  const __m256 vright = _mm256_castsi256_ps(_mm256_set1_epi32(int32_t(bg_right)));
  int i = 0;
  for (; i + 8 <= W; i += 8) {
    const __m256 iz = _mm256_loadu_ps(zr + i);
    const __m256 va = _mm256_loadu_ps(a + i);
    const __m256 zg = _mm256_div_ps(vnh, _mm256_add_ps(_mm256_mul_ps(vgx, va), vgb));
    const __m256 hit = _mm256_cmp_ps(iz, vzero, _CMP_GT_OQ);
    const __m256 z = _mm256_blendv_ps(zg, _mm256_div_ps(vone, iz), hit);
    const __m256 ok =
        _mm256_and_ps(_mm256_cmp_ps(z, vnear, _CMP_GE_OQ), _mm256_cmp_ps(z, vfar, _CMP_LE_OQ));
    const __m256 zz = _mm256_blendv_ps(vnan, z, ok);
    _mm256_storeu_ps(dr + i, zz);
    const __m256 x = _mm256_mul_ps(va, zz), y = _mm256_mul_ps(vb, zz);
    __m256 c =
        paint ? _mm256_castsi256_ps(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(cr + i)))
              : vzero;
    if (rgb8) {
      const __m256 left = _mm256_castsi256_ps(
          _mm256_cmpgt_epi32(vsplit, _mm256_add_epi32(_mm256_set1_epi32(i), lane)));
      c = _mm256_blendv_ps(_mm256_blendv_ps(vright, vleft, left), c, hit);
      const __m256i s = _mm256_shuffle_epi8(_mm256_castps_si256(c), to_rgb);
      const __m128i lo = _mm256_castsi256_si128(s), hi = _mm256_extracti128_si256(s, 1);
      const uint32_t lo2 = uint32_t(_mm_extract_epi32(lo, 2));
      const uint32_t hi2 = uint32_t(_mm_extract_epi32(hi, 2));
      uint8_t* o = rgb8 + 3 * i;
      _mm_storel_epi64(reinterpret_cast<__m128i*>(o), lo);
      std::memcpy(o + 8, &lo2, 4);
      _mm_storel_epi64(reinterpret_cast<__m128i*>(o + 12), hi);
      std::memcpy(o + 20, &hi2, 4);
    }
    const __m256 t0 = _mm256_unpacklo_ps(x, y), t1 = _mm256_unpackhi_ps(x, y);
    const __m256 t2 = _mm256_unpacklo_ps(zz, c), t3 = _mm256_unpackhi_ps(zz, c);
    // r_k: pixel k in the low half, pixel k + 4 in the high half.
    const __m256 r0 = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(1, 0, 1, 0));
    const __m256 r1 = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(3, 2, 3, 2));
    const __m256 r2 = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(1, 0, 1, 0));
    const __m256 r3 = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(3, 2, 3, 2));
    float* p = pr + 4 * i;
    _mm256_storeu_ps(p, _mm256_permute2f128_ps(r0, r1, 0x20));
    _mm256_storeu_ps(p + 8, _mm256_permute2f128_ps(r2, r3, 0x20));
    _mm256_storeu_ps(p + 16, _mm256_permute2f128_ps(r0, r1, 0x31));
    _mm256_storeu_ps(p + 24, _mm256_permute2f128_ps(r2, r3, 0x31));
  }
  return i;
}
#endif

}  // namespace

CameraIntrinsics camera_intrinsics(const CameraSensorSpec& spec) {
  CameraIntrinsics c;
  c.width = spec.width;
  c.height = spec.height;
  c.fx = c.fy = 0.5 * spec.width / std::tan(0.5 * spec.hfov);
  c.cx = 0.5 * (spec.width - 1);
  c.cy = 0.5 * (spec.height - 1);
  c.K = {c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1};
  c.P = {c.fx, 0, c.cx, 0, 0, c.fy, c.cy, 0, 0, 0, 1, 0};
  return c;
}

Mat3 optical_in_body() {
  Mat3 R;
  R << 0, 0, 1,  //
      -1, 0, 0,  //
      0, -1, 0;
  return R;
}

bool check_camera_spec(const CameraSensorSpec& s, std::string* error) {
  auto fail = [&](const std::string& why) {
    if (error) *error = why;
    return false;
  };
  if (s.width < 1 || s.width > 8192) return fail("width must be in [1, 8192]");
  if (s.height < 1 || s.height > 8192) return fail("height must be in [1, 8192]");
  if (!(s.hfov > 0 && s.hfov < M_PI)) return fail("horizontal_fov must be in (0, pi) rad");
  if (!(s.near > 0) || !std::isfinite(s.near)) return fail("near must be > 0 (m)");
  if (!(s.far > s.near) || !std::isfinite(s.far)) return fail("far must be finite and > near");
  return true;
}

DrawItem shape_item(const Shape& shape, const Eigen::Vector3f& rgb, int body,
                    const std::string& name) {
  DrawItem it;
  it.body = body;
  it.name = it.link = name;
  it.shape = shape.type;
  it.color = rgb.cast<double>();
  it.mesh = std::make_shared<RenderMesh>(make_render_mesh(tessellate(shape), Vec3::Ones(), rgb));
  return it;
}

CameraSensor::CameraSensor(const CameraSensorSpec& spec)
    : spec_(clamped(spec)), intr_(camera_intrinsics(spec_)), color_(spec_.color || !spec_.depth) {
  Camera cam;
  cam.width = spec_.width;
  cam.height = spec_.height;
  cam.focal_px = intr_.fx;
  cam.near = spec_.near;
  renderer_.set_camera(cam);
  renderer_.style().overlay = false;
  renderer_.style().frames = false;
  // A camera sees the ground plane, not the viewer's grid lines (which would also cost a
  // quarter of a frame wherever the camera moves).
  renderer_.style().grid = false;
  renderer_.style().threads = 1;
  const std::size_t n = std::size_t(spec_.width) * spec_.height;
  rgb_.assign(3 * n, 0);
  if (spec_.depth) {
    depth_.assign(n, std::numeric_limits<float>::quiet_NaN());
    cloud_.assign(4 * n, std::numeric_limits<float>::quiet_NaN());
    columns_.resize(spec_.width);
    for (int i = 0; i < spec_.width; ++i) columns_[i] = float((i - intr_.cx) / intr_.fx);
  }
}

void CameraSensor::render(const SE3& oMc, const std::vector<SE3>& oMb,
                          const std::vector<Marker>& markers, const CameraOutputs& out) {
  uint8_t* const rgb_out = out.rgb ? out.rgb : rgb_.data();
  Camera cam = renderer_.camera();
  cam.eye = oMc.p;
  cam.target = oMc.p + oMc.R.col(2);
  cam.up = -oMc.R.col(1);
  renderer_.set_camera(cam);
  // With depth on the AVX2 path (whole groups of eight a row) the rgb8 bytes come out of the
  // depth and cloud pass, which reads the colours anyway (one pass over the frame instead of
  // two) and takes the background's colours where the depth says nothing was drawn: the
  // renderer need not restore them.
#if SE3_CAMERA_AVX2
  const bool fused = color_ && spec_.depth && spec_.width % 8 == 0 &&
                     std::as_const(renderer_).framebuffer().path() == RasterPath::Avx2;
#else
  const bool fused = false;
#endif
  renderer_.style().paint = color_;
  renderer_.style().keep_background = !fused;
  renderer_.render(oMb, markers);
  if (color_ && !fused) renderer_.copy_rgb8(rgb_out);
  if (!spec_.depth) return;
  float* const depth_out = out.depth ? out.depth : depth_.data();
  float* const cloud_out = out.cloud ? out.cloud : cloud_.data();

  // Read through a const Renderer: its non-const framebuffer() drops the cached background.
  const Renderer& r = renderer_;
  const Camera& c = r.camera();
  const Framebuffer& fb = r.framebuffer();
  const int W = spec_.width, H = spec_.height;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float near = float(spec_.near), far = float(spec_.far);
  // Ground: the ray through (a, b, 1) (optical) meets z = 0 at depth -eye_z / (g . (a, b, 1)),
  // g the world z axis in optical coordinates; no ground: a negative depth (never valid).
  const Vec3 g = c.R_wc.row(2).transpose();
  const bool ground = spec_.ground && std::isfinite(c.eye.z());
  const float h = ground ? float(c.eye.z()) : 0.0f;
  const float gx = ground ? float(g.x()) : 0.0f;
  const float* zbuf = fb.depth();
  const uint32_t* color = fb.color();
  const bool paint = color_;
  const float* a = columns_.data();
#if SE3_CAMERA_AVX2
  const bool avx2 = r.framebuffer().path() == RasterPath::Avx2;
#endif
  // Float throughout and no branches in the row loop (the compiler vectorizes it): 1 / iz in
  // float is within 6e-8 relative of the depth buffer's value.
  for (int j = 0; j < H; ++j) {
    const float b = float((j - intr_.cy) / intr_.fy);
    const float gb = ground ? float(g.y() * b + g.z()) : 1.0f;
    const std::size_t row = std::size_t(j) * W;
    const float* zr = zbuf + row;
    float* dr = depth_out + row;
    float* pr = cloud_out + 4 * row;
    const uint32_t* cr = color + row;
    int i = 0;
#if SE3_CAMERA_AVX2
    if (avx2) {
      uint8_t* rgb8 = fused ? rgb_out + 3 * row : nullptr;
      int split = 0;
      uint32_t left = 0, right = 0;
      if (fused) r.background_row(j, split, left, right);
      i = cloud_row_avx2(W, zr, a, cr, paint, b, gb, gx, h, near, far, dr, pr, rgb8, split, left,
                         right);  // all of the row when fused (W a multiple of 8)
    }
#endif
#if defined(__SSE2__)
    // Four pixels at a time, the same float operations as the loop below (the same bits); the
    // cloud's four fields of four pixels by one transpose.
    const __m128 vnan = _mm_set1_ps(nan), vnear = _mm_set1_ps(near), vfar = _mm_set1_ps(far);
    const __m128 vzero = _mm_setzero_ps(), vone = _mm_set1_ps(1.0f), vnh = _mm_set1_ps(-h);
    const __m128 vgx = _mm_set1_ps(gx), vgb = _mm_set1_ps(gb), vb = _mm_set1_ps(b);
    for (; i + 4 <= W; i += 4) {  // the AVX2 loop's remainder, or all without AVX2
      const __m128 iz = _mm_loadu_ps(zr + i);
      const __m128 va = _mm_loadu_ps(a + i);
      const __m128 zg = _mm_div_ps(vnh, _mm_add_ps(_mm_mul_ps(vgx, va), vgb));
      const __m128 hit = _mm_cmpgt_ps(iz, vzero);
      const __m128 z = _mm_or_ps(_mm_and_ps(hit, _mm_div_ps(vone, iz)), _mm_andnot_ps(hit, zg));
      const __m128 ok = _mm_and_ps(_mm_cmpge_ps(z, vnear), _mm_cmple_ps(z, vfar));
      __m128 zz = _mm_or_ps(_mm_and_ps(ok, z), _mm_andnot_ps(ok, vnan));
      _mm_storeu_ps(dr + i, zz);
      __m128 x = _mm_mul_ps(va, zz), y = _mm_mul_ps(vb, zz);
      __m128 c = paint ? _mm_castsi128_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(cr + i)))
                       : vzero;
      _MM_TRANSPOSE4_PS(x, y, zz, c);
      _mm_storeu_ps(pr + 4 * i, x);
      _mm_storeu_ps(pr + 4 * i + 4, y);
      _mm_storeu_ps(pr + 4 * i + 8, zz);
      _mm_storeu_ps(pr + 4 * i + 12, c);
    }
#endif
    for (; i < W; ++i) {
      const float iz = zr[i];
      const float den = gx * a[i] + gb;
      const float zg = -h / den;  // no ground: -0; parallel: +-Inf or NaN, never in the clip
      const float z = iz > 0.0f ? 1.0f / iz : zg;
      const bool ok = z >= near && z <= far;
      const float zz = ok ? z : nan;
      dr[i] = zz;
      pr[4 * i + 0] = a[i] * zz;
      pr[4 * i + 1] = b * zz;
      pr[4 * i + 2] = zz;
      const uint32_t rgb = paint ? cr[i] : 0u;
      std::memcpy(&pr[4 * i + 3], &rgb, sizeof(float));
    }
  }
}

}  // namespace render
}  // namespace se3
