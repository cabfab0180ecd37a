// The peers in the charts (peers_charts.h).
#include "peers_charts.h"

#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <iostream>
#include <random>
#include <sstream>

#include "engines.h"
#include "se3_sim/integrate/integrate.h"
#include "se3_sim/sim/sim.h"

#ifdef SE3_SIM_HAVE_DART
#include "dart_peer.h"
#endif

namespace se3::charts {
namespace {

double cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

double base_error(const State& a, const State& ref) {
  return log_se3(ref.base.inverse_times(a.base)).norm();
}
double joint_error(const State& a, const State& ref) {
  return a.q.size() ? (a.q - ref.q).norm() : 0.0;
}

/// The semi-implicit Euler step under its registry name (renamed from symplectic_euler).
std::string semi_implicit_name() {
  for (const auto& n : stepper_names()) {
    if (n == "semi_implicit_euler") return n;
  }
  return "symplectic_euler";
}

/// A run of an engine: final state, CPU time of the steps only, the conserved quantities'
/// largest errors at the samples, and whether (and when) it failed.
struct Run {
  State x;
  bool ok = true;
  double t_fail = NAN;
  double cpu = 0;
  long evals = 0, steps = 0;
  double energy = 0, momentum = 0;  ///< max |E - E0| / scale, max |L - L0| / |L0|
};

/// Observer of a run: called at `samples` evenly spaced times (outside the timed part).
using Sample = std::function<void(double t, const State& x)>;

Run run_engine(peers::Engine& e, const Model& m, const State& x0, double h, double T,
               int samples = 0, const Sample& at = {}, bool repeat = true) {
  Run r;
  const long n = std::lround(T / h);
  double total = 0;
  int reps = 0;
  do {
    e.set_state(x0);
    State x = x0;
    long evals = 0;
    bool ok = true;
    long k = 0;
    double t_fail = NAN;
    const long chunk = samples > 0 ? std::max(1L, n / samples) : n;
    double cpu = 0;
    while (k < n && ok) {
      const long end = std::min(n, k + chunk);
      const double c0 = cpu_seconds();
      for (; k < end; ++k) {
        if (!e.step(h)) {
          ok = false;
          t_fail = (k + 1) * h;
          ++k;
          break;
        }
        evals += e.evaluations();
      }
      cpu += cpu_seconds() - c0;
      e.get_state(x);
      if (ok && !(x.finite() && x.v.cwiseAbs().maxCoeff() < 1e6)) {
        ok = false;
        t_fail = k * h;
      }
      if (ok && at) at(k * h, x);
    }
    total += cpu;
    ++reps;
    r.x = x;
    r.ok = ok;
    r.t_fail = t_fail;
    r.evals = evals;
    r.steps = k;
    if (!ok || !repeat || samples > 0) break;
  } while (total < 0.02 && reps < 50);
  r.cpu = total / reps;
  (void)m;
  return r;
}

std::string read_file_text(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

/// A planar chain of n links along x, hinge axes all along y, fixed at its first joint: link
/// length L, mass 1 kg (a slender box 0.04 m wide), centre at mid-length.
std::string planar_chain_urdf(int n, double L) {
  std::ostringstream o;
  o.precision(17);
  o << "<robot name='planar_chain" << n << "'>\n<link name='base'/>\n";
  const double m = 1.0, w = 0.04;
  const double Ia = m * (w * w + w * w) / 12, Ib = m * (L * L + w * w) / 12;
  for (int i = 1; i <= n; ++i) {
    o << "<link name='link" << i << "'><inertial><origin xyz='" << L / 2 << " 0 0'/><mass value='"
      << m << "'/><inertia ixx='" << Ia << "' iyy='" << Ib << "' izz='" << Ib
      << "' ixy='0' ixz='0' iyz='0'/></inertial></link>\n"
      << "<joint name='joint" << i << "' type='continuous'><parent link='"
      << (i == 1 ? std::string("base") : "link" + std::to_string(i - 1)) << "'/><child link='link"
      << i << "'/><origin xyz='" << (i == 1 ? 0.0 : L) << " 0 0'/><axis xyz='0 1 0'/></joint>\n";
  }
  o << "</robot>\n";
  return o.str();
}

}  // namespace

// ------------------------------------------------------------------ work-precision

void peer_work_precision(const Model& m, const State& x0, const State& ref, double T,
                         const std::vector<double>& dts, bool damped, std::ofstream& f,
                         bool limits) {
  for (const std::string& name : peers::peer_engine_names()) {
    if (name == "mujoco_implicit" && !damped) continue;
    std::unique_ptr<peers::Engine> e;
    try {
      e = peers::make_engine(name, m, true, 1e-6, limits);
    } catch (const std::exception& ex) {
      std::printf("  %-17s skipped: %s\n", name.c_str(), ex.what());
      continue;
    }
    double best = INFINITY, best_dt = NAN;
    std::vector<double> hs, es;
    for (double dt : dts) {
      const Run r = run_engine(*e, m, x0, dt, T);
      if (!r.ok) {
        f << name << "," << dt << ",,nan,nan,nan," << r.cpu << "," << r.evals << "," << r.steps
          << "\n";
        continue;
      }
      const double eb = base_error(r.x, ref), ej = joint_error(r.x, ref);
      f << name << "," << dt << ",," << eb << "," << ej << "," << eb + ej << "," << r.cpu << ","
        << r.evals << "," << r.steps << "\n";
      if (eb + ej < best) best = eb + ej, best_dt = dt;
      if (eb + ej < 0.5 && eb + ej > 1e-10) hs.push_back(dt), es.push_back(eb + ej);
    }
    // Fitted order over the four smallest steps, as for ours.
    std::vector<std::pair<double, double>> pts;
    for (std::size_t k = 0; k < hs.size(); ++k) pts.push_back({hs[k], es[k]});
    std::sort(pts.begin(), pts.end());
    if (pts.size() > 4) pts.resize(4);
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (const auto& p : pts) {
      const double lx = std::log(p.first), ly = std::log(p.second);
      sx += lx, sy += ly, sxx += lx * lx, sxy += lx * ly;
    }
    const double n = static_cast<double>(pts.size());
    const double order = pts.size() >= 2 ? (n * sxy - sx * sy) / (n * sxx - sx * sx) : NAN;
    std::printf("  %-24s fitted order %5.2f (%zu points); smallest error %.3g (dt %g)\n",
                peers::engine_label(name).c_str(), order, pts.size(), best, best_dt);
  }
}

// ------------------------------------------------------------------ the study

void study(const std::string& outdir, const std::string& root, bool quick) {
  std::cout << "== study (Erez, Tassa, Todorov 2015): speed against consistency, energy and "
               "angular momentum\n";
  std::ofstream f(outdir + "/study.csv");
  f << "model,engine,dt,rtf,consistency,energy_err,momentum_err,evals,ok\n";
  f.precision(6);
  struct StudyModel {
    std::string name;
    Model m;
    State x0;
    bool momentum;  ///< free-floating in zero gravity: angular momentum is conserved
    double T;       ///< simulated time
  };
  std::vector<StudyModel> models;
  {
    UrdfOptions opt;
    Model m = model_from_urdf_string(planar_chain_urdf(20, 0.1), opt);
    m.gravity = Vec3(0, 0, -9.81);
    State x0(m);
    std::mt19937 gen(3);
    std::uniform_real_distribution<double> u(-1, 1);
    // Released from rest near horizontal (x along the chain), each joint bent by up to 0.2 rad:
    // it falls and whips; half a second holds the first swing.
    for (int i = 1; i < m.n; ++i) x0.q[i] = 0.2 * u(gen);
    models.push_back({"planar_chain20", m, x0, false, quick ? 0.25 : 0.5});
  }
  {
    UrdfOptions opt;
    opt.floating = true;
    Model m = model_from_urdf_file(root + "/data/robots/romeo_small.urdf", opt);
    m.gravity.setZero();
    const State x0 = random_state(m, 1);
    models.push_back({"romeo_free", m, x0, true, quick ? 0.25 : 1.0});
  }
  std::vector<double> dts = {1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4};
  if (quick) dts = {5e-3, 1e-3, 2e-4};
  const double dt_ref = dts.back() / 16;
  std::vector<std::string> engines = {semi_implicit_name(), "rkmk4", "variational"};
  for (const auto& n : peers::peer_engine_names()) engines.push_back(n);

  for (const StudyModel& sm : models) {
    const Model& m = sm.m;
    const double T = sm.T;
    Data d(m);
    const double E0 = kinetic_energy(m, d, sm.x0.base, sm.x0.q, sm.x0.v) +
                      potential_energy(m, d, sm.x0.base, sm.x0.q);
    // Energy scale: T(0), or released from rest m |g| times the reach (sum of joint offsets).
    double reach = 0;
    for (int i = 1; i <= m.n; ++i) reach += m.X_tree[i].p.norm();
    const double T0 = kinetic_energy(m, d, sm.x0.base, sm.x0.q, sm.x0.v);
    const double scale = T0 > 0 ? T0 : m.total_mass() * m.gravity.norm() * reach;
    const Vec3 L0 = spatial_momentum(m, d, sm.x0.base, sm.x0.q, sm.x0.v).head<3>();
    std::printf(
        "  %s: nv %d, T = %g s, energy scale %.3g J, %s; consistency against the same "
        "engine at dt = %g\n",
        sm.name.c_str(), m.nv, T, scale,
        sm.momentum ? ("zero gravity, |L0| = " + std::to_string(L0.norm()) + " N m s").c_str()
                    : "gravity",
        dt_ref);
    for (const std::string& name : engines) {
      std::unique_ptr<peers::Engine> e;
      try {
        e = peers::make_engine(name, m, false);
      } catch (const std::exception& ex) {
        std::printf("    %-24s skipped: %s\n", name.c_str(), ex.what());
        continue;
      }
      const Run ref = run_engine(*e, m, sm.x0, dt_ref, T, 0, {}, false);
      for (double dt : dts) {
        double emax = 0, lmax = 0;
        const Run r = run_engine(*e, m, sm.x0, dt, T, 100, [&](double, const State& x) {
          const double E =
              kinetic_energy(m, d, x.base, x.q, x.v) + potential_energy(m, d, x.base, x.q);
          emax = std::max(emax, std::abs(E - E0) / scale);
          if (sm.momentum) {
            const Vec3 L = spatial_momentum(m, d, x.base, x.q, x.v).head<3>();
            lmax = std::max(lmax, (L - L0).norm() / L0.norm());
          }
        });
        const double rtf = r.cpu > 0 ? T / r.cpu : NAN;
        const double cons = r.ok && ref.ok ? base_error(r.x, ref.x) + joint_error(r.x, ref.x) : NAN;
        f << sm.name << "," << name << "," << dt << "," << rtf << "," << cons << ","
          << (r.ok ? emax : NAN) << "," << (r.ok && sm.momentum ? lmax : NAN) << "," << r.evals
          << "," << (r.ok ? 1 : 0) << "\n";
        char mom[48] = "";
        if (sm.momentum) std::snprintf(mom, sizeof mom, "  ang. momentum %9.3g", lmax);
        std::printf("    %-24s dt %-6g rtf %8.3g  consistency %9.3g  energy %9.3g%s%s\n",
                    peers::engine_label(name).c_str(), dt, rtf, cons, r.ok ? emax : NAN, mom,
                    r.ok ? "" : "  [failed]");
      }
    }
  }
  // The study's contact scene (a pile, as in the paper) is bench_contact --study, which runs
  // MuJoCo's contact beside ours; scripts/charts.sh runs it after this program.
  std::printf("  contact scene: bench_contact --study (scripts/charts.sh runs it)\n");
}

// ------------------------------------------------------------------ stability

void stability(const std::string& outdir, const std::string& root, bool quick) {
  std::cout << "== stability: the undamped Panda at 1 kHz (fingers locked), released from its "
               "ready pose\n";
  const Scene scene = load_scene(root + "/config/scenes/fixed_panda.yaml");
  Model m = scene_model(scene);
  for (int i = 1; i <= m.n; ++i) m.damping[i] = m.friction[i] = 0;
  const State x0 = scene_state(scene, m);
  Data d(m);
  const double E0 =
      kinetic_energy(m, d, x0.base, x0.q, x0.v) + potential_energy(m, d, x0.base, x0.q);
  const double T = quick ? 20 : 60, h = 1e-3;
  std::ofstream f(outdir + "/stability_panda.csv");
  f << "engine,t,energy_err,failed_at\n";
  std::vector<std::string> engines = {semi_implicit_name(), "euler", "rkmk4", "variational"};
  for (const auto& n : peers::peer_engine_names()) engines.push_back(n);
  for (const std::string& name : engines) {
    std::unique_ptr<peers::Engine> e;
    try {
      e = peers::make_engine(name, m, false);
    } catch (const std::exception& ex) {
      std::printf("  %-24s skipped: %s\n", name.c_str(), ex.what());
      continue;
    }
    double emax = 0;
    std::vector<std::pair<double, double>> pts;
    const Run r =
        run_engine(*e, m, x0, h, T, static_cast<int>(T / 0.05), [&](double t, const State& x) {
          const double E =
              kinetic_energy(m, d, x.base, x.q, x.v) + potential_energy(m, d, x.base, x.q);
          emax = std::max(emax, std::abs(E - E0));
          pts.push_back({t, std::abs(E - E0)});
        });
    for (const auto& p : pts) f << name << "," << p.first << "," << p.second << ",\n";
    f << name << ",,," << (r.ok ? NAN : r.t_fail) << "\n";
    if (r.ok) {
      std::printf("  %-24s survives %g s: max |E - E0| = %.3g J\n",
                  peers::engine_label(name).c_str(), T, emax);
    } else {
      std::printf("  %-24s FAILS at t = %.3f s (max |E - E0| before: %.3g J)\n",
                  peers::engine_label(name).c_str(), r.t_fail, emax);
    }
  }

#ifdef SE3_SIM_HAVE_DART
  std::cout << "== stability: DART's inverse mass matrix against the inverse of its own mass "
               "matrix\n";
  std::ofstream g(outdir + "/stability_minv.csv");
  g << "robot,welded,dart_self,dart_mass_vs_ours,ours_self\n";
  struct Case {
    std::string label, file;
    bool floating;
  };
  const std::vector<Case> cases = {{"ur5", "ur5_robot.urdf", false},
                                   {"kuka_iiwa", "kuka_iiwa.urdf", false},
                                   {"panda", "panda.urdf", false},
                                   {"panda (free)", "panda.urdf", true},
                                   {"solo12 (free)", "solo12.urdf", true},
                                   {"hyq", "hyq_no_sensors.urdf", false},
                                   {"hyq (free)", "hyq_no_sensors.urdf", true},
                                   {"anymal_c (free)", "anymal_c.urdf", true},
                                   {"romeo_small (free)", "romeo_small.urdf", true}};
  for (const Case& c : cases) {
    const std::string text = read_file_text(root + "/data/robots/" + c.file);
    UrdfOptions opt;
    opt.floating = c.floating;
    const Model mm = model_from_urdf_string(text, opt);
    double self = 0, mass = 0, ours = 0;
    int welded = 0;
    for (unsigned seed = 1; seed <= 5; ++seed) {
      const peers::DartMinvCheck k = peers::dart_minv_check(mm, text, random_state(mm, seed));
      self = std::max(self, k.self);
      mass = std::max(mass, k.mass);
      ours = std::max(ours, k.ours);
      welded = k.welded;
    }
    g << c.label << "," << welded << "," << self << "," << mass << "," << ours << "\n";
    std::printf(
        "  %-20s bodies welded between moving joints %2d: DART M^-1 vs its M inverted "
        "%.2e (its M vs ours %.1e); ours %.1e\n",
        c.label.c_str(), welded, self, mass, ours);
  }
#endif
}

}  // namespace se3::charts
