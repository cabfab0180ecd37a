// The text overlay without allocation: the monospace font's glyphs are rendered once with
// Cairo into an alpha atlas; a frame's text is blended from it.
#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "impl.h"

namespace se3 {
namespace render {

void TextAtlas::build(double size) {
  font_size = size;
  cairo_surface_t* probe = cairo_image_surface_create(CAIRO_FORMAT_A8, 4, 4);
  cairo_t* cr = cairo_create(probe);
  cairo_select_font_face(cr, "monospace", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, size);
  cairo_font_extents_t fe;
  cairo_font_extents(cr, &fe);
  cairo_text_extents_t te;
  cairo_text_extents(cr, "M", &te);
  cairo_destroy(cr);
  cairo_surface_destroy(probe);
  cell_w = std::max(1, int(std::ceil(te.x_advance)));
  cell_h = std::max(1, int(std::ceil(fe.ascent + fe.descent)));
  ascent = int(std::ceil(fe.ascent));
  const int n = 95;
  cairo_surface_t* s = cairo_image_surface_create(CAIRO_FORMAT_A8, cell_w * n, cell_h);
  cr = cairo_create(s);
  cairo_select_font_face(cr, "monospace", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, size);
  cairo_set_source_rgba(cr, 1, 1, 1, 1);
  for (int g = 0; g < n; ++g) {
    const char text[2] = {char(32 + g), 0};
    cairo_move_to(cr, g * cell_w, ascent);
    cairo_show_text(cr, text);
  }
  cairo_surface_flush(s);
  const unsigned char* data = cairo_image_surface_get_data(s);
  const int stride = cairo_image_surface_get_stride(s);
  alpha.assign(std::size_t(cell_w) * cell_h * n, 0);
  for (int g = 0; g < n; ++g)
    for (int y = 0; y < cell_h; ++y)
      std::memcpy(&alpha[(std::size_t(g) * cell_h + y) * cell_w], data + y * stride + g * cell_w,
                  cell_w);
  cairo_destroy(cr);
  cairo_surface_destroy(s);
}

int TextAtlas::width(const char* text) const {
  return int(std::strlen(text)) * cell_w;
}

void TextAtlas::draw(Framebuffer& fb, int x0, int y0, const char* text, Rgb color) const {
  if (alpha.empty()) return;
  const int W = fb.width(), H = fb.height();
  for (int i = 0; text[i]; ++i) {
    const int c = static_cast<unsigned char>(text[i]);
    const int g = (c >= 32 && c < 127) ? c - 32 : '?' - 32;
    const int gx = x0 + i * cell_w;
    if (gx >= W) break;
    const uint8_t* a = &alpha[std::size_t(g) * cell_h * cell_w];
    for (int y = 0; y < cell_h; ++y) {
      const int py = y0 + y;
      if (py < 0 || py >= H) continue;
      for (int x = 0; x < cell_w; ++x) {
        const int px = gx + x;
        if (px < 0 || px >= W) continue;
        const uint8_t v = a[y * cell_w + x];
        if (v) fb.blend(px, py, color, v / 255.0f);
      }
    }
  }
}

void Renderer::draw_overlay(const Overlay& ov) {
  constexpr int kMaxLines = 16;
  char lines[kMaxLines][128];
  int n = 0;
  if (std::isfinite(ov.sim_time)) std::snprintf(lines[n++], 128, "sim time  %9.3f s", ov.sim_time);
  if (std::isfinite(ov.real_time_factor)) {
    std::snprintf(lines[n++], 128, "real time x %.3g", ov.real_time_factor);
  }
  if (!ov.joint.empty()) {
    if (std::isfinite(ov.torque)) {
      std::snprintf(lines[n++], 128, "joint %.60s  tau %+.3f", ov.joint.c_str(), ov.torque);
    } else {
      std::snprintf(lines[n++], 128, "joint %.60s", ov.joint.c_str());
    }
  }
  for (std::size_t i = 0; i < ov.lines.size() && n < kMaxLines; ++i) {
    std::snprintf(lines[n++], 128, "%.100s", ov.lines[i].c_str());
  }
  if (!n) return;
  TextAtlas& atlas = impl_->atlas;
  const double fs = std::clamp(fb_.height() / 50.0, 9.0, 28.0);
  if (atlas.font_size != fs) atlas.build(fs);  // once per image height, not per frame
  int wmax = 0;
  for (int i = 0; i < n; ++i) wmax = std::max(wmax, atlas.width(lines[i]));
  const int pad = int(0.5 * fs), lh = int(std::lround(1.35 * fs));
  // The panel: a dark, half-transparent box behind the text.
  const int x1 = std::min(fb_.width(), pad + wmax + 2 * pad);
  const int y1 = std::min(fb_.height(), pad + n * lh + pad);
  impl_->next_dirty.add(Rect{pad, pad, x1, y1});
  const Rgb panel(20, 26, 36);
  for (int y = pad; y < y1; ++y)
    for (int x = pad; x < x1; ++x) fb_.blend(x, y, panel, 0.55f);
  const Rgb ink(247, 247, 247);
  for (int i = 0; i < n; ++i) {
    const int base = pad + (i + 1) * lh - int(0.25 * fs);  // text baseline
    atlas.draw(fb_, 2 * pad, base - atlas.ascent, lines[i], ink);
  }
}

}  // namespace render
}  // namespace se3
