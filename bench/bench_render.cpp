// Milliseconds per 1280x1024 frame: background, ground grid to the horizon, the robot's
// shaded stand-ins, the text overlay and the copy into an rgb8 message buffer.
//
//   bench_render [google-benchmark flags]         the panda and ur5 scenes
//   bench_render --save_png=docs/render_panda.png  also writes the README's picture
//   bench_render --robots=DIR                     robots from DIR (default: the source tree's)
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

#include "se3_sim/render.h"

namespace {

using namespace se3;

// The shared robots: --robots=DIR, else data/robots beside this source file.
std::string g_robots;

std::string robots_dir() {
  if (!g_robots.empty()) return g_robots;
  std::string src = __FILE__;
  const size_t cut = src.rfind("/bench/");
  return (cut == std::string::npos ? std::string(".") : src.substr(0, cut)) + "/data/robots";
}

struct Scene {
  Model model;
  std::vector<SE3> oMb;
  render::Camera cam;
};

Scene load(const std::string& file) {
  Scene s;
  s.model = model_from_urdf_file(robots_dir() + "/" + file);
  Data data(s.model);
  VecX q = VecX::Zero(s.model.n);
  // A bent, readable pose: every other joint turned.
  for (int i = 0; i < s.model.n; ++i) q(i) = (i % 2 ? -0.7 : 0.4);
  if (file == "panda.urdf" && s.model.n >= 7) {
    const double ready[7] = {0.3, -0.5, -0.2, -2.1, 0.1, 1.7, 0.9};
    for (int i = 0; i < 7; ++i) q(i) = ready[i];
  }
  for (int i = 0; i < s.model.n; ++i) {  // within the limits (fingers closed)
    const int b = i + 1;
    if (!s.model.joints[b].angular()) q(i) = 0.0;
    q(i) = std::min(std::max(q(i), s.model.lower[b]), s.model.upper[b]);
  }
  forward_kinematics(s.model, data, SE3(), q);
  s.oMb = data.oMb;
  render::frame_bodies(s.model, s.oMb, s.cam);
  return s;
}

void BM_RenderFrame(benchmark::State& state, const std::string& file) {
  Scene s;
  try {
    s = load(file);
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  render::Renderer r(s.cam);
  r.set_model(s.model);
  render::Overlay ov;
  ov.sim_time = 12.345;
  ov.real_time_factor = 1.0;
  ov.joint = s.model.n ? s.model.joint_name[1] : "";
  ov.torque = 1.5;
  std::vector<uint8_t> rgb8(size_t(s.cam.width) * s.cam.height * 3);
  for (auto _ : state) {
    r.render(s.oMb, {}, ov);
    r.framebuffer().copy_rgb8(rgb8.data());
    benchmark::DoNotOptimize(rgb8.data());
  }
  state.counters["triangles_items"] = double(r.items().size());
}

BENCHMARK_CAPTURE(BM_RenderFrame, panda, std::string("panda.urdf"))
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);
BENCHMARK_CAPTURE(BM_RenderFrame, ur5, std::string("ur5_robot.urdf"))
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);

int save_png(const std::string& path) {
  Scene s = load("panda.urdf");
  render::Camera cam = s.cam;
  cam.eye = Vec3(1.55, -1.35, 0.95);
  cam.target = Vec3(0.25, 0.0, 0.42);
  cam.update();
  render::Renderer r(cam);
  r.set_model(s.model);
  r.style().frames = false;
  render::Overlay ov;
  ov.sim_time = 3.250;
  ov.real_time_factor = 1.0;
  ov.joint = s.model.joint_name.size() > 4 ? s.model.joint_name[4] : "";
  ov.torque = 2.0;
  r.render(s.oMb, {}, ov);
  std::string err;
  if (!r.write_png(path, &err)) {
    std::cerr << err << "\n";
    return 1;
  }
  std::cout << "wrote " << path << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i)
    if (std::string(argv[i]).rfind("--robots=", 0) == 0) g_robots = std::string(argv[i]).substr(9);
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--robots=", 0) == 0) continue;
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
  int n = int(rest.size());
  benchmark::Initialize(&n, rest.data());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
