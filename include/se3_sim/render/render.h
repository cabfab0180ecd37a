// The renderer: draws a model's visual geometry (geometry.h: meshes and primitives alike, as
// triangle meshes) in linear perspective into a 1280x1024 RGB image, over a sky and a ground
// grid that runs to the horizon (the painter's perspective of section 3.3 of Reuss 2002), with
// markers, link frames and a text overlay. No roscpp here; the ROS node
// (src/ros/renderer_node.cpp) feeds it poses from TF.
//
// ---- For `se3_dyn render MODEL.urdf [--floating] [--scene S] [--camera ...] --out frame.png`
//
//   #include "se3_sim/render/render.h"
//   se3::GeometryModel geom = se3::geometry_from_urdf_file(model, "robot.urdf");
//   se3::render::RenderOptions opt;            // camera, pose, overlay, markers
//   opt.base = f0;                              // base pose in the world (default identity)
//   opt.q = q;                                  // joint positions (size model.n; empty = 0)
//   opt.auto_camera = true;                     // frame the robot (ignores opt.camera's pose)
//   std::string err;                            // or: parse_camera_spec(arg, opt, &err)
//   int rc = se3::render::render_to_png(model, geom, opt, "frame.png", &err);  // 0 = written
//
// render_to_png runs se3::forward_kinematics, draws one frame and writes a PNG; it returns
// 0 on success and 1 with a one-line reason in *error otherwise (it never throws for bad
// options). `--camera` is parsed by parse_camera_spec: "ex,ey,ez,tx,ty,tz[,focal_px]" (eye
// and look-at target in metres, optional focal length in pixels), which also turns
// auto_camera off. The pinhole: camera x right, y down, z forward, K = [f 0 w/2; 0 f h/2;
// 0 0 1] with pixel (0, 0)'s top-left corner at (0, 0) (camera.h).
//
// ---- Drawing
//
// Every visual becomes a DrawItem holding a RenderMesh: positions and per-vertex normals (a
// mesh's scale applied), triangles in runs of one colour (a mesh file's material colour, else
// the URDF material, else grey). Shading is Lambert per vertex (a sun and a head light, plus
// ambient), interpolated across the triangle. Runs whose surface is closed (TriangleMesh::
// SubMesh::closed) have their back faces culled before setup; open surfaces are drawn from
// both sides, lit on the side seen. A mesh whose triangles are finer than it can show is
// simplified once, in make_draw_items, with meshoptimizer: DrawOptions::simplify_error.
//
// One frame allocates nothing (malloc or new), overlay included. With Style::threads = 2 the
// frame's rows are shared between two threads in bands of 32 (background, grid, triangles, the
// rgb8 copy); the result is the same image.
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

#include "se3_sim/dynamics/dynamics.h"
#include "se3_sim/geometry/geometry.h"
#include "se3_sim/model/model.h"
#include "se3_sim/render/camera.h"
#include "se3_sim/render/raster.h"

namespace se3 {
namespace render {

struct RenderMesh;

/// A marker in world coordinates (the simple form of visualization_msgs/Marker).
struct Marker {
  enum class Type { Point, Sphere, Arrow, Line, Box, Cylinder, Mesh };
  Type type = Type::Point;
  /// position (point, sphere, box and cylinder centre) or start (arrow, line)
  Vec3 a = Vec3::Zero();
  Vec3 b = Vec3::Zero();  ///< end (arrow, line)
  /// Point: diameter in pixels; sphere: diameter (m); arrow: shaft diameter (m); line: width in
  /// pixels; box: full extents along its axes R (m, all three entries of size3); cylinder:
  /// size3 = (diameter along x, diameter along y, length along z) in its axes R, as RViz's
  /// CYLINDER (a capsule is a cylinder and two spheres, as the simulator publishes it).
  double size = 0.02;
  Vec3 size3 = Vec3::Constant(0.1);
  Mat3 R = Mat3::Identity();  ///< box, cylinder, mesh: orientation in the world (its axes)
  Eigen::Vector3d color = Eigen::Vector3d(1.0, 0.3, 0.1);  ///< rgb in [0, 1]
  /// Mesh: the triangles (scale already applied, make_render_mesh) drawn at (R, a); null draws
  /// nothing. Copying a marker shares the mesh (no allocation).
  std::shared_ptr<const RenderMesh> mesh;
  bool mesh_colors = false;  ///< mesh: keep its runs' own colours instead of `color`
};

/// Text drawn at the top-left corner; NaN / empty fields are left out.
struct Overlay {
  double sim_time = std::numeric_limits<double>::quiet_NaN();
  double real_time_factor = std::numeric_limits<double>::quiet_NaN();
  std::string joint;  ///< selected joint
  double torque = std::numeric_limits<double>::quiet_NaN();
  std::vector<std::string> lines;  ///< extra lines (the first 12 are drawn)
};

struct Style {
  bool grid = true;
  double grid_spacing = 0.5;  ///< metres between grid lines
  int grid_lines = 20;        ///< lines of each family on each side of the origin
  bool frames = false;        ///< link frames as short axes
  double frame_length = 0.1;  ///< metres
  bool overlay = true;
  Eigen::Vector3d light = Eigen::Vector3d(0.35, -0.45, 0.82);  ///< towards the sun (world)
  bool simd = true;  ///< SSE2 raster path where built (the scalar one gives the same image)
  int threads = 1;   ///< 1 or 2: rows shared between this many threads
  /// Colours (sky, ground, grid, shaded triangles); false: the depth buffer alone is drawn (a
  /// depth camera whose colour nobody reads), the same depth bits, the colour buffer stale.
  bool paint = true;
  /// Restore the background's colours where the last frame drew. False: where this frame draws
  /// nothing the colour buffer keeps what it held (the depth there is 0, background_row() has
  /// the colours), which saves a copy a frame for a caller that reads the frame through its
  /// depth (the camera sensor). The next frame with true redraws the whole background.
  bool keep_background = true;
};

/// A triangle mesh as the rasterizer reads it: structure-of-arrays positions and unit normals
/// (in the item's frame, scale applied), triangles, and runs of one colour.
struct RenderMesh {
  std::vector<float> px, py, pz, nx, ny, nz;
  std::vector<uint32_t> indices;
  struct Run {
    uint32_t first = 0, count = 0;                               ///< triangles
    Eigen::Vector3f rgb = Eigen::Vector3f(0.75f, 0.75f, 0.75f);  ///< 0..1
    bool cull = false;    ///< closed surface: back faces are not drawn
    bool outward = true;  ///< counter-clockwise faces out
  };
  std::vector<Run> runs;
  Eigen::Vector3f lower = Eigen::Vector3f::Zero(), upper = Eigen::Vector3f::Zero();
  std::size_t source_triangles = 0;  ///< before simplification
  std::size_t vertex_count() const { return px.size(); }
  std::size_t triangle_count() const { return indices.size() / 3; }
};

/// How make_draw_items turns geometry into RenderMeshes.
struct DrawOptions {
  /// Meshes are simplified (meshoptimizer, borders of sub-meshes kept) while no surface moves
  /// by more than this (metres): 0.5 mm is half a pixel seen from 1 m with f = 1000 px. 0 or
  /// less: full meshes.
  double simplify_error = 0.5e-3;
  int segments = 32;  ///< around cylinders, spheres and capsules
};

/// Builds the RenderMesh of a triangle mesh (scaled), colouring runs by their material, else
/// `rgb`; simplified as opt says.
RenderMesh make_render_mesh(const TriangleMesh& mesh, const Vec3& scale, const Eigen::Vector3f& rgb,
                            const DrawOptions& opt = DrawOptions());

/// What the renderer draws for one visual, and what the node tells RViz about it.
struct DrawItem {
  int body = 0;
  SE3 local;  ///< item frame in the body frame
  std::shared_ptr<const RenderMesh> mesh;
  Eigen::Vector3d color = Eigen::Vector3d(0.75, 0.75, 0.75);  ///< the visual's (URDF) colour
  std::string link, name;
  ShapeType shape = ShapeType::Box;
  /// Primitives as RViz markers take them: box x y z; cylinder 2r 2r l; sphere 2r 2r 2r;
  /// capsule 2r 2r l (cylinder part).
  Vec3 size = Vec3::Ones();
  std::string mesh_resource;  ///< a mesh's URI for RViz (package:// as written, else file://)
  Vec3 mesh_scale = Vec3::Ones();
  bool mesh_colors = false;  ///< the mesh file carries its own colours
  bool stand_in = false;
};

/// The draw list of a model's visuals (deterministic; the node's RViz MarkerArray uses it).
std::vector<DrawItem> make_draw_items(const Model& model, const GeometryModel& geometry,
                                      const DrawOptions& opt = DrawOptions());

/// Chooses an eye and target that show the items at the body poses oMb and the box and mesh
/// markers among `boxes` (and the ground) from a three-quarter view; keeps
/// cam's size and focal length.
void frame_items(const std::vector<DrawItem>& items, const std::vector<SE3>& oMb, Camera& cam,
                 const std::vector<Marker>& boxes = {});

struct Rect;  // a pixel rectangle (internal)

class Renderer {
 public:
  explicit Renderer(const Camera& cam = Camera());
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  /// Sets the camera (calls cam.update()); reallocates only when the image size changes.
  void set_camera(const Camera& cam);
  const Camera& camera() const { return cam_; }
  /// The style; threads takes effect at the next frame.
  Style& style() { return style_; }
  /// Draws this model's visuals from now on (allocates; not per frame).
  void set_model(const Model& model, const GeometryModel& geometry,
                 const DrawOptions& opt = DrawOptions());
  /// Draws these items from now on (allocates; not per frame).
  void set_items(std::vector<DrawItem> items);
  const std::vector<DrawItem>& items() const { return items_; }

  /// One frame: background (sky, ground, grid to the horizon), the items at their bodies'
  /// poses oMb (world poses of bodies 0..n; a missing or non-finite pose hides its body),
  /// markers, frames and the overlay. oMb may be empty (no model drawn). Allocates nothing.
  void render(const std::vector<SE3>& oMb, const std::vector<Marker>& markers = {},
              const Overlay& overlay = Overlay());

  // ---- the steps of render(), usable on their own
  void draw_background();  ///< sky gradient, ground, depth cleared
  void draw_grid();        ///< the ground grid's two line families, running to the horizon
  void draw_box(const SE3& pose, const Vec3& size, const Eigen::Vector3d& rgb);
  void draw_cylinder(const SE3& pose, const Vec3& size, const Eigen::Vector3d& rgb);
  void draw_sphere(const SE3& pose, const Vec3& size, const Eigen::Vector3d& rgb);
  /// A mesh at pose with per-axis scale; rgb replaces the runs' colours when given.
  void draw_mesh(const RenderMesh& mesh, const SE3& pose, const Vec3& scale = Vec3::Ones(),
                 const Eigen::Vector3d* rgb = nullptr);
  /// Homogeneous segment a-b (s = 0 allowed for an end at infinity), clipped in RP^3.
  void draw_segment(const Vec4& a, const Vec4& b, Rgb color, float width = 1.0f,
                    bool depth_test = true, float opacity = 1.0f, float fade = 0.0f);
  void draw_marker(const Marker& m);
  void draw_overlay(const Overlay& overlay);

  const Framebuffer& framebuffer() const { return fb_; }
  /// Write access; the next render() then redraws the whole background (it otherwise
  /// restores only where the previous frame drew).
  Framebuffer& framebuffer();
  /// Sky and ground colours of pixel row y at column x as draw_background() paints them.
  uint32_t background(int x, int y) const;
  /// Row y's background as draw_background() paints it: colour `left` in columns below
  /// `split`, `right` from there on.
  void background_row(int y, int& split, uint32_t& left, uint32_t& right) const;
  /// Whether draw_background() painted pixel (x, y) as ground (else sky).
  bool ground_at(int x, int y) const;
  /// Writes the current frame as PNG; false (and *error) on failure.
  bool write_png(const std::string& path, std::string* error = nullptr) const;
  /// The frame as rgb8 (width * height * 3 bytes), copied by the frame's threads.
  void copy_rgb8(uint8_t* dst);

  /// Triangles set up in the last frame (after culling), for benchmarks.
  std::size_t last_triangles() const { return last_triangles_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  struct RowBackground {
    int split = 0;  ///< first column of the right part
    bool ground_left = true;
    uint32_t sky = 0, ground = 0;
  };
  void frame_part(int phase, int part, int parts);
  void background_rows(const RowSet& rows);
  void grid_rows(const RowSet& rows);
  Rect draw_segment_rows(const Vec4& a, const Vec4& b, Rgb color, float width, bool depth_test,
                         float opacity, float fade, const RowSet& rows);

  Camera cam_;
  ClipPlanes planes_{cam_};
  Style style_;
  std::vector<RowBackground> rows_;
  Framebuffer fb_;
  std::vector<DrawItem> items_;
  std::size_t last_triangles_ = 0;
};

struct RenderOptions {
  Camera camera;
  bool auto_camera = true;  ///< frame the robot; false: use camera's eye / target
  SE3 base;                 ///< base pose f0 in the world
  VecX q;                   ///< joint positions (size model.n); empty means zero
  Style style;
  Overlay overlay;
  std::vector<Marker> markers;
  DrawOptions draw;
};

/// Parses "ex,ey,ez,tx,ty,tz[,focal_px]" into opt.camera and sets opt.auto_camera = false.
bool parse_camera_spec(const std::string& spec, RenderOptions& opt, std::string* error);

/// Draws one frame of model with its geometry at (opt.base, opt.q) and writes it to out_path
/// as PNG. Returns 0 on success, 1 with a one-line reason in *error otherwise.
int render_to_png(const Model& model, const GeometryModel& geometry, const RenderOptions& opt,
                  const std::string& out_path, std::string* error = nullptr);

}  // namespace render
}  // namespace se3
