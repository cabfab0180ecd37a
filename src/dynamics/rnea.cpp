// Recursive Newton-Euler, eqs. (33)-(37), body frames.
//
// Verified against the paper: eq. (36) must read ad*_{V_j}(J_j V_j) (the Newton-Euler wrench
// (24) of the body's own velocity), not ad*_{Vdot_j}; with that change the recursion matches
// RNEA(ABA(tau)) = tau and the oracles to rounding. Gravity enters as the fictitious base
// acceleration Vdot_{-1} = [0; -R0^T g] (section 4.3).
//
// The outward pass carries each body's twist V and acceleration A together, component k of both
// in one SSE2 register (V_k, A_k): (33) and (35) apply the same Ad_{f^-1} to both, and J V, J A
// of (36) the same inertia, so every coefficient is loaded once for two products.
#include "joint.h"
#include "se3_sim/dynamics.h"

namespace se3 {
using detail::load2;
using detail::store2;
using detail::v2d;

const VecX& rnea(const Model& model, Data& data, const SE3& base, const VecX& q, const VecX& v,
                 const VecX& a, const Vec6* f_ext_base) {
  const int off = model.floating ? 6 : 0;
  detail::joint_transforms(model, data, q);
  const Vec3 ag = -(base.R.transpose() * model.gravity);
  double* va0 = data.VA[0].data();  // (V_0, A_0, ..., V_5, A_5) of body 0
  if (model.floating) {
    Vec6 A0 = a.head<6>();
    A0.tail<3>() += ag;
    const Vec6 V0 = v.head<6>();
    for (int k = 0; k < 6; ++k) store2(va0 + 2 * k, v2d{V0[k], A0[k]});
    const Inertia& I0 = model.inertia[0];
    data.F[0] = I0 * A0 + cross_force(V0, I0 * V0);
    if (f_ext_base) data.F[0] -= *f_ext_base;
  } else {
    for (int k = 0; k < 3; ++k) {
      store2(va0 + 2 * k, v2d{0, 0});
      store2(va0 + 6 + 2 * k, v2d{0, ag[k]});
    }
    data.F[0].setZero();
  }
  for (int i = 1; i <= model.n; ++i) {
    const SE3& X = data.Xup[i];
    const double* R = X.R.data();  // column-major: R(r, c) = R[r + 3 c]
    const double px = X.p[0], py = X.p[1], pz = X.p[2];
    const double* in = data.VA[2 * model.parent[i]].data();
    const v2d w0 = load2(in), w1 = load2(in + 2), w2 = load2(in + 4);
    // (33), (35): Ad_{f^-1} of the parent's twist and acceleration: R^T w, R^T (v - p x w).
    const v2d t0 = load2(in + 6) - (py * w2 - pz * w1);
    const v2d t1 = load2(in + 8) - (pz * w0 - px * w2);
    const v2d t2 = load2(in + 10) - (px * w1 - py * w0);
    v2d W[3], L[3];
    for (int j = 0; j < 3; ++j) {
      const double r0 = R[3 * j], r1 = R[3 * j + 1], r2 = R[3 * j + 2];
      W[j] = r0 * w0 + r1 * w1 + r2 * w2;
      L[j] = r0 * t0 + r1 * t1 + r2 * t2;
    }
    // The joint: V += S qd; A += V x (S qd) + S qdd, eq. (34) (only the second lane moves).
    const double qd = v[off + i - 1], qdd = a[off + i - 1];
    if (model.joint_type[i] == JointType::Revolute) {
      const double V0 = W[0][0], V1 = W[1][0], V3 = L[0][0], V4 = L[1][0];
      W[0] += v2d{0, qd * V1};
      W[1] -= v2d{0, qd * V0};
      W[2] += v2d{qd, qdd};
      L[0] += v2d{0, qd * V4};
      L[1] -= v2d{0, qd * V3};
    } else {
      const double V0 = W[0][0], V1 = W[1][0];
      L[0] += v2d{0, qd * V1};
      L[1] -= v2d{0, qd * V0};
      L[2] += v2d{qd, qdd};
    }
    double* out = data.VA[2 * i].data();
    for (int j = 0; j < 3; ++j) {
      store2(out + 2 * j, W[j]);
      store2(out + 6 + 2 * j, L[j]);
    }
    // (J V, J A) with J = [I, h^; -h^, m] (eq. 23): n = I w + h x v, f = m v - h x w.
    const Inertia& J = model.inertia[i];
    const double* I = J.I.data();
    const double hx = J.h[0], hy = J.h[1], hz = J.h[2], m = J.m;
    const v2d n0 = I[0] * W[0] + I[3] * W[1] + I[6] * W[2] + (hy * L[2] - hz * L[1]);
    const v2d n1 = I[1] * W[0] + I[4] * W[1] + I[7] * W[2] + (hz * L[0] - hx * L[2]);
    const v2d n2 = I[2] * W[0] + I[5] * W[1] + I[8] * W[2] + (hx * L[1] - hy * L[0]);
    const v2d f0 = m * L[0] - (hy * W[2] - hz * W[1]);
    const v2d f1 = m * L[1] - (hz * W[0] - hx * W[2]);
    const v2d f2 = m * L[2] - (hx * W[1] - hy * W[0]);
    // (36), own-body term: F = J A - ad*_V (J V) = J A + [w x N + v x G; w x G] with
    // (N, G) = J V (first lanes), J A the second lanes.
    const double wx = W[0][0], wy = W[1][0], wz = W[2][0];
    const double vx = L[0][0], vy = L[1][0], vz = L[2][0];
    const double Nx = n0[0], Ny = n1[0], Nz = n2[0], Gx = f0[0], Gy = f1[0], Gz = f2[0];
    double* F = data.F[i].data();
    F[0] = n0[1] + (wy * Nz - wz * Ny) + (vy * Gz - vz * Gy);
    F[1] = n1[1] + (wz * Nx - wx * Nz) + (vz * Gx - vx * Gz);
    F[2] = n2[1] + (wx * Ny - wy * Nx) + (vx * Gy - vy * Gx);
    F[3] = f0[1] + (wy * Gz - wz * Gy);
    F[4] = f1[1] + (wz * Gx - wx * Gz);
    F[5] = f2[1] + (wx * Gy - wy * Gx);
  }
  for (int i = model.n; i >= 1; --i) {
    data.tau[off + i - 1] = data.F[i][detail::axis_index(model.joint_type[i])];  // eq. (37)
    const int p = model.parent[i];
    if (p > 0 || model.floating)
      detail::add_force(data.Xup[i], data.F[i].data(), data.F[p].data());  // eq. (36)
  }
  if (model.floating) data.tau.head<6>() = data.F[0];
  return data.tau;
}

const VecX& bias(const Model& model, Data& data, const SE3& base, const VecX& q, const VecX& v) {
  data.ddq.setZero();
  rnea(model, data, base, q, v, data.ddq);
  data.nle = data.tau;
  return data.nle;
}

}  // namespace se3
