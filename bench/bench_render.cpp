// The rasterizer against Mesa's llvmpipe (software OpenGL through OSMesa), on the same
// triangles in the same run: 1280x1024, depth test, Lambert lighting (sun + head light +
// ambient), back faces culled on closed surfaces and two-sided lighting on open ones, the
// frame read back into memory (rgb8). Scenes: 16 spheres tessellated to 1k, 10k, 100k and 1M
// triangles in all (the same pixels, finer and finer triangles), and the Panda and Solo-12
// with their full visual meshes. Also the node's whole frame (sky, grid, overlay, the default
// mesh simplification) for the Panda and UR5.
//
//   bench_render [google-benchmark flags]          all of it
//   bench_render --gl_threads=N                    llvmpipe's threads (LP_NUM_THREADS; 1 default)
//   bench_render --save_png=docs/render_panda.png  also writes a picture of the Panda
//   bench_render --robots=DIR                      robots from DIR (default: the source tree's)
//   bench_render --frames=SCENE[:N[:THREADS]]      only N frames (10) of ours, for callgrind:
//     valgrind --tool=callgrind --toggle-collect='se3::render::Renderer::render*'
//              --toggle-collect='se3::render::Renderer::copy_rgb8*' bench_render
//              --frames=panda_full
//   (SCENE: 1k 10k 100k 1M panda_full solo12_full)
//   bench_render --simplify_report                 what DrawOptions::simplify_error costs and
//                                                  saves: triangles, silhouette IoU against the
//                                                  full meshes, ms a frame (median of 9)
//
// The benchmark names: Tri/<scene>/<ours|ours_2threads|llvmpipe>, Frame/<robot>. Counters:
// triangles (as submitted), ns_per_tri, and for llvmpipe iou (silhouette of its frame against
// ours: both draw the same thing).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "se3_sim/render/render.h"

#if SE3_SIM_HAVE_OSMESA
#define GL_GLEXT_PROTOTYPES 1
#include <GL/gl.h>
#include <GL/glext.h>
#include <GL/osmesa.h>

#include "../test/source_paths.h"
#endif

namespace {

using namespace se3;

std::string g_robots;

std::string robots_dir() {
  if (!g_robots.empty()) return g_robots;
  return se3_sim_test::source_dir() + "/data/robots";  // the package's, set by CMake
}

// ---------------------------------------------------------------- scenes

struct Scene {
  std::string name;
  std::vector<render::DrawItem> items;
  std::vector<SE3> oMb;
  render::Camera cam;
  std::size_t triangles = 0;
};

// 16 spheres of radius 0.12 m on a 4 x 4 grid 1.6 m across, seen from 2.2 m.
Scene spheres(std::size_t total, const std::string& name) {
  Scene s;
  s.name = name;
  const std::size_t per = total / 16;
  int seg = 4;
  while (std::size_t((seg + 1) * (seg + 1) - 2 * (seg + 1)) <= per) ++seg;
  render::DrawOptions full;
  full.simplify_error = 0;
  auto mesh = std::make_shared<render::RenderMesh>(render::make_render_mesh(
      tessellate(make_sphere(0.12), seg), Vec3::Ones(), Eigen::Vector3f(0.8f, 0.5f, 0.3f), full));
  s.oMb = {SE3()};
  for (int i = 0; i < 16; ++i) {
    render::DrawItem it;
    it.body = 0;
    it.local = SE3(Mat3::Identity(), Vec3(0.5 * (i % 4) - 0.75, 0.0, 0.5 * (i / 4) - 0.75 + 1.0));
    it.mesh = mesh;
    s.items.push_back(it);
    s.triangles += mesh->triangle_count();
  }
  s.cam.eye = Vec3(0, -2.2, 1.0);
  s.cam.target = Vec3(0, 0, 1.0);
  s.cam.update();
  return s;
}

// A robot with its full visual meshes (no simplification) at a bent pose, framed.
Scene robot(const std::string& file, const std::string& name, double simplify = 0.0) {
  Scene s;
  s.name = name;
  UrdfOptions uo;
  uo.floating = file == "solo12.urdf";
  const Model m = model_from_urdf_file(robots_dir() + "/" + file, uo);
  GeometryOptions go;
  go.paths.package_path = {robots_dir() + "/../meshes"};
  const GeometryModel g = geometry_from_urdf_file(m, robots_dir() + "/" + file, go);
  for (const std::string& w : g.warnings) std::cerr << "warning: " << w << "\n";
  render::DrawOptions dopt;
  dopt.simplify_error = simplify;
  s.items = render::make_draw_items(m, g, dopt);
  for (const auto& it : s.items) s.triangles += it.mesh->triangle_count();
  Data data(m);
  VecX q = VecX::Zero(m.n);
  for (int i = 0; i < m.n; ++i) q(i) = (i % 2 ? -0.7 : 0.4);
  if (file == "panda.urdf" && m.n >= 7) {
    const double ready[7] = {0.3, -0.5, -0.2, -2.1, 0.1, 1.7, 0.9};
    for (int i = 0; i < 7; ++i) q(i) = ready[i];
  }
  for (int i = 0; i < m.n; ++i) {  // within the limits (fingers closed)
    const int b = i + 1;
    if (m.joints[b].type == JointType::Prismatic) q(i) = 0.0;
    q(i) = std::min(std::max(q(i), m.lower[b]), m.upper[b]);
  }
  forward_kinematics(m, data, SE3(), q);
  s.oMb = data.oMb;
  render::frame_items(s.items, s.oMb, s.cam);
  return s;
}

const Scene& scene(int k) {
  static std::vector<std::unique_ptr<Scene>> all(6);
  if (!all[k]) {
    switch (k) {
      case 0:
        all[k] = std::make_unique<Scene>(spheres(1000, "1k"));
        break;
      case 1:
        all[k] = std::make_unique<Scene>(spheres(10000, "10k"));
        break;
      case 2:
        all[k] = std::make_unique<Scene>(spheres(100000, "100k"));
        break;
      case 3:
        all[k] = std::make_unique<Scene>(spheres(1000000, "1M"));
        break;
      case 4:
        all[k] = std::make_unique<Scene>(robot("panda.urdf", "panda_full"));
        break;
      default:
        all[k] = std::make_unique<Scene>(robot("solo12.urdf", "solo12_full"));
        break;
    }
  }
  return *all[k];
}

std::vector<uint8_t> g_ours_rgb[6];  // our last frame of each scene (for the IoU)

// ---------------------------------------------------------------- ours

void BM_Ours(benchmark::State& state, int k, int threads) {
  const Scene* s = nullptr;
  try {
    s = &scene(k);
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  render::Renderer r(s->cam);
  r.style().grid = false;
  r.style().overlay = false;
  r.style().threads = threads;
  r.set_items(s->items);
  std::vector<uint8_t> rgb(std::size_t(s->cam.width) * s->cam.height * 3);
  for (auto _ : state) {
    r.render(s->oMb);
    r.copy_rgb8(rgb.data());
    benchmark::DoNotOptimize(rgb.data());
  }
  g_ours_rgb[k] = rgb;
  state.counters["triangles"] = double(s->triangles);
  state.counters["drawn"] = double(r.last_triangles());
  state.counters["ns_per_tri"] = benchmark::Counter(
      double(s->triangles) * 1e-9,
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

// ---------------------------------------------------------------- llvmpipe

#if SE3_SIM_HAVE_OSMESA

PFNGLGENBUFFERSPROC p_glGenBuffers;
PFNGLBINDBUFFERPROC p_glBindBuffer;
PFNGLBUFFERDATAPROC p_glBufferData;
PFNGLDELETEBUFFERSPROC p_glDeleteBuffers;

struct GlMesh {
  GLuint vbo[2] = {0, 0};  // positions + normals, indices
  const render::RenderMesh* mesh = nullptr;
};

// Column-major 4x4 of an affine pose.
void gl_matrix(const Mat4& M, GLdouble* out) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) out[4 * c + r] = M(r, c);
}

// Intersection over union of the pixels that differ from each image's own background.
double silhouette_iou(const std::vector<uint8_t>& a, const std::vector<uint8_t>& a_bg,
                      const std::vector<uint8_t>& b, const std::vector<uint8_t>& b_bg) {
  std::size_t inter = 0, uni = 0;
  for (std::size_t i = 0; i + 2 < a.size() && i + 2 < b.size(); i += 3) {
    const bool in_a = a[i] != a_bg[i] || a[i + 1] != a_bg[i + 1] || a[i + 2] != a_bg[i + 2];
    const bool in_b = b[i] != b_bg[i] || b[i + 1] != b_bg[i + 1] || b[i + 2] != b_bg[i + 2];
    inter += in_a && in_b;
    uni += in_a || in_b;
  }
  return uni ? double(inter) / double(uni) : 1.0;
}

void BM_Llvmpipe(benchmark::State& state, int k) {
  const Scene* s = nullptr;
  try {
    s = &scene(k);
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  const int W = s->cam.width, H = s->cam.height;
  std::vector<uint8_t> rgba(std::size_t(W) * H * 4);
  OSMesaContext ctx = OSMesaCreateContextExt(OSMESA_RGBA, 24, 0, 0, nullptr);
  if (!ctx || !OSMesaMakeCurrent(ctx, rgba.data(), GL_UNSIGNED_BYTE, W, H)) {
    state.SkipWithError("OSMesa context failed");
    return;
  }
  OSMesaPixelStore(OSMESA_Y_UP, 0);  // row 0 at the top, as ours
  p_glGenBuffers = reinterpret_cast<PFNGLGENBUFFERSPROC>(OSMesaGetProcAddress("glGenBuffers"));
  p_glBindBuffer = reinterpret_cast<PFNGLBINDBUFFERPROC>(OSMesaGetProcAddress("glBindBuffer"));
  p_glBufferData = reinterpret_cast<PFNGLBUFFERDATAPROC>(OSMesaGetProcAddress("glBufferData"));
  p_glDeleteBuffers =
      reinterpret_cast<PFNGLDELETEBUFFERSPROC>(OSMesaGetProcAddress("glDeleteBuffers"));
  // Meshes into vertex buffer objects once (as ours are resident).
  std::vector<GlMesh> meshes;
  std::vector<int> item_mesh;
  for (const auto& it : s->items) {
    int found = -1;
    for (std::size_t m = 0; m < meshes.size(); ++m)
      if (meshes[m].mesh == it.mesh.get()) found = int(m);
    if (found < 0) {
      GlMesh g;
      g.mesh = it.mesh.get();
      const render::RenderMesh& rm = *it.mesh;
      std::vector<float> vn(6 * rm.vertex_count());
      for (std::size_t i = 0; i < rm.vertex_count(); ++i) {
        const float v[6] = {rm.px[i], rm.py[i], rm.pz[i], rm.nx[i], rm.ny[i], rm.nz[i]};
        std::copy(v, v + 6, &vn[6 * i]);
      }
      p_glGenBuffers(2, g.vbo);
      p_glBindBuffer(GL_ARRAY_BUFFER, g.vbo[0]);
      p_glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(vn.size() * 4), vn.data(), GL_STATIC_DRAW);
      p_glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g.vbo[1]);
      p_glBufferData(GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(rm.indices.size() * 4), rm.indices.data(),
                     GL_STATIC_DRAW);
      meshes.push_back(g);
      found = int(meshes.size()) - 1;
    }
    item_mesh.push_back(found);
  }
  state.SetLabel(reinterpret_cast<const char*>(glGetString(GL_RENDERER)));

  // The pinhole as a frustum (camera x right, y down, z forward; GL looks down -z, y up).
  const render::Camera& c = s->cam;
  const double n = c.near, f = 100.0;
  glViewport(0, 0, W, H);
  glMatrixMode(GL_PROJECTION);
  glLoadIdentity();
  glFrustum(-c.cx() * n / c.focal_px, (W - c.cx()) * n / c.focal_px, -(H - c.cy()) * n / c.focal_px,
            c.cy() * n / c.focal_px, n, f);
  Mat4 flip = Mat4::Identity();
  flip(1, 1) = -1;
  flip(2, 2) = -1;
  const Mat4 view = flip * c.T_cw;
  glEnable(GL_DEPTH_TEST);
  glEnable(GL_LIGHTING);
  glEnable(GL_LIGHT0);
  glEnable(GL_LIGHT1);
  glEnable(GL_COLOR_MATERIAL);
  glColorMaterial(GL_FRONT_AND_BACK, GL_AMBIENT_AND_DIFFUSE);
  glLightModeli(GL_LIGHT_MODEL_TWO_SIDE, GL_TRUE);
  glShadeModel(GL_SMOOTH);
  const GLfloat amb[4] = {0.26f, 0.26f, 0.26f, 1}, sun[4] = {0.58f, 0.58f, 0.58f, 1};
  const GLfloat head[4] = {0.22f, 0.22f, 0.22f, 1}, none[4] = {0, 0, 0, 1};
  glLightModelfv(GL_LIGHT_MODEL_AMBIENT, amb);
  glLightfv(GL_LIGHT0, GL_DIFFUSE, sun);
  glLightfv(GL_LIGHT0, GL_AMBIENT, none);
  glLightfv(GL_LIGHT1, GL_DIFFUSE, head);
  glLightfv(GL_LIGHT1, GL_AMBIENT, none);
  glClearColor(0.5f, 0.55f, 0.6f, 1.0f);
  std::vector<uint8_t> rgb(std::size_t(W) * H * 3);
  GLdouble mv[16];
  const render::Style style;
  const Vec3 L = style.light.normalized();
  for (auto _ : state) {
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glMatrixMode(GL_MODELVIEW);
    glLoadIdentity();
    const GLfloat head_dir[4] = {0, 0, 1, 0};  // towards the eye, in eye coordinates
    glLightfv(GL_LIGHT1, GL_POSITION, head_dir);
    gl_matrix(view, mv);
    glLoadMatrixd(mv);
    const GLfloat sun_dir[4] = {float(L.x()), float(L.y()), float(L.z()), 0};
    glLightfv(GL_LIGHT0, GL_POSITION, sun_dir);
    glEnableClientState(GL_VERTEX_ARRAY);
    glEnableClientState(GL_NORMAL_ARRAY);
    for (std::size_t i = 0; i < s->items.size(); ++i) {
      const auto& it = s->items[i];
      const SE3 pose = s->oMb[it.body] * it.local;
      gl_matrix(view * pose.matrix(), mv);
      glLoadMatrixd(mv);
      const GlMesh& g = meshes[item_mesh[i]];
      p_glBindBuffer(GL_ARRAY_BUFFER, g.vbo[0]);
      p_glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g.vbo[1]);
      glVertexPointer(3, GL_FLOAT, 24, nullptr);
      glNormalPointer(GL_FLOAT, 24, reinterpret_cast<const void*>(12));
      for (const auto& run : g.mesh->runs) {
        if (run.cull) {
          glEnable(GL_CULL_FACE);
          glFrontFace(run.outward ? GL_CCW : GL_CW);
        } else {
          glDisable(GL_CULL_FACE);
        }
        glColor3f(run.rgb.x(), run.rgb.y(), run.rgb.z());
        glDrawElements(GL_TRIANGLES, GLsizei(3 * run.count), GL_UNSIGNED_INT,
                       reinterpret_cast<const void*>(std::size_t(12) * run.first));
      }
    }
    glReadPixels(0, 0, W, H, GL_RGB, GL_UNSIGNED_BYTE, rgb.data());
    benchmark::DoNotOptimize(rgb.data());
  }
  state.counters["triangles"] = double(s->triangles);
  state.counters["ns_per_tri"] = benchmark::Counter(
      double(s->triangles) * 1e-9,
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  if (!g_ours_rgb[k].empty()) {
    // Both backgrounds for the same camera, to find the drawn pixels of each.
    render::Renderer bg(s->cam);
    bg.style().grid = false;
    bg.style().overlay = false;
    bg.render({});
    std::vector<uint8_t> ours_bg(rgb.size()), gl_bg(rgb.size());
    bg.copy_rgb8(ours_bg.data());
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glReadPixels(0, 0, W, H, GL_RGB, GL_UNSIGNED_BYTE, gl_bg.data());
    // glReadPixels returns rows bottom up.
    for (int y = 0; y < H / 2; ++y) {
      std::swap_ranges(rgb.begin() + std::ptrdiff_t(3) * W * y,
                       rgb.begin() + std::ptrdiff_t(3) * W * (y + 1),
                       rgb.begin() + std::ptrdiff_t(3) * W * (H - 1 - y));
    }
    state.counters["iou"] = silhouette_iou(g_ours_rgb[k], ours_bg, rgb, gl_bg);
    if (const char* dir = std::getenv("SE3_BENCH_DUMP")) {  // both frames as PPM, to compare
      for (int w = 0; w < 2; ++w) {
        const std::string path = std::string(dir) + "/" + s->name + (w ? "_ours" : "_gl") + ".ppm";
        FILE* fp = std::fopen(path.c_str(), "wb");
        if (!fp) continue;
        std::fprintf(fp, "P6 %d %d 255\n", W, H);
        std::fwrite(w ? g_ours_rgb[k].data() : rgb.data(), 1, rgb.size(), fp);
        std::fclose(fp);
      }
    }
  }
  for (GlMesh& g : meshes) p_glDeleteBuffers(2, g.vbo);
  OSMesaDestroyContext(ctx);
}

#endif

// ---------------------------------------------------------------- whole frames

void BM_Frame(benchmark::State& state, const std::string& file, int threads) {
  Scene s;
  try {
    s = robot(file, file, render::DrawOptions().simplify_error);
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  render::Renderer r(s.cam);
  r.style().threads = threads;
  r.set_items(s.items);
  render::Overlay ov;
  ov.sim_time = 12.345;
  ov.real_time_factor = 1.0;
  ov.joint = "joint";
  ov.torque = 1.5;
  std::vector<uint8_t> rgb8(std::size_t(s.cam.width) * s.cam.height * 3);
  for (auto _ : state) {
    r.render(s.oMb, {}, ov);
    r.copy_rgb8(rgb8.data());
    benchmark::DoNotOptimize(rgb8.data());
  }
  state.counters["triangles"] = double(s.triangles);
}

int save_png(const std::string& path) {
  Scene s = robot("panda.urdf", "panda", render::DrawOptions().simplify_error);
  render::Renderer r(s.cam);
  r.set_items(s.items);
  render::Overlay ov;
  ov.sim_time = 3.250;
  ov.real_time_factor = 1.0;
  r.render(s.oMb, {}, ov);
  std::string err;
  if (!r.write_png(path, &err)) {
    std::cerr << err << "\n";
    return 1;
  }
  std::cout << "wrote " << path << "\n";
  return 0;
}

int frames_only(const std::string& spec) {
  const char* names[6] = {"1k", "10k", "100k", "1M", "panda_full", "solo12_full"};
  const std::size_t c1 = spec.find(':');
  const std::string name = spec.substr(0, c1);
  int n = 10, threads = 1;
  if (c1 != std::string::npos) {
    n = std::atoi(spec.c_str() + c1 + 1);
    const std::size_t c2 = spec.find(':', c1 + 1);
    if (c2 != std::string::npos) threads = std::atoi(spec.c_str() + c2 + 1);
  }
  for (int k = 0; k < 6; ++k) {
    if (name != names[k]) continue;
    const Scene& s = scene(k);
    render::Renderer r(s.cam);
    r.style().grid = false;
    r.style().overlay = false;
    r.style().threads = threads;
    r.set_items(s.items);
    std::vector<uint8_t> rgb(std::size_t(s.cam.width) * s.cam.height * 3);
    for (int i = 0; i < n; ++i) {
      r.render(s.oMb);
      r.copy_rgb8(rgb.data());
    }
    std::cout << name << ": " << n << " frames, " << s.triangles << " triangles, "
              << r.last_triangles() << " drawn\n";
    return 0;
  }
  std::cerr << "unknown scene '" << name << "'\n";
  return 1;
}

double wall_ms() {
  return std::chrono::duration<double, std::milli>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

int simplify_report() {
  struct R {
    const char* file;
    bool floating;
  };
  std::printf("%-16s %8s %10s %8s %10s %10s\n", "robot", "error_mm", "triangles", "vertices",
              "IoU_min", "ms_frame");
  for (const R& rb : {R{"panda.urdf", false}, R{"ur5_robot.urdf", false}, R{"solo12.urdf", true}}) {
    UrdfOptions uo;
    uo.floating = rb.floating;
    const Model m = model_from_urdf_file(robots_dir() + "/" + rb.file, uo);
    GeometryOptions go;
    go.paths.package_path = {robots_dir() + "/../meshes"};
    const GeometryModel g = geometry_from_urdf_file(m, robots_dir() + "/" + rb.file, go);
    std::vector<std::vector<SE3>> poses;
    for (int k = 0; k < 3; ++k) {
      Data d(m);
      VecX q(m.n);
      for (int i = 0; i < m.n; ++i) {
        const int b = i + 1;
        const double lo = std::isfinite(m.lower[b]) ? m.lower[b] : -M_PI;
        const double hi = std::isfinite(m.upper[b]) ? m.upper[b] : M_PI;
        q(i) = m.joints[b].type == JointType::Prismatic
                   ? lo
                   : lo + (0.5 + 0.4 * std::sin(1.7 * (i + 1) * (k + 1))) * (hi - lo);
      }
      forward_kinematics(m, d, SE3(), q);
      poses.push_back(d.oMb);
    }
    render::DrawOptions full;
    full.simplify_error = 0;
    const auto full_items = render::make_draw_items(m, g, full);
    render::Camera cam;
    render::frame_items(full_items, poses[0], cam);
    std::vector<std::vector<char>> ref;
    for (const auto& oMb : poses) {
      render::Renderer r(cam);
      r.style().grid = false;
      r.style().overlay = false;
      r.set_items(full_items);
      r.render(oMb);
      const render::Renderer& cr = r;
      std::vector<char> mask(std::size_t(cam.width) * cam.height);
      for (std::size_t i = 0; i < mask.size(); ++i) mask[i] = cr.framebuffer().depth()[i] > 0;
      ref.push_back(mask);
    }
    for (double err : {0.0, 0.25e-3, 0.5e-3, 1e-3, 2e-3, 4e-3}) {
      render::DrawOptions o;
      o.simplify_error = err;
      const auto items = render::make_draw_items(m, g, o);
      std::size_t tris = 0, verts = 0;
      for (const auto& it : items)
        tris += it.mesh->triangle_count(), verts += it.mesh->vertex_count();
      render::Renderer r(cam);
      r.style().grid = false;
      r.style().overlay = false;
      r.set_items(items);
      double worst = 1.0;
      std::vector<double> ms;
      for (std::size_t k = 0; k < poses.size(); ++k) {
        r.render(poses[k]);
        const render::Renderer& cr = r;
        std::size_t in = 0, un = 0;
        for (std::size_t i = 0; i < ref[k].size(); ++i) {
          const bool b = cr.framebuffer().depth()[i] > 0;
          in += ref[k][i] && b;
          un += ref[k][i] || b;
        }
        worst = std::min(worst, un ? double(in) / double(un) : 1.0);
      }
      for (int rep = 0; rep < 9; ++rep) {
        const double t0 = wall_ms();
        r.render(poses[rep % 3]);
        ms.push_back(wall_ms() - t0);
      }
      std::sort(ms.begin(), ms.end());
      std::printf("%-16s %8.2f %10zu %8zu %10.4f %10.2f\n", rb.file, err * 1e3, tris, verts, worst,
                  ms[ms.size() / 2]);
    }
  }
  return 0;
}

void register_all() {
  const char* names[6] = {"1k", "10k", "100k", "1M", "panda_full", "solo12_full"};
  for (int k = 0; k < 6; ++k) {
    const std::string base = std::string("Tri/") + names[k];
    benchmark::RegisterBenchmark((base + "/ours").c_str(), BM_Ours, k, 1)
        ->Unit(benchmark::kMillisecond)
        ->MeasureProcessCPUTime()
        ->MinTime(1.0);
    benchmark::RegisterBenchmark((base + "/ours_2threads").c_str(), BM_Ours, k, 2)
        ->Unit(benchmark::kMillisecond)
        ->MeasureProcessCPUTime()
        ->MinTime(1.0);
#if SE3_SIM_HAVE_OSMESA
    benchmark::RegisterBenchmark((base + "/llvmpipe").c_str(), BM_Llvmpipe, k)
        ->Unit(benchmark::kMillisecond)
        ->MeasureProcessCPUTime()
        ->MinTime(1.0);
#endif
  }
  for (const char* f : {"panda.urdf", "ur5_robot.urdf"}) {
    for (int threads : {1, 2}) {
      const std::string name =
          std::string("Frame/") + f + (threads == 2 ? "/2threads" : "/1thread");
      benchmark::RegisterBenchmark(name.c_str(), BM_Frame, std::string(f), threads)
          ->Unit(benchmark::kMillisecond)
          ->MeasureProcessCPUTime()
          ->MinTime(1.0);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<char*> rest;
  std::string gl_threads = "1";
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--robots=", 0) == 0) {
      g_robots = a.substr(9);
    } else if (a.rfind("--gl_threads=", 0) == 0) {
      gl_threads = a.substr(13);
    }
  }
  // llvmpipe reads its thread count once, when the first context is made.
  setenv("LP_NUM_THREADS", gl_threads.c_str(), 1);
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--robots=", 0) == 0 || a.rfind("--gl_threads=", 0) == 0) continue;
    if (a.rfind("--frames=", 0) == 0) return frames_only(a.substr(9));
    if (a == "--simplify_report") return simplify_report();
    if (a.rfind("--save_png=", 0) == 0) {
      try {
        if (save_png(a.substr(11))) return 1;
      } catch (const std::exception& e) {
        std::cerr << e.what() << "\n";
        return 1;
      }
      continue;
    }
    rest.push_back(argv[i]);
  }
  register_all();
  int n = int(rest.size());
  benchmark::Initialize(&n, rest.data());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
