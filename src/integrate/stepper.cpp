// The stepper interface, the passive-force law, the registry, and the two first-order methods.
#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <stdexcept>

#include "lie/simd.h"
#include "se3_sim/integrate/integrate.h"
#include "steppers.h"

namespace se3 {

PassiveForces::PassiveForces(const Model& model, double friction_eps, bool enabled)
    : nv_(model.nv),
      damping_(VecX::Zero(model.nv)),
      friction_(VecX::Zero(model.nv)),
      inv_eps_(1.0 / friction_eps) {
  if (!(friction_eps > 0)) throw std::invalid_argument("friction_eps must be positive");
  if (!enabled) return;
  for (int i = 1; i <= model.n; ++i) {
    const int k = model.idx_v(i);
    damping_[k] = model.damping[i];
    friction_[k] = model.friction[i];
    if (model.friction[i] != 0) rubbing_.push_back({k, model.friction[i]});
    any_ = any_ || model.damping[i] != 0 || model.friction[i] != 0;
  }
}

namespace {

// PassiveForces::apply: damping on every coordinate at once (d = 0 on the base and the undamped
// joints), then friction on the joints that have it. File-local, so that it is inlined into the
// time step (Stepper::acceleration; a public member of a shared library is not).
inline void apply_passive(const PassiveForces& p, const double* base, const double* w, double* o) {
  const int nv = static_cast<int>(p.damping().size());
  const double* d = p.damping().data();
  if (base) {
    for (int k = 0; k < nv; ++k) o[k] = base[k] - d[k] * w[k];
  } else {
    for (int k = 0; k < nv; ++k) o[k] = -d[k] * w[k];
  }
  const double inv_eps = p.inv_eps();
  for (const PassiveForces::Rubbing& j : p.rubbing()) o[j.k] -= j.f * std::tanh(w[j.k] * inv_eps);
}

}  // namespace

void PassiveForces::apply(const double* base, const double* w, double* o) const {
  apply_passive(*this, base, w, o);
}

double PassiveForces::at(int k, double base, double w) const {
  double o = base - damping_[k] * w;
  if (friction_[k] != 0) o -= friction_[k] * std::tanh(w * inv_eps_);
  return o;
}

void PassiveForces::friction(const double* w, double* out) const {
  for (int k = 0; k < nv_; ++k) out[k] = 0;
  for (const Rubbing& j : rubbing_) out[j.k] = -j.f * std::tanh(w[j.k] * inv_eps_);
}

Stepper::Stepper(const Model& model, const StepperOptions& opt)
    : model_(model),
      opt_(opt),
      data_(model),
      tau_(VecX::Zero(model.nv)),
      passive_(model, opt.friction_eps, opt.passive_forces),
      free_base_(model) {}

StepInfo Stepper::velocity_level_step(State& x, const VecX& tau_cmd, double h) {
  const VecX& a = acceleration(x.base, x.q, x.v, tau_cmd);
  const VecX* a_unconstrained = nullptr;
  if (hook_) {  // the hook's constraint forces count as external on the base
    a_unconstrained = &aba(model_, data_, x.base, x.q, x.v, passive_.any() ? tau_ : tau_cmd);
  }
  const VecX& af = free_base_.free_acceleration(data_, x, tau_cmd, a, a_unconstrained);
  detail::axpy(model_.nv, h, af.data(), x.v.data());
  free_base_.advance(data_, x, h);
  StepInfo info;
  info.evaluations = hook_ ? 2 : 1;
  info.substeps = 1;
  return info;
}

void Stepper::passive_forces(const VecX& v, VecX& out) const {
  out.resize(model_.nv);
  passive_.apply(nullptr, v.data(), out.data());
}

const VecX& Stepper::acceleration(const SE3& base, const VecX& q, const VecX& v,
                                  const VecX& tau_cmd) {
  const VecX* tau = &tau_cmd;
  if (passive_.any()) {  // tau_ = tau_cmd + passive forces
    apply_passive(passive_, tau_cmd.data(), v.data(), tau_.data());
    tau = &tau_;
  }
  if (hook_) return hook_->acceleration(base, q, v, *tau);
  return aba(model_, data_, base, q, v, *tau);
}

namespace {

// Base update f <- f exp(h V0), kept orthonormal (rounding in long products of rotations).
inline void advance_base(SE3& f, const Vec6& xi) {
  f = f * exp_se3(xi);
  f.R = reorthonormalize(f.R);
}

/// Explicit (forward) Euler: every part of the state moves with the old rates.
class EulerStepper final : public Stepper {
 public:
  using Stepper::Stepper;
  std::string name() const override { return "euler"; }
  int order() const override { return 1; }
  StepInfo step(State& x, const VecX& tau_cmd, double h) override {
    const VecX& a = acceleration(x.base, x.q, x.v, tau_cmd);
    const int nq = model_.nq, nv = model_.nv;
    if (model_.floating) advance_base(x.base, h * x.v.head<6>());
    // q <- q + h qdot: every joint has nq = nv = 1, its rates after the base's.
    detail::axpy(nq, h, x.v.data() + model_.nv_base(), x.q.data());
    detail::axpy(nv, h, a.data(), x.v.data());
    StepInfo info;
    info.evaluations = 1;
    info.substeps = 1;
    return info;
  }
};

/// Semi-implicit Euler (MuJoCo's name; symplectic only for a constant mass matrix): rates first,
/// then the pose with the new rates.
class SemiImplicitEulerStepper final : public Stepper {
 public:
  using Stepper::Stepper;
  std::string name() const override { return "semi_implicit_euler"; }
  int order() const override { return 1; }
  bool contact_scheme() const override { return true; }
  StepInfo step(State& x, const VecX& tau_cmd, double h) override {
    return velocity_level_step(x, tau_cmd, h);
  }
};

template <class T>
StepperFactory factory_of() {
  return [](const Model& m, const StepperOptions& o) -> std::unique_ptr<Stepper> {
    return std::make_unique<T>(m, o);
  };
}

struct Entry {
  std::string description;
  StepperFactory factory;
  std::string alias_of;  ///< non-empty for an alias: the name it stands for
};

// Every built-in is registered here, in one list (not by static objects in other translation
// units, which a static library drops when nothing references them).
struct Registry {
  std::mutex mutex;
  std::map<std::string, Entry> entries;
  Registry() {
    entries["euler"] = {"explicit Euler on SE(3) (order 1)", factory_of<EulerStepper>(), ""};
    entries["semi_implicit_euler"] = {
        "semi-implicit Euler: v first, then f <- f exp(h V0), q <- q + h qdot (order 1; "
        "symplectic only for a constant mass matrix)",
        factory_of<SemiImplicitEulerStepper>(), ""};
    entries["symplectic_euler"] = {"", nullptr, "semi_implicit_euler"};
    entries[kContactStepper] = {
        "the contact scheme: v* = v + h a, impulses of limits and contact (velocity level), "
        "then f <- f exp(h V0), q <- q + h qdot with the new rates (order 1)",
        detail::make_contact_stepper, ""};
    entries["rkmk4"] = {"classical Runge-Kutta 4 in Runge-Kutta-Munthe-Kaas form (order 4)",
                        [](const Model& m, const StepperOptions& o) {
                          return make_rkmk_stepper(tableau_rk4(), m, o);
                        },
                        ""};
    entries["rkmk45"] = {
        "Dormand-Prince 5(4) in Runge-Kutta-Munthe-Kaas form, adaptive with error control (tol)",
        [](const Model& m, const StepperOptions& o) {
          return make_rkmk_stepper(tableau_dormand_prince45(), m, o);
        },
        ""};
    entries["variational"] = {
        "Lie-group variational integrator (trapezoidal discrete Lagrangian on exp arcs of SE(3)): "
        "implicit, symplectic, momentum-preserving, time-reversible (order 2)",
        detail::make_variational_stepper, ""};
    entries["rk4_euler_angles"] = {
        "baseline: classical RK4 with the base orientation in ZYX Euler angles (singular at "
        "pitch = +-90 deg; order 4 away from it)",
        detail::make_rk4_euler_angles_stepper, ""};
    entries["rk4_quaternion"] = {
        "baseline: classical RK4 with the base orientation as a quaternion, renormalized after "
        "each step (order 4)",
        detail::make_rk4_quaternion_stepper, ""};
  }
  // The entry a name stands for (an alias resolved), or nullptr. Call with the mutex held.
  const Entry* find(const std::string& name, std::string* canonical = nullptr) const {
    auto it = entries.find(name);
    if (it == entries.end()) return nullptr;
    if (!it->second.alias_of.empty()) it = entries.find(it->second.alias_of);
    if (it == entries.end()) return nullptr;
    if (canonical) *canonical = it->first;
    return &it->second;
  }
};

Registry& registry() {
  static Registry r;
  return r;
}

}  // namespace

std::unique_ptr<Stepper> make_stepper(const std::string& name, const Model& model,
                                      const StepperOptions& opt) {
  StepperFactory f;
  {
    Registry& r = registry();
    std::lock_guard<std::mutex> lock(r.mutex);
    if (const Entry* e = r.find(name)) f = e->factory;
  }
  if (!f) {
    std::string known;
    for (const auto& s : stepper_names()) known += (known.empty() ? "" : ", ") + s;
    throw std::invalid_argument("unknown integrator '" + name + "' (known: " + known + ")");
  }
  return f(model, opt);
}

void register_stepper(const std::string& name, const std::string& description,
                      StepperFactory factory) {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  r.entries[name] = {description, std::move(factory), ""};
}

void register_stepper_alias(const std::string& alias, const std::string& name) {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  std::string target;
  if (!r.find(name, &target)) {
    throw std::invalid_argument("alias '" + alias + "' of unknown integrator '" + name + "'");
  }
  r.entries[alias] = {"", nullptr, target};
}

std::vector<std::string> stepper_names() {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  std::vector<std::string> names;
  for (const auto& kv : r.entries) names.push_back(kv.first);
  return names;
}

std::string stepper_canonical_name(const std::string& name) {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  std::string canonical;
  return r.find(name, &canonical) ? canonical : std::string();
}

std::string stepper_description(const std::string& name) {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  const auto it = r.entries.find(name);
  if (it == r.entries.end()) return std::string();
  if (!it->second.alias_of.empty()) return "alias of " + it->second.alias_of;
  return it->second.description;
}

std::string stepper_help() {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  std::map<std::string, std::string> aliases;  // name -> its aliases
  size_t width = 0;
  for (const auto& kv : r.entries) {
    if (kv.second.alias_of.empty()) {
      width = std::max(width, kv.first.size());
    } else {
      std::string& a = aliases[kv.second.alias_of];
      a += (a.empty() ? "" : ", ") + kv.first;
    }
  }
  std::string out;
  for (const auto& kv : r.entries) {
    if (!kv.second.alias_of.empty()) continue;
    out += "  " + kv.first + std::string(width + 2 - kv.first.size(), ' ') + kv.second.description;
    const auto a = aliases.find(kv.first);
    if (a != aliases.end()) out += " [alias: " + a->second + "]";
    out += "\n";
  }
  return out;
}

}  // namespace se3
