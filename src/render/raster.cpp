// The software rasterizer: scanline triangles with an inverse-depth buffer, anti-aliased lines.
#include "se3_sim/render/raster.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
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

void Framebuffer::fill_span(int y, int x0, int x1, uint32_t color) {
  if (y < 0 || y >= height_) return;
  x0 = std::max(x0, 0);
  x1 = std::min(x1, width_);
  if (x1 > x0) std::fill_n(color_.data() + size_t(y) * width_ + x0, x1 - x0, color);
}

void Framebuffer::fill_triangle(const ScreenVertex& a, const ScreenVertex& b, const ScreenVertex& c,
                                uint32_t color, bool write_depth) {
  const ScreenVertex* v0 = &a;
  const ScreenVertex* v1 = &b;
  const ScreenVertex* v2 = &c;
  if (v1->y < v0->y) std::swap(v0, v1);
  if (v2->y < v1->y) std::swap(v1, v2);
  if (v1->y < v0->y) std::swap(v0, v1);
  const double e1x = v1->x - v0->x, e1y = v1->y - v0->y;
  const double e2x = v2->x - v0->x, e2y = v2->y - v0->y;
  const double area = e1x * e2y - e2x * e1y;
  if (!(std::abs(area) > 1e-12)) return;
  // Inverse depth is affine in screen space: iz = A x + B y + C.
  const double d1 = v1->inv_depth - v0->inv_depth, d2 = v2->inv_depth - v0->inv_depth;
  const double A = (d1 * e2y - d2 * e1y) / area;
  const double B = (e1x * d2 - e2x * d1) / area;
  const double C = v0->inv_depth - A * v0->x - B * v0->y;

  // Rows whose centre y + 0.5 lies in [y0, y2).
  const int ys = std::max(0, int(std::ceil(v0->y - 0.5)));
  const int ye = std::min(height_, int(std::ceil(v2->y - 0.5)));
  const double inv_long = 1.0 / (v2->y - v0->y);
  const float fA = float(A);
  for (int y = ys; y < ye; ++y) {
    const double yc = y + 0.5;
    const double xl0 = v0->x + (v2->x - v0->x) * (yc - v0->y) * inv_long;
    double xs;
    if (yc < v1->y) {
      xs = v0->x + (v1->x - v0->x) * (yc - v0->y) / (v1->y - v0->y);
    } else {
      const double dy = v2->y - v1->y;
      xs = dy > 0 ? v1->x + (v2->x - v1->x) * (yc - v1->y) / dy : v1->x;
    }
    double xl = xl0, xr = xs;
    if (xl > xr) std::swap(xl, xr);
    const int x0 = std::max(0, int(std::ceil(xl - 0.5)));
    const int x1 = std::min(width_, int(std::ceil(xr - 0.5)));
    if (x1 <= x0) continue;
    const size_t row = size_t(y) * width_;
    float iz = float(A * (x0 + 0.5) + B * yc + C);
    uint32_t* col = color_.data() + row;
    float* dep = depth_.data() + row;
    if (write_depth) {
      for (int x = x0; x < x1; ++x, iz += fA) {
        if (iz > dep[x]) {
          dep[x] = iz;
          col[x] = color;
        }
      }
    } else {
      for (int x = x0; x < x1; ++x, iz += fA) {
        if (iz > dep[x]) col[x] = color;
      }
    }
  }
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
                            float opacity, bool depth_test, float fade) {
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
  const size_t n = color_.size();
  const uint32_t* src = color_.data();
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
