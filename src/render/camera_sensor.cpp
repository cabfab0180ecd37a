// Camera sensor: the rasterizer's frame turned into rgb8, REP 118 depth and an organized cloud.
#include "se3_sim/render/camera_sensor.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#if defined(__SSE2__)
#include <emmintrin.h>
#include <xmmintrin.h>
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

CameraSensor::CameraSensor(const CameraSensorSpec& spec)
    : spec_(clamped(spec)), intr_(camera_intrinsics(spec_)) {
  Camera cam;
  cam.width = spec_.width;
  cam.height = spec_.height;
  cam.focal_px = intr_.fx;
  cam.near = spec_.near;
  renderer_.set_camera(cam);
  renderer_.style().overlay = false;
  renderer_.style().frames = false;
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
                          const std::vector<Marker>& markers) {
  Camera cam = renderer_.camera();
  cam.eye = oMc.p;
  cam.target = oMc.p + oMc.R.col(2);
  cam.up = -oMc.R.col(1);
  renderer_.set_camera(cam);
  renderer_.render(oMb, markers);
  renderer_.copy_rgb8(rgb_.data());
  if (!spec_.depth) return;

  const Camera& c = renderer_.camera();
  const Framebuffer& fb = renderer_.framebuffer();
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
  const float* a = columns_.data();
  // Float throughout and no branches in the row loop (the compiler vectorizes it): 1 / iz in
  // float is within 6e-8 relative of the depth buffer's value.
  for (int j = 0; j < H; ++j) {
    const float b = float((j - intr_.cy) / intr_.fy);
    const float gb = ground ? float(g.y() * b + g.z()) : 1.0f;
    const std::size_t row = std::size_t(j) * W;
    const float* zr = zbuf + row;
    float* dr = depth_.data() + row;
    float* pr = cloud_.data() + 4 * row;
    const uint32_t* cr = color + row;
    int i = 0;
#if defined(__SSE2__)
    // Four pixels at a time, the same float operations as the loop below (the same bits); the
    // cloud's four fields of four pixels by one transpose.
    const __m128 vnan = _mm_set1_ps(nan), vnear = _mm_set1_ps(near), vfar = _mm_set1_ps(far);
    const __m128 vzero = _mm_setzero_ps(), vone = _mm_set1_ps(1.0f), vnh = _mm_set1_ps(-h);
    const __m128 vgx = _mm_set1_ps(gx), vgb = _mm_set1_ps(gb), vb = _mm_set1_ps(b);
    for (; i + 4 <= W; i += 4) {
      const __m128 iz = _mm_loadu_ps(zr + i);
      const __m128 va = _mm_loadu_ps(a + i);
      const __m128 zg = _mm_div_ps(vnh, _mm_add_ps(_mm_mul_ps(vgx, va), vgb));
      const __m128 hit = _mm_cmpgt_ps(iz, vzero);
      const __m128 z = _mm_or_ps(_mm_and_ps(hit, _mm_div_ps(vone, iz)), _mm_andnot_ps(hit, zg));
      const __m128 ok = _mm_and_ps(_mm_cmpge_ps(z, vnear), _mm_cmple_ps(z, vfar));
      __m128 zz = _mm_or_ps(_mm_and_ps(ok, z), _mm_andnot_ps(ok, vnan));
      _mm_storeu_ps(dr + i, zz);
      __m128 x = _mm_mul_ps(va, zz), y = _mm_mul_ps(vb, zz);
      __m128 c = _mm_castsi128_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(cr + i)));
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
      std::memcpy(&pr[4 * i + 3], &cr[i], sizeof(float));
    }
  }
}

}  // namespace render
}  // namespace se3
