// simulate_headless (sim.h): the core of `se3_dyn simulate`.
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "se3_sim/model/limits.h"
#include "se3_sim/sim/gain_check.h"
#include "se3_sim/sim/scene_collision.h"
#include "se3_sim/sim/sim.h"

namespace se3 {
namespace {

// A header cell as RFC 4180 has it: quoted (with its quotes doubled) when it holds a comma or
// a quote (object names may).
std::string csv_cell(const std::string& text) {
  if (text.find_first_of(",\"") == std::string::npos) return text;
  std::string out = "\"";
  for (const char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

void write_header(std::ofstream& out, const Simulator& sim) {
  const Model& m = sim.model();
  out << "t,base_x,base_y,base_z,base_qx,base_qy,base_qz,base_qw";
  if (m.floating) out << ",base_wx,base_wy,base_wz,base_vx,base_vy,base_vz";
  for (int i = 1; i <= m.n; ++i) out << ",q:" << m.joint_name[i];
  for (int i = 1; i <= m.n; ++i) out << ",v:" << m.joint_name[i];
  out << ",kinetic,potential";
  // Every free object, in the scene's order: world pose (position, quaternion x y z w) and
  // twist in its own frame (angular first), as the base's.
  static const char* const kObjectColumns[] = {"x",  "y",  "z",  "qx", "qy", "qz", "qw",
                                               "wx", "wy", "wz", "vx", "vy", "vz"};
  for (const ObjectState& o : sim.objects()) {
    if (o.is_static) continue;
    for (const char* c : kObjectColumns) out << ',' << csv_cell("obj:" + o.name + ":" + c);
  }
  out << '\n';
}

void write_row(std::ofstream& out, Simulator& sim) {
  const State& x = sim.state();
  char buf[40];
  auto put = [&](double v) {
    std::snprintf(buf, sizeof buf, ",%.17g", v);
    out << buf;
  };
  std::snprintf(buf, sizeof buf, "%.17g", sim.time());
  out << buf;
  for (int k = 0; k < 3; ++k) put(x.base.p[k]);
  const Eigen::Vector4d q = quaternion_from_rotation(x.base.R);
  for (int k = 0; k < 4; ++k) put(q[k]);
  const int off = sim.model().nv_base();
  for (int k = 0; k < off; ++k) put(x.v[k]);
  for (int k = 0; k < x.q.size(); ++k) put(x.q[k]);
  for (int k = 0; k < x.q.size(); ++k) put(x.v[off + k]);
  put(sim.kinetic_energy());
  put(sim.potential_energy());
  for (const ObjectState& o : sim.objects()) {
    if (o.is_static) continue;
    for (int k = 0; k < 3; ++k) put(o.pose.p[k]);
    const Eigen::Vector4d qo = quaternion_from_rotation(o.pose.R);
    for (int k = 0; k < 4; ++k) put(qo[k]);
    for (int k = 0; k < 6; ++k) put(o.twist[k]);
  }
  out << '\n';
}

// "chain:N" checked (1 <= N <= limits::kMaxBodies); a path is left to the URDF loader.
void check_chain(const std::string& model) {
  if (model.compare(0, 6, "chain:") != 0) return;
  char* end = nullptr;
  errno = 0;
  const long n = std::strtol(model.c_str() + 6, &end, 10);
  if (model.size() == 6 || *end != '\0' || errno != 0 || n < 1 || n > limits::kMaxBodies) {
    throw std::invalid_argument("chain:N needs 1 <= N <= " + std::to_string(limits::kMaxBodies) +
                                ", got '" + model + "'");
  }
}

}  // namespace

SimulateResult simulate_headless(const SimulateOptions& o) {
  if (!(o.duration >= 0) || !std::isfinite(o.duration)) {
    throw std::invalid_argument("duration must be a finite number >= 0");
  }
  // dt 0: the scene's.
  if (const std::string why = o.dt == 0 ? "" : dt_problem(o.dt); !why.empty()) {
    throw std::invalid_argument("dt " + three_figures(o.dt) + " s " + why);
  }
  if (o.tol < 0 || !std::isfinite(o.tol)) throw std::invalid_argument("tol must be positive");
  Scene scene;
  bool use_scene_state = false;
  if (!o.scene.empty()) {
    scene = load_scene(o.scene);
    use_scene_state = !o.random_initial;
    if (!scene.base_given) scene.floating = o.floating;
    if (o.floating) scene.floating = true;
  } else {
    if (o.model.empty()) throw std::invalid_argument("simulate needs a model or a scene");
    scene.floating = o.floating;
    scene.file = o.model;
  }
  if (!o.model.empty()) {  // a robot from outside replaces the scene's
    check_chain(o.model);
    scene.robot = o.model;
    scene.robot_path = o.model;
  }
  if (o.has_gravity) scene.gravity = o.gravity;
  if (!o.integrator.empty()) scene.integrator = o.integrator;
  if (o.dt > 0) scene.dt = o.dt;
  if (o.tol > 0) scene.tol = o.tol;
  // The work asked for, before anything is built: steps, then steps x bodies.
  const double steps_asked = o.duration / scene.dt;
  if (!(steps_asked <= static_cast<double>(limits::kMaxSteps))) {
    throw std::invalid_argument("duration / dt asks for " + three_figures(steps_asked) +
                                " steps, more than the " + three_figures(limits::kMaxSteps) +
                                " one run may take (docs/robustness.md)");
  }
  // A run rounds duration / dt to whole steps: one that would take none is a mistake (a dt
  // written in the wrong unit, a duration of 0), not a success.
  if (!(std::llround(steps_asked) >= 1)) {
    throw std::invalid_argument(
        "duration " + three_figures(o.duration) + " s is less than half the step dt " +
        three_figures(scene.dt) +
        " s: the run would take no step (a duration of at least dt takes one)");
  }

  Model model = scene_model(scene);
  const double bodies = model.n + 1;
  if (steps_asked * bodies > o.max_body_steps) {
    throw std::invalid_argument(three_figures(steps_asked) + " steps of " +
                                std::to_string(model.n + 1) + " bodies are more than the " +
                                three_figures(o.max_body_steps) +
                                " body-steps one run may take (docs/robustness.md)");
  }
  const State x0 = use_scene_state ? scene_state(scene, model) : random_state(model, o.seed);
  SimConfig cfg;
  cfg.integrator = scene.integrator;
  cfg.dt = scene.dt;
  cfg.stepper.tol = scene.tol;
  cfg.stepper.friction_eps = scene.friction_eps;
  Simulator sim(std::move(model), x0, cfg);
  const ConstraintSpec spec = scene_constraints(scene, sim.model());
  if (!spec.empty()) sim.set_constraints(spec);
  if (uses_scene_collision(scene)) {  // the objects' collision model: the scene collision's
    const GeometryModel none;
    sim.set_objects(scene.objects, scene_collision(scene, &sim.model(),
                                                   scene.robot_path.empty() ? &none : nullptr));
  } else if (!scene.objects.empty()) {
    sim.set_objects(scene.objects);
  }
  if (!scene.controllers.empty()) {
    sim.set_controllers(scene.controllers);
    for (const std::string& w :
         gain_stability_warnings(sim.model(), x0, scene.controllers, scene.dt)) {
      std::fprintf(stderr, "warning: %s\n", w.c_str());
    }
  }

  const std::string deep = sim.deep_penetration_warning();
  if (!deep.empty()) std::fprintf(stderr, "warning: %s\n", deep.c_str());

  std::ofstream csv;
  if (!o.out_csv.empty()) {
    csv.open(o.out_csv);
    if (!csv) throw std::invalid_argument("cannot write '" + o.out_csv + "'");
    write_header(csv, sim);
    write_row(csv, sim);
  }

  SimulateResult r;
  r.integrator = sim.integrator();
  r.dt = scene.dt;
  // The whole scene's energy and momentum (robot and free objects). Momentum is conserved in
  // zero gravity when nothing holds the scene: a free (or no) robot base, no ground and no
  // static object.
  bool held = !sim.model().floating && sim.model().n > 0;
  held = held || spec.ground;
  for (const SceneObject& ob : scene.objects) held = held || ob.is_static;
  const bool conserve_momentum = !held && scene.gravity.norm() == 0.0;
  const double T0 = sim.scene_kinetic_energy();
  const Vec6 h0 = sim.scene_momentum();
  const Vec3 c0 = sim.center_of_mass();
  double dE = 0, dB = 0, T_max = T0, dh = 0, dc = 0;
  double dcon = sim.constraints() ? sim.constraint_error() : 0.0;
  const std::uint64_t n_steps = static_cast<std::uint64_t>(std::llround(o.duration / scene.dt));
  using clock = std::chrono::steady_clock;
  clock::duration wall{0};
  for (std::uint64_t k = 0; k < n_steps; ++k) {
    const auto t0 = clock::now();
    const bool ok = sim.step();
    wall += clock::now() - t0;
    if (!ok) {
      r.diverged = true;
      r.status = sim.failure();
      break;
    }
    // An adaptive stepper may take many internal steps per step: they count as work too.
    if (static_cast<double>(sim.substeps() + sim.rejected()) * bodies > o.max_body_steps) {
      r.stopped = true;
      r.status = "stopped at t = " + three_figures(sim.time()) + " s: the adaptive stepper's " +
                 std::to_string(sim.substeps() + sim.rejected()) + " internal steps of " +
                 std::to_string(static_cast<long long>(bodies)) + " bodies passed the " +
                 three_figures(o.max_body_steps) +
                 " body-steps one run may take (docs/robustness.md)";
      break;
    }
    // Diagnostics every step, outside the timed part.
    const double T = sim.scene_kinetic_energy();
    const double E = T + sim.scene_potential_energy();
    dE = std::max(dE, std::abs(E - T0));
    dB = std::max(dB, std::abs(E - T0 - sim.work()));
    T_max = std::max(T_max, T);
    if (conserve_momentum) {
      dh = std::max(dh, (sim.scene_momentum() - h0).norm());
      const Vec3 c_free = c0 + sim.time() * h0.tail<3>() / sim.model().total_mass();
      dc = std::max(dc, (sim.center_of_mass() - c_free).norm());
    }
    if (sim.constraints()) dcon = std::max(dcon, sim.constraint_error());
    if (csv.is_open()) write_row(csv, sim);
  }
  r.steps = sim.steps();
  r.sim_s = sim.time();
  r.wall_s = std::chrono::duration<double>(wall).count();
  r.substeps = sim.substeps();
  r.rejected = sim.rejected();
  r.evaluations = sim.evaluations();
  r.velocity_level_steps = sim.velocity_level_steps();
  r.events = sim.events();
  r.integrator = sim.schemes_used();
  const double scale = energy_drift_scale(sim.energy_scale0(), T_max);
  r.energy_drift_rel = dE / scale;
  r.energy_balance_rel = dB / scale;
  if (sim.constraints()) r.constraint_error_max = dcon;
  if (conserve_momentum) {
    r.momentum_drift_rel = h0.norm() > 0 ? dh / h0.norm() : dh;
    r.com_drift_max = dc;
  }
  r.fast_steps = sim.fast_steps();
  if (!sim.fast_step_warning().empty()) {
    std::fprintf(stderr, "warning: %s (%llu such steps in the run)\n",
                 sim.fast_step_warning().c_str(), static_cast<unsigned long long>(r.fast_steps));
  }
  const bool contact = !scene.objects.empty() || spec.ground || !spec.contacts.empty() ||
                       uses_scene_collision(scene);
  if (contact) r.penetration_max = sim.penetration_max();
  for (std::size_t j = 0; j < sim.object_specs().size() && j < sim.objects().size(); ++j) {
    r.objects.push_back(
        {sim.object_specs()[j].name, sim.objects()[j].pose, sim.objects()[j].twist});
  }
  return r;
}

std::string steps_by_scheme(const SimulateResult& r) {
  const std::string own = r.integrator.substr(0, r.integrator.find('+'));
  const std::uint64_t contact = r.velocity_level_steps;
  std::string out;
  if (own != kContactStepper && r.steps > contact) {
    out += "\"" + own + "\": " + std::to_string(r.steps - contact);
  }
  if (contact > 0 || own == kContactStepper) {
    out += std::string(out.empty() ? "" : ", ") + "\"" + kContactStepper +
           "\": " + std::to_string(own == kContactStepper ? r.steps : contact);
  }
  return out;
}

std::string simulate_result_json(const SimulateResult& r) {
  auto num = [](double v) -> std::string {
    if (!std::isfinite(v)) return "null";
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
  };
  auto text = [](const std::string& t) {
    std::string out = "\"";
    for (const char ch : t) {
      const auto c = static_cast<unsigned char>(ch);
      if (c == '"' || c == '\\') {
        out += '\\';
        out += ch;
      } else if (c < 0x20) {
        char buf[8];
        std::snprintf(buf, sizeof buf, "\\u%04x", c);
        out += buf;
      } else {
        out += ch;
      }
    }
    return out + "\"";
  };
  std::ostringstream o;
  o << "{\"integrator\": " << text(r.integrator) << ", \"dt\": " << num(r.dt)
    << ", \"sim_s\": " << num(r.sim_s) << ", \"wall_s\": " << num(r.wall_s)
    << ", \"steps\": " << r.steps << ", \"steps_by_scheme\": {" << steps_by_scheme(r) << "}"
    << ", \"events\": " << r.events << ", \"energy_drift_rel\": " << num(r.energy_drift_rel)
    << ", \"energy_balance_rel\": " << num(r.energy_balance_rel)
    << ", \"momentum_drift_rel\": " << num(r.momentum_drift_rel)
    << ", \"constraint_error_max\": " << num(r.constraint_error_max)
    << ", \"penetration_max\": " << num(r.penetration_max) << ", \"fast_steps\": " << r.fast_steps;
  if (!r.objects.empty()) {
    auto list = [&](const double* v, int n) {
      std::string out = "[";
      for (int k = 0; k < n; ++k) out += (k ? ", " : "") + num(v[k]);
      return out + "]";
    };
    o << ", \"objects\": {";
    for (std::size_t j = 0; j < r.objects.size(); ++j) {
      const SimulateResult::FinalObject& ob = r.objects[j];
      const Eigen::Vector4d q = quaternion_from_rotation(ob.pose.R);
      o << (j ? ", " : "") << text(ob.name) << ": {\"position\": " << list(ob.pose.p.data(), 3)
        << ", \"orientation\": " << list(q.data(), 4) << ", \"twist\": " << list(ob.twist.data(), 6)
        << "}";
    }
    o << "}";
  }
  o << ", \"diverged\": " << (r.diverged ? "true" : "false")
    << ", \"status\": " << (r.status.empty() ? std::string("null") : text(r.status)) << "}";
  return o.str();
}

}  // namespace se3
