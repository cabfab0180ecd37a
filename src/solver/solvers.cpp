// The solvers on a step's rows (solver.h): eq. (32)'s multipliers, projected Gauss-Seidel with
// Coulomb friction, and the active-set (Newton-type) direct method.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "se3_sim/solver.h"

namespace se3 {

namespace {

constexpr double kTinyPivot = 1e-14;  // a row whose W_ii is below this has no effect: skipped
// Active-set guesses, per row.
constexpr int kInactive = 0;  // limit or normal: no impulse (separating)
constexpr int kStick = 1;     // limit or normal: active; a contact's friction rows too (r_t = 0)
constexpr int kSlide = 2;     // contact: normal active, friction mu p_n along dir (r_t != 0)

bool unilateral(RowType t) {
  return t == RowType::JointLimit || t == RowType::ContactNormal;
}

// Solves the m x m system in the top-left of A for x (rhs in, solution out) by LU with partial
// pivoting, in place. Returns false for a (numerically) singular system. Column-oriented (A is
// column-major with the workspace's capacity as its stride): every inner loop runs down a column.
bool lu_solve(MatX& A, int m, std::vector<int>& piv, VecX& x) {
  for (int k = 0; k < m; ++k) {
    double* ck = &A(0, k);
    int best = k;
    double big = std::abs(ck[k]);
    for (int i = k + 1; i < m; ++i) {
      if (std::abs(ck[i]) > big) big = std::abs(ck[i]), best = i;
    }
    if (!(big > 0)) return false;
    piv[k] = best;
    if (best != k) {
      for (int j = 0; j < m; ++j) std::swap(A(k, j), A(best, j));
      std::swap(x[k], x[best]);
    }
    const double inv = 1.0 / ck[k];
    for (int i = k + 1; i < m; ++i) {
      ck[i] *= inv;
      x[i] -= ck[i] * x[k];
    }
    for (int j = k + 1; j < m; ++j) {
      double* cj = &A(0, j);
      const double akj = cj[k];
      if (akj == 0) continue;
      for (int i = k + 1; i < m; ++i) cj[i] -= ck[i] * akj;
    }
  }
  for (int k = m - 1; k >= 0; --k) {
    const double* ck = &A(0, k);
    x[k] /= ck[k];
    const double xk = x[k];
    for (int i = 0; i < k; ++i) x[i] -= ck[i] * xk;
  }
  return x.head(m).allFinite();
}

// (W p)_r over the first n rows: W symmetric, so column r (contiguous) in place of row r.
double row_dot(const MatX& W, int r, int n, const VecX& p) {
  const double* w = &W(0, r);
  const double* q = p.data();
  double s0 = 0, s1 = 0;
  int j = 0;
  for (; j + 2 <= n; j += 2) s0 += w[j] * q[j], s1 += w[j + 1] * q[j + 1];
  if (j < n) s0 += w[j] * q[j];
  return s0 + s1;
}

}  // namespace

void SolverWorkspace::reserve(int capacity, int equality_rows) {
  if (equality_rows >= 0 && equality_rows != equality_size) {
    ldlt = Eigen::LDLT<MatX>(equality_rows);
    eig = Eigen::SelfAdjointEigenSolver<MatX>(equality_rows);
    equality_size = equality_rows;
  }
  A = MatX::Zero(capacity, capacity);
  x = VecX::Zero(capacity);
  r = VecX::Zero(capacity);
  p0 = VecX::Zero(capacity);
  var.assign(capacity, 0);
  piv.assign(capacity, 0);
  slot.assign(capacity, -1);
  state.assign(capacity, kInactive);
  dir.assign(capacity, Eigen::Vector2d::Zero());
}

SolverStats solve_equality(const MatX& W, const VecX& rhs, VecX& x, SolverWorkspace& ws,
                           double singular_tol) {
  SolverStats st;
  const int m = static_cast<int>(rhs.size());
  if (m == 0) return st;
  const double wmax = W.diagonal().cwiseAbs().maxCoeff();
  if (!(wmax > 0) || !std::isfinite(wmax)) {
    x.setZero();
    st.singular = true;
    return st;
  }
  ws.ldlt.compute(W);
  const auto D = ws.ldlt.vectorD();
  const double dmax = D.cwiseAbs().maxCoeff();
  if (ws.ldlt.info() == Eigen::Success && D.minCoeff() > singular_tol * dmax) {
    x = ws.ldlt.solve(rhs);
    st.rank = m;
    return st;
  }
  // Rank deficient: the minimum-norm least-squares solution (the pseudo-inverse).
  st.singular = true;
  ws.eig.compute(W);
  const auto& ev = ws.eig.eigenvalues();
  const auto& V = ws.eig.eigenvectors();
  const double thr = singular_tol * ev.cwiseAbs().maxCoeff();
  x.setZero();
  for (int k = 0; k < m; ++k) {
    if (ev[k] > thr) {
      x.noalias() += V.col(k) * (V.col(k).dot(rhs) / ev[k]);
      ++st.rank;
    }
  }
  return st;
}

SolverStats solve_pgs(const MatX& W, const VecX& c, const ConstraintRows& rows, VecX& p,
                      const SolverOptions& opt) {
  SolverStats st;
  const int n = rows.count;
  if (n == 0) return st;
  int it = 0;
  double change = 0;
  for (it = 1; it <= opt.iterations; ++it) {
    change = 0;
    for (int r = 0; r < n; ++r) {
      const RowType t = rows.type[r];
      if (t == RowType::ContactFriction) continue;  // with its normal, below
      const double wii = W(r, r);
      if (wii > kTinyPivot) {
        double np = p[r] - (c[r] + row_dot(W, r, n, p)) / wii;
        if (t != RowType::Equality) np = std::max(0.0, np);
        change = std::max(change, std::abs(np - p[r]));
        p[r] = np;
      }
      const int f1 = rows.friction[r], f2 = rows.friction2[r];
      if (f1 == ConstraintRows::kNone) continue;
      // The friction pair: each row's Gauss-Seidel value, then projected on the disc mu p_n.
      const double w1 = W(f1, f1), w2 = W(f2, f2);
      double n1 = w1 > kTinyPivot ? p[f1] - (c[f1] + row_dot(W, f1, n, p)) / w1 : 0.0;
      double n2 = w2 > kTinyPivot ? p[f2] - (c[f2] + row_dot(W, f2, n, p)) / w2 : 0.0;
      const double lim = rows.mu[r] * p[r];
      const double len = std::hypot(n1, n2);
      if (len > lim) {
        const double s = len > 0 ? lim / len : 0.0;
        n1 *= s;
        n2 *= s;
      }
      change = std::max(change, std::max(std::abs(n1 - p[f1]), std::abs(n2 - p[f2])));
      p[f1] = n1;
      p[f2] = n2;
    }
    if (change <= opt.tol) break;
  }
  st.iterations = std::min(it, opt.iterations);
  st.change = change;
  return st;
}

SolverStats solve_active_set(const MatX& W, const VecX& c, const ConstraintRows& rows, VecX& p,
                             SolverWorkspace& ws, const SolverOptions& opt) {
  SolverStats st;
  const int n = rows.count;
  if (n == 0) return st;
  if (static_cast<int>(ws.state.size()) < n) {
    throw std::length_error("solve_active_set: workspace smaller than the rows");
  }
  constexpr double kVelTol = 1e-9;              // m/s: residuals below this count as zero
  constexpr double kImpTol = 1e-12;             // N s
  for (int r = 0; r < n; ++r) ws.p0[r] = p[r];  // the warm start, for the fallback below
  bool converged = false;
  // First guess from the warm start (or, without one, from the free residual).
  for (int r = 0; r < n; ++r) {
    const RowType t = rows.type[r];
    if (!unilateral(t)) continue;
    if (p[r] > 0 || c[r] < -kVelTol) {
      ws.state[r] = kStick;
      const int f1 = rows.friction[r];
      if (f1 != ConstraintRows::kNone && p[r] > 0) {
        const Eigen::Vector2d pt(p[f1], p[rows.friction2[r]]);
        if (pt.norm() > rows.mu[r] * p[r] * (1 + 1e-9) && pt.norm() > 0) {
          ws.state[r] = kSlide;
          ws.dir[r] = pt.normalized();
        }
      }
    } else {
      ws.state[r] = kInactive;
    }
  }
  int it = 0;
  for (it = 1; it <= opt.active_set_iterations; ++it) {
    // Unknowns: equality rows, active limits and normals, sticking contacts' friction rows.
    int m = 0;
    for (int r = 0; r < n; ++r) ws.slot[r] = -1;
    for (int r = 0; r < n; ++r) {
      const RowType t = rows.type[r];
      if (t == RowType::ContactFriction) continue;
      if (t != RowType::Equality && ws.state[r] == kInactive) continue;
      ws.slot[r] = m;
      ws.var[m++] = r;
      if (t == RowType::ContactNormal && ws.state[r] == kStick &&
          rows.friction[r] != ConstraintRows::kNone) {
        ws.slot[rows.friction[r]] = m;
        ws.var[m++] = rows.friction[r];
        ws.slot[rows.friction2[r]] = m;
        ws.var[m++] = rows.friction2[r];
      }
    }
    // Column by column (W symmetric: W(ri, rj) = W(rj, ri), read down column rj).
    for (int j = 0; j < m; ++j) {
      const int rj = ws.var[j];
      double* a = &ws.A(0, j);
      const double* wj = &W(0, rj);
      for (int i = 0; i < m; ++i) a[i] = wj[ws.var[i]];
      if (ws.state[rj] == kSlide && rows.type[rj] == RowType::ContactNormal) {
        const Eigen::Vector2d& d = ws.dir[rj];
        const double s1 = rows.mu[rj] * d[0], s2 = rows.mu[rj] * d[1];
        const double* w1 = &W(0, rows.friction[rj]);
        const double* w2 = &W(0, rows.friction2[rj]);
        for (int i = 0; i < m; ++i) a[i] += s1 * w1[ws.var[i]] + s2 * w2[ws.var[i]];
      }
      a[j] += opt.regularization * W(rj, rj) + 1e-300;
      ws.x[j] = -c[rj];
    }
    // LU, not Cholesky, also when no contact slides: on panda_push the Cholesky solution of the
    // same (nearly singular) system sent the box flying (110 m in 2 s) where LU's does not.
    if (m > 0 && !lu_solve(ws.A, m, ws.piv, ws.x)) break;  // the fallback below
    for (int r = 0; r < n; ++r) p[r] = 0;
    for (int i = 0; i < m; ++i) p[ws.var[i]] = ws.x[i];
    for (int r = 0; r < n; ++r) {
      if (rows.type[r] == RowType::ContactNormal && ws.state[r] == kSlide) {
        const double ft = rows.mu[r] * p[r];
        p[rows.friction[r]] = ft * ws.dir[r][0];
        p[rows.friction2[r]] = ft * ws.dir[r][1];
      }
    }
    for (int r = 0; r < n; ++r) ws.r[r] = c[r] + row_dot(W, r, n, p);
    bool changed = false;
    for (int r = 0; r < n; ++r) {
      const RowType t = rows.type[r];
      if (!unilateral(t)) continue;
      int& s = ws.state[r];
      if (s != kInactive && p[r] < -kImpTol) {
        s = kInactive;
        changed = true;
        continue;
      }
      if (s == kInactive) {
        if (ws.r[r] < -kVelTol) s = kStick, changed = true;
        continue;
      }
      const int f1 = rows.friction[r];
      if (f1 == ConstraintRows::kNone) continue;
      const int f2 = rows.friction2[r];
      if (s == kStick) {
        const Eigen::Vector2d pt(p[f1], p[f2]);
        if (pt.norm() > rows.mu[r] * p[r] * (1 + 1e-9) + kImpTol) {
          s = kSlide;
          ws.dir[r] = pt.normalized();
          changed = true;
        }
      } else {
        const Eigen::Vector2d rt(ws.r[f1], ws.r[f2]);
        if (rt.norm() <= kVelTol) continue;
        const Eigen::Vector2d want = -rt / rt.norm();  // friction opposes the slip
        if (want.dot(ws.dir[r]) < 0) {
          s = kStick;
          changed = true;
        } else if ((want - ws.dir[r]).norm() > 1e-9) {
          ws.dir[r] = (ws.dir[r] + want).normalized();
          changed = true;
        }
      }
    }
    if (!changed) {
      converged = true;
      break;
    }
  }
  st.iterations = std::min(it, opt.active_set_iterations);
  for (int r = 0; r < n && converged; ++r) converged = std::isfinite(p[r]);
  // Guesses that never settled (a sliding contact's direction cycling, a singular system) leave
  // an iterate that is not a solution: sliding boxes on a stack were thrown kilometres. Then
  // projected Gauss-Seidel from the warm start with its full sweeps solves the step instead;
  // otherwise a few sweeps from the direct solution make it feasible to rounding.
  SolverOptions polish = opt;
  if (converged) {
    polish.iterations = std::max(1, opt.polish_sweeps);
  } else {
    for (int r = 0; r < n; ++r) p[r] = ws.p0[r];
    st.fallback = true;
  }
  const SolverStats ps = solve_pgs(W, c, rows, p, polish);
  st.change = ps.change;
  return st;
}

ContactSolver contact_solver_from_name(const std::string& name) {
  if (name == "pgs") return ContactSolver::PGS;
  if (name == "active_set") return ContactSolver::ActiveSet;
  throw std::invalid_argument("contact solver '" + name + "': known are pgs, active_set");
}

}  // namespace se3
