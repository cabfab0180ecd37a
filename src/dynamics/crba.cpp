// Mass matrix D of eq. (50), D = S^T G^T Ic G S, by composite rigid bodies. Equivalent to the
// paper's route of n unit-acceleration RNEA passes (section 6.1), in O(n d) instead of O(n^2).
// Two evaluations of the same sums, chosen per model by their cost (Data::crba_local):
//
// - local frames (shallow trees: arms, legged robots): composite inertias Ic_p += Ad* Ic_i Ad^-1
//   through the joint transforms (no forward kinematics), F_i = Ic_i S_i, and D_ji = S_j^T F_i
//   as F_i travels inward through every ancestor j. The columns of a subtree are contiguous,
//   so the whole block of F's travels at once.
// - world frame (deep chains): composite inertias add without transforms, and
//   D_ji = S_j^T (Ic_i S_i) with world axes, six multiply-adds per entry instead of a wrench
//   transform per entry.
#include "joint.h"
#include "row_kernel.h"
#include "se3_sim/dynamics.h"

namespace se3 {

namespace {

const MatX& crba_local(const Model& model, Data& data, const VecX& q) {
  const int nv = model.nv;
  detail::joint_transforms(model, data, q);
  for (int i = model.floating ? 0 : 1; i <= model.n; ++i) data.Ic[i] = model.inertia[i];
  double* F[6];
  for (int r = 0; r < 6; ++r) F[r] = data.Fm.row(r).data();
  double* M = data.M.data();  // column-major, leading dimension nv
  for (int i = model.n; i >= 1; --i) {
    const int p = model.parent[i];
    const bool carry = p > 0 || model.floating;
    const Inertia& Ic = data.Ic[i];  // complete: every descendant has been added
    if (carry) Ic.add_transformed(data.Xup[i], data.Ic[p]);
    // F_i = Ic_i S_i: a column of eq. (23)'s matrix. The subtree's columns are [col, end).
    const JointModel& jm = model.joints[i];
    const JointModel& last = model.joints[model.subtree_end[i]];
    const int col = jm.idx_v, end = last.idx_v + last.nv;
    const int k = jm.axis();
    double Fi[6];
    detail::with_joint(jm, [&](auto J) { J.inertia_column(Ic, Fi); });
    for (int r = 0; r < 6; ++r) F[r][col] = Fi[r];
    // Row i of D over the subtree: D_ic = S_i^T F_c, every F_c of the subtree in frame i now.
    double* mcol = M + static_cast<std::ptrdiff_t>(col) * nv;
    for (int c = col; c < end; ++c) {
      mcol[c] = F[k][c];
      M[col + static_cast<std::ptrdiff_t>(c) * nv] = F[k][c];
    }
    if (!carry) continue;
    const double* R = data.Xup[i].R.data();
    const double* t = data.Xup[i].p.data();
    for (int c = col; c < end; ++c) {
      double x[6];
      for (int r = 0; r < 6; ++r) x[r] = F[r][c];
      detail::force_to_parent(R, t, x);
      for (int r = 0; r < 6; ++r) F[r][c] = x[r];
    }
  }
  if (model.floating) {  // the base rows: S_0 = 1, the F's now in the base frame
    for (int c = 6; c < nv; ++c) {
      for (int r = 0; r < 6; ++r) {
        M[r + static_cast<std::ptrdiff_t>(c) * nv] = F[r][c];
        M[c + static_cast<std::ptrdiff_t>(r) * nv] = F[r][c];
      }
    }
    data.M.topLeftCorner<6, 6>() = data.Ic[0].matrix();
  }
  return data.M;
}

const MatX& crba_world(const Model& model, Data& data, const SE3& base, const VecX& q) {
  const int nv = model.nv;
  // Every moving body's joint has one dof, numbered in body order after the base's: body b's
  // column is v1 + b. Row bounds in body indices let the compiler run the row loops below on one
  // index (docs/performance.md).
  const int v1 = model.nv_base() - 1;
  forward_kinematics(model, data, base, q);
  for (int i = model.floating ? 0 : 1; i <= model.n; ++i) {
    data.Ic[i] = model.inertia[i].transformed(data.oMb[i]);
  }
  // World-frame joint axes S_i (revolute: [z; p x z], prismatic: [0; z]), one row of Jrow per
  // twist component so that a row of D is six axpys.
  double* J[6];
  for (int r = 0; r < 6; ++r) J[r] = data.Jrow.row(r).data();
  for (int i = 1; i <= model.n; ++i) {
    double S[6];
    detail::with_joint(model.joints[i], [&](auto Jt) { Jt.world_axis(data.oMb[i], S); });
    for (int r = 0; r < 6; ++r) J[r][v1 + i] = S[r];
  }
  double* M = data.M.data();  // column-major, leading dimension nv
  for (int i = model.n; i >= 1; --i) {
    const int p = model.parent[i];
    Inertia& Ic = data.Ic[i];
    if (p > 0 || model.floating) {
      Inertia& Ip = data.Ic[p];
      Ip.m += Ic.m;
      for (int r = 0; r < 3; ++r) Ip.h[r] += Ic.h[r];
      for (int r = 0; r < 9; ++r) Ip.I.data()[r] += Ic.I.data()[r];
    }
    // F = Ic S_i.
    const int col = v1 + i;
    const double S[6] = {J[0][col], J[1][col], J[2][col], J[3][col], J[4][col], J[5][col]};
    double Fv[6];
    detail::inertia_times(Ic, S, Fv);
    const double F0 = Fv[0], F1 = Fv[1], F2 = Fv[2], F3 = Fv[3], F4 = Fv[4], F5 = Fv[5];
    const double* const Jc[6] = {J[0], J[1], J[2], J[3], J[4], J[5]};
    // D(j, i) = S_j . F for every ancestor j of i (and j = i), written to both triangles.
    // Ancestors come in runs of consecutive indices (a chain is a single run); column i above
    // the diagonal is contiguous in column-major storage.
    double* mcol = M + static_cast<std::ptrdiff_t>(col) * nv;
    int j = i;
    while (j > 0) {
      const int s = data.run_start[j];
      const int c0 = v1 + s, c1 = v1 + j + 1;  // the run s..j
      detail::row_segment(Fv, Jc, c0, c1, mcol, M + col, nv);
      j = model.parent[s];
    }
    if (model.floating) {  // the base rows: S_0 = 1 in the base frame, Ad*_{f0}^-1 F
      const Vec6 Fb = act_inv_force(data.oMb[0], (Vec6() << F0, F1, F2, F3, F4, F5).finished());
      for (int r = 0; r < 6; ++r) {
        mcol[r] = Fb[r];
        M[col + static_cast<std::ptrdiff_t>(r) * nv] = Fb[r];
      }
    }
  }
  if (model.floating) {
    // The whole system's composite inertia in the base frame.
    data.M.topLeftCorner<6, 6>() = data.Ic[0].transformed(data.oMb[0].inverse()).matrix();
  }
  return data.M;
}

}  // namespace

const MatX& crba(const Model& model, Data& data, const SE3& base, const VecX& q) {
  if (!data.crba_reserved()) data.reserve_crba(model);
  return data.crba_local ? crba_local(model, data, q) : crba_world(model, data, base, q);
}

}  // namespace se3
