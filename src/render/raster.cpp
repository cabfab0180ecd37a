// The software rasterizer: buffers, anti-aliased lines and discs, the rgb8 copy (triangles:
// triangle.cpp).
#include "se3_sim/render/raster.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#elif defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace se3 {
namespace render {

namespace {

uint8_t to_byte(double v) {
  if (!(v > 0)) return 0;
  if (v >= 1) return 255;
  return uint8_t(v * 255.0 + 0.5);
}

}  // namespace

Rgb Rgb::from_float(double r, double g, double b) {
  return Rgb(to_byte(r), to_byte(g), to_byte(b));
}

void Framebuffer::resize(int width, int height) {
  width_ = std::max(width, 1);
  height_ = std::max(height, 1);
  color_.assign(size_t(width_) * height_, 0u);
  depth_.assign(size_t(width_) * height_, 0.0f);
}

Rgb Framebuffer::rgb(int x, int y) const {
  const uint32_t p = pixel(x, y);
  return Rgb(uint8_t(p >> 16), uint8_t(p >> 8), uint8_t(p));
}

void Framebuffer::clear_depth() {
  std::memset(depth_.data(), 0, depth_.size() * sizeof(float));
}

void Framebuffer::clear_depth_rows(int y0, int y1) {
  y0 = std::max(y0, 0);
  y1 = std::min(y1, height_);
  if (y1 > y0) {
    std::memset(depth_.data() + std::size_t(y0) * width_, 0,
                std::size_t(y1 - y0) * width_ * sizeof(float));
  }
}

void Framebuffer::set_simd(bool on) {
  path_ = on ? raster_best_path() : RasterPath::Scalar;
}

void Framebuffer::set_path(RasterPath p) {
  path_ = RasterPath(std::min(int(p), int(raster_best_path())));
}

void Framebuffer::fill_span(int y, int x0, int x1, uint32_t color) {
  if (y < 0 || y >= height_) return;
  x0 = std::max(x0, 0);
  x1 = std::min(x1, width_);
  if (x1 <= x0) return;
  uint32_t* p = color_.data() + size_t(y) * width_ + x0;
  int n = x1 - x0;
#if defined(__SSE2__)
  const __m128i v = _mm_set1_epi32(int(color));
  for (; n >= 4; n -= 4, p += 4) _mm_storeu_si128(reinterpret_cast<__m128i*>(p), v);
#endif
  std::fill_n(p, n, color);
}

void Framebuffer::blend(int x, int y, Rgb c, float a) {
  uint32_t& p = color_[size_t(y) * width_ + x];
  if (a >= 0.999f) {
    p = c.packed();
    return;
  }
  const int ia = int(a * 256.0f);
  const int r = int((p >> 16) & 0xff), g = int((p >> 8) & 0xff), b = int(p & 0xff);
  const int nr = r + (((int(c.r) - r) * ia) >> 8);
  const int ng = g + (((int(c.g) - g) * ia) >> 8);
  const int nb = b + (((int(c.b) - b) * ia) >> 8);
  p = (uint32_t(nr) << 16) | (uint32_t(ng) << 8) | uint32_t(nb);
}

void Framebuffer::draw_line(const ScreenVertex& a, const ScreenVertex& b, Rgb color, float width,
                            float opacity, bool depth_test, float fade, const RowSet& rows) {
  const double dx = double(b.x) - a.x, dy = double(b.y) - a.y;
  const double len = std::sqrt(dx * dx + dy * dy);
  if (!(len > 1e-6) || !std::isfinite(len) || !(opacity > 0)) return;
  const bool steep = std::abs(dy) > std::abs(dx);
  // Walk the major axis (pixel centres between the ends); cover the minor axis across the
  // line's width, with coverage from the perpendicular distance.
  const double ma0 = steep ? a.y : a.x, ma1 = steep ? b.y : b.x;
  const double mi0 = steep ? a.x : a.y, mi1 = steep ? b.x : b.y;
  const double dma = ma1 - ma0, dmi = mi1 - mi0;
  const double cosf = std::abs(dma) / len;  // minor-axis offset -> perpendicular distance
  const double half = std::max(1.0f, width) * 0.5;
  const float weight = opacity * std::min(1.0f, std::max(width, 0.0f));
  // Pixels whose centres are within (half + 0.5) of the line, measured perpendicularly.
  const double reach = (half + 0.5) / cosf;
  const int major_size = steep ? height_ : width_;
  const int minor_size = steep ? width_ : height_;
  const double lo = std::min(ma0, ma1), hi = std::max(ma0, ma1);
  const int m0 = std::max(0, int(std::ceil(lo - 0.5)));
  const int m1 = std::min(major_size - 1, int(std::floor(hi - 0.5)));
  for (int m = m0; m <= m1; ++m) {
    const double t = (m + 0.5 - ma0) / dma;
    const double mc = mi0 + t * dmi;
    const float iz = float(a.inv_depth + t * (double(b.inv_depth) - a.inv_depth));
    float w = weight;
    if (fade > 0) w *= std::min(1.0f, fade * std::max(iz, 0.0f));
    if (w < 0.02f) continue;  // invisible (below 1/50 opacity)
    const int n0 = std::max(0, int(std::ceil(mc - reach - 0.5)));
    const int n1 = std::min(minor_size - 1, int(std::floor(mc + reach - 0.5)));
    for (int n = n0; n <= n1; ++n) {
      const double dist = std::abs(n + 0.5 - mc) * cosf;
      const double cov = std::min(1.0, half + 0.5 - dist);
      if (cov <= 0) continue;
      const int x = steep ? n : m, y = steep ? m : n;
      if (!rows.has(y)) continue;
      if (depth_test) {
        const float dz = depth_[size_t(y) * width_ + x];
        if (dz > iz * 1.002f + 1e-6f) continue;
      }
      blend(x, y, color, float(cov) * w);
    }
  }
}

void Framebuffer::fill_disc(const ScreenVertex& c, float radius, Rgb color, bool depth_test) {
  if (!(radius > 0) || !std::isfinite(c.x) || !std::isfinite(c.y)) return;
  const int x0 = std::max(0, int(std::floor(c.x - radius - 1)));
  const int x1 = std::min(width_ - 1, int(std::floor(c.x + radius + 1)));
  const int y0 = std::max(0, int(std::floor(c.y - radius - 1)));
  const int y1 = std::min(height_ - 1, int(std::floor(c.y + radius + 1)));
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) {
      const float ddx = x + 0.5f - c.x, ddy = y + 0.5f - c.y;
      const float cov = std::min(1.0f, radius + 0.5f - std::sqrt(ddx * ddx + ddy * ddy));
      if (cov <= 0) continue;
      if (depth_test && depth_[size_t(y) * width_ + x] > c.inv_depth * 1.002f + 1e-6f) continue;
      blend(x, y, color, cov);
    }
  }
}

#if defined(__x86_64__) && defined(__GNUC__)
namespace {

// Four 0x00RRGGBB pixels (16 bytes) to 12 bytes R, G, B, ... with one byte shuffle.
__attribute__((target("ssse3"))) size_t copy_rgb8_ssse3(const uint32_t* src, size_t n,
                                                        uint8_t* dst) {
  const __m128i shuffle = _mm_setr_epi8(2, 1, 0, 6, 5, 4, 10, 9, 8, 14, 13, 12, -1, -1, -1, -1);
  size_t i = 0;
  // Each store writes 16 bytes of which 12 count; stop early enough to stay inside dst.
  for (; i + 8 <= n; i += 4) {
    const __m128i p = _mm_loadu_si128(reinterpret_cast<const __m128i*>(src + i));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(dst), _mm_shuffle_epi8(p, shuffle));
    dst += 12;
  }
  return i;
}

}  // namespace
#endif

void Framebuffer::copy_rgb8(uint8_t* dst) const {
  copy_rgb8_rows(dst, 0, height_);
}

void Framebuffer::copy_rgb8_rows(uint8_t* dst, int y0, int y1) const {
  y0 = std::max(y0, 0);
  y1 = std::min(y1, height_);
  if (y1 <= y0) return;
  const size_t n = size_t(y1 - y0) * width_;
  const uint32_t* src = color_.data() + size_t(y0) * width_;
  dst += size_t(y0) * width_ * 3;
  size_t i = 0;
#if defined(__x86_64__) && defined(__GNUC__)
  static const bool ssse3 = __builtin_cpu_supports("ssse3");
  if (ssse3) {
    i = copy_rgb8_ssse3(src, n, dst);
    dst += 3 * i;
  }
#endif
  for (; i < n; ++i) {
    const uint32_t p = src[i];
    dst[0] = uint8_t(p >> 16);
    dst[1] = uint8_t(p >> 8);
    dst[2] = uint8_t(p);
    dst += 3;
  }
}

}  // namespace render
}  // namespace se3
