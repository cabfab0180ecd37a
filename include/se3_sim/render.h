// The renderer: draws a model (or any set of body poses) in linear perspective into a
// 1280x1024 RGB image, over a sky and a ground grid that runs to the horizon (the painter's
// perspective of section 3.3 of Reuss 2002), with markers, link frames and a text overlay.
// No roscpp here; the ROS node (src/nodes/renderer_node.cpp) only feeds it poses from TF.
//
// ---- For `se3_dyn render MODEL.urdf [--floating] [--scene S] [--camera ...] --out frame.png`
//
//   #include "se3_sim/render.h"
//   se3::render::RenderOptions opt;            // camera, pose, overlay, markers
//   opt.base = f0;                              // base pose in the world (default identity)
//   opt.q = q;                                  // joint positions (size model.n; empty = 0)
//   opt.auto_camera = true;                     // frame the robot (ignores opt.camera's pose)
//   std::string err;                            // or: parse_camera_spec(arg, opt, &err)
//   int rc = se3::render::render_to_png(model, opt, "frame.png", &err);  // 0 = written
//
// render_to_png runs se3::forward_kinematics, draws one frame and writes a PNG; it returns
// 0 on success and 1 with a one-line reason in *error otherwise (it never throws for bad
// options). `--camera` is parsed by parse_camera_spec: "ex,ey,ez,tx,ty,tz[,focal_px]" (eye
// and look-at target in metres, optional focal length in pixels), which also turns
// auto_camera off.
//
// ---- The renderer node's camera command (topic renderer/camera_command, geometry_msgs/Twist)
//
//   angular.z: yaw step (rad) of the eye about the target, around world z (positive = the
//              eye moves counter-clockwise seen from above);
//   angular.y: pitch step (rad): raises the eye (elevation clamped to +-89 deg);
//   linear.x:  zoom delta: the eye-target distance is multiplied by (1 - linear.x)
//              (0.1 = 10 % closer; clamped to a factor in [0.1, 10]);
//   linear.y, linear.z: pan the target (and eye) along the camera's right and world up, metres.
//   Each message is one step (not a rate). Non-finite fields are ignored.
#pragma once

#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "se3_sim/dynamics.h"
#include "se3_sim/model.h"
#include "se3_sim/render/camera.h"
#include "se3_sim/render/raster.h"

namespace se3 {
namespace render {

/// A marker in world coordinates (the simple form of visualization_msgs/Marker).
struct Marker {
  enum class Type { Point, Sphere, Arrow, Line, Box };
  Type type = Type::Point;
  Vec3 a = Vec3::Zero();  ///< position (point, sphere, box centre) or start (arrow, line)
  Vec3 b = Vec3::Zero();  ///< end (arrow, line)
  /// Point: diameter in pixels; sphere: diameter (m); arrow: shaft diameter (m); line: width in
  /// pixels; box: full extents along its axes R (m, all three entries of size3).
  double size = 0.02;
  Vec3 size3 = Vec3::Constant(0.1);
  Mat3 R = Mat3::Identity();  ///< box: orientation in the world (columns: its axes)
  Eigen::Vector3d color = Eigen::Vector3d(1.0, 0.3, 0.1);  ///< rgb in [0, 1]
};

/// Text drawn at the top-left corner; NaN / empty fields are left out.
struct Overlay {
  double sim_time = std::numeric_limits<double>::quiet_NaN();
  double real_time_factor = std::numeric_limits<double>::quiet_NaN();
  std::string joint;  ///< selected joint
  double torque = std::numeric_limits<double>::quiet_NaN();
  std::vector<std::string> lines;  ///< extra lines
};

struct Style {
  bool grid = true;
  double grid_spacing = 0.5;  ///< metres between grid lines
  int grid_lines = 20;        ///< lines of each family on each side of the origin
  bool frames = false;        ///< link frames as short axes
  double frame_length = 0.1;  ///< metres
  bool overlay = true;
  Eigen::Vector3d light = Eigen::Vector3d(0.35, -0.45, 0.82);  ///< towards the light (world)
};

/// What the renderer draws for one visual: a primitive whose frame sits at `local` in its
/// body frame, with full extents `size` (box: x y z; cylinder: 2r, 2r, length along z;
/// sphere: 2r, 2r, 2r), as RViz markers take them. Mesh visuals become stand-ins (the link's
/// collision primitive, else cylinders from the body origin to its children's joints).
struct DrawItem {
  enum class Shape { Box, Cylinder, Sphere };
  Shape shape = Shape::Box;
  int body = 0;
  SE3 local;
  Vec3 size = Vec3::Ones();
  Eigen::Vector3d color = Eigen::Vector3d(0.8, 0.8, 0.8);
  std::string link;
};

/// The draw list of a model (visuals with mesh stand-ins). Deterministic; used by the renderer
/// and by the node for its RViz MarkerArray.
std::vector<DrawItem> make_draw_items(const Model& model);

/// Chooses an eye and target that show bodies at the given poses and the box markers among
/// boxes (and the ground) from a three-quarter view; keeps cam's image size and focal length.
void frame_bodies(const Model& model, const std::vector<SE3>& oMb, Camera& cam,
                  const std::vector<Marker>& boxes = {});

class Renderer {
 public:
  explicit Renderer(const Camera& cam = Camera());
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  /// Sets the camera (calls cam.update()); reallocates only when the image size changes.
  void set_camera(const Camera& cam);
  const Camera& camera() const { return cam_; }
  Style& style() { return style_; }
  /// Uses the draw list of this model from now on (allocates; not per frame).
  void set_model(const Model& model);
  const std::vector<DrawItem>& items() const { return items_; }

  /// One frame: background (sky, ground, grid to the horizon), the model's bodies at oMb
  /// (world poses of bodies 0..n; a missing or non-finite pose hides its body), markers,
  /// frames and the overlay. oMb may be empty (no model drawn).
  void render(const std::vector<SE3>& oMb, const std::vector<Marker>& markers = {},
              const Overlay& overlay = Overlay());

  // ---- the steps of render(), usable on their own
  void draw_background();  ///< sky gradient, ground, depth cleared
  void draw_grid();        ///< the ground grid's two line families, running to the horizon
  void draw_box(const SE3& pose, const Vec3& size, const Eigen::Vector3d& rgb);
  void draw_cylinder(const SE3& pose, const Vec3& size, const Eigen::Vector3d& rgb);
  void draw_sphere(const SE3& pose, const Vec3& size, const Eigen::Vector3d& rgb);
  /// Homogeneous segment a-b (s = 0 allowed for an end at infinity), clipped in RP^3.
  void draw_segment(const Vec4& a, const Vec4& b, Rgb color, float width = 1.0f,
                    bool depth_test = true, float opacity = 1.0f, float fade = 0.0f);
  void draw_marker(const Marker& m);
  void draw_overlay(const Overlay& overlay);

  const Framebuffer& framebuffer() const { return fb_; }
  Framebuffer& framebuffer() { return fb_; }
  /// Sky and ground colours of pixel row y at column x as draw_background() paints them.
  uint32_t background(int x, int y) const;
  /// Whether draw_background() painted pixel (x, y) as ground (else sky).
  bool ground_at(int x, int y) const;
  /// Writes the current frame as PNG; false (and *error) on failure.
  bool write_png(const std::string& path, std::string* error = nullptr) const;

 private:
  struct Mesh;
  void draw_mesh(const Mesh& mesh, const SE3& pose, const Vec3& scale, const Eigen::Vector3d& rgb);
  void draw_triangle_clip(const Vec4& a, const Vec4& b, const Vec4& c, uint32_t color);

  struct RowBackground {
    int split = 0;  ///< first column of the right part
    bool ground_left = true;
    uint32_t sky = 0, ground = 0;
  };

  Camera cam_;
  ClipPlanes planes_{cam_};
  Style style_;
  std::vector<RowBackground> rows_;
  Framebuffer fb_;
  std::vector<DrawItem> items_;
  std::unique_ptr<Mesh> box_, cylinder_, sphere_, cone_;
  std::vector<Vec4> clip_scratch_;  ///< per-mesh transformed vertices (reused)
  std::vector<Vec3> world_scratch_;
  void* cairo_surface_ = nullptr;  ///< cairo_surface_t over fb_'s colour buffer
  void* cairo_ = nullptr;          ///< cairo_t
  void make_cairo();
  void free_cairo();
};

struct RenderOptions {
  Camera camera;
  bool auto_camera = true;  ///< frame the robot; false: use camera's eye / target
  SE3 base;                 ///< base pose f0 in the world
  VecX q;                   ///< joint positions (size model.n); empty means zero
  Style style;
  Overlay overlay;
  std::vector<Marker> markers;
};

/// Parses "ex,ey,ez,tx,ty,tz[,focal_px]" into opt.camera and sets opt.auto_camera = false.
bool parse_camera_spec(const std::string& spec, RenderOptions& opt, std::string* error);

/// Draws one frame of model at (opt.base, opt.q) and writes it to out_path as PNG.
/// Returns 0 on success, 1 with a one-line reason in *error otherwise.
int render_to_png(const Model& model, const RenderOptions& opt, const std::string& out_path,
                  std::string* error = nullptr);

}  // namespace render
}  // namespace se3
