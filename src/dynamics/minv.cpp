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
const MatX& minv(const Model& model, Data& data, const SE3& base, const VecX& q) {
  const int off = model.floating ? 6 : 0;
  const int nv = model.nv;
  forward_kinematics(model, data, base, q);
  for (int i = model.floating ? 0 : 1; i <= model.n; ++i) {
    model.inertia[i].transformed(data.oMb[i]).to_matrix(data.IA[i]);
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
    const Vec6 U = IA * S;               // (61) up to Omega^-1
    const double Dinv = 1.0 / S.dot(U);  // (60)
    data.U[i] = U;
    data.Dinv[i] = Dinv;
    const int row = off + i - 1;
    const int len = model.subtree_end[i] - i + 1;
    // Row i of D^-1 (upper triangle) is kept as column i (contiguous in column-major storage).
    // The column loops touch entry j of each array only at step j (no loop-carried
    // dependency, also when P_i and P_parent share storage), hence `ivdep`.
    // One fused pass over the subtree's columns: r = Omega^-1 (e_i - S^T F), F += U r.
    double* r = Mi.col(row).data();
    double* f0 = F.row(0).data();
    double* f1 = F.row(1).data();
    double* f2 = F.row(2).data();
    double* f3 = F.row(3).data();
    double* f4 = F.row(4).data();
    double* f5 = F.row(5).data();
    const int p = model.parent[i];
    const bool carry = p > 0 || model.floating;
    // Column i of F is still zero (only descendants wrote F), so r_i = Omega^-1.
    r[row] = Dinv;
    const double s0 = -Dinv * S[0], s1 = -Dinv * S[1], s2 = -Dinv * S[2], s3 = -Dinv * S[3],
                 s4 = -Dinv * S[4], s5 = -Dinv * S[5];
#pragma GCC ivdep
    for (int j = row + 1; j < row + len; ++j) {
      r[j] = s0 * f0[j] + s1 * f1[j] + s2 * f2[j] + s3 * f3[j] + s4 * f4[j] + s5 * f5[j];
    }
    if (carry) {  // (62)
      const double u0 = U[0], u1 = U[1], u2 = U[2], u3 = U[3], u4 = U[4], u5 = U[5];
#pragma GCC ivdep
      for (int j = row; j < row + len; ++j) {
        const double x = r[j];
        f0[j] += u0 * x;
        f1[j] += u1 * x;
        f2[j] += u2 * x;
        f3[j] += u3 * x;
        f4[j] += u4 * x;
        f5[j] += u5 * x;
      }
    }
    for (int j = row + len; j < nv; ++j) r[j] = 0;             // filled by the outward pass
    if (carry) data.IA[p] += IA - (U * Dinv) * U.transpose();  // (59), (63)
  }
  if (model.floating) {
    // S_0 = 1 in the base frame: Omega_0 = Ad^T IA_0 Ad, row block = Omega_0^-1 (E - Ad^T F).
    const SE3& f0 = data.oMb[0];
    const Mat6 Adf = Ad(f0);
    const Mat6 Omega0 = Adf.transpose() * data.IA[0] * Adf;
    const Eigen::LLT<Mat6> llt(Omega0);
    Data::Mat6X& P0 = data.Pm[data.P_slot[0]];
    const Mat6 minus_AdT = -Adf.transpose();
    P0.noalias() = minus_AdT * F;
    P0.leftCols<6>() += Mat6::Identity();
    llt.solveInPlace(P0);
    Mi.leftCols<6>() = P0.transpose();
    P0.noalias() = Adf * Mi.leftCols<6>().transpose();  // base accelerations, world frame
  }
  for (int i = 1; i <= model.n; ++i) {
    const int p = model.parent[i];
    const int row = off + i - 1;
    double* r = Mi.col(row).data();
    const Vec6& S = data.S[i];
    Data::Mat6X& Pi = data.Pm[data.P_slot[i]];
    double* q0 = Pi.row(0).data();
    double* q1 = Pi.row(1).data();
    double* q2 = Pi.row(2).data();
    double* q3 = Pi.row(3).data();
    double* q4 = Pi.row(4).data();
    double* q5 = Pi.row(5).data();
    const double s0 = S[0], s1 = S[1], s2 = S[2], s3 = S[3], s4 = S[4], s5 = S[5];
    if (p > 0 || model.floating) {
      const Vec6 W = data.Dinv[i] * data.U[i];
      const double w0 = W[0], w1 = W[1], w2 = W[2], w3 = W[3], w4 = W[4], w5 = W[5];
      const Data::Mat6X& Pp = data.Pm[data.P_slot[p]];
      // P_i may be P_parent itself (same slot): each column is read before it is written.
      const double* p0 = Pp.row(0).data();
      const double* p1 = Pp.row(1).data();
      const double* p2 = Pp.row(2).data();
      const double* p3 = Pp.row(3).data();
      const double* p4 = Pp.row(4).data();
      const double* p5 = Pp.row(5).data();
#pragma GCC ivdep
      for (int j = row; j < nv; ++j) {
        const double a0 = p0[j], a1 = p1[j], a2 = p2[j], a3 = p3[j], a4 = p4[j], a5 = p5[j];
        const double x =
            r[j] - (w0 * a0 + w1 * a1 + w2 * a2 + w3 * a3 + w4 * a4 + w5 * a5);  // (58)
        r[j] = x;
        q0[j] = a0 + s0 * x;
        q1[j] = a1 + s1 * x;
        q2[j] = a2 + s2 * x;
        q3[j] = a3 + s3 * x;
        q4[j] = a4 + s4 * x;
        q5[j] = a5 + s5 * x;
      }
    } else {
#pragma GCC ivdep
      for (int j = row; j < nv; ++j) {
        const double x = r[j];
        q0[j] = s0 * x;
        q1[j] = s1 * x;
        q2[j] = s2 * x;
        q3[j] = s3 * x;
        q4[j] = s4 * x;
        q5[j] = s5 * x;
      }
    }
  }
  Mi.triangularView<Eigen::StrictlyUpper>() = Mi.transpose();
  return Mi;
}

}  // namespace se3
