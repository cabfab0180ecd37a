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

#include "../lie/simd.h"
#include "joint.h"
#include "se3_sim/dynamics/dynamics.h"

namespace se3 {
namespace {

// The body's inertia J placed at f (the world frame for f = oMb), as the upper triangle of its
// 6x6 matrix (eq. 23) in out; the lower triangle is left as it was (minv reads the upper
// triangles only). With g = R h: h' = g + m p,
// I' = R I R^T + (2 p.g + m p.p) 1 - (w p^T + p w^T), w = g + m p / 2 (Inertia::transformed,
// written straight into the matrix the recursion sums).
SE3_KERNEL void world_inertia(const Inertia& J, const SE3& f, Mat6& out) {
  const double* R = f.R.data();  // column-major
  const double* I = J.I.data();
  const double* h = J.h.data();
  const double m = J.m;
  double g[3], Z[3][3];
#pragma GCC unroll 3
  for (int r = 0; r < 3; ++r) {
    const double r0 = R[r], r1 = R[r + 3], r2 = R[r + 6];
    g[r] = r0 * h[0] + r1 * h[1] + r2 * h[2];
    for (int c = 0; c < 3; ++c) Z[r][c] = r0 * I[3 * c] + r1 * I[3 * c + 1] + r2 * I[3 * c + 2];
  }
  const double px = f.p[0], py = f.p[1], pz = f.p[2];
  const double d = 2.0 * (px * g[0] + py * g[1] + pz * g[2]) + m * (px * px + py * py + pz * pz);
  const double w[3] = {g[0] + 0.5 * m * px, g[1] + 0.5 * m * py, g[2] + 0.5 * m * pz};
  const double pv[3] = {px, py, pz};
  double* o = out.data();  // o[r + 6 c]
#pragma GCC unroll 3
  for (int r = 0; r < 3; ++r) {
#pragma GCC unroll 3
    for (int c = r; c < 3; ++c) {
      double x =
          Z[r][0] * R[c] + Z[r][1] * R[c + 3] + Z[r][2] * R[c + 6] - (w[r] * pv[c] + pv[r] * w[c]);
      if (r == c) x += d;
      o[r + 6 * c] = x;
    }
  }
  const double hx = g[0] + m * px, hy = g[1] + m * py, hz = g[2] + m * pz;
  o[0 + 18] = 0, o[0 + 24] = -hz, o[0 + 30] = hy;
  o[1 + 18] = hz, o[1 + 24] = 0, o[1 + 30] = -hx;
  o[2 + 18] = -hy, o[2 + 24] = hx, o[2 + 30] = 0;
  o[3 + 18] = m, o[3 + 24] = 0, o[3 + 30] = 0;
  o[4 + 24] = m, o[4 + 30] = 0;
  o[5 + 30] = m;
}

// U = IA S for a symmetric IA given by its upper triangle (column-major, m[r + 6 c], r <= c),
// each entry summed over c = 0..5 in order as the full product does.
SE3_KERNEL void upper_times(const Mat6& IA, const Vec6& S, Vec6& U) {
  const double* m = IA.data();
  double u[6] = {0, 0, 0, 0, 0, 0};
#pragma GCC unroll 6
  for (int c = 0; c < 6; ++c) {
    const double s = S[c];
    double x = 0;
#pragma GCC unroll 6
    for (int r = 0; r < c; ++r) {
      u[r] += m[r + 6 * c] * s;  // entry (r, c)
      x += m[r + 6 * c] * S[r];  // entry (c, r) = (r, c)
    }
    u[c] = x + m[c + 6 * c] * s;
  }
  for (int r = 0; r < 6; ++r) U[r] = u[r];
}

// D^-1 from CRBA's D (eq. 50) for small trees, where the recursion's O(n^2) column loops are
// mostly loop overhead: D = L^T Diag L (mass_matrix_ltdl), then Y = D^-1 row by row from
// L Y = Diag^-1 L^-T:
//   Y(k, j) = -sum_{i anc k} L(k, i) Y(i, j)  (j < k),
//   Y(k, k) = 1 / Diag_k - sum_{i anc k} L(k, i) Y(k, i),
// whose right-hand sides hold only rows already done (Y symmetric): Y's row k in the upper part
// of column k of Minv, then mirrored.
// The loops run 1 to nv times: GCC's vectorized versions (alias checks, peeling) cost more than
// they save at these lengths.
#if defined(__GNUC__) && !defined(__clang__)
__attribute__((optimize("no-tree-vectorize")))
#endif
const MatX&
minv_factor(const Model& model, Data& data, const SE3& base, const VecX& q) {
  const int nv = model.nv;
  const double* L = mass_matrix_ltdl(model, data, base, q).data();
  MatX& Y = data.Minv;
  double* H = Y.data();  // column-major: H[r + nv c]
  const int* lam = data.v_parent.data();
  const auto at = [nv](int r, int c) { return r + static_cast<std::ptrdiff_t>(c) * nv; };
  const double* dinv = data.Dinv.data();
  for (int k = 0; k < nv; ++k) {
    double* yk = H + at(0, k);  // yk[j] = Y(k, j) = Y(j, k) for j < k
    for (int j = 0; j < k; ++j) yk[j] = 0;
    for (int i = lam[k]; i >= 0; i = lam[i]) {
      const double l = L[at(k, i)];
      const double* yi = H + at(0, i);  // Y(i, j) for j <= i: column i's upper part
      for (int j = 0; j <= i; ++j) yk[j] -= l * yi[j];
      for (int j = i + 1; j < k; ++j) yk[j] -= l * H[at(i, j)];  // Y(i, j) = Y(j, i): row i
    }
    double d = dinv[k];
    for (int i = lam[k]; i >= 0; i = lam[i]) d -= L[at(k, i)] * yk[i];
    yk[k] = d;
  }
  for (int c = 0; c < nv; ++c) {
    for (int r = c + 1; r < nv; ++r) H[at(r, c)] = H[at(c, r)];
  }
  return Y;
}

const MatX& minv_recursive(const Model& model, Data& data, const SE3& base, const VecX& q) {
  const int nv = model.nv;
  // Every moving body's joint has one dof, numbered in body order after the base's: body i's
  // row and column is v1 + i, its subtree's columns v1 + i .. v1 + subtree_end[i]. Bounds in body
  // indices let the compiler run the column loops on one index (docs/performance.md).
  const int v1 = model.nv_base() - 1;
  forward_kinematics(model, data, base, q);
  for (int i = model.floating ? 0 : 1; i <= model.n; ++i) {
    world_inertia(model.inertia[i], data.oMb[i], data.IA[i]);
  }
  auto& F = data.Fm;
  F.setZero();
  MatX& Mi = data.Minv;
  for (int i = model.n; i >= 1; --i) {
    const JointModel& jm = model.joints[i];
    const int row = v1 + i;
    Vec6& S = data.S[row];
    detail::with_joint_form(jm, [&](auto J) SE3_LAMBDA { J.world_axis(data.oMb[i], S.data()); });
    const Mat6& IA = data.IA[i];
    Vec6& U = data.U[row];
    upper_times(IA, S, U);               // (61) up to Omega^-1
    const double Dinv = 1.0 / S.dot(U);  // (60)
    data.Dinv[row] = Dinv;
    const int len = model.subtree_end[i] - i + 1;
    // Row i of D^-1 (upper triangle) is kept as column i (contiguous in column-major storage).
    // The column loops touch entry j of each array only at step j (no loop-carried
    // dependency, also when P_i and P_parent share storage), hence SE3_SIM_IVDEP.
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
    SE3_SIM_IVDEP
    for (int j = row + 1; j < row + len; ++j) {
      r[j] = s0 * f0[j] + s1 * f1[j] + s2 * f2[j] + s3 * f3[j] + s4 * f4[j] + s5 * f5[j];
    }
    if (carry) {  // (62)
      const double u0 = U[0], u1 = U[1], u2 = U[2], u3 = U[3], u4 = U[4], u5 = U[5];
      SE3_SIM_IVDEP
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
    for (int j = row + len; j < nv; ++j) r[j] = 0;  // filled by the outward pass
    if (carry) {                                    // (59), (63), on the upper triangle
      double* o = data.IA[p].data();
      const double* a = IA.data();
      double Ud[6];
      for (int r = 0; r < 6; ++r) Ud[r] = U[r] * Dinv;
#pragma GCC unroll 6
      for (int c = 0; c < 6; ++c) {
        const double uc = U[c];
#pragma GCC unroll 6
        for (int r = 0; r <= c; ++r) o[r + 6 * c] += a[r + 6 * c] - Ud[r] * uc;
      }
    }
  }
  if (model.floating) {
    // S_0 = 1 in the base frame: Omega_0 = Ad^T IA_0 Ad, row block = Omega_0^-1 (E - Ad^T F),
    // E the first six columns of the identity. Row operations on the 6 x nv blocks (each row
    // contiguous), Omega_0 = L L^T by Cholesky.
    const SE3& f0 = data.oMb[0];
    const Mat6 Adf = Ad(f0);
    const Mat6 IA0 = data.IA[0].selfadjointView<Eigen::Upper>();
    const Mat6 Omega0 = Adf.transpose() * IA0 * Adf;
    const Eigen::LLT<Mat6> llt(Omega0);
    const Mat6 L = llt.matrixL();
    Data::Mat6X& P0 = data.Pm[data.P_slot[0]];
    double* pr[6];
    const double* fr[6];
    for (int k = 0; k < 6; ++k) pr[k] = P0.row(k).data(), fr[k] = F.row(k).data();
    for (int k = 0; k < 6; ++k) {  // row k of E - Ad^T F
      const double a0 = Adf(0, k), a1 = Adf(1, k), a2 = Adf(2, k), a3 = Adf(3, k), a4 = Adf(4, k),
                   a5 = Adf(5, k);
      double* o = pr[k];
      for (int j = 0; j < nv; ++j) {
        o[j] = -(a0 * fr[0][j] + a1 * fr[1][j] + a2 * fr[2][j] + a3 * fr[3][j] + a4 * fr[4][j] +
                 a5 * fr[5][j]);
      }
      o[k] += 1.0;
    }
    for (int k = 0; k < 6; ++k) {  // L y = x, row by row
      double* o = pr[k];
      for (int l = 0; l < k; ++l) {
        const double c = L(k, l);
        const double* y = pr[l];
        for (int j = 0; j < nv; ++j) o[j] -= c * y[j];
      }
      const double d = 1.0 / L(k, k);
      for (int j = 0; j < nv; ++j) o[j] *= d;
    }
    for (int k = 5; k >= 0; --k) {  // L^T x = y
      double* o = pr[k];
      for (int l = k + 1; l < 6; ++l) {
        const double c = L(l, k);
        const double* y = pr[l];
        for (int j = 0; j < nv; ++j) o[j] -= c * y[j];
      }
      const double d = 1.0 / L(k, k);
      for (int j = 0; j < nv; ++j) o[j] *= d;
    }
    Mi.leftCols<6>() = P0.transpose();
    Mi.topRightCorner(6, nv - 6) = P0.rightCols(nv - 6);
    for (int c = 1; c < 6; ++c) {
      for (int r = 0; r < c; ++r) Mi(r, c) = Mi(c, r);  // exactly symmetric
    }
    // The base accelerations in the world frame, Ad P0, into F (free now); then F and P0 swap.
    for (int k = 0; k < 6; ++k) {
      const double a0 = Adf(k, 0), a1 = Adf(k, 1), a2 = Adf(k, 2), a3 = Adf(k, 3), a4 = Adf(k, 4),
                   a5 = Adf(k, 5);
      double* o = F.row(k).data();
      for (int j = 0; j < nv; ++j) {
        o[j] = a0 * pr[0][j] + a1 * pr[1][j] + a2 * pr[2][j] + a3 * pr[3][j] + a4 * pr[4][j] +
               a5 * pr[5][j];
      }
    }
    P0.swap(F);
  }
  for (int i = 1; i <= model.n; ++i) {
    const int p = model.parent[i];
    const int row = v1 + i;
    double* r = Mi.col(row).data();
    double* mrow = Mi.data() + row;  // row `row` of D^-1, stride nv
    const Vec6& S = data.S[row];
    Data::Mat6X& Pi = data.Pm[data.P_slot[i]];
    double* q0 = Pi.row(0).data();
    double* q1 = Pi.row(1).data();
    double* q2 = Pi.row(2).data();
    double* q3 = Pi.row(3).data();
    double* q4 = Pi.row(4).data();
    double* q5 = Pi.row(5).data();
    const double s0 = S[0], s1 = S[1], s2 = S[2], s3 = S[3], s4 = S[4], s5 = S[5];
    if (p > 0 || model.floating) {
      const Vec6 W = data.Dinv[row] * data.U[row];
      const double w0 = W[0], w1 = W[1], w2 = W[2], w3 = W[3], w4 = W[4], w5 = W[5];
      const Data::Mat6X& Pp = data.Pm[data.P_slot[p]];
      // P_i may be P_parent itself (same slot): each column is read before it is written.
      const double* p0 = Pp.row(0).data();
      const double* p1 = Pp.row(1).data();
      const double* p2 = Pp.row(2).data();
      const double* p3 = Pp.row(3).data();
      const double* p4 = Pp.row(4).data();
      const double* p5 = Pp.row(5).data();
      // Column `row` of P_i is read by nobody (the descendants read columns past their own
      // rows), so the first column only finishes row i (r[row] is the diagonal entry itself).
      r[row] -=
          w0 * p0[row] + w1 * p1[row] + w2 * p2[row] + w3 * p3[row] + w4 * p4[row] + w5 * p5[row];
      SE3_SIM_IVDEP
      for (int j = row + 1; j < nv; ++j) {
        const double a0 = p0[j], a1 = p1[j], a2 = p2[j], a3 = p3[j], a4 = p4[j], a5 = p5[j];
        const double x =
            r[j] - (w0 * a0 + w1 * a1 + w2 * a2 + w3 * a3 + w4 * a4 + w5 * a5);  // (58)
        r[j] = x;
        mrow[static_cast<std::ptrdiff_t>(j) * nv] = x;
        q0[j] = a0 + s0 * x;
        q1[j] = a1 + s1 * x;
        q2[j] = a2 + s2 * x;
        q3[j] = a3 + s3 * x;
        q4[j] = a4 + s4 * x;
        q5[j] = a5 + s5 * x;
      }
    } else {
      SE3_SIM_IVDEP
      for (int j = row + 1; j < nv; ++j) {
        const double x = r[j];
        mrow[static_cast<std::ptrdiff_t>(j) * nv] = x;
        q0[j] = s0 * x;
        q1[j] = s1 * x;
        q2[j] = s2 * x;
        q3[j] = s3 * x;
        q4[j] = s4 * x;
        q5[j] = s5 * x;
      }
    }
  }
  return Mi;
}

}  // namespace

const MatX& minv(const Model& model, Data& data, const SE3& base, const VecX& q) {
  if (!data.minv_reserved()) data.reserve_minv(model);
  return data.minv_by_factor ? minv_factor(model, data, base, q)
                             : minv_recursive(model, data, base, q);
}

}  // namespace se3
