// Several robots in one Simulator (sim.h, docs/multi_robot.md): robots 1.. beside robot 0, each
// a system of its own with its state, stepper, commands, controllers and joint limits.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

#include "se3_sim/lie/format.h"
#include "se3_sim/sim/scene_collision.h"
#include "se3_sim/sim/sim.h"

namespace se3 {

namespace {

constexpr std::uint64_t kNever = std::numeric_limits<std::uint64_t>::max();

// A state of model m: sizes, finite, continuous joints wrapped.
State checked_state(const Model& m, const State& s, const std::string& what) {
  if (s.q.size() != m.n || s.v.size() != m.nv) {
    throw std::invalid_argument(what + ": state sizes do not match the model");
  }
  if (!s.finite()) {
    throw std::invalid_argument(what + ": state is not finite (or its rotation not orthonormal)");
  }
  State x = s;
  wrap_continuous_joints(m, x.q);
  return x;
}

// The guard's per-step check of a robot: finite, no rate above lim, a free base's pose finite.
bool robot_ok(const Model& m, const State& x, double lim) {
  bool ok = x.q.allFinite();
  for (int k = 0; k < m.nv; ++k) ok &= std::abs(x.v[k]) <= lim;
  if (!m.floating) return ok;
  return ok && x.base.p.allFinite() && is_rotation(x.base.R);
}

}  // namespace

Simulator::ExtraRobot& Simulator::extra(int k) const {
  if (k < 1 || k > static_cast<int>(extra_.size())) {
    throw std::out_of_range("robot index " + std::to_string(k) + " out of range (" +
                            std::to_string(robot_count()) + " robots)");
  }
  return *extra_[k - 1];
}

int Simulator::add_robot(const std::string& name, const std::string& ns, Model model,
                         const State& initial, const std::vector<ControllerSpec>& controllers,
                         bool joint_limits) {
  if (name.empty()) throw std::invalid_argument("robot name is empty");
  for (char c : name) {
    if (std::isspace(static_cast<unsigned char>(c)) || c == '/' || c == '#' || c == ':') {
      throw std::invalid_argument("robot name '" + name +
                                  "' is not a frame name (no spaces, '/', '#' or ':')");
    }
  }
  if (robot_index(name) >= 0 || object_index(name) >= 0) {
    throw std::invalid_argument("robot name '" + name + "' is already a model's");
  }
  if (scene_collision_) {
    throw std::invalid_argument("robot '" + name +
                                "': add robots before set_scene_collision (it holds their shapes)");
  }
  return insert_robot(make_extra_robot(name, ns, std::make_unique<Model>(std::move(model)), initial,
                                       controllers, joint_limits));
}

std::unique_ptr<Simulator::ExtraRobot> Simulator::make_extra_robot(
    const std::string& name, const std::string& ns, std::unique_ptr<Model> model,
    const State& initial, const std::vector<ControllerSpec>& controllers, bool joint_limits) const {
  const std::string what = "robot '" + name + "'";
  auto r = std::make_unique<ExtraRobot>(*model);
  r->name = name;
  r->ns = ns;
  r->model = std::move(model);
  const Model& m = *r->model;
  r->initial = checked_state(m, initial, what);
  r->stepper = make_stepper(config_.integrator, m, config_.stepper);
  ConstraintSpec spec;
  spec.joint_limits = joint_limits;
  if (config_.mimic_joints) spec.bilateral = mimic_constraints(m);
  if (!spec.empty()) {
    r->constraints = std::make_unique<ConstraintSystem>(m, spec);
    r->constraints->anchor(r->initial);
    r->constraints->project(r->initial);
    r->constraints_start = std::make_unique<ConstraintSystem>(*r->constraints);
  }
  r->command = VecX::Zero(m.nv);
  r->actuation = VecX::Zero(m.nv);
  r->forces = VecX::Zero(m.nv);
  r->command_until.assign(m.nv, kNever);
  if (!controllers.empty()) r->controllers = std::make_unique<ControllerSet>(m, controllers);
  return r;
}

int Simulator::insert_robot(std::unique_ptr<ExtraRobot> r) {
  extra_states_.push_back(r->initial);
  extra_a_.push_back(VecX::Zero(r->model->nv));
  extra_.push_back(std::move(r));
  reset_extra_robot(*extra_.back());  // the others run on (a robot spawned at run time)
  return robot_count() - 1;
}

int Simulator::robot_index(const std::string& name) const {
  if (name.empty()) return -1;
  if (name == robot_name_) return 0;
  for (size_t k = 0; k < extra_.size(); ++k) {
    if (extra_[k]->name == name) return static_cast<int>(k) + 1;
  }
  return -1;
}

const Model& Simulator::robot_model(int k) const {
  return k == 0 ? *model_ : *extra(k).model;
}

const State& Simulator::robot_state(int k) const {
  return k == 0 ? state_ : extra(k).state;
}

const std::string& Simulator::robot_name(int k) const {
  return k == 0 ? robot_name_ : extra(k).name;
}

const std::string& Simulator::robot_namespace(int k) const {
  return k == 0 ? robot_ns_ : extra(k).ns;
}

double Simulator::set_robot_joint_effort(int k, int i, double effort) {
  if (k == 0) return set_joint_effort(i, effort);
  ExtraRobot& r = extra(k);
  const Model& m = *r.model;
  if (i < 1 || i > m.n) throw std::out_of_range("joint index out of range");
  if (!std::isfinite(effort)) throw std::invalid_argument("effort is not finite");
  const double lim = m.effort[i];
  if (std::isfinite(lim) && lim > 0) effort = std::min(lim, std::max(-lim, effort));
  const int iv = m.idx_v(i);
  r.command[iv] = effort;
  r.command_until[iv] = command_expiry();
  r.next_expiry = std::min(r.next_expiry, r.command_until[iv]);
  return effort;
}

void Simulator::set_robot_base_wrench(int k, const Vec6& wrench) {
  if (k == 0) return set_base_wrench(wrench);
  ExtraRobot& r = extra(k);
  if (!wrench.allFinite()) throw std::invalid_argument("base wrench is not finite");
  if (!r.model->floating) return;
  r.command.head<6>() = wrench;
  const std::uint64_t until = command_expiry();
  for (int k = 0; k < 6; ++k) r.command_until[k] = until;
  r.next_expiry = std::min(r.next_expiry, until);
}

void Simulator::expire_commands(ExtraRobot& r) const {
  if (steps_ < r.next_expiry) return;  // one comparison per step unless a command runs out now
  r.next_expiry = kNever;
  for (int k = 0; k < r.model->nv; ++k) {
    if (steps_ >= r.command_until[k]) {
      r.command[k] = 0;
      r.command_until[k] = kNever;
    }
    r.next_expiry = std::min(r.next_expiry, r.command_until[k]);
  }
}

const VecX& Simulator::robot_actuation(int k) const {
  if (k == 0) return actuation();
  const ExtraRobot& r = extra(k);
  return r.controllers ? r.actuation : r.command;
}

void Simulator::robot_applied_joint_efforts(int k, VecX& out) {
  if (k == 0) return applied_joint_efforts(out);
  const ExtraRobot& r = extra(k);
  const Model& m = *r.model;
  out.resize(m.n);
  const PassiveForces& passive = r.stepper->passive();
  for (int i = 1; i <= m.n; ++i) {
    const int iv = m.idx_v(i);
    const double cmd =
        r.controllers && r.controllers->controls(i) ? r.actuation[iv] : r.command[iv];
    out[i - 1] = passive.at(iv, cmd, r.state.v[iv]);
  }
}

void Simulator::set_robot_state(int k, const State& s) {
  if (k == 0) return set_state(s);
  ExtraRobot& r = extra(k);
  r.state = checked_state(*r.model, s, "robot '" + r.name + "'");
  r.last_good = r.state;
  r.stepper->restart();
}

ControllerSet* Simulator::robot_controllers(int k) {
  return k == 0 ? controllers() : extra(k).controllers.get();
}

void Simulator::set_robot_controllers(int k, const std::vector<ControllerSpec>& specs) {
  if (k == 0) return set_controllers(specs);
  ExtraRobot& r = extra(k);
  if (specs.empty()) {
    r.controllers.reset();
    return;
  }
  auto c = std::make_unique<ControllerSet>(*r.model, specs);
  c->reset(r.state);
  r.controllers = std::move(c);
}

void Simulator::robot_link_poses(int k, std::vector<SE3>& out) {
  if (k == 0) return link_poses(out);
  ExtraRobot& r = extra(k);
  const Model& m = *r.model;
  forward_kinematics(m, r.diag, r.state.base, r.state.q);
  out.resize(m.links.size());
  for (size_t j = 0; j < m.links.size(); ++j) {
    out[j] = r.diag.oMb[m.links[j].body] * m.links[j].offset;
  }
}

Vec6 Simulator::robot_momentum(int k) {
  if (k == 0) return momentum();
  ExtraRobot& r = extra(k);
  return spatial_momentum(*r.model, r.diag, r.state.base, r.state.q, r.state.v);
}

double Simulator::robot_kinetic_energy(int k) {
  if (k == 0) return kinetic_energy();
  ExtraRobot& r = extra(k);
  return se3::kinetic_energy(*r.model, r.diag, r.state.base, r.state.q, r.state.v);
}

double Simulator::robot_potential_energy(int k) {
  if (k == 0) return potential_energy();
  ExtraRobot& r = extra(k);
  return se3::potential_energy(*r.model, r.diag, r.state.base, r.state.q) - r.U0;
}

const VecX* Simulator::extra_robot_forces(ExtraRobot& r, int k, const VecX* tau) {
  if (!has_link_wrenches(k)) return tau;
  r.forces = *tau;  // the same size: no allocation
  forward_kinematics(*r.model, r.diag, r.state.base, r.state.q);
  for (const LinkWrench& w : wrenches_) {
    if (w.robot == k) add_link_wrench_force(*r.model, r.diag, w.link, w.point, w.wrench, r.forces);
  }
  return &r.forces;
}

std::vector<const Model*> Simulator::extra_robot_models() const {
  std::vector<const Model*> out;
  for (const auto& r : extra_) out.push_back(r->model.get());
  return out;
}

bool Simulator::coupled_robots() const {
  return scene_collision_ && scene_collision_->robot_frames > 0;
}

void Simulator::prepare_coupled_robots() {
  for (size_t k = 0; k < extra_.size(); ++k) {
    ExtraRobot& r = *extra_[k];
    expire_commands(r);
    r.tau = &r.command;
    if (r.controllers) {
      r.actuation = r.command;
      r.controllers->update(r.state, time_, config_.dt, r.actuation);
      r.tau = &r.actuation;
    }
    r.tau = extra_robot_forces(r, static_cast<int>(k) + 1, r.tau);
    State& s = extra_states_[k];
    s.base = r.state.base;
    s.q = r.state.q;
    s.v = r.state.v;
    extra_a_[k] = contact_free_acceleration(*r.stepper, r.state, *r.tau);
  }
}

bool Simulator::finish_coupled_robots(StepInfo& info) {
  const double h = config_.dt;
  for (size_t k = 0; k < extra_.size(); ++k) {
    ExtraRobot& r = *extra_[k];
    StepInfo own;
    if (constraints_->robot_touched(static_cast<int>(k))) {
      r.state.v = extra_states_[k].v;
      advance_velocity_level(*r.stepper, r.state, h);
    } else {
      own = r.constraints ? constrained_step(*r.constraints, *r.stepper, r.state, *r.tau, h)
                          : r.stepper->step(r.state, *r.tau, h);
    }
    if (own.ok && robot_ok(*r.model, r.state, config_.guard.max_rate)) continue;
    info.ok = false;
    info.reason = "robot '" + r.name + "': " +
                  (own.ok ? "a rate exceeds the limit " + num(config_.guard.max_rate) +
                                " or the state is not finite"
                          : own.reason);
    return false;
  }
  return true;
}

bool Simulator::step_extra_robots() {
  const double h = config_.dt;
  for (size_t k = 0; k < extra_.size(); ++k) {
    ExtraRobot& r = *extra_[k];
    expire_commands(r);
    const VecX* tau = &r.command;
    if (r.controllers) {
      r.actuation = r.command;
      r.controllers->update(r.state, time_, h, r.actuation);
      tau = &r.actuation;
    }
    tau = extra_robot_forces(r, static_cast<int>(k) + 1, tau);
    const StepInfo info = r.constraints
                              ? constrained_step(*r.constraints, *r.stepper, r.state, *tau, h)
                              : r.stepper->step(r.state, *tau, h);
    if (info.ok && robot_ok(*r.model, r.state, config_.guard.max_rate)) continue;
    std::string why = info.ok ? "a rate exceeds the limit " + num(config_.guard.max_rate) +
                                    " or the state is not finite"
                              : info.reason;
    roll_back_extra_robots();
    failure_ = "diverged at t = " + num(time_ + h) + " s with " + r.stepper->name() +
               ", dt = " + num(h) + ": robot '" + r.name + "': " + why +
               "; state rolled back to t = " + num(time_) + " s";
    return false;
  }
  return true;
}

void Simulator::roll_back_extra_robots() {
  for (const auto& r : extra_) {
    r->state = r->last_good;
    r->stepper->restart();
  }
}

void Simulator::reset_extra_robots() {
  for (const auto& rp : extra_) reset_extra_robot(*rp);
}

void Simulator::reset_extra_robot(ExtraRobot& r) {
  r.state = r.initial;
  r.U0 = se3::potential_energy(*r.model, r.diag, r.state.base, r.state.q);
  r.last_good = r.initial;
  r.command.setZero();
  r.actuation.setZero();
  std::fill(r.command_until.begin(), r.command_until.end(), kNever);
  r.next_expiry = kNever;
  if (r.constraints_start) r.constraints = std::make_unique<ConstraintSystem>(*r.constraints_start);
  if (r.controllers) r.controllers->reset(r.state);
  r.stepper->restart();
}

void Simulator::remove_robot(int k) {
  extra(k);  // checks k
  // Its link wrenches go with it; the later robots' move down one index.
  wrenches_.erase(std::remove_if(wrenches_.begin(), wrenches_.end(),
                                 [k](const LinkWrench& w) { return w.robot == k; }),
                  wrenches_.end());
  for (LinkWrench& w : wrenches_) {
    if (w.robot > k) --w.robot;
  }
  extra_.erase(extra_.begin() + (k - 1));
  extra_states_.erase(extra_states_.begin() + (k - 1));
  extra_a_.erase(extra_a_.begin() + (k - 1));
}

void add_scene_robots(Simulator& sim, const Scene& scene) {
  for (size_t i = 0; i < scene.extra_robots.size(); ++i) {
    const Scene& e = scene.extra_robots[i];
    const std::string where = scene.file + ": robots[" + std::to_string(i + 1) + "]";
    Model m = scene_model(e);
    const State x = scene_state(e, m);
    const std::string name = !e.robot_name.empty() ? e.robot_name
                             : m.name.empty()      ? "robot" + std::to_string(i + 1)
                                                   : m.name;
    try {
      sim.add_robot(name, e.robot_namespace, std::move(m), x, e.controllers,
                    e.constraints.joint_limits);
    } catch (const std::invalid_argument& err) {
      throw SceneError(where + ": " + err.what());
    } catch (const ControllerError& err) {
      throw SceneError(where + ".controllers: " + err.what());
    }
  }
}

}  // namespace se3
