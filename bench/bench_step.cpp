// One time step per scene and integrator, side by side with the ABA call it is built on.
// Each step benchmark reports `aba_ns` (the same scene's ABA, measured in the same run) and
// `x_aba` = step time / ABA time. Targets (issue 3): symplectic_euler <= 1.2, rkmk4 <= 4.5.
// `rtf/<scene>` reports the headless real-time factor at the scene's 1 kHz (simulated seconds
// per wall second, zero torques, diagnostics excluded).
//
//   cd <package> && devel/lib/se3_sim/bench_step [--benchmark_filter=satellite]
// (scenes from ./config/scenes, or from $SE3_SIM_SCENES)
#include <benchmark/benchmark.h>
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "se3_sim/sim.h"

#ifndef SE3_SIM_SOURCE_DIR
#define SE3_SIM_SOURCE_DIR "."
#endif

namespace {

using namespace se3;

const char* kScenes[] = {"satellite_arm", "fixed_arm", "chain20", "pendulum"};

std::string scene_path(const std::string& name) {
  // Run from the package directory or from anywhere with SE3_SIM_SCENES set.
  const char* env = std::getenv("SE3_SIM_SCENES");
  if (env) return std::string(env) + "/" + name + ".yaml";
  return std::string(SE3_SIM_SOURCE_DIR) + "/config/scenes/" + name + ".yaml";
}

// Thread CPU time in ns: ratios stay meaningful on a shared, loaded machine.
double cpu_ns() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e9 + ts.tv_nsec;
}

struct Subject {
  Scene scene;
  Model model;
  State x0;
};

Subject& subject(const std::string& name) {
  static std::map<std::string, Subject> cache;
  auto it = cache.find(name);
  if (it == cache.end()) {
    Subject s;
    s.scene = load_scene(scene_path(name));
    s.model = scene_model(s.scene);
    s.x0 = scene_state(s.scene, s.model);
    it = cache.emplace(name, std::move(s)).first;
  }
  return it->second;
}

// ABA of the scene in ns per call (median of batches), for the ratio.
double aba_ns(Subject& s) {
  static std::map<std::string, double> cache;
  auto it = cache.find(s.scene.name);
  if (it != cache.end()) return it->second;
  Data d(s.model);
  VecX tau = VecX::Zero(s.model.nv);
  std::vector<double> batches;
  for (int b = 0; b < 21; ++b) {
    const double t0 = cpu_ns();
    for (int k = 0; k < 2000; ++k) {
      benchmark::DoNotOptimize(aba(s.model, d, s.x0.base, s.x0.q, s.x0.v, tau));
      benchmark::ClobberMemory();
    }
    batches.push_back((cpu_ns() - t0) / 2000);
  }
  std::nth_element(batches.begin(), batches.begin() + 10, batches.end());
  cache[s.scene.name] = batches[10];
  return batches[10];
}

void BM_Aba(benchmark::State& state, const std::string& name) {
  Subject& s = subject(name);
  Data d(s.model);
  VecX tau = VecX::Zero(s.model.nv);
  for (auto _ : state) {
    benchmark::DoNotOptimize(aba(s.model, d, s.x0.base, s.x0.q, s.x0.v, tau));
    benchmark::ClobberMemory();
  }
  state.counters["nv"] = s.model.nv;
}

void BM_Step(benchmark::State& state, const std::string& name, const std::string& integ) {
  Subject& s = subject(name);
  const double ref = aba_ns(s);
  StepperOptions opt;
  opt.tol = s.scene.tol;
  opt.friction_eps = s.scene.friction_eps;
  auto st = make_stepper(integ, s.model, opt);
  State x = s.x0;
  const VecX tau = VecX::Zero(s.model.nv);
  const double h = s.scene.dt;
  std::int64_t n = 0, evals = 0;
  const double t0 = cpu_ns();
  for (auto _ : state) {
    const StepInfo info = st->step(x, tau, h);
    evals += info.evaluations;
    if ((++n & 1023) == 0) {  // stay near the scene's state (explicit Euler drifts away)
      x.base = s.x0.base;
      x.q = s.x0.q;
      x.v = s.x0.v;
      st->restart();
    }
    benchmark::ClobberMemory();
  }
  const double ns = (cpu_ns() - t0) / std::max<std::int64_t>(n, 1);
  state.counters["aba_ns"] = ref;
  state.counters["x_aba"] = ns / ref;
  state.counters["aba_calls"] = static_cast<double>(evals) / std::max<std::int64_t>(n, 1);
}

// The Simulator's step: the stepper plus command handling and the divergence guard.
void BM_SimStep(benchmark::State& state, const std::string& name, const std::string& integ) {
  Subject& s = subject(name);
  const double ref = aba_ns(s);
  SimConfig cfg;
  cfg.integrator = integ;
  cfg.dt = s.scene.dt;
  Simulator sim(s.model, s.x0, cfg);
  std::int64_t n = 0;
  const double t0 = cpu_ns();
  for (auto _ : state) {
    if (!sim.step() || (++n % 4096) == 0) sim.reset();
    benchmark::ClobberMemory();
  }
  const double ns = (cpu_ns() - t0) / std::max<std::int64_t>(n, 1);
  state.counters["x_aba"] = ns / ref;
}

void BM_Rtf(benchmark::State& state, const std::string& name) {
  SimulateOptions o;
  o.scene = scene_path(name);
  o.duration = 2.0;
  SimulateResult r;
  for (auto _ : state) r = simulate_headless(o);
  state.counters["rtf"] = r.sim_s / r.wall_s;
  state.counters["energy_drift_rel"] = r.energy_drift_rel;
  if (std::isfinite(r.momentum_drift_rel))
    state.counters["momentum_drift_rel"] = r.momentum_drift_rel;
}

int register_all() {
  for (const char* sc : kScenes) {
    const std::string name = sc;
    benchmark::RegisterBenchmark(("aba/" + name).c_str(), BM_Aba, name);
    for (const char* integ : {"symplectic_euler", "euler", "rkmk4", "rkmk45"}) {
      benchmark::RegisterBenchmark(("step/" + name + "/" + integ).c_str(), BM_Step, name,
                                   std::string(integ));
    }
    for (const char* integ : {"symplectic_euler", "rkmk4"}) {
      benchmark::RegisterBenchmark(("sim_step/" + name + "/" + integ).c_str(), BM_SimStep, name,
                                   std::string(integ));
    }
    benchmark::RegisterBenchmark(("rtf/" + name).c_str(), BM_Rtf, name)
        ->Iterations(1)
        ->Unit(benchmark::kMillisecond);
  }
  return 0;
}

const int registered = register_all();

}  // namespace

int main(int argc, char** argv) {
  (void)registered;
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
