// A constrained step against the unconstrained step of the same model, per scene:
//   fourbar          rkmk4 with the loop's multipliers (eq. 32) in every stage + projection,
//                    vs rkmk4 on the open tree;
//   pinned_chain     rkmk4 with pin + axis rows on a free base, vs the free chain;
//   quadruped_ground velocity-level time stepping with PGS contact (solo12, standing), vs
//                    semi_implicit_euler in free fall;
//   panda_limits     time stepping with the joint-limit rows (all at a limit), vs
//   semi_implicit_euler.
// Each constrained benchmark reports `free_ns` (the unconstrained step, same run) and
// `x_free` = constrained / unconstrained.
//
//   cd <package> && devel/lib/se3_sim/bench_constraints [--benchmark_filter=fourbar]
//   devel/lib/se3_sim/bench_constraints --drift_csv=docs/charts/constraint_drift.csv
// The second form writes the four-bar's loop-closure error over 20 s (every 10 ms) without
// stabilization, with Baumgarte only, and with Baumgarte + projection, then exits; the chart
// docs/charts/constraint_drift.png is drawn from it by tools/charts/plot_constraint_drift.py.
#include <benchmark/benchmark.h>
#include <time.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "../test/source_paths.h"
#include "se3_sim/sim/sim.h"
#include "se3_sim/solver/constraints.h"

namespace {

using namespace se3;

std::string scene_path(const std::string& name) {
  return se3_sim_test::source_dir() + "/config/scenes/" + name + ".yaml";
}

double cpu_ns() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e9 + ts.tv_nsec;
}

// ns per step of sim over `steps` steps (thread CPU time), restarting from its initial state
// whenever it has run for `horizon` steps (so the motion stays typical).
double ns_per_step(Simulator& sim, int steps, int horizon) {
  double total = 0;
  int done = 0;
  while (done < steps) {
    sim.reset();
    const int k = std::min(horizon, steps - done);
    const double t0 = cpu_ns();
    for (int i = 0; i < k; ++i) sim.step();
    total += cpu_ns() - t0;
    done += k;
  }
  return total / steps;
}

struct Pair {
  std::unique_ptr<Simulator> constrained, free;
};

Pair make_pair_for(const std::string& which) {
  Pair p;
  if (which == "panda_limits") {
    Scene sc;
    sc.robot = "data/robots/panda.urdf";
    sc.robot_path = se3_sim_test::source_dir() + "/data/robots/panda.urdf";
    sc.floating = false;
    sc.integrator = "semi_implicit_euler";
    Model m = scene_model(sc);
    State x(m);
    for (int i = 1; i <= m.n; ++i) x.q[i - 1] = m.upper[i];  // every joint at its upper limit
    SimConfig cfg;
    cfg.integrator = "semi_implicit_euler";
    p.free = std::make_unique<Simulator>(m, x, cfg);
    p.constrained = std::make_unique<Simulator>(m, x, cfg);
    ConstraintSpec spec;
    spec.joint_limits = true;
    p.constrained->set_constraints(spec);
    for (int i = 1; i <= m.n; ++i) {
      p.constrained->set_joint_effort(i, 50.0);
      p.free->set_joint_effort(i, 50.0);
    }
    return p;
  }
  const Scene sc = load_scene(scene_path(which));
  p.constrained = make_simulator(sc);
  Scene open = sc;
  open.constraints = ConstraintSpec();
  p.free = make_simulator(open);
  return p;
}

void BM_constrained(benchmark::State& state, const std::string& which) {
  Pair p = make_pair_for(which);
  const int horizon = 2000;
  double c_ns = 0, f_ns = 0;
  long n = 0;
  for (auto _ : state) {
    c_ns += ns_per_step(*p.constrained, 1000, horizon);
    f_ns += ns_per_step(*p.free, 1000, horizon);
    ++n;
  }
  state.counters["step_ns"] = c_ns / n;
  state.counters["free_ns"] = f_ns / n;
  state.counters["x_free"] = c_ns / f_ns;
  state.counters["rows"] = p.constrained->constraints()->report().rows;
  state.SetLabel(p.constrained->integrator());
}

int write_drift_csv(const std::string& file) {
  Scene sc = load_scene(scene_path("fourbar"));
  struct Variant {
    const char* name;
    double omega;
    bool project;
  };
  const Variant variants[] = {
      {"none", 0.0, false},
      {"baumgarte", sc.constraints.options.baumgarte_omega, false},
      {"baumgarte_projection", sc.constraints.options.baumgarte_omega, true}};
  std::vector<std::unique_ptr<Simulator>> sims;
  for (const Variant& v : variants) {
    Scene s = sc;
    s.constraints.options.baumgarte_omega = v.omega;
    s.constraints.options.project = v.project;
    sims.push_back(make_simulator(s));
  }
  std::ofstream out(file);
  if (!out) {
    std::fprintf(stderr, "cannot write %s\n", file.c_str());
    return 1;
  }
  out << "t";
  for (const Variant& v : variants) out << ",err_" << v.name;
  out << "\n";
  const int steps = 20000, every = 10;
  char buf[64];
  for (int k = 0; k <= steps; ++k) {
    if (k > 0) {
      for (auto& s : sims) s->step();
    }
    if (k % every) continue;
    std::snprintf(buf, sizeof buf, "%.6g", sims[0]->time());
    out << buf;
    for (auto& s : sims) {
      std::snprintf(buf, sizeof buf, ",%.6g", s->constraint_error());
      out << buf;
    }
    out << "\n";
  }
  std::printf("wrote %s (four-bar loop error, 20 s, dt %g, %s)\n", file.c_str(), sims[0]->dt(),
              sims[0]->integrator().c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const char* key = "--drift_csv=";
    if (std::strncmp(argv[i], key, std::strlen(key)) == 0) {
      return write_drift_csv(argv[i] + std::strlen(key));
    }
  }
  for (const char* s : {"fourbar", "pinned_chain", "quadruped_ground", "panda_limits"}) {
    benchmark::RegisterBenchmark((std::string("constrained_step/") + s).c_str(), BM_constrained,
                                 std::string(s))
        ->Iterations(4)
        ->Unit(benchmark::kMicrosecond);
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
