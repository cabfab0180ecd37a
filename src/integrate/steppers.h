// The built-in steppers' factories, for the registry (stepper.cpp). Internal header.
#pragma once

#include <memory>

#include "se3_sim/integrate/integrate.h"

namespace se3 {
namespace detail {

std::unique_ptr<Stepper> make_variational_stepper(const Model& model, const StepperOptions& opt);
std::unique_ptr<Stepper> make_rk4_euler_angles_stepper(const Model& model,
                                                       const StepperOptions& opt);
std::unique_ptr<Stepper> make_rk4_quaternion_stepper(const Model& model, const StepperOptions& opt);
std::unique_ptr<Stepper> make_contact_stepper(const Model& model, const StepperOptions& opt);

}  // namespace detail
}  // namespace se3
