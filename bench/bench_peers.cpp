// Side by side in one run: se3_sim against MuJoCo 2.2 (fixed and free bases, through its own URDF
// import), DART 6 (fixed and free) and KDL (fixed base), on the same random states, with the same
// Release flags. Per robot and algorithm: median ns per call (each call from the raw state: the
// peers get their state set anew before every call, so nothing is cached), optionally callgrind
// instructions per call, and the largest relative difference of the answers. Prints a Markdown
// table, then the cases below the goal of issue 16 (algorithms 2x, whole steps 3x MuJoCo).
//
//   bench_peers [--seconds S] [--rounds N] [--robots DIR] [--only TEXT] [--callgrind] [--reps R]
//
// Times are medians of batches over S seconds (default 0.4) per measurement; with --rounds N
// every robot is measured N times and the smallest median kept (a load burst on a shared
// machine then slows only one round).
// Algorithms: RNEA; forward dynamics (ours ABA; MuJoCo mj_kinematics, mj_comPos, mj_crb,
// mj_factorM, mj_comVel, mj_rne for the bias and mj_solveM: its fastest route, mj_forward is
// printed below the table); mass matrix (MuJoCo mj_crb, its sparse qM, without mj_fullM);
// inverse mass matrix (MuJoCo mj_crb, mj_factorM, mj_solveM on the identity); whole steps of
// dt = 1 ms: ours semi_implicit_euler (symplectic_euler before the rename) and rkmk4 against
// mj_step with mjINT_EULER and mjINT_RK4 (no damping, no contact, no constraint on both sides).
//
// --callgrind runs the measurements again under `valgrind --tool=callgrind --collect-atstart=no`
// (the program re-executes itself), each one between CALLGRIND_TOGGLE_COLLECT requests after a
// warm-up and dumped with CALLGRIND_DUMP_STATS_AT; the dumps give instructions per call, which
// a loaded machine does not change. --only keeps the robots whose label contains TEXT.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <regex>
#include <sstream>
#include <string>

#include "se3_sim/dynamics/dynamics.h"
#include "se3_sim/integrate/integrate.h"
#include "se3_sim/sim/sim.h"

#ifdef SE3_SIM_HAVE_CALLGRIND
#include <valgrind/callgrind.h>
#endif
#ifdef SE3_SIM_HAVE_MUJOCO
#include "mujoco_peer.h"
#endif
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

#include "../test/source_paths.h"
#endif

using namespace se3;
using Clock = std::chrono::steady_clock;

namespace {

double g_seconds = 0.4;
double g_sink = 0;
bool g_cg_child = false;  ///< running under callgrind: count instructions, do not time
int g_reps = 4;           ///< batches of the states counted under callgrind
int g_rounds = 1;         ///< timing rounds: the smallest median of each is kept
constexpr double kDt = 1e-3;

enum Algo { kRnea, kFd, kCrba, kMinv, kEuler, kRk4, kAlgos };
const char* kAlgoName[kAlgos] = {"RNEA", "FD (ABA)", "M (CRBA)", "M^-1", "step Euler", "step RK4"};
enum Engine { kOurs, kMujoco, kDart, kKdl, kEngines };
const char* kEngineName[kEngines] = {"ours", "MuJoCo", "DART", "KDL"};

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

/// Times f, or (callgrind child) counts its instructions into a dump named `key|calls`.
double measure(const std::string& key, int count, const std::function<void(int)>& f) {
  if (!g_cg_child) return median_ns(count, f);
  for (int r = 0; r < 2; ++r) {
    for (int k = 0; k < count; ++k) f(k);
  }
#ifdef SE3_SIM_HAVE_CALLGRIND
  CALLGRIND_ZERO_STATS;
  CALLGRIND_TOGGLE_COLLECT;
  for (int r = 0; r < g_reps; ++r) {
    for (int k = 0; k < count; ++k) f(k);
  }
  CALLGRIND_TOGGLE_COLLECT;
  const std::string label = key + "|" + std::to_string(g_reps * count);
  CALLGRIND_DUMP_STATS_AT(label.c_str());
#else
  (void)key;
#endif
  return NAN;
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

/// The semi-implicit Euler step under its registry name (renamed from symplectic_euler).
std::string semi_implicit_name() {
  for (const auto& n : stepper_names()) {
    if (n == "semi_implicit_euler") return n;
  }
  return "symplectic_euler";
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
  int bodies = 0, nv = 0, mj_bodies = -1, mj_nv = -1;
  std::string mj_note;
  double ns[kEngines][kAlgos], ir[kEngines][kAlgos], err[kEngines][kAlgos];
  double mj_forward_ns = NAN, mj_forward_ir = NAN, mj_fullm_ns = NAN, mj_fullm_ir = NAN;
  Row() {
    for (int e = 0; e < kEngines; ++e) {
      for (int a = 0; a < kAlgos; ++a) ns[e][a] = ir[e][a] = err[e][a] = NAN;
    }
  }
};

std::string key(const Case& c, int engine, int algo) {
  return c.label + "|" + kEngineName[engine] + "|" + std::to_string(algo);
}

/// Difference of two states after one step, relative to the step's own change of the state.
double step_rel(const State& a, const State& b, const State& x0) {
  const double base = log_se3(b.base.inverse_times(a.base)).cwiseAbs().maxCoeff();
  const double dq = a.q.size() ? (a.q - b.q).cwiseAbs().maxCoeff() : 0.0;
  const double dv = (a.v - b.v).cwiseAbs().maxCoeff();
  double change = (b.v - x0.v).cwiseAbs().maxCoeff();
  if (b.q.size()) change = std::max(change, (b.q - x0.q).cwiseAbs().maxCoeff());
  change = std::max(change, log_se3(x0.base.inverse_times(b.base)).cwiseAbs().maxCoeff());
  return std::max({base, dq, dv}) / std::max(change, 1e-300);
}

Row run(const Case& c) {
  Row row;
  row.label = c.label;
  UrdfOptions opt;
  opt.floating = c.floating;
  opt.locked = c.locked;
  const Model m = model_from_urdf_string(c.urdf_text, opt);
  row.nv = m.nv;
  row.bodies = c.floating ? m.n + 1 : m.n;
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
  std::vector<State> x(N, State(m));
  for (int k = 0; k < N; ++k) {
    x[k].base = base[k];
    x[k].q = q[k];
    x[k].v = v[k];
  }
  auto ours = [&](int algo, const std::function<void(int)>& f) {
    row.ns[kOurs][algo] = measure(key(c, kOurs, algo), N, f);
  };
  ours(kRnea, [&](int k) { g_sink += rnea(m, d, base[k], q[k], v[k], a[k])[0]; });
  ours(kFd, [&](int k) { g_sink += aba(m, d, base[k], q[k], v[k], tau[k])[0]; });
  ours(kCrba, [&](int k) { g_sink += crba(m, d, base[k], q[k])(0, 0); });
  ours(kMinv, [&](int k) { g_sink += minv(m, d, base[k], q[k])(0, 0); });
  StepperOptions sopt;
  sopt.passive_forces = false;
  const VecX zero = VecX::Zero(m.nv);
  std::vector<State> stepped(2, State(m));  // ours after one step from x[0]: Euler, RK4
  for (int s = 0; s < 2; ++s) {
    auto st = make_stepper(s == 0 ? semi_implicit_name() : "rkmk4", m, sopt);
    State w(m);
    ours(s == 0 ? kEuler : kRk4, [&](int k) {
      w.base = x[k].base;
      w.q = x[k].q;
      w.v = x[k].v;
      st->step(w, zero, kDt);
      g_sink += w.v[0];
    });
    stepped[s] = x[0];
    st->step(stepped[s], zero, kDt);
  }

#ifdef SE3_SIM_HAVE_MUJOCO
  try {
    peers::MujocoRobot R(m, c.urdf_text, opt);
    mjModel* mm = R.m();
    mjData* md = R.d();
    row.mj_bodies = R.bodies();
    row.mj_nv = R.dofs();
    row.mj_note = R.summary();
    const int nq = mm->nq, nv = mm->nv;
    std::vector<std::vector<mjtNum>> qpos(N), qvel(N), qacc(N), qfrc(N);
    for (int k = 0; k < N; ++k) {
      R.set_state(x[k]);
      qpos[k].assign(md->qpos, md->qpos + nq);
      qvel[k].assign(md->qvel, md->qvel + nv);
      qacc[k].resize(nv);
      qfrc[k].resize(nv);
      R.accel_to_mj(x[k], a[k], qacc[k].data());
      R.force_to_mj(x[k], tau[k], qfrc[k].data());
    }
    std::vector<mjtNum> res(nv), rhs(nv), Minv(nv * nv), eye(nv * nv, 0.0), Mfull(nv * nv);
    for (int k = 0; k < nv; ++k) eye[k * nv + k] = 1;
    auto set = [&](int k) {
      mju_copy(md->qpos, qpos[k].data(), nq);
      mju_copy(md->qvel, qvel[k].data(), nv);
    };
    auto mj = [&](int algo, const std::function<void(int)>& f) {
      row.ns[kMujoco][algo] = measure(key(c, kMujoco, algo), N, f);
    };
    auto rne = [&](int k) {
      set(k);
      mju_copy(md->qacc, qacc[k].data(), nv);
      mj_kinematics(mm, md);
      mj_comPos(mm, md);
      mj_comVel(mm, md);
      mj_rne(mm, md, 1, res.data());
    };
    auto fd = [&](int k) {
      set(k);
      mj_kinematics(mm, md);
      mj_comPos(mm, md);
      mj_crb(mm, md);
      mj_factorM(mm, md);
      mj_comVel(mm, md);
      mj_rne(mm, md, 0, md->qfrc_bias);
      mju_sub(rhs.data(), qfrc[k].data(), md->qfrc_bias, nv);
      mj_solveM(mm, md, md->qacc, rhs.data(), 1);
    };
    auto crb = [&](int k) {
      mju_copy(md->qpos, qpos[k].data(), nq);
      mj_kinematics(mm, md);
      mj_comPos(mm, md);
      mj_crb(mm, md);
    };
    auto inv = [&](int k) {
      crb(k);
      mj_factorM(mm, md);
      mj_solveM(mm, md, Minv.data(), eye.data(), nv);
    };
    mj(kRnea, [&](int k) {
      rne(k);
      g_sink += res[0];
    });
    mj(kFd, [&](int k) {
      fd(k);
      g_sink += md->qacc[0];
    });
    mj(kCrba, [&](int k) {
      crb(k);
      g_sink += md->qM[0];
    });
    mj(kMinv, [&](int k) {
      inv(k);
      g_sink += Minv[0];
    });
    mm->opt.timestep = kDt;
    for (int s = 0; s < 2; ++s) {
      mm->opt.integrator = s == 0 ? mjINT_EULER : mjINT_RK4;
      mj(s == 0 ? kEuler : kRk4, [&](int k) {
        set(k);
        md->time = 0;
        mj_step(mm, md);
        g_sink += md->qvel[0];
      });
    }
    // MuJoCo's full pipeline, and the dense mass matrix: printed below the table.
    const double fwd = measure(c.label + "|MuJoCo|mj_forward", N, [&](int k) {
      set(k);
      mju_copy(md->qfrc_applied, qfrc[k].data(), nv);
      mj_forward(mm, md);
      g_sink += md->qacc[0];
    });
    const double full = measure(c.label + "|MuJoCo|crb+fullM", N, [&](int k) {
      crb(k);
      mj_fullM(mm, Mfull.data(), md->qM);
      g_sink += Mfull[0];
    });
    row.mj_forward_ns = fwd;
    row.mj_fullm_ns = full;
    mju_zero(md->qfrc_applied, nv);

    // The answers at state 0.
    R.set_state(x[0]);
    rne(0);
    VecX t;
    R.force_from_mj(x[0], res.data(), t);
    row.err[kMujoco][kRnea] = rel(t, rnea(m, d, base[0], q[0], v[0], a[0]));
    fd(0);
    VecX acc;
    R.accel_from_mj(x[0], md->qacc, acc);
    row.err[kMujoco][kFd] = rel(acc, aba(m, d, base[0], q[0], v[0], tau[0]));
    crb(0);
    mj_fullM(mm, Mfull.data(), md->qM);
    row.err[kMujoco][kCrba] = rel(R.mass_from_mj(x[0], Mfull.data()), crba(m, d, base[0], q[0]));
    inv(0);
    row.err[kMujoco][kMinv] = rel(R.minv_from_mj(x[0], Minv.data()), minv(m, d, base[0], q[0]));
    for (int s = 0; s < 2; ++s) {
      mm->opt.integrator = s == 0 ? mjINT_EULER : mjINT_RK4;
      set(0);
      md->time = 0;
      mj_step(mm, md);
      State y = x[0];
      R.get_state(y);
      row.err[kMujoco][s == 0 ? kEuler : kRk4] = step_rel(y, stepped[s], x[0]);
    }
  } catch (const std::exception& e) {
    row.mj_note = std::string("MuJoCo: ") + e.what();
  }
#endif

#ifdef SE3_SIM_HAVE_DART
  {
    const std::string path = "/tmp/se3_sim_bench_peers_" + std::to_string(getpid()) + ".urdf";
    {
      static const std::regex geom(R"(<(visual|collision)\b[\s\S]*?</\1\s*>)");
      std::ofstream(path) << std::regex_replace(c.urdf_text, geom, "");
    }
    using dart::utils::DartLoader;
    // Links without <inertial> are massless in URDF; DART's default would give them mass 1.
    DartLoader::Options dopt(
        nullptr,
        c.floating ? DartLoader::RootJointType::FLOATING : DartLoader::RootJointType::FIXED,
        dart::dynamics::Inertia(0.0, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Zero()));
    DartLoader loader(dopt);
    auto skel = loader.parseSkeleton(dart::common::Uri::createFromPath(path));
    std::remove(path.c_str());
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
      auto dart = [&](int algo, const std::function<void(int)>& f) {
        row.ns[kDart][algo] = measure(key(c, kDart, algo), N, f);
      };
      dart(kRnea, [&](int k) {
        set(k);
        skel->setAccelerations(da[k]);
        skel->computeInverseDynamics();
        g_sink += skel->getForce(0);
      });
      dart(kFd, [&](int k) {
        set(k);
        skel->setForces(dt[k]);
        skel->computeForwardDynamics();
        g_sink += skel->getAcceleration(0);
      });
      dart(kCrba, [&](int k) {
        skel->setPositions(dq[k]);
        g_sink += skel->getMassMatrix()(0, 0);
      });
      dart(kMinv, [&](int k) {
        skel->setPositions(dq[k]);
        g_sink += skel->getInvMassMatrix()(0, 0);
      });
      // Same answers (state 0).
      auto pick = [&](const Eigen::VectorXd& y) {
        VecX z(m.nv);
        for (int j = 0; j < m.nv; ++j) z[j] = y[map[j]];
        return z;
      };
      auto pick_mat = [&](const Eigen::MatrixXd& Y) {
        MatX Z(m.nv, m.nv);
        for (int r = 0; r < m.nv; ++r) {
          for (int cc = 0; cc < m.nv; ++cc) Z(r, cc) = Y(map[r], map[cc]);
        }
        return Z;
      };
      set(0);
      skel->setAccelerations(da[0]);
      skel->computeInverseDynamics();
      row.err[kDart][kRnea] = rel(pick(skel->getForces()), rnea(m, d, base[0], q[0], v[0], a[0]));
      set(0);
      skel->setForces(dt[0]);
      skel->computeForwardDynamics();
      row.err[kDart][kCrba] = rel(pick_mat(skel->getMassMatrix()), crba(m, d, base[0], q[0]));
      // With locked joints DART's forward dynamics moves them: no like-for-like comparison.
      if (c.locked.empty()) {
        row.err[kDart][kFd] =
            rel(pick(skel->getAccelerations()), aba(m, d, base[0], q[0], v[0], tau[0]));
        row.err[kDart][kMinv] = rel(pick_mat(skel->getInvMassMatrix()), minv(m, d, base[0], q[0]));
      }
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
      row.ns[kKdl][kRnea] = measure(key(c, kKdl, kRnea), N, [&](int k) {
        for (int i = 0; i < n; ++i) {
          jq(i) = q[k][i];
          jv(i) = v[k][i];
          ja(i) = a[k][i];
        }
        id.CartToJnt(jq, jv, ja, wr, jt);
        g_sink += jt(0);
      });
      row.ns[kKdl][kCrba] = measure(key(c, kKdl, kCrba), N, [&](int k) {
        for (int i = 0; i < n; ++i) jq(i) = q[k][i];
        dyn.JntToMass(jq, H);
        g_sink += H(0, 0);
      });
      if (c.kdl_whole) {
        for (int i = 0; i < n; ++i) {
          jq(i) = q[0][i];
          jv(i) = v[0][i];
          ja(i) = a[0][i];
        }
        id.CartToJnt(jq, jv, ja, wr, jt);
        row.err[kKdl][kRnea] = rel(jt.data, rnea(m, d, base[0], q[0], v[0], a[0]));
        dyn.JntToMass(jq, H);
        row.err[kKdl][kCrba] = rel(H.data, crba(m, d, base[0], q[0]));
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

std::string fmt_ir(double x) {
  if (std::isnan(x)) return "—";
  char b[32];
  std::snprintf(b, sizeof b, x >= 1e6 ? "%.3g" : "%.0f", x);
  return b;
}

std::string fmt_e(double x) {
  if (std::isnan(x)) return "—";
  char b[32];
  std::snprintf(b, sizeof b, "%.0e", x);
  return b;
}

std::string ratio(double peer, double ours) {
  if (std::isnan(peer) || std::isnan(ours)) return "—";
  char b[32];
  std::snprintf(b, sizeof b, "%.2f×", peer / ours);
  return b;
}

/// Instructions per call from the callgrind dumps in dir (key -> Ir / call).
std::map<std::string, double> read_dumps(const std::string& dir) {
  std::map<std::string, double> out;
  for (int n = 1;; ++n) {
    std::ifstream f(dir + "/cg.out." + std::to_string(n));
    if (!f) break;
    std::string line, label;
    double total = NAN;
    while (std::getline(f, line)) {
      const std::string trig = "desc: Trigger: Client Request: ";
      if (line.compare(0, trig.size(), trig) == 0) label = line.substr(trig.size());
      if (line.compare(0, 8, "summary:") == 0) total = std::atof(line.c_str() + 8);
    }
    const std::size_t bar = label.rfind('|');
    if (bar == std::string::npos || std::isnan(total)) continue;
    const double calls = std::atof(label.c_str() + bar + 1);
    if (calls > 0) out[label.substr(0, bar)] = total / calls;
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::string dir = se3_sim_test::source_dir() + "/data/robots", only;
  bool callgrind = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has = i + 1 < argc;
    if (a == "--seconds" && has) {
      g_seconds = std::atof(argv[++i]);
    } else if (a == "--robots" && has) {
      dir = argv[++i];
    } else if (a == "--only" && has) {
      only = argv[++i];
    } else if (a == "--rounds" && has) {
      g_rounds = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--reps" && has) {
      g_reps = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--callgrind") {
      callgrind = true;
    } else if (a == "--cg-child") {
      g_cg_child = true;
    } else {
      std::fprintf(stderr,
                   "usage: bench_peers [--seconds S] [--rounds N] [--robots DIR] [--only TEXT] "
                   "[--callgrind] [--reps R]\n");
      return 2;
    }
  }
  const std::vector<std::pair<std::string, double>> fingers = {{"panda_finger_joint1", 0},
                                                               {"panda_finger_joint2", 0}};
  std::vector<Case> all = {
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
      {"20-link chain", model_to_urdf(make_chain(20, false)), false, {}, "base", "link20"},
      {"20-link chain (free base)", model_to_urdf(make_chain(20, true)), true, {}, "", ""},
      {"200-link chain", model_to_urdf(make_chain(200, false)), false, {}, "base", "link200"},
  };
  std::vector<Case> cases;
  for (const Case& c : all) {
    if (only.empty() || c.label.find(only) != std::string::npos) cases.push_back(c);
  }

  std::vector<Row> rows;
  for (const Case& c : cases) {
    if (!g_cg_child) std::fprintf(stderr, "bench_peers: %s\n", c.label.c_str());
    Row row = run(c);
    // Later rounds: the smallest median of each measurement (a load burst only slows one).
    for (int k = 1; k < (g_cg_child ? 1 : g_rounds); ++k) {
      const Row again = run(c);
      for (int e = 0; e < kEngines; ++e) {
        for (int a = 0; a < kAlgos; ++a) row.ns[e][a] = std::fmin(row.ns[e][a], again.ns[e][a]);
      }
      row.mj_forward_ns = std::fmin(row.mj_forward_ns, again.mj_forward_ns);
      row.mj_fullm_ns = std::fmin(row.mj_fullm_ns, again.mj_fullm_ns);
    }
    rows.push_back(row);
  }
  if (g_cg_child) {
    if (g_sink == 0.5) std::printf(" ");
    return 0;
  }

  // Instructions: the same measurements again, under callgrind.
  std::map<std::string, double> ir;
  if (callgrind) {
#ifdef SE3_SIM_HAVE_CALLGRIND
    char tmpl[] = "/tmp/se3_sim_cg_XXXXXX";
    const std::string cgdir = mkdtemp(tmpl) ? tmpl : "/tmp";
    std::fprintf(stderr, "bench_peers: counting instructions under callgrind (%s)\n",
                 cgdir.c_str());
    const pid_t pid = fork();
    if (pid == 0) {
      const std::string out = "--callgrind-out-file=" + cgdir + "/cg.out";
      const std::string reps = std::to_string(g_reps);
      std::vector<const char*> args = {"valgrind",
                                       "--tool=callgrind",
                                       "--collect-atstart=no",
                                       out.c_str(),
                                       "-q",
                                       argv[0],
                                       "--cg-child",
                                       "--robots",
                                       dir.c_str(),
                                       "--reps",
                                       reps.c_str()};
      if (!only.empty()) {
        args.push_back("--only");
        args.push_back(only.c_str());
      }
      args.push_back(nullptr);
      execvp("valgrind", const_cast<char* const*>(args.data()));
      std::perror("bench_peers: valgrind");
      _exit(127);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
      std::fprintf(stderr, "bench_peers: the callgrind run failed (status %d)\n", status);
    }
    ir = read_dumps(cgdir);
    for (int n = 0;; ++n) {
      const std::string f = cgdir + "/cg.out" + (n ? "." + std::to_string(n) : "");
      if (std::remove(f.c_str()) != 0) break;
    }
    rmdir(cgdir.c_str());
#else
    std::fprintf(stderr,
                 "bench_peers: built without valgrind/callgrind.h: no instruction counts\n");
#endif
  }
  for (std::size_t r = 0; r < rows.size(); ++r) {
    for (int e = 0; e < kEngines; ++e) {
      for (int a = 0; a < kAlgos; ++a) {
        const auto it = ir.find(key(cases[r], e, a));
        if (it != ir.end()) rows[r].ir[e][a] = it->second;
      }
    }
    auto get = [&](const std::string& k) {
      const auto it = ir.find(cases[r].label + "|MuJoCo|" + k);
      return it == ir.end() ? NAN : it->second;
    };
    rows[r].mj_forward_ir = get("mj_forward");
    rows[r].mj_fullm_ir = get("crb+fullM");
  }

  std::printf(
      "| robot | bodies / nv (MuJoCo's) | algorithm | ours ns / Ir | MuJoCo ns / Ir | DART ns / Ir "
      "| KDL ns / Ir | MuJoCo/ours by ns / Ir | DART/ours | KDL/ours | max rel. diff MuJoCo / "
      "DART / KDL |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
  struct Short {
    std::string what;
    double by_ns, by_ir, goal;
  };
  std::vector<Short> below;
  auto both = [](double ns, double ir) {
    if (std::isnan(ns)) return std::string("—");
    return std::isnan(ir) ? fmt(ns) : fmt(ns) + " / " + fmt_ir(ir);
  };
  auto ratios = [](double pn, double on, double pi, double oi) {
    if (std::isnan(pn)) return std::string("—");
    return std::isnan(pi) ? ratio(pn, on) : ratio(pn, on) + " / " + ratio(pi, oi);
  };
  for (const Row& r : rows) {
    for (int a = 0; a < kAlgos; ++a) {
      char counts[64] = "";
      if (a == 0) {
        if (r.mj_bodies >= 0) {
          std::snprintf(counts, sizeof counts, "%d / %d (%d / %d)", r.bodies, r.nv, r.mj_bodies,
                        r.mj_nv);
        } else {
          std::snprintf(counts, sizeof counts, "%d / %d (—)", r.bodies, r.nv);
        }
      }
      std::string cells;
      for (int e = 0; e < kEngines; ++e) cells += " | " + both(r.ns[e][a], r.ir[e][a]);
      for (int e = 1; e < kEngines; ++e) {
        cells += " | " + ratios(r.ns[e][a], r.ns[kOurs][a], r.ir[e][a], r.ir[kOurs][a]);
      }
      std::printf("| %s | %s | %s%s | %s / %s / %s |\n", a == 0 ? r.label.c_str() : "", counts,
                  kAlgoName[a], cells.c_str(), fmt_e(r.err[kMujoco][a]).c_str(),
                  fmt_e(r.err[kDart][a]).c_str(), fmt_e(r.err[kKdl][a]).c_str());
      const double goal = a >= kEuler ? 3.0 : 2.0;
      const double by_ns = r.ns[kMujoco][a] / r.ns[kOurs][a];
      const double by_ir = r.ir[kMujoco][a] / r.ir[kOurs][a];
      if (by_ns < goal || by_ir < goal) {
        below.push_back({r.label + ", " + kAlgoName[a], by_ns, by_ir, goal});
      }
    }
    std::fflush(stdout);
  }
  std::printf(
      "\nSteps: dt = 1 ms, ours %s / rkmk4 against mj_step (mjINT_EULER / mjINT_RK4); their "
      "difference is that of the states after one step relative to the step's change of the "
      "state. MuJoCo's FD is its fastest route (CRB, LTDL factor, RNE bias, solve); M is its "
      "sparse qM (no mj_fullM); M^-1 is mj_factorM + mj_solveM on the identity.\n\n",
      semi_implicit_name().c_str());
  for (const Row& r : rows) {
    std::printf("- %s: %s; mj_forward %s ns%s%s, mj_crb + mj_fullM %s ns%s%s\n", r.label.c_str(),
                r.mj_note.c_str(), fmt(r.mj_forward_ns).c_str(),
                std::isnan(r.mj_forward_ir) ? "" : " / ",
                std::isnan(r.mj_forward_ir) ? "" : (fmt_ir(r.mj_forward_ir) + " Ir").c_str(),
                fmt(r.mj_fullm_ns).c_str(), std::isnan(r.mj_fullm_ir) ? "" : " / ",
                std::isnan(r.mj_fullm_ir) ? "" : (fmt_ir(r.mj_fullm_ir) + " Ir").c_str());
  }
  std::printf("\nBelow the goal (MuJoCo/ours by time, by instructions; goal):\n");
  if (below.empty()) std::printf("- none\n");
  for (const Short& s : below) {
    std::printf("- %s: %.2f× / %.2f× (goal %.0f×)\n", s.what.c_str(), s.by_ns, s.by_ir, s.goal);
  }
  if (g_sink == 0.5) std::printf(" ");
  return 0;
}
