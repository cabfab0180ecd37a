// Energy, momentum and centre of mass of the whole system.
#include "se3_sim/dynamics/dynamics.h"

namespace se3 {

double kinetic_energy(const Model& model, Data& data, const SE3& base, const VecX& q,
                      const VecX& v) {
  forward_kinematics(model, data, base, q, v);
  double T = 0;
  for (int i = model.floating ? 0 : 1; i <= model.n; ++i) {
    T += data.V[i].dot(model.inertia[i] * data.V[i]);
  }
  return 0.5 * T;
}

double potential_energy(const Model& model, Data& data, const SE3& base, const VecX& q) {
  forward_kinematics(model, data, base, q);
  double V = 0;
  for (int i = model.floating ? 0 : 1; i <= model.n; ++i) {
    const Inertia& I = model.inertia[i];
    if (I.m == 0) continue;
    // m g . c_world with c_world = R h / m + p
    V -= model.gravity.dot(data.oMb[i].R * I.h + I.m * data.oMb[i].p);
  }
  return V;
}

Vec6 spatial_momentum(const Model& model, Data& data, const SE3& base, const VecX& q,
                      const VecX& v) {
  forward_kinematics(model, data, base, q, v);
  Vec6 h = Vec6::Zero();
  for (int i = model.floating ? 0 : 1; i <= model.n; ++i) {
    h += act_force(data.oMb[i], model.inertia[i] * data.V[i]);
  }
  return h;
}

Vec3 center_of_mass(const Model& model, Data& data, const SE3& base, const VecX& q) {
  forward_kinematics(model, data, base, q);
  Vec3 c = Vec3::Zero();
  double m = 0;
  for (int i = model.floating ? 0 : 1; i <= model.n; ++i) {
    const Inertia& I = model.inertia[i];
    c += data.oMb[i].R * I.h + I.m * data.oMb[i].p;
    m += I.m;
  }
  return m > 0 ? Vec3(c / m) : Vec3::Zero();
}

}  // namespace se3
