// Renderer: projection in RP^3, vanishing points, clipping at the near plane, the horizon,
// rasterized coverage, mesh stand-ins and PNG output.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "se3_sim/render/render.h"
#include "source_paths.h"

using namespace se3;
using namespace se3::render;

namespace {

Camera level_camera() {
  Camera c;
  c.width = 1280;
  c.height = 1024;
  c.focal_px = 1000;
  c.eye = Vec3(0, -5, 1);
  c.target = Vec3(0, 0, 1);
  c.update();
  return c;
}

// VertexArrays::xy from separate x and y.
std::vector<int32_t> interleave(const std::vector<int32_t>& X, const std::vector<int32_t>& Y) {
  std::vector<int32_t> xy(2 * X.size());
  for (std::size_t i = 0; i < X.size(); ++i) {
    xy[2 * i] = X[i];
    xy[2 * i + 1] = Y[i];
  }
  return xy;
}

void make_plain(Renderer& r) {
  r.style().grid = false;
  r.style().overlay = false;
}

}  // namespace

TEST(RenderCamera, KnownPointLandsOnItsPixel) {
  const Camera c = level_camera();
  // Camera frame: x right = world x, y down = -world z, z forward = world y; depth 5.
  Vec2 px;
  double iz = 0;
  ASSERT_TRUE(c.project(Vec3(1.0, 0.0, 1.5), px, &iz));
  EXPECT_NEAR(px.x(), 640 + 1000 * 1.0 / 5, 1e-9);
  EXPECT_NEAR(px.y(), 512 - 1000 * 0.5 / 5, 1e-9);
  EXPECT_NEAR(iz, 1.0 / 5, 1e-12);
  EXPECT_FALSE(c.project(Vec3(0, -6, 1), px));  // behind the eye

  // A general camera, against a construction by hand.
  Camera g;
  g.eye = Vec3(3, -2, 1.5);
  g.target = Vec3(0.2, 0.3, 0.4);
  g.focal_px = 800;
  g.update();
  const Vec3 f = (g.target - g.eye).normalized();
  const Vec3 right = f.cross(Vec3::UnitZ()).normalized();
  const Vec3 down = f.cross(right);
  const Vec3 x = g.target + 0.3 * right - 0.2 * down + 0.5 * f;
  const double depth = (g.target - g.eye).norm() + 0.5;
  ASSERT_TRUE(g.project(x, px));
  EXPECT_NEAR(px.x(), 640 + 800 * 0.3 / depth, 1e-9);
  EXPECT_NEAR(px.y(), 512 - 800 * 0.2 / depth, 1e-9);

  // The rendered point marker covers that pixel.
  Renderer r(c);
  make_plain(r);
  r.draw_background();
  Marker m;
  m.type = Marker::Type::Point;
  m.a = Vec3(1.0, 0.0, 1.5);
  m.size = 6;
  m.color = Eigen::Vector3d(1, 0, 0);
  r.draw_marker(m);
  const Rgb p = r.framebuffer().rgb(840, 412);
  EXPECT_EQ(p.r, 255);
  EXPECT_EQ(p.g, 0);
  EXPECT_EQ(p.b, 0);
  EXPECT_EQ(r.framebuffer().pixel(860, 412), r.background(860, 412));
}

TEST(RenderCamera, VanishingPointIsTheImageOfThePointAtInfinity) {
  Camera c;
  c.eye = Vec3(2.5, -3.0, 1.7);
  c.target = Vec3(0, 0.5, 0.3);
  c.update();
  const Vec3 d = Vec3(1.0, 2.0, 0.3).normalized();
  const Eigen::Vector3d vp = c.vanishing_point(d);  // projection of (d, 0), s = 0
  ASSERT_GT(vp.z(), 0);
  const Vec2 v(vp.x() / vp.z(), vp.y() / vp.z());
  const Vec3 starts[] = {Vec3(0, 0, 0), Vec3(1, -1, 0.5), Vec3(-2, 0.3, 1.2), Vec3(0.4, 2, -1)};
  for (const Vec3& p : starts) {
    // Far along the line the image tends to the vanishing point ...
    Vec2 far;
    ASSERT_TRUE(c.project(p + 1e9 * d, far));
    EXPECT_NEAR((far - v).norm(), 0, 1e-3);
    // ... and the image of the whole line passes through it.
    Vec2 a, b;
    ASSERT_TRUE(c.project(p, a));
    ASSERT_TRUE(c.project(p + 0.5 * d, b));
    const double cross = (b - a).x() * (v - a).y() - (b - a).y() * (v - a).x();
    EXPECT_NEAR(cross / ((b - a).norm() * (v - a).norm()), 0, 1e-9);
  }
  // The ground families' vanishing points lie on the horizon, where viewing rays are level.
  const Eigen::Vector3d l = c.horizon_line();
  for (const Vec3& dir : {Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(1, 1, 0), Vec3(-3, 1, 0)}) {
    const Eigen::Vector3d w = c.vanishing_point(dir);
    EXPECT_NEAR(l.dot(w) / (l.norm() * w.norm()), 0, 1e-12);
  }
  const double u = 100, vh = -(l.x() * u + l.z()) / l.y();
  EXPECT_NEAR(c.ray(u, vh).z(), 0, 1e-12);
  EXPECT_LT(c.ray(u, vh + 10).z(), 0);  // below the horizon the ray goes down
}

TEST(RenderClip, SegmentThroughTheEyePlaneIsClippedNotWrapped) {
  const Camera c = level_camera();
  // In camera coordinates A = (-0.5, 0, 2) is in front, B = (1.5, 0, -2) behind the eye. The
  // visible part runs from A's pixel (u = 390) to the right, off the image; a wrapped line
  // would run left from u = 390 towards B's naive image u = 640 - 750.
  const Vec4 A(-0.5, -3, 1, 1), B(1.5, -7, 1, 1);
  Vec4 ca = c.clip(A), cb = c.clip(B);
  ASSERT_LT(cb.w(), 0);
  ASSERT_TRUE(clip_segment(ClipPlanes(c), ca, cb));
  EXPECT_GE(ca.w(), c.near - 1e-12);
  EXPECT_GE(cb.w(), c.near - 1e-12);
  EXPECT_NEAR(ca.x() / ca.w(), 390, 1e-9);
  EXPECT_GT(cb.x() / cb.w(), 1280);

  Renderer r(c);
  make_plain(r);
  r.draw_background();
  r.draw_segment(A, B, Rgb(255, 0, 0), 2.0f, false);
  int changed = 0, right_edge = 0, min_x = 1 << 30;
  for (int y = 0; y < 1024; ++y)
    for (int x = 0; x < 1280; ++x)
      if (r.framebuffer().pixel(x, y) != r.background(x, y)) {
        ++changed;
        min_x = std::min(min_x, x);
        if (x >= 1275) ++right_edge;
        EXPECT_NEAR(y, 512, 3);
      }
  EXPECT_GT(changed, 800);
  EXPECT_GE(min_x, 388);
  EXPECT_GT(right_edge, 0);

  // Entirely behind the eye: nothing at all.
  Vec4 a2 = c.clip(Vec4(0, -6, 1, 1)), b2 = c.clip(Vec4(1, -8, 2, 1));
  EXPECT_FALSE(clip_segment(ClipPlanes(c), a2, b2));
}

TEST(RenderPainter, HorizonRowWhereTheCameraSays) {
  Camera c;
  c.eye = Vec3(0, -6, 2);
  c.target = Vec3(0, 0, 1);  // looking down by atan(1/6)
  c.update();
  const double vh = 512 - 1000 * std::tan(std::atan(1.0 / 6.0));  // 345.33
  const Eigen::Vector3d l = c.horizon_line();
  for (double u : {0.0, 640.0, 1279.0}) EXPECT_NEAR(-(l.x() * u + l.z()) / l.y(), vh, 1e-9);

  Renderer r(c);
  make_plain(r);
  r.draw_background();
  const int row = int(std::ceil(vh - 0.5));  // first row whose centre is below the horizon
  for (int x : {5, 640, 1270}) {
    // The sharpest change of colour down a column is at the horizon.
    int best = -1, best_d = -1;
    for (int y = 1; y < 1024; ++y) {
      const Rgb p = r.framebuffer().rgb(x, y - 1), q = r.framebuffer().rgb(x, y);
      const int d = std::abs(p.r - q.r) + std::abs(p.g - q.g) + std::abs(p.b - q.b);
      if (d > best_d) best_d = d, best = y;
    }
    EXPECT_EQ(best, row);
    EXPECT_GT(best_d, 30);
  }
  // A rolled camera: the ground side of every pixel agrees with its viewing ray.
  Camera rolled = c;
  rolled.up = Vec3(0.3, 0, 1);
  rolled.update();
  Renderer rr(rolled);
  make_plain(rr);
  rr.draw_background();
  for (int y = 8; y < 1024; y += 37)
    for (int x = 3; x < 1280; x += 41) {
      const double z = rolled.ray(x + 0.5, y + 0.5).z();
      if (std::abs(z) < 2e-3) continue;
      const uint32_t bg = rr.background(x, y);
      const uint32_t px = rr.framebuffer().pixel(x, y);
      EXPECT_EQ(px, bg);
      // The ground is painted exactly where the viewing ray goes down.
      EXPECT_EQ(rr.ground_at(x, y), z < 0) << x << "," << y;
    }
}

TEST(RenderPainter, GridLinesRunToTheVanishingPoints) {
  Camera c;
  c.eye = Vec3(1.0, -4.0, 1.5);
  c.target = Vec3(0.5, 0, 0.5);
  c.update();
  Renderer r(c);
  r.style().overlay = false;
  r.draw_background();
  r.draw_grid();
  // Near the vanishing point of the e_y family (in the image), grid pixels are present.
  const Eigen::Vector3d w = c.vanishing_point(Vec3(0, 1, 0));
  ASSERT_GT(w.z(), 0);
  const int u = int(w.x() / w.z()), v = int(w.y() / w.z());
  ASSERT_TRUE(u > 20 && u < 1260 && v > 20 && v < 1000);
  int changed = 0;
  for (int y = v + 1; y < v + 12; ++y)
    for (int x = u - 15; x <= u + 15; ++x)
      changed += r.framebuffer().pixel(x, y) != r.background(x, y);
  EXPECT_GT(changed, 10);
  // Nothing drawn above the horizon (sky stays untouched).
  for (int x = 0; x < 1280; x += 7) EXPECT_EQ(r.framebuffer().pixel(x, 3), r.background(x, 3));
}

TEST(RenderRaster, BoxCoversExpectedPixelsAndBackgroundElsewhere) {
  const Camera c = level_camera();
  Renderer r(c);
  make_plain(r);
  r.draw_background();
  r.draw_box(SE3(Mat3::Identity(), Vec3(0, 0, 1)), Vec3(1, 1, 1), Eigen::Vector3d(0.9, 0.1, 0.1));
  // Front face at depth 4.5: a square of half side 1000 * 0.5 / 4.5 = 111.1 px.
  const double h = 1000 * 0.5 / 4.5;
  int inside = 0;
  for (int y = 0; y < 1024; y += 3)
    for (int x = 0; x < 1280; x += 3) {
      const double dx = std::abs(x + 0.5 - 640), dy = std::abs(y + 0.5 - 512);
      const uint32_t p = r.framebuffer().pixel(x, y);
      if (dx < h - 1 && dy < h - 1) {
        const Rgb q = r.framebuffer().rgb(x, y);
        EXPECT_GT(int(q.r), int(q.g) + 60) << x << "," << y;
        ++inside;
      } else if (dx > h + 1 || dy > h + 1) {
        ASSERT_EQ(p, r.background(x, y)) << x << "," << y;
      }
    }
  EXPECT_GT(inside, 5000);
  // The depth buffer holds 1 / 4.5 on the front face.
  EXPECT_NEAR(r.framebuffer().depth()[512 * 1280 + 640], 1 / 4.5, 1e-5);

  // A nearer box in front wins the depth test, whatever the drawing order.
  r.draw_box(SE3(Mat3::Identity(), Vec3(0, -2, 1)), Vec3(0.2, 0.2, 0.2),
             Eigen::Vector3d(0.1, 0.1, 0.9));
  r.draw_box(SE3(Mat3::Identity(), Vec3(0, 0, 1)), Vec3(1, 1, 1), Eigen::Vector3d(0.9, 0.1, 0.1));
  const Rgb q = r.framebuffer().rgb(640, 512);
  EXPECT_GT(int(q.b), int(q.r) + 60);
}

// Every raster path (scalar, SSE2, AVX2 where the CPU has it) gives the same colour and depth
// bits: random triangles from below a pixel to hundreds of pixels across (the small-triangle
// path, the pixel loops with and without row spans, the split of very large ones), partly off
// the image, through fill_triangle and fill_indexed (culling, two row sets), on an odd width
// whose right border cuts groups of four and eight and on images narrower than a group.
TEST(RenderRaster, AllPathsGiveTheSameBits) {
  std::vector<RasterPath> paths = {RasterPath::Scalar};
  if (raster_has_simd()) paths.push_back(RasterPath::Sse2);
  if (raster_best_path() == RasterPath::Avx2) paths.push_back(RasterPath::Avx2);
  std::printf("paths compared: %zu (best %d)\n", paths.size(), int(raster_best_path()));
  for (const int size : {0, 1, 2}) {
    const int W = size == 0 ? 1283 : size == 1 ? 7 : 3, H = size == 0 ? 301 : 9;
    std::vector<Framebuffer> fbs;
    for (RasterPath p : paths) {
      fbs.emplace_back(W, H);
      fbs.back().set_path(p);
      EXPECT_EQ(fbs.back().path(), p);
      fbs.back().clear_depth();
    }
    uint32_t seed = 12345u + uint32_t(size);
    auto rnd = [&seed]() {  // [0, 1)
      seed = seed * 1664525u + 1013904223u;
      return double(seed >> 8) / double(1u << 24);
    };
    const int n = size == 0 ? 6000 : 300;
    // fill_triangle, one triangle at a time.
    for (int t = 0; t < n; ++t) {
      const double scale = std::pow(10.0, 3.0 * rnd() - 1.0);  // 0.1 .. 100 px
      const double cx = (1.2 * rnd() - 0.1) * W, cy = (1.2 * rnd() - 0.1) * H;
      RasterVertex v[3];
      for (RasterVertex& q : v) {
        q.x = int32_t(std::lrint((cx + scale * (rnd() - 0.5) * (t % 97 == 0 ? 40 : 1)) * 16));
        q.y = int32_t(std::lrint((cy + scale * (rnd() - 0.5) * (t % 89 == 0 ? 30 : 1)) * 16));
        q.z = float(0.1 + rnd());
        q.k = float(0.2 + 1.2 * rnd());
      }
      const float rgb[3] = {float(255 * rnd()), float(255 * rnd()), float(255 * rnd())};
      for (Framebuffer& fb : fbs) fb.fill_triangle(v[0], v[1], v[2], rgb);
    }
    // fill_indexed over a vertex array, both row sets of a two-thread frame, culling.
    const int nv = 3000;
    std::vector<int32_t> X(nv), Y(nv);
    std::vector<float> Z(nv), KF(nv), KB(nv);
    std::vector<uint8_t> out(nv, 0);
    for (int i = 0; i < nv; ++i) {
      X[i] = int32_t(rnd() * W * 16);
      Y[i] = int32_t(rnd() * H * 16);
      Z[i] = float(0.5 + rnd());
      KF[i] = float(rnd());
      KB[i] = float(rnd());
    }
    std::vector<uint32_t> idx;
    for (int t = 0; t < 2000; ++t) {
      const uint32_t a = uint32_t(rnd() * nv) % nv;
      // Neighbours in a small window: mostly small triangles.
      const uint32_t b = (a + 1 + uint32_t(rnd() * 40)) % nv;
      const uint32_t c = (a + 1 + uint32_t(rnd() * 40)) % nv;
      idx.insert(idx.end(), {a, b, c});
    }
    for (int i = 0; i + 1 < nv; i += 2) {  // near neighbours in space too
      X[i + 1] = X[i] + int32_t(rnd() * 64) - 32;
      Y[i + 1] = Y[i] + int32_t(rnd() * 64) - 32;
    }
    const std::vector<int32_t> XY = interleave(X, Y);
    const VertexArrays va{XY.data(), Z.data(), KF.data(), KB.data(), out.data()};
    const float rgb[3] = {200.0f, 120.0f, 60.0f};
    for (Framebuffer& fb : fbs) {
      for (int part = 0; part < 2; ++part) {
        RowSet rows;
        rows.shift = 3;
        rows.parts = 2;
        rows.part = part;
        fb.fill_indexed(va, idx.data(), idx.size() / 6, rgb, true, part == 0, rows, nullptr,
                        nullptr);
        fb.fill_indexed(va, idx.data() + idx.size() / 2, idx.size() / 6, rgb, false, true, rows,
                        nullptr, nullptr);
      }
    }
    std::size_t drawn = 0;
    for (int i = 0; i < W * H; ++i) drawn += fbs[0].depth()[i] > 0;
    EXPECT_GT(drawn, std::size_t(W * H / 2)) << "the triangles cover most of the image";
    for (std::size_t p = 1; p < fbs.size(); ++p) {
      EXPECT_EQ(std::memcmp(fbs[0].color(), fbs[p].color(), 4 * std::size_t(W) * H), 0)
          << "colour, path " << int(paths[p]) << ", " << W << " x " << H;
      EXPECT_EQ(std::memcmp(fbs[0].depth(), fbs[p].depth(), 4 * std::size_t(W) * H), 0)
          << "depth, path " << int(paths[p]) << ", " << W << " x " << H;
    }
  }
}

// fill_indexed's eight-wide front end (AVX2) against the one-triangle-at-a-time loops: tiny,
// medium and huge triangles (extent above 2^14 sub-pixels), both windings, vertices outside
// (the clip callback: called for the same triangles in the same order), culling on and off,
// one and two row sets, a count that is not a multiple of eight. Same drawn counts, same bits.
TEST(RenderRaster, IndexedFrontEndMatchesTheOtherPaths) {
  std::vector<RasterPath> paths = {RasterPath::Scalar};
  if (raster_has_simd()) paths.push_back(RasterPath::Sse2);
  if (raster_best_path() == RasterPath::Avx2) paths.push_back(RasterPath::Avx2);
  const int W = 1283, H = 301;
  uint32_t seed = 777u;
  auto rnd = [&seed]() {  // [0, 1)
    seed = seed * 1664525u + 1013904223u;
    return double(seed >> 8) / double(1u << 24);
  };
  const int nv = 4000;
  std::vector<int32_t> X(nv), Y(nv);
  std::vector<float> Z(nv), KF(nv), KB(nv);
  std::vector<uint8_t> out(nv, 0);
  for (int i = 0; i < nv; ++i) {
    const int kind = i % 8;  // 0: anywhere in the guard band, else near the previous vertex
    const double spread = kind < 6 ? 1.5 : kind == 6 ? 6.0 : 40.0;
    if (kind == 0 || i == 0) {
      X[i] = int32_t((rnd() * (W + 128) - 64) * 16);
      Y[i] = int32_t((rnd() * (H + 128) - 64) * 16);
    } else {
      X[i] = X[i - 1] + int32_t((rnd() - 0.5) * spread * 16);
      Y[i] = Y[i - 1] + int32_t((rnd() - 0.5) * spread * 16);
    }
    if (i >= nv / 2) {  // on the half-pixel grid: edges through pixel centres (top-left rule)
      X[i] &= ~7;
      Y[i] &= ~7;
    }
    Z[i] = float(0.5 + rnd());
    KF[i] = float(rnd());
    KB[i] = float(rnd());
    if (rnd() < 0.02) out[i] = uint8_t(1 + int(rnd() * 31));
  }
  std::vector<uint32_t> idx;
  const int nt = 3005;
  for (int t = 0; t < nt; ++t) {
    const bool huge = t % 53 == 0;  // three far vertices: extents up to the whole image
    const uint32_t a = uint32_t(rnd() * nv) % nv;
    const uint32_t b = huge ? uint32_t(rnd() * nv) % nv : (a + 1 + uint32_t(rnd() * 3)) % nv;
    const uint32_t c = huge ? uint32_t(rnd() * nv) % nv : (a + 1 + uint32_t(rnd() * 3)) % nv;
    idx.insert(idx.end(), {a, b, c});
  }
  // Tiny triangles with a horizontal or vertical edge through pixel centres (the top-left
  // rule decides whether they draw anything), both windings, in the middle of the list.
  std::vector<uint32_t> edges;
  for (int j = 0; j < 24; ++j) {
    const int32_t x = 16 * (2 * j + 1) + 8, y = 16 * (j % 12 + 2) + 8;  // a pixel centre
    const int32_t d = 8 * (1 + j % 2);
    const int32_t px[6] = {x - d, x + d, x, x, x, x + 8};
    const int32_t py[6] = {y, y, y + 8, y + 16 * 3 + d, y + 16 * 3 - d, y + 16 * 3};
    const uint32_t v0 = uint32_t(X.size());
    for (int k = 0; k < 6; ++k) {
      X.push_back(px[k]);
      Y.push_back(py[k]);
      Z.push_back(2.0f);
      KF.push_back(0.5f);
      KB.push_back(0.9f);
      out.push_back(0);
    }
    // Below a horizontal edge (top), above it (bottom: nothing), right of a vertical edge.
    edges.insert(edges.end(), {v0, v0 + 1, v0 + 2, v0 + 1, v0, v0 + 2});
    edges.insert(edges.end(), {v0 + 3, v0 + 4, v0 + 5, v0 + 4, v0 + 3, v0 + 5});
    edges.insert(edges.end(), {v0, v0 + 1, uint32_t(v0 + 2 - 2 * (j % 2))});
  }
  idx.insert(idx.begin() + 3 * (nt / 2), edges.begin(), edges.end());
  const std::size_t ntri = idx.size() / 3;
  struct Calls {
    std::vector<uint32_t> seen;
  };
  auto clip = [](void* ctx, uint32_t a, uint32_t b, uint32_t c) -> std::size_t {
    static_cast<Calls*>(ctx)->seen.insert(static_cast<Calls*>(ctx)->seen.end(), {a, b, c});
    return 1;
  };
  const std::vector<int32_t> XY = interleave(X, Y);
  const VertexArrays va{XY.data(), Z.data(), KF.data(), KB.data(), out.data()};
  std::vector<Framebuffer> fbs;
  std::vector<Calls> calls(paths.size());
  std::vector<std::vector<std::size_t>> drawn(paths.size());
  for (std::size_t p = 0; p < paths.size(); ++p) {
    fbs.emplace_back(W, H);
    fbs.back().set_path(paths[p]);
    fbs.back().clear_depth();
    for (int pass = 0; pass < 6; ++pass) {
      const float rgb[3] = {float(40 * pass + 30), float(200 - 30 * pass), 90.0f};
      const bool cull = pass % 2 == 0, outward = pass % 3 != 0;
      for (int part = 0; part < (pass < 4 ? 1 : 2); ++part) {
        RowSet rows;
        if (pass >= 4) {
          rows.shift = 4;
          rows.parts = 2;
          rows.part = part;
        }
        const std::size_t first = std::size_t(pass % 3) * 7, count = ntri - first - pass;
        drawn[p].push_back(fbs.back().fill_indexed(va, idx.data() + 3 * first, count, rgb, cull,
                                                   outward, rows, clip, &calls[p]));
      }
    }
  }
  std::size_t covered = 0;
  for (int i = 0; i < W * H; ++i) covered += fbs[0].depth()[i] > 0;
  EXPECT_GT(covered, std::size_t(W * H / 4)) << "the huge triangles cover much of the image";
  EXPECT_GT(calls[0].seen.size(), 3u * 100) << "clipped triangles";
  for (std::size_t p = 1; p < paths.size(); ++p) {
    EXPECT_EQ(drawn[0], drawn[p]) << "path " << int(paths[p]);
    EXPECT_EQ(calls[0].seen, calls[p].seen) << "path " << int(paths[p]);
    EXPECT_EQ(std::memcmp(fbs[0].color(), fbs[p].color(), 4 * std::size_t(W) * H), 0)
        << "colour, path " << int(paths[p]);
    EXPECT_EQ(std::memcmp(fbs[0].depth(), fbs[p].depth(), 4 * std::size_t(W) * H), 0)
        << "depth, path " << int(paths[p]);
  }
}

// Two triangles at exactly the same depth on a pixel (coplanar copies with other shades)
// leave the same bits whatever order they are drawn in: the larger colour wins the tie. Tiny,
// small and wide triangles, forward and backward, on every path, through fill_indexed and
// fill_triangle. (With "the first drawn wins" the two orders differ.)
TEST(RenderRaster, DepthTiesGoToTheLargerColourInAnyOrder) {
  std::vector<RasterPath> paths = {RasterPath::Scalar};
  if (raster_has_simd()) paths.push_back(RasterPath::Sse2);
  if (raster_best_path() == RasterPath::Avx2) paths.push_back(RasterPath::Avx2);
  const int W = 211, H = 97, nv = 1800;
  uint32_t seed = 4242u;
  auto rnd = [&seed]() {  // [0, 1)
    seed = seed * 1664525u + 1013904223u;
    return double(seed >> 8) / double(1u << 24);
  };
  // Vertices nv .. 2 nv - 1 copy 0 .. nv - 1 but for their shade.
  std::vector<int32_t> X(2 * nv), Y(2 * nv);
  std::vector<float> Z(2 * nv), KF(2 * nv), KB(2 * nv);
  for (int i = 0; i < nv; ++i) {
    const double spread = i % 3 == 0 ? 1.5 : i % 3 == 1 ? 5.0 : 60.0;
    const int32_t cx = int32_t(rnd() * W * 16), cy = int32_t(rnd() * H * 16);
    X[i] = i % 3 == 0 || i == 0 ? cx : X[i - 1] + int32_t((rnd() - 0.5) * spread * 16);
    Y[i] = i % 3 == 0 || i == 0 ? cy : Y[i - 1] + int32_t((rnd() - 0.5) * spread * 16);
    Z[i] = float(0.5 + 0.01 * rnd());
    KF[i] = KB[i] = float(rnd());  // both sides alike: fill_triangle below has no sides
    X[nv + i] = X[i];
    Y[nv + i] = Y[i];
    Z[nv + i] = Z[i];
    KF[nv + i] = KB[nv + i] = float(rnd());
  }
  std::vector<uint32_t> fwd;
  for (int t = 0; t + 2 < nv; t += 3) {
    fwd.insert(fwd.end(), {uint32_t(t), uint32_t(t + 1), uint32_t(t + 2)});
    fwd.insert(fwd.end(), {uint32_t(nv + t), uint32_t(nv + t + 1), uint32_t(nv + t + 2)});
  }
  std::vector<uint32_t> bwd;
  for (std::size_t t = fwd.size() / 3; t-- > 0;) {
    bwd.insert(bwd.end(), {fwd[3 * t], fwd[3 * t + 1], fwd[3 * t + 2]});
  }
  const std::vector<int32_t> XY = interleave(X, Y);
  const VertexArrays va{XY.data(), Z.data(), KF.data(), KB.data(), nullptr};
  const float rgb[3] = {220.0f, 160.0f, 90.0f};
  std::vector<Framebuffer> fbs;
  for (RasterPath path : paths) {
    for (const std::vector<uint32_t>* order : {&fwd, &bwd}) {
      fbs.emplace_back(W, H);
      Framebuffer& fb = fbs.back();
      fb.set_path(path);
      fb.clear_depth();
      std::fill(fb.color(), fb.color() + W * H, 0x102030u);
      fb.fill_indexed(va, order->data(), order->size() / 3, rgb, false, true, RowSet(), nullptr,
                      nullptr);
    }
    for (const std::vector<uint32_t>* order : {&fwd, &bwd}) {  // one triangle at a time
      fbs.emplace_back(W, H);
      Framebuffer& fb = fbs.back();
      fb.set_path(path);
      fb.clear_depth();
      std::fill(fb.color(), fb.color() + W * H, 0x102030u);
      for (std::size_t t = 0; t < order->size(); t += 3) {
        const uint32_t* q = order->data() + t;
        RasterVertex v[3];
        for (int k = 0; k < 3; ++k) v[k] = {X[q[k]], Y[q[k]], Z[q[k]], KF[q[k]]};
        fb.fill_triangle(v[0], v[1], v[2], rgb);
      }
    }
  }
  for (std::size_t f = 1; f < fbs.size(); ++f) {
    EXPECT_EQ(std::memcmp(fbs[0].color(), fbs[f].color(), 4 * std::size_t(W) * H), 0)
        << "colour, frame " << f << " (path " << int(paths[f / 4]) << ", order " << f % 2 << ")";
    EXPECT_EQ(std::memcmp(fbs[0].depth(), fbs[f].depth(), 4 * std::size_t(W) * H), 0)
        << "depth, frame " << f;
  }
  // There are ties to decide: the originals alone and the copies alone give the same depth
  // and other colours on many pixels.
  Framebuffer alone[2] = {Framebuffer(W, H), Framebuffer(W, H)};
  for (int k = 0; k < 2; ++k) {
    std::vector<uint32_t> half;
    for (std::size_t t = 3 * k; t < fwd.size(); t += 6)
      half.insert(half.end(), &fwd[t], &fwd[t + 3]);
    alone[k].clear_depth();
    alone[k].fill_indexed(va, half.data(), half.size() / 3, rgb, false, true, RowSet(), nullptr,
                          nullptr);
  }
  std::size_t tied = 0;
  for (int i = 0; i < W * H; ++i) {
    tied += alone[0].depth()[i] > 0 && alone[0].depth()[i] == alone[1].depth()[i] &&
            alone[0].color()[i] != alone[1].color()[i];
  }
  EXPECT_GT(tied, std::size_t(W * H / 10));
}

// Draws the triangles idx (fill_indexed, both sides) on the scalar and the AVX2 path, in colour
// and depth alone, one band or two, and expects the same counts and bits; returns the scalar
// frame of the last pass (colour, two bands).
Framebuffer avx2_matches_scalar(const VertexArrays& va, const std::vector<uint32_t>& idx, int W,
                                int H, const float rgb[3]) {
  Framebuffer last(W, H);
  for (int paint = 0; paint < 2; ++paint) {
    for (int parts = 1; parts <= 2; ++parts) {
      Framebuffer ref(W, H), avx(W, H);
      std::size_t n[2] = {0, 0};
      for (int k = 0; k < 2; ++k) {
        Framebuffer& fb = k == 0 ? ref : avx;
        fb.set_path(k == 0 ? RasterPath::Scalar : RasterPath::Avx2);
        fb.set_paint(paint == 1);
        fb.clear_depth();
        std::fill(fb.color(), fb.color() + W * H, 0x123456u);
        for (int part = 0; part < parts; ++part) {
          RowSet rows;
          rows.shift = 2;
          rows.parts = parts;
          rows.part = part;
          n[k] += fb.fill_indexed(va, idx.data(), idx.size() / 3, rgb, false, true, rows, nullptr,
                                  nullptr);
        }
      }
      EXPECT_EQ(n[0], n[1]);
      EXPECT_EQ(std::memcmp(ref.depth(), avx.depth(), 4 * std::size_t(W) * H), 0)
          << "depth, paint " << paint << ", parts " << parts;
      EXPECT_EQ(std::memcmp(ref.color(), avx.color(), 4 * std::size_t(W) * H), 0)
          << "colour, paint " << paint << ", parts " << parts;
      last = ref;
    }
  }
  return last;
}

// Triangles whose pixel box is at most 2 x 2 pixels (the AVX2 loop computes their pixels' z
// and colour eight triangles wide, then tests and writes one pixel at a time): many of them
// piled on a few pixels, both sides seen, in colour and depth alone, one band or two, give the
// scalar path's bits.
TEST(RenderRaster, TinyTrianglesGiveTheScalarPathsBits) {
  if (raster_best_path() != RasterPath::Avx2) GTEST_SKIP() << "no AVX2 here";
  const int W = 37, H = 29, nv = 3000;
  uint32_t seed = 4242u;
  auto rnd = [&seed]() {  // [0, 1)
    seed = seed * 1664525u + 1013904223u;
    return double(seed >> 8) / double(1u << 24);
  };
  std::vector<int32_t> X(nv), Y(nv);
  std::vector<float> Z(nv), KF(nv), KB(nv);
  for (int i = 0; i < nv; ++i) {
    // Triples near one point: boxes of one to four pixels, on a 10 x 8 pixel patch.
    const int c = i / 3;
    X[i] = int32_t(16 * (2 + (c * 7) % 10) + rnd() * 30);
    Y[i] = int32_t(16 * (3 + (c * 3) % 8) + rnd() * 30);
    Z[i] = float(0.5 + rnd());
    KF[i] = float(2 * rnd());  // above 1 too: colours clamp at 255
    KB[i] = float(rnd());
  }
  std::vector<uint32_t> idx(nv);
  for (int i = 0; i < nv; ++i) idx[std::size_t(i)] = uint32_t(i);
  const float rgb[3] = {230.0f, 140.0f, 35.0f};
  std::size_t tiny = 0;
  for (int t = 0; t < nv / 3; ++t) {
    const int32_t* xs = &X[3 * t];
    const int32_t* ys = &Y[3 * t];
    const int32_t x0 = std::min({xs[0], xs[1], xs[2]}), x1 = std::max({xs[0], xs[1], xs[2]});
    const int32_t y0 = std::min({ys[0], ys[1], ys[2]}), y1 = std::max({ys[0], ys[1], ys[2]});
    tiny += ((x1 - 8) >> 4) - ((x0 + 7) >> 4) <= 1 && ((y1 - 8) >> 4) - ((y0 + 7) >> 4) <= 1;
  }
  EXPECT_GT(tiny, std::size_t(nv / 3 * 9 / 10)) << "boxes of at most 2 x 2 pixels";
  const std::vector<int32_t> XY = interleave(X, Y);
  const VertexArrays va{XY.data(), Z.data(), KF.data(), KB.data(), nullptr};
  avx2_matches_scalar(va, idx, W, H, rgb);
}

// Triangles of one to five pixels across the image's right and bottom borders and its corner
// (their pixel boxes clipped to the image: the AVX2 loop's queues must not draw the columns and
// rows a box lost), in colour and depth alone, one band or two: the scalar path's bits.
TEST(RenderRaster, SmallTrianglesAtTheBordersGiveTheScalarPathsBits) {
  if (raster_best_path() != RasterPath::Avx2) GTEST_SKIP() << "no AVX2 here";
  const int W = 37, H = 29, nv = 3000;
  uint32_t seed = 99u;
  auto rnd = [&seed]() {  // [0, 1)
    seed = seed * 1664525u + 1013904223u;
    return double(seed >> 8) / double(1u << 24);
  };
  std::vector<int32_t> X(nv), Y(nv);
  std::vector<float> Z(nv), KF(nv), KB(nv);
  for (int i = 0; i < nv; ++i) {
    const int c = i / 3, side = c % 3;  // right border, bottom border, the corner
    const double cx = side == 1 ? rnd() * W : W - 1.5 + 3 * rnd();
    const double cy = side == 0 ? rnd() * H : H - 1.5 + 3 * rnd();
    const double extent = 1 + 4 * rnd();
    X[i] = int32_t(16 * (cx + extent * (rnd() - 0.5)));
    Y[i] = int32_t(16 * (cy + extent * (rnd() - 0.5)));
    Z[i] = float(0.5 + rnd());
    KF[i] = float(2 * rnd());
    KB[i] = float(rnd());
  }
  std::vector<uint32_t> idx(nv);
  for (int i = 0; i < nv; ++i) idx[std::size_t(i)] = uint32_t(i);
  const float rgb[3] = {30.0f, 200.0f, 140.0f};
  const std::vector<int32_t> XY = interleave(X, Y);
  const VertexArrays va{XY.data(), Z.data(), KF.data(), KB.data(), nullptr};
  const Framebuffer ref = avx2_matches_scalar(va, idx, W, H, rgb);
  std::size_t covered = 0;
  for (int y = 0; y < H; ++y) covered += ref.depth()[y * W + W - 1] > 0;
  EXPECT_GT(covered, std::size_t(H / 2)) << "the right border is drawn on";
}

// VertexArrays without outcodes (out null: every vertex inside) draw as with all-zero
// outcodes, on every path, in the eight-wide front end and its one-at-a-time tail.
TEST(RenderRaster, NullOutcodesDrawAsAllInside) {
  std::vector<RasterPath> paths = {RasterPath::Scalar};
  if (raster_has_simd()) paths.push_back(RasterPath::Sse2);
  if (raster_best_path() == RasterPath::Avx2) paths.push_back(RasterPath::Avx2);
  const int W = 203, H = 117, nv = 900;
  uint32_t seed = 99u;
  auto rnd = [&seed]() {  // [0, 1)
    seed = seed * 1664525u + 1013904223u;
    return double(seed >> 8) / double(1u << 24);
  };
  std::vector<int32_t> X(nv), Y(nv);
  std::vector<float> Z(nv), KF(nv), KB(nv);
  std::vector<uint8_t> out(nv, 0);
  for (int i = 0; i < nv; ++i) {
    X[i] = int32_t(rnd() * W * 16);
    Y[i] = int32_t(rnd() * H * 16);
    Z[i] = float(0.5 + rnd());
    KF[i] = float(rnd());
    KB[i] = float(rnd());
  }
  std::vector<uint32_t> idx;
  for (int t = 0; t < 1003; ++t) {
    const uint32_t a = uint32_t(rnd() * nv) % nv;
    idx.insert(idx.end(),
               {a, (a + 1 + uint32_t(rnd() * 5)) % nv, (a + 2 + uint32_t(rnd() * 5)) % nv});
  }
  const float rgb[3] = {200.0f, 120.0f, 40.0f};
  for (RasterPath path : paths) {
    Framebuffer with(W, H), without(W, H);
    std::size_t n[2] = {0, 0};
    for (int k = 0; k < 2; ++k) {
      Framebuffer& fb = k == 0 ? with : without;
      fb.set_path(path);
      fb.clear_depth();
      const std::vector<int32_t> XY = interleave(X, Y);
      const VertexArrays va{XY.data(), Z.data(), KF.data(), KB.data(),
                            k == 0 ? out.data() : nullptr};
      n[k] = fb.fill_indexed(va, idx.data(), idx.size() / 3, rgb, false, true, RowSet(), nullptr,
                             nullptr);
    }
    EXPECT_GT(n[0], 500u);
    EXPECT_EQ(n[0], n[1]) << "path " << int(path);
    EXPECT_EQ(std::memcmp(with.color(), without.color(), 4 * std::size_t(W) * H), 0)
        << "path " << int(path);
    EXPECT_EQ(std::memcmp(with.depth(), without.depth(), 4 * std::size_t(W) * H), 0)
        << "path " << int(path);
  }
}

// A box marker turns with its orientation R (a satellite bus tumbles with its base): a 2 x 0.2 x
// 0.2 m bar is wide on screen along world x, tall once R turns its x axis onto world z, and a
// non-rotation R draws nothing.
TEST(RenderScene, BoxMarkerTurnsWithItsOrientation) {
  auto coloured = [](Renderer& r, int x, int y) {
    const Rgb q = r.framebuffer().rgb(x, y);
    return int(q.r) > int(q.g) + 60;
  };
  auto extents = [&](const Mat3& R, int& wide, int& tall) {
    Renderer r(level_camera());
    make_plain(r);
    r.draw_background();
    Marker m;
    m.type = Marker::Type::Box;
    m.a = Vec3(0, 0, 1);
    m.size3 = Vec3(2.0, 0.2, 0.2);
    m.R = R;
    m.color = Eigen::Vector3d(0.9, 0.1, 0.1);
    r.draw_marker(m);
    wide = tall = 0;
    for (int x = 0; x < 1280; ++x) wide += coloured(r, x, 512);
    for (int y = 0; y < 1024; ++y) tall += coloured(r, 640, y);
  };
  int wide = 0, tall = 0;
  extents(Mat3::Identity(), wide, tall);
  // Front face at depth 4.9: 2 m span 1000 * 2 / 4.9 = 408 px, 0.2 m span 41 px.
  EXPECT_NEAR(wide, 408, 4);
  EXPECT_NEAR(tall, 41, 3);
  extents(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitY()).toRotationMatrix(), wide, tall);
  EXPECT_NEAR(wide, 41, 3);
  EXPECT_NEAR(tall, 408, 4);
  extents(2.0 * Mat3::Identity(), wide, tall);
  EXPECT_EQ(wide + tall, 0);
}

namespace {

// Base box + one revolute link whose visual is a mesh that does not exist (and no collision):
// its stand-in runs from the link origin to its child's joint.
const char* kTwoBodyUrdf = R"(<robot name="two">
  <link name="base"><visual><geometry><box size="0.3 0.3 0.1"/></geometry></visual></link>
  <link name="arm">
    <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="arm_missing.dae"/></geometry></visual>
  </link>
  <link name="tip">
    <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="j1" type="continuous"><parent link="base"/><child link="arm"/>
    <origin xyz="0 0 0.2"/><axis xyz="0 0 1"/></joint>
  <joint name="j2" type="continuous"><parent link="arm"/><child link="tip"/>
    <origin xyz="0 0 0.5"/><axis xyz="0 0 1"/></joint>
</robot>)";

}  // namespace

TEST(RenderScene, MeshStandInsAndModelPixels) {
  const Model m = model_from_urdf_string(kTwoBodyUrdf);
  GeometryOptions go;
  go.paths.base_dir = ::testing::TempDir();
  const GeometryModel g = geometry_from_urdf_string(m, kTwoBodyUrdf, go);
  ASSERT_EQ(g.warnings.size(), 1u);
  EXPECT_NE(g.warnings[0].find("arm"), std::string::npos);
  EXPECT_NE(g.warnings[0].find("arm_missing.dae"), std::string::npos);
  const auto items = make_draw_items(m, g);
  ASSERT_EQ(items.size(), 2u);
  EXPECT_EQ(items[0].shape, ShapeType::Box);
  EXPECT_EQ(items[1].shape, ShapeType::Capsule);
  EXPECT_TRUE(items[1].stand_in);
  EXPECT_EQ(items[1].body, 1);
  EXPECT_NEAR(items[1].size.z(), 0.5, 1e-12);
  EXPECT_TRUE(items[1].local.p.isApprox(Vec3(0, 0, 0.25)));
  EXPECT_NEAR(std::abs(items[1].local.R.col(2).z()), 1.0, 1e-12);

  // Poses by hand (body 1 at 0.2 m, body 2 at 0.7 m above the base).
  std::vector<SE3> oMb = {SE3(), SE3(Mat3::Identity(), Vec3(0, 0, 0.2)),
                          SE3(Mat3::Identity(), Vec3(0, 0, 0.7))};
  Camera c;
  c.eye = Vec3(0, -3, 0.5);
  c.target = Vec3(0, 0, 0.5);
  c.update();
  Renderer r(c);
  make_plain(r);
  r.set_items(items);
  r.render(oMb);
  Vec2 px;
  ASSERT_TRUE(c.project(Vec3(0, 0, 0.45), px));  // the middle of the arm's stand-in
  EXPECT_NE(r.framebuffer().pixel(int(px.x()), int(px.y())),
            r.background(int(px.x()), int(px.y())));
  ASSERT_TRUE(c.project(Vec3(0.5, 0, 0.45), px));  // beside it: background (sky or ground)
  EXPECT_EQ(r.framebuffer().pixel(int(px.x()), int(px.y())),
            r.background(int(px.x()), int(px.y())));

  // Non-finite poses hide their bodies and never poison the image.
  oMb[1].p.x() = std::nan("");
  r.style().frames = true;
  Overlay ov;
  ov.sim_time = 1.5;
  ov.real_time_factor = 0.98;
  ov.joint = "j1";
  ov.torque = -2.5;
  r.style().overlay = true;
  r.render(oMb, {}, ov);
  ASSERT_TRUE(c.project(Vec3(0, 0, 0.45), px));
  EXPECT_EQ(r.framebuffer().pixel(int(px.x()), int(px.y())),
            r.background(int(px.x()), int(px.y())));
  // The overlay wrote text into the top-left corner.
  int text = 0;
  for (int y = 0; y < 80; ++y)
    for (int x = 0; x < 300; ++x) text += r.framebuffer().pixel(x, y) != r.background(x, y);
  EXPECT_GT(text, 100);
}

TEST(RenderScene, MarkersAndOrbit) {
  Camera c = level_camera();
  Renderer r(c);
  make_plain(r);
  r.draw_background();
  Marker arrow;
  arrow.type = Marker::Type::Arrow;
  arrow.a = Vec3(-0.5, 0, 1);
  arrow.b = Vec3(0.5, 0, 1);
  arrow.size = 0.05;
  arrow.color = Eigen::Vector3d(0, 1, 0);
  r.draw_marker(arrow);
  EXPECT_NE(r.framebuffer().pixel(640, 512), r.background(640, 512));
  EXPECT_EQ(r.framebuffer().pixel(640, 600), r.background(640, 600));
  Marker bad = arrow;
  bad.b.x() = std::nan("");
  r.draw_marker(bad);  // ignored

  const double d0 = (c.eye - c.target).norm();
  c.orbit(0.5, 0.2, 0.5);
  EXPECT_NEAR((c.eye - c.target).norm(), 0.5 * d0, 1e-9);
  c.orbit(std::nan(""), 10.0, std::nan(""));  // pitch clamps, NaN ignored
  EXPECT_TRUE(c.eye.allFinite());
  EXPECT_LT(std::asin((c.eye - c.target).normalized().z()), 89.01 * M_PI / 180);
  EXPECT_TRUE(c.P.allFinite());
}

TEST(RenderScene, CameraSpecAndPngOfARealRobot) {
  RenderOptions opt;
  std::string err;
  EXPECT_FALSE(parse_camera_spec("1,2,3", opt, &err));
  EXPECT_FALSE(parse_camera_spec("1,2,x,0,0,0", opt, &err));
  EXPECT_FALSE(parse_camera_spec("1,1,1,1,1,1", opt, &err));
  EXPECT_TRUE(opt.auto_camera);
  ASSERT_TRUE(parse_camera_spec("3,-2,1.5,0,0,0.5,900", opt, &err)) << err;
  EXPECT_FALSE(opt.auto_camera);
  EXPECT_EQ(opt.camera.focal_px, 900);

  const std::string urdf = se3_sim_test::source_dir() + "/data/robots/panda.urdf";
  const Model m = model_from_urdf_file(urdf);
  GeometryOptions go;
  go.paths.package_path = {se3_sim_test::source_dir() + "/data/meshes"};
  const GeometryModel g = geometry_from_urdf_file(m, urdf, go);
  EXPECT_TRUE(g.warnings.empty());
  RenderOptions o;
  o.q = VecX::Zero(m.n);
  if (m.n >= 7) {
    o.q(1) = -0.6;
    o.q(3) = -2.2;
    o.q(5) = 1.6;
  }
  const std::string out = ::testing::TempDir() + "se3_render_panda.png";
  std::remove(out.c_str());
  ASSERT_EQ(render_to_png(m, g, o, out, &err), 0) << err;
  std::ifstream f(out, std::ios::binary);
  char sig[8] = {};
  f.read(sig, 8);
  EXPECT_EQ(std::string(sig + 1, 3), "PNG");
  EXPECT_EQ(render_to_png(m, g, o, "/nonexistent-dir/x.png", &err), 1);
  EXPECT_FALSE(err.empty());
  o.q = VecX::Zero(m.n + 1);
  EXPECT_EQ(render_to_png(m, g, o, out, &err), 1);
}

TEST(RenderRaster, Rgb8CopyMatchesThePixels) {
  Framebuffer fb(37, 5);  // odd sizes exercise the tail of the fast copy
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 37; ++x)
      fb.fill_span(y, x, x + 1, Rgb(uint8_t(x * 7), uint8_t(y * 50), uint8_t(x + y)).packed());
  std::vector<uint8_t> out(37 * 5 * 3 + 1, 0xab);
  fb.copy_rgb8(out.data());
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 37; ++x) {
      const size_t i = 3 * (size_t(y) * 37 + x);
      EXPECT_EQ(out[i], x * 7);
      EXPECT_EQ(out[i + 1], y * 50);
      EXPECT_EQ(out[i + 2], x + y);
    }
  EXPECT_EQ(out.back(), 0xab);  // nothing written past the end
}

// ---------------------------------------------------------------- meshes

namespace {

struct Robot {
  Model model;
  GeometryModel geometry;
};

Robot load_robot(const std::string& file, bool floating, bool load_meshes = true) {
  const std::string urdf = se3_sim_test::source_dir() + "/data/robots/" + file;
  UrdfOptions uo;
  uo.floating = floating;
  Robot r{model_from_urdf_file(urdf, uo), {}};
  GeometryOptions go;
  go.paths.package_path = {se3_sim_test::source_dir() + "/data/meshes"};
  go.paths.use_ros_package_path = false;
  go.load_meshes = load_meshes;
  r.geometry = geometry_from_urdf_file(r.model, urdf, go);
  return r;
}

// Joint positions: a fraction t of each joint's range (or of [-pi, pi]), fingers closed.
VecX pose_at(const Model& m, double t, int seed) {
  VecX q(m.n);
  for (int i = 0; i < m.n; ++i) {
    const int b = i + 1;
    const double lo = std::isfinite(m.lower[b]) ? m.lower[b] : -M_PI;
    const double hi = std::isfinite(m.upper[b]) ? m.upper[b] : M_PI;
    const double f = 0.5 + 0.4 * std::sin(1.7 * (i + 1) * (seed + 1) + t);
    q(i) = m.joints[b].type == JointType::Prismatic ? lo : lo + f * (hi - lo);
  }
  return q;
}

// The pinhole of `se3_dyn render --camera` built here on its own (not the renderer's Camera):
// camera x right, y down, z forward, u = f x / z + w / 2, v = f y / z + h / 2, pixel (i, j)
// covering [i, i + 1) x [j, j + 1). The silhouette: pixel centres inside the image of any
// visual triangle, from the GeometryModel's meshes placed on the bodies.
std::vector<char> reference_silhouette(const Robot& r, const std::vector<SE3>& oMb, const Vec3& eye,
                                       const Vec3& target, double f, int W, int H) {
  const Vec3 fwd = (target - eye).normalized();
  const Vec3 right = fwd.cross(Vec3::UnitZ()).normalized();
  const Vec3 down = fwd.cross(right);
  std::vector<char> mask(std::size_t(W) * H, 0);
  for (const GeometryObject& o : r.geometry.visuals) {
    if (!o.shape.mesh) continue;
    const SE3 pose = oMb[o.body] * o.placement;
    const TriangleMesh& m = *o.shape.mesh;
    std::vector<Vec3> px(m.positions.size());
    for (std::size_t i = 0; i < m.positions.size(); ++i) {
      const Vec3 w = pose.act(m.positions[i].cast<double>().cwiseProduct(o.shape.scale));
      const Vec3 c(right.dot(w - eye), down.dot(w - eye), fwd.dot(w - eye));
      px[i] = Vec3(f * c.x() / c.z() + 0.5 * W, f * c.y() / c.z() + 0.5 * H, c.z());
    }
    for (std::size_t t = 0; t + 2 < m.indices.size(); t += 3) {
      const Vec3& a = px[m.indices[t]];
      const Vec3& b = px[m.indices[t + 1]];
      const Vec3& c = px[m.indices[t + 2]];
      if (a.z() < 0.05 || b.z() < 0.05 || c.z() < 0.05) continue;
      const int i0 = std::max(0, int(std::floor(std::min({a.x(), b.x(), c.x()}))));
      const int i1 = std::min(W - 1, int(std::floor(std::max({a.x(), b.x(), c.x()}))));
      const int j0 = std::max(0, int(std::floor(std::min({a.y(), b.y(), c.y()}))));
      const int j1 = std::min(H - 1, int(std::floor(std::max({a.y(), b.y(), c.y()}))));
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i) {
          const double x = i + 0.5, y = j + 0.5;
          const double w0 = (b.x() - x) * (c.y() - y) - (c.x() - x) * (b.y() - y);
          const double w1 = (c.x() - x) * (a.y() - y) - (a.x() - x) * (c.y() - y);
          const double w2 = (a.x() - x) * (b.y() - y) - (b.x() - x) * (a.y() - y);
          if ((w0 >= 0 && w1 >= 0 && w2 >= 0) || (w0 <= 0 && w1 <= 0 && w2 <= 0)) {
            mask[std::size_t(j) * W + i] = 1;
          }
        }
    }
  }
  return mask;
}

double iou(const std::vector<char>& a, const Framebuffer& fb) {
  std::size_t in = 0, un = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const bool b = fb.depth()[i] > 0;  // drawn: something wrote its depth
    in += a[i] && b;
    un += a[i] || b;
  }
  return un ? double(in) / double(un) : 0.0;
}

}  // namespace

// The drawn robot against the projection of its own triangles with the documented pinhole:
// IoU >= 0.95 for the UR5, Panda and Solo-12 at three configurations each, with the default
// mesh simplification and with full meshes. Stand-ins (meshes not loaded: the renderer of
// before meshes) fail the same test.
TEST(RenderMeshes, SilhouetteMatchesTheProjectedTriangles) {
  struct Case {
    const char* file;
    bool floating;
    Vec3 eye, target;
  };
  const Case cases[] = {
      {"ur5_robot.urdf", false, Vec3(1.4, -1.3, 0.9), Vec3(0, 0, 0.35)},
      {"panda.urdf", false, Vec3(1.6, -1.4, 1.0), Vec3(0, 0, 0.45)},
      {"solo12.urdf", true, Vec3(0.8, -0.75, 0.45), Vec3(0, 0, -0.05)},
  };
  const int W = 1280, H = 1024;
  const double f = 1000;
  for (const Case& c : cases) {
    const Robot r = load_robot(c.file, c.floating);
    ASSERT_TRUE(r.geometry.warnings.empty()) << r.geometry.warnings[0];
    const Robot stand_in = load_robot(c.file, c.floating, false);
    Camera cam;
    cam.eye = c.eye;
    cam.target = c.target;
    cam.focal_px = f;
    Renderer simplified(cam), full(cam), stand(cam);
    DrawOptions no_simplify;
    no_simplify.simplify_error = 0;
    simplified.set_model(r.model, r.geometry);
    full.set_model(r.model, r.geometry, no_simplify);
    stand.set_model(stand_in.model, stand_in.geometry);
    for (Renderer* x : {&simplified, &full, &stand}) make_plain(*x);
    for (int k = 0; k < 3; ++k) {
      Data d(r.model);
      forward_kinematics(r.model, d, SE3(), pose_at(r.model, 0.3 * k, k));
      const auto ref = reference_silhouette(r, d.oMb, c.eye, c.target, f, W, H);
      std::size_t area = 0;
      for (char p : ref) area += p;
      EXPECT_GT(area, 20000u) << c.file;  // the robot fills a good part of the image
      simplified.render(d.oMb);
      full.render(d.oMb);
      stand.render(d.oMb);
      const double a = iou(ref, simplified.framebuffer()), b = iou(ref, full.framebuffer());
      const double s = iou(ref, stand.framebuffer());
      EXPECT_GE(a, 0.95) << c.file << " configuration " << k << " (simplified)";
      EXPECT_GE(b, 0.95) << c.file << " configuration " << k << " (full meshes)";
      EXPECT_LT(s, 0.95) << c.file << " configuration " << k << " (stand-ins)";
      std::printf("%-16s configuration %d: IoU %.4f simplified, %.4f full, %.4f stand-ins\n",
                  c.file, k, a, b, s);
    }
  }
}

namespace {

bool same_pixels(const Framebuffer& a, const Framebuffer& b) {
  const std::size_t n = std::size_t(a.width()) * a.height();
  return a.width() == b.width() && a.height() == b.height() &&
         std::memcmp(a.color(), b.color(), 4 * n) == 0 &&
         std::memcmp(a.depth(), b.depth(), 4 * n) == 0;
}

}  // namespace

// The SSE2 and scalar paths, one thread and two, and the cached background (restored where
// the last frame drew) against a full redraw: the same bits, frame after frame, on a mesh
// robot with markers, frames and overlay, through a near plane that cuts the robot.
TEST(RenderMeshes, SimdScalarThreadsAndCachedBackgroundGiveTheSameImage) {
  const Robot r = load_robot("panda.urdf", false);
  Camera cam;
  cam.eye = Vec3(1.2, -1.0, 0.8);
  cam.target = Vec3(0, 0, 0.45);
  Camera close = cam;
  close.eye = Vec3(0.25, -0.2, 0.55);  // inside the arm's reach: near-plane clipping
  std::vector<Marker> markers(4);
  markers[0].type = Marker::Type::Box;
  markers[0].a = Vec3(0.3, 0.3, 0.1);
  markers[1].type = Marker::Type::Arrow;
  markers[1].a = Vec3(0, 0, 0);
  markers[1].b = Vec3(0.4, 0, 0.2);
  markers[2].type = Marker::Type::Point;
  markers[2].a = Vec3(0.1, -0.2, 0.3);
  markers[3].type = Marker::Type::Line;
  markers[3].a = Vec3(-0.3, 0, 0);
  markers[3].b = Vec3(-0.3, 0, 0.8);
  Overlay ov;
  ov.sim_time = 1.25;
  ov.lines = {"paused"};
  for (const Camera& c : {cam, close}) {
    Renderer a(c), b(c), t(c);
    a.set_model(r.model, r.geometry);
    b.set_model(r.model, r.geometry);
    t.set_model(r.model, r.geometry);
    b.style().simd = false;
    t.style().threads = 2;
    for (Renderer* x : {&a, &b, &t}) x->style().frames = true;
    for (int k = 0; k < 4; ++k) {
      Data d(r.model);
      forward_kinematics(r.model, d, SE3(), pose_at(r.model, 0.7 * k, 1));
      a.render(d.oMb, markers, ov);
      b.render(d.oMb, markers, ov);
      t.render(d.oMb, markers, ov);
      const Renderer& ca = a;  // const access keeps the cached background
      const Renderer& cb = b;
      const Renderer& ct = t;
      EXPECT_TRUE(same_pixels(ca.framebuffer(), cb.framebuffer())) << "SSE2 vs scalar, frame " << k;
      EXPECT_TRUE(same_pixels(ca.framebuffer(), ct.framebuffer())) << "2 threads, frame " << k;
      Renderer fresh(c);  // whole background drawn
      fresh.set_model(r.model, r.geometry);
      fresh.style().frames = true;
      fresh.render(d.oMb, markers, ov);
      const Renderer& cf = fresh;
      EXPECT_TRUE(same_pixels(ca.framebuffer(), cf.framebuffer()))
          << "cached background, frame " << k;
      if (k == 1) markers.pop_back();
    }
    EXPECT_GT(a.last_triangles(), 500u);
  }
}

// Either winding is drawn, closed surfaces lose only their back faces, open ones are seen
// from inside: a box wound inside out looks like the box, and into a box without its front
// face one sees its inner walls.
TEST(RenderMeshes, EitherWindingAndOpenSurfaces) {
  const Camera c = level_camera();  // looking along +y at z = 1
  TriangleMesh box = tessellate(make_box(Vec3::Ones()));
  TriangleMesh inverted = box;
  for (std::size_t t = 0; t < inverted.triangle_count(); ++t)
    std::swap(inverted.indices[3 * t + 1], inverted.indices[3 * t + 2]);
  finish_mesh(inverted);
  ASSERT_TRUE(inverted.closed);
  ASSERT_FALSE(inverted.outward);
  const RenderMesh rb = make_render_mesh(box, Vec3::Ones(), Eigen::Vector3f(0.9f, 0.2f, 0.2f));
  const RenderMesh ri = make_render_mesh(inverted, Vec3::Ones(), Eigen::Vector3f(0.9f, 0.2f, 0.2f));
  Renderer a(c), b(c);
  make_plain(a);
  make_plain(b);
  a.draw_background();
  b.draw_background();
  const SE3 pose(Eigen::AngleAxisd(0.5, Vec3(1, 2, 3).normalized()).toRotationMatrix(),
                 Vec3(0, 0, 1));
  a.draw_mesh(rb, pose);
  b.draw_mesh(ri, pose);
  EXPECT_TRUE(same_pixels(a.framebuffer(), b.framebuffer()));

  // The box without its -y face (the one towards the camera): open, its inside is drawn.
  TriangleMesh open = box;
  std::vector<uint32_t> kept;
  for (std::size_t t = 0; t < open.triangle_count(); ++t) {
    bool front = true;
    for (int k = 0; k < 3; ++k) front = front && open.positions[open.indices[3 * t + k]].y() < 0;
    if (!front) kept.insert(kept.end(), &open.indices[3 * t], &open.indices[3 * t] + 3);
  }
  open.indices = kept;
  open.submeshes.clear();
  finish_mesh(open);
  ASSERT_FALSE(open.closed);
  const RenderMesh ro = make_render_mesh(open, Vec3::Ones(), Eigen::Vector3f(0.2f, 0.9f, 0.2f));
  Renderer o(c);
  make_plain(o);
  o.draw_background();
  o.draw_mesh(ro, SE3(Mat3::Identity(), Vec3(0, 0, 1)));
  // Through the opening: the back wall's inside at depth 5.5 (camera at y = -5).
  EXPECT_NEAR(o.framebuffer().depth()[512 * 1280 + 640], 1 / 5.5, 1e-5);
  const Rgb q = o.framebuffer().rgb(640, 512);
  EXPECT_GT(int(q.g), int(q.r) + 40);
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
