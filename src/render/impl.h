// Renderer internals shared by the render sources: the per-frame vertex buffers, the mesh
// pipeline (vertex stage, triangle stage with clipping), the text atlas and the frame's helper
// thread.
#pragma once

#include <algorithm>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

#include "se3_sim/render/render.h"

namespace se3 {
namespace render {

/// Outcode bits of a transformed vertex.
enum : uint8_t {
  kBehind = 1,  ///< in front of the eye by less than the near distance (or behind it)
  kLeft = 2,
  kRight = 4,
  kTop = 8,
  kBottom = 16
};

/// A pixel rectangle [x0, x1) x [y0, y1); empty when x0 >= x1 or y0 >= y1.
struct Rect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  bool empty() const { return x0 >= x1 || y0 >= y1; }
  void add(const Rect& r) {
    if (r.empty()) return;
    if (empty()) {
      *this = r;
      return;
    }
    x0 = std::min(x0, r.x0);
    y0 = std::min(y0, r.y0);
    x1 = std::max(x1, r.x1);
    y1 = std::max(y1, r.y1);
  }
};

/// Where a frame drew: tiles of 8 x 8 pixels marked by the rectangles added (items, markers,
/// the overlay), so that the next frame restores the background there only (separate items
/// leave the space between them alone, as one enclosing rectangle would not).
struct DirtyTiles {
  static constexpr int kShift = 3;
  int tx = 0, ty = 0;
  std::vector<uint8_t> mark;  ///< tx * ty, row-major
  bool any = false;
  void resize(int width, int height) {
    tx = (width + (1 << kShift) - 1) >> kShift;
    ty = (height + (1 << kShift) - 1) >> kShift;
    mark.assign(std::size_t(tx) * ty, 0);
    any = false;
  }
  void add(const Rect& r) {
    if (r.empty() || mark.empty()) return;
    const int x0 = std::max(r.x0, 0) >> kShift, y0 = std::max(r.y0, 0) >> kShift;
    const int x1 = std::min((r.x1 - 1) >> kShift, tx - 1);
    const int y1 = std::min((r.y1 - 1) >> kShift, ty - 1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) mark[std::size_t(y) * tx + x] = 1;
    any = any || (x0 <= x1 && y0 <= y1);
  }
  void clear() {
    if (any) std::fill(mark.begin(), mark.end(), uint8_t(0));
    any = false;
  }
};

/// One item's transform for one frame.
struct ItemFrame {
  float m[12];           ///< rows U, V, W of P * pose * scale (clip x, y, depth), row-major 3x4
  Mat4 clip;             ///< the same in double, 4 rows (U, V, S, W): for clipping
  float L[3];            ///< towards the sun, item frame
  float H[3];            ///< towards the eye (head light, the view direction), item frame
  float inv_scale[3];    ///< normal scaling (non-uniform scales)
  bool rescale = false;  ///< normals need inv_scale and renormalizing
  bool visible = false;
  std::size_t vbase = 0;  ///< first vertex in the frame buffers
  Rect rect;              ///< pixels it may cover (its box's image, or all)
  double depth = 0;       ///< depth of its box's centre: items are drawn nearest first
  /// The outcodes of its vertices or-ed, by the part that transformed them (transform's
  /// caller): all zero, the triangle loops skip the per-triangle outcode test.
  uint8_t outside[2] = {0, 0};
};

/// Glyphs of the overlay font, rendered once with Cairo; drawing text is then a blend.
struct TextAtlas {
  double font_size = 0;
  int cell_w = 0, cell_h = 0, ascent = 0;
  std::vector<uint8_t> alpha;  ///< 95 glyphs (ASCII 32..126), cell_w x cell_h each
  void build(double size);
  /// Width in pixels of text (monospace).
  int width(const char* text) const;
  void draw(Framebuffer& fb, int x, int y, const char* text, Rgb color) const;
};

struct Renderer::Impl {
  // Frame buffers of transformed vertices (structure of arrays).
  std::vector<int32_t> XY;  // x, y of vertex i at 2 i, 2 i + 1
  std::vector<float> Z, KF, KB;
  std::vector<uint8_t> out;
  std::vector<ItemFrame> frames;
  std::vector<uint32_t> order;  // the items, nearest first (drawn in this order)
  RenderMesh box, cylinder, sphere, cone;
  TextAtlas atlas;

  // The background and grid depend on the camera only: drawn once into `background` and
  // restored each frame where the last frame drew (`dirty`), with the depth cleared there.
  std::vector<uint32_t> background;
  bool background_ok = false;
  bool stale_color = false;  // a frame left old colours where it drew nothing
  Mat4 background_P = Mat4::Zero();
  Vec3 background_eye = Vec3::Zero();
  double background_grid[4] = {0, 0, 0, 0};
  DirtyTiles dirty, next_dirty;

  // Lighting (ambient, sun, head light).
  float ka = 0.26f, kd = 0.58f, kh = 0.22f;

  void reserve(std::size_t vertices);
  /// Frame of one mesh at pose with scale; false when it cannot be seen at all.
  bool prepare(const RenderMesh& mesh, const SE3& pose, const Vec3& scale, const Camera& cam,
               const ClipPlanes& planes, const Eigen::Vector3d& light, std::size_t vbase,
               ItemFrame& f) const;
  /// Vertices [v0, v1) of mesh into the buffers at f.vbase; returns their outcodes or-ed.
  uint8_t transform(const RenderMesh& mesh, std::size_t v0, std::size_t v1, const ItemFrame& f,
                    const Camera& cam, bool simd);
  /// The triangles of mesh, rows in `rows`; rgb (0..1) replaces the runs' colours when given.
  /// Returns the triangles set up.
  std::size_t triangles(const RenderMesh& mesh, const ItemFrame& f, const float* rgb,
                        const ClipPlanes& planes, const RowSet& rows, Framebuffer& fb) const;

  // ---- the helper thread of a two-thread frame
  std::thread worker;
  std::mutex mu;
  std::condition_variable cv;
  int job = 0;  ///< 0 idle, 1 phase A, 2 phase B, 3 copy, -1 quit
  bool done = true;
  uint8_t* copy_dst = nullptr;
  Renderer* owner = nullptr;
  std::size_t worker_triangles = 0;
  void start(Renderer* r);
  void stop();
  /// Runs job on the worker and waits for it while `mine` runs here.
  template <class F>
  void together(int j, F&& mine) {
    {
      std::lock_guard<std::mutex> lock(mu);
      job = j;
      done = false;
    }
    cv.notify_all();
    mine();
    std::unique_lock<std::mutex> lock(mu);
    cv.wait(lock, [&] { return done; });
  }
};

}  // namespace render
}  // namespace se3
