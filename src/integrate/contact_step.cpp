// The time-stepping scheme of contact scenes (integrate.h): the registered stepper
// contact_semi_implicit, the position update it shares with the constrained step, and
// constrained_step, which drives the constraint layer's ConstraintSystem (it knows no stepper).
#include <memory>

#include "se3_sim/constraints.h"
#include "se3_sim/integrate.h"
#include "steppers.h"

namespace se3 {

void advance_positions_semi_implicit(const Model& model, State& x, double h) {
  if (model.floating) {
    x.base = x.base * exp_se3(h * x.v.head<6>());
    x.base.R = reorthonormalize(x.base.R);
  }
  const int nb = model.nv_base();
  for (int k = 0; k < model.nq; ++k) x.q[k] += h * x.v[nb + k];
}

void free_body_acceleration(const Model& body, const State& x, VecX& a) {
  a.head<3>().setZero();
  a.segment<3>(3) = x.base.R.transpose() * body.gravity;
}

void advance_free_body(const Model& body, State& x, double h) {
  const Vec3 w = x.v.head<3>(), v = x.v.segment<3>(3);
  const Mat3 E = exp_so3(h * w);
  x.base.p += h * (x.base.R * v);
  x.base.R = reorthonormalize(x.base.R * E);
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
    const VecX& a = acceleration(x.base, x.q, x.v, tau_cmd);
    x.v.noalias() += h * a;
    advance_positions_semi_implicit(model_, x, h);
    StepInfo info;
    info.evaluations = 1;
    info.substeps = 1;
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

StepInfo constrained_step(ConstraintSystem& constraints, Stepper& stepper, State& x,
                          const VecX& tau_cmd, double h, const ContactBodies& bodies) {
  AccelerationHook* const previous = stepper.acceleration_hook();
  const size_t nbody = bodies.states ? bodies.states->size() : 0;
  const bool velocity_level =
      constraints.has_unilateral() || nbody > 0 || (bodies.contacts && !bodies.contacts->empty());
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
  stepper.set_acceleration_hook(nullptr);
  const VecX& a_free = stepper.acceleration(x.base, x.q, x.v, tau_cmd);  // passive forces in
  stepper.set_acceleration_hook(previous);
  // The documented combination: a scene that names another integrator (rkmk4, ...) takes its
  // steps with it while no limit or contact is within reach, and the steps that have one by
  // this scheme (the free bodies always move by it).
  if (!stepper.contact_scheme() && !constraints.unilateral_within_reach(x, a_free, h, in)) {
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
  StepInfo info;
  info.evaluations = 1;
  info.substeps = 1;
  info.velocity_level = true;
  if (!constraints.velocity_step(x, a_free, h, in)) {
    info.ok = false;
    info.reason = "constraint solve produced a non-finite state";
    return info;
  }
  advance_positions_semi_implicit(stepper.model(), x, h);
  for (size_t j = 0; j < nbody; ++j) {
    advance_free_body(*(*bodies.models)[j], (*bodies.states)[j], h);
  }
  constraints.finish_velocity_step(x);
  return info;
}

}  // namespace se3
