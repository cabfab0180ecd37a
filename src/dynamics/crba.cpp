// Mass matrix D of eq. (50), D = S^T G^T Ic G S, by composite rigid bodies in the world frame:
// composite inertias then add without transforms, and D_ij = S_j^T (Ic_i S_i) for every
// ancestor j of i (zero otherwise). Equivalent to the paper's route of n unit-acceleration RNEA
// passes (section 6.1), in O(n d) instead of O(n^2).
#include "joint.h"
#include "se3_sim/dynamics.h"

namespace se3 {
namespace detail {

/// World-frame joint axis of body i (S_i carried by oMb[i]).
inline Vec6 world_axis(JointType t, const SE3& oMi) {
  Vec6 s;
  const Vec3 z = oMi.R.col(2);
  if (t == JointType::Revolute) {
    s << z, oMi.p.cross(z);
  } else {
    s << 0, 0, 0, z;
  }
  return s;
}

}  // namespace detail

const MatX& crba(const Model& model, Data& data, const SE3& base, const VecX& q) {
  const int off = model.floating ? 6 : 0;
  forward_kinematics(model, data, base, q);
  for (int i = model.floating ? 0 : 1; i <= model.n; ++i) {
    data.Ic[i] = model.inertia[i].transformed(data.oMb[i]);
  }
  for (int i = 1; i <= model.n; ++i) {
    data.S[i] = detail::world_axis(model.joint_type[i], data.oMb[i]);
    data.Jrow.col(off + i - 1) = data.S[i];
  }
  for (int i = model.n; i >= 1; --i) {
    const int p = model.parent[i];
    if (p > 0 || model.floating) data.Ic[p] += data.Ic[i];
    const Vec6 F = data.Ic[i] * data.S[i];
    const int col = off + i - 1;
    // Column i of D above the diagonal (contiguous in column-major storage); ancestors come
    // in runs of consecutive indices (a chain is a single run).
    int j = i;
    while (j > 0) {
      const int s = data.run_start[j];
      const int c0 = off + s - 1, len = j - s + 1;
      double* m = data.M.col(col).data();
      const double *j0 = data.Jrow.row(0).data(), *j1 = data.Jrow.row(1).data(),
                   *j2 = data.Jrow.row(2).data(), *j3 = data.Jrow.row(3).data(),
                   *j4 = data.Jrow.row(4).data(), *j5 = data.Jrow.row(5).data();
#pragma GCC ivdep
      for (int c = c0; c < c0 + len; ++c) {
        m[c] =
            F[0] * j0[c] + F[1] * j1[c] + F[2] * j2[c] + F[3] * j3[c] + F[4] * j4[c] + F[5] * j5[c];
      }
      j = model.parent[s];
    }
    if (model.floating) data.M.col(col).head<6>() = act_inv_force(data.oMb[0], F);
  }
  if (model.floating) {
    // The whole system's composite inertia in the base frame.
    data.M.topLeftCorner<6, 6>() = data.Ic[0].transformed(data.oMb[0].inverse()).matrix();
  }
  data.M.triangularView<Eigen::StrictlyLower>() = data.M.transpose();
  return data.M;
}

}  // namespace se3
