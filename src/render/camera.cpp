// Camera, projection in RP^3 and clipping in homogeneous coordinates (section 3 of Reuss 2002).
#include "se3_sim/render/camera.h"

#include <algorithm>
#include <cmath>

namespace se3 {
namespace render {

namespace {

bool finite3(const Vec3& v) {
  return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z());
}

}  // namespace

bool Camera::update() {
  bool ok = true;
  if (width < 1 || height < 1) {
    width = std::max(width, 1);
    height = std::max(height, 1);
    ok = false;
  }
  if (!(focal_px > 0) || !std::isfinite(focal_px)) {
    focal_px = 1000.0;
    ok = false;
  }
  if (!(near > 0) || !std::isfinite(near)) {
    near = 0.02;
    ok = false;
  }
  if (!finite3(eye)) {
    eye = Vec3(2.2, -1.8, 1.3);
    ok = false;
  }
  if (!finite3(target)) {
    target = Vec3::Zero();
    ok = false;
  }
  Vec3 fwd = target - eye;
  if (!(fwd.norm() > 1e-9)) {
    fwd = Vec3(0, 1, 0);
    target = eye + fwd;
    ok = false;
  }
  fwd.normalize();
  Vec3 u = finite3(up) ? up : Vec3(0, 0, 1);
  Vec3 right = fwd.cross(u);
  if (!(right.norm() > 1e-9 * std::max(1.0, u.norm()))) {
    // Looking along up: any perpendicular serves; keep world y (then x) as the image "down".
    right = fwd.cross(std::abs(fwd.y()) < 0.9 ? Vec3(0, 1, 0) : Vec3(1, 0, 0));
    ok = ok && u.norm() > 0;
  }
  right.normalize();
  const Vec3 down = fwd.cross(right);
  R_wc.col(0) = right;
  R_wc.col(1) = down;
  R_wc.col(2) = fwd;

  T_cw.setIdentity();
  T_cw.topLeftCorner<3, 3>() = R_wc.transpose();
  T_cw.topRightCorner<3, 1>() = -(R_wc.transpose() * eye);

  Mat4 K4 = Mat4::Zero();
  K4(0, 0) = focal_px;
  K4(0, 2) = cx();
  K4(1, 1) = focal_px;
  K4(1, 2) = cy();
  K4(2, 3) = 1.0;  // S = s
  K4(3, 2) = 1.0;  // W = z
  P = K4 * T_cw;
  return ok;
}

bool Camera::project(const Vec3& x, Vec2& pixel, double* inv_depth) const {
  const Vec4 c = clip(x);
  if (!(c.w() >= near)) return false;
  pixel = Vec2(c.x() / c.w(), c.y() / c.w());
  if (inv_depth) *inv_depth = c.z() / c.w();
  return true;
}

Eigen::Vector3d Camera::vanishing_point(const Vec3& d) const {
  const Vec4 c = P * Vec4(d.x(), d.y(), d.z(), 0.0);
  return Eigen::Vector3d(c.x(), c.y(), c.w());
}

Eigen::Vector3d Camera::horizon_line() const {
  // The painter's construction: the ground plane's line at infinity through the images of
  // two of its points at infinity (s = 0).
  Eigen::Vector3d l = vanishing_point(Vec3::UnitX()).cross(vanishing_point(Vec3::UnitY()));
  // Orientation: l . (u, v, 1) must grow with the world z of the viewing ray. The ray through
  // pixel p has direction R_wc K^-1 p, and its world z is linear in p: compare with it.
  const Eigen::Vector3d zc = R_wc.row(2).transpose();  // world z in camera coordinates
  const Eigen::Vector3d ref(zc.x() / focal_px, zc.y() / focal_px,
                            zc.z() - (zc.x() * cx() + zc.y() * cy()) / focal_px);
  if (l.dot(ref) < 0) l = -l;
  return l;
}

Vec3 Camera::ray(double u, double v) const {
  return (R_wc * Vec3((u - cx()) / focal_px, (v - cy()) / focal_px, 1.0)).normalized();
}

void Camera::orbit(double yaw, double pitch, double zoom) {
  if (!std::isfinite(yaw)) yaw = 0;
  if (!std::isfinite(pitch)) pitch = 0;
  if (!(zoom > 0) || !std::isfinite(zoom)) zoom = 1;
  Vec3 d = eye - target;
  double r = d.norm();
  if (!(r > 1e-9)) {
    d = Vec3(1, 0, 0);
    r = 1;
  }
  double az = std::atan2(d.y(), d.x()) + yaw;
  const double lim = 89.0 * M_PI / 180.0;
  double el = std::asin(std::clamp(d.z() / r, -1.0, 1.0)) + pitch;
  el = std::clamp(el, -lim, lim);
  r = std::clamp(r * zoom, near * 10.0, 1e4);
  eye = target + r * Vec3(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
  update();
}

ClipPlanes::ClipPlanes(const Camera& cam, double guard_px) {
  const double x0 = -guard_px, x1 = cam.width + guard_px;
  const double y0 = -guard_px, y1 = cam.height + guard_px;
  // A visible point C = (U, V, S, W) has plane . C >= 0 for each plane.
  plane[0] = Vec4(0, 0, -cam.near, 1);  // W - near S >= 0 (in front of the near plane)
  plane[1] = Vec4(1, 0, 0, -x0);        // U >= x0 W
  plane[2] = Vec4(-1, 0, 0, x1);        // U <= x1 W
  plane[3] = Vec4(0, 1, 0, -y0);
  plane[4] = Vec4(0, -1, 0, y1);
}

int clip_polygon(const ClipPlanes& planes, const Vec4* in, int n, Vec4* out) {
  // Ping-pong between two small buffers; a convex polygon gains at most one vertex a plane.
  constexpr int kMax = 16;
  Vec4 buf[2][kMax];
  if (n > kMax - planes.count) return 0;
  int cnt = n;
  for (int i = 0; i < n; ++i) buf[0][i] = in[i];
  int cur = 0;
  for (int p = 0; p < planes.count; ++p) {
    const Vec4& pl = planes.plane[p];
    const Vec4* src = buf[cur];
    Vec4* dst = buf[1 - cur];
    int m = 0;
    for (int i = 0; i < cnt; ++i) {
      const Vec4& a = src[i];
      const Vec4& b = src[(i + 1) % cnt];
      const double da = pl.dot(a), db = pl.dot(b);
      if (da >= 0) dst[m++] = a;
      if ((da >= 0) != (db >= 0)) {
        const double t = da / (da - db);
        dst[m++] = a + t * (b - a);
      }
    }
    cnt = m;
    cur = 1 - cur;
    if (cnt < 3) return 0;
  }
  for (int i = 0; i < cnt; ++i) out[i] = buf[cur][i];
  return cnt;
}

bool clip_segment(const ClipPlanes& planes, Vec4& a, Vec4& b) {
  double t0 = 0, t1 = 1;
  const Vec4 d = b - a;
  for (int p = 0; p < planes.count; ++p) {
    const double da = planes.plane[p].dot(a), dd = planes.plane[p].dot(d);
    // plane . (a + t d) = da + t dd >= 0
    if (dd == 0) {
      if (da < 0) return false;
    } else if (dd > 0) {
      t0 = std::max(t0, -da / dd);
    } else {
      t1 = std::min(t1, -da / dd);
    }
    if (!(t0 <= t1)) return false;
  }
  const Vec4 a0 = a;
  a = a0 + t0 * d;
  b = a0 + t1 * d;
  return a.w() > 0 && b.w() > 0;
}

}  // namespace render
}  // namespace se3
