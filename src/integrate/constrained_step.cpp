// A time step under constraints (integrate.h): the integrate layer drives the dynamics layer's
// ConstraintSystem, which knows no stepper.
#include "se3_sim/constraints.h"
#include "se3_sim/integrate.h"

namespace se3 {

StepInfo constrained_step(ConstraintSystem& constraints, Stepper& stepper, State& x,
                          const VecX& tau_cmd, double h) {
  AccelerationHook* const previous = stepper.acceleration_hook();
  if (constraints.has_unilateral()) {
    StepInfo info;
    info.evaluations = 1;
    info.substeps = 1;
    stepper.set_acceleration_hook(nullptr);
    const VecX& a_free = stepper.acceleration(x.base, x.q, x.v, tau_cmd);  // passive forces in
    stepper.set_acceleration_hook(previous);
    if (!constraints.velocity_step(x, a_free, h)) {
      info.ok = false;
      info.reason = "constraint solve produced a non-finite state";
    }
    return info;
  }
  stepper.set_acceleration_hook(&constraints);
  const StepInfo info = stepper.step(x, tau_cmd, h);
  stepper.set_acceleration_hook(previous);
  if (info.ok) constraints.finish_bilateral_step(x);
  return info;
}

}  // namespace se3
