// The hot-path forms of the joint model (model.h's JointModel) and the spatial kernels the
// recursions share. Every moving body's joint has one dof with its axis along the body's z, so
// S is a unit vector e_K of twist coordinates [w; v]: K = 2 (revolute) or 5 (prismatic), and
// S^T x, S q, v x (S qd), I S reduce to a component or a column: the joint-axis sparsity.
// with_joint() is the one dispatch on the joint type: each pass of a recursion calls it once per
// body, with the step written once for any AxisJoint.
//
// A joint whose X_tree turns about z only (JointModel::z_rotation: R = [Q 0; 0 1] exactly, e.g.
// the identity: the first joint of the arms, Solo12's knees) keeps that form in X_tree exp(S q),
// and its kernels transform by the 2x2 block Q: 4 multiplies per 3-vector instead of 9. A joint
// whose X_tree maps its z axis exactly onto a parent axis +-e_k (JointModel::axis_row = k: the
// quarter turns of the arms' wrists and Solo12's hips) keeps that too, with 5 multiplies. They
// compute the same sums as the general kernels less the products with the exact zeros, so the
// results are the same numbers (the forms kZ and kAxisRow, nonzero() and dot3() below). Likewise a
// revolute joint's offset p (Xup's is X_tree's) has components that are exactly zero on most robots
// (JointModel::offset_axes): its cross products p x . then skip them.
#pragma once

#include <cmath>
#include <type_traits>

#include "se3_sim/dynamics/dynamics.h"

// The kernels below are instantiated per joint form (with_joint): forced inline so that each
// recursion's step stays one function (GCC otherwise stops inlining the larger ones, with calls
// and spills that cost more than the forms save).
// SE3_LAMBDA does the same for the steps handed to with_joint.
// SE3_NOINLINE keeps a rarely taken step out of its caller, whose registers GCC allocates worse
// with it inside. SE3_SIM_NO_FORCED_INLINE leaves inlining to the compiler (the sanitizer build:
// the same code, compiled in a fraction of the time).
#if defined(__GNUC__) && !defined(SE3_SIM_NO_FORCED_INLINE)
#define SE3_KERNEL inline __attribute__((always_inline))
#define SE3_LAMBDA __attribute__((always_inline))
#define SE3_NOINLINE __attribute__((noinline))
#else
#define SE3_KERNEL inline
#define SE3_LAMBDA
#define SE3_NOINLINE
#endif

namespace se3 {
namespace detail {

/// The joint forms: what the kernels may assume of the rotation R of X_tree, and so of
/// X_tree exp(S q) (whose first two columns mix X_tree's, the third kept). kGeneral: nothing;
/// kZ (JointModel::z_rotation): R = [Q 0; 0 1] exactly, whose 1 they need not multiply by;
/// kAxisRow + k (JointModel::axis_row): row k = (0, 0, +-1) and column 2 = +-e_k exactly.
/// Written against the pattern, a kernel computes the general kernel's sums less the products
/// with the exact zeros (and the exact one of kZ), in the same order: the same numbers.
constexpr int kGeneral = 0, kZ = 1, kAxisRow = 2;
/// May R(r, c) be nonzero in form F?
constexpr bool nonzero(int F, int r, int c) {
  return F == kGeneral || (F == kZ ? (r < 2) == (c < 2) : (r == F - kAxisRow) == (c == 2));
}
/// Row r of R is zero in columns 0 and 1 (r is where form F sends the joint axis).
constexpr bool axis_row_of(int F, int r) {
  return (F == kZ && r == 2) || (F >= kAxisRow && r == F - kAxisRow);
}

/// Row i of R (Row) or its column i, times (x0, x1, x2), without the products form F makes zero
/// (or one).
template <int F, bool Row, int i>
SE3_KERNEL double dot3(const double* R, double x0, double x1, double x2) {
  constexpr bool n0 = Row ? nonzero(F, i, 0) : nonzero(F, 0, i);
  constexpr bool n1 = Row ? nonzero(F, i, 1) : nonzero(F, 1, i);
  constexpr bool n2 = Row ? nonzero(F, i, 2) : nonzero(F, 2, i);
  constexpr int e0 = Row ? i : 3 * i, e1 = Row ? i + 3 : 3 * i + 1, e2 = Row ? i + 6 : 3 * i + 2;
  if constexpr (n0 && n1 && n2) {
    return R[e0] * x0 + R[e1] * x1 + R[e2] * x2;
  } else if constexpr (n0 && n1) {
    return R[e0] * x0 + R[e1] * x1;
  } else if constexpr (n0 && n2) {
    return R[e0] * x0 + R[e2] * x2;
  } else if constexpr (n1 && n2) {
    return R[e1] * x1 + R[e2] * x2;
  } else if constexpr (n2) {
    if constexpr (F == kZ) {
      return x2;  // R(2, 2) = 1
    } else {
      return R[e2] * x2;
    }
  } else if constexpr (n1) {
    return R[e1] * x1;
  } else if constexpr (n0) {
    return R[e0] * x0;
  } else {
    return 0.0;
  }
}

/// X_tree * exp(S q) of a revolute joint, given c = cos q and s = sin q: the parent-from-body
/// displacement f_{i,j} = KK_j exp(S_j q_j) (eq. 26). Rz(q) turns the first two columns; the
/// row form F makes zero in them stays zero (copied from X_tree).
template <int F = kGeneral>
SE3_KERNEL void revolute_transform(const SE3& Xt, double c, double s, SE3& out) {
  const double* a = Xt.R.data();  // column-major
  double* r = out.R.data();
  auto row = [&](auto kk) SE3_LAMBDA {
    constexpr int k = decltype(kk)::value;
    if constexpr (axis_row_of(F, k)) {
      r[k] = a[k], r[3 + k] = a[3 + k];
    } else {
      r[k] = c * a[k] + s * a[3 + k];
      r[3 + k] = c * a[3 + k] - s * a[k];
    }
  };
  row(std::integral_constant<int, 0>());
  row(std::integral_constant<int, 1>());
  row(std::integral_constant<int, 2>());
  for (int k = 0; k < 3; ++k) r[6 + k] = a[6 + k];
  out.p = Xt.p;
}

/// X_tree * exp(S q) of a prismatic joint: a shift along the joint axis.
SE3_KERNEL void prismatic_transform(const SE3& Xt, double q, SE3& out) {
  out.R = Xt.R;
  out.p = Xt.p + q * Xt.R.col(2);
}

/// A one-dof joint whose motion subspace is S = e_K (K = 2: rotation about z, K = 5: translation
/// along z); F: its X_tree's form (kGeneral, kZ: JointModel::z_rotation, kAxisRow + k:
/// JointModel::axis_row = k; a prismatic joint has kGeneral or kZ).
/// PM: the components of Xup's offset that may be nonzero (bit k for p[k]; 7 for a prismatic
/// joint, whose offset moves with q).
template <int K, int F = kGeneral, int PM = 7>
struct AxisJoint {
  static_assert(K == 2 || K == 5, "joints turn about or slide along the body's z axis");
  static_assert(K == 2 || PM == 7, "a prismatic joint's offset moves with q");
  static_assert(K == 2 || F <= kZ, "a prismatic joint has the general or the z form");
  static constexpr int axis = K;
  static constexpr int form = F;
  static constexpr bool z_rotation = F == kZ;
  static constexpr int offset = PM;

  /// out = X_tree exp(S q); c = cos q and s = sin q (read by the revolute joint only).
  SE3_KERNEL static void transform(const SE3& Xt, double q, double c, double s, SE3& out) {
    if constexpr (K == 2) {
      (void)q;
      revolute_transform<F>(Xt, c, s, out);
    } else {
      (void)c, (void)s;
      prismatic_transform(Xt, q, out);
    }
  }
  /// c = V x (S qd), the velocity-product acceleration of eq. (34), for the body's twist V (all
  /// six entries written).
  SE3_KERNEL static void bias_acceleration(const double* V, double qd, double* c) {
    if constexpr (K == 2) {
      c[0] = qd * V[1], c[1] = -qd * V[0], c[2] = 0, c[3] = qd * V[4], c[4] = -qd * V[3], c[5] = 0;
    } else {
      c[0] = c[1] = c[2] = 0, c[3] = qd * V[1], c[4] = -qd * V[0], c[5] = 0;
    }
  }
  /// A += V x (S qd), the same for an acceleration that already holds Ad_{Xup^-1} A_parent.
  SE3_KERNEL static void add_bias_acceleration(const double* V, double qd, double* A) {
    if constexpr (K == 2) {
      A[0] += qd * V[1], A[1] -= qd * V[0], A[3] += qd * V[4], A[4] -= qd * V[3];
    } else {
      A[3] += qd * V[1], A[4] -= qd * V[0];
    }
  }
  /// out = J S, the column K of eq. (23)'s matrix of J.
  SE3_KERNEL static void inertia_column(const Inertia& J, double* out) {
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
  SE3_KERNEL static void world_axis(const SE3& f, double* out) {
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

/// The joint of dispatch index Kind (JointModel::kind): revolute AxisJoint<2, Kind / 8, Kind % 8>
/// for Kind < 40 (the forms kGeneral, kZ, kAxisRow + k are 0 to 4), prismatic AxisJoint<5,
/// Kind - 40> for 40 and 41.
template <int Kind>
using JointOfKind =
    std::conditional_t<(Kind < 40), AxisJoint<2, Kind / 8, Kind % 8>, AxisJoint<5, Kind - 40>>;

// The cases of with_joint's switch, eight at a time (one case a line; clang-format would
// otherwise reflow the macro differently on every pass).
// clang-format off
#define SE3_JOINT_CASE(k) \
  case k:                 \
    return f(JointOfKind<k>());
#define SE3_JOINT_CASES8(b) \
  SE3_JOINT_CASE(b)         \
  SE3_JOINT_CASE(b + 1)     \
  SE3_JOINT_CASE(b + 2)     \
  SE3_JOINT_CASE(b + 3)     \
  SE3_JOINT_CASE(b + 4)     \
  SE3_JOINT_CASE(b + 5)     \
  SE3_JOINT_CASE(b + 6)     \
  SE3_JOINT_CASE(b + 7)
// clang-format on

/// f(AxisJoint<K, F, PM>()) for the joint of a moving body (Model::validate admits no other joint
/// on bodies 1..n): K from its type, F its form (z_rotation, axis_row), PM its offset_axes
/// (revolute), all read from JointModel::kind by one switch (a jump table).
template <class F>
SE3_KERNEL decltype(auto) with_joint(const JointModel& j, F&& f) {
  switch (j.kind) {
    SE3_JOINT_CASES8(0)
    SE3_JOINT_CASES8(8)
    SE3_JOINT_CASES8(16)
    SE3_JOINT_CASES8(24)
    SE3_JOINT_CASES8(32)
    SE3_JOINT_CASE(41)
    default:
      return f(JointOfKind<40>());
  }
}
#undef SE3_JOINT_CASES8
#undef SE3_JOINT_CASE

/// with_joint for steps that read no offset (AxisJoint<K, F>, PM = 7): fewer copies of them.
template <class F>
SE3_KERNEL decltype(auto) with_joint_form(const JointModel& j, F&& f) {
  switch (j.kind >> 3) {
    case 0:
      return f(AxisJoint<2, kGeneral>());
    case 1:
      return f(AxisJoint<2, kZ>());
    case 2:
      return f(AxisJoint<2, kAxisRow>());
    case 3:
      return f(AxisJoint<2, kAxisRow + 1>());
    case 4:
      return f(AxisJoint<2, kAxisRow + 2>());
    default:
      if (j.kind == 41) return f(AxisJoint<5, kZ>());
      return f(AxisJoint<5, kGeneral>());
  }
}

/// out = a b for b = Xup of a joint J (forward kinematics' oMb[parent] Xup[i]): column c of
/// out's rotation sums a.R's columns k over the entries b.R(k, c) that J's form may make
/// nonzero, and out.p = a.R b.p + a.p over the components of b.p that J's offset may make
/// nonzero (12 to 15 multiplies for the rotation instead of 27).
template <class J>
SE3_KERNEL void compose(J, const SE3& a, const SE3& b, SE3& out) {
  constexpr int F = J::form, PM = J::offset;
  const double* A = a.R.data();  // column-major
  const double* B = b.R.data();
  double* O = out.R.data();
  auto column = [&](auto cc) SE3_LAMBDA {
    constexpr int c = decltype(cc)::value;
#pragma GCC unroll 3
    for (int r = 0; r < 3; ++r) O[r + 3 * c] = dot3<F, false, c>(B, A[r], A[r + 3], A[r + 6]);
  };
  column(std::integral_constant<int, 0>());
  column(std::integral_constant<int, 1>());
  column(std::integral_constant<int, 2>());
  const double* bp = b.p.data();
  constexpr bool p0 = PM & 1, p1 = PM & 2, p2 = PM & 4;
#pragma GCC unroll 3
  for (int r = 0; r < 3; ++r) {
    double x = 0;
    if constexpr (p0) x = A[r] * bp[0];
    if constexpr (p1) x = p0 ? x + A[r + 3] * bp[1] : A[r + 3] * bp[1];
    if constexpr (p2) x = (p0 || p1) ? x + A[r + 6] * bp[2] : A[r + 6] * bp[2];
    out.p[r] = (p0 || p1 || p2) ? x + a.p[r] : a.p[r];
  }
}

/// Xup[i] = X_tree[i] exp(S_i q_i) for every body, the sines and cosines first in one batch
/// (sin_q, cos_q). Every recursion starts here: the joints are independent of each other.
void joint_transforms(const Model& model, Data& data, const VecX& q);

/// y = R^T x for a column-major R of form F (9 multiplies; kZ 4, kAxisRow + k 5).
template <int F = kGeneral>
SE3_KERNEL void rotate_back(const double* R, double x0, double x1, double x2, double* y) {
  y[0] = dot3<F, false, 0>(R, x0, x1, x2);
  y[1] = dot3<F, false, 1>(R, x0, x1, x2);
  y[2] = dot3<F, false, 2>(R, x0, x1, x2);
}

/// y = R x for a column-major R of form F (9 multiplies; kZ 4, kAxisRow + k 5).
template <int F = kGeneral>
SE3_KERNEL void rotate(const double* R, double x0, double x1, double x2, double* y) {
  y[0] = dot3<F, true, 0>(R, x0, x1, x2);
  y[1] = dot3<F, true, 1>(R, x0, x1, x2);
  y[2] = dot3<F, true, 2>(R, x0, x1, x2);
}

/// Component r of p x x, p[i] x[j] - p[j] x[i] for (i, j) = (r + 1, r + 2) mod 3, where only the
/// components of p in PM (bit k: p[k]) may be nonzero: the others' products are left out (a
/// product with an exact zero adds nothing; 0 when both are out).
template <int PM, int r>
SE3_KERNEL double cross(const double* p, const double* x) {
  constexpr int i = (r + 1) % 3, j = (r + 2) % 3;
  constexpr bool hi = (PM >> i) & 1, hj = (PM >> j) & 1;
  if constexpr (hi && hj) {
    return p[i] * x[j] - p[j] * x[i];
  } else if constexpr (hi) {
    return p[i] * x[j];
  } else if constexpr (hj) {
    return -(p[j] * x[i]);
  } else {
    return 0.0;
  }
}
/// a - (p x x)_r with cross's PM, written so that a left-out product leaves no operation.
template <int PM, int r>
SE3_KERNEL double minus_cross(double a, const double* p, const double* x) {
  constexpr int i = (r + 1) % 3, j = (r + 2) % 3;
  constexpr bool hi = (PM >> i) & 1, hj = (PM >> j) & 1;
  if constexpr (hi && hj) {
    return a - (p[i] * x[j] - p[j] * x[i]);
  } else if constexpr (hi) {
    return a - p[i] * x[j];
  } else if constexpr (hj) {
    return a + p[j] * x[i];
  } else {
    return a;
  }
}
/// a + (p x x)_r with cross's PM (a + 0 is a, but for the sign of a zero a).
template <int PM, int r>
SE3_KERNEL double plus_cross(double a, const double* p, const double* x) {
  constexpr int i = (r + 1) % 3, j = (r + 2) % 3;
  constexpr bool hi = (PM >> i) & 1, hj = (PM >> j) & 1;
  if constexpr (hi && hj) {
    return a + (p[i] * x[j] - p[j] * x[i]);
  } else if constexpr (hi) {
    return a + p[i] * x[j];
  } else if constexpr (hj) {
    return a - p[j] * x[i];
  } else {
    return a;
  }
}

/// out = Ad_{f^-1} in for a twist (eq. 33's transform): (R^T w, R^T (v - p x w)). out != in.
/// F: f.R's form; PM: the components of f.p that may be nonzero.
template <int F = kGeneral, int PM = 7>
SE3_KERNEL void inv_motion(const SE3& f, const double* in, double* out) {
  const double* R = f.R.data();  // column-major
  const double* p = f.p.data();
  const double w[3] = {in[0], in[1], in[2]};
  const double t0 = minus_cross<PM, 0>(in[3], p, w);
  const double t1 = minus_cross<PM, 1>(in[4], p, w);
  const double t2 = minus_cross<PM, 2>(in[5], p, w);
  rotate_back<F>(R, w[0], w[1], w[2], out);
  rotate_back<F>(R, t0, t1, t2, out + 3);
}

/// The twist recursion of eq. (33) for one body: V = Ad_{Xup^-1} V_parent + S qd.
template <class J>
SE3_KERNEL void child_twist(J, const SE3& Xup, const double* Vp, double qd, double* V) {
  inv_motion<J::form, J::offset>(Xup, Vp, V);
  V[J::axis] += qd;
}

/// x <- Ad*_{f^-1} x for wrenches x = (n0, n1, n2, f0, f1, f2) given by R, p of f (eq. 19:
/// (R n + p x R f, R f)). F: R's form; PM: the components of p that may be nonzero.
template <int F = kGeneral, int PM = 7>
SE3_KERNEL void force_to_parent(const double* R, const double* p, double (&x)[6]) {
  double f[3], n[3];
  rotate<F>(R, x[3], x[4], x[5], f);
  rotate<F>(R, x[0], x[1], x[2], n);
  x[0] = plus_cross<PM, 0>(n[0], p, f);
  x[1] = plus_cross<PM, 1>(n[1], p, f);
  x[2] = plus_cross<PM, 2>(n[2], p, f);
  x[3] = f[0], x[4] = f[1], x[5] = f[2];
}

/// Component K of force_to_parent's result (K = 2: the torque's z, 5: the force's z), the same
/// sums without the other components.
template <int F, int PM, int K>
SE3_KERNEL double force_to_parent_component(const double* R, const double* p,
                                            const double (&x)[6]) {
  if constexpr (K == 5) {
    return dot3<F, true, 2>(R, x[3], x[4], x[5]);
  } else {
    static_assert(K == 2, "a joint axis is component 2 or 5");
    double f[3];
    rotate<F>(R, x[3], x[4], x[5], f);
    const double n2 = dot3<F, true, 2>(R, x[0], x[1], x[2]);
    return plus_cross<PM, 2>(n2, p, f);
  }
}

/// out += Ad*_{f^-1} in for a wrench (eq. 19): (R n + p x R f, R f). F, PM: force_to_parent's.
template <int F = kGeneral, int PM = 7>
SE3_KERNEL void add_force(const SE3& f, const double* in, double* out) {
  double x[6] = {in[0], in[1], in[2], in[3], in[4], in[5]};
  force_to_parent<F, PM>(f.R.data(), f.p.data(), x);
  for (int r = 0; r < 6; ++r) out[r] += x[r];
}

/// out = J V for a twist V (eq. 23): (I w + h x v, m v - h x w).
SE3_KERNEL void inertia_times(const Inertia& J, const double* V, double* out) {
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
SE3_KERNEL void bias_force(const Inertia& J, const double* V, double* out) {
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

/// out = J A + V x* (J V), the Newton-Euler wrench of eq. (36) for the body's own motion, in the
/// arrangement of fewest products: with V = (w, v), A = (al, a), J = (I, h, m) and b = a + w x v
/// (Jacobi's identity turns w x (h x v) + v x (w x h) into h x (w x v)),
///   n = I al + w x (I w) + h x b,   f = m b - h x al - w x (h x w):
/// 57 multiplies instead of inertia_times and bias_force's 66 (the same sums but for rounding).
SE3_KERNEL void newton_euler(const Inertia& J, const double* V, const double* A, double* out) {
  const double w0 = V[0], w1 = V[1], w2 = V[2], v0 = V[3], v1 = V[4], v2 = V[5];
  const double l0 = A[0], l1 = A[1], l2 = A[2];
  const double hx = J.h[0], hy = J.h[1], hz = J.h[2], m = J.m;
  const double* I = J.I.data();
  const double b0 = A[3] + (w1 * v2 - w2 * v1);
  const double b1 = A[4] + (w2 * v0 - w0 * v2);
  const double b2 = A[5] + (w0 * v1 - w1 * v0);
  const double n0 = I[0] * w0 + I[3] * w1 + I[6] * w2;  // I w
  const double n1 = I[1] * w0 + I[4] * w1 + I[7] * w2;
  const double n2 = I[2] * w0 + I[5] * w1 + I[8] * w2;
  const double s0 = hy * w2 - hz * w1, s1 = hz * w0 - hx * w2, s2 = hx * w1 - hy * w0;  // h x w
  out[0] = (I[0] * l0 + I[3] * l1 + I[6] * l2) + (w1 * n2 - w2 * n1) + (hy * b2 - hz * b1);
  out[1] = (I[1] * l0 + I[4] * l1 + I[7] * l2) + (w2 * n0 - w0 * n2) + (hz * b0 - hx * b2);
  out[2] = (I[2] * l0 + I[5] * l1 + I[8] * l2) + (w0 * n1 - w1 * n0) + (hx * b1 - hy * b0);
  out[3] = m * b0 - (hy * l2 - hz * l1) - (w1 * s2 - w2 * s1);
  out[4] = m * b1 - (hz * l0 - hx * l2) - (w2 * s0 - w0 * s2);
  out[5] = m * b2 - (hx * l1 - hy * l0) - (w0 * s1 - w1 * s0);
}

}  // namespace detail
}  // namespace se3
