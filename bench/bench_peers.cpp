// Side by side in one run: se3_sim against DART 6 (fixed and free bases) and KDL (fixed base),
// on the same random states, with the same Release flags. Median ns per call of RNEA, ABA,
// CRBA (mass matrix) and D^-1, each call from the raw state (peers get their positions set
// anew before every call, so nothing is cached), and the largest relative difference of the
// answers. Prints a Markdown table.
//
//   bench_peers [--seconds S] [--robots DIR]     (default: the package's data/robots)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <random>
#include <regex>
#include <sstream>
#include <string>

#include "se3_sim/dynamics.h"
#include "se3_sim/sim.h"

#ifdef SE3_SIM_HAVE_DART
#include <dart/dynamics/DegreeOfFreedom.hpp>
#include <dart/dynamics/FreeJoint.hpp>
#include <dart/dynamics/Inertia.hpp>
#include <dart/dynamics/Joint.hpp>
#include <dart/dynamics/Skeleton.hpp>
#include <dart/utils/urdf/DartLoader.hpp>
#endif
#ifdef SE3_SIM_HAVE_KDL
#include <kdl/chaindynparam.hpp>
#include <kdl/chainidsolver_recursive_newton_euler.hpp>
#include <kdl/tree.hpp>
#include <kdl_parser/kdl_parser.hpp>
#endif

using namespace se3;
using Clock = std::chrono::steady_clock;

namespace {

double g_seconds = 0.4;
double g_sink = 0;

/// Median ns per call of f(k) over batches cycling through `count` states.
double median_ns(int count, const std::function<void(int)>& f) {
  const auto warm = Clock::now() + std::chrono::milliseconds(30);
  while (Clock::now() < warm) {
    for (int k = 0; k < count; ++k) f(k);
  }
  std::vector<double> per;
  const auto end = Clock::now() + std::chrono::duration<double>(g_seconds);
  while ((Clock::now() < end || per.size() < 7) && per.size() < 100000) {
    const auto t0 = Clock::now();
    for (int k = 0; k < count; ++k) f(k);
    per.push_back(std::chrono::duration<double, std::nano>(Clock::now() - t0).count() / count);
  }
  std::nth_element(per.begin(), per.begin() + per.size() / 2, per.end());
  return per[per.size() / 2];
}

double rel(const MatX& a, const MatX& b) {
  const double s = std::max(b.cwiseAbs().maxCoeff(), 1e-300);
  return (a - b).cwiseAbs().maxCoeff() / s;
}

std::string read_text(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

struct Case {
  std::string label, urdf_text;
  bool floating;
  std::vector<std::pair<std::string, double>> locked;
  std::string kdl_root, kdl_tip;  ///< chain for KDL ("" = no KDL)
  bool kdl_whole = true;          ///< the KDL chain holds every body of the model
};

struct Row {
  std::string label;
  int nv = 0;
  double ours[4] = {NAN, NAN, NAN, NAN}, dart[4] = {NAN, NAN, NAN, NAN},
         kdl[4] = {NAN, NAN, NAN, NAN};
  double err_dart = 0, err_kdl = 0;
};

const char* kAlgo[4] = {"RNEA", "ABA", "CRBA", "D^-1"};

Row run(const Case& c) {
  Row row;
  row.label = c.label;
  UrdfOptions opt;
  opt.floating = c.floating;
  opt.locked = c.locked;
  const Model m = model_from_urdf_string(c.urdf_text, opt);
  row.nv = m.nv;
  Data d(m);
  constexpr int N = 16;
  std::mt19937 gen(7);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<SE3> base(N);
  std::vector<VecX> q(N), v(N), a(N), tau(N);
  for (int k = 0; k < N; ++k) {
    if (c.floating) base[k] = SE3(exp_so3(Vec3(u(gen), u(gen), u(gen))), Vec3(u(gen), u(gen), 0));
    q[k] = VecX::Random(m.n);
    v[k] = VecX::Random(m.nv);
    a[k] = VecX::Random(m.nv);
    tau[k] = VecX::Random(m.nv);
  }
  row.ours[0] = median_ns(N, [&](int k) { g_sink += rnea(m, d, base[k], q[k], v[k], a[k])[0]; });
  row.ours[1] = median_ns(N, [&](int k) { g_sink += aba(m, d, base[k], q[k], v[k], tau[k])[0]; });
  row.ours[2] = median_ns(N, [&](int k) { g_sink += crba(m, d, base[k], q[k])(0, 0); });
  row.ours[3] = median_ns(N, [&](int k) { g_sink += minv(m, d, base[k], q[k])(0, 0); });

#ifdef SE3_SIM_HAVE_DART
  {
    static const std::regex geom(R"(<(visual|collision)\b[\s\S]*?</\1\s*>)");
    const std::string path = "/tmp/se3_sim_bench_peers.urdf";
    std::ofstream(path) << std::regex_replace(c.urdf_text, geom, "");
    using dart::utils::DartLoader;
    // Links without <inertial> are massless in URDF; DART's default would give them mass 1.
    DartLoader::Options dopt(
        nullptr,
        c.floating ? DartLoader::RootJointType::FLOATING : DartLoader::RootJointType::FIXED,
        dart::dynamics::Inertia(0.0, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Zero()));
    DartLoader loader(dopt);
    auto skel = loader.parseSkeleton(dart::common::Uri::createFromPath(path));
    if (skel && static_cast<int>(skel->getNumDofs()) == m.nv + static_cast<int>(c.locked.size())) {
      // Locked joints (panda's fingers) stay at zero in DART: same dynamics as ours.
      skel->setGravity(m.gravity);
      for (std::size_t k = 0; k < skel->getNumDofs(); ++k) {
        skel->getDof(k)->setDampingCoefficient(0);
        skel->getDof(k)->setSpringStiffness(0);
        skel->getDof(k)->setCoulombFriction(0);
      }
      for (std::size_t k = 0; k < skel->getNumJoints(); ++k) {
        skel->getJoint(k)->setActuatorType(dart::dynamics::Joint::FORCE);
      }
      const int nd = static_cast<int>(skel->getNumDofs());
      std::vector<int> map(m.nv);
      for (int k = 0; k < (c.floating ? 6 : 0); ++k) map[k] = k;
      for (int i = 1; i <= m.n; ++i) {
        map[m.idx_v(i)] = static_cast<int>(skel->getJoint(m.joint_name[i])->getIndexInSkeleton(0));
      }
      std::vector<Eigen::VectorXd> dq(N), dv(N), da(N), dt(N);
      for (int k = 0; k < N; ++k) {
        dq[k] = dv[k] = da[k] = dt[k] = Eigen::VectorXd::Zero(nd);
        if (c.floating) {
          Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
          T.linear() = base[k].R;
          T.translation() = base[k].p;
          dq[k].head<6>() = dart::dynamics::FreeJoint::convertToPositions(T);
        }
        for (int i = 1; i <= m.n; ++i) dq[k][map[m.idx_v(i)]] = q[k][i - 1];
        for (int j = 0; j < m.nv; ++j) {
          dv[k][map[j]] = v[k][j];
          da[k][map[j]] = a[k][j];
          dt[k][map[j]] = tau[k][j];
        }
      }
      auto set = [&](int k) {
        skel->setPositions(dq[k]);
        skel->setVelocities(dv[k]);
      };
      row.dart[0] = median_ns(N, [&](int k) {
        set(k);
        skel->setAccelerations(da[k]);
        skel->computeInverseDynamics();
        g_sink += skel->getForce(0);
      });
      row.dart[1] = median_ns(N, [&](int k) {
        set(k);
        skel->setForces(dt[k]);
        skel->computeForwardDynamics();
        g_sink += skel->getAcceleration(0);
      });
      row.dart[2] = median_ns(N, [&](int k) {
        skel->setPositions(dq[k]);
        g_sink += skel->getMassMatrix()(0, 0);
      });
      row.dart[3] = median_ns(N, [&](int k) {
        skel->setPositions(dq[k]);
        g_sink += skel->getInvMassMatrix()(0, 0);
      });
      // Same answers (state 0): inverse dynamics, forward dynamics, mass matrix.
      auto pick = [&](const Eigen::VectorXd& x) {
        VecX y(m.nv);
        for (int j = 0; j < m.nv; ++j) y[j] = x[map[j]];
        return y;
      };
      set(0);
      skel->setAccelerations(da[0]);
      skel->computeInverseDynamics();
      row.err_dart = std::max(row.err_dart,
                              rel(rnea(m, d, base[0], q[0], v[0], a[0]), pick(skel->getForces())));
      set(0);
      skel->setForces(dt[0]);
      skel->computeForwardDynamics();
      row.err_dart = std::max(row.err_dart, rel(aba(m, d, base[0], q[0], v[0], tau[0]),
                                                pick(skel->getAccelerations())));
      const Eigen::MatrixXd Md = skel->getMassMatrix();
      MatX Mo(m.nv, m.nv);
      for (int r = 0; r < m.nv; ++r) {
        for (int cc = 0; cc < m.nv; ++cc) Mo(r, cc) = Md(map[r], map[cc]);
      }
      row.err_dart = std::max(row.err_dart, rel(crba(m, d, base[0], q[0]), Mo));
    }
  }
#endif
#ifdef SE3_SIM_HAVE_KDL
  if (!c.kdl_root.empty() && !c.floating) {
    // KDL's chain ends at kdl_tip: links beyond it (panda's hand and fingers) are not in KDL's
    // model, so its answers are compared only where the chain holds the whole robot.
    KDL::Tree tree;
    KDL::Chain chain;
    if (kdl_parser::treeFromString(c.urdf_text, tree) &&
        tree.getChain(c.kdl_root, c.kdl_tip, chain) &&
        static_cast<int>(chain.getNrOfJoints()) == m.n) {
      const KDL::Vector g(m.gravity.x(), m.gravity.y(), m.gravity.z());
      KDL::ChainIdSolver_RNE id(chain, g);
      KDL::ChainDynParam dyn(chain, g);
      const int n = m.n;
      KDL::JntArray jq(n), jv(n), ja(n), jt(n);
      KDL::Wrenches wr(chain.getNrOfSegments(), KDL::Wrench::Zero());
      KDL::JntSpaceInertiaMatrix H(n);
      // KDL orders joints along the chain, as our model does for a chain.
      row.kdl[0] = median_ns(N, [&](int k) {
        for (int i = 0; i < n; ++i) {
          jq(i) = q[k][i];
          jv(i) = v[k][i];
          ja(i) = a[k][i];
        }
        id.CartToJnt(jq, jv, ja, wr, jt);
        g_sink += jt(0);
      });
      row.kdl[2] = median_ns(N, [&](int k) {
        for (int i = 0; i < n; ++i) jq(i) = q[k][i];
        dyn.JntToMass(jq, H);
        g_sink += H(0, 0);
      });
      for (int i = 0; i < n; ++i) {
        jq(i) = q[0][i];
        jv(i) = v[0][i];
        ja(i) = a[0][i];
      }
      if (c.kdl_whole) {
        id.CartToJnt(jq, jv, ja, wr, jt);
        row.err_kdl = std::max(row.err_kdl, rel(rnea(m, d, base[0], q[0], v[0], a[0]), jt.data));
        dyn.JntToMass(jq, H);
        row.err_kdl = std::max(row.err_kdl, rel(crba(m, d, base[0], q[0]), H.data));
      } else {
        row.err_kdl = NAN;
      }
    }
  }
#endif
  return row;
}

std::string fmt(double x) {
  if (std::isnan(x)) return "—";
  char b[32];
  std::snprintf(b, sizeof b, x >= 1e5 ? "%.3g" : "%.0f", x);
  return b;
}

std::string fmt_e(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1e", x);
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  std::string dir = SE3_SIM_SOURCE_DIR "/data/robots";
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--seconds")) g_seconds = std::atof(argv[i + 1]);
    if (!std::strcmp(argv[i], "--robots")) dir = argv[i + 1];
  }
  const std::vector<std::pair<std::string, double>> fingers = {{"panda_finger_joint1", 0},
                                                               {"panda_finger_joint2", 0}};
  std::vector<Case> cases = {
      {"UR5", read_text(dir + "/ur5_robot.urdf"), false, {}, "base_link", "ee_link"},
      {"Panda (7, fingers off)", read_text(dir + "/panda.urdf"), false, fingers, "panda_link0",
       "panda_link8", false},
      {"KUKA iiwa",
       read_text(dir + "/kuka_iiwa.urdf"),
       false,
       {},
       "lbr_iiwa_link_0",
       "lbr_iiwa_link_7"},
      {"double pendulum", read_text(dir + "/double_pendulum.urdf"), false, {}, "", ""},
      {"Solo12 (free base)", read_text(dir + "/solo12.urdf"), true, {}, "", ""},
      {"ANYmal C (free base)", read_text(dir + "/anymal_c.urdf"), true, {}, "", ""},
      {"HyQ (free base)", read_text(dir + "/hyq_no_sensors.urdf"), true, {}, "", ""},
      {"Romeo (free base)", read_text(dir + "/romeo_small.urdf"), true, {}, "", ""},
      {"200-link chain", model_to_urdf(make_chain(200, false)), false, {}, "base", "link200"},
  };
  std::printf(
      "| robot | nv | algorithm | ours ns | DART 6.12 ns | KDL ns | DART/ours | "
      "KDL/ours | max rel. diff DART / KDL |\n|---|---|---|---|---|---|---|---|---|\n");
  std::fflush(stdout);
  double worst_dart = 0, worst_kdl = 0;
  for (const Case& c : cases) {
    const Row r = run(c);
    for (int k = 0; k < 4; ++k) {
      char ratio_d[32] = "—", ratio_k[32] = "—";
      if (!std::isnan(r.dart[k]))
        std::snprintf(ratio_d, sizeof ratio_d, "%.1f×", r.dart[k] / r.ours[k]);
      if (!std::isnan(r.kdl[k]))
        std::snprintf(ratio_k, sizeof ratio_k, "%.1f×", r.kdl[k] / r.ours[k]);
      char diff[64] = "";
      if (k == 0) {
        std::snprintf(
            diff, sizeof diff, "%s / %s", std::isnan(r.dart[0]) ? "—" : fmt_e(r.err_dart).c_str(),
            std::isnan(r.kdl[0]) || std::isnan(r.err_kdl) ? "—" : fmt_e(r.err_kdl).c_str());
      }
      std::printf("| %s | %d | %s | %s | %s | %s | %s | %s | %s |\n", k == 0 ? r.label.c_str() : "",
                  r.nv, kAlgo[k], fmt(r.ours[k]).c_str(), fmt(r.dart[k]).c_str(),
                  fmt(r.kdl[k]).c_str(), ratio_d, ratio_k, diff);
    }
    std::fflush(stdout);
    worst_dart = std::max(worst_dart, r.err_dart);
    if (!std::isnan(r.err_kdl)) worst_kdl = std::max(worst_kdl, r.err_kdl);
  }
  std::printf(
      "\nlargest relative difference of the answers (RNEA, ABA, mass matrix; max norm): "
      "DART %.1e, KDL %.1e\n",
      worst_dart, worst_kdl);
  if (g_sink == 0.5) std::printf(" ");
  return 0;
}
