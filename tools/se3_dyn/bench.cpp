// se3_dyn bench: median ns per call of fk, rnea, aba, crba, minv over random states.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <random>
#include <sstream>

#include "cli.h"
#include "se3_sim/dynamics/dynamics.h"
#include "se3_sim/model/limits.h"

namespace se3_dyn {
namespace {

struct RandomStates {
  std::vector<se3::SE3> base;
  std::vector<se3::VecX> q, v, x;  // x: tau (aba) or a (rnea)
};

RandomStates make_states(const se3::Model& m, int count, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  RandomStates s;
  for (int k = 0; k < count; ++k) {
    const se3::Vec3 a(u(gen), u(gen), u(gen)), p(u(gen), u(gen), u(gen));
    s.base.emplace_back(se3::exp_so3(2.0 * a), p);
    se3::VecX q(m.n), v(m.nv), x(m.nv);
    for (int i = 0; i < m.n; ++i) {
      const double lo = std::max(m.lower[i + 1], -3.0), hi = std::min(m.upper[i + 1], 3.0);
      q[i] = lo + (hi - lo) * 0.5 * (u(gen) + 1.0);
    }
    for (int i = 0; i < m.nv; ++i) {
      v[i] = u(gen);
      x[i] = u(gen);
    }
    s.q.push_back(q);
    s.v.push_back(v);
    s.x.push_back(x);
  }
  return s;
}

}  // namespace

int cmd_bench(int argc, char** argv) {
  const Args args(argc, argv, 2, {"floating", "json"}, {"algo", "gravity", "seconds"});
  const se3::Model m = load_model(args);
  std::vector<std::string> algos = {"fk", "rnea", "aba", "crba", "minv"};
  if (!args.has("algo") && m.nv > se3::limits::kMaxDenseNv) {
    algos = {"fk", "rnea", "aba"};
    std::fprintf(stderr, "se3_dyn bench: crba and minv left out: nv = %d is more than %d\n", m.nv,
                 se3::limits::kMaxDenseNv);
  }
  if (args.has("algo")) {
    algos.clear();
    std::stringstream ss(args.get("algo"));
    std::string a;
    while (std::getline(ss, a, ',')) {
      if (a != "fk" && a != "rnea" && a != "aba" && a != "crba" && a != "minv") {
        throw UsageError("--algo takes a comma-separated list of fk, rnea, aba, crba, minv");
      }
      algos.push_back(a);
    }
  }
  for (const auto& a : algos) {
    if ((a == "crba" || a == "minv") && m.nv > se3::limits::kMaxDenseNv) {
      throw InputError(a + " makes an nv x nv matrix: nv = " + std::to_string(m.nv) +
                       " is more than the " + std::to_string(se3::limits::kMaxDenseNv) +
                       " it allows (docs/robustness.md); choose --algo fk,rnea,aba");
    }
  }
  const double seconds = args.get_double("seconds", 1.0);  // per algorithm
  if (!(seconds > 0 && seconds <= 3600)) throw UsageError("--seconds needs 0 < s <= 3600");
  se3::Data d(m);
  constexpr int kStates = 32;
  const RandomStates s = make_states(m, kStates, 1);
  double sink = 0;
  auto run_once = [&](const std::string& a, int k) {
    if (a == "fk") {
      se3::forward_kinematics(m, d, s.base[k], s.q[k]);
      sink += d.oMb[m.n].p[0];
    } else if (a == "rnea") {
      sink += se3::rnea(m, d, s.base[k], s.q[k], s.v[k], s.x[k])[0];
    } else if (a == "aba") {
      sink += se3::aba(m, d, s.base[k], s.q[k], s.v[k], s.x[k])[0];
    } else if (a == "crba") {
      sink += se3::crba(m, d, s.base[k], s.q[k])(0, 0);
    } else {
      sink += se3::minv(m, d, s.base[k], s.q[k])(0, 0);
    }
  };
  using clock = std::chrono::steady_clock;
  std::vector<std::pair<std::string, double>> results;
  for (const auto& a : algos) {
    // Warm-up, then batches of one call per state; the median batch gives ns per call.
    const auto warm_end = clock::now() + std::chrono::milliseconds(50);
    while (clock::now() < warm_end) {
      for (int k = 0; k < kStates; ++k) run_once(a, k);
    }
    std::vector<double> per_call;
    const auto end = clock::now() + std::chrono::duration<double>(seconds);
    while ((clock::now() < end || per_call.size() < 11) && per_call.size() < 200000) {
      const auto t0 = clock::now();
      for (int k = 0; k < kStates; ++k) run_once(a, k);
      const auto t1 = clock::now();
      per_call.push_back(std::chrono::duration<double, std::nano>(t1 - t0).count() / kStates);
    }
    std::nth_element(per_call.begin(), per_call.begin() + per_call.size() / 2, per_call.end());
    results.emplace_back(a, per_call[per_call.size() / 2]);
  }
  if (args.has("json")) {
    std::printf("{\"model\": \"%s\", \"nv\": %d, \"ns_per_call\": {", args.positional[0].c_str(),
                m.nv);
    for (size_t k = 0; k < results.size(); ++k) {
      std::printf("%s\"%s\": %.1f", k ? ", " : "", results[k].first.c_str(), results[k].second);
    }
    std::printf("}}\n");
  } else {
    std::printf("%s: nv = %d (%s base), median ns per call over %d random states\n",
                args.positional[0].c_str(), m.nv, m.floating ? "free" : "fixed", kStates);
    for (const auto& r : results) std::printf("  %-5s %12.1f\n", r.first.c_str(), r.second);
  }
  if (sink == 0.123456789) std::printf(" ");  // keeps the calls observable
  return 0;
}

}  // namespace se3_dyn
