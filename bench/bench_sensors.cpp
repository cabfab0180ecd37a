// Camera and laser sensors (issue 38) on one core, the Panda with its full visual meshes (no
// simplification) over the panda_push table and box, seen by the scene's table_camera:
//
//   Camera/<W>x<H>/<full|simplified>   one CameraSensor frame: rgb8 + depth + organized cloud
//   Camera/<W>x<H>/rgb_only             the same frame without depth and cloud
//   Camera/<W>x<H>/depth_only           depth and cloud without colour (nothing shaded)
//   Scan/raycast/<N>                    an N-sample 360 deg LaserScanner sweep (ray casts against
//                                       the collision hulls, table, box and ground)
//   Scan/depth_sweep/<N>                the alternative: N samples rendered as three 1-row depth
//                                       cameras of 120 deg each (as gazebo's gpu_ray renders)
//   Depth/640x480/llvmpipe              Mesa's llvmpipe (OSMesa, LP_NUM_THREADS=1) drawing the same
//                                       full meshes and reading the depth back as metres (where
//                                       built with OSMesa; as bench_render's RGB comparison)
//
//   bench_sensors [google-benchmark flags]     medians of 9 repetitions
//   bench_sensors --frames=N [--depth-only] [--size=WxH] [--dump=FILE]   N camera frames only,
//                                              640x480 unless --size; --dump writes the last
//                                              frame's rgb8, depth and cloud bytes to FILE (to
//                                              compare two builds' images bit for bit) (for
//                                              callgrind:
//     valgrind --tool=callgrind --toggle-collect='se3::render::CameraSensor::render*'
//              bench_sensors --frames=10; a frame's count is the difference of two N)
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "se3_sim/collision/laser.h"
#include "se3_sim/render/camera_sensor.h"

#if SE3_SIM_HAVE_OSMESA
#define GL_GLEXT_PROTOTYPES 1
#include <GL/gl.h>
#include <GL/glext.h>
#include <GL/osmesa.h>

#include "../test/source_paths.h"
#endif

namespace {

using namespace se3;

struct World {
  Model model;
  GeometryModel geometry;
  std::vector<SE3> oMb;
  std::vector<render::Marker> objects;  ///< table and box
  std::vector<CollisionObject> shapes;  ///< collisions, table, box, ground
  SE3 camera;                           ///< table_camera's optical frame
};

const World& world() {
  static std::unique_ptr<World> w;
  if (w) return *w;
  w = std::make_unique<World>();
  const std::string dir = se3_sim_test::source_dir() + "/data/robots/";
  w->model = model_from_urdf_file(dir + "panda.urdf");
  GeometryOptions go;
  go.paths.package_path = {se3_sim_test::source_dir() + "/data/meshes"};
  go.paths.use_ros_package_path = false;
  w->geometry = geometry_from_urdf_file(w->model, dir + "panda.urdf", go);
  for (const std::string& s : w->geometry.warnings) std::cerr << "warning: " << s << "\n";
  Data d(w->model);
  VecX q = VecX::Zero(w->model.n);
  const double pose[7] = {0.6, 0.5, 0.0, -2.0, 0.0, 2.5, 0.8};  // panda_push's push
  for (int i = 0; i < 7 && i < w->model.n; ++i) q(i) = pose[i];
  forward_kinematics(w->model, d, SE3(), q);
  w->oMb = d.oMb;
  render::Marker table, box;
  table.type = box.type = render::Marker::Type::Box;
  table.a = Vec3(0.6, 0, 0.025);
  table.size3 = Vec3(0.6, 1.2, 0.05);
  table.color = Eigen::Vector3d(0.55, 0.4, 0.25);
  box.a = Vec3(0.55, 0.26, 0.09);
  box.size3 = Vec3(0.08, 0.08, 0.08);
  box.color = Eigen::Vector3d(0.2, 0.5, 0.9);
  w->objects = {table, box};
  for (const GeometryObject& g : w->geometry.collisions) {
    CollisionObject c;
    c.name = g.name;
    c.frame = g.body;
    c.placement = g.placement;
    c.shape = g.shape;
    w->shapes.push_back(c);
  }
  for (const render::Marker& m : w->objects) {
    CollisionObject c;
    c.name = "object";
    c.frame = CollisionObject::kWorld;
    c.placement = SE3(Mat3::Identity(), m.a);
    c.shape = make_box(m.size3);
    c.group = 1;
    w->shapes.push_back(c);
  }
  CollisionObject ground;
  ground.name = "ground";
  ground.halfspace = true;
  ground.group = 1;
  w->shapes.push_back(ground);
  // table_camera of panda_push.yaml: at (1.4, 0.9, 0.7), x towards (0.5, 0.1, 0.1), z up.
  const Vec3 eye(1.4, 0.9, 0.7);
  const Vec3 x = (Vec3(0.5, 0.1, 0.1) - eye).normalized();
  const Vec3 y = Vec3::UnitZ().cross(x).normalized();
  Mat3 R;
  R << x, y, x.cross(y);
  w->camera = SE3(R * render::optical_in_body(), eye);
  return *w;
}

void BM_Camera(benchmark::State& state, int width, int height, bool full, bool depth, bool color) {
  const World& w = world();
  render::CameraSensorSpec spec;
  spec.width = width;
  spec.height = height;
  spec.far = 6;
  spec.depth = depth;
  spec.color = color;
  render::CameraSensor cam(spec);
  render::DrawOptions opt;
  if (full) opt.simplify_error = 0;
  cam.set_model(w.model, w.geometry, opt);
  std::size_t tris = 0;
  for (const auto& it : cam.renderer().items()) tris += it.mesh ? it.mesh->triangle_count() : 0;
  for (auto _ : state) {
    cam.render(w.camera, w.oMb, w.objects);
    benchmark::DoNotOptimize(cam.rgb().data());
    benchmark::DoNotOptimize(cam.cloud().data());
  }
  std::size_t hits = 0;
  for (float z : cam.depth()) hits += std::isfinite(z);
  state.counters["triangles"] = double(tris);
  state.counters["depth_hits"] = double(hits);
}

void BM_ScanRaycast(benchmark::State& state, int samples) {
  const World& w = world();
  CollisionModel model(w.shapes, CollisionOptions());
  LaserSpec spec;
  spec.samples = samples;
  spec.range_max = 6;
  LaserScanner scanner(model, spec);
  // Level, 4 cm above the table, where the box and the fingers are.
  const SE3 at(Mat3::Identity(), Vec3(1.1, 0.0, 0.09));
  for (auto _ : state) {
    scanner.scan(at, w.oMb);
    benchmark::DoNotOptimize(scanner.ranges().data());
  }
  int hits = 0;
  for (float r : scanner.ranges()) hits += std::isfinite(r);
  state.counters["hits"] = hits;
  state.counters["shapes"] = double(w.shapes.size());
}

// The sweep as three 120 deg depth cameras of one row each (full meshes, as the visuals).
void BM_ScanDepthSweep(benchmark::State& state, int samples) {
  const World& w = world();
  render::CameraSensorSpec spec;
  spec.width = samples / 3;
  spec.height = 1;
  spec.hfov = 2.0 * M_PI / 3.0;
  spec.far = 6;
  std::vector<std::unique_ptr<render::CameraSensor>> cams;
  render::DrawOptions opt;
  opt.simplify_error = 0;
  for (int k = 0; k < 3; ++k) {
    cams.push_back(std::make_unique<render::CameraSensor>(spec));
    cams.back()->set_model(w.model, w.geometry, opt);
  }
  const Vec3 at(1.1, 0.0, 0.09);
  for (auto _ : state) {
    for (int k = 0; k < 3; ++k) {
      const Mat3 yaw = Eigen::AngleAxisd(2.0 * M_PI * k / 3.0, Vec3::UnitZ()).toRotationMatrix();
      cams[k]->render(SE3(yaw * render::optical_in_body(), at), w.oMb, w.objects);
      benchmark::DoNotOptimize(cams[k]->depth().data());
    }
  }
}

#if SE3_SIM_HAVE_OSMESA
// The same depth frame through llvmpipe: meshes in vertex buffers once, no lighting (depth
// only), glReadPixels of the 24-bit depth as floats, turned into metres along the optical axis
// (NaN beyond the far plane), and the depth of ours compared pixel by pixel.
void BM_LlvmpipeDepth(benchmark::State& state, int W, int H) {
  const World& w = world();
  render::CameraSensorSpec spec;
  spec.width = W;
  spec.height = H;
  spec.far = 6;
  spec.ground = false;
  render::CameraSensor ours(spec);
  render::DrawOptions opt;
  opt.simplify_error = 0;
  ours.set_model(w.model, w.geometry, opt);
  ours.render(w.camera, w.oMb);
  std::vector<uint8_t> rgba(std::size_t(W) * H * 4);
  OSMesaContext ctx = OSMesaCreateContextExt(OSMESA_RGBA, 24, 0, 0, nullptr);
  if (!ctx || !OSMesaMakeCurrent(ctx, rgba.data(), GL_UNSIGNED_BYTE, W, H)) {
    state.SkipWithError("OSMesa context failed");
    return;
  }
  auto gen = reinterpret_cast<PFNGLGENBUFFERSPROC>(OSMesaGetProcAddress("glGenBuffers"));
  auto bind = reinterpret_cast<PFNGLBINDBUFFERPROC>(OSMesaGetProcAddress("glBindBuffer"));
  auto data = reinterpret_cast<PFNGLBUFFERDATAPROC>(OSMesaGetProcAddress("glBufferData"));
  const auto& items = ours.renderer().items();
  std::vector<GLuint> vbo(2 * items.size());
  for (std::size_t i = 0; i < items.size(); ++i) {
    const render::RenderMesh& m = *items[i].mesh;
    std::vector<float> xyz(3 * m.vertex_count());
    for (std::size_t v = 0; v < m.vertex_count(); ++v) {
      xyz[3 * v] = m.px[v];
      xyz[3 * v + 1] = m.py[v];
      xyz[3 * v + 2] = m.pz[v];
    }
    gen(2, &vbo[2 * i]);
    bind(GL_ARRAY_BUFFER, vbo[2 * i]);
    data(GL_ARRAY_BUFFER, GLsizeiptr(4 * xyz.size()), xyz.data(), GL_STATIC_DRAW);
    bind(GL_ELEMENT_ARRAY_BUFFER, vbo[2 * i + 1]);
    data(GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(4 * m.indices.size()), m.indices.data(),
         GL_STATIC_DRAW);
  }
  state.SetLabel(reinterpret_cast<const char*>(glGetString(GL_RENDERER)));
  const render::Camera& c = ours.renderer().camera();
  const double n = spec.near, f = spec.far;
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
  glDisable(GL_CULL_FACE);
  std::vector<float> zbuf(std::size_t(W) * H), depth(zbuf.size());
  GLdouble mv[16];
  for (auto _ : state) {
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glMatrixMode(GL_MODELVIEW);
    glEnableClientState(GL_VERTEX_ARRAY);
    for (std::size_t i = 0; i < items.size(); ++i) {
      const Mat4 M = view * (w.oMb[items[i].body] * items[i].local).matrix();
      for (int col = 0; col < 4; ++col)
        for (int r = 0; r < 4; ++r) mv[4 * col + r] = M(r, col);
      glLoadMatrixd(mv);
      bind(GL_ARRAY_BUFFER, vbo[2 * i]);
      bind(GL_ELEMENT_ARRAY_BUFFER, vbo[2 * i + 1]);
      glVertexPointer(3, GL_FLOAT, 12, nullptr);
      glDrawElements(GL_TRIANGLES, GLsizei(items[i].mesh->indices.size()), GL_UNSIGNED_INT,
                     nullptr);
    }
    glReadPixels(0, 0, W, H, GL_DEPTH_COMPONENT, GL_FLOAT, zbuf.data());
    for (int y = 0; y < H; ++y) {  // rows bottom up; window depth d -> z
      const float* src = &zbuf[std::size_t(H - 1 - y) * W];
      float* dst = &depth[std::size_t(y) * W];
      for (int x = 0; x < W; ++x) {
        const double d = src[x];
        dst[x] = d < 1.0 ? float(n * f / (f - d * (f - n))) : NAN;
      }
    }
    benchmark::DoNotOptimize(depth.data());
  }
  // Agreement with ours: the pixels either sees (iou) and, where both do, the share within
  // 1e-3 relative (the rest are silhouette pixels where one sees an edge, the other past it).
  std::size_t both = 0, either = 0, close = 0;
  for (std::size_t k = 0; k < depth.size(); ++k) {
    const float a = ours.depth()[k], b = depth[k];
    either += std::isfinite(a) || std::isfinite(b);
    if (std::isfinite(a) && std::isfinite(b)) {
      ++both;
      close += std::abs(a - b) <= 1e-3f * a;
    }
  }
  state.counters["iou"] = either ? double(both) / double(either) : 1.0;
  state.counters["within_1e-3"] = both ? double(close) / double(both) : 1.0;
  OSMesaDestroyContext(ctx);
}
#endif

int frames_only(int n, bool color, int width, int height, const std::string& dump) {
  const World& w = world();
  render::CameraSensorSpec spec;
  spec.width = width;
  spec.height = height;
  spec.far = 6;
  spec.color = color;
  render::CameraSensor cam(spec);
  render::DrawOptions opt;
  opt.simplify_error = 0;
  cam.set_model(w.model, w.geometry, opt);
  for (int k = 0; k < n; ++k) cam.render(w.camera, w.oMb, w.objects);
  std::printf("%d frames, centre depth %.4f m\n", n,
              cam.depth()[std::size_t(height / 2) * width + width / 2]);
  if (!dump.empty()) {
    std::FILE* f = std::fopen(dump.c_str(), "wb");
    if (!f) {
      std::fprintf(stderr, "cannot write %s\n", dump.c_str());
      return 1;
    }
    std::fwrite(cam.rgb().data(), 1, cam.rgb().size(), f);
    std::fwrite(cam.depth().data(), sizeof(float), cam.depth().size(), f);
    std::fwrite(cam.cloud().data(), sizeof(float), cam.cloud().size(), f);
    std::fclose(f);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<char*> rest;
  int frames = 0;
  bool color = true;
  int width = 640, height = 480;
  std::string dump;
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--dump=", 0) == 0) {
      dump = a.substr(7);
    } else if (a.rfind("--frames=", 0) == 0) {
      frames = std::stoi(a.substr(9));
    } else if (a == "--depth-only") {
      color = false;
    } else if (a.rfind("--size=", 0) == 0 && a.find('x') != std::string::npos) {
      width = std::stoi(a.substr(7));
      height = std::stoi(a.substr(a.find('x') + 1));
    } else {
      rest.push_back(argv[i]);
    }
  }
  if (frames > 0) return frames_only(frames, color, width, height, dump);
  auto reg = [](benchmark::internal::Benchmark* b) {
    b->Unit(benchmark::kMillisecond)
        ->MeasureProcessCPUTime()
        ->Repetitions(9)
        ->ReportAggregatesOnly(true)
        ->MinTime(0.3)
        // The best repetition beside the median: on a shared machine the median of a run moves
        // by a quarter from run to run (other tenants), the best far less.
        ->ComputeStatistics("min", [](const std::vector<double>& v) {
          return *std::min_element(v.begin(), v.end());
        });
  };
  for (const auto& size : {std::make_pair(640, 480), std::make_pair(1280, 1024)}) {
    const std::string base =
        "Camera/" + std::to_string(size.first) + "x" + std::to_string(size.second);
    reg(benchmark::RegisterBenchmark((base + "/full").c_str(), BM_Camera, size.first, size.second,
                                     true, true, true));
    reg(benchmark::RegisterBenchmark((base + "/simplified").c_str(), BM_Camera, size.first,
                                     size.second, false, true, true));
    reg(benchmark::RegisterBenchmark((base + "/rgb_only").c_str(), BM_Camera, size.first,
                                     size.second, true, false, true));
    reg(benchmark::RegisterBenchmark((base + "/depth_only").c_str(), BM_Camera, size.first,
                                     size.second, true, true, false));
  }
#if SE3_SIM_HAVE_OSMESA
  setenv("LP_NUM_THREADS", "1", 1);
  reg(benchmark::RegisterBenchmark("Depth/640x480/llvmpipe", BM_LlvmpipeDepth, 640, 480));
  reg(benchmark::RegisterBenchmark("Depth/1280x1024/llvmpipe", BM_LlvmpipeDepth, 1280, 1024));
#endif
  reg(benchmark::RegisterBenchmark("Scan/raycast/720", BM_ScanRaycast, 720));
  reg(benchmark::RegisterBenchmark("Scan/depth_sweep/720", BM_ScanDepthSweep, 720));
  int n = int(rest.size());
  benchmark::Initialize(&n, rest.data());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
