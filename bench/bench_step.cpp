// One time step per scene and integrator, side by side with the ABA call it is built on.
//
//   step/<scene>/<integrator>      the bare Stepper::step (no guard, no bookkeeping)
//   sim_step/<scene>/<integrator>  the whole Simulator::step, as a user or the node runs it:
//                                  stepper, divergence guard, last-good copies, counters
//   aba/<scene>                    ABA alone at the scene's initial state
//   rtf/<scene>                    headless real-time factor at the scene's step (simulated
//                                  seconds per wall second, zero torques, diagnostics excluded)
//
// Step and ABA are timed in the same run, interleaved: each of kBatches batches times k calls
// of the step, then k ABA calls of the same scene (k chosen so that k ABA calls take about
// 200 us), in thread CPU time (ratios stay meaningful on a shared, loaded machine). Counters:
// `ns` and `aba_ns` are the medians over the batches of ns per call, `x_aba` = ns / aba_ns, and
// `aba_calls` the ABA calls per step. `aba_chained_ns` and `x_aba_chained`: the same against ABA
// calls chained through their inputs as a time loop chains them (AbaCall::chained): independent
// calls overlap, which no integrator's dependent calls can, so x_aba charges that overlap to the
// step and x_aba_chained does not. The Time column is the mean ns per step.
// Issue 3's targets and the measurements: docs/performance.md.
//
//   cd <package> && devel/lib/se3_sim/bench_step [--benchmark_filter=fixed_panda]
// (scenes from ./config/scenes, or from $SE3_SIM_SCENES)
#include <benchmark/benchmark.h>
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "../test/source_paths.h"
#include "se3_sim/sim/sim.h"

namespace {

using namespace se3;

const char* kScenes[] = {"fixed_panda", "satellite_arm", "fixed_arm", "chain20", "pendulum"};
constexpr int kBatches = 201;

std::string scene_path(const std::string& name) {
  // Run from the package directory or from anywhere with SE3_SIM_SCENES set.
  const char* env = std::getenv("SE3_SIM_SCENES");
  if (env) return std::string(env) + "/" + name + ".yaml";
  return se3_sim_test::source_dir() + "/config/scenes/" + name + ".yaml";
}

double cpu_ns() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e9 + ts.tv_nsec;
}

double median(std::vector<double> v) {
  const size_t m = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + m, v.end());
  return v[m];
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

// The scene's ABA at its initial state (own Data, zero torques). operator() calls it on the same
// input every time: consecutive calls are independent and the processor overlaps the end of one
// with the start of the next. chained() makes every input depend on the previous call's output,
// as in any time loop (q <- q0 + 0 ddq, v <- v0 + 0 ddq: the same numbers, but the next call must
// wait), and so includes those n + nv multiply-adds.
struct AbaCall {
  const Subject& s;
  Data d;
  VecX tau, q, v;
  double zero;
  explicit AbaCall(const Subject& subj)
      : s(subj), d(subj.model), tau(VecX::Zero(subj.model.nv)), q(subj.x0.q), v(subj.x0.v) {
    volatile double z = 0.0;  // not a constant the compiler could fold
    zero = z;
  }
  void operator()() {
    benchmark::DoNotOptimize(aba(s.model, d, s.x0.base, s.x0.q, s.x0.v, tau));
    benchmark::ClobberMemory();
  }
  void chained() {
    const VecX& a = aba(s.model, d, s.x0.base, q, v, tau);
    const int n = s.model.n, nv = s.model.nv;
    for (int k = 0; k < n; ++k) q[k] = s.x0.q[k] + zero * a[nv - n + k];
    for (int k = 0; k < nv; ++k) v[k] = s.x0.v[k] + zero * a[k];
  }
};

// Batch size: about 200 us of ABA calls.
int batch_size(AbaCall& a) {
  for (int k = 0; k < 200; ++k) a();
  const double t0 = cpu_ns();
  for (int k = 0; k < 200; ++k) a();
  const double ns = (cpu_ns() - t0) / 200;
  return std::max(20, static_cast<int>(2e5 / std::max(ns, 1.0)));
}

// Times step() against the scene's ABA, interleaved batch by batch (see the header).
template <class F>
void time_against_aba(benchmark::State& state, const Subject& s, F&& step) {
  AbaCall a(s);
  const int k = batch_size(a);
  for (int i = 0; i < 10; ++i) step();  // warm up
  std::vector<double> t_step, t_aba, t_chain;
  for (auto _ : state) {
    const double t0 = cpu_ns();
    for (int i = 0; i < k; ++i) {
      step();
      benchmark::ClobberMemory();
    }
    const double t1 = cpu_ns();
    for (int i = 0; i < k; ++i) a();
    const double t2 = cpu_ns();
    for (int i = 0; i < k; ++i) a.chained();
    const double t3 = cpu_ns();
    t_step.push_back((t1 - t0) / k);
    t_aba.push_back((t2 - t1) / k);
    t_chain.push_back((t3 - t2) / k);
    state.SetIterationTime((t1 - t0) * 1e-9 / k);
  }
  const double ns = median(t_step), ref = median(t_aba), chain = median(t_chain);
  state.counters["ns"] = ns;
  state.counters["aba_ns"] = ref;
  state.counters["x_aba"] = ns / ref;
  state.counters["aba_chained_ns"] = chain;
  state.counters["x_aba_chained"] = ns / chain;
}

void BM_Aba(benchmark::State& state, const std::string& name) {
  Subject& s = subject(name);
  AbaCall a(s);
  for (auto _ : state) a();
  state.counters["nv"] = s.model.nv;
}

void BM_Step(benchmark::State& state, const std::string& name, const std::string& integ) {
  Subject& s = subject(name);
  StepperOptions opt;
  opt.tol = s.scene.tol;
  opt.friction_eps = s.scene.friction_eps;
  auto st = make_stepper(integ, s.model, opt);
  State x = s.x0;
  const VecX tau = VecX::Zero(s.model.nv);
  const double h = s.scene.dt;
  std::int64_t n = 0, evals = 0;
  time_against_aba(state, s, [&] {
    evals += st->step(x, tau, h).evaluations;
    if ((++n & 1023) == 0) {  // stay near the scene's state (explicit Euler drifts away)
      x.base = s.x0.base;
      x.q = s.x0.q;
      x.v = s.x0.v;
      st->restart();
    }
  });
  state.counters["aba_calls"] = static_cast<double>(evals) / std::max<std::int64_t>(n, 1);
}

void BM_SimStep(benchmark::State& state, const std::string& name, const std::string& integ) {
  Subject& s = subject(name);
  SimConfig cfg;
  cfg.integrator = integ;
  cfg.dt = s.scene.dt;
  cfg.stepper.tol = s.scene.tol;
  cfg.stepper.friction_eps = s.scene.friction_eps;
  Simulator sim(s.model, s.x0, cfg);
  if (!s.scene.constraints.empty()) sim.set_constraints(s.scene.constraints);
  std::int64_t n = 0;
  time_against_aba(state, s, [&] {
    // Back to the scene's state now and then, as in step/ (and after a divergence).
    if (!sim.step() || (++n & 4095) == 0) sim.reset();
  });
  state.counters["aba_calls"] =
      static_cast<double>(sim.evaluations()) / std::max<std::uint64_t>(sim.steps(), 1);
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
    for (const char* integ : {"semi_implicit_euler", "euler", "rkmk4", "rkmk45"}) {
      benchmark::RegisterBenchmark(("step/" + name + "/" + integ).c_str(), BM_Step, name,
                                   std::string(integ))
          ->Iterations(kBatches)
          ->UseManualTime();
    }
    for (const char* integ : {"semi_implicit_euler", "euler", "rkmk4"}) {
      benchmark::RegisterBenchmark(("sim_step/" + name + "/" + integ).c_str(), BM_SimStep, name,
                                   std::string(integ))
          ->Iterations(kBatches)
          ->UseManualTime();
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
