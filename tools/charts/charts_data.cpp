// charts_data: the CSV data behind docs/charts/*.png (issue 6), printed summaries on stdout.
//
//   charts_data OUTDIR [--root PACKAGE_DIR] [--only work|limits|energy|dynamics|...] [--quick]
//
// work      wp_<scene>.csv: final-state error of every integrator against CPU time and dynamics
//           evaluations, for a torque-free axisymmetric body (closed-form solution), the
//           satellite arm (config/scenes/satellite_arm.yaml) and a 20-link chain under gravity.
//           The reference of the last two is rkmk4 at a tiny step, whose own convergence is
//           checked; the fitted order of every fixed-step method is printed.
// energy    energy_<scene>.csv: relative energy (and momentum) error against simulated time over
//           1e4 s of a double pendulum and of a free asymmetric rigid body.
// dynamics  dyn_scaling.csv: ABA, CRBA + Cholesky, D^-1 (minv) time and accuracy for chains of
//           1..500 bodies; dyn_mass_ratio.csv: accuracy when the link masses span up to 1e8.
//           Accuracy is measured against an ABA evaluated in long double.
// study     study.csv, stability: MuJoCo and DART beside ours (peers_charts.h); the work
//           charts also get the peers' integrators (issue 16).
#include <time.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "aba_long_double.h"
#include "engines.h"
#include "peers_charts.h"
#include "se3_sim/integrate/integrate.h"
#include "se3_sim/sim/sim.h"

using namespace se3;
using se3::reference::aba_long_double;
using se3::reference::VecXL;

namespace {

double cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

// ------------------------------------------------------------------ models and exact solution

/// A free rigid body with its frame at the centre of mass along principal axes (n = 0).
Model free_body(const Vec3& principal, double mass) {
  Model m;
  m.name = "free_body";
  m.floating = true;
  m.start_with_base("body", Inertia::from_com(mass, Vec3::Zero(), principal.asDiagonal()));
  m.links.push_back({"body", 0, SE3()});
  m.gravity.setZero();
  m.finalize();
  m.validate();
  return m;
}

/// Axisymmetric body (I1 = I2) under the model's gravity, its frame at the centre of mass: the
/// rotation is the torque-free one, R(t) = exp(t hat(L_s) / I1) R0 exp(t c hat(e3)),
/// c = (1/I3 - 1/I1) L3, and the centre moves on the parabola p0 + v0 t + g t^2 / 2.
State axisymmetric_exact(const Model& m, const State& x0, double t) {
  const Mat3& I = m.inertia[0].I;
  const double I1 = I(0, 0), I3 = I(2, 2);
  const Vec3 Lb = I * x0.v.head<3>();
  const Vec3 Ls = x0.base.R * Lb;
  const double c = (1.0 / I3 - 1.0 / I1) * Lb.z();
  State x = x0;
  x.base.R = exp_so3(Ls * (t / I1)) * x0.base.R * exp_so3(Vec3(0, 0, c * t));
  const Vec3 vs = x0.base.R * x0.v.tail<3>();
  x.base.p = x0.base.p + vs * t + 0.5 * t * t * m.gravity;
  const Vec3 Lbt = x.base.R.transpose() * Ls;
  x.v.head<3>() = Lbt / I1 + Vec3(0, 0, c);
  x.v.tail<3>() = x.base.R.transpose() * (vs + t * m.gravity);
  return x;
}

struct RunResult {
  State x;
  bool ok = true;
  double cpu = 0;
  long evals = 0;
  long steps = 0;
};

/// Runs integrator from x0 for T with outer step h (an adaptive stepper subdivides it).
/// CPU time is averaged over repeats until at least 20 ms have been measured.
RunResult run(const Model& m, const std::string& integrator, const State& x0, double h, double T,
              double tol = 1e-6, bool time_it = true) {
  RunResult r;
  StepperOptions opt;
  opt.tol = tol;
  opt.max_substeps = 10000000;
  const VecX zero = VecX::Zero(m.nv);
  const long n = std::lround(T / h);
  double total = 0;
  int reps = 0;
  do {
    auto st = make_stepper(integrator, m, opt);
    State x = x0;
    long evals = 0, steps = 0;
    bool ok = true;
    const double t0 = cpu_seconds();
    for (long k = 0; k < n && ok; ++k) {
      const StepInfo info = st->step(x, zero, h);
      evals += info.evaluations;
      steps += info.substeps;
      ok = info.ok && x.finite() && x.v.cwiseAbs().maxCoeff() < 1e8;
    }
    total += cpu_seconds() - t0;
    ++reps;
    r.x = x;
    r.ok = ok;
    r.evals = evals;
    r.steps = steps;
    if (!ok) break;
  } while (time_it && total < 0.02 && reps < 50);
  r.cpu = total / reps;
  return r;
}

double base_error(const State& a, const State& ref) {
  return log_se3(ref.base.inverse_times(a.base)).norm();
}
double joint_error(const State& a, const State& ref) {
  return a.q.size() ? (a.q - ref.q).norm() : 0.0;
}

/// Least-squares slope of log(y) against log(x).
double fit_slope(const std::vector<double>& x, const std::vector<double>& y) {
  const int n = static_cast<int>(x.size());
  if (n < 2) return std::nan("");
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (int i = 0; i < n; ++i) {
    const double lx = std::log(x[i]), ly = std::log(y[i]);
    sx += lx;
    sy += ly;
    sxx += lx * lx;
    sxy += lx * ly;
  }
  return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

// ------------------------------------------------------------------ work-precision

struct WpScene {
  std::string name;
  Model model;
  State x0;
  double T;
  std::vector<double> dts;
  std::vector<double> dts_first;  ///< smaller extra steps for the first-order methods
  bool exact = false;             ///< axisymmetric free body: closed-form reference
  double dt_ref = 0;
};

void work_precision(const WpScene& sc, const std::string& outdir) {
  std::cout << "== work-precision: " << sc.name << " (T = " << sc.T << " s, nv = " << sc.model.nv
            << ")\n";
  State ref;
  if (sc.exact) {
    ref = axisymmetric_exact(sc.model, sc.x0, sc.T);
    std::cout << "  reference: closed-form torque-free axisymmetric body\n";
  } else {
    // The reference and its own convergence check (rkmk4 at h, 2h, 4h).
    const RunResult r1 = run(sc.model, "rkmk4", sc.x0, sc.dt_ref, sc.T, 0, false);
    const RunResult r2 = run(sc.model, "rkmk4", sc.x0, 2 * sc.dt_ref, sc.T, 0, false);
    const RunResult r4 = run(sc.model, "rkmk4", sc.x0, 4 * sc.dt_ref, sc.T, 0, false);
    ref = r1.x;
    auto dist = [](const State& a, const State& b) { return base_error(a, b) + joint_error(a, b); };
    const double e42 = dist(r4.x, r2.x), e21 = dist(r2.x, r1.x);
    std::printf(
        "  reference: rkmk4 dt = %g; |x(4h)-x(2h)| = %.3g, |x(2h)-x(h)| = %.3g, observed order "
        "%.2f (theory 4), estimated reference error %.2g\n",
        sc.dt_ref, e42, e21, std::log2(e42 / e21), e21 / 15);
  }
  std::ofstream f(outdir + "/wp_" + sc.name + ".csv");
  f << "integrator,dt,tol,err_base,err_joint,err,cpu_s,evals,steps\n";
  f.precision(6);
  const std::vector<std::string> fixed = {"euler",       "symplectic_euler", "rkmk4",
                                          "variational", "rk4_euler_angles", "rk4_quaternion"};
  std::map<std::string, int> theory = {
      {"euler", 1},       {"symplectic_euler", 1}, {"rkmk4", 4},
      {"variational", 2}, {"rk4_euler_angles", 4}, {"rk4_quaternion", 4}};
  for (const auto& name : fixed) {
    std::vector<double> hs, es;
    std::vector<double> dts = sc.dts;
    if (name == "euler" || name == "symplectic_euler") {
      dts.insert(dts.end(), sc.dts_first.begin(), sc.dts_first.end());
    }
    for (double dt : dts) {
      const RunResult r = run(sc.model, name, sc.x0, dt, sc.T);
      if (!r.ok) {
        f << name << "," << dt << ",,nan,nan,nan," << r.cpu << "," << r.evals << "," << r.steps
          << "\n";
        continue;
      }
      const double eb = base_error(r.x, ref), ej = joint_error(r.x, ref);
      f << name << "," << dt << ",," << eb << "," << ej << "," << eb + ej << "," << r.cpu << ","
        << r.evals << "," << r.steps << "\n";
      // Fit in the asymptotic range (the smallest steps), above the reference's own error.
      if (eb + ej < 0.5 && eb + ej > 1e-10) {
        hs.push_back(dt);
        es.push_back(eb + ej);
      }
    }
    if (hs.size() > 4) {
      hs.erase(hs.begin(), hs.end() - 4);
      es.erase(es.begin(), es.end() - 4);
    }
    std::printf("  %-17s fitted order %5.2f (theory %d, %zu points)\n", name.c_str(),
                fit_slope(hs, es), theory[name], hs.size());
  }
  std::vector<double> tols = {1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11};
  std::vector<double> ev, es;
  for (double tol : tols) {
    const double H = sc.T / 20;
    const RunResult r = run(sc.model, "rkmk45", sc.x0, H, sc.T, tol);
    const double eb = base_error(r.x, ref), ej = joint_error(r.x, ref);
    f << "rkmk45," << H << "," << tol << "," << eb << "," << ej << "," << eb + ej << "," << r.cpu
      << "," << r.evals << "," << r.steps << "\n";
    if (eb + ej > 1e-10 && eb + ej < 1e-2) {
      ev.push_back(static_cast<double>(r.evals));
      es.push_back(eb + ej);
    }
  }
  std::printf("  %-17s error ~ evaluations^%.2f (theory -5)\n", "rkmk45", fit_slope(ev, es));
  // The peers' own integrators on the same scene (MuJoCo's implicit one where damping is on).
  std::vector<double> peer_dts = sc.dts;
  peer_dts.insert(peer_dts.end(), sc.dts_first.begin(), sc.dts_first.end());
  bool damped = false;
  for (int i = 1; i <= sc.model.n; ++i) damped |= sc.model.damping[i] > 0;
  charts::peer_work_precision(sc.model, sc.x0, ref, sc.T, peer_dts, damped, f);
}

/// wp_satellite_limits.csv: the satellite arm with its joint limits on (the scene's default),
/// driven into them, through the Simulator: the located impacts of rkmk4, rkmk45 and
/// variational, the velocity-level scheme, and MuJoCo with its own (soft) limits. Reference:
/// rkmk4 with located impacts at a small step, its convergence checked as above. The impacts
/// are plastic (restitution 0), which MuJoCo's default limit approaches.
void limit_work_precision(const std::string& root, const std::string& outdir) {
  Scene scene = load_scene(root + "/config/scenes/satellite_arm.yaml");
  // Joints 2 and 4 driven towards their limits (panda_joint4 reaches -3.07 rad after ~0.9 s).
  scene.initial_velocities = {
      {"panda_joint1", 0.6}, {"panda_joint2", 1.2}, {"panda_joint4", -0.8}, {"panda_joint6", 1.0}};
  scene.constraints.options.limit_restitution = 0;
  const double T = 2.0;
  std::cout << "== work-precision: satellite_limits (T = " << T << " s, joint limits struck)\n";
  auto simulate = [&](const std::string& integrator, double dt, double tol, RunResult& r,
                      std::size_t* events = nullptr) {
    Scene sc = scene;
    sc.integrator = integrator;
    sc.dt = dt;
    sc.tol = tol;
    const double t0 = cpu_seconds();
    auto sim = make_simulator(sc);
    const int n = static_cast<int>(std::lround(T / dt));
    r.ok = sim->step_n(n) == n;
    r.cpu = cpu_seconds() - t0;
    r.x = sim->state();
    r.steps = n;
    r.evals = static_cast<long>(sim->evaluations());
    if (events) *events = sim->events() + sim->velocity_level_steps();
  };
  RunResult r1, r2, r4;
  const double h_ref = 2.5e-5;
  std::size_t ev = 0;
  simulate("rkmk4", h_ref, 1e-6, r1, &ev);
  simulate("rkmk4", 2 * h_ref, 1e-6, r2);
  simulate("rkmk4", 4 * h_ref, 1e-6, r4);
  auto dist = [](const State& a, const State& b) { return base_error(a, b) + joint_error(a, b); };
  const double e42 = dist(r4.x, r2.x), e21 = dist(r2.x, r1.x);
  std::printf(
      "  reference: rkmk4 with located impacts, dt = %g (%zu impacts); |x(4h)-x(2h)| = %.3g, "
      "|x(2h)-x(h)| = %.3g, observed order %.2f\n",
      h_ref, ev, e42, e21, std::log2(e42 / e21));
  const State ref = r1.x;
  std::ofstream f(outdir + "/wp_satellite_limits.csv");
  f << "integrator,dt,tol,err_base,err_joint,err,cpu_s,evals,steps\n";
  f.precision(6);
  const std::vector<double> dts = {0.02, 0.01, 0.005, 0.002, 0.001, 5e-4, 2e-4, 1e-4};
  for (const std::string name : {"semi_implicit_euler", "rkmk4", "variational"}) {
    std::vector<double> hs, es;
    for (double dt : dts) {
      RunResult r;
      simulate(name, dt, 1e-6, r);
      const double eb = r.ok ? base_error(r.x, ref) : NAN, ej = r.ok ? joint_error(r.x, ref) : NAN;
      f << name << "," << dt << ",," << eb << "," << ej << "," << eb + ej << "," << r.cpu << ","
        << r.evals << "," << r.steps << "\n";
      if (eb + ej < 0.5 && eb + ej > 1e-9) hs.push_back(dt), es.push_back(eb + ej);
    }
    if (hs.size() > 4) hs.erase(hs.begin(), hs.end() - 4), es.erase(es.begin(), es.end() - 4);
    std::printf("  %-24s fitted order %5.2f (%zu points)\n", name.c_str(), fit_slope(hs, es),
                hs.size());
  }
  for (double tol : {1e-3, 1e-5, 1e-7, 1e-9, 1e-11}) {
    RunResult r;
    simulate("rkmk45", 0.01, tol, r);
    const double eb = base_error(r.x, ref), ej = joint_error(r.x, ref);
    f << "rkmk45,0.01," << tol << "," << eb << "," << ej << "," << eb + ej << "," << r.cpu << ","
      << r.evals << "," << r.steps << "\n";
  }
  const Model m = scene_model(scene);
  charts::peer_work_precision(m, scene_state(scene, m), ref, T, dts, false, f, true);
  // MuJoCo's limit is a critically damped spring-damper that lets go when its force vanishes:
  // at e^-2 = 0.135 of the impact speed for a linear one. Against our impacts with that
  // restitution its distance shrinks accordingly (the rest: its impedance and contact time).
  scene.constraints.options.limit_restitution = std::exp(-2.0);
  RunResult re;
  simulate("rkmk4", h_ref, 1e-6, re);
  try {
    auto e = peers::make_engine("mujoco_rk4", m, true, 1e-6, true);
    e->set_state(scene_state(scene, m));
    for (long k = 0; k < std::lround(T / 1e-4); ++k) e->step(1e-4);
    State xm = scene_state(scene, m);
    e->get_state(xm);
    std::printf(
        "  MuJoCo RK4 at dt 1e-4 against our impacts with restitution e^-2 instead of 0: %.3g "
        "(against plastic impacts: above)\n",
        dist(xm, re.x));
  } catch (const std::invalid_argument&) {
    // MuJoCo is not in this build.
  }
}

// ------------------------------------------------------------------ energy over long runs

void energy_run(const std::string& scene, const Model& m, const State& x0, double dt, double T,
                const std::vector<std::string>& integrators, bool momentum, std::ofstream& f) {
  Data d(m);
  // Energy scale: the initial kinetic energy, or (released from rest) the largest kinetic
  // energy of the first 10 s of a fine rkmk4 run.
  double T0 = kinetic_energy(m, d, x0.base, x0.q, x0.v);
  const double E0 = T0 + potential_energy(m, d, x0.base, x0.q);
  if (T0 == 0) {
    StepperOptions opt;
    opt.passive_forces = false;
    auto st = make_stepper("rkmk4", m, opt);
    State x = x0;
    const VecX z = VecX::Zero(m.nv);
    for (int k = 0; k < 10000; ++k) {
      st->step(x, z, 1e-3);
      T0 = std::max(T0, kinetic_energy(m, d, x.base, x.q, x.v));
    }
  }
  const Vec6 h0 = spatial_momentum(m, d, x0.base, x0.q, x0.v);
  const long n = std::lround(T / dt);
  const int samples = 400;
  // Sample times spaced logarithmically, so short and long times both show.
  std::vector<long> marks;
  for (int s = 0; s <= samples; ++s) {
    const long k = std::lround(std::pow(static_cast<double>(n), s / double(samples)));
    if (marks.empty() || k > marks.back()) marks.push_back(k);
  }
  const VecX zero = VecX::Zero(m.nv);
  for (const auto& name : integrators) {
    StepperOptions opt;
    opt.tol = 1e-6;
    opt.passive_forces = false;  // conservative: the URDF's joint damping is left out
    auto st = make_stepper(name, m, opt);
    State x = x0;
    double emax = 0, hmax = 0;
    size_t next = 0;
    const double c0 = cpu_seconds();
    bool dead = false;
    for (long k = 1; k <= n; ++k) {
      const StepInfo info = st->step(x, zero, dt);
      if (!info.ok || !x.finite()) {
        dead = true;
        break;
      }
      const double E = kinetic_energy(m, d, x.base, x.q, x.v) + potential_energy(m, d, x.base, x.q);
      emax = std::max(emax, std::abs(E - E0) / T0);
      if (momentum) {
        hmax = std::max(hmax, (spatial_momentum(m, d, x.base, x.q, x.v) - h0).norm() / h0.norm());
      }
      if (next < marks.size() && k == marks[next]) {
        f << scene << "," << name << "," << k * dt << "," << emax << ","
          << (momentum ? hmax : std::nan("")) << "\n";
        ++next;
      }
      if (emax > 1e3) {
        dead = true;
        break;
      }
    }
    char mom[64] = "";
    if (momentum) std::snprintf(mom, sizeof mom, ", max |dh|/|h0| = %.3g", hmax);
    std::printf("  %-10s %-17s dt %g: max |dE|/T0 = %.3g%s%s over %g s (cpu %.1f s)\n",
                scene.c_str(), name.c_str(), dt, emax, mom, dead ? " [stopped: blew up]" : "", T,
                cpu_seconds() - c0);
  }
}

// ------------------------------------------------------------------ dynamics algorithms

struct AlgoErr {
  double aba = 0, chol = 0, minv = 0;
};

/// Relative errors (normwise) of the three ways to get accelerations, for one random state.
AlgoErr algorithm_errors(const Model& m, Data& d, std::mt19937& rng) {
  std::uniform_real_distribution<double> U(-1, 1);
  VecX q(m.n), v(m.nv), tau(m.nv);
  for (int i = 0; i < m.n; ++i) q[i] = M_PI * U(rng);
  for (int i = 0; i < m.nv; ++i) v[i] = U(rng), tau[i] = U(rng);
  SE3 base(exp_so3(Vec3(U(rng), U(rng), U(rng))), Vec3(U(rng), U(rng), U(rng)));
  const VecXL ref = aba_long_double(m, base, q, v, tau);
  const VecX refd = ref.cast<double>();
  const double nr = refd.norm();
  AlgoErr e;
  e.aba = (aba(m, d, base, q, v, tau) - refd).norm() / nr;
  const VecX rhs = tau - bias(m, d, base, q, v);
  const MatX& M = crba(m, d, base, q);
  e.chol = (M.llt().solve(rhs) - refd).norm() / nr;
  const MatX& Mi = minv(m, d, base, q);
  e.minv = (Mi * rhs - refd).norm() / nr;
  return e;
}

void dynamics_charts(const std::string& outdir, bool quick) {
  std::cout << "== dynamics algorithms: free-floating chains, gravity on\n";
  std::ofstream f(outdir + "/dyn_scaling.csv");
  f << "n,nv,aba_ns,chol_ns,minv_ns,aba_err,chol_err,minv_err\n";
  std::vector<int> sizes = {1, 2, 4, 8, 16, 32, 64, 128, 256, 500};
  if (quick) sizes = {1, 4, 16, 64, 256};
  std::vector<double> ns, ta, tc, tm;
  std::mt19937 rng(7);
  for (int n : sizes) {
    const Model m = make_chain(n, true);
    Data d(m);
    std::uniform_real_distribution<double> U(-1, 1);
    VecX q(m.n), v(m.nv), tau(m.nv), out(m.nv);
    for (int i = 0; i < m.n; ++i) q[i] = M_PI * U(rng);
    for (int i = 0; i < m.nv; ++i) v[i] = U(rng), tau[i] = U(rng);
    const SE3 base;
    // Time each way (median of batches), every call from the raw state.
    auto timeit = [&](auto&& fn) {
      std::vector<double> batches;
      int reps = 1;
      for (;;) {
        const double t0 = cpu_seconds();
        for (int r = 0; r < reps; ++r) fn();
        const double dtm = cpu_seconds() - t0;
        if (dtm > 0.01) break;
        reps *= 2;
      }
      for (int b = 0; b < 7; ++b) {
        const double t0 = cpu_seconds();
        for (int r = 0; r < reps; ++r) fn();
        batches.push_back((cpu_seconds() - t0) / reps * 1e9);
      }
      std::sort(batches.begin(), batches.end());
      return batches[batches.size() / 2];
    };
    Eigen::LLT<MatX> llt(m.nv);
    const double t_aba = timeit([&] { out = aba(m, d, base, q, v, tau); });
    const double t_chol = timeit([&] {
      out = tau - bias(m, d, base, q, v);
      llt.compute(crba(m, d, base, q));
      llt.solveInPlace(out);
    });
    const double t_minv = timeit([&] {
      out = tau - bias(m, d, base, q, v);
      out = minv(m, d, base, q) * out;
    });
    AlgoErr e;
    const int trials = n > 200 ? 3 : 10;
    for (int t = 0; t < trials; ++t) {
      const AlgoErr k = algorithm_errors(m, d, rng);
      e.aba = std::max(e.aba, k.aba);
      e.chol = std::max(e.chol, k.chol);
      e.minv = std::max(e.minv, k.minv);
    }
    f << n << "," << m.nv << "," << t_aba << "," << t_chol << "," << t_minv << "," << e.aba << ","
      << e.chol << "," << e.minv << "\n";
    std::printf(
        "  n = %3d: aba %10.0f ns, crba+chol %10.0f ns, minv %10.0f ns; max rel err %.1e / %.1e "
        "/ %.1e\n",
        n, t_aba, t_chol, t_minv, e.aba, e.chol, e.minv);
    if (n >= 32) {
      ns.push_back(n);
      ta.push_back(t_aba);
      tc.push_back(t_chol);
      tm.push_back(t_minv);
    }
  }
  std::printf("  scaling exponents (n >= 32): aba %.2f, crba+cholesky %.2f, minv %.2f\n",
              fit_slope(ns, ta), fit_slope(ns, tc), fit_slope(ns, tm));

  std::cout << "== dynamics algorithms: link masses spanning many orders of magnitude\n";
  std::ofstream g(outdir + "/dyn_mass_ratio.csv");
  g << "pattern,span,n,aba_err,chol_err,minv_err\n";
  const int n = 30;
  for (const std::string pattern : {"alternating", "ramp"}) {
    for (int k = 0; k <= 8; ++k) {
      const double span = std::pow(10.0, k);
      std::vector<double> masses(n + 1);
      for (int i = 0; i <= n; ++i) {
        if (pattern == "alternating") {
          masses[i] = (i % 2 == 0) ? std::sqrt(span) : 1 / std::sqrt(span);
        } else {
          masses[i] = std::pow(span, i / double(n) - 0.5);
        }
      }
      const Model m = make_chain(n, true, masses);
      Data d(m);
      AlgoErr e;
      for (int t = 0; t < 20; ++t) {
        const AlgoErr r = algorithm_errors(m, d, rng);
        e.aba = std::max(e.aba, r.aba);
        e.chol = std::max(e.chol, r.chol);
        e.minv = std::max(e.minv, r.minv);
      }
      g << pattern << "," << span << "," << n << "," << e.aba << "," << e.chol << "," << e.minv
        << "\n";
      std::printf("  %-11s span 1e%d: max rel err aba %.1e, crba+chol %.1e, minv %.1e\n",
                  pattern.c_str(), k, e.aba, e.chol, e.minv);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: charts_data OUTDIR [--root PACKAGE_DIR] [--only "
                 "work|limits|energy|dynamics|study|stability] [--quick]\n";
    return 2;
  }
  std::string outdir = argv[1], root = ".", only;
  bool quick = false;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--root" && i + 1 < argc) {
      root = argv[++i];
    } else if (a == "--only" && i + 1 < argc) {
      only = argv[++i];
    } else if (a == "--quick") {
      quick = true;
    } else {
      std::cerr << "charts_data: unknown argument '" << a << "'\n";
      return 2;
    }
  }
  try {
    if (only.empty() || only == "work") {
      std::vector<WpScene> scenes;
      {
        WpScene s;
        s.name = "free_body";
        s.model = free_body(Vec3(0.2, 0.2, 0.5), 2.0);
        s.x0 = State(s.model);
        s.x0.v << 1.0, 0.5, 2.0, 0.1, -0.2, 0.3;
        s.T = 10;
        s.dts = {0.2, 0.1, 0.05, 0.02, 0.01, 0.005, 0.002, 0.001};
        s.dts_first = {5e-4, 2e-4};
        s.exact = true;
        scenes.push_back(std::move(s));
      }
      {
        // The tossed link of docs/accuracy.md made axisymmetric (so that its rotation has a
        // closed form), under gravity: the free base's ballistic flight.
        WpScene s;
        s.name = "free_body_tossed";
        s.model = free_body(Vec3(0.3, 0.3, 0.05), 4.0);
        s.model.gravity = Vec3(0, 0, -9.81);
        s.x0 = State(s.model);
        s.x0.v << 0.2, 4.0, -0.1, 1.0, -3.0, 6.0;
        s.T = 4;
        s.dts = {0.2, 0.1, 0.05, 0.02, 0.01, 0.005, 0.002, 0.001};
        s.dts_first = {5e-4, 2e-4};
        s.exact = true;
        scenes.push_back(std::move(s));
      }
      {
        const Scene scene = load_scene(root + "/config/scenes/satellite_arm.yaml");
        WpScene s;
        s.name = "satellite_arm";
        s.model = scene_model(scene);
        s.x0 = scene_state(scene, s.model);
        // Faster joint motion than the scene's, so that 4 s hold a few swings.
        s.x0.v.tail(s.model.n).setConstant(0.8);
        s.T = 4;
        s.dts = {0.1, 0.05, 0.02, 0.01, 0.005, 0.002, 0.001, 0.0005};
        s.dts_first = {2e-4, 1e-4, 5e-5, 2e-5};
        s.dt_ref = 1e-4;
        scenes.push_back(std::move(s));
      }
      {
        Scene scene = load_scene(root + "/config/scenes/chain20.yaml");
        scene.base_twist.setZero();  // the chain is mounted here: a fixed base, under gravity
        WpScene s;
        s.name = "chain20_gravity";
        s.model = make_chain(20, false);
        s.model.gravity = Vec3(0, 0, -9.81);
        s.x0 = scene_state(scene, s.model);
        s.T = 1;
        s.dts = {0.02, 0.01, 0.005, 0.002, 0.001, 0.0005, 0.0002, 0.0001};
        s.dts_first = {5e-5, 2e-5, 1e-5};
        s.dt_ref = 2.5e-5;
        scenes.push_back(std::move(s));
      }
      for (const auto& s : scenes) work_precision(s, outdir);
    }
    if (only.empty() || only == "work" || only == "limits") limit_work_precision(root, outdir);
    if (only.empty() || only == "energy") {
      std::cout << "== energy over long runs\n";
      std::ofstream f(outdir + "/energy.csv");
      f << "scene,integrator,t,energy_err,momentum_err\n";
      const double T = quick ? 1e3 : 1e4;
      {
        const Scene scene = load_scene(root + "/config/scenes/pendulum.yaml");
        const Model m = scene_model(scene);
        const State x0 = scene_state(scene, m);
        energy_run("pendulum", m, x0, 0.002, T,
                   {"euler", "symplectic_euler", "rkmk4", "rkmk45", "variational"}, false, f);
      }
      {
        const Model m = free_body(Vec3(0.1, 0.2, 0.3), 2.0);
        State x0(m);
        x0.v << 0.3, 1.0, 0.2, 0.1, 0.0, 0.0;
        energy_run("free_body", m, x0, 0.05, T,
                   {"euler", "symplectic_euler", "rkmk4", "rkmk45", "variational",
                    "rk4_euler_angles", "rk4_quaternion"},
                   true, f);
      }
    }
    if (only.empty() || only == "dynamics") dynamics_charts(outdir, quick);
    if (only.empty() || only == "study") charts::study(outdir, root, quick);
    if (only.empty() || only == "stability") charts::stability(outdir, root, quick);
  } catch (const std::exception& e) {
    std::cerr << "charts_data: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
