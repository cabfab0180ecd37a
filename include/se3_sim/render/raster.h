// Software rasterizer: a 0x00RRGGBB colour buffer (Cairo's RGB24 layout) and an inverse-depth
// buffer (1/z, 0 = infinitely far: larger is nearer; cleared with memset). Nothing here
// allocates after construction or resize().
//
// Triangles use half-space edge functions on vertices snapped to 1/16 pixel (integer, exact):
// a pixel is covered when its centre is inside, with the top-left rule on edges, so triangles
// that share an edge cover each pixel along it once. Inverse depth and the shade factor are
// affine in screen space and are interpolated from the snapped vertices. Rows of a frame can be
// shared out between threads (RowSet): a triangle touches only the rows of its thread.
// There are SSE2 (x86-64 baseline) and AVX2 (run-time choice) paths and a portable scalar
// path; all produce the same bits (tested), Framebuffer::set_simd(false) selects the scalar one.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace se3 {
namespace render {

/// 8-bit RGB colour.
struct Rgb {
  uint8_t r = 0, g = 0, b = 0;
  constexpr Rgb() = default;
  constexpr Rgb(uint8_t r_, uint8_t g_, uint8_t b_) : r(r_), g(g_), b(b_) {}
  /// From components in [0, 1] (clamped; NaN gives 0).
  static Rgb from_float(double r, double g, double b);
  constexpr uint32_t packed() const { return (uint32_t(r) << 16) | (uint32_t(g) << 8) | b; }
};

/// A vertex in screen space: pixel coordinates and inverse depth (lines, discs).
struct ScreenVertex {
  float x = 0, y = 0, inv_depth = 0;
};

/// Sub-pixel precision of triangle vertices: 1 / kSubpixel pixel.
constexpr int kSubpixel = 16;

/// A triangle vertex: position in 1/kSubpixel pixels (pixel (0, 0)'s top-left corner at 0;
/// coordinates within +-2^14.5, i.e. the image and its guard band), inverse depth z, shade k
/// (multiplies the colour; 1 = the colour itself).
struct RasterVertex {
  int32_t x = 0, y = 0;
  float z = 0, k = 1;
};

/// The rows a triangle may write: all (parts = 1), or the bands (2^shift rows each) whose
/// index i has i % parts == part (parts a power of two).
struct RowSet {
  int shift = 5;
  int parts = 1;
  int part = 0;
  bool has(int y) const { return parts == 1 || ((y >> shift) & (parts - 1)) == part; }
};

/// Transformed vertices as the renderer's vertex stage leaves them (structure of arrays):
/// sub-pixel position, inverse depth, the shade of the front and of the back side, and an
/// outcode (non-zero: outside the near plane or the guard band around the image).
struct VertexArrays {
  const int32_t* xy;  ///< vertex i at x = xy[2 i], y = xy[2 i + 1]: one 8-byte load a vertex
  const float* z;
  const float* kf;
  const float* kb;
  const uint8_t* out;  ///< outcodes; null: every vertex inside (all zero)
};
/// Called for a triangle with a vertex outside (some outcode set, not all in one plane's
/// half-space: it needs clipping); returns the triangles it drew.
using ClipCallback = std::size_t (*)(void* ctx, uint32_t a, uint32_t b, uint32_t c);

/// Whether this build has the SSE2 path.
bool raster_has_simd();

/// The triangle loops: portable scalar, SSE2 (four pixels wide, x86-64 baseline), AVX2 (eight
/// wide, chosen at run time where the CPU has it). All give the same bits.
enum class RasterPath { Scalar = 0, Sse2 = 1, Avx2 = 2 };
/// The widest path of this build on this CPU.
RasterPath raster_best_path();

class Framebuffer {
 public:
  Framebuffer(int width = 1280, int height = 1024) { resize(width, height); }
  void resize(int width, int height);

  int width() const { return width_; }
  int height() const { return height_; }
  /// Row-major pixels, 0x00RRGGBB, stride width() * 4 bytes.
  uint32_t* color() { return color_.data(); }
  const uint32_t* color() const { return color_.data(); }
  float* depth() { return depth_.data(); }
  const float* depth() const { return depth_.data(); }
  uint32_t pixel(int x, int y) const { return color_[std::size_t(y) * width_ + x]; }
  Rgb rgb(int x, int y) const;

  /// The widest SIMD path (default) or the scalar one; all give the same pixels.
  void set_simd(bool on);
  bool simd() const { return path_ != RasterPath::Scalar; }
  /// One path (at most raster_best_path(); narrower images fall back to narrower paths).
  void set_path(RasterPath p);
  RasterPath path() const { return path_; }
  /// Whether triangles write colour (default) or depth alone (a depth camera nobody watches in
  /// colour): the depth is the same either way.
  void set_paint(bool on) { paint_ = on; }
  bool paint() const { return paint_; }

  /// Depth to 0 (everything infinitely far).
  void clear_depth();
  /// Depth of rows y0..y1-1 to 0.
  void clear_depth_rows(int y0, int y1);
  /// Fills row y, columns [x0, x1), with one colour.
  void fill_span(int y, int x0, int x1, uint32_t color);

  /// Filled, depth-tested, depth-writing triangle of either winding, Gouraud-shaded: a pixel
  /// gets rgb * k (rgb in 0..255 per channel, clamped to 255) interpolated from the vertices.
  /// Writes only rows in `rows`. Degenerate triangles draw nothing.
  void fill_triangle(const RasterVertex& a, const RasterVertex& b, const RasterVertex& c,
                     const float rgb[3], const RowSet& rows = RowSet());
  /// The renderer's inner loop: `count` triangles of idx (three vertex indices each) over v,
  /// in colour rgb (0..255), shaded by kf or kb as the side seen; back faces skipped when
  /// `cull`; `outward`: counter-clockwise triangles face out. Returns the triangles drawn.
  std::size_t fill_indexed(const VertexArrays& v, const uint32_t* idx, std::size_t count,
                           const float rgb[3], bool cull, bool outward, const RowSet& rows,
                           ClipCallback clip, void* ctx);
  /// Flat triangle from float pixel coordinates (snapped to the sub-pixel grid).
  void fill_triangle(const ScreenVertex& a, const ScreenVertex& b, const ScreenVertex& c,
                     uint32_t color);
  /// Anti-aliased line of a given width (pixels) and opacity, blended over the colour buffer.
  /// With depth_test, pixels behind the depth buffer (minus a small bias) are skipped. A
  /// fade distance > 0 scales the opacity by min(1, fade * inv_depth), so lines fade out
  /// towards their points at infinity. Only rows in `rows` are written.
  void draw_line(const ScreenVertex& a, const ScreenVertex& b, Rgb color, float width = 1.0f,
                 float opacity = 1.0f, bool depth_test = true, float fade = 0.0f,
                 const RowSet& rows = RowSet());
  /// Anti-aliased filled disc (screen-space point marker), depth-tested at its centre depth.
  void fill_disc(const ScreenVertex& c, float radius, Rgb color, bool depth_test = true);
  /// Blends colour c with opacity a in [0, 1] over pixel (x, y) (no bounds check).
  void blend(int x, int y, Rgb c, float a);

  /// Packed 8-bit RGB, 3 bytes a pixel, rows top to bottom (sensor_msgs/Image rgb8); dst
  /// holds width() * height() * 3 bytes. Rows y0..y1-1 only with the second form.
  void copy_rgb8(uint8_t* dst) const;
  void copy_rgb8_rows(uint8_t* dst, int y0, int y1) const;

 private:
  int width_ = 0, height_ = 0;
  RasterPath path_ = raster_best_path();
  bool paint_ = true;
  int usable_path() const;
  std::vector<uint32_t> color_;
  std::vector<float> depth_;
};

}  // namespace render
}  // namespace se3
