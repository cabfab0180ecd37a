// Recursive Newton-Euler, eqs. (33)-(37), body frames.
//
// Verified against the paper: eq. (36) must read ad*_{V_j}(J_j V_j) (the Newton-Euler wrench
// (24) of the body's own velocity), not ad*_{Vdot_j}; with that change the recursion matches
// RNEA(ABA(tau)) = tau and the oracles to rounding. Gravity enters as the fictitious base
// acceleration Vdot_{-1} = [0; -R0^T g] (section 4.3).
// GCC's code hoisting lifts the loads that the joint forms' copies of the step share above their
// dispatch, where they are spilled to the stack and read back: off for this file. Scheduling
// before register allocation with register pressure in view (and IRA's loop pressure) spills
// less of the step's twenty-odd live values (docs/performance.md).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC optimize("no-code-hoisting", "sched-pressure", "schedule-insns", "ira-loop-pressure")
#endif
#include "joint.h"
#include "se3_sim/dynamics/dynamics.h"

namespace se3 {

const VecX& rnea(const Model& model, Data& data, const SE3& base, const VecX& q, const VecX& v,
                 const VecX& a, const Vec6* f_ext_base) {
  detail::joint_transforms(model, data, q);
  const Vec3 ag = -(base.R.transpose() * model.gravity);
  if (model.floating) {
    data.V[0] = v.head<6>();
    data.A[0] = a.head<6>();
    data.A[0].tail<3>() += ag;
    detail::newton_euler(model.inertia[0], data.V[0].data(), data.A[0].data(), data.F[0].data());
    if (f_ext_base) data.F[0] -= *f_ext_base;
  } else {
    data.V[0].setZero();
    data.A[0] << 0, 0, 0, ag;
    data.F[0].setZero();
  }
  // The arrays' data pointers and the base's kind read once: the stores through double* below
  // would otherwise make GCC reload some of them for every body.
  const bool fixed = !model.floating;
  const double* vd = v.data();
  const double* ad = a.data();
  const JointModel* joints = model.joints.data();
  const SE3* Xup = data.Xup.data();
  const int* parent = model.parent.data();
  const Inertia* inertia = model.inertia.data();
  Vec6* Vs = data.V.data();
  Vec6* As = data.A.data();
  Vec6* Fs = data.F.data();
  for (int i = 1; i <= model.n; ++i) {
    const JointModel& jm = joints[i];
    const SE3& X = Xup[i];
    const int p = parent[i];
    const double qd = vd[jm.idx_v], qdd = ad[jm.idx_v];
    double* V = Vs[i].data();
    double* A = As[i].data();
    const Inertia& I = inertia[i];
    double* F = Fs[i].data();
    detail::with_joint(jm, [&](auto J) SE3_LAMBDA {
      constexpr int k = J.axis;
      if (p == 0 && fixed) {
        // On the fixed base: V_p = 0 and A_p = [0; ag], so V = S qd, V x S qd = 0 and
        // A = [0; R^T ag] + S qdd (the sums below without their zero terms).
        for (int r = 0; r < 6; ++r) V[r] = 0;
        V[k] = qd;
        A[0] = A[1] = A[2] = 0;
        detail::rotate_back<J.form>(X.R.data(), ag[0], ag[1], ag[2], A + 3);
        A[k] += qdd;
        // (36): F = J A + V x* (J V), J V = qd J S.
        detail::inertia_times(I, A, F);
        if constexpr (k == 2) {  // V x* (J V) = qd^2 e_z x [I e_z; h x e_z] on both halves
          double G[6];
          J.inertia_column(I, G);
          const double q2 = qd * qd;
          F[0] -= q2 * G[1], F[1] += q2 * G[0], F[3] -= q2 * G[4], F[4] += q2 * G[3];
        }  // prismatic: V x* (J V) = [v x m v; 0] = 0
        return;
      }
      // (33), (34), (35): V = Ad^-1 V_p + S qd, A = Ad^-1 A_p + V x S qd + S qdd.
      detail::child_twist(J, X, Vs[p].data(), qd, V);
      detail::inv_motion<J.form, J.offset>(X, As[p].data(), A);
      J.add_bias_acceleration(V, qd, A);
      A[k] += qdd;
      // (36), own-body term: F = J A - ad*_V (J V).
      detail::newton_euler(I, V, A, F);
    });
  }
  for (int i = model.n; i >= 1; --i) {
    const JointModel& jm = model.joints[i];
    data.tau[jm.idx_v] = data.F[i][jm.axis()];  // eq. (37): S^T F
    const int p = model.parent[i];
    if (p > 0 || model.floating) {
      detail::with_joint_form(jm, [&](auto J) SE3_LAMBDA {  // eq. (36)
        detail::add_force<J.form, J.offset>(data.Xup[i], data.F[i].data(), data.F[p].data());
      });
    }
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
