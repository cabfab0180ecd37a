// Articulated-body algorithm in long double: the accuracy reference of charts_data and
// test/gtest_stability.cpp. Same conventions as dynamics.h (body-frame twists, gravity folded
// into the base acceleration, free base first in the output), written independently of
// src/dynamics with plain 6x6 matrices.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "se3_sim/model/model.h"

namespace se3 {
namespace reference {

using L = long double;
using Vec3L = Eigen::Matrix<L, 3, 1>;
using Mat3L = Eigen::Matrix<L, 3, 3>;
using Vec6L = Eigen::Matrix<L, 6, 1>;
using Mat6L = Eigen::Matrix<L, 6, 6>;
using VecXL = Eigen::Matrix<L, Eigen::Dynamic, 1>;

inline Mat3L hatL(const Vec3L& a) {
  Mat3L m;
  m << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return m;
}
/// Ad_{X^-1} as a matrix (motion, child from parent) for X = (R, p).
inline Mat6L motion_inv(const Mat3L& R, const Vec3L& p) {
  Mat6L M = Mat6L::Zero();
  M.topLeftCorner<3, 3>() = R.transpose();
  M.bottomRightCorner<3, 3>() = R.transpose();
  M.bottomLeftCorner<3, 3>() = -R.transpose() * hatL(p);
  return M;
}
inline Vec6L crossm(const Vec6L& V, const Vec6L& U) {
  Vec6L r;
  r.head<3>() = V.head<3>().cross(U.head<3>());
  r.tail<3>() = V.tail<3>().cross(U.head<3>()) + V.head<3>().cross(U.tail<3>());
  return r;
}
inline Vec6L crossf(const Vec6L& V, const Vec6L& F) {
  Vec6L r;
  r.head<3>() = V.head<3>().cross(F.head<3>()) + V.tail<3>().cross(F.tail<3>());
  r.tail<3>() = V.head<3>().cross(F.tail<3>());
  return r;
}

/// ddq (nv) for tau (nv; the first six entries a wrench on a free base).
inline VecXL aba_long_double(const Model& m, const SE3& base, const Eigen::VectorXd& q,
                             const Eigen::VectorXd& v, const Eigen::VectorXd& tau) {
  const int n = m.n;
  std::vector<Mat6L> Xi(n + 1), IA(n + 1);
  std::vector<Vec6L> V(n + 1), c(n + 1), pA(n + 1), U(n + 1), A(n + 1);
  std::vector<L> D(n + 1), u(n + 1);
  std::vector<int> ax(n + 1);
  auto inertia = [](const Inertia& I) {
    Mat6L J = Mat6L::Zero();
    const Vec3L h = I.h.cast<L>();
    J.topLeftCorner<3, 3>() = I.I.cast<L>();
    J.topRightCorner<3, 3>() = hatL(h);
    J.bottomLeftCorner<3, 3>() = -hatL(h);
    J.bottomRightCorner<3, 3>() = Mat3L::Identity() * static_cast<L>(I.m);
    return J;
  };
  const Mat3L R0 = base.R.cast<L>();
  Vec6L ag;
  ag << 0, 0, 0, -(R0.transpose() * m.gravity.cast<L>());
  V[0] = m.floating ? Vec6L(v.head<6>().cast<L>()) : Vec6L::Zero();
  IA[0] = inertia(m.inertia[0]);
  pA[0] = crossf(V[0], IA[0] * V[0]);
  for (int i = 1; i <= n; ++i) {
    const Mat3L Rt = m.X_tree[i].R.cast<L>();
    const Vec3L pt = m.X_tree[i].p.cast<L>();
    const L qi = q[i - 1];
    Mat3L R = Rt;
    Vec3L p = pt;
    ax[i] = m.joints[i].axis();
    if (ax[i] == 2) {
      Mat3L Rz = Mat3L::Identity();
      Rz(0, 0) = std::cos(qi);
      Rz(0, 1) = -std::sin(qi);
      Rz(1, 0) = std::sin(qi);
      Rz(1, 1) = std::cos(qi);
      R = Rt * Rz;
    } else {
      p = pt + qi * Rt.col(2);
    }
    Xi[i] = motion_inv(R, p);
    const L qd = v[m.idx_v(i)];
    V[i] = Xi[i] * V[m.parent[i]];
    V[i][ax[i]] += qd;
    Vec6L Sq = Vec6L::Zero();
    Sq[ax[i]] = qd;
    c[i] = crossm(V[i], Sq);
    IA[i] = inertia(m.inertia[i]);
    pA[i] = crossf(V[i], IA[i] * V[i]);
  }
  for (int i = n; i >= 1; --i) {
    U[i] = IA[i].col(ax[i]);
    D[i] = U[i][ax[i]];
    u[i] = static_cast<L>(tau[m.idx_v(i)]) - pA[i][ax[i]];
    const Mat6L Ia = IA[i] - U[i] * U[i].transpose() / D[i];
    const Vec6L pa = pA[i] + Ia * c[i] + U[i] * (u[i] / D[i]);
    const int p = m.parent[i];
    IA[p] += Xi[i].transpose() * Ia * Xi[i];
    pA[p] += Xi[i].transpose() * pa;
  }
  VecXL out(m.nv);
  if (m.floating) {
    pA[0] -= tau.head<6>().cast<L>();
    A[0] = -IA[0].ldlt().solve(pA[0]);
    out.head<6>() = A[0] - ag;
  } else {
    A[0] = ag;
  }
  for (int i = 1; i <= n; ++i) {
    A[i] = Xi[i] * A[m.parent[i]] + c[i];
    const L qdd = (u[i] - U[i].dot(A[i])) / D[i];
    A[i][ax[i]] += qdd;
    out[m.idx_v(i)] = qdd;
  }
  return out;
}

}  // namespace reference
}  // namespace se3
