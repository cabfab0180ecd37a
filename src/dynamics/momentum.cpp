// The base rows of the mass matrix, D_0 = [D_00 D_0q] (6 x nv), in the base frame: the linear
// map from the generalized velocity to the momentum of the whole tree about the base frame,
//   P_0 = D_0 v = sum_i Ad*_{T_0i^-1} J_i V_i                  (T_0i: body i in the base frame).
// By composite inertias (eq. 50 at the root): D_00 = Ic_0, the whole tree locked into one rigid
// body, and the column of dof k of body i is Ic_i S_k, Ic_i the composite inertia of i's subtree;
// all of them in the base frame, where composite inertias add without transforms.
#include "se3_sim/dynamics/dynamics.h"

namespace se3 {

void base_momentum_map(const Model& model, Data& data, const VecX& q, Mat6N& D0) {
  D0.resize(6, model.nv);
  if (!model.floating) {
    D0.setZero();
    return;
  }
  forward_kinematics(model, data, SE3(), q);  // oMb: the bodies in the base frame
  data.Ic[0] = model.inertia[0];
  for (int i = 1; i <= model.n; ++i) data.Ic[i] = model.inertia[i].transformed(data.oMb[i]);
  for (int i = model.n; i >= 1; --i) data.Ic[model.parent[i]] += data.Ic[i];
  Mat6 Ic0;
  data.Ic[0].to_matrix(Ic0);
  D0.leftCols<6>() = Ic0;
  for (int i = 1; i <= model.n; ++i) {
    const int k = model.idx_v(i);
    Vec6 S = Vec6::Zero();
    S[model.joints[i].axis()] = 1;
    D0.col(k) = data.Ic[i] * act_motion(data.oMb[i], S);
  }
}

}  // namespace se3
