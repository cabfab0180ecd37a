// The stepper interface, the registry, and the two first-order methods.
#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <stdexcept>

#include "lie/simd.h"
#include "se3_sim/integrate.h"

namespace se3 {

Stepper::Stepper(const Model& model, const StepperOptions& opt)
    : model_(model),
      opt_(opt),
      data_(model),
      tau_(VecX::Zero(model.nv)),
      damping_(VecX::Zero(model.nv)),
      inv_eps_(1.0 / opt.friction_eps) {
  if (!(opt_.friction_eps > 0)) throw std::invalid_argument("friction_eps must be positive");
  if (!opt_.passive_forces) return;
  const int off = model.floating ? 6 : 0;
  for (int i = 1; i <= model.n; ++i) {
    const int k = off + i - 1;
    damping_[k] = model.damping[i];
    if (model.friction[i] != 0) friction_.push_back({k, model.friction[i]});
    has_passive_ = has_passive_ || model.damping[i] != 0 || model.friction[i] != 0;
  }
}

namespace {

// o = base - d qdot - f tanh(qdot / eps) over nv entries: damping on every joint at once (d = 0 on
// the base and the undamped joints), then friction on the joints that have it (list fr of {k, f}).
// base may be null (zero). File-local, so that it is inlined into the time step.
template <class FrictionList>
void add_passive(int nv, const double* base, const double* d, const double* w,
                 const FrictionList& fr, double inv_eps, double* o) {
  int k = 0;
  if (base) {
    for (; k + 2 <= nv; k += 2) {
      detail::store2(o + k, detail::load2(base + k) - detail::load2(d + k) * detail::load2(w + k));
    }
    if (k < nv) o[k] = base[k] - d[k] * w[k];
  } else {
    for (; k < nv; ++k) o[k] = -d[k] * w[k];
  }
  for (const auto& j : fr) o[j.k] -= j.f * std::tanh(w[j.k] * inv_eps);
}

}  // namespace

void Stepper::passive_forces(const VecX& v, VecX& out) const {
  out.resize(model_.nv);
  add_passive(model_.nv, nullptr, damping_.data(), v.data(), friction_, inv_eps_, out.data());
}

const VecX& Stepper::acceleration(const SE3& base, const VecX& q, const VecX& v,
                                  const VecX& tau_cmd) {
  const VecX* tau = &tau_cmd;
  if (has_passive_) {  // tau_ = tau_cmd + passive forces
    add_passive(model_.nv, tau_cmd.data(), damping_.data(), v.data(), friction_, inv_eps_,
                tau_.data());
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
    const int n = model_.n, nv = model_.nv;
    if (model_.floating) advance_base(x.base, h * x.v.head<6>());
    detail::axpy(n, h, x.v.data() + (nv - n), x.q.data());
    detail::axpy(nv, h, a.data(), x.v.data());
    StepInfo info;
    info.evaluations = 1;
    info.substeps = 1;
    return info;
  }
};

/// Semi-implicit (symplectic) Euler: rates first, then the pose with the new rates.
class SymplecticEulerStepper final : public Stepper {
 public:
  using Stepper::Stepper;
  std::string name() const override { return "symplectic_euler"; }
  int order() const override { return 1; }
  StepInfo step(State& x, const VecX& tau_cmd, double h) override {
    const VecX& a = acceleration(x.base, x.q, x.v, tau_cmd);
    const int n = model_.n, nv = model_.nv;
    detail::axpy(nv, h, a.data(), x.v.data());
    if (model_.floating) advance_base(x.base, h * x.v.head<6>());
    detail::axpy(n, h, x.v.data() + (nv - n), x.q.data());
    StepInfo info;
    info.evaluations = 1;
    info.substeps = 1;
    return info;
  }
};

struct Entry {
  std::string description;
  StepperFactory factory;
};

struct Registry {
  std::mutex mutex;
  std::map<std::string, Entry> entries;
  Registry() {
    entries["euler"] = {"explicit Euler on SE(3) (order 1)",
                        [](const Model& m, const StepperOptions& o) -> std::unique_ptr<Stepper> {
                          return std::make_unique<EulerStepper>(m, o);
                        }};
    entries["symplectic_euler"] = {
        "semi-implicit Euler: v first, then f <- f exp(h V0), q <- q + h qdot (order 1)",
        [](const Model& m, const StepperOptions& o) -> std::unique_ptr<Stepper> {
          return std::make_unique<SymplecticEulerStepper>(m, o);
        }};
    entries["rkmk4"] = {"classical Runge-Kutta 4 in Runge-Kutta-Munthe-Kaas form (order 4)",
                        [](const Model& m, const StepperOptions& o) {
                          return make_rkmk_stepper(tableau_rk4(), m, o);
                        }};
    entries["rkmk45"] = {
        "Dormand-Prince 5(4) in Runge-Kutta-Munthe-Kaas form, adaptive with error control (tol)",
        [](const Model& m, const StepperOptions& o) {
          return make_rkmk_stepper(tableau_dormand_prince45(), m, o);
        }};
  }
};

// Built-ins are registered in the constructor, not by static objects in other translation
// units (a static library drops those when nothing references them).
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
    const auto it = r.entries.find(name);
    if (it != r.entries.end()) f = it->second.factory;
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
  r.entries[name] = {description, std::move(factory)};
}

std::vector<std::string> stepper_names() {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  std::vector<std::string> names;
  for (const auto& kv : r.entries) names.push_back(kv.first);
  return names;
}

std::string stepper_description(const std::string& name) {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  const auto it = r.entries.find(name);
  return it == r.entries.end() ? std::string() : it->second.description;
}

}  // namespace se3
