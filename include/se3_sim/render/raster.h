// Software rasterizer: a 0x00RRGGBB colour buffer (Cairo's RGB24 layout, so Cairo can draw the
// text overlay into the same memory) and an inverse-depth buffer (1/z, 0 = infinitely far:
// larger is nearer; cleared with memset). Primitives come in pixel coordinates with their
// inverse depth, which is affine in screen space for planar primitives, so depth is
// interpolated linearly. Nothing here allocates after construction or resize().
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

/// A vertex in screen space: pixel coordinates and inverse depth.
struct ScreenVertex {
  float x = 0, y = 0, inv_depth = 0;
};

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

  /// Depth to 0 (everything infinitely far).
  void clear_depth();
  /// Fills row y, columns [x0, x1), with one colour.
  void fill_span(int y, int x0, int x1, uint32_t color);

  /// Filled, depth-tested triangle (either winding); pixels whose centres lie inside are
  /// written (top-left rule), with its inverse depth when write_depth.
  void fill_triangle(const ScreenVertex& a, const ScreenVertex& b, const ScreenVertex& c,
                     uint32_t color, bool write_depth = true);
  /// Anti-aliased line of a given width (pixels) and opacity, blended over the colour buffer.
  /// With depth_test, pixels behind the depth buffer (minus a small bias) are skipped. A
  /// fade distance > 0 scales the opacity by min(1, fade * inv_depth), so lines fade out
  /// towards their points at infinity.
  void draw_line(const ScreenVertex& a, const ScreenVertex& b, Rgb color, float width = 1.0f,
                 float opacity = 1.0f, bool depth_test = true, float fade = 0.0f);
  /// Anti-aliased filled disc (screen-space point marker), depth-tested at its centre depth.
  void fill_disc(const ScreenVertex& c, float radius, Rgb color, bool depth_test = true);

  /// Packed 8-bit RGB, 3 bytes a pixel, rows top to bottom (sensor_msgs/Image rgb8); dst
  /// holds width() * height() * 3 bytes.
  void copy_rgb8(uint8_t* dst) const;

 private:
  void blend(int x, int y, Rgb c, float a);

  int width_ = 0, height_ = 0;
  std::vector<uint32_t> color_;
  std::vector<float> depth_;
};

}  // namespace render
}  // namespace se3
