// Google Benchmark of the dynamics algorithms per robot: forward kinematics, RNEA, ABA, CRBA
// and D^-1 on random states (fixed seed), each call from the raw state.
//   bench_dynamics [--benchmark_filter=...]     (median of repetitions: --benchmark_repetitions)
#include <benchmark/benchmark.h>

#include <random>
#include <string>

#include "../test/source_paths.h"
#include "se3_sim/dynamics/dynamics.h"

namespace {

using namespace se3;

struct Subject {
  const char* name;
  std::string path;  ///< URDF file or chain:N
  bool floating;
};

Model load(const Subject& s) {
  if (s.path.compare(0, 6, "chain:") == 0)
    return make_chain(std::stoi(s.path.substr(6)), s.floating);
  UrdfOptions opt;
  opt.floating = s.floating;
  if (s.path.find("panda") != std::string::npos) {
    opt.locked = {{"panda_finger_joint1", 0}, {"panda_finger_joint2", 0}};
  }
  return model_from_urdf_file(s.path, opt);
}

template <class F>
void run(benchmark::State& st, const Subject& subj, F f) {
  const Model m = load(subj);
  Data d(m);
  constexpr int N = 16;
  std::mt19937 gen(1);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<SE3> base(N);
  std::vector<VecX> q(N), v(N), x(N);
  for (int k = 0; k < N; ++k) {
    base[k] = SE3(exp_so3(Vec3(u(gen), u(gen), u(gen))), Vec3(u(gen), u(gen), u(gen)));
    q[k] = VecX::Random(m.n);
    v[k] = VecX::Random(m.nv);
    x[k] = VecX::Random(m.nv);
  }
  int k = 0;
  for (auto _ : st) {
    benchmark::DoNotOptimize(f(m, d, base[k], q[k], v[k], x[k]));
    k = (k + 1) % N;
  }
  st.counters["nv"] = m.nv;
}

double fk(const Model& m, Data& d, const SE3& b, const VecX& q, const VecX&, const VecX&) {
  forward_kinematics(m, d, b, q);
  return d.oMb[m.n].p[0];
}
double rn(const Model& m, Data& d, const SE3& b, const VecX& q, const VecX& v, const VecX& a) {
  return rnea(m, d, b, q, v, a)[0];
}
double ab(const Model& m, Data& d, const SE3& b, const VecX& q, const VecX& v, const VecX& t) {
  return aba(m, d, b, q, v, t)[0];
}
double cr(const Model& m, Data& d, const SE3& b, const VecX& q, const VecX&, const VecX&) {
  return crba(m, d, b, q)(0, 0);
}
double mi(const Model& m, Data& d, const SE3& b, const VecX& q, const VecX&, const VecX&) {
  return minv(m, d, b, q)(0, 0);
}

const std::string kDir = se3_sim_test::source_dir() + "/data/robots/";
const Subject kSubjects[] = {
    {"ur5", kDir + "ur5_robot.urdf", false},
    {"panda7", kDir + "panda.urdf", false},
    {"kuka_iiwa", kDir + "kuka_iiwa.urdf", false},
    {"double_pendulum", kDir + "double_pendulum.urdf", false},
    {"solo12_free", kDir + "solo12.urdf", true},
    {"anymal_c_free", kDir + "anymal_c.urdf", true},
    {"hyq_free", kDir + "hyq_no_sensors.urdf", true},
    {"romeo_free", kDir + "romeo_small.urdf", true},
    {"chain200", "chain:200", false},
};

const int kRegistered = [] {
  for (const Subject& s : kSubjects) {
    const std::string n = s.name;
    benchmark::RegisterBenchmark(("fk/" + n).c_str(),
                                 [s](benchmark::State& st) { run(st, s, fk); });
    benchmark::RegisterBenchmark(("rnea/" + n).c_str(),
                                 [s](benchmark::State& st) { run(st, s, rn); });
    benchmark::RegisterBenchmark(("aba/" + n).c_str(),
                                 [s](benchmark::State& st) { run(st, s, ab); });
    benchmark::RegisterBenchmark(("crba/" + n).c_str(),
                                 [s](benchmark::State& st) { run(st, s, cr); });
    benchmark::RegisterBenchmark(("minv/" + n).c_str(),
                                 [s](benchmark::State& st) { run(st, s, mi); });
  }
  return 0;
}();

}  // namespace

BENCHMARK_MAIN();
