// Articulated-body algorithm, eqs. (38)-(43), body frames.
//
// Checked against the paper: (38) is the articulated inertia IA_j = J_j + sum over children of
// Ad*(IA_k - U_k U_k^T / D_k) Ad^-1 (U = IA S, D = S^T IA S); (40)-(41) carry the bias force
// pA_k + Ia_k gamma_k + U_k u_k / D_k to the parent, with u_k = tau_k - S^T pA_k; (42)-(43) run
// outward. For the free base, S_0 = 1 (eq. 26) so (42) becomes a 6x6 solve with IA_0.
//
// Cost. The articulated inertias are symmetric: only their upper triangles are formed and
// read (IA[i] below holds a valid upper triangle only). The projected inertia
// Ia = IA - U U^T / D passed to the parent has a zero row and column at the joint axis
// (Ia S = U - U D / D = 0), so for a revolute joint its blocks [A B; B^T C] have A's third
// row and column and B's third row zero: the transform into the parent's frame works on the
// 15 entries left.
#include <cmath>
#include <type_traits>

#include "joint.h"
#include "lie/simd.h"
#include "se3_sim/dynamics/dynamics.h"
#include "sincos.h"

namespace se3 {
namespace {

// Upper-triangle entry (r, c), r <= c, of a column-major 6x6.
inline double& up(Mat6& m, int r, int c) {
  return m.data()[r + 6 * c];
}
inline double up(const Mat6& m, int r, int c) {
  return m.data()[r + 6 * c];
}

// out (upper triangle) += Ia's blocks after the rotation, A' (upper), B' and C' (both triangles),
// moved by the shift of eq. (38)'s Ad*: with P = hat(p), A'' = A' + M + M^T - N P, B'' = B' + N,
// C'' = C', where N = P C' and M = P B'^T (N P is symmetric). C' is given with both triangles
// (its column j is its row j); PM: the components of p that may be nonzero (detail::cross).
template <int PM>
SE3_KERNEL void add_shifted(const Vec3& pv, const double (&Ap)[3][3], const double (&Bp)[3][3],
                            const double (&Cp)[3][3], Mat6& out) {
  using detail::cross;
  const double* p = pv.data();
  double N[3][3], M[3][3];
#pragma GCC unroll 3
  for (int j = 0; j < 3; ++j) {  // N(:, j) = p x C'(:, j); M(:, j) = p x B'(j, :)
    N[0][j] = cross<PM, 0>(p, Cp[j]);
    N[1][j] = cross<PM, 1>(p, Cp[j]);
    N[2][j] = cross<PM, 2>(p, Cp[j]);
    M[0][j] = cross<PM, 0>(p, Bp[j]);
    M[1][j] = cross<PM, 1>(p, Bp[j]);
    M[2][j] = cross<PM, 2>(p, Bp[j]);
  }
  double* o = out.data();
#pragma GCC unroll 3
  for (int i = 0; i < 3; ++i) {
    const double q[3] = {cross<PM, 0>(p, N[i]), cross<PM, 1>(p, N[i]),
                         cross<PM, 2>(p, N[i])};  // -(N P)(i, :)
#pragma GCC unroll 3
    for (int j = 0; j < 3; ++j) {
      if (j >= i) {
        o[i + 6 * j] += Ap[i][j] + M[i][j] + M[j][i] + q[j];
        o[3 + i + 6 * (3 + j)] += Cp[i][j];
      }
      o[i + 6 * (3 + j)] += Bp[i][j] + N[i][j];
    }
  }
}

// The inward step of a revolute body i (eqs. 38, 40, 41), on the upper triangle of its
// articulated inertia IA: Ia = IA - U U^T / D, whose row and column 2 vanish, and
// pa = pA + Ia c + U u / D; then adds Ad*_{f^-1} Ia Ad_{f^-1} to the parent's IA (upper
// triangle) and Ad*_{f^-1} pa to the parent's pA. f = (R, p) is the child in its parent.
//
// Ia = [A B; B^T C] has A = [a00 a01 0; a01 a11 0; 0 0 0] and B's row 2 zero. The rotation:
// A' = R A R^T = u r0^T + w r1^T (r_k the columns of R, u = a00 r0 + a01 r1,
// w = a01 r0 + a11 r1), B' = R B R^T = r0 (R b0)^T + r1 (R b1)^T (b_k the rows of B),
// C' = R C R^T; then the shift (add_shifted).
//
// F = kZ (f.R = [Q 0; 0 1]): r0 = (Q00, Q10, 0), r1 = (Q01, Q11, 0), r2 = e_3, so A' and B'
// keep a zero third row (and A' a zero third column) and only Q enters the products. F =
// kAxisRow + k: r0 and r1 have a zero component k and r2 = +-e_k, so A' and B' have a zero row k
// (A' a zero column k too), and the products skip R's zeros (detail::dot3).
template <int F, int PM>
SE3_KERNEL void inward_revolute(const SE3& f, const Mat6& IA, const Vec6& U, double Dinv, double u,
                                const Vec6& pA, const Vec6& c, Mat6& IAp, Vec6& pAp) {
  const double* m = IA.data();  // m[r + 6 c], r <= c
  // Ia's entries and pa, two at a time (detail::v2d): the pairs are consecutive rows of one
  // column of IA's upper triangle, and each lane does the scalar sums in their order (the same
  // numbers). Bt[j][r] = B(r, j); Cm is C with both triangles.
  using detail::load2;
  using detail::v2d;
  const auto dup = [](double x) SE3_LAMBDA { return detail::pair(x, x); };
  const v2d Dv = dup(Dinv);
  const v2d Ud01 = load2(U.data()) * Dv, Ud23 = load2(U.data() + 2) * Dv,
            Ud45 = load2(U.data() + 4) * Dv;
  const double a00 = m[0] - Ud01[0] * U[0];
  const v2d a01_11 = load2(m + 6) - Ud01 * dup(U[1]);  // (a01, a11)
  const double a01 = a01_11[0], a11 = a01_11[1];
  const v2d Ud34 = detail::pair(Ud23[1], Ud45[0]);
  const v2d Bc0 = load2(m + 18) - Ud01 * dup(U[3]);  // (B(0, j), B(1, j))
  const v2d Bc1 = load2(m + 24) - Ud01 * dup(U[4]);
  const v2d Bc2 = load2(m + 30) - Ud01 * dup(U[5]);
  const double C00 = m[21] - Ud34[0] * U[3], C22 = m[35] - Ud45[1] * U[5];
  const v2d Cc1 = load2(m + 27) - Ud34 * dup(U[4]);  // (C(0, 1), C(1, 1))
  const v2d Cc2 = load2(m + 33) - Ud34 * dup(U[5]);  // (C(0, 2), C(1, 2))
  alignas(16) double Bt[3][2];
  double Cm[3][3];
  detail::store2(Bt[0], Bc0), detail::store2(Bt[1], Bc1), detail::store2(Bt[2], Bc2);
  Cm[0][0] = C00, Cm[0][1] = Cm[1][0] = Cc1[0], Cm[1][1] = Cc1[1];
  Cm[0][2] = Cm[2][0] = Cc2[0], Cm[1][2] = Cm[2][1] = Cc2[1], Cm[2][2] = C22;
  // (40)-(41): pa = pA + U u / D + Ia c, with c = (c0, c1, 0, c3, c4, 0).
  const v2d uv = dup(u), c0 = dup(c[0]), c1 = dup(c[1]), c3 = dup(c[3]), c4 = dup(c[4]);
  const v2d pa01 = load2(pA.data()) + Ud01 * uv + detail::pair(a00, a01) * c0 + a01_11 * c1 +
                   Bc0 * c3 + Bc1 * c4;
  const v2d pa34 = load2(pA.data() + 3) + Ud34 * uv + detail::pair(Bc0[0], Bc1[0]) * c0 +
                   detail::pair(Bc0[1], Bc1[1]) * c1 + detail::pair(C00, Cc1[0]) * c3 + Cc1 * c4;
  Vec6 pa;
  detail::store2(pa.data(), pa01);
  detail::store2(pa.data() + 3, pa34);
  pa[2] = pA[2] + Ud23[0] * u;
  pa[5] = pA[5] + Ud45[1] * u + Bc2[0] * c[0] + Bc2[1] * c[1] + Cc2[0] * c[3] + Cc2[1] * c[4];
  // (38): the rotation.
  const double* R = f.R.data();  // column-major: R(r, k) = R[r + 3 k]
  double Ap[3][3], Bp[3][3], Cp[3][3], Z[3][3], y0[3], y1[3], uu[3], ww[3];
  if constexpr (F == detail::kZ) {
    const double q00 = R[0], q10 = R[1], q01 = R[3], q11 = R[4];
#pragma GCC unroll 3
    for (int j = 0; j < 3; ++j) {  // Z = R C: rows 0, 1 mixed by Q, row 2 kept
      Z[0][j] = q00 * Cm[0][j] + q01 * Cm[1][j];
      Z[1][j] = q10 * Cm[0][j] + q11 * Cm[1][j];
      Z[2][j] = Cm[2][j];
    }
    y0[0] = q00 * Bt[0][0] + q01 * Bt[1][0], y0[1] = q10 * Bt[0][0] + q11 * Bt[1][0],
    y0[2] = Bt[2][0];
    y1[0] = q00 * Bt[0][1] + q01 * Bt[1][1], y1[1] = q10 * Bt[0][1] + q11 * Bt[1][1],
    y1[2] = Bt[2][1];
    uu[0] = a00 * q00 + a01 * q01, uu[1] = a00 * q10 + a01 * q11;
    ww[0] = a01 * q00 + a11 * q01, ww[1] = a01 * q10 + a11 * q11;
#pragma GCC unroll 3
    for (int j = 0; j < 3; ++j) {
      Bp[0][j] = q00 * y0[j] + q01 * y1[j];
      Bp[1][j] = q10 * y0[j] + q11 * y1[j];
      Bp[2][j] = 0;
    }
    // C' = Z R^T (symmetric): columns 0, 1 by Q, column 2 kept.
    Cp[0][0] = Z[0][0] * q00 + Z[0][1] * q01;
    Cp[0][1] = Cp[1][0] = Z[0][0] * q10 + Z[0][1] * q11;
    Cp[1][1] = Z[1][0] * q10 + Z[1][1] * q11;
    Cp[0][2] = Cp[2][0] = Z[0][2];
    Cp[1][2] = Cp[2][1] = Z[1][2];
    Cp[2][2] = Z[2][2];
    Ap[0][0] = uu[0] * q00 + ww[0] * q01, Ap[0][1] = uu[0] * q10 + ww[0] * q11;
    Ap[1][1] = uu[1] * q10 + ww[1] * q11;
    Ap[0][2] = Ap[1][2] = Ap[2][2] = 0;
    add_shifted<PM>(f.p, Ap, Bp, Cp, IAp);
    detail::add_force<F, PM>(f, pa.data(), pAp.data());
    return;
  }
  if constexpr (F == detail::kGeneral) {
    // The general rotation two entries at a time: R's entries broadcast (bR) against operands
    // paired as they lie (C's and B's rows, (a00, a01) and (a01, a11)), or pairs of R's
    // column against broadcasts; each lane does the scalar form's sums in its order, so the
    // sparse forms below still give the same numbers.
    using detail::pair;
    using detail::store2;
    v2d bR[9];
#pragma GCC unroll 9
    for (int k = 0; k < 9; ++k) bR[k] = dup(R[k]);
    const v2d C0 = load2(Cm[0]), C1 = load2(Cm[1]), C2 = load2(Cm[2]);  // (C(k, 0), C(k, 1))
    const v2d B0 = load2(Bt[0]), B1 = load2(Bt[1]), B2 = load2(Bt[2]);  // (B(0, k), B(1, k))
    const v2d A0 = pair(a00, a01);
    v2d ZR[3], Y[3], UW[3];  // (Z(r, 0), Z(r, 1)), (y0[r], y1[r]), (u[r], w[r])
    double Z2[3];            // Z(r, 2)
#pragma GCC unroll 3
    for (int r = 0; r < 3; ++r) {
      ZR[r] = bR[r] * C0 + bR[r + 3] * C1 + bR[r + 6] * C2;
      Z2[r] = R[r] * Cm[0][2] + R[r + 3] * Cm[1][2] + R[r + 6] * Cm[2][2];
      Y[r] = bR[r] * B0 + bR[r + 3] * B1 + bR[r + 6] * B2;
      UW[r] = A0 * bR[r] + a01_11 * bR[r + 3];
    }
    // B'(i, j) = R(i, 0) y0[j] + R(i, 1) y1[j]: (B'(i, 0), B'(i, 1)) a pair.
    const v2d Y0 = pair(Y[0][0], Y[1][0]), Y1 = pair(Y[0][1], Y[1][1]);
#pragma GCC unroll 3
    for (int i = 0; i < 3; ++i) {
      store2(Bp[i], bR[i] * Y0 + bR[i + 3] * Y1);
      Bp[i][2] = R[i] * Y[2][0] + R[i + 3] * Y[2][1];
    }
    // C'(i, j) = R(j, :) Z(i, :) and A'(i, j) = u[i] R(j, 0) + w[i] R(j, 1) for j >= i: rows 0
    // and 1 of column j a pair.
    const v2d ZC0 = pair(ZR[0][0], ZR[1][0]), ZC1 = pair(ZR[0][1], ZR[1][1]),
              ZC2 = pair(Z2[0], Z2[1]);
    const v2d U01 = pair(UW[0][0], UW[1][0]), W01 = pair(UW[0][1], UW[1][1]);
#pragma GCC unroll 3
    for (int j = 0; j < 3; ++j) {
      const v2d cj = bR[j] * ZC0 + bR[j + 3] * ZC1 + bR[j + 6] * ZC2;
      const v2d aj = U01 * bR[j] + W01 * bR[j + 3];
      Cp[0][j] = cj[0], Ap[0][j] = aj[0];
      if (j > 0) {
        store2(Cp[j], cj);  // C'(j, 0), C'(j, 1): the symmetric entries
        Cp[1][j] = cj[1], Ap[1][j] = aj[1];
      }
    }
    Cp[2][2] = R[2] * ZR[2][0] + R[5] * ZR[2][1] + R[8] * Z2[2];
    Ap[2][2] = UW[2][0] * R[2] + UW[2][1] * R[5];
    add_shifted<PM>(f.p, Ap, Bp, Cp, IAp);
    // pAp += Ad*_{f^-1} pa (eq. 19, detail::force_to_parent): (R n, R f) row by row as a pair,
    // then n += p x f.
    const v2d X0 = pair(pa01[0], pa34[0]), X1 = pair(pa01[1], pa34[1]), X2 = pair(pa[2], pa[5]);
    double n[3], fr[3];
#pragma GCC unroll 3
    for (int r = 0; r < 3; ++r) {
      const v2d nf = bR[r] * X0 + bR[r + 3] * X1 + bR[r + 6] * X2;
      n[r] = nf[0], fr[r] = nf[1];
    }
    const double* p = f.p.data();
    pAp[0] += detail::plus_cross<PM, 0>(n[0], p, fr);
    pAp[1] += detail::plus_cross<PM, 1>(n[1], p, fr);
    pAp[2] += detail::plus_cross<PM, 2>(n[2], p, fr);
    pAp[3] += fr[0], pAp[4] += fr[1], pAp[5] += fr[2];
    return;
  }
  using detail::axis_row_of;
  using detail::dot3;
  using I0 = std::integral_constant<int, 0>;
  using I1 = std::integral_constant<int, 1>;
  using I2 = std::integral_constant<int, 2>;
  auto rows = [&](auto rr) SE3_LAMBDA {  // Z = R C, y_k = R b_k, u, w: row r
    constexpr int r = decltype(rr)::value;
#pragma GCC unroll 3
    for (int j = 0; j < 3; ++j) Z[r][j] = dot3<F, true, r>(R, Cm[0][j], Cm[1][j], Cm[2][j]);
    y0[r] = dot3<F, true, r>(R, Bt[0][0], Bt[1][0], Bt[2][0]);
    y1[r] = dot3<F, true, r>(R, Bt[0][1], Bt[1][1], Bt[2][1]);
    if constexpr (axis_row_of(F, r)) {
      uu[r] = ww[r] = 0;
    } else {
      const double R0 = R[r], R1 = R[r + 3];
      uu[r] = a00 * R0 + a01 * R1;
      ww[r] = a01 * R0 + a11 * R1;
    }
  };
  rows(I0()), rows(I1()), rows(I2());
  auto entries = [&](auto ii, auto jj) SE3_LAMBDA {  // B'(i, j), and C'(i, j), A'(i, j) for j >= i
    constexpr int i = decltype(ii)::value, j = decltype(jj)::value;
    if constexpr (axis_row_of(F, i)) {
      Bp[i][j] = 0;
    } else {
      Bp[i][j] = R[i] * y0[j] + R[i + 3] * y1[j];
    }
    if constexpr (j >= i) {
      Cp[i][j] = dot3<F, true, j>(R, Z[i][0], Z[i][1], Z[i][2]);
      if constexpr (j > i) Cp[j][i] = Cp[i][j];
      if constexpr (axis_row_of(F, i) || axis_row_of(F, j)) {
        Ap[i][j] = 0;
      } else {
        Ap[i][j] = uu[i] * R[j] + ww[i] * R[j + 3];
      }
    }
  };
  auto row_entries = [&](auto ii)
                         SE3_LAMBDA { entries(ii, I0()), entries(ii, I1()), entries(ii, I2()); };
  row_entries(I0()), row_entries(I1()), row_entries(I2());
  add_shifted<PM>(f.p, Ap, Bp, Cp, IAp);
  detail::add_force<F, PM>(f, pa.data(), pAp.data());
}

// The same step for a prismatic body (eq. 38 on the full symmetric Ia; its row and column 5
// vanish): out += Ad*_{f^-1} Ia Ad_{f^-1}, Ia given as a full symmetric array.
SE3_KERNEL void add_transformed_inertia(const SE3& f, const double (&ia)[6][6], Mat6& out) {
  const double* R = f.R.data();
  auto Rm = [R](int r, int c) { return R[r + 3 * c]; };
  double Ap[3][3], Bp[3][3], Cp[3][3];
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      double a = 0, b = 0, cc = 0;
      for (int k = 0; k < 3; ++k) {
        for (int l = 0; l < 3; ++l) {
          const double rr = Rm(i, k) * Rm(j, l);
          a += rr * ia[k][l];
          b += rr * ia[k][3 + l];
          cc += rr * ia[3 + k][3 + l];
        }
      }
      Ap[i][j] = a, Bp[i][j] = b, Cp[i][j] = cc;
    }
  }
  add_shifted<7>(f.p, Ap, Bp, Cp, out);
}

// Solves IA x = b for a symmetric positive definite IA given by its upper triangle, by Cholesky
// IA = L L^T (the free base's 6x6 system of eq. 42). A matrix that is not positive definite
// gives NaN, which the simulator's divergence guard reports.
inline Vec6 solve_spd6(const Mat6& IA, const Vec6& b) {
  double L[6][6];
  for (int j = 0; j < 6; ++j) {
    double d = up(IA, j, j);
    for (int k = 0; k < j; ++k) d -= L[j][k] * L[j][k];
    const double inv = 1.0 / std::sqrt(d);
    L[j][j] = 1.0 / inv;
    for (int i = j + 1; i < 6; ++i) {
      double x = up(IA, j, i);  // IA(i, j)
      for (int k = 0; k < j; ++k) x -= L[i][k] * L[j][k];
      L[i][j] = x * inv;
    }
  }
  double y[6];
  for (int i = 0; i < 6; ++i) {  // L y = b
    double x = b[i];
    for (int k = 0; k < i; ++k) x -= L[i][k] * y[k];
    y[i] = x / L[i][i];
  }
  Vec6 out;
  for (int i = 5; i >= 0; --i) {  // L^T out = y
    double x = y[i];
    for (int k = i + 1; k < 6; ++k) x -= L[k][i] * out[k];
    out[i] = x / L[i][i];
  }
  return out;
}

// J as a 6x6 (eq. 23), upper triangle: [I h^; -h^ m 1].
SE3_KERNEL void set_inertia_upper(const Inertia& J, Mat6& out) {
  for (int c = 0; c < 3; ++c) {
    for (int r = 0; r <= c; ++r) up(out, r, c) = J.I(r, c);
  }
  up(out, 0, 3) = 0, up(out, 0, 4) = -J.h.z(), up(out, 0, 5) = J.h.y();
  up(out, 1, 3) = J.h.z(), up(out, 1, 4) = 0, up(out, 1, 5) = -J.h.x();
  up(out, 2, 3) = -J.h.y(), up(out, 2, 4) = J.h.x(), up(out, 2, 5) = 0;
  up(out, 3, 3) = J.m, up(out, 3, 4) = 0, up(out, 3, 5) = 0;
  up(out, 4, 4) = J.m, up(out, 4, 5) = 0;
  up(out, 5, 5) = J.m;
}

// The inward step of body i on joint J (eqs. 38, 40, 41): the articulated inertia's projection
// Ia = IA - U U^T / D (zero row and column at the axis) and the bias force pa = pA + Ia c + U u / D
// go to the parent, Ad*_{f^-1} Ia Ad_{f^-1} into its IA (upper triangle) and Ad*_{f^-1} pa into
// its pA. f = Xup: the body in its parent.
template <class J>
SE3_KERNEL void inward_step(J, const SE3& f, const Mat6& IA, const Vec6& U, double Dinv, double u,
                            const Vec6& pA, const Vec6& c, Mat6& IAp, Vec6& pAp) {
  constexpr int k = J::axis;
  if constexpr (k == 2) {
    inward_revolute<J::form, J::offset>(f, IA, U, Dinv, u, pA, c, IAp, pAp);
  } else {
    Vec6 pa;
    double ia[6][6];
    const Vec6 Ud = U * Dinv;
    for (int cc = 0; cc < 6; ++cc) {
      for (int r = 0; r <= cc; ++r) ia[r][cc] = ia[cc][r] = up(IA, r, cc) - Ud[r] * U[cc];
    }
    for (int r = 0; r < 6; ++r) ia[r][k] = ia[k][r] = 0;
    pa = pA + Ud * u;
    for (int r = 0; r < 6; ++r) {
      pa[r] += ia[r][0] * c[0] + ia[r][1] * c[1] + ia[r][3] * c[3] + ia[r][4] * c[4];
    }
    add_transformed_inertia(f, ia, IAp);
    detail::add_force<J::form, J::offset>(f, pa.data(), pAp.data());
  }
}

}  // namespace

const VecX& aba(const Model& model, Data& data, const SE3& base, const VecX& q, const VecX& v,
                const VecX& tau, const Vec6* f_ext_base) {
  // The joints' sines and cosines in one batch; each body's Xup (joint_transforms) is formed in
  // the first outward loop, where its twist reads it at once.
  double* sq = data.sin_q.data();
  double* cq = data.cos_q.data();
  detail::sincos_n(q.data(), model.nq, sq, cq);
  // Outward: transforms, velocities (33), gamma (34), J_j and beta_j (39).
  if (model.floating) {
    data.V[0] = v.head<6>();
    set_inertia_upper(model.inertia[0], data.IA[0]);
    // The base's generalized force tau[0:6] is a wrench on it, like f_ext_base.
    data.F[0] = cross_force(data.V[0], model.inertia[0] * data.V[0]) - tau.head<6>();
    if (f_ext_base) data.F[0] -= *f_ext_base;
  } else {
    data.V[0].setZero();
  }
  // The arrays' data pointers and the base's kind read once: the stores through double* below
  // would otherwise make GCC reload some of them for every body.
  const bool fixed = !model.floating;
  const JointModel* joints = model.joints.data();
  const int* parent = model.parent.data();
  const Inertia* inertia = model.inertia.data();
  const SE3* X_tree = model.X_tree.data();
  SE3* Xup = data.Xup.data();
  const double* qs = q.data();
  Vec6* Vs = data.V.data();
  Vec6* Fs = data.F.data();
  Vec6* cs = data.c.data();
  Vec6* As = data.A.data();
  Vec6* Us = data.U.data();
  Mat6* IAs = data.IA.data();
  double* Dinvs = data.Dinv.data();
  double* us = data.u.data();
  double* ddq = data.ddq.data();
  const double* vd = v.data();
  const double* taud = tau.data();
  for (int i = 1; i <= model.n; ++i) {
    const JointModel& jm = joints[i];
    const double qd = vd[jm.idx_v];
    double* V = Vs[i].data();
    const Inertia& I = inertia[i];
    set_inertia_upper(I, IAs[i]);
    double* pA = Fs[i].data();
    detail::with_joint(jm, [&](auto J) SE3_LAMBDA {
      constexpr int k = J.axis;
      const int iq = jm.idx_q;
      J.transform(X_tree[i], qs[iq], cq[iq], sq[iq], Xup[i]);
      if (parent[i] == 0 && fixed) {
        // On the fixed base: V = S qd, so gamma = V x S qd = 0 and pA = V x* (J V) =
        // qd^2 e_z x [I e_z; h x e_z] on both halves (revolute), 0 (prismatic).
        for (int r = 0; r < 6; ++r) V[r] = 0, cs[i][r] = 0, pA[r] = 0;
        V[k] = qd;
        if constexpr (k == 2) {
          double G[6];
          J.inertia_column(I, G);
          const double q2 = qd * qd;
          pA[0] = -(q2 * G[1]), pA[1] = q2 * G[0], pA[3] = -(q2 * G[4]), pA[4] = q2 * G[3];
        }
        return;
      }
      detail::child_twist(J, Xup[i], Vs[parent[i]].data(), qd, V);
      J.bias_acceleration(V, qd, cs[i].data());
      detail::bias_force(I, V, pA);  // pA, eq. (39): -ad*_V J V
    });
  }
  // Inward: articulated inertias (38) and bias forces (40)-(41).
  for (int i = model.n; i >= 1; --i) {
    const JointModel& jm = joints[i];
    const int iv = jm.idx_v;
    detail::with_joint(jm, [&](auto J) SE3_LAMBDA {
      constexpr int k = J.axis;
      const Mat6& IA = IAs[i];
      Vec6& U = Us[iv];
      for (int r = 0; r < 6; ++r) U[r] = r <= k ? up(IA, r, k) : up(IA, k, r);  // IA S
      const double Dinv = 1.0 / U[k];
      Dinvs[iv] = Dinv;
      const double u = taud[iv] - Fs[i][k];
      us[iv] = u;
      const int p = parent[i];
      if (p == 0 && fixed) return;
      inward_step(J, Xup[i], IA, U, Dinv, u, Fs[i], cs[i], IAs[p], Fs[p]);
    });
  }
  // Outward: accelerations (42)-(43), with gravity as the fictitious base acceleration.
  Vec6 ag;
  ag << 0, 0, 0, -(base.R.transpose() * model.gravity);
  if (model.floating) {
    // IA_0 a_0 = -pA_0 in the gravity-free frame; the true dV0/dt adds g back.
    data.A[0] = -solve_spd6(data.IA[0], data.F[0]);
    data.ddq.head<6>() = data.A[0] - ag;
  } else {
    data.A[0] = ag;
  }
  for (int i = 1; i <= model.n; ++i) {
    const JointModel& jm = joints[i];
    const int iv = jm.idx_v;
    double* a = As[i].data();
    const double* U = Us[iv].data();
    detail::with_joint(jm, [&](auto J) SE3_LAMBDA {
      double Ua;
      if (parent[i] == 0 && fixed) {  // a = [0; R^T ag] (gamma = 0)
        a[0] = a[1] = a[2] = 0;
        detail::rotate_back<J.form>(Xup[i].R.data(), ag[3], ag[4], ag[5], a + 3);
        Ua = U[3] * a[3] + U[4] * a[4] + U[5] * a[5];
      } else {
        detail::inv_motion<J.form, J.offset>(Xup[i], As[parent[i]].data(), a);
        // a += c and U.a, two entries at a time.
        const double* c = cs[i].data();
        const detail::v2d a01 = detail::load2(a) + detail::load2(c);
        const detail::v2d a23 = detail::load2(a + 2) + detail::load2(c + 2);
        const detail::v2d a45 = detail::load2(a + 4) + detail::load2(c + 4);
        detail::store2(a, a01), detail::store2(a + 2, a23), detail::store2(a + 4, a45);
        const detail::v2d Us =
            detail::load2(U) * a01 + detail::load2(U + 2) * a23 + detail::load2(U + 4) * a45;
        Ua = Us[0] + Us[1];
      }
      const double qdd = (us[iv] - Ua) * Dinvs[iv];
      a[J.axis] += qdd;
      ddq[iv] = qdd;
    });
  }
  return data.ddq;
}

}  // namespace se3
