// Driver for instruction counts of the dynamics algorithms (scripts/callgrind_dynamics.py runs it
// under valgrind --tool=callgrind): CALLS calls of one algorithm on one robot, cycling over 16
// random states (fixed seed), each call from the raw state.
//
//   callgrind_dynamics SUBJECT ALGO CALLS
//   SUBJECT: ur5, panda7, iiwa, pendulum, solo12, solo12_free, romeo_free, chainN, chainN_free (N
//   links); ALGO: fk, rnea, aba, crba, minv, and minv_factor / minv_recursive (minv by the route
//   named, whichever the model would choose)
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "../test/source_paths.h"
#include "se3_sim/dynamics/dynamics.h"

namespace {

using namespace se3;

Model load(const std::string& subject) {
  const std::string dir = se3_sim_test::source_dir() + "/data/robots/";
  UrdfOptions opt;
  if (subject == "ur5") return model_from_urdf_file(dir + "ur5_robot.urdf", opt);
  if (subject == "panda7") {
    opt.locked = {{"panda_finger_joint1", 0}, {"panda_finger_joint2", 0}};
    return model_from_urdf_file(dir + "panda.urdf", opt);
  }
  if (subject == "solo12") return model_from_urdf_file(dir + "solo12.urdf", opt);
  if (subject == "solo12_free") {
    opt.floating = true;
    return model_from_urdf_file(dir + "solo12.urdf", opt);
  }
  if (subject == "iiwa") return model_from_urdf_file(dir + "kuka_iiwa.urdf", opt);
  if (subject == "pendulum") return model_from_urdf_file(dir + "double_pendulum.urdf", opt);
  if (subject == "romeo_free") {
    opt.floating = true;
    return model_from_urdf_file(dir + "romeo_small.urdf", opt);
  }
  if (subject.rfind("chain", 0) == 0) {
    const bool free = subject.size() > 5 && subject.compare(subject.size() - 5, 5, "_free") == 0;
    const int links = std::atoi(subject.c_str() + 5);
    if (links > 0) return make_chain(links, free);
  }
  std::fprintf(stderr, "unknown subject '%s'\n", subject.c_str());
  std::exit(2);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(
        stderr,
        "usage: callgrind_dynamics SUBJECT fk|rnea|aba|crba|minv[_factor|_recursive] CALLS\n");
    return 2;
  }
  const Model m = load(argv[1]);
  const std::string algo = argv[2];
  const int calls = std::atoi(argv[3]);
  Data d(m);
  if (algo == "minv_factor" || algo == "minv_recursive") d.minv_by_factor = algo == "minv_factor";
  constexpr int kStates = 16;
  std::mt19937 gen(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<SE3> base;
  std::vector<VecX> q, v, x;
  for (int k = 0; k < kStates; ++k) {
    const Vec3 a(u(gen), u(gen), u(gen)), p(u(gen), u(gen), u(gen));
    base.emplace_back(exp_so3(2.0 * a), p);
    VecX qk(m.n), vk(m.nv), xk(m.nv);
    for (int i = 0; i < m.n; ++i) {
      const double lo = std::max(m.lower[i + 1], -3.0), hi = std::min(m.upper[i + 1], 3.0);
      qk[i] = lo + (hi - lo) * 0.5 * (u(gen) + 1.0);
    }
    for (int i = 0; i < m.nv; ++i) vk[i] = u(gen), xk[i] = u(gen);
    q.push_back(qk);
    v.push_back(vk);
    x.push_back(xk);
  }
  double sink = 0;
  for (int c = 0; c < calls; ++c) {
    const int k = c % kStates;
    if (algo == "fk") {
      forward_kinematics(m, d, base[k], q[k]);
      sink += d.oMb[m.n].p[0];
    } else if (algo == "rnea") {
      sink += rnea(m, d, base[k], q[k], v[k], x[k])[0];
    } else if (algo == "aba") {
      sink += aba(m, d, base[k], q[k], v[k], x[k])[0];
    } else if (algo == "crba") {
      sink += crba(m, d, base[k], q[k])(0, 0);
    } else if (algo.rfind("minv", 0) == 0) {
      sink += minv(m, d, base[k], q[k])(0, 0);
    } else {
      std::fprintf(stderr, "unknown algorithm '%s'\n", algo.c_str());
      return 2;
    }
  }
  std::printf("%s %s %d calls: %.17g\n", argv[1], algo.c_str(), calls, sink);
  return 0;
}
