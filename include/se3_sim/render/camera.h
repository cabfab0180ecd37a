// The pinhole camera of the renderer and the projective geometry of section 3 of Reuss 2002.
//
// Points are homogeneous in RP^3 (section 3.1): X = (x, y, z, s), s = 0 for points at infinity
// (directions). Every transformation is a 4x4 operator and they compose by products, X_0 =
// T_1 T_2 ... T_n X_n. The camera maps a world point X to clip coordinates
//
//   C = P X = (U, V, S, W),  P = K4 * T_cw,
//
// with T_cw the world-to-camera operator (camera frame: x right, y down, z forward, the ROS
// optical frame) and K4 = [f 0 cx 0; 0 f cy 0; 0 0 0 1; 0 0 1 0]. Hence the pixel is
// (U/W, V/W), S/W = s/z is the inverse depth (0 for a point at infinity) and W = z is the depth
// along the optical axis. Pixel (0, 0) is the top-left corner of the top-left pixel; the centre
// of pixel (i, j) is (i + 0.5, j + 0.5). camera_info: K = [f 0 cx; 0 f cy; 0 0 1], no
// distortion.
//
// Clipping happens on C, before any division: the near plane is W - near S >= 0, so a segment
// that passes behind the eye is cut where it crosses the near plane and never wraps around
// through infinity. A ray to a point at infinity (s = 0) is an ordinary segment of RP^3 here.
//
// The painter's perspective (section 3.3): the horizon of the ground plane z = 0 is the line
// through the images of two of its points at infinity, (1, 0, 0, 0) and (0, 1, 0, 0), which are
// the vanishing points of the ground grid's two line families.
#pragma once

#include <Eigen/Core>

#include "se3_sim/lie/lie.h"

namespace se3 {
namespace render {

using Vec2 = Eigen::Vector2d;
using Vec4 = Eigen::Vector4d;

struct Camera {
  int width = 1280;
  int height = 1024;
  double focal_px = 1000.0;  ///< fx = fy, pixels
  double near = 0.02;        ///< near clipping distance, metres
  Vec3 eye = Vec3(2.2, -1.8, 1.3);
  Vec3 target = Vec3(0.0, 0.0, 0.45);
  Vec3 up = Vec3(0, 0, 1);

  /// Principal point: the image centre.
  double cx() const { return 0.5 * width; }
  double cy() const { return 0.5 * height; }

  // ---- derived by update()
  Mat3 R_wc = Mat3::Identity();  ///< columns: camera x (right), y (down), z (forward) in world
  Mat4 T_cw = Mat4::Identity();  ///< world -> camera operator on RP^3
  Mat4 P = Mat4::Identity();     ///< world -> clip (U, V, S, W)

  /// Recomputes R_wc, T_cw and P from eye, target, up, focal_px and the image size. A
  /// degenerate pose (eye == target, or up along the view) falls back to a valid one and
  /// returns false. Always call after changing a field.
  bool update();

  /// Clip coordinates of a homogeneous world point.
  Vec4 clip(const Vec4& X) const { return P * X; }
  Vec4 clip(const Vec3& x) const { return P * Vec4(x.x(), x.y(), x.z(), 1.0); }
  /// Pixel of a finite world point; false (pixel untouched) when it is not in front of the
  /// near plane.
  bool project(const Vec3& x, Vec2& pixel, double* inv_depth = nullptr) const;
  /// Homogeneous image point (U, V, W) of a direction d seen as the point at infinity
  /// (d, 0): the vanishing point of every line with direction d. Its pixel is (U/W, V/W)
  /// when W > 0; W = 0 means the vanishing point is itself at infinity in the image.
  Eigen::Vector3d vanishing_point(const Vec3& d) const;
  /// The horizon of the ground plane z = 0: the image line l = vp(e_x) x vp(e_y), scaled so
  /// that l . (u, v, 1) has the sign of the world z component of the viewing ray through
  /// pixel (u, v) (negative: the ray goes down). A camera looking straight down gets the
  /// line at infinity of the image, (0, 0, c).
  Eigen::Vector3d horizon_line() const;
  /// Unit world direction of the viewing ray through pixel (u, v).
  Vec3 ray(double u, double v) const;

  /// Orbit about the target: yaw about world z, pitch (elevation) clamped to +-89 deg,
  /// distance multiplied by `zoom` (clamped to [near * 10, 1e4]).
  void orbit(double yaw, double pitch, double zoom);
};

/// Clipping planes used on clip coordinates: the near plane and a guard band around the
/// image (the guard keeps every coordinate small without changing what is drawn).
struct ClipPlanes {
  Vec4 plane[5];
  int count = 5;
  explicit ClipPlanes(const Camera& cam, double guard_px = 64.0);
};

/// Sutherland-Hodgman clipping of a convex polygon given by clip coordinates; out must hold
/// n + planes.count vertices. Returns the number of output vertices (0 if invisible).
int clip_polygon(const ClipPlanes& planes, const Vec4* in, int n, Vec4* out);
/// Clips the segment a-b of RP^3, the points (1 - t) a + t b for t in [0, 1] (with s >= 0
/// representatives: the finite segment, or the ray from a finite point to a point at
/// infinity), to the visible half-spaces. Returns false if nothing is left.
bool clip_segment(const ClipPlanes& planes, Vec4& a, Vec4& b);

}  // namespace render
}  // namespace se3
