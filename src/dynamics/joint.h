// The hot-path forms of the joint model (model.h's JointModel) and the spatial kernels the
// recursions share. Every moving body's joint has one dof with its axis along the body's z, so
// S is a unit vector e_K of twist coordinates [w; v]: K = 2 (revolute) or 5 (prismatic), and
// S^T x, S q, v x (S qd), I S reduce to a component or a column: the joint-axis sparsity.
// with_joint() is the one dispatch on the joint type: each pass of a recursion calls it once per
// body, with the step written once for any AxisJoint.
#pragma once

#include <cmath>

#include "se3_sim/dynamics.h"

namespace se3 {
namespace detail {

/// X_tree * exp(S q) of a revolute joint, given c = cos q and s = sin q: the parent-from-body
/// displacement f_{i,j} = KK_j exp(S_j q_j) (eq. 26). Rz(q) turns the first two columns.
inline void revolute_transform(const SE3& Xt, double c, double s, SE3& out) {
  const double* a = Xt.R.data();  // column-major
  double* r = out.R.data();
  for (int k = 0; k < 3; ++k) {
    r[k] = c * a[k] + s * a[3 + k];
    r[3 + k] = c * a[3 + k] - s * a[k];
    r[6 + k] = a[6 + k];
  }
  out.p = Xt.p;
}

/// X_tree * exp(S q) of a prismatic joint: a shift along the joint axis.
inline void prismatic_transform(const SE3& Xt, double q, SE3& out) {
  out.R = Xt.R;
  out.p = Xt.p + q * Xt.R.col(2);
}

/// A one-dof joint whose motion subspace is S = e_K (K = 2: rotation about z, K = 5: translation
/// along z).
template <int K>
struct AxisJoint {
  static_assert(K == 2 || K == 5, "joints turn about or slide along the body's z axis");
  static constexpr int axis = K;

  /// out = X_tree exp(S q); c = cos q and s = sin q (read by the revolute joint only).
  static void transform(const SE3& Xt, double q, double c, double s, SE3& out) {
    if constexpr (K == 2) {
      (void)q;
      revolute_transform(Xt, c, s, out);
    } else {
      (void)c, (void)s;
      prismatic_transform(Xt, q, out);
    }
  }
  /// c = V x (S qd), the velocity-product acceleration of eq. (34), for the body's twist V (all
  /// six entries written).
  static void bias_acceleration(const double* V, double qd, double* c) {
    if constexpr (K == 2) {
      c[0] = qd * V[1], c[1] = -qd * V[0], c[2] = 0, c[3] = qd * V[4], c[4] = -qd * V[3], c[5] = 0;
    } else {
      c[0] = c[1] = c[2] = 0, c[3] = qd * V[1], c[4] = -qd * V[0], c[5] = 0;
    }
  }
  /// A += V x (S qd), the same for an acceleration that already holds Ad_{Xup^-1} A_parent.
  static void add_bias_acceleration(const double* V, double qd, double* A) {
    if constexpr (K == 2) {
      A[0] += qd * V[1], A[1] -= qd * V[0], A[3] += qd * V[4], A[4] -= qd * V[3];
    } else {
      A[3] += qd * V[1], A[4] -= qd * V[0];
    }
  }
  /// out = J S, the column K of eq. (23)'s matrix of J.
  static void inertia_column(const Inertia& J, double* out) {
    const double* I = J.I.data();
    if constexpr (K == 2) {
      out[0] = I[6], out[1] = I[7], out[2] = I[8];
      out[3] = -J.h[1], out[4] = J.h[0], out[5] = 0;
    } else {
      out[0] = J.h[1], out[1] = -J.h[0], out[2] = 0;
      out[3] = 0, out[4] = 0, out[5] = J.m;
    }
  }
  /// out = Ad_f S, the joint's axis in the frame where the body sits at f (the world for f = oMb):
  /// revolute [z; p x z], prismatic [0; z], z = f.R e_3.
  static void world_axis(const SE3& f, double* out) {
    const double* R = f.R.data();
    const double zx = R[6], zy = R[7], zz = R[8];
    if constexpr (K == 2) {
      const double* p = f.p.data();
      out[0] = zx, out[1] = zy, out[2] = zz;
      out[3] = p[1] * zz - p[2] * zy;
      out[4] = p[2] * zx - p[0] * zz;
      out[5] = p[0] * zy - p[1] * zx;
    } else {
      out[0] = out[1] = out[2] = 0;
      out[3] = zx, out[4] = zy, out[5] = zz;
    }
  }
};
using RevoluteZ = AxisJoint<2>;
using PrismaticZ = AxisJoint<5>;

/// f(RevoluteZ()) or f(PrismaticZ()) for the joint of a moving body (Model::validate admits no
/// other joint on bodies 1..n).
template <class F>
inline decltype(auto) with_joint(const JointModel& j, F&& f) {
  if (j.type == JointType::Revolute) return f(RevoluteZ());
  return f(PrismaticZ());
}

/// Xup[i] = X_tree[i] exp(S_i q_i) for every body, the sines and cosines first in one batch
/// (sin_q, cos_q). Every recursion starts here: the joints are independent of each other.
void joint_transforms(const Model& model, Data& data, const VecX& q);

/// out = Ad_{f^-1} in for a twist (eq. 33's transform): (R^T w, R^T (v - p x w)). out != in.
inline void inv_motion(const SE3& f, const double* in, double* out) {
  const double* R = f.R.data();  // column-major
  const double px = f.p[0], py = f.p[1], pz = f.p[2];
  const double w0 = in[0], w1 = in[1], w2 = in[2];
  const double t0 = in[3] - (py * w2 - pz * w1);
  const double t1 = in[4] - (pz * w0 - px * w2);
  const double t2 = in[5] - (px * w1 - py * w0);
  for (int j = 0; j < 3; ++j) {
    const double r0 = R[3 * j], r1 = R[3 * j + 1], r2 = R[3 * j + 2];
    out[j] = r0 * w0 + r1 * w1 + r2 * w2;
    out[3 + j] = r0 * t0 + r1 * t1 + r2 * t2;
  }
}

/// The twist recursion of eq. (33) for one body: V = Ad_{Xup^-1} V_parent + S qd.
template <class J>
inline void child_twist(J, const SE3& Xup, const double* Vp, double qd, double* V) {
  inv_motion(Xup, Vp, V);
  V[J::axis] += qd;
}

/// x <- Ad*_{f^-1} x for wrenches x = (n0, n1, n2, f0, f1, f2) given by R, p of f (eq. 19:
/// (R n + p x R f, R f)).
inline void force_to_parent(const double* R, const double* p, double (&x)[6]) {
  double f[3], n[3];
  for (int r = 0; r < 3; ++r) {
    f[r] = R[r] * x[3] + R[r + 3] * x[4] + R[r + 6] * x[5];
    n[r] = R[r] * x[0] + R[r + 3] * x[1] + R[r + 6] * x[2];
  }
  x[0] = n[0] + (p[1] * f[2] - p[2] * f[1]);
  x[1] = n[1] + (p[2] * f[0] - p[0] * f[2]);
  x[2] = n[2] + (p[0] * f[1] - p[1] * f[0]);
  x[3] = f[0], x[4] = f[1], x[5] = f[2];
}

/// out += Ad*_{f^-1} in for a wrench (eq. 19): (R n + p x R f, R f).
inline void add_force(const SE3& f, const double* in, double* out) {
  double x[6] = {in[0], in[1], in[2], in[3], in[4], in[5]};
  force_to_parent(f.R.data(), f.p.data(), x);
  for (int r = 0; r < 6; ++r) out[r] += x[r];
}

/// out = J V for a twist V (eq. 23): (I w + h x v, m v - h x w).
inline void inertia_times(const Inertia& J, const double* V, double* out) {
  const double w0 = V[0], w1 = V[1], w2 = V[2], v0 = V[3], v1 = V[4], v2 = V[5];
  const double hx = J.h[0], hy = J.h[1], hz = J.h[2], m = J.m;
  const double* I = J.I.data();
  out[0] = I[0] * w0 + I[3] * w1 + I[6] * w2 + (hy * v2 - hz * v1);
  out[1] = I[1] * w0 + I[4] * w1 + I[7] * w2 + (hz * v0 - hx * v2);
  out[2] = I[2] * w0 + I[5] * w1 + I[8] * w2 + (hx * v1 - hy * v0);
  out[3] = m * v0 - (hy * w2 - hz * w1);
  out[4] = m * v1 - (hz * w0 - hx * w2);
  out[5] = m * v2 - (hx * w1 - hy * w0);
}

/// out = -ad*_V (J V) = V x* (J V), the velocity-product (bias) wrench of eqs. (24), (39).
inline void bias_force(const Inertia& J, const double* V, double* out) {
  double G[6];
  inertia_times(J, V, G);
  const double w0 = V[0], w1 = V[1], w2 = V[2], v0 = V[3], v1 = V[4], v2 = V[5];
  out[0] = (w1 * G[2] - w2 * G[1]) + (v1 * G[5] - v2 * G[4]);
  out[1] = (w2 * G[0] - w0 * G[2]) + (v2 * G[3] - v0 * G[5]);
  out[2] = (w0 * G[1] - w1 * G[0]) + (v0 * G[4] - v1 * G[3]);
  out[3] = w1 * G[5] - w2 * G[4];
  out[4] = w2 * G[3] - w0 * G[5];
  out[5] = w0 * G[4] - w1 * G[3];
}

}  // namespace detail
}  // namespace se3
