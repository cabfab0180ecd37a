// D^-1 by the recursive square-root-free factorization of eqs. (55)-(63), evaluated column-block
// by column-block in the world frame (where Ad of eq. (62)-(63) reduces to sums):
//   inward  (59)-(61): IA_i, U_i = IA_i S_i, Omega_i = S_i^T U_i; row i of D^-1 starts as
//                      Omega_i^-1 (e_i - S_i^T F_i) over the subtree's columns, and the bias
//                      wrenches F_p += F_i + U_i row_i carry the columns inward (the Pi, aleph
//                      terms of (62)-(63));
//   outward (58):      row_i -= Omega_i^-1 U_i^T P_parent and P_i = P_parent + S_i row_i over
//                      columns >= i, P the accelerations produced by unit torques.
// The paper states (58)-(63) for a chain; here the same recursion runs on trees (subtree column
// ranges) and on the free base (S_0 = 1, Omega_0 = IA_0 a 6x6 block). Cost O(n^2) for the n^2
// output, O(n d) per column.
#include <Eigen/Cholesky>

#include "joint.h"
#include "se3_sim/dynamics.h"

namespace se3 {
namespace {

inline void inertia_matrix(const Inertia& I, Mat6& M) {
  M.topLeftCorner<3, 3>() = I.I;
  const Mat3 H = hat(I.h);
  M.topRightCorner<3, 3>() = H;
  M.bottomLeftCorner<3, 3>() = -H;
  M.bottomRightCorner<3, 3>() = I.m * Mat3::Identity();
}

}  // namespace

const MatX& minv(const Model& model, Data& data, const SE3& base, const VecX& q) {
  const int off = model.floating ? 6 : 0;
  const int nv = model.nv;
  forward_kinematics(model, data, base, q);
  for (int i = model.floating ? 0 : 1; i <= model.n; ++i) {
    inertia_matrix(model.inertia[i].transformed(data.oMb[i]), data.IA[i]);
  }
  auto& F = data.Fm;
  F.setZero();
  MatX& Mi = data.Minv;
  for (int i = model.n; i >= 1; --i) {
    const Vec3 z = data.oMb[i].R.col(2);
    Vec6& S = data.S[i];
    if (model.joint_type[i] == JointType::Revolute) {
      S << z, data.oMb[i].p.cross(z);
    } else {
      S << 0, 0, 0, z;
    }
    const Mat6& IA = data.IA[i];
    const Vec6 U = IA * S;  // (61) up to Omega^-1
    const double Dinv = 1.0 / S.dot(U);  // (60)
    data.U[i] = U;
    data.Dinv[i] = Dinv;
    const int row = off + i - 1;
    const int len = model.subtree_end[i] - i + 1;
    auto r = Mi.row(row).segment(row, len);
    r.noalias() = -Dinv * (S.transpose() * F.middleCols(row, len));
    r[0] += Dinv;
    Mi.row(row).tail(nv - row - len).setZero();  // filled by the outward pass
    const int p = model.parent[i];
    if (p > 0 || model.floating) {
      F.middleCols(row, len).noalias() += U * r;                 // (62)
      data.IA[p] += IA - (U * Dinv) * U.transpose();             // (59), (63)
    }
  }
  if (model.floating) {
    // S_0 = 1 in the base frame: Omega_0 = Ad^T IA_0 Ad, row block = Omega_0^-1 (E - Ad^T F).
    const SE3& f0 = data.oMb[0];
    const Mat6 Adf = Ad(f0);
    const Mat6 Omega0 = Adf.transpose() * data.IA[0] * Adf;
    const Eigen::LLT<Mat6> llt(Omega0);
    Eigen::Matrix<double, 6, Eigen::Dynamic>& P0 = data.Pm[data.P_slot[0]];
    P0.noalias() = -(Adf.transpose() * F);
    P0.leftCols<6>() += Mat6::Identity();
    Mi.topRows<6>() = llt.solve(P0);
    P0.noalias() = Adf * Mi.topRows<6>();  // accelerations of the base, world frame
  }
  for (int i = 1; i <= model.n; ++i) {
    const int p = model.parent[i];
    const int row = off + i - 1;
    const int len = nv - row;
    auto r = Mi.row(row).segment(row, len);
    auto Pi = data.Pm[data.P_slot[i]].middleCols(row, len);
    if (p > 0 || model.floating) {
      const auto Pp = data.Pm[data.P_slot[p]].middleCols(row, len);
      r.noalias() -= (data.Dinv[i] * data.U[i].transpose()) * Pp;  // (58)
      if (data.P_slot[i] != data.P_slot[p]) Pi = Pp;
      Pi.noalias() += data.S[i] * r;
    } else {
      Pi.noalias() = data.S[i] * r;
    }
  }
  Mi.triangularView<Eigen::StrictlyLower>() = Mi.transpose();
  return Mi;
}

}  // namespace se3
