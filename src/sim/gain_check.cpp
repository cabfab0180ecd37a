#include "se3_sim/sim/gain_check.h"

#include <cmath>
#include <cstdio>

namespace se3 {

std::vector<std::string> gain_stability_warnings(const Model& model, const State& x,
                                                 const std::vector<ControllerSpec>& specs,
                                                 double dt) {
  std::vector<std::string> out;
  if (!(dt > 0) || !std::isfinite(dt)) return out;
  bool any = false;
  for (const ControllerSpec& s : specs) any = any || (uses_pid(s.kind) && !s.gains.empty());
  if (!any) return out;
  Data data(model);
  const MatX& Dinv = minv(model, data, x.base, x.q);
  char line[512];
  for (const ControllerSpec& s : specs) {
    if (!uses_pid(s.kind) || s.gains.size() != s.joints.size()) continue;
    // A velocity trajectory controller's gains turn a position error into a velocity.
    if (s.kind == ControllerKind::Trajectory && s.iface != JointInterface::Effort) continue;
    const bool velocity = s.kind == ControllerKind::Velocity;
    for (size_t k = 0; k < s.joints.size(); ++k) {
      const int i = model.joint_index(s.joints[k]);
      if (i < 1) continue;
      const int iv = model.idx_v(i);
      const double m = Dinv(iv, iv);  // 1 / effective inertia, the other joints free
      if (!(m > 0) || !std::isfinite(m)) continue;
      const PidGains& g = s.gains[k];
      const double damping = velocity ? g.p : g.d;
      const double stiffness = velocity ? 0.0 : g.p;
      const double factor = dt * damping * m + 0.5 * dt * dt * stiffness * m;
      if (factor < 2) continue;
      // What to lower: the damping, to its bound at this stiffness, unless the stiffness alone
      // is past it (then p, to its bound without damping).
      const double d_max = (2 - 0.5 * dt * dt * stiffness * m) / (dt * m);
      const bool lower_p = velocity || d_max <= 0;
      const double bound = velocity ? d_max : d_max > 0 ? d_max : 4 / (dt * dt * m);
      char gains[96];
      if (velocity) {
        std::snprintf(gains, sizeof gains, "p = %g", g.p);
      } else {
        std::snprintf(gains, sizeof gains, "gains p = %g, d = %g", g.p, g.d);
      }
      std::snprintf(line, sizeof line,
                    "controller '%s': joint '%s' %s %s past what a step of %g s carries "
                    "(effective inertia %.3g, %s = %.3g, stable below 2): its velocity will flip "
                    "from step to step; lower %s below %.3g or dt",
                    s.name.c_str(), s.joints[k].c_str(), gains, velocity ? "is" : "are", dt, 1 / m,
                    velocity ? "dt p / M" : "dt d / M + dt^2 p / 2M", factor, lower_p ? "p" : "d",
                    bound);
      out.emplace_back(line);
    }
  }
  return out;
}

}  // namespace se3
