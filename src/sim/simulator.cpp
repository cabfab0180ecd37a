// The Simulator (sim.h): stepping with commands, passive forces and the divergence guard.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <stdexcept>

#include "lie/simd.h"
#include "object_parts.h"
#include "se3_sim/lie/format.h"
#include "se3_sim/model/limits.h"
#include "se3_sim/sim/ground.h"
#include "se3_sim/sim/scene_collision.h"
#include "se3_sim/sim/sim.h"

namespace se3 {

namespace {
constexpr std::uint64_t kNever = std::numeric_limits<std::uint64_t>::max();

// The mimic joints of x where their leaders put them (leaders first: chains in order).
void align_mimics(const Model& m, State& x) {
  for (const JointMimic& mm : m.mimics) {
    x.q[m.idx_q(mm.joint)] = mm.multiplier * x.q[m.idx_q(mm.leader)] + mm.offset;
    x.v[m.idx_v(mm.joint)] = mm.multiplier * x.v[m.idx_v(mm.leader)];
  }
  wrap_continuous_joints(m, x.q);
}
}  // namespace

KineticEnergyBound::KineticEnergyBound(const Model& model)
    : floating_(model.floating), body_(model.n + 1), path_(model.n + 1) {
  for (int i = 0; i <= model.n; ++i) {
    Body& b = body_[i];
    const Inertia& I = model.inertia[i];
    b.mass = I.m;
    b.com = I.m > 0 ? I.h.norm() / I.m : 0.0;
    b.trace = I.I.trace();
    if (i == 0) continue;
    b.parent = model.parent[i];
    b.iv = model.idx_v(i);
    b.iq = model.idx_q(i);
    const Vec6 S = model.joints[i].motion_subspace().col(0);  // a one-dof joint
    b.turn = S.head<3>().norm();
    b.slide = S.tail<3>().norm();
    b.offset = model.X_tree[i].p.norm();
  }
}

double KineticEnergyBound::operator()(const VecX& q, const VecX& v) {
  double w0 = 0, v0 = 0, T = 0;
  if (floating_) {
    w0 = v.head<3>().norm();
    v0 = v.segment<3>(3).norm();
    const Body& b = body_[0];
    const double vc = v0 + w0 * b.com;
    T = b.mass * vc * vc + b.trace * w0 * w0;
  }
  for (size_t i = 1; i < body_.size(); ++i) {
    const Body& b = body_[i];
    const Path& up = path_[b.parent];
    Path& p = path_[i];
    const double qd = std::abs(v[b.iv]);
    p.L = up.L + b.offset + b.slide * std::abs(q[b.iq]);
    p.W = up.W + b.turn * qd;
    p.P = up.P + b.turn * qd * p.L;
    p.S = up.S + b.slide * qd;
    const double r = p.L + b.com;  // base origin to the centre of mass, at most
    // sum_j |qdot_j| (r - L_j) over the revolute joints j on the path: r W - P.
    const double vc = v0 + w0 * r + (r * p.W - p.P) + p.S;
    const double w = w0 + p.W;
    T += b.mass * vc * vc + b.trace * w * w;
  }
  return 0.5 * T;
}

Simulator::Simulator(Model model, const State& initial, const SimConfig& config)
    : model_(std::make_unique<Model>(std::move(model))),
      config_(config),
      diag_(*model_),
      energy_bound_(*model_),
      initial_(initial),
      command_(VecX::Zero(model_->nv)),
      actuation_(VecX::Zero(model_->nv)),
      forces_(VecX::Zero(model_->nv)),
      command_until_(model_->nv, kNever) {
  wrenches_.reserve(kMaxLinkWrenches);
  if (const std::string why = dt_problem(config_.dt); !why.empty()) {
    throw std::invalid_argument("dt " + three_figures(config_.dt) + " s " + why);
  }
  if (config_.guard.energy_check_every < 1) config_.guard.energy_check_every = 1;
  stepper_ = make_stepper(config_.integrator, *model_, config_.stepper);
  for (int i = 1; config_.stepper.passive_forces && i <= model_->n; ++i) {
    if (model_->damping[i] != 0) damped_.push_back({model_->idx_v(i), model_->damping[i]});
    if (model_->friction[i] != 0) rubbing_.push_back({model_->idx_v(i), model_->friction[i]});
  }
  set_initial_state(initial);
  if (config_.mimic_joints && !model_->mimics.empty()) rebuild_constraints();
  reset();
  // An empty robot (a scene of objects alone: fixed, massless, no joints) is no model.
  if (model_->n > 0 || model_->floating || model_->total_mass() > 0) {
    robot_name_ = model_->name.empty() ? "robot" : model_->name;
  }
}

Simulator::~Simulator() = default;

CollisionModel* Simulator::collider() const {
  return scene_collision_ ? &scene_collision_->model : collision_.get();
}

const std::vector<Contact>& Simulator::contacts() const {
  return collision_data_.contacts;
}

const std::vector<CollisionObject>* Simulator::contact_objects() const {
  const CollisionModel* c = collider();
  return c ? &c->objects() : nullptr;
}

void Simulator::set_scene_collision(SceneCollision&& collision) {
  int robot_frames = 0;
  for (const auto& r : extra_) robot_frames += r->model->n + 1;
  if (collision.robot_bodies != model_->n + 1 ||
      collision.free_objects != static_cast<int>(bodies_.size()) ||
      (collision.robot_frames != 0 && collision.robot_frames != robot_frames)) {
    throw std::invalid_argument(
        "scene collision frames do not match the simulator's robot and "
        "free objects");
  }
  scene_collision_ = std::make_unique<SceneCollision>(std::move(collision));
  // The contact spheres are in the scene collision now: the constraint system keeps the
  // ground only as the reason for velocity-level steps.
  spec_.contacts.clear();
  spec_.contacts_from_collisions = false;
  frame_poses_.assign(model_->n + 1 + bodies_.size() + collision.robot_frames, SE3());
  free_poses_.assign(bodies_.size(), SE3());
  collision_data_.contacts.reserve(256);
  rebuild_constraints();
  reset();
}

void Simulator::set_initial_state(const State& s) {
  if (s.q.size() != model_->n || s.v.size() != model_->nv) {
    throw std::invalid_argument("state sizes do not match the model");
  }
  if (!s.finite()) throw std::invalid_argument("initial state is not finite");
  initial_ = s;
  wrap_continuous_joints(*model_, initial_.q);
  if (config_.mimic_joints) align_mimics(*model_, initial_);
}

void Simulator::set_state(const State& s) {
  if (s.q.size() != model_->n || s.v.size() != model_->nv) {
    throw std::invalid_argument("state sizes do not match the model");
  }
  // Refused here, not left to the guard: the guard checks what a step can change, and no step
  // changes a fixed base's pose.
  if (!s.finite())
    throw std::invalid_argument("state is not finite (or its rotation not orthonormal)");
  state_.base = s.base;
  state_.q = s.q;
  wrap_continuous_joints(*model_, state_.q);
  state_.v = s.v;
  last_good_ = state_;
  last_checked_ = state_;
  last_checked_time_ = time_;
  last_checked_steps_ = steps_;
  stepper_->restart();
  passive_power_ = passive_power();
}

void Simulator::reset() {
  state_ = initial_;
  last_good_ = initial_;
  last_checked_ = initial_;
  time_ = last_checked_time_ = 0;
  steps_ = substeps_ = rejected_ = evaluations_ = 0;
  velocity_level_steps_ = events_ = 0;
  last_checked_steps_ = 0;
  steps_to_energy_check_ = config_.guard.energy_check_every;
  failure_.clear();
  clear_command();
  actuation_.setZero();
  wrenches_.clear();
  if (controllers_) controllers_->reset(state_);
  // The constraint solver keeps warm starts between steps: start again from the system as set,
  // so that the same commands after a reset give the same states.
  if (constraints_start_) constraints_ = std::make_unique<ConstraintSystem>(*constraints_start_);
  if (CollisionModel* c = collider()) c->reset_broad_phase();
  stepper_->restart();
  refresh_reference();
  W_ = W_checked_ = 0;
  passive_power_ = passive_power();
  reset_objects();
  if (!extra_.empty()) reset_extra_robots();
}

void Simulator::refresh_reference() {
  T0_ = se3::kinetic_energy(*model_, diag_, state_.base, state_.q, state_.v);
  U0_ = se3::potential_energy(*model_, diag_, state_.base, state_.q);
  const double m = model_->total_mass();
  E_ref_ = std::max(T0_, 0.5 * m) + m * model_->gravity.norm();
  if (!(E_ref_ > 0)) E_ref_ = 1;
  // The energy gravity exchanges when the robot turns over: M |g| L, L the largest distance of
  // a body origin from the centre of mass (at least kMinEnergyLength).
  const Vec3 c = se3::center_of_mass(*model_, diag_, state_.base, state_.q);
  forward_kinematics(*model_, diag_, state_.base, state_.q);
  double L = kMinEnergyLength;
  for (int i = 0; i <= model_->n; ++i) L = std::max(L, (diag_.oMb[i].p - c).norm());
  energy_scale0_ = std::max(T0_, m * model_->gravity.norm() * L);
  if (!std::isfinite(energy_scale0_)) energy_scale0_ = 0;
}

void Simulator::set_integrator(const std::string& name) {
  auto s = make_stepper(name, *model_, config_.stepper);
  stepper_ = std::move(s);
  config_.integrator = name;
}

double Simulator::set_joint_effort(int i, double effort) {
  if (i < 1 || i > model_->n) throw std::out_of_range("joint index out of range");
  if (!std::isfinite(effort)) throw std::invalid_argument("effort is not finite");
  const double lim = model_->effort[i];
  if (std::isfinite(lim) && lim > 0) effort = std::min(lim, std::max(-lim, effort));
  const int k = model_->idx_v(i);
  command_[k] = effort;
  command_until_[k] = command_expiry();
  next_expiry_ = std::min(next_expiry_, command_until_[k]);
  return effort;
}

void Simulator::set_base_wrench(const Vec6& wrench) {
  if (!wrench.allFinite()) throw std::invalid_argument("base wrench is not finite");
  if (!model_->floating) return;
  command_.head<6>() = wrench;
  const std::uint64_t until = command_expiry();
  for (int k = 0; k < 6; ++k) command_until_[k] = until;
  next_expiry_ = std::min(next_expiry_, until);
}

void Simulator::set_command_timeout(double seconds) {
  command_timeout_ = seconds > 0 ? seconds : std::numeric_limits<double>::infinity();
}

std::uint64_t Simulator::command_expiry() const {
  if (!std::isfinite(command_timeout_)) return kNever;
  const double n = std::ceil(command_timeout_ / config_.dt - 1e-9);
  if (!(n < 1e18)) return kNever;
  return steps_ + static_cast<std::uint64_t>(std::max(1.0, n));
}

void Simulator::set_controllers(const std::vector<ControllerSpec>& specs) {
  if (specs.empty()) {
    controllers_.reset();
    return;
  }
  auto c = std::make_unique<ControllerSet>(*model_, specs);
  c->reset(state_);
  controllers_ = std::move(c);
  actuation_ = command_;
  held_ = VecX::Zero(model_->nv);
}

void Simulator::apply_link_wrench(int link, const Vec3& point, const Vec6& wrench,
                                  double duration) {
  apply_robot_link_wrench(0, link, point, wrench, duration);
}

void Simulator::apply_robot_link_wrench(int k, int link, const Vec3& point, const Vec6& wrench,
                                        double duration) {
  if (k < 0 || k >= robot_count()) {
    throw std::invalid_argument("robot index " + std::to_string(k) + " out of range (" +
                                std::to_string(robot_count()) + " robots)");
  }
  if (link < 0 || link >= static_cast<int>(robot_model(k).links.size())) {
    throw std::invalid_argument("link index out of range");
  }
  if (!point.allFinite() || !wrench.allFinite() || std::isnan(duration)) {
    throw std::invalid_argument("wrench, point or duration is not finite");
  }
  if (static_cast<int>(wrenches_.size()) >= kMaxLinkWrenches) {
    throw std::invalid_argument("already " + std::to_string(kMaxLinkWrenches) +
                                " link wrenches act; clear some first");
  }
  LinkWrench w;
  w.robot = k;
  w.link = link;
  w.point = point;
  w.wrench = wrench;
  if (duration >= 0) {
    const double n = std::ceil(duration / config_.dt - 1e-9);
    w.steps_left = n < 1e18 ? static_cast<std::int64_t>(std::max(0.0, n)) : -1;
    if (w.steps_left == 0) return;  // acts on no step
  }
  wrenches_.push_back(w);
}

void Simulator::clear_link_wrenches(int link) {
  if (link < 0) {
    wrenches_.clear();
    return;
  }
  wrenches_.erase(
      std::remove_if(wrenches_.begin(), wrenches_.end(),
                     [link](const LinkWrench& w) { return w.robot == 0 && w.link == link; }),
      wrenches_.end());
}

void add_link_wrench_force(const Model& model, const Data& data, int link, const Vec3& point,
                           const Vec6& wrench, VecX& tau) {
  const LinkFrame& L = model.links[link];
  const Vec3 p = (data.oMb[L.body] * L.offset).act(point);
  const Vec3 N = wrench.head<3>(), F = wrench.tail<3>();
  for (int i = L.body; i > 0; i = model.parent[i]) {
    // S^T of the wrench about the body origin, S = [s_w; s_v] the joint's motion subspace in
    // the body frame turned into the world.
    const SE3& X = data.oMb[i];
    const Vec6 S = Vec6::Unit(model.joints[i].axis());  // a one-dof joint
    const Vec3 w = X.R * S.head<3>(), u = X.R * S.tail<3>();
    tau[model.idx_v(i)] += w.dot(N + (p - X.p).cross(F)) + u.dot(F);
  }
  if (model.floating) {
    const SE3& B = data.oMb[0];
    tau.head<3>() += B.R.transpose() * (N + (p - B.p).cross(F));
    tau.segment<3>(3) += B.R.transpose() * F;
  }
}

std::vector<std::string> Simulator::set_links_without_gravity(
    const std::vector<std::string>& links) {
  std::vector<std::string> not_applied;
  weightless_.clear();
  for (const std::string& name : links) {
    const int k = model_->link_index(name);
    if (k < 0 || model_->links[k].fixed) {
      not_applied.push_back(name);
      continue;
    }
    const LinkFrame& L = model_->links[k];
    const Inertia& I = model_->inertia[L.body];
    if (!(I.m > 0)) continue;  // nothing to weigh
    LinkWrench w;
    w.link = k;
    w.point = L.offset.inverse().act(I.h / I.m);  // the body's centre of mass, link frame
    w.wrench.tail<3>() = -I.m * model_->gravity;
    weightless_.push_back(w);
  }
  return not_applied;
}

void Simulator::add_link_wrenches(VecX& tau) {
  forward_kinematics(*model_, diag_, state_.base, state_.q);
  for (const LinkWrench& w : weightless_) {
    add_link_wrench_force(*model_, diag_, w.link, w.point, w.wrench, tau);
  }
  for (const LinkWrench& w : wrenches_) {
    if (w.robot == 0) add_link_wrench_force(*model_, diag_, w.link, w.point, w.wrench, tau);
  }
}

bool Simulator::has_link_wrenches(int k) const {
  for (const LinkWrench& w : wrenches_) {
    if (w.robot == k) return true;
  }
  return false;
}

const VecX& Simulator::step_forces() {
  if (steps_ >= next_expiry_) {  // one comparison per step unless a command runs out now
    next_expiry_ = kNever;
    for (int k = 0; k < model_->nv; ++k) {
      if (steps_ >= command_until_[k]) {
        command_[k] = 0;
        command_until_[k] = kNever;
      }
      next_expiry_ = std::min(next_expiry_, command_until_[k]);
    }
  }
  const bool wrenched = !weightless_.empty() || has_link_wrenches(0);
  if (!controllers_ && !wrenched) return command_;
  const VecX* tau = &command_;
  if (controllers_) {
    if (control_every_ <= 1 || steps_ % control_every_ == 0) {
      actuation_ = command_;
      controllers_->update(state_, time_, config_.dt * control_every_, actuation_);
      if (control_every_ > 1) held_ = actuation_ - command_;  // sized in set_controllers
    } else {
      actuation_ = command_ + held_;
    }
    tau = &actuation_;
  }
  if (!wrenched) return *tau;
  forces_ = *tau;
  add_link_wrenches(forces_);
  return forces_;
}

void Simulator::set_objects(const std::vector<SceneObject>& objects) {
  place_objects(objects, true);
  rebuild_constraints();
  reset();
}

void Simulator::set_objects(const std::vector<SceneObject>& objects, SceneCollision&& collision) {
  place_objects(objects, false);
  set_scene_collision(std::move(collision));
}

void Simulator::place_objects(const std::vector<SceneObject>& objects, bool own_collision) {
  std::vector<ObjectBody> bodies;
  for (size_t j = 0; j < objects.size(); ++j) {
    const SceneObject& o = objects[j];
    if (!o.pose.p.allFinite() || !is_rotation(o.pose.R) || !o.twist.allFinite()) {
      throw std::invalid_argument("object '" + o.name + "': pose or twist is not finite");
    }
    if (o.is_static) continue;
    if (!(o.mass > 0) || !std::isfinite(o.mass) || !(o.inertia.m > 0)) {
      throw std::invalid_argument("object '" + o.name + "': a free object needs a mass > 0");
    }
    ObjectBody b;
    b.index = static_cast<int>(j);
    b.model = std::make_unique<Model>();
    b.model->floating = true;
    b.model->name = o.name;
    b.model->start_with_base(o.name, o.inertia);
    b.model->gravity = model_->gravity;
    b.model->finalize();
    try {
      b.model->validate();
    } catch (const ModelError&) {
      throw std::invalid_argument("object '" + o.name +
                                  "': a free object needs a mass and a positive-definite "
                                  "inertia (check the shape's size and the mass)");
    }
    b.initial = State(*b.model);
    b.initial.base = o.pose;
    b.initial.v = o.twist;
    b.size = smallest_extent(o.shape);
    bodies.push_back(std::move(b));
  }
  object_specs_ = objects;
  bodies_ = std::move(bodies);
  scene_collision_.reset();  // its frames were for the objects before
  body_models_.clear();
  body_states_.clear();
  body_a_.clear();
  collision_.reset();
  for (const ObjectBody& b : bodies_) {
    body_models_.push_back(b.model.get());
    body_states_.push_back(b.initial);
    body_a_.push_back(VecX::Zero(6));
  }
  contacts_fresh_ = false;
  body_last_good_ = body_states_;
  if (!own_collision) return;
  std::vector<CollisionObject> colliders;
  for (size_t j = 0, free_index = 0; j < object_specs_.size(); ++j) {
    const SceneObject& o = object_specs_[j];
    const int frame =
        o.is_static ? CollisionObject::kWorld : model_->n + 1 + static_cast<int>(free_index++);
    colliders.push_back(object_collider(o, frame));
  }
  if (spec_.ground) {  // the plane n.x = offset, solid below: z <= 0 of its shape frame
    CollisionObject g;
    g.name = "ground";
    g.halfspace = true;
    g.group = 1;
    g.mu = spec_.mu;
    g.restitution = spec_.options.restitution;
    const Vec3 n = spec_.ground_normal.normalized();
    Vec3 t1, t2;
    tangent_basis(n, t1, t2);
    g.placement.R.col(0) = t1;
    g.placement.R.col(1) = t2;
    g.placement.R.col(2) = n;
    g.placement.p = spec_.ground_offset * n;
    colliders.push_back(g);
  }
  if (!bodies_.empty()) {
    CollisionOptions copt;
    copt.margin = spec_.options.margin;
    collision_ = std::make_unique<CollisionModel>(std::move(colliders), copt);
    frame_poses_.assign(model_->n + 1 + bodies_.size(), SE3());
    collision_data_.contacts.reserve(64 * bodies_.size());
  }
}

void Simulator::reset_objects() {
  objects_.resize(object_specs_.size());
  for (size_t j = 0; j < object_specs_.size(); ++j) {
    ObjectState& s = objects_[j];
    s.name = object_specs_[j].name;
    s.is_static = object_specs_[j].is_static;
    s.pose = object_specs_[j].pose;
    s.twist = s.is_static ? Vec6::Zero() : object_specs_[j].twist;
  }
  for (size_t j = 0; j < bodies_.size(); ++j) {
    body_states_[j] = bodies_[j].initial;
    body_last_good_[j] = bodies_[j].initial;
  }
  penetration_ = penetration_max_ = 0;
  contacts_fresh_ = false;
  fast_steps_ = 0;
  fast_step_warning_.clear();
}

void Simulator::note_fast_step(size_t j, double moved) {
  if (fast_steps_++ > 0) return;
  char buf[200];
  std::snprintf(buf, sizeof buf,
                "' moved %.3g m in one step at t = %.6g s, more than its size (%.3g m): it may "
                "pass through thin objects unseen (tunnelling); a smaller dt avoids it",
                moved, time_ + config_.dt, bodies_[j].size);
  fast_step_warning_ = "object '" + object_specs_[bodies_[j].index].name + buf;
}

double Simulator::collide_objects() {
  CollisionModel* cm = collider();
  if (!cm) return 0;
  if (scene_collision_) {
    // The constraint system's forward kinematics when there is one: the step's rows reuse it.
    const std::vector<SE3>* oMb = &diag_.oMb;
    if (constraints_) {
      oMb = &constraints_->body_poses(state_.base, state_.q);
    } else {
      forward_kinematics(*model_, diag_, state_.base, state_.q);
    }
    for (size_t j = 0; j < bodies_.size(); ++j) free_poses_[j] = body_states_[j].base;
    scene_frame_poses(*oMb, free_poses_, frame_poses_);
    if (scene_collision_->robot_frames > 0) {  // the other robots' bodies after the objects
      size_t f = frame_poses_.size();
      frame_poses_.resize(f + scene_collision_->robot_frames);  // within its capacity
      for (const auto& r : extra_) {
        forward_kinematics(*r->model, r->diag, r->state.base, r->state.q);
        for (int i = 0; i <= r->model->n; ++i) frame_poses_[f++] = r->diag.oMb[i];
      }
    }
  } else {
    for (size_t j = 0; j < bodies_.size(); ++j) {
      frame_poses_[model_->n + 1 + j] = body_states_[j].base;
    }
  }
  collide(*cm, collision_data_, frame_poses_);
  double deepest = 0;
  for (const Contact& c : collision_data_.contacts) deepest = std::max(deepest, c.depth);
  contacts_fresh_ = true;
  return deepest;
}

std::string Simulator::deep_penetration_warning() {
  if (!collider()) return "";
  collide_objects();
  const ConstraintOptions& o = spec_.options;
  const double reach = o.slop + (o.erp > 0 ? o.max_correction_velocity * config_.dt / o.erp : 0);
  const Contact* deepest = nullptr;
  for (const Contact& c : collision_data_.contacts) {
    if (c.depth > std::max(o.margin, reach) && (!deepest || c.depth > deepest->depth)) {
      deepest = &c;
    }
  }
  if (!deepest) return "";
  const std::vector<CollisionObject>& objects = collider()->objects();
  char buf[160];
  std::snprintf(buf, sizeof buf, "%.3g m deep", deepest->depth);
  std::string what = "'" + objects[deepest->a].name + "' and '" + objects[deepest->b].name +
                     "' interpenetrate " + buf;
  std::snprintf(buf, sizeof buf,
                ": they are pushed apart at no more than %g m/s (constraint_options: "
                "max_correction_velocity), taking about %.2g s",
                o.max_correction_velocity, deepest->depth / o.max_correction_velocity);
  return what + buf;
}

void Simulator::rebuild_constraints() {
  constraints_.reset();
  constraints_start_.reset();
  ConstraintSpec spec = spec_;
  if (config_.mimic_joints && !model_->mimics.empty()) {
    const std::vector<BilateralConstraint> mimics = mimic_constraints(*model_);
    spec.bilateral.insert(spec.bilateral.end(), mimics.begin(), mimics.end());
    align_mimics(*model_, initial_);  // the mimic joints start where their leaders put them
  }
  if (spec.empty() && bodies_.empty() && !scene_collision_) return;
  constraints_ = std::make_unique<ConstraintSystem>(*model_, spec);
  if (!bodies_.empty()) {
    constraints_->set_free_bodies(body_models_, static_cast<int>(16 * bodies_.size()));
  }
  if (scene_collision_) {
    std::vector<bool> limits;
    for (const auto& r : extra_)
      limits.push_back(r->constraints && r->constraints->spec().joint_limits);
    constraints_->set_free_bodies(
        body_models_, 64 + static_cast<int>(16 * (bodies_.size() + extra_.size())),
        coupled_robots() ? extra_robot_models() : std::vector<const Model*>{}, limits);
  }
  constraints_->anchor(initial_);
  State x = initial_;
  constraints_->project(x);
  initial_ = x;
  constraints_start_ = std::make_unique<ConstraintSystem>(*constraints_);
}

void Simulator::set_constraints(const ConstraintSpec& spec) {
  spec_ = spec;
  if (!object_specs_.empty()) {
    const std::vector<SceneObject> objects = object_specs_;
    set_objects(objects);  // the ground and its mu may have changed: a new collision model
    return;
  }
  rebuild_constraints();
  reset();
}

void Simulator::set_constraints(const ConstraintSpec& spec, SceneCollision&& collision) {
  spec_ = spec;
  if (!object_specs_.empty()) {
    const std::vector<SceneObject> objects = object_specs_;
    set_objects(objects, std::move(collision));  // the objects placed anew, as set_constraints
    return;
  }
  set_scene_collision(std::move(collision));  // rebuilds the constraints and resets
}

double Simulator::constraint_error() {
  return constraints_ ? constraints_->error(state_) : std::numeric_limits<double>::quiet_NaN();
}

void Simulator::clear_command() {
  command_.setZero();
  std::fill(command_until_.begin(), command_until_.end(), kNever);
  next_expiry_ = kNever;
}

void Simulator::applied_joint_efforts(VecX& out) {
  out.resize(model_->n);
  const PassiveForces& passive = stepper_->passive();
  // The command as it stands (a controlled joint's effort as its controller set it last step),
  // plus the passive forces.
  for (int i = 1; i <= model_->n; ++i) {
    const int k = model_->idx_v(i);
    const double cmd = controllers_ && controllers_->controls(i) ? actuation_[k] : command_[k];
    out[i - 1] = passive.at(k, cmd, state_.v[k]);
  }
}

namespace {

// x . y for the short vectors of a step (Eigen's dynamic-size dot costs more in set-up).
double dot(int n, const double* x, const double* y) {
  double a = 0, b = 0;
  int k = 0;
  for (; k + 2 <= n; k += 2) a += x[k] * y[k], b += x[k + 1] * y[k + 1];
  if (k < n) a += x[k] * y[k];
  return a + b;
}

// to = from, for states of the same model (no resize check, no memcpy call for a dozen numbers).
void save(const State& from, State& to) {
  to.base = from.base;
  detail::copy(static_cast<int>(from.q.size()), from.q.data(), to.q.data());
  detail::copy(static_cast<int>(from.v.size()), from.v.data(), to.v.data());
}

}  // namespace

namespace {

// A free object's state finite (pose and twist) with every twist component within lim.
bool object_ok(const State& b, double lim) {
  bool ok = detail::all_finite(3, b.base.p.data());
  for (int k = 0; k < 6; ++k) ok &= std::abs(b.v[k]) <= lim;
  return ok && is_rotation(b.base.R);
}

}  // namespace

// State::finite() with every rate within max_rate, in one pass over each vector; the same for
// every free object (its pose finite, no twist component above max_rate).
bool Simulator::rates_ok() const {
  // A NaN fails the comparison and an infinity exceeds the limit.
  const double lim = config_.guard.max_rate;
  const double* v = state_.v.data();
  bool ok = detail::all_finite(model_->n, state_.q.data());
  for (int k = 0; k < model_->nv; ++k) ok &= std::abs(v[k]) <= lim;
  for (const State& b : body_states_) ok &= object_ok(b, lim);
  if (!model_->floating) return ok;  // a fixed base does not move: no stepper writes it
  return ok && detail::all_finite(3, state_.base.p.data()) && is_rotation(state_.base.R);
}

bool Simulator::energy_ok() {
  const double limit = config_.guard.energy_growth * E_ref_;
  // The bound settles the check in practice (with a factor 2 to spare for rounding), and then
  // the exact energy would pass too; the exact energy (a kinematics pass) only when it does not.
  const double bound = energy_bound_(state_.q, state_.v);
  if (std::isfinite(bound) && bound <= 0.5 * limit) return true;
  const double T = se3::kinetic_energy(*model_, diag_, state_.base, state_.q, state_.v);
  return std::isfinite(T) && T <= limit;
}

// The guard (GuardOptions): every step the state must be finite with no rate above max_rate,
// every energy_check_every-th step since the reset also the kinetic energy below its bound.
// Invariant between steps: last_good_ is the state, and time and step count are its.
bool Simulator::step() {
  if (!failure_.empty()) return false;
  const bool coupled = !extra_.empty() && coupled_robots();
  if (!extra_.empty() && !coupled && !step_extra_robots()) return false;
  if (coupled) prepare_coupled_robots();
  const VecX& tau = step_forces();
  const int nv = model_->nv;
  const double P0 = dot(nv, tau.data(), state_.v.data()) + passive_power_;  // at the start
  StepInfo info;
  if (constraints_) {
    ContactBodies cb;
    if (!bodies_.empty() || scene_collision_) {
      for (size_t j = 0; j < bodies_.size(); ++j) {
        free_body_acceleration(*bodies_[j].model, body_states_[j], body_a_[j]);
      }
      if (!contacts_fresh_) collide_objects();
      cb.models = &body_models_;
      cb.states = &body_states_;
      cb.a_free = &body_a_;
      cb.contacts = &collision_data_.contacts;
      cb.objects = &collider()->objects();
      if (coupled) {
        cb.robot_states = &extra_states_;
        cb.robot_a_free = &extra_a_;
      }
    }
    info = constrained_step(*constraints_, *stepper_, state_, tau, config_.dt, cb);
    if (coupled && info.ok) finish_coupled_robots(info);
  } else {
    info = stepper_->step(state_, tau, config_.dt);
  }
  evaluations_ += info.evaluations;
  substeps_ += info.substeps;
  rejected_ += info.rejected;
  const bool energy_step = steps_to_energy_check_ == 1;
  if (!(info.ok && rates_ok() && (!energy_step || energy_ok()))) {
    roll_back(info);
    return false;
  }
  if (constraints_) {
    penetration_ = constraints_->report().penetration;
    if (!bodies_.empty() || scene_collision_) {
      penetration_ = std::max(penetration_, collide_objects());
      for (size_t j = 0; j < bodies_.size(); ++j) {
        ObjectState& o = objects_[bodies_[j].index];
        o.pose = body_states_[j].base;
        o.twist = body_states_[j].v;
        save(body_states_[j], body_last_good_[j]);
        const double moved = body_states_[j].v.tail<3>().norm() * config_.dt;
        if (moved > bodies_[j].size) note_fast_step(j, moved);
      }
    }
    penetration_max_ = std::max(penetration_max_, penetration_);
  }
  ++steps_;
  if (info.velocity_level) ++velocity_level_steps_;
  events_ += static_cast<std::uint64_t>(info.events);
  time_ += config_.dt;
  passive_power_ = passive_power();
  W_ += 0.5 * config_.dt * (P0 + dot(nv, tau.data(), state_.v.data()) + passive_power_);
  save(state_, last_good_);
  for (const auto& r : extra_) save(r->state, r->last_good);
  if (!wrenches_.empty()) count_down_link_wrenches();
  if (energy_step) {
    save(state_, last_checked_);
    W_checked_ = W_;
    last_checked_time_ = time_;
    last_checked_steps_ = steps_;
    steps_to_energy_check_ = config_.guard.energy_check_every;
  } else {
    --steps_to_energy_check_;
  }
  return true;
}

// A failed step: says why, and goes back to the last good state (the one before the step), or
// to the last checked one when the energy check failed (the states since are suspect).
void Simulator::roll_back(const StepInfo& info) {
  std::string why;
  bool to_checked = false;
  if (!info.ok) {
    why = info.reason;
  } else if (!state_.finite()) {
    why = "non-finite state";
  } else if (const int j = first_bad_object(); j >= 0) {
    const State& b = body_states_[j];
    const std::string& name = object_specs_[bodies_[j].index].name;
    if (!b.base.p.allFinite() || !is_rotation(b.base.R) || !b.v.allFinite()) {
      why = "object '" + name + "': non-finite pose or twist";
    } else {
      why = "object '" + name + "': a rate of " + three_figures(b.v.cwiseAbs().maxCoeff()) +
            " exceeds the limit " + three_figures(config_.guard.max_rate);
    }
  } else if (!rates_ok()) {
    why = "a rate of " + num(state_.v.cwiseAbs().maxCoeff()) + " exceeds the limit " +
          num(config_.guard.max_rate);
  } else {
    const double T = se3::kinetic_energy(*model_, diag_, state_.base, state_.q, state_.v);
    to_checked = true;
    why = "kinetic energy " + num(T) + " J exceeds " + num(config_.guard.energy_growth) +
          " x the reference " + num(E_ref_) + " J";
  }
  for (size_t j = 0; j < bodies_.size(); ++j) body_states_[j] = body_last_good_[j];
  if (!extra_.empty()) roll_back_extra_robots();
  contacts_fresh_ = false;
  const State& back = to_checked ? last_checked_ : last_good_;
  state_.base = back.base;
  state_.q = back.q;
  state_.v = back.v;
  if (to_checked) {
    time_ = last_checked_time_;
    steps_ = last_checked_steps_;
    W_ = W_checked_;
  }
  failure_ = "diverged at t = " + num(time_ + config_.dt) + " s with " + stepper_->name() +
             ", dt = " + num(config_.dt) + ": " + why + "; state rolled back to t = " + num(time_) +
             " s";
  stepper_->restart();
  passive_power_ = passive_power();
}

int Simulator::first_bad_object() const {
  for (size_t j = 0; j < body_states_.size(); ++j) {
    if (!object_ok(body_states_[j], config_.guard.max_rate)) return static_cast<int>(j);
  }
  return -1;
}

double Simulator::passive_power() const {
  const double* v = state_.v.data();
  double P = 0;
  for (const PassiveJoint& j : damped_) P -= j.c * v[j.k] * v[j.k];
  for (const PassiveJoint& j : rubbing_) {
    P -= j.c * std::tanh(v[j.k] / config_.stepper.friction_eps) * v[j.k];
  }
  return P;
}

void Simulator::count_down_link_wrenches() {
  size_t keep = 0;
  for (size_t k = 0; k < wrenches_.size(); ++k) {
    LinkWrench& w = wrenches_[k];
    if (w.steps_left > 0) --w.steps_left;
    if (w.steps_left != 0) wrenches_[keep++] = w;
  }
  wrenches_.resize(keep);  // shrinking: no allocation
}

int Simulator::step_n(int k) {
  int done = 0;
  while (done < k && step()) ++done;
  return done;
}

double Simulator::kinetic_energy() {
  return se3::kinetic_energy(*model_, diag_, state_.base, state_.q, state_.v);
}

double Simulator::potential_energy() {
  return se3::potential_energy(*model_, diag_, state_.base, state_.q) - U0_;
}

Vec6 Simulator::momentum() {
  return se3::spatial_momentum(*model_, diag_, state_.base, state_.q, state_.v);
}

std::string Simulator::schemes_used() const {
  const std::string own = stepper_->name();
  if (own == kContactStepper || velocity_level_steps_ == 0) return own;
  if (velocity_level_steps_ == steps_) return kContactStepper;
  return own + "+" + kContactStepper;
}

double Simulator::scene_kinetic_energy() {
  double T = kinetic_energy();
  for (const ObjectBody& b : bodies_) {
    const ObjectState& o = objects_[b.index];
    T += 0.5 * o.twist.dot(object_specs_[b.index].inertia * o.twist);
  }
  return T;
}

double Simulator::scene_potential_energy() {
  double U = potential_energy();
  for (const ObjectBody& b : bodies_) {
    const SceneObject& spec = object_specs_[b.index];
    const ObjectState& o = objects_[b.index];
    const Vec3 c = spec.inertia.m > 0 ? Vec3(spec.inertia.h / spec.inertia.m) : Vec3::Zero();
    const Vec3 now = o.pose.p + o.pose.R * c, then = spec.pose.p + spec.pose.R * c;
    U -= spec.inertia.m * model_->gravity.dot(now - then);
  }
  return U;
}

Vec6 Simulator::scene_momentum() {
  Vec6 h = momentum();
  for (const ObjectBody& b : bodies_) {
    const ObjectState& o = objects_[b.index];
    const Vec6 hb = object_specs_[b.index].inertia * o.twist;  // body frame [angular; linear]
    const Vec3 lin = o.pose.R * hb.tail<3>();
    h.head<3>() += o.pose.R * hb.head<3>() + o.pose.p.cross(lin);
    h.tail<3>() += lin;
  }
  return h;
}

Vec3 Simulator::center_of_mass() {
  return se3::center_of_mass(*model_, diag_, state_.base, state_.q);
}

void Simulator::link_poses(std::vector<SE3>& out) {
  forward_kinematics(*model_, diag_, state_.base, state_.q);
  out.resize(model_->links.size());
  for (size_t k = 0; k < model_->links.size(); ++k) {
    const LinkFrame& L = model_->links[k];
    out[k] = diag_.oMb[L.body] * L.offset;
  }
}

bool uses_scene_collision(const Scene& scene) {
  return !scene.objects.empty() || scene.self_collision ||
         scene.constraints.contacts_from_collisions;
}

std::unique_ptr<Simulator> make_simulator(const Scene& scene, const std::string& urdf_xml) {
  GazeboTags gazebo;  // from the one parse of the URDF
  Model m = scene_model(scene, urdf_xml, &gazebo);
  State x = scene_state(scene, m);
  // The robot's geometry with its meshes, loaded once for the ground placement and the
  // collision model.
  const bool robot = !(urdf_xml.empty() && scene.robot_path.empty());
  std::optional<GeometryModel> geometry;
  if (robot && (uses_scene_collision(scene) || places_on_ground(scene))) {
    geometry = scene_robot_geometry(scene, m, urdf_xml);
  }
  const GeometryModel* g = geometry ? &*geometry : nullptr;
  x.base = base_on_ground(scene, m, x, urdf_xml, g);  // robot_on_ground: its lowest shape on it
  SimConfig cfg;
  cfg.integrator = scene.integrator;
  cfg.dt = scene.dt;
  cfg.stepper.tol = scene.tol;
  cfg.stepper.friction_eps = scene.friction_eps;
  auto sim = std::make_unique<Simulator>(std::move(m), x, cfg);
  add_scene_robots(*sim, scene);  // before the scene collision, which holds their shapes
  const ConstraintSpec spec = scene_constraints(scene, sim->model(), urdf_xml);
  if (!spec.empty()) sim->set_constraints(spec);
  if (uses_scene_collision(scene)) {  // the objects' collision model: the scene collision's
    const GeometryModel none;
    sim->set_objects(scene.objects, scene_collision(scene, &sim->model(), robot ? g : &none,
                                                    urdf_xml, sim->extra_robot_models()));
  } else if (!scene.objects.empty()) {
    sim->set_objects(scene.objects);
  }
  if (!scene.controllers.empty()) sim->set_controllers(scene.controllers);
  set_gazebo_gravity(*sim, gazebo);
  if (!scene.robot_name.empty() || !scene.robot_namespace.empty()) {
    sim->set_robot_name(scene.robot_name.empty() ? sim->robot_name() : scene.robot_name,
                        scene.robot_namespace);
  }
  return sim;
}

}  // namespace se3
