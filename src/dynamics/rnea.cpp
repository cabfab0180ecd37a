// Recursive Newton-Euler, eqs. (33)-(37), body frames.
//
// Verified against the paper: eq. (36) must read ad*_{V_j}(J_j V_j) (the Newton-Euler wrench
// (24) of the body's own velocity), not ad*_{Vdot_j}; with that change the recursion matches
// RNEA(ABA(tau)) = tau and the oracles to rounding. Gravity enters as the fictitious base
// acceleration Vdot_{-1} = [0; -R0^T g] (section 4.3).
#include "joint.h"
#include "se3_sim/dynamics.h"

namespace se3 {

const VecX& rnea(const Model& model, Data& data, const SE3& base, const VecX& q, const VecX& v,
                 const VecX& a, const Vec6* f_ext_base) {
  const int off = model.floating ? 6 : 0;
  Vec6 ag;
  ag << 0, 0, 0, -(base.R.transpose() * model.gravity);
  if (model.floating) {
    data.V[0] = v.head<6>();
    data.A[0] = a.head<6>() + ag;
    const Inertia& I0 = model.inertia[0];
    data.F[0] = I0 * data.A[0] + cross_force(data.V[0], I0 * data.V[0]);
    if (f_ext_base) data.F[0] -= *f_ext_base;
  } else {
    data.V[0].setZero();
    data.A[0] = ag;
    data.F[0].setZero();
  }
  for (int i = 1; i <= model.n; ++i) {
    const int p = model.parent[i];
    const JointType t = model.joint_type[i];
    const int k = detail::axis_index(t);
    const double qd = v[off + i - 1];
    SE3& X = data.Xup[i];
    detail::joint_transform(model.X_tree[i], t, q[i - 1], X);
    Vec6 Vi = act_inv_motion(X, data.V[p]);  // eq. (33)
    Vi[k] += qd;
    Vec6 Ai = act_inv_motion(X, data.A[p]) + detail::cross_axis(t, Vi, qd);  // eqs. (34), (35)
    Ai[k] += a[off + i - 1];
    const Inertia& I = model.inertia[i];
    data.F[i] = I * Ai + cross_force(Vi, I * Vi);  // eq. (36), own-body term
    data.V[i] = Vi;
    data.A[i] = Ai;
  }
  for (int i = model.n; i >= 1; --i) {
    data.tau[off + i - 1] = data.F[i][detail::axis_index(model.joint_type[i])];  // eq. (37)
    const int p = model.parent[i];
    if (p > 0 || model.floating) data.F[p] += act_force(data.Xup[i], data.F[i]);  // eq. (36)
  }
  if (model.floating) data.tau.head<6>() = data.F[0];
  return data.tau;
}

const VecX& bias(const Model& model, Data& data, const SE3& base, const VecX& q, const VecX& v) {
  data.ddq.setZero();
  rnea(model, data, base, q, v, data.ddq);
  data.nle = data.tau;
  return data.nle;
}

}  // namespace se3
