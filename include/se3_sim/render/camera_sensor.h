// A camera sensor: RGB, depth and an organized point cloud of the scene, drawn by the software
// rasterizer (render.h) into buffers allocated once.
//
// Frames. The sensor's body frame follows REP 103 (x forward, y left, z up); its images and
// cloud are in the optical frame (z forward, x right, y down): optical_in_body() is the rotation
// between them. render() takes the optical frame's world pose.
//
// The pinhole. fx = fy = (width / 2) / tan(hfov / 2). CameraInfo's convention (OpenCV's, as
// image_geometry reads it) puts pixel (i, j)'s centre at (i, j), so cx = (width - 1) / 2 and
// cy = (height - 1) / 2: a point at optical (x, y, z) is drawn in the pixel nearest to
// (fx x / z + cx, fy y / z + cy), exactly where the rasterizer (pixel centres at i + 0.5)
// covers it. P = [K | 0] (no stereo baseline, no distortion).
//
// Depth (REP 118): 32-bit floats, metres along the optical axis (z, not the ray's length), NaN
// where nothing is hit, nearer than the near clip or beyond the far clip. The rasterizer's depth
// buffer holds 1 / z interpolated in screen space (exact for planar faces up to float
// rounding); the ground plane z = 0 (the renderer always draws it) gets its depth from the ray's
// intersection when CameraSensorSpec::ground is set.
//
// The cloud: width x height points (row-major, as the image), four floats each: x y z in the
// optical frame (metres; NaN x y z where the depth is NaN) and the pixel's colour as
// sensor_msgs/PointCloud2's packed "rgb" float (the bits 0x00RRGGBB): a PointCloud2 with
// point_step 16 is a copy of cloud().
//
// The image is the sky, the ground plane and what stands on it (no grid lines, no overlay).
// A depth camera can skip colour (CameraSensorSpec::color, set_color): the rasterizer then
// writes depth alone.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "se3_sim/render/render.h"

namespace se3 {
namespace render {

struct CameraSensorSpec {
  int width = 640;
  int height = 480;
  double hfov = 1.047;  ///< horizontal field of view, rad (Gazebo's default 60 deg)
  double near = 0.05;   ///< m
  double far = 10.0;    ///< m
  bool depth = true;    ///< depth image and cloud too (else RGB only)
  bool ground = true;   ///< the ground plane z = 0 returns depth
  /// The rgb image and the cloud's colour; false (with depth): depth and cloud alone, nothing
  /// shaded (the same depth and points, bit for bit; the cloud's rgb 0).
  bool color = true;
};

/// CameraInfo's matrices (row-major) for an image of width x height.
struct CameraIntrinsics {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::array<double, 9> K{};
  std::array<double, 12> P{};
};

/// fx, fy, cx, cy, K and P of a spec (the convention of the header comment).
CameraIntrinsics camera_intrinsics(const CameraSensorSpec& spec);

/// The optical frame's axes in the body frame (REP 103 body, x forward, z up): columns are
/// optical x (right) = -y, optical y (down) = -z, optical z (forward) = x.
Mat3 optical_in_body();

/// Whether spec is usable: sizes in [1, 8192], 0 < hfov < pi, 0 < near < far, all finite. On
/// false *error names the field.
bool check_camera_spec(const CameraSensorSpec& spec, std::string* error);

/// The draw item of a shape (a scene object's: tessellated, in one colour rgb in [0, 1]) on
/// frame `body`, drawn at render()'s oMb[body] (the simulator's objects follow its bodies:
/// object j of Simulator::object_specs() on frame model.n + 1 + j, at its pose in objects()).
DrawItem shape_item(const Shape& shape, const Eigen::Vector3f& rgb, int body,
                    const std::string& name);

/// Where CameraSensor::render writes a frame, output by output (null: its own buffer): rgb
/// width * height * 3 bytes, depth width * height floats, cloud width * height * 4 floats.
struct CameraOutputs {
  uint8_t* rgb = nullptr;
  float* depth = nullptr;
  float* cloud = nullptr;
};

class CameraSensor {
 public:
  /// Allocates every buffer (spec must pass check_camera_spec; bad values are clamped).
  explicit CameraSensor(const CameraSensorSpec& spec);
  const CameraSensorSpec& spec() const { return spec_; }
  const CameraIntrinsics& intrinsics() const { return intr_; }
  /// Whether the next frames draw colour (rgb() and the cloud's rgb); ignored without depth
  /// (an RGB camera always draws colour). rgb() keeps its last colour frame while off.
  void set_color(bool on) { color_ = on || !spec_.depth; }
  bool color() const { return color_; }

  /// What is drawn (allocates; not per frame).
  void set_items(std::vector<DrawItem> items) { renderer_.set_items(std::move(items)); }
  void set_model(const Model& model, const GeometryModel& geometry,
                 const DrawOptions& opt = DrawOptions()) {
    renderer_.set_model(model, geometry, opt);
  }

  /// One frame seen from the optical frame at world pose oMc (z forward, x right, y down) with
  /// the bodies at oMb and the markers (scene objects drawn as box, cylinder, sphere markers
  /// write depth too). Fills rgb(), and depth() and cloud() when spec().depth. Allocates nothing.
  void render(const SE3& oMc, const std::vector<SE3>& oMb,
              const std::vector<Marker>& markers = {}) {
    render(oMc, oMb, markers, CameraOutputs());
  }
  /// The same, writing each output given in `out` there instead (rgb(), depth() or cloud() then
  /// keep their last frame): a caller's message buffers, saving a copy of the frame.
  void render(const SE3& oMc, const std::vector<SE3>& oMb, const std::vector<Marker>& markers,
              const CameraOutputs& out);

  /// rgb8, width * height * 3 bytes, rows top to bottom.
  const std::vector<uint8_t>& rgb() const { return rgb_; }
  /// 32FC1 metres (NaN: no return), width * height.
  const std::vector<float>& depth() const { return depth_; }
  /// x y z rgb per pixel, width * height * 4 floats.
  const std::vector<float>& cloud() const { return cloud_; }
  Renderer& renderer() { return renderer_; }

 private:
  CameraSensorSpec spec_;
  CameraIntrinsics intr_;
  Renderer renderer_;
  std::vector<uint8_t> rgb_;
  std::vector<float> depth_, cloud_;
  std::vector<float> columns_;  ///< (i - cx) / fx per column
  bool color_ = true;
};

}  // namespace render
}  // namespace se3
