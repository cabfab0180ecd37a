// The time-stepping scheme of contact scenes (integrate.h): the registered stepper
// contact_semi_implicit, the position update it shares with the constrained step, and
// constrained_step, which drives the constraint layer's ConstraintSystem (it knows no stepper).
#include <cmath>
#include <limits>
#include <memory>

#include "se3_sim/integrate/integrate.h"
#include "se3_sim/solver/constraints.h"
#include "steppers.h"

namespace se3 {

void free_body_acceleration(const Model& body, const State& x, VecX& a) {
  a.head<3>().setZero();
  a.segment<3>(3) = x.base.R.transpose() * body.gravity;
}

void advance_free_body(const Model& body, State& x, double h) {
  const Vec3 w = x.v.head<3>(), v = x.v.segment<3>(3);
  const Mat3 E = advance_free_pose(x.base, x.v.head<6>(), h).R;
  // (V3) for one body with its frame at its centre of mass: Ad*_E^T [I w; m v] = [E^T I w;
  // E^T m v] (the frame moves along the momentum, so no moment arm), D_00 = diag(I, m).
  const Mat3& I = body.inertia[0].I;
  x.v.segment<3>(3) = E.transpose() * v;
  x.v.head<3>() = I.ldlt().solve(E.transpose() * (I * w));
}

namespace detail {
namespace {

// Without constraints the scheme is the semi-implicit Euler step: v+ = v + h a(x), then the
// positions with v+. With constraints (constrained_step) the impulses enter between the two.
class ContactSemiImplicitStepper final : public Stepper {
 public:
  using Stepper::Stepper;
  std::string name() const override { return kContactStepper; }
  int order() const override { return 1; }
  bool contact_scheme() const override { return true; }
  StepInfo step(State& x, const VecX& tau_cmd, double h) override {
    StepInfo info = velocity_level_step(x, tau_cmd, h);
    info.velocity_level = true;
    return info;
  }
};

}  // namespace

std::unique_ptr<Stepper> make_contact_stepper(const Model& model, const StepperOptions& opt) {
  return std::make_unique<ContactSemiImplicitStepper>(model, opt);
}

}  // namespace detail

bool is_contact_scheme(const std::string& name) {
  const std::string c = stepper_canonical_name(name);
  return c == kContactStepper || c == "semi_implicit_euler";
}

namespace {

// The velocity-level step of the contact scheme: the free velocity (ABA with the passive forces,
// the free base's part by FreeBaseStep), the impulses, then the positions and the base twist.
// The free velocity's acceleration: ABA with the passive forces and without the hook, the free
// base's part by FreeBaseStep (V1).
const VecX& free_acceleration(Stepper& stepper, const State& x, const VecX& tau_cmd) {
  AccelerationHook* const previous = stepper.acceleration_hook();
  stepper.set_acceleration_hook(nullptr);
  const VecX& a = stepper.acceleration(x.base, x.q, x.v, tau_cmd);
  stepper.set_acceleration_hook(previous);
  return stepper.free_base().free_acceleration(stepper.data(), x, tau_cmd, a);
}

// a_free: free_acceleration at x, or nullptr to compute it here.
StepInfo velocity_level_step(ConstraintSystem& constraints, Stepper& stepper, State& x,
                             const VecX& tau_cmd, double h, const ContactBodies& bodies,
                             const ConstraintSystem::StepInput& in, const VecX* a_given) {
  const VecX& a_free = a_given ? *a_given : free_acceleration(stepper, x, tau_cmd);
  StepInfo info;
  info.evaluations = 1;
  info.substeps = 1;
  info.velocity_level = true;
  if (!constraints.velocity_step(x, a_free, h, in)) {
    info.ok = false;
    info.reason = "constraint solve produced a non-finite state";
    return info;
  }
  stepper.free_base().advance(stepper.data(), x, h);
  const size_t nbody = bodies.states ? bodies.states->size() : 0;
  for (size_t j = 0; j < nbody; ++j) {
    advance_free_body(*(*bodies.models)[j], (*bodies.states)[j], h);
  }
  constraints.finish_velocity_step(x);
  return info;
}

void copy_state(const State& from, State& to) {
  to.base = from.base;
  for (int k = 0; k < from.q.size(); ++k) to.q[k] = from.q[k];
  for (int k = 0; k < from.v.size(); ++k) to.v[k] = from.v[k];
}

void add_counts(const StepInfo& part, StepInfo& total) {
  total.evaluations += part.evaluations;
  total.substeps += part.substeps;
  total.rejected += part.rejected;
  total.events += part.events;
  total.velocity_level = total.velocity_level || part.velocity_level;
}

// A limit of body i as a row: +i the lower limit (gap q - lower, J = e_k), -i the upper (gap
// upper - q, J = -e_k).
double row_gap(const Model& m, const VecX& q, int row) {
  const int i = std::abs(row);
  const double qi = q[m.idx_q(i)];
  return row > 0 ? qi - m.lower[i] : m.upper[i] - qi;
}
double row_rate(const Model& m, const VecX& v, int row) {
  const double w = v[m.idx_v(std::abs(row))];
  return row > 0 ? w : -w;
}

// Whether the step is the contact scheme's: a limit crossed, or touched (gap <= rest_gap, not
// separating at rest_speed) while the free acceleration drives into it or holds it (resting on
// a limit is a contact, not an event). A touched limit that the free acceleration leaves, as
// at the instant after a plastic impact, keeps the integrator and its order: its step leaves
// the limit, and a later crossing is located as any other. The acceleration costs one dynamics
// evaluation, only while a limit is touched.
bool limit_resting(Stepper& stepper, const State& x, const VecX& tau_cmd,
                   const LimitEventOptions& o) {
  const Model& m = stepper.model();
  bool touching = false;
  for (int i = 1; i <= m.n; ++i) {
    for (int row : {i, -i}) {
      if (!std::isfinite(row > 0 ? m.lower[i] : m.upper[i])) continue;
      const double g = row_gap(m, x.q, row);
      if (g < -o.gap_tol) return true;
      touching = touching || (g <= o.rest_gap && row_rate(m, x.v, row) < o.rest_speed);
    }
  }
  if (!touching) return false;
  const VecX& a = stepper.acceleration(x.base, x.q, x.v, tau_cmd);
  for (int i = 1; i <= m.n; ++i) {
    for (int row : {i, -i}) {
      if (!std::isfinite(row > 0 ? m.lower[i] : m.upper[i])) continue;
      if (row_gap(m, x.q, row) <= o.rest_gap && row_rate(m, x.v, row) < o.rest_speed &&
          !(row_rate(m, a, row) > 0)) {
        return true;
      }
    }
  }
  return false;
}

// The limits crossed beyond gap_tol at q, into rows; the deepest gap among them (inf: none).
double crossed_limits(const Model& m, const VecX& q, double gap_tol, std::vector<int>& rows) {
  rows.clear();
  double deepest = std::numeric_limits<double>::infinity();
  for (int i = 1; i <= m.n; ++i) {
    for (int row : {i, -i}) {
      if (!std::isfinite(row > 0 ? m.lower[i] : m.upper[i])) continue;
      const double g = row_gap(m, q, row);
      if (g < -gap_tol) rows.push_back(row), deepest = std::min(deepest, g);
    }
  }
  return deepest;
}

double deepest_of(const Model& m, const VecX& q, const std::vector<int>& rows) {
  double g = std::numeric_limits<double>::infinity();
  for (int row : rows) g = std::min(g, row_gap(m, q, row));
  return g;
}

// The impact at x: the limits within rest_gap that approach get J v+ = -e J v- (impulses >= 0:
// a row whose impulse would pull is dropped and the rest solved again), v+ = v + D^-1 J^T
// lambda through the full D^-1, so the free base's momentum does not change.
void apply_limit_impact(Stepper& stepper, State& x, const LimitEventOptions& o,
                        LimitEventWorkspace& w) {
  const Model& m = stepper.model();
  w.rows.clear();
  for (int i = 1; i <= m.n; ++i) {
    for (int row : {i, -i}) {
      if (!std::isfinite(row > 0 ? m.lower[i] : m.upper[i])) continue;
      if (row_gap(m, x.q, row) <= o.rest_gap && row_rate(m, x.v, row) < 0) w.rows.push_back(row);
    }
  }
  const MatX& Minv = minv(m, stepper.data(), x.base, x.q);
  while (!w.rows.empty()) {
    const int r = static_cast<int>(w.rows.size());
    for (int a = 0; a < r; ++a) {
      const int ka = m.idx_v(std::abs(w.rows[a]));
      const double sa = w.rows[a] > 0 ? 1.0 : -1.0;
      for (int b = 0; b < r; ++b) {
        const int kb = m.idx_v(std::abs(w.rows[b]));
        w.W(a, b) = sa * (w.rows[b] > 0 ? 1.0 : -1.0) * Minv(ka, kb);
      }
      const double u = row_rate(m, x.v, w.rows[a]);
      const double e = -u > o.restitution_velocity ? o.restitution : 0.0;
      w.rhs[a] = -(1 + e) * u;
    }
    // W lambda = rhs by Gaussian elimination with partial pivoting (r is a handful).
    for (int c = 0; c < r; ++c) {
      int piv = c;
      for (int a = c + 1; a < r; ++a) {
        if (std::abs(w.W(a, c)) > std::abs(w.W(piv, c))) piv = a;
      }
      if (piv != c) {
        for (int b = 0; b < r; ++b) std::swap(w.W(c, b), w.W(piv, b));
        std::swap(w.rhs[c], w.rhs[piv]);
      }
      for (int a = c + 1; a < r; ++a) {
        const double f = w.W(a, c) / w.W(c, c);
        for (int b = c; b < r; ++b) w.W(a, b) -= f * w.W(c, b);
        w.rhs[a] -= f * w.rhs[c];
      }
    }
    for (int c = r - 1; c >= 0; --c) {
      double t = w.rhs[c];
      for (int b = c + 1; b < r; ++b) t -= w.W(c, b) * w.lambda[b];
      w.lambda[c] = t / w.W(c, c);
    }
    int worst = -1;
    for (int a = 0; a < r; ++a) {
      if (w.lambda[a] < 0 && (worst < 0 || w.lambda[a] < w.lambda[worst])) worst = a;
    }
    if (worst < 0) break;
    w.rows.erase(w.rows.begin() + worst);  // keeps its capacity: no allocation
  }
  for (size_t a = 0; a < w.rows.size(); ++a) {
    const int k = m.idx_v(std::abs(w.rows[a]));
    const double p = (w.rows[a] > 0 ? 1.0 : -1.0) * w.lambda[a];
    for (int j = 0; j < m.nv; ++j) x.v[j] += Minv(j, k) * p;
  }
}

// Joint limits under the stepper's own method, impacts located (LimitEventOptions).
StepInfo limit_event_step(ConstraintSystem& constraints, Stepper& stepper, State& x,
                          const VecX& tau_cmd, double h, const ContactBodies& bodies,
                          const ConstraintSystem::StepInput& in, const LimitEventOptions& o) {
  const Model& m = stepper.model();
  LimitEventWorkspace& w = stepper.limit_events();
  StepInfo total;
  double left = h;
  for (int events = 0;; ++events) {
    if (events > o.max_events || limit_resting(stepper, x, tau_cmd, o)) {
      StepInfo rest =
          velocity_level_step(constraints, stepper, x, tau_cmd, left, bodies, in, nullptr);
      add_counts(rest, total);
      total.ok = rest.ok;
      total.reason = rest.reason;
      return total;
    }
    copy_state(x, w.x1);
    StepInfo part = stepper.step(w.x1, tau_cmd, left);
    add_counts(part, total);
    if (!part.ok) {
      total.ok = false;
      total.reason = part.reason;
      return total;
    }
    if (!(crossed_limits(m, w.x1.q, o.gap_tol, w.rows) < -o.gap_tol)) {
      copy_state(w.x1, x);
      return total;
    }
    // Locate the impact: regula falsi (Illinois) on the step length s for the deepest of the
    // crossed limits, g(0) > -gap_tol >= ... > g(left).
    copy_state(x, w.x0);
    double s_lo = 0, g_lo = deepest_of(m, x.q, w.rows);
    double s_hi = left, g_hi = deepest_of(m, w.x1.q, w.rows);
    double s_at = left;
    int side = 0;
    for (int it = 0; it < o.max_iterations; ++it) {
      double s = (s_lo * g_hi - s_hi * g_lo) / (g_hi - g_lo);
      if (!(s > s_lo && s < s_hi)) s = 0.5 * (s_lo + s_hi);
      copy_state(w.x0, w.x1);
      part = stepper.step(w.x1, tau_cmd, s);
      add_counts(part, total);
      if (!part.ok) {
        total.ok = false;
        total.reason = part.reason;
        return total;
      }
      const double g = deepest_of(m, w.x1.q, w.rows);
      if (g <= 0 && g >= -o.gap_tol) {
        s_at = s;
        break;
      }
      if (g > 0) {
        s_lo = s, g_lo = g;
        if (side > 0) g_hi *= 0.5;
        side = 1;
      } else {
        s_hi = s, g_hi = g;
        if (side < 0) g_lo *= 0.5;
        side = -1;
      }
      if (s_hi - s_lo <= o.time_tol) {  // bracketed to the time tolerance: the far end
        copy_state(w.x0, w.x1);
        part = stepper.step(w.x1, tau_cmd, s_hi);
        add_counts(part, total);
        s_at = s_hi;
        break;
      }
      s_at = s_hi;  // (iterations exhausted: the far end, crossed by more than gap_tol)
      if (it + 1 == o.max_iterations) {
        copy_state(w.x0, w.x1);
        part = stepper.step(w.x1, tau_cmd, s_hi);
        add_counts(part, total);
      }
    }
    copy_state(w.x1, x);
    apply_limit_impact(stepper, x, o, w);
    ++total.events;
    left -= s_at;
    if (left <= o.time_tol) return total;
  }
}

}  // namespace

LimitEventWorkspace::LimitEventWorkspace(const Model& model)
    : x0(model),
      x1(model),
      W(MatX::Zero(2 * model.n + 1, 2 * model.n + 1)),
      rhs(VecX::Zero(2 * model.n + 1)),
      lambda(VecX::Zero(2 * model.n + 1)) {
  rows.reserve(2 * model.n + 1);
}

LimitEventWorkspace& Stepper::limit_events() {
  if (!limit_events_) {
    limit_events_ = std::make_unique<LimitEventWorkspace>(model_);
    data_.reserve_minv(model_);
  }
  return *limit_events_;
}

const VecX& contact_free_acceleration(Stepper& stepper, const State& x, const VecX& tau_cmd) {
  return free_acceleration(stepper, x, tau_cmd);
}

void advance_velocity_level(Stepper& stepper, State& x, double h) {
  stepper.free_base().advance(stepper.data(), x, h);
}

StepInfo constrained_step(ConstraintSystem& constraints, Stepper& stepper, State& x,
                          const VecX& tau_cmd, double h, const ContactBodies& bodies) {
  AccelerationHook* const previous = stepper.acceleration_hook();
  const size_t nbody = bodies.states ? bodies.states->size() : 0;
  const size_t nrobot = bodies.robot_states ? bodies.robot_states->size() : 0;
  const bool velocity_level = constraints.has_unilateral() || nbody > 0 || nrobot > 0 ||
                              (bodies.contacts && !bodies.contacts->empty());
  if (!velocity_level) {  // bilateral only: the integrator with eq. (32) in every stage
    stepper.set_acceleration_hook(&constraints);
    const StepInfo info = stepper.step(x, tau_cmd, h);
    stepper.set_acceleration_hook(previous);
    if (info.ok) constraints.finish_bilateral_step(x);
    return info;
  }
  ConstraintSystem::StepInput in;
  in.bodies = bodies.states;
  in.body_a_free = bodies.a_free;
  in.contacts = bodies.contacts;
  in.objects = bodies.objects;
  in.robots = bodies.robot_states;
  in.robot_a_free = bodies.robot_a_free;
  // Joint limits alone (no ground, contact, objects or bilateral rows) under another
  // integrator: its own steps with the impacts located (limit_event_step).
  const ConstraintSpec& spec = constraints.spec();
  if (!stepper.contact_scheme() && spec.joint_limits && !spec.ground && nbody == 0 && nrobot == 0 &&
      !bodies.objects && !bodies.contacts && constraints.bilateral_rows() == 0) {
    LimitEventOptions o;
    o.restitution = spec.options.limit_restitution;
    o.restitution_velocity = spec.options.restitution_velocity;
    StepInfo info = limit_event_step(constraints, stepper, x, tau_cmd, h, bodies, in, o);
    return info;
  }
  if (stepper.contact_scheme()) {
    return velocity_level_step(constraints, stepper, x, tau_cmd, h, bodies, in, nullptr);
  }
  const VecX& a_free = free_acceleration(stepper, x, tau_cmd);
  // The documented combination: a scene that names another integrator (rkmk4, ...) takes its
  // steps with it while no limit or contact is within reach, and the steps that have one by
  // this scheme (the free bodies always move by it).
  if (!constraints.unilateral_within_reach(x, a_free, h, in)) {
    stepper.set_acceleration_hook(constraints.bilateral_rows() > 0 ? &constraints : nullptr);
    StepInfo info = stepper.step(x, tau_cmd, h);
    stepper.set_acceleration_hook(previous);
    if (info.ok && constraints.bilateral_rows() > 0) constraints.finish_bilateral_step(x);
    for (size_t j = 0; j < nbody; ++j) {
      State& s = (*bodies.states)[j];
      s.v.noalias() += h * (*bodies.a_free)[j];
      advance_free_body(*(*bodies.models)[j], s, h);
    }
    return info;
  }
  return velocity_level_step(constraints, stepper, x, tau_cmd, h, bodies, in, &a_free);
}

}  // namespace se3
