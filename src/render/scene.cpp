// The scene: sky and ground, the ground grid in the painter's perspective, the model's
// visuals (with mesh stand-ins), markers, frames, text overlay and PNG output.
#include <cairo.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "se3_sim/render.h"

namespace se3 {
namespace render {

struct Renderer::Mesh {
  std::vector<Vec3> v;
  std::vector<std::array<int, 3>> tri;  ///< counter-clockwise seen from outside
};

namespace {

using Vec3d = Eigen::Vector3d;

bool finite_pose(const SE3& f) {
  return f.R.allFinite() && f.p.allFinite();
}

// Unit shapes centred at the origin: box [-0.5, 0.5]^3, cylinder of radius 0.5 and length 1
// along z, sphere of radius 0.5, cone of base radius 0.5 at z = 0 and apex at z = 1.

constexpr int kCylSeg = 24;
constexpr int kSphLat = 9, kSphLon = 18;

template <class M>
void box_mesh(M& m) {
  for (int i = 0; i < 8; ++i)
    m.v.emplace_back((i & 1) ? 0.5 : -0.5, (i & 2) ? 0.5 : -0.5, (i & 4) ? 0.5 : -0.5);
  const int q[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                       {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (auto& f : q) {
    m.tri.push_back({f[0], f[1], f[2]});
    m.tri.push_back({f[0], f[2], f[3]});
  }
}

template <class M>
void cylinder_mesh(M& m) {
  for (int i = 0; i < kCylSeg; ++i) {
    const double a = 2 * M_PI * i / kCylSeg;
    m.v.emplace_back(0.5 * std::cos(a), 0.5 * std::sin(a), -0.5);
    m.v.emplace_back(0.5 * std::cos(a), 0.5 * std::sin(a), 0.5);
  }
  const int cb = int(m.v.size());
  m.v.emplace_back(0, 0, -0.5);
  m.v.emplace_back(0, 0, 0.5);
  for (int i = 0; i < kCylSeg; ++i) {
    const int j = (i + 1) % kCylSeg;
    const int b0 = 2 * i, t0 = 2 * i + 1, b1 = 2 * j, t1 = 2 * j + 1;
    m.tri.push_back({b0, b1, t1});
    m.tri.push_back({b0, t1, t0});
    m.tri.push_back({cb, b1, b0});
    m.tri.push_back({cb + 1, t0, t1});
  }
}

template <class M>
void sphere_mesh(M& m) {
  m.v.emplace_back(0, 0, -0.5);
  for (int i = 1; i < kSphLat; ++i) {
    const double th = M_PI * i / kSphLat - M_PI / 2;
    for (int j = 0; j < kSphLon; ++j) {
      const double ph = 2 * M_PI * j / kSphLon;
      m.v.emplace_back(0.5 * std::cos(th) * std::cos(ph), 0.5 * std::cos(th) * std::sin(ph),
                       0.5 * std::sin(th));
    }
  }
  m.v.emplace_back(0, 0, 0.5);
  const int top = int(m.v.size()) - 1;
  auto ring = [](int i, int j) { return 1 + (i - 1) * kSphLon + (j % kSphLon); };
  for (int j = 0; j < kSphLon; ++j) m.tri.push_back({0, ring(1, j + 1), ring(1, j)});
  for (int i = 1; i < kSphLat - 1; ++i) {
    for (int j = 0; j < kSphLon; ++j) {
      m.tri.push_back({ring(i, j), ring(i, j + 1), ring(i + 1, j + 1)});
      m.tri.push_back({ring(i, j), ring(i + 1, j + 1), ring(i + 1, j)});
    }
  }
  for (int j = 0; j < kSphLon; ++j)
    m.tri.push_back({top, ring(kSphLat - 1, j), ring(kSphLat - 1, j + 1)});
}

template <class M>
void cone_mesh(M& m) {
  for (int i = 0; i < kCylSeg; ++i) {
    const double a = 2 * M_PI * i / kCylSeg;
    m.v.emplace_back(0.5 * std::cos(a), 0.5 * std::sin(a), 0.0);
  }
  m.v.emplace_back(0, 0, 0);
  m.v.emplace_back(0, 0, 1);
  const int c = kCylSeg, apex = kCylSeg + 1;
  for (int i = 0; i < kCylSeg; ++i) {
    const int j = (i + 1) % kCylSeg;
    m.tri.push_back({i, j, apex});
    m.tri.push_back({c, j, i});
  }
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

DrawItem item_from_geometry(const Geometry& g, int body, const Vec3d& color) {
  DrawItem it;
  it.body = body;
  it.local = g.origin;
  it.link = g.link;
  it.color = g.has_color ? Vec3d(g.rgba.head<3>()) : color;
  switch (g.type) {
    case GeometryType::Box:
      it.shape = DrawItem::Shape::Box;
      it.size = g.size;
      break;
    case GeometryType::Cylinder:
      it.shape = DrawItem::Shape::Cylinder;
      it.size = Vec3(2 * g.size.x(), 2 * g.size.x(), g.size.y());
      break;
    case GeometryType::Sphere:
    case GeometryType::Mesh:
      it.shape = DrawItem::Shape::Sphere;
      it.size = Vec3::Constant(2 * g.size.x());
      break;
  }
  return it;
}

const Vec3d kPrimitiveColor(0.74, 0.76, 0.80);
const Vec3d kLinkColor(0.90, 0.91, 0.93);
const Vec3d kJointColor(0.24, 0.26, 0.30);

}  // namespace

std::vector<DrawItem> make_draw_items(const Model& model) {
  std::vector<DrawItem> items;
  const int nb = int(model.parent.size());
  // Stand-in radius from the model's typical joint spacing.
  double sum = 0;
  int cnt = 0;
  for (int i = 1; i < nb && i < int(model.X_tree.size()); ++i) {
    const double l = model.X_tree[i].p.norm();
    if (l > 1e-4 && std::isfinite(l)) sum += l, ++cnt;
  }
  const double r = std::clamp(cnt ? 0.22 * sum / cnt : 0.03, 0.012, 0.06);

  std::vector<std::pair<int, std::string>> stand_in;  // (body, link) of mesh visuals
  const size_t nv = std::min(model.visuals.size(), model.visual_body.size());
  for (size_t k = 0; k < nv; ++k) {
    const Geometry& g = model.visuals[k];
    const int b = model.visual_body[k];
    if (b < 0 || b >= nb) continue;
    if (g.type != GeometryType::Mesh) {
      if (g.size.allFinite()) items.push_back(item_from_geometry(g, b, kPrimitiveColor));
      continue;
    }
    std::pair<int, std::string> key(b, g.link);
    if (std::find(stand_in.begin(), stand_in.end(), key) == stand_in.end()) stand_in.push_back(key);
  }

  for (const auto& [b, link] : stand_in) {
    // 1. The link's collision primitives.
    bool found = false;
    const size_t nc = std::min(model.collisions.size(), model.collision_body.size());
    for (size_t j = 0; j < nc; ++j) {
      const Geometry& c = model.collisions[j];
      if (model.collision_body[j] != b || c.link != link || c.type == GeometryType::Mesh) continue;
      items.push_back(item_from_geometry(c, b, kLinkColor));
      found = true;
    }
    if (found) continue;
    // 2. Cylinders from the body origin to the joints of its children (the body's own link)
    // or to the merged link's frame, a joint housing along the joint axis (body z), and a
    // ball at a leaf.
    const int li = model.link_index(link);
    const bool carrier = b < int(model.body_name.size()) && model.body_name[b] == link;
    std::vector<Vec3> ends;
    if (carrier || li < 0) {
      for (int c = 1; c < nb; ++c)
        if (model.parent[c] == b && c < int(model.X_tree.size())) ends.push_back(model.X_tree[c].p);
    } else {
      ends.push_back(model.links[li].offset.p);
    }
    bool drew_segment = false;
    for (const Vec3& e : ends) {
      const double len = e.norm();
      if (!(len > 1e-4) || !std::isfinite(len)) continue;
      DrawItem it;
      it.shape = DrawItem::Shape::Cylinder;
      it.body = b;
      it.link = link;
      it.local = segment_frame(Vec3::Zero(), e);
      it.size = Vec3(2 * r, 2 * r, len);
      it.color = kLinkColor;
      items.push_back(it);
      DrawItem ball = it;
      ball.shape = DrawItem::Shape::Sphere;
      ball.local = SE3(Mat3::Identity(), e);
      ball.size = Vec3::Constant(2 * r);
      items.push_back(ball);
      drew_segment = true;
    }
    if (carrier && b >= 1) {
      DrawItem it;
      it.shape = DrawItem::Shape::Cylinder;
      it.body = b;
      it.link = link;
      it.size = Vec3(2.5 * r, 2.5 * r, 3.0 * r);
      it.color = kJointColor;
      items.push_back(it);
      drew_segment = true;
    }
    if (!drew_segment) {
      DrawItem it;
      it.shape = DrawItem::Shape::Sphere;
      it.body = b;
      it.link = link;
      it.local =
          SE3(Mat3::Identity(), li >= 0 && !carrier ? model.links[li].offset.p : Vec3::Zero());
      it.size = Vec3::Constant(2 * r);
      it.color = kLinkColor;
      items.push_back(it);
    }
  }
  return items;
}

void frame_bodies(const Model& model, const std::vector<SE3>& oMb, Camera& cam,
                  const std::vector<Marker>& boxes) {
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  int cnt = 0;
  auto add = [&](const Vec3& p) {
    if (!p.allFinite()) return;
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
    ++cnt;
  };
  for (size_t i = 0; i < oMb.size(); ++i) {
    if (!finite_pose(oMb[i])) continue;
    add(oMb[i].p);
    for (size_t c = 1; c < model.parent.size() && c < model.X_tree.size(); ++c)
      if (model.parent[c] == int(i)) add(oMb[i].act(model.X_tree[c].p));
  }
  for (const Marker& m : boxes) {  // the corners of box markers (solid geometry, like a body)
    if (m.type != Marker::Type::Box || !m.R.allFinite()) continue;
    for (int c = 0; c < 8; ++c) {
      const Vec3 s((c & 1) ? 0.5 : -0.5, (c & 2) ? 0.5 : -0.5, (c & 4) ? 0.5 : -0.5);
      add(m.a + m.R * s.cwiseProduct(m.size3));
    }
  }
  if (!cnt) add(Vec3::Zero());
  const Vec3 center = 0.5 * (lo + hi);
  const double radius = std::max(0.5 * (hi - lo).norm(), 0.3) + 0.15;
  const double half_fov = std::atan(0.5 * std::min(cam.width, cam.height) / cam.focal_px);
  const double dist = radius / std::sin(half_fov) * 1.05;
  const double az = -55.0 * M_PI / 180.0, el = 20.0 * M_PI / 180.0;
  cam.target = center;
  cam.eye =
      center + dist * Vec3(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
  cam.up = Vec3(0, 0, 1);
  cam.update();
}

// ---------------------------------------------------------------- Renderer

Renderer::Renderer(const Camera& cam)
    : box_(new Mesh), cylinder_(new Mesh), sphere_(new Mesh), cone_(new Mesh) {
  box_mesh(*box_);
  cylinder_mesh(*cylinder_);
  sphere_mesh(*sphere_);
  cone_mesh(*cone_);
  size_t nmax = 0;
  for (const Mesh* m : {box_.get(), cylinder_.get(), sphere_.get(), cone_.get()})
    nmax = std::max(nmax, m->v.size());
  clip_scratch_.resize(nmax);
  world_scratch_.resize(nmax);
  cam_ = cam;
  cam_.update();
  planes_ = ClipPlanes(cam_);
  fb_.resize(cam_.width, cam_.height);
  rows_.resize(cam_.height);
  make_cairo();
}

Renderer::~Renderer() {
  free_cairo();
}

void Renderer::make_cairo() {
  free_cairo();
  auto* s = cairo_image_surface_create_for_data(reinterpret_cast<unsigned char*>(fb_.color()),
                                                CAIRO_FORMAT_RGB24, fb_.width(), fb_.height(),
                                                fb_.width() * 4);
  cairo_surface_ = s;
  cairo_ = cairo_create(s);
}

void Renderer::free_cairo() {
  if (cairo_) cairo_destroy(static_cast<cairo_t*>(cairo_));
  if (cairo_surface_) cairo_surface_destroy(static_cast<cairo_surface_t*>(cairo_surface_));
  cairo_ = nullptr;
  cairo_surface_ = nullptr;
}

void Renderer::set_camera(const Camera& cam) {
  Camera c = cam;
  c.update();
  const bool resized = c.width != fb_.width() || c.height != fb_.height();
  cam_ = c;
  planes_ = ClipPlanes(cam_);
  if (resized) {
    free_cairo();
    fb_.resize(cam_.width, cam_.height);
    rows_.assign(cam_.height, RowBackground());
    make_cairo();
  }
}

void Renderer::set_model(const Model& model) {
  items_ = make_draw_items(model);
}

namespace {

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
  const Eigen::Vector3d l = cam_.horizon_line();
  // The ground is where the viewing ray heads towards the plane z = 0: down (l . p < 0) from
  // above it, up from below.
  const double side = cam_.eye.z() >= 0 ? 1.0 : -1.0;
  const double h = std::max(std::abs(cam_.eye.z()), 1e-3);
  const int W = fb_.width();
  for (int y = 0; y < fb_.height(); ++y) {
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
  }
  fb_.clear_depth();
}

uint32_t Renderer::background(int x, int y) const {
  const RowBackground& rb = rows_[std::clamp(y, 0, int(rows_.size()) - 1)];
  const bool left = x < rb.split;
  return left == rb.ground_left ? rb.ground : rb.sky;
}

bool Renderer::ground_at(int x, int y) const {
  const RowBackground& rb = rows_[std::clamp(y, 0, int(rows_.size()) - 1)];
  return (x < rb.split) == rb.ground_left;
}

void Renderer::draw_grid() {
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
      draw_segment(p, dir, c, w, false, 0.85f, fade);
      draw_segment(p, -dir, c, w, false, 0.85f, fade);
    }
  }
}

void Renderer::draw_segment(const Vec4& a, const Vec4& b, Rgb color, float width, bool depth_test,
                            float opacity, float fade) {
  const ClipPlanes& planes = planes_;
  Vec4 ca = cam_.clip(a), cb = cam_.clip(b);
  if (!clip_segment(planes, ca, cb)) return;
  const ScreenVertex sa{float(ca.x() / ca.w()), float(ca.y() / ca.w()), float(ca.z() / ca.w())};
  const ScreenVertex sb{float(cb.x() / cb.w()), float(cb.y() / cb.w()), float(cb.z() / cb.w())};
  fb_.draw_line(sa, sb, color, width, opacity, depth_test, fade);
}

void Renderer::draw_triangle_clip(const Vec4& a, const Vec4& b, const Vec4& c, uint32_t color) {
  const ClipPlanes& planes = planes_;
  const Vec4 in[3] = {a, b, c};
  Vec4 out[16];
  int n;
  bool inside = true;
  for (const Vec4& v : in)
    for (int p = 0; p < planes.count; ++p) inside = inside && planes.plane[p].dot(v) >= 0;
  if (inside) {
    for (int i = 0; i < 3; ++i) out[i] = in[i];
    n = 3;
  } else {
    n = clip_polygon(planes, in, 3, out);
  }
  if (n < 3) return;
  ScreenVertex sv[16];
  for (int i = 0; i < n; ++i) {
    if (!(out[i].w() > 0)) return;
    sv[i] = ScreenVertex{float(out[i].x() / out[i].w()), float(out[i].y() / out[i].w()),
                         float(out[i].z() / out[i].w())};
  }
  for (int i = 1; i + 1 < n; ++i) fb_.fill_triangle(sv[0], sv[i], sv[i + 1], color);
}

void Renderer::draw_mesh(const Mesh& mesh, const SE3& pose, const Vec3& scale,
                         const Eigen::Vector3d& rgb) {
  if (!finite_pose(pose) || !scale.allFinite()) return;
  const size_t nv = mesh.v.size();
  const Mat3 RS = pose.R * scale.asDiagonal();
  for (size_t i = 0; i < nv; ++i) {
    world_scratch_[i] = RS * mesh.v[i] + pose.p;
    clip_scratch_[i] = cam_.clip(world_scratch_[i]);
  }
  Vec3 L = style_.light;
  L = L.norm() > 0 ? Vec3(L.normalized()) : Vec3(0, 0, 1);
  for (const auto& t : mesh.tri) {
    const Vec3& p0 = world_scratch_[t[0]];
    const Vec3 nrm = (world_scratch_[t[1]] - p0).cross(world_scratch_[t[2]] - p0);
    const Vec3 to_eye = cam_.eye - p0;
    if (nrm.dot(to_eye) <= 0) continue;  // back face
    const double nn = nrm.norm();
    if (!(nn > 0)) continue;
    const Vec3 nu = nrm / nn;
    const double view = std::max(0.0, nu.dot(to_eye.normalized()));
    const double k = 0.30 + 0.55 * std::max(0.0, nu.dot(L)) + 0.22 * view;
    const Rgb c = Rgb::from_float(rgb.x() * k, rgb.y() * k, rgb.z() * k);
    draw_triangle_clip(clip_scratch_[t[0]], clip_scratch_[t[1]], clip_scratch_[t[2]], c.packed());
  }
}

void Renderer::draw_box(const SE3& pose, const Vec3& size, const Eigen::Vector3d& rgb) {
  draw_mesh(*box_, pose, size, rgb);
}
void Renderer::draw_cylinder(const SE3& pose, const Vec3& size, const Eigen::Vector3d& rgb) {
  draw_mesh(*cylinder_, pose, size, rgb);
}
void Renderer::draw_sphere(const SE3& pose, const Vec3& size, const Eigen::Vector3d& rgb) {
  draw_mesh(*sphere_, pose, size, rgb);
}

void Renderer::draw_marker(const Marker& m) {
  if (!m.a.allFinite() || !m.b.allFinite() || !m.color.allFinite() || !std::isfinite(m.size))
    return;
  const Rgb c = Rgb::from_float(m.color.x(), m.color.y(), m.color.z());
  switch (m.type) {
    case Marker::Type::Point: {
      Vec2 px;
      double iz;
      if (cam_.project(m.a, px, &iz))
        fb_.fill_disc(ScreenVertex{float(px.x()), float(px.y()), float(iz)},
                      float(std::clamp(m.size, 1.0, 200.0) * 0.5), c, true);
      break;
    }
    case Marker::Type::Sphere:
      draw_sphere(SE3(Mat3::Identity(), m.a), Vec3::Constant(std::abs(m.size)), m.color);
      break;
    case Marker::Type::Box:
      if (m.size3.allFinite() && is_rotation(m.R))
        draw_box(SE3(m.R, m.a), m.size3.cwiseAbs(), m.color);
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
        draw_mesh(*cylinder_, segment_frame(m.a, mid), Vec3(shaft, shaft, (mid - m.a).norm()),
                  m.color);
      SE3 f = segment_frame(mid, m.b);
      f.p = mid;
      draw_mesh(*cone_, f, Vec3(2 * shaft, 2 * shaft, head), m.color);
      break;
    }
  }
}

void Renderer::draw_overlay(const Overlay& ov) {
  std::vector<std::string> lines;
  char buf[160];
  if (std::isfinite(ov.sim_time)) {
    std::snprintf(buf, sizeof buf, "sim time  %9.3f s", ov.sim_time);
    lines.emplace_back(buf);
  }
  if (std::isfinite(ov.real_time_factor)) {
    std::snprintf(buf, sizeof buf, "real time x %.2f", ov.real_time_factor);
    lines.emplace_back(buf);
  }
  if (!ov.joint.empty()) {
    if (std::isfinite(ov.torque))
      std::snprintf(buf, sizeof buf, "joint %.60s  tau %+.3f", ov.joint.c_str(), ov.torque);
    else
      std::snprintf(buf, sizeof buf, "joint %.60s", ov.joint.c_str());
    lines.emplace_back(buf);
  }
  for (const auto& l : ov.lines) lines.push_back(l);
  if (lines.empty() || !cairo_) return;
  auto* cr = static_cast<cairo_t*>(cairo_);
  const double fs = std::clamp(fb_.height() / 50.0, 9.0, 28.0);
  cairo_surface_mark_dirty(static_cast<cairo_surface_t*>(cairo_surface_));
  cairo_save(cr);
  cairo_select_font_face(cr, "monospace", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, fs);
  double wmax = 0;
  for (const auto& l : lines) {
    cairo_text_extents_t e;
    cairo_text_extents(cr, l.c_str(), &e);
    wmax = std::max(wmax, e.x_advance);
  }
  const double pad = 0.5 * fs, lh = 1.35 * fs;
  cairo_rectangle(cr, pad, pad, wmax + 2 * pad, lines.size() * lh + pad);
  cairo_set_source_rgba(cr, 0.08, 0.10, 0.14, 0.55);
  cairo_fill(cr);
  cairo_set_source_rgb(cr, 0.97, 0.97, 0.97);
  for (size_t i = 0; i < lines.size(); ++i) {
    cairo_move_to(cr, 2 * pad, pad + (i + 1) * lh - 0.25 * fs);
    cairo_show_text(cr, lines[i].c_str());
  }
  cairo_restore(cr);
  cairo_surface_flush(static_cast<cairo_surface_t*>(cairo_surface_));
}

void Renderer::render(const std::vector<SE3>& oMb, const std::vector<Marker>& markers,
                      const Overlay& overlay) {
  draw_background();
  if (style_.grid) draw_grid();
  for (const DrawItem& it : items_) {
    if (it.body < 0 || it.body >= int(oMb.size())) continue;
    const SE3 pose = oMb[it.body] * it.local;
    switch (it.shape) {
      case DrawItem::Shape::Box:
        draw_mesh(*box_, pose, it.size, it.color);
        break;
      case DrawItem::Shape::Cylinder:
        draw_mesh(*cylinder_, pose, it.size, it.color);
        break;
      case DrawItem::Shape::Sphere:
        draw_mesh(*sphere_, pose, it.size, it.color);
        break;
    }
  }
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

bool Renderer::write_png(const std::string& path, std::string* error) const {
  auto* s = static_cast<cairo_surface_t*>(cairo_surface_);
  if (!s) {
    if (error) *error = "no image surface";
    return false;
  }
  cairo_surface_mark_dirty(s);
  const cairo_status_t st = cairo_surface_write_to_png(s, path.c_str());
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

int render_to_png(const Model& model, const RenderOptions& opt, const std::string& out_path,
                  std::string* error) {
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
    Camera cam = opt.camera;
    if (opt.auto_camera) frame_bodies(model, data.oMb, cam, opt.markers);
    Renderer r(cam);
    r.style() = opt.style;
    r.set_model(model);
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
