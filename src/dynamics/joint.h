// One-dof joint helpers shared by the recursions. The body frame of every moving body has its
// joint axis along z (model.h), so S is e_3 (revolute, angular z) or e_6 (prismatic, linear z)
// and S^T x, S q, v x (S qd) reduce to a component or two: the joint-axis sparsity.
#pragma once

#include <cmath>

#include "se3_sim/model.h"

namespace se3 {
namespace detail {

/// Index of the non-zero entry of S in a 6-vector: 2 (revolute) or 5 (prismatic).
inline int axis_index(JointType t) {
  return t == JointType::Revolute ? 2 : 5;
}

/// X_tree * exp(S q): the parent-from-body displacement f_{i,j} = KK_j exp(S_j q_j).
inline void joint_transform(const SE3& Xt, JointType t, double q, SE3& out) {
  if (t == JointType::Revolute) {
    const double c = std::cos(q), s = std::sin(q);
    out.R.col(0) = c * Xt.R.col(0) + s * Xt.R.col(1);
    out.R.col(1) = c * Xt.R.col(1) - s * Xt.R.col(0);
    out.R.col(2) = Xt.R.col(2);
    out.p = Xt.p;
  } else {
    out.R = Xt.R;
    out.p = Xt.p + q * Xt.R.col(2);
  }
}

/// V x (S qd), eq. (34) gamma = -ad_{S w}(V) = ad_V(S w).
inline Vec6 cross_axis(JointType t, const Vec6& V, double qd) {
  Vec6 r;
  if (t == JointType::Revolute) {
    r << qd * V(1), -qd * V(0), 0, qd * V(4), -qd * V(3), 0;
  } else {
    r << 0, 0, 0, qd * V(1), -qd * V(0), 0;
  }
  return r;
}

}  // namespace detail
}  // namespace se3
