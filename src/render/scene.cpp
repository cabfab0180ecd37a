// The scene: sky and ground, the ground grid in the painter's perspective, the model's items,
// markers, frames, the frame's two threads, PNG output.
#include <cairo.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>

#include "impl.h"

namespace se3 {
namespace render {

namespace {

using Vec3d = Eigen::Vector3d;

bool finite_pose(const SE3& f) {
  return f.R.allFinite() && f.p.allFinite();
}

/// A pose whose z axis runs from a to b (length |b - a|), centred between them.
SE3 segment_frame(const Vec3& a, const Vec3& b) {
  const Vec3 z = (b - a).normalized();
  const Vec3 helper = std::abs(z.z()) < 0.9 ? Vec3(0, 0, 1) : Vec3(1, 0, 0);
  const Vec3 x = helper.cross(z).normalized();
  Mat3 R;
  R.col(0) = x;
  R.col(1) = z.cross(x);
  R.col(2) = z;
  return SE3(R, 0.5 * (a + b));
}

RenderMesh unit_mesh(const TriangleMesh& m) {
  DrawOptions plain;
  plain.simplify_error = 0;
  return make_render_mesh(m, Vec3::Ones(), Eigen::Vector3f::Ones(), plain);
}

}  // namespace

// ---------------------------------------------------------------- Renderer

Renderer::Renderer(const Camera& cam) : impl_(new Impl) {
  // Unit primitives of markers: box [-0.5, 0.5]^3, cylinder of radius 0.5 and length 1 along
  // z, sphere of radius 0.5, cone of base radius 0.5 at z = 0 and apex at z = 1.
  impl_->box = unit_mesh(tessellate(make_box(Vec3::Ones())));
  impl_->cylinder = unit_mesh(tessellate(make_cylinder(0.5, 1.0), 24));
  impl_->sphere = unit_mesh(tessellate(make_sphere(0.5), 20));
  impl_->cone = unit_mesh(cone_mesh(24));
  std::size_t nmax = 0;
  for (const RenderMesh* m : {&impl_->box, &impl_->cylinder, &impl_->sphere, &impl_->cone})
    nmax = std::max(nmax, m->vertex_count());
  impl_->reserve(nmax);
  cam_ = cam;
  cam_.update();
  planes_ = ClipPlanes(cam_);
  fb_.resize(cam_.width, cam_.height);
  rows_.resize(cam_.height);
  impl_->atlas.build(std::clamp(fb_.height() / 50.0, 9.0, 28.0));
}

Renderer::~Renderer() {
  impl_->stop();
}

void Renderer::set_camera(const Camera& cam) {
  Camera c = cam;
  c.update();
  const bool resized = c.width != fb_.width() || c.height != fb_.height();
  cam_ = c;
  planes_ = ClipPlanes(cam_);
  if (resized) {
    fb_.resize(cam_.width, cam_.height);
    rows_.assign(cam_.height, RowBackground());
    impl_->atlas.build(std::clamp(fb_.height() / 50.0, 9.0, 28.0));
  }
}

void Renderer::set_model(const Model& model, const GeometryModel& geometry,
                         const DrawOptions& opt) {
  set_items(make_draw_items(model, geometry, opt));
}

void Renderer::set_items(std::vector<DrawItem> items) {
  items_ = std::move(items);
  std::size_t total = 0;
  for (const DrawItem& it : items_) total += it.mesh ? it.mesh->vertex_count() : 0;
  impl_->reserve(total);
  impl_->frames.assign(items_.size(), ItemFrame());
  impl_->order.resize(items_.size());
}

void Renderer::draw_mesh(const RenderMesh& mesh, const SE3& pose, const Vec3& scale,
                         const Eigen::Vector3d* rgb) {
  Impl& I = *impl_;
  I.reserve(mesh.vertex_count());  // allocates only for a mesh larger than any before
  ItemFrame f;
  if (!I.prepare(mesh, pose, scale, cam_, planes_, style_.light, 0, f)) return;
  I.next_dirty.add(f.rect);
  fb_.set_simd(style_.simd);
  fb_.set_paint(style_.paint);
  f.outside[0] = I.transform(mesh, 0, mesh.vertex_count(), f, cam_, style_.simd);
  float c[3];
  if (rgb) {
    if (!rgb->allFinite()) return;
    for (int k = 0; k < 3; ++k) c[k] = float(std::clamp((*rgb)[k], 0.0, 1.0));
  }
  I.triangles(mesh, f, rgb ? c : nullptr, planes_, RowSet(), fb_);
}

Framebuffer& Renderer::framebuffer() {
  impl_->background_ok = false;
  return fb_;
}

void Renderer::draw_box(const SE3& pose, const Vec3& size, const Eigen::Vector3d& rgb) {
  draw_mesh(impl_->box, pose, size, &rgb);
}
void Renderer::draw_cylinder(const SE3& pose, const Vec3& size, const Eigen::Vector3d& rgb) {
  draw_mesh(impl_->cylinder, pose, size, &rgb);
}
void Renderer::draw_sphere(const SE3& pose, const Vec3& size, const Eigen::Vector3d& rgb) {
  draw_mesh(impl_->sphere, pose, size, &rgb);
}

namespace {

std::size_t npix_tiles(int w, int h) {
  return std::size_t((w + (1 << DirtyTiles::kShift) - 1) >> DirtyTiles::kShift) *
         std::size_t((h + (1 << DirtyTiles::kShift) - 1) >> DirtyTiles::kShift);
}

Vec3d mix(const Vec3d& a, const Vec3d& b, double t) {
  return a + (b - a) * t;
}

const Vec3d kSkyHorizon(0.86, 0.90, 0.95);
const Vec3d kSkyZenith(0.36, 0.53, 0.78);
const Vec3d kGroundNear(0.42, 0.47, 0.54);
const Vec3d kGroundFar(0.70, 0.75, 0.81);
const Vec3d kGridColor(0.30, 0.35, 0.43);

}  // namespace

void Renderer::draw_background() {
  background_rows(RowSet());
}

void Renderer::background_rows(const RowSet& rows) {
  const Eigen::Vector3d l = cam_.horizon_line();
  // The ground is where the viewing ray heads towards the plane z = 0: down (l . p < 0) from
  // above it, up from below.
  const double side = cam_.eye.z() >= 0 ? 1.0 : -1.0;
  const double h = std::max(std::abs(cam_.eye.z()), 1e-3);
  const int W = fb_.width();
  for (int y = 0; y < fb_.height(); ++y) {
    if (!rows.has(y)) continue;
    const double yc = y + 0.5;
    RowBackground& rb = rows_[y];
    // Colours from the ray through the row's middle pixel.
    const Vec3 d = cam_.ray(cam_.cx(), yc);
    const double elev = std::asin(std::clamp(d.z(), -1.0, 1.0));
    const double tsky = std::sqrt(std::clamp(side * elev / (0.5 * M_PI), 0.0, 1.0));
    rb.sky = Rgb::from_float(mix(kSkyHorizon, kSkyZenith, tsky).x(),
                             mix(kSkyHorizon, kSkyZenith, tsky).y(),
                             mix(kSkyHorizon, kSkyZenith, tsky).z())
                 .packed();
    const double dist = std::abs(d.z()) > 1e-9 ? h / std::abs(d.z()) : 1e9;
    const Vec3d g = mix(kGroundNear, kGroundFar, 1.0 - std::exp(-dist / 25.0));
    rb.ground = Rgb::from_float(g.x(), g.y(), g.z()).packed();
    // Split of the row at the horizon: g(u) = side * (l0 u + l1 yc + l2) < 0 is ground.
    const double a = side * l.x(), c = side * (l.y() * yc + l.z());
    if (std::abs(a) < 1e-12 * (std::abs(c) + 1e-300)) {
      rb.split = c < 0 ? W : 0;
      rb.ground_left = true;
    } else {
      const double u = -c / a;  // ground for u < u* when a > 0
      const double uc = std::clamp(u, -1.0, double(W) + 1.0);
      rb.split = std::clamp(int(std::ceil(uc - 0.5)), 0, W);
      rb.ground_left = a > 0;
    }
    if (rb.ground_left) {
      fb_.fill_span(y, 0, rb.split, rb.ground);
      fb_.fill_span(y, rb.split, W, rb.sky);
    } else {
      fb_.fill_span(y, 0, rb.split, rb.sky);
      fb_.fill_span(y, rb.split, W, rb.ground);
    }
    fb_.clear_depth_rows(y, y + 1);
  }
}

uint32_t Renderer::background(int x, int y) const {
  const RowBackground& rb = rows_[std::clamp(y, 0, int(rows_.size()) - 1)];
  const bool left = x < rb.split;
  return left == rb.ground_left ? rb.ground : rb.sky;
}

void Renderer::background_row(int y, int& split, uint32_t& left, uint32_t& right) const {
  const RowBackground& rb = rows_[std::clamp(y, 0, int(rows_.size()) - 1)];
  split = rb.split;
  left = rb.ground_left ? rb.ground : rb.sky;
  right = rb.ground_left ? rb.sky : rb.ground;
}

bool Renderer::ground_at(int x, int y) const {
  const RowBackground& rb = rows_[std::clamp(y, 0, int(rows_.size()) - 1)];
  return (x < rb.split) == rb.ground_left;
}

void Renderer::draw_grid() {
  grid_rows(RowSet());
}

void Renderer::grid_rows(const RowSet& rows) {
  // Two families of parallel lines on z = 0: y = k s (direction e_x) and x = k s (direction
  // e_y). Each line is drawn as two rays from a point on it to its points at infinity
  // (+-d, 0), clipped in RP^3: they end at the family's vanishing point, on the horizon.
  const double s = style_.grid_spacing > 0 ? style_.grid_spacing : 0.5;
  const int n = std::clamp(style_.grid_lines, 0, 1000);
  const Rgb grid = Rgb::from_float(kGridColor.x(), kGridColor.y(), kGridColor.z());
  const Rgb xaxis(150, 70, 70), yaxis(70, 130, 80);
  const float fade = float(6.0 * std::max(1.0, std::abs(cam_.eye.z())));
  for (int fam = 0; fam < 2; ++fam) {
    const Vec4 dir = fam == 0 ? Vec4(1, 0, 0, 0) : Vec4(0, 1, 0, 0);
    for (int k = -n; k <= n; ++k) {
      const Vec4 p = fam == 0 ? Vec4(0, k * s, 0, 1) : Vec4(k * s, 0, 0, 1);
      const Rgb c = k != 0 ? grid : (fam == 0 ? xaxis : yaxis);
      const float w = k != 0 ? 1.0f : 1.6f;
      draw_segment_rows(p, dir, c, w, false, 0.85f, fade, rows);
      draw_segment_rows(p, -dir, c, w, false, 0.85f, fade, rows);
    }
  }
}

void Renderer::draw_segment(const Vec4& a, const Vec4& b, Rgb color, float width, bool depth_test,
                            float opacity, float fade) {
  impl_->next_dirty.add(draw_segment_rows(a, b, color, width, depth_test, opacity, fade, RowSet()));
}

Rect Renderer::draw_segment_rows(const Vec4& a, const Vec4& b, Rgb color, float width,
                                 bool depth_test, float opacity, float fade, const RowSet& rows) {
  Vec4 ca = cam_.clip(a), cb = cam_.clip(b);
  if (!clip_segment(planes_, ca, cb)) return Rect();
  const ScreenVertex sa{float(ca.x() / ca.w()), float(ca.y() / ca.w()), float(ca.z() / ca.w())};
  const ScreenVertex sb{float(cb.x() / cb.w()), float(cb.y() / cb.w()), float(cb.z() / cb.w())};
  fb_.draw_line(sa, sb, color, width, opacity, depth_test, fade, rows);
  const float r = std::max(1.0f, width) + 2.0f;
  auto clampi = [](float v, int lo, int hi) {
    return std::isfinite(v) ? std::clamp(int(v), lo, hi) : lo;
  };
  return Rect{clampi(std::floor(std::min(sa.x, sb.x) - r), 0, fb_.width()),
              clampi(std::floor(std::min(sa.y, sb.y) - r), 0, fb_.height()),
              clampi(std::ceil(std::max(sa.x, sb.x) + r), 0, fb_.width()),
              clampi(std::ceil(std::max(sa.y, sb.y) + r), 0, fb_.height())};
}

void Renderer::draw_marker(const Marker& m) {
  if (!m.a.allFinite() || !m.b.allFinite() || !m.color.allFinite() || !std::isfinite(m.size))
    return;
  const Rgb c = Rgb::from_float(m.color.x(), m.color.y(), m.color.z());
  switch (m.type) {
    case Marker::Type::Point: {
      Vec2 px;
      double iz;
      if (cam_.project(m.a, px, &iz) && px.allFinite() && std::abs(px.x()) < 1e6 &&
          std::abs(px.y()) < 1e6) {
        const float rad = float(std::clamp(m.size, 1.0, 200.0) * 0.5);
        fb_.fill_disc(ScreenVertex{float(px.x()), float(px.y()), float(iz)}, rad, c, true);
        impl_->next_dirty.add(Rect{std::max(0, int(px.x() - rad) - 2),
                                   std::max(0, int(px.y() - rad) - 2),
                                   std::min(fb_.width(), int(px.x() + rad) + 3),
                                   std::min(fb_.height(), int(px.y() + rad) + 3)});
      }
      break;
    }
    case Marker::Type::Sphere:
      draw_sphere(SE3(Mat3::Identity(), m.a), Vec3::Constant(std::abs(m.size)), m.color);
      break;
    case Marker::Type::Box:
      if (m.size3.allFinite() && is_rotation(m.R))
        draw_box(SE3(m.R, m.a), m.size3.cwiseAbs(), m.color);
      break;
    case Marker::Type::Cylinder:  // the geometry layer's cylinder mesh (unit, scaled)
      if (m.size3.allFinite() && is_rotation(m.R))
        draw_cylinder(SE3(m.R, m.a), m.size3.cwiseAbs(), m.color);
      break;
    case Marker::Type::Mesh:
      if (m.mesh && is_rotation(m.R))
        draw_mesh(*m.mesh, SE3(m.R, m.a), Vec3::Ones(), m.mesh_colors ? nullptr : &m.color);
      break;
    case Marker::Type::Line:
      draw_segment(Vec4(m.a.x(), m.a.y(), m.a.z(), 1), Vec4(m.b.x(), m.b.y(), m.b.z(), 1), c,
                   float(std::clamp(m.size, 0.5, 20.0)), true);
      break;
    case Marker::Type::Arrow: {
      const Vec3 d = m.b - m.a;
      const double len = d.norm();
      if (!(len > 1e-6)) break;
      const double shaft = std::clamp(std::abs(m.size), 1e-4, 0.5 * len);
      const double head = std::min(0.35 * len, 3.0 * shaft);
      const Vec3 mid = m.b - d / len * head;
      if ((mid - m.a).norm() > 1e-6)
        draw_mesh(impl_->cylinder, segment_frame(m.a, mid), Vec3(shaft, shaft, (mid - m.a).norm()),
                  &m.color);
      SE3 f = segment_frame(mid, m.b);
      f.p = mid;
      draw_mesh(impl_->cone, f, Vec3(2 * shaft, 2 * shaft, head), &m.color);
      break;
    }
  }
}

// ---------------------------------------------------------------- one frame

// The two halves of a frame, for part `part` of `parts` (rows in bands of 32).
//   phase 1: background and grid of the part's rows, and its share of the vertices;
//   phase 2: every triangle, written to the part's rows;
//   phase 3: the rgb8 copy of the part's rows.
void Renderer::Impl::start(Renderer* r) {
  if (worker.joinable()) return;
  owner = r;
  worker = std::thread([this] {
    for (;;) {
      int j;
      {
        std::unique_lock<std::mutex> lock(mu);
        cv.wait(lock, [&] { return job != 0; });
        j = job;
      }
      if (j < 0) return;
      owner->frame_part(j, 1, 2);
      {
        std::lock_guard<std::mutex> lock(mu);
        job = 0;
        done = true;
      }
      cv.notify_all();
    }
  });
}

void Renderer::Impl::stop() {
  if (!worker.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(mu);
    job = -1;
  }
  cv.notify_all();
  worker.join();
}

void Renderer::frame_part(int phase, int part, int parts) {
  Impl& I = *impl_;
  RowSet rows;
  rows.parts = parts;
  rows.part = part;
  if (phase == 1) {
    const int W = fb_.width();
    if (I.background_ok) {
      // Only where the last frame drew (runs of marked tiles): the cached background back,
      // depth cleared.
      const DirtyTiles& d = I.dirty;
      for (int t = 0; t < d.ty && d.any; ++t) {
        const uint8_t* m = d.mark.data() + std::size_t(t) * d.tx;
        for (int a = 0; a < d.tx;) {
          if (!m[a]) {
            ++a;
            continue;
          }
          int b = a + 1;
          while (b < d.tx && m[b]) ++b;
          const int x0 = a << DirtyTiles::kShift, x1 = std::min(W, b << DirtyTiles::kShift);
          const int y1 = std::min(fb_.height(), (t + 1) << DirtyTiles::kShift);
          for (int y = t << DirtyTiles::kShift; y < y1; ++y) {
            if (!rows.has(y)) continue;
            const std::size_t at = std::size_t(y) * W + x0;
            if (style_.paint && style_.keep_background)
              std::memcpy(fb_.color() + at, I.background.data() + at, std::size_t(x1 - x0) * 4);
            std::memset(fb_.depth() + at, 0, std::size_t(x1 - x0) * 4);
          }
          a = b;
        }
      }
    } else if (!style_.paint) {
      for (int y = 0; y < fb_.height(); ++y) {
        if (rows.has(y)) fb_.clear_depth_rows(y, y + 1);
      }
    } else {
      background_rows(rows);
      if (style_.grid) grid_rows(rows);
      for (int y = 0; y < fb_.height(); ++y) {
        if (!rows.has(y)) continue;
        const std::size_t at = std::size_t(y) * W;
        std::memcpy(I.background.data() + at, fb_.color() + at, std::size_t(W) * 4);
      }
    }
    std::size_t total = 0;
    for (const DrawItem& it : items_) total += it.mesh ? it.mesh->vertex_count() : 0;
    const std::size_t lo = total * part / parts, hi = total * (part + 1) / parts;
    for (std::size_t k = 0; k < items_.size(); ++k) {
      ItemFrame& f = I.frames[k];
      if (!f.visible) continue;
      const std::size_t n = items_[k].mesh->vertex_count();
      const std::size_t a = std::max(f.vbase, lo), b = std::min(f.vbase + n, hi);
      // Each part its own byte (the other part may write its own at the same time).
      f.outside[part] =
          a < b ? I.transform(*items_[k].mesh, a - f.vbase, b - f.vbase, f, cam_, style_.simd) : 0;
    }
  } else if (phase == 2) {
    std::size_t n = 0;
    for (const uint32_t k : I.order) {
      n += I.triangles(*items_[k].mesh, I.frames[k], nullptr, planes_, rows, fb_);
    }
    if (part == 0) {
      last_triangles_ = n;
    } else {
      I.worker_triangles = n;
    }
  } else if (phase == 3) {
    for (int y0 = part << rows.shift; y0 < fb_.height(); y0 += parts << rows.shift) {
      fb_.copy_rgb8_rows(I.copy_dst, y0, std::min(fb_.height(), y0 + (1 << rows.shift)));
    }
  }
}

void Renderer::render(const std::vector<SE3>& oMb, const std::vector<Marker>& markers,
                      const Overlay& overlay) {
  Impl& I = *impl_;
  fb_.set_simd(style_.simd);
  fb_.set_paint(style_.paint);
  std::swap(I.dirty, I.next_dirty);  // no allocation: the two buffers trade places
  if (I.next_dirty.mark.size() != npix_tiles(fb_.width(), fb_.height())) {
    I.dirty.resize(fb_.width(), fb_.height());  // first frame or a new size: all redrawn
    I.next_dirty.resize(fb_.width(), fb_.height());
    I.background_ok = false;
  }
  I.next_dirty.clear();
  // The cached background serves while camera and grid are as when it was drawn.
  const double grid_sig[4] = {style_.grid ? 1.0 : 0.0, style_.grid_spacing,
                              double(style_.grid_lines), style_.paint ? 1.0 : 0.0};
  const std::size_t npix = std::size_t(fb_.width()) * fb_.height();
  if (I.background.size() != npix || I.background_P != cam_.P || I.background_eye != cam_.eye ||
      !std::equal(grid_sig, grid_sig + 4, I.background_grid) ||
      (I.stale_color && style_.keep_background)) {
    I.background_ok = false;
  }
  I.stale_color = !style_.keep_background;
  if (!I.background_ok) {
    I.background.resize(npix);  // allocates only when the image size changes
    I.background_P = cam_.P;
    I.background_eye = cam_.eye;
    std::copy(grid_sig, grid_sig + 4, I.background_grid);
  }
  // Item transforms (serial: a few matrix products each).
  std::size_t vbase = 0;
  for (std::size_t k = 0; k < items_.size(); ++k) {
    const DrawItem& it = items_[k];
    ItemFrame& f = I.frames[k];
    f.visible = false;
    f.vbase = vbase;
    f.outside[0] = f.outside[1] = 0;
    if (!it.mesh) continue;
    vbase += it.mesh->vertex_count();
    const bool world = it.body == GeometryObject::kWorld;  // fixed in the world
    if (!world && (it.body < 0 || it.body >= int(oMb.size()) || !finite_pose(oMb[it.body]))) {
      continue;
    }
    if (I.prepare(*it.mesh, world ? it.local : oMb[it.body] * it.local, Vec3::Ones(), cam_, planes_,
                  style_.light, f.vbase, f)) {
      I.next_dirty.add(f.rect);
    }
  }
  // Nearest first: nearer triangles then hide more of the farther ones' pixels before they are
  // shaded. The depth test does not depend on the order, so neither does the image.
  for (std::size_t k = 0; k < I.order.size(); ++k) I.order[k] = uint32_t(k);
  std::sort(I.order.begin(), I.order.end(), [&I](uint32_t a, uint32_t b) {
    return I.frames[a].depth < I.frames[b].depth ||
           (I.frames[a].depth == I.frames[b].depth && a < b);
  });
  const int parts = style_.threads >= 2 ? 2 : 1;
  if (parts == 2) {
    I.start(this);
    I.together(1, [&] { frame_part(1, 0, 2); });
    I.together(2, [&] { frame_part(2, 0, 2); });
    last_triangles_ += I.worker_triangles;
  } else {
    frame_part(1, 0, 1);
    frame_part(2, 0, 1);
  }
  I.background_ok = true;
  for (const Marker& m : markers) draw_marker(m);
  if (style_.frames) {
    const double L = style_.frame_length;
    const Rgb axis_color[3] = {Rgb(220, 40, 40), Rgb(40, 180, 60), Rgb(40, 80, 230)};
    for (const SE3& f : oMb) {
      if (!finite_pose(f)) continue;
      const Vec4 o(f.p.x(), f.p.y(), f.p.z(), 1);
      for (int a = 0; a < 3; ++a) {
        const Vec3 e = f.p + L * f.R.col(a);
        draw_segment(o, Vec4(e.x(), e.y(), e.z(), 1), axis_color[a], 2.0f, true);
      }
    }
  }
  if (style_.overlay) draw_overlay(overlay);
}

void Renderer::copy_rgb8(uint8_t* dst) {
  Impl& I = *impl_;
  I.copy_dst = dst;
  if (style_.threads >= 2) {
    I.start(this);
    I.together(3, [&] { frame_part(3, 0, 2); });
  } else {
    fb_.copy_rgb8(dst);
  }
}

bool Renderer::write_png(const std::string& path, std::string* error) const {
  // Cairo's RGB24 is the colour buffer's layout: a surface over it writes the PNG.
  cairo_surface_t* s = cairo_image_surface_create_for_data(
      reinterpret_cast<unsigned char*>(const_cast<uint32_t*>(fb_.color())), CAIRO_FORMAT_RGB24,
      fb_.width(), fb_.height(), fb_.width() * 4);
  const cairo_status_t st = cairo_surface_write_to_png(s, path.c_str());
  cairo_surface_destroy(s);
  if (st != CAIRO_STATUS_SUCCESS) {
    if (error) *error = "cannot write " + path + ": " + cairo_status_to_string(st);
    return false;
  }
  return true;
}

// ---------------------------------------------------------------- one frame to PNG

bool parse_camera_spec(const std::string& spec, RenderOptions& opt, std::string* error) {
  std::vector<double> v;
  std::stringstream ss(spec);
  std::string tok;
  while (std::getline(ss, tok, ',')) {
    char* end = nullptr;
    const double x = std::strtod(tok.c_str(), &end);
    if (tok.empty() || end == tok.c_str() || *end != '\0' || !std::isfinite(x)) {
      if (error) *error = "bad --camera value '" + tok + "' (want ex,ey,ez,tx,ty,tz[,focal_px])";
      return false;
    }
    v.push_back(x);
  }
  if (v.size() != 6 && v.size() != 7) {
    if (error) *error = "--camera wants 6 or 7 numbers: ex,ey,ez,tx,ty,tz[,focal_px]";
    return false;
  }
  if (v.size() == 7 && !(v[6] > 0)) {
    if (error) *error = "--camera focal_px must be positive";
    return false;
  }
  const Vec3 eye(v[0], v[1], v[2]), target(v[3], v[4], v[5]);
  if ((eye - target).norm() < 1e-9) {
    if (error) *error = "--camera eye and target coincide";
    return false;
  }
  opt.camera.eye = eye;
  opt.camera.target = target;
  if (v.size() == 7) opt.camera.focal_px = v[6];
  opt.auto_camera = false;
  return true;
}

int render_to_png(const Model& model, const GeometryModel& geometry, const RenderOptions& opt,
                  const std::string& out_path, std::string* error) {
  try {
    if (opt.q.size() != 0 && opt.q.size() != model.n) {
      if (error)
        *error = "q has " + std::to_string(opt.q.size()) + " entries, model has " +
                 std::to_string(model.n) + " joints";
      return 1;
    }
    if (!opt.q.allFinite() || !finite_pose(opt.base)) {
      if (error) *error = "non-finite pose or joint position";
      return 1;
    }
    Data data(model);
    const VecX q = opt.q.size() ? opt.q : VecX(VecX::Zero(model.n));
    forward_kinematics(model, data, opt.base, q);
    const std::vector<DrawItem> items = make_draw_items(model, geometry, opt.draw);
    Camera cam = opt.camera;
    if (opt.auto_camera) frame_items(items, data.oMb, cam, opt.markers);
    Renderer r(cam);
    r.style() = opt.style;
    r.set_items(items);
    r.render(data.oMb, opt.markers, opt.overlay);
    std::string err;
    if (!r.write_png(out_path, &err)) {
      if (error) *error = err;
      return 1;
    }
    return 0;
  } catch (const std::exception& e) {
    if (error) *error = e.what();
    return 1;
  }
}

}  // namespace render
}  // namespace se3
