// Articulated-body algorithm, eqs. (38)-(43), body frames.
//
// Checked against the paper: (38) is the articulated inertia IA_j = J_j + sum over children of
// Ad*(IA_k - U_k U_k^T / D_k) Ad^-1 (U = IA S, D = S^T IA S); (40)-(41) carry the bias force
// pA_k + Ia_k gamma_k + U_k u_k / D_k to the parent, with u_k = tau_k - S^T pA_k; (42)-(43) run
// outward. For the free base, S_0 = 1 (eq. 26) so (42) becomes a 6x6 solve with IA_0.
#include <Eigen/Cholesky>

#include "joint.h"
#include "se3_sim/dynamics.h"

namespace se3 {
namespace {

// out += Ad*_{X^-1} Ia Ad_{X^-1}: an articulated inertia of a child (frame X in its parent)
// expressed in the parent's frame. Blockwise with Ia = [A B; B^T C]: rotate every block, then
// shift by p: A' - B' p^ + p^ B'^T - p^ C' p^, B' + p^ C', C'.
inline void add_transformed_inertia(const SE3& X, const Mat6& Ia, Mat6& out) {
  const Mat3& R = X.R;
  const Mat3 A = R * Ia.topLeftCorner<3, 3>() * R.transpose();
  const Mat3 B = R * Ia.topRightCorner<3, 3>() * R.transpose();
  const Mat3 C = R * Ia.bottomRightCorner<3, 3>() * R.transpose();
  const Mat3 P = hat(X.p);
  const Mat3 PC = P * C;
  const Mat3 BP = B * P;
  out.topLeftCorner<3, 3>() += A - BP - BP.transpose() - PC * P;
  out.topRightCorner<3, 3>() += B + PC;
  out.bottomLeftCorner<3, 3>() += B.transpose() + PC.transpose();
  out.bottomRightCorner<3, 3>() += C;
}

}  // namespace

const VecX& aba(const Model& model, Data& data, const SE3& base, const VecX& q, const VecX& v,
                const VecX& tau, const Vec6* f_ext_base) {
  const int off = model.floating ? 6 : 0;
  // Outward: velocities (33), gamma (34), J_j and beta_j (39).
  if (model.floating) {
    data.V[0] = v.head<6>();
    model.inertia[0].to_matrix(data.IA[0]);
    // The base's generalized force tau[0:6] is a wrench on it, like f_ext_base.
    data.F[0] = cross_force(data.V[0], model.inertia[0] * data.V[0]) - tau.head<6>();
    if (f_ext_base) data.F[0] -= *f_ext_base;
  } else {
    data.V[0].setZero();
  }
  for (int i = 1; i <= model.n; ++i) {
    const int p = model.parent[i];
    const JointType t = model.joint_type[i];
    const double qd = v[off + i - 1];
    SE3& X = data.Xup[i];
    detail::joint_transform(model.X_tree[i], t, q[i - 1], X);
    Vec6 Vi = act_inv_motion(X, data.V[p]);
    Vi[detail::axis_index(t)] += qd;
    data.V[i] = Vi;
    data.c[i] = detail::cross_axis(t, Vi, qd);
    const Inertia& I = model.inertia[i];
    I.to_matrix(data.IA[i]);
    data.F[i] = cross_force(Vi, I * Vi);  // pA, eq. (39) (sign: bias force = -ad*_V J V)
  }
  // Inward: articulated inertias (38) and bias forces (40)-(41).
  for (int i = model.n; i >= 1; --i) {
    const int k = detail::axis_index(model.joint_type[i]);
    const Mat6& IA = data.IA[i];
    data.U[i] = IA.col(k);
    const double Dinv = 1.0 / data.U[i][k];
    data.Dinv[i] = Dinv;
    data.u[i] = tau[off + i - 1] - data.F[i][k];
    const int p = model.parent[i];
    if (p == 0 && !model.floating) continue;
    const Vec6& U = data.U[i];
    Mat6 Ia = IA;
    Ia.noalias() -= (U * Dinv) * U.transpose();
    const Vec6 pa = data.F[i] + Ia * data.c[i] + U * (data.u[i] * Dinv);
    add_transformed_inertia(data.Xup[i], Ia, data.IA[p]);
    data.F[p] += act_force(data.Xup[i], pa);
  }
  // Outward: accelerations (42)-(43), with gravity as the fictitious base acceleration.
  Vec6 ag;
  ag << 0, 0, 0, -(base.R.transpose() * model.gravity);
  if (model.floating) {
    // IA_0 a_0 = -pA_0 in the gravity-free frame; the true dV0/dt adds g back.
    data.A[0] = -(data.IA[0].llt().solve(data.F[0]));
    data.ddq.head<6>() = data.A[0] - ag;
  } else {
    data.A[0] = ag;
  }
  for (int i = 1; i <= model.n; ++i) {
    const int k = detail::axis_index(model.joint_type[i]);
    Vec6 a = act_inv_motion(data.Xup[i], data.A[model.parent[i]]) + data.c[i];
    const double qdd = (data.u[i] - data.U[i].dot(a)) * data.Dinv[i];
    a[k] += qdd;
    data.A[i] = a;
    data.ddq[off + i - 1] = qdd;
  }
  return data.ddq;
}

}  // namespace se3
