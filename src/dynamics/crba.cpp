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
// GCC's code hoisting lifts the loads that the joint forms' copies of a step share above their
// dispatch, where they are spilled to the stack and read back (docs/performance.md): off for this
// file.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC optimize("no-code-hoisting")
#endif
#include <type_traits>

#include "joint.h"
#include "row_kernel.h"
#include "se3_sim/dynamics/dynamics.h"

namespace se3 {

namespace {

// out += `in` placed at f (Ad*_{f^-1} J Ad_{f^-1}): Inertia::add_transformed's sums, inline, and
// for Z (f.R = [Q 0; 0 1]) without the products with R's exact zeros. With g = R h:
// h' = g + m p, I' = R I R^T + (2 p.g + m p.p) 1 - (w p^T + p w^T), w = g + m p / 2.
// out.I's lower triangle is set to its upper one (Inertia::add_transformed adds to both, which
// differ only where a body's inertia is not symmetric to the last bit).
template <bool Z>
SE3_KERNEL void add_transformed(const Inertia& in, const SE3& f, Inertia& out) {
  const double m = in.m;
  const double* h = in.h.data();
  const double* R = f.R.data();  // column-major: R(r, c) = R[r + 3 c]
  const double* J = in.I.data();
  double g[3];  // g = R h
  if constexpr (Z) {
    g[0] = R[0] * h[0] + R[3] * h[1], g[1] = R[1] * h[0] + R[4] * h[1], g[2] = h[2];
  } else {
    for (int r = 0; r < 3; ++r) g[r] = R[r] * h[0] + R[r + 3] * h[1] + R[r + 6] * h[2];
  }
  const double px = f.p[0], py = f.p[1], pz = f.p[2];
  const double p3[3] = {px, py, pz};
  const double gx = g[0], gy = g[1], gz = g[2];
  const double d = 2.0 * (px * gx + py * gy + pz * gz) + m * (px * px + py * py + pz * pz);
  const double w[3] = {gx + 0.5 * m * px, gy + 0.5 * m * py, gz + 0.5 * m * pz};
  out.m += m;
  out.h[0] += gx + m * px;
  out.h[1] += gy + m * py;
  out.h[2] += gz + m * pz;
  double* o = out.I.data();
  // Row r of Z = R I, then the upper triangle's row r of Z R^T, (R I R^T)(r, c) =
  // sum_k Z(r, k) R(c, k), and its parallel-axis terms: one row of Z live at a time.
#pragma GCC unroll 3
  for (int r = 0; r < 3; ++r) {
    double z[3];
    if constexpr (Z) {
      if (r == 2) {
        z[0] = J[2], z[1] = J[5], z[2] = J[8];
      } else {
        const double q0 = R[r], q1 = R[r + 3];
        for (int c = 0; c < 3; ++c) z[c] = q0 * J[3 * c] + q1 * J[3 * c + 1];
      }
    } else {
      const double r0 = R[r], r1 = R[r + 3], r2 = R[r + 6];
      for (int c = 0; c < 3; ++c) z[c] = r0 * J[3 * c] + r1 * J[3 * c + 1] + r2 * J[3 * c + 2];
    }
#pragma GCC unroll 3
    for (int c = r; c < 3; ++c) {
      double rir;
      if constexpr (Z) {
        rir = c == 2 ? z[2] : z[0] * R[c] + z[1] * R[c + 3];
      } else {
        rir = z[0] * R[c] + z[1] * R[c + 3] + z[2] * R[c + 6];
      }
      if (c == r) {
        o[4 * r] += rir - 2 * w[r] * p3[r] + d;
      } else {
        const double x = rir - (w[r] * p3[c] + p3[r] * w[c]);
        o[c + 3 * r] = o[r + 3 * c] += x;  // the lower triangle a copy of the upper
      }
    }
  }
}

// Component kp of Ad*_{Xup^-1} F_c for the columns c in [col, end), written to F[kp][c]: the
// only entries of the columns the parent reads when it is the last row they enter (SE3_NOINLINE:
// inlined, it made GCC allocate crba_local's registers worse, docs/performance.md).
SE3_NOINLINE void wrench_components_to_parent(const JointModel& jm, int kp, const double* R,
                                              const double* t, int col, int end,
                                              double* const (&F)[6]) {
  detail::with_joint(jm, [&](auto J) SE3_LAMBDA {
    auto columns = [&](auto k) SE3_LAMBDA {
      for (int c = col; c < end; ++c) {
        double x[6];
        for (int r = 0; r < 6; ++r) x[r] = F[r][c];
        F[k][c] = detail::force_to_parent_component<J.form, J.offset, k>(R, t, x);
      }
    };
    if (kp == 2) {
      columns(std::integral_constant<int, 2>());
    } else {
      columns(std::integral_constant<int, 5>());
    }
  });
}

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
    const JointModel& jm = model.joints[i];
    if (carry) {
      detail::with_joint_form(jm, [&](auto J) SE3_LAMBDA {
        add_transformed<J.z_rotation>(Ic, data.Xup[i], data.Ic[p]);
      });
    }
    // F_i = Ic_i S_i: a column of eq. (23)'s matrix. The subtree's columns are [col, end).
    const JointModel& last = model.joints[model.subtree_end[i]];
    const int col = jm.idx_v, end = last.idx_v + last.nv;
    const int k = jm.axis();
    double Fi[6];
    detail::with_joint_form(jm, [&](auto J) SE3_LAMBDA { J.inertia_column(Ic, Fi); });
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
    if (!model.floating && model.parent[p] == 0) {
      // The parent sits on the fixed base: its row is the last one these columns enter, and it
      // reads only component k_p (its joint axis) of each wrench.
      wrench_components_to_parent(jm, model.joints[p].axis(), R, t, col, end, F);
      continue;
    }
    detail::with_joint(jm, [&](auto J) SE3_LAMBDA {
      for (int c = col; c < end; ++c) {
        double x[6];
        for (int r = 0; r < 6; ++r) x[r] = F[r][c];
        detail::force_to_parent<J.form, J.offset>(R, t, x);
        for (int r = 0; r < 6; ++r) F[r][c] = x[r];
      }
    });
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
    detail::with_joint_form(model.joints[i],
                            [&](auto Jt) SE3_LAMBDA { Jt.world_axis(data.oMb[i], S); });
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
