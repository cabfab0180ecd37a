// The solvers on a step's rows (solver.h): eq. (32)'s multipliers, projected Gauss-Seidel with
// Coulomb friction, and the active-set (Newton-type) direct method.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "../lie/simd.h"
#include "se3_sim/solver/solver.h"
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#endif

namespace se3 {

namespace {

constexpr double kTinyPivot = 1e-14;  // a row whose W_ii is below this has no effect: skipped
// Active-set guesses, per row.
constexpr int kInactive = 0;  // limit or normal: no impulse (separating)
constexpr int kStick = 1;     // limit or normal: active; a contact's friction rows too (r_t = 0)
constexpr int kSlide = 2;     // contact: normal active, friction on the disc's edge (r_t != 0)

bool unilateral(RowType t) {
  return t == RowType::JointLimit || t == RowType::ContactNormal;
}

// Solves the m x m system in the top-left of A for x (rhs in, solution out) by LU with partial
// pivoting, in place. Returns false for a (numerically) singular system. Column-oriented (A is
// column-major with the workspace's capacity as its stride): every inner loop runs down a column.
#ifdef SE3_SIM_RUNTIME_AVX
// The elimination of column k from the columns right of it (rows below k), four rows at a time:
// the scalar loop's products and differences, so the same bits.
__attribute__((target("avx"))) void eliminate_avx(MatX& A, int k, int m) {
  const double* ck = &A(0, k);
  for (int j = k + 1; j < m; ++j) {
    double* cj = &A(0, j);
    const double akj = cj[k];
    if (akj == 0) continue;
    const __m256d a = _mm256_set1_pd(akj);
    int i = k + 1;
    for (; i + 4 <= m; i += 4) {
      _mm256_storeu_pd(cj + i, _mm256_sub_pd(_mm256_loadu_pd(cj + i),
                                             _mm256_mul_pd(_mm256_loadu_pd(ck + i), a)));
    }
    for (; i < m; ++i) cj[i] -= ck[i] * akj;
  }
}
#endif

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
#ifdef SE3_SIM_RUNTIME_AVX
    if (m - k > 8 && detail::have_avx()) {
      eliminate_avx(A, k, m);
      continue;
    }
#endif
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
  shrink.assign(capacity, 0.0);
  state1.assign(capacity, kInactive);
  state2.assign(capacity, kInactive);
  frozen.assign(capacity, 0);
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

namespace {

constexpr double kVelTol = 1e-9;   // m/s: residuals below this count as zero
constexpr double kImpTol = 1e-12;  // N s
constexpr double kWorkTol = 1e-6;  // p.r above this fraction of sum |p_i c_i|: not a solution
// A sliding direction within this of the one of the last update has settled (Newton's updates
// of the direction converge quadratically: the next one would move it by about its square).
constexpr double kDirTol = 1e-6;
// A warm friction impulse within this (relative) of its disc's edge: the contact slid.
constexpr double kEdge = 1e-6;

// W read by columns, all of them there (the full product)...
struct DenseColumns {
  static constexpr bool kLazy = false;
  const MatX& W;
  const double* col(int j) const { return &W(0, j); }
  double diag(int j) const { return W(j, j); }
};
// ... or formed the first time the solver asks for one (W_jj with its column).
struct LazyColumns {
  static constexpr bool kLazy = true;
  DelassusColumns& D;
  const double* col(int j) { return delassus_column(D, j); }
  double diag(int j) { return delassus_column(D, j)[j]; }
};

// r += s w over the first n entries.
void axpy(const double* w, double s, int n, double* r) {
  for (int i = 0; i < n; ++i) r[i] += s * w[i];
}

bool starts_active(const VecX& c, const VecX& p, int r) {
  return p[r] > 0 || c[r] < -kVelTol;
}

// r = c + W p over the first n rows from the columns of the rows that carry impulse (W is
// symmetric: a row without impulse needs no column, not even for its own residual).
template <class Cols>
void residuals(Cols& W, const VecX& c, const VecX& p, int n, VecX& r) {
  for (int i = 0; i < n; ++i) r[i] = c[i];
  for (int j = 0; j < n; ++j) {
    if (p[j] != 0) axpy(W.col(j), p[j], n, r.data());
  }
}

// Projected Gauss-Seidel sweeps as solve_pgs (the same updates in the same order), on the
// residuals r = c + W p kept up to date: a row whose impulse changes by d adds d W(:, row) to r.
// On lazy columns a row that stays at zero (a separated contact: p = 0, r >= 0, and its
// friction without load) reads only its r: neither its column nor its pivot W_kk.
template <class Cols>
SolverStats pgs_on_residuals(Cols& W, const ConstraintRows& rows, VecX& p, VecX& r,
                             const SolverOptions& opt) {
  SolverStats st;
  const int n = rows.count;
  double* res = r.data();
  auto move = [&](int row, double np) {
    const double d = np - p[row];
    p[row] = np;
    if (d != 0) axpy(W.col(row), d, n, res);
    return std::abs(d);
  };
  int it = 0;
  double change = 0;
  for (it = 1; it <= opt.iterations; ++it) {
    change = 0;
    for (int k = 0; k < n; ++k) {
      const RowType t = rows.type[k];
      if (t == RowType::ContactFriction) continue;  // with its normal, below
      const bool stays = Cols::kLazy && t != RowType::Equality && p[k] == 0 && res[k] >= 0;
      const double wkk = stays ? 0.0 : W.diag(k);
      if (wkk > kTinyPivot) {
        double np = p[k] - res[k] / wkk;
        if (t != RowType::Equality) np = std::max(0.0, np);
        change = std::max(change, move(k, np));
      }
      const int f1 = rows.friction[k], f2 = rows.friction2[k];
      if (f1 == ConstraintRows::kNone) continue;
      if (Cols::kLazy && p[k] == 0 && p[f1] == 0 && p[f2] == 0) continue;  // radius 0: they stay
      const double w1 = W.diag(f1), w2 = W.diag(f2);
      double n1 = w1 > kTinyPivot ? p[f1] - res[f1] / w1 : 0.0;
      double n2 = w2 > kTinyPivot ? p[f2] - res[f2] / w2 : 0.0;
      const double lim = rows.mu[k] * p[k];
      const double len = std::hypot(n1, n2);
      if (len > lim) {
        const double s = len > 0 ? lim / len : 0.0;
        n1 *= s;
        n2 *= s;
      }
      change = std::max(change, move(f1, n1));
      change = std::max(change, move(f2, n2));
    }
    if (change <= opt.tol) break;
  }
  st.iterations = std::min(it, opt.iterations);
  st.change = change;
  return st;
}

// The active set's unknowns: equality rows, active limits and normals, the friction rows of
// every active contact (sticking or sliding) (their count).
int active_variables(const ConstraintRows& rows, SolverWorkspace& ws) {
  int m = 0;
  for (int r = 0; r < rows.count; ++r) ws.slot[r] = -1;
  for (int r = 0; r < rows.count; ++r) {
    const RowType t = rows.type[r];
    if (t == RowType::ContactFriction) continue;
    if (t != RowType::Equality && ws.state[r] == kInactive) continue;
    ws.slot[r] = m;
    ws.var[m++] = r;
    if (t == RowType::ContactNormal && rows.friction[r] != ConstraintRows::kNone) {
      ws.slot[rows.friction[r]] = m;
      ws.var[m++] = rows.friction[r];
      ws.slot[rows.friction2[r]] = m;
      ws.var[m++] = rows.friction2[r];
    }
  }
  return m;
}

// A contact's friction rows' mean pivot: the scale that weighs its slip r_t against its
// friction impulse p_t (z = p_t - r_t / w, Alart and Curnier's augmented variable).
template <class Cols>
double friction_scale(Cols& W, const ConstraintRows& rows, int normal) {
  return 0.5 * (W.diag(rows.friction[normal]) + W.diag(rows.friction2[normal]));
}

// p_t - r_t / w: inside the disc of radius mu p_n the contact sticks (r_t = 0, p_t = z); outside,
// it slides with p_t = mu p_n z / |z| (friction on the edge, opposing the slip).
Eigen::Vector2d augmented_friction(const ConstraintRows& rows, int normal, const VecX& p,
                                   const VecX& r, double w) {
  const int f1 = rows.friction[normal], f2 = rows.friction2[normal];
  const double inv = w > kTinyPivot ? 1.0 / w : 0.0;
  return Eigen::Vector2d(p[f1] - inv * r[f1], p[f2] - inv * r[f2]);
}

// A sliding contact's two friction equations in place of its rows of W p = -c: Newton's
// linearization of p_t = mu p_n z / |z| at the last iterate (direction u = z / |z|, k = mu p_n /
// |z| < 1, e the unit normal to u in the plane). Along u: u.p_t - mu p_n = 0. Across:
// k e.(c_t + W_t p) + (1 - k) w e.p_t = 0, so the direction follows the slip's response to it
// (the slip's derivative): a fixed-point update of the direction alone converges at a rate near
// 1 where the slip follows the friction direction (two sliding corners of one box).
template <class Cols>
void sliding_rows(Cols& W, const ConstraintRows& rows, int normal, int m, SolverWorkspace& ws) {
  const int sn = ws.slot[normal];
  const int s1 = ws.slot[rows.friction[normal]], s2 = ws.slot[rows.friction2[normal]];
  const Eigen::Vector2d& u = ws.dir[normal];
  const Eigen::Vector2d e(-u[1], u[0]);
  const double k = ws.shrink[normal];
  const double soft = (1 - k) * friction_scale(W, rows, normal);
  for (int j = 0; j < m; ++j) {
    double* a = &ws.A(0, j);
    const double across = k * (e[0] * a[s1] + e[1] * a[s2]);
    a[s1] = 0;
    a[s2] = across;
  }
  ws.A(s1, s1) = u[0];
  ws.A(s1, s2) = u[1];
  ws.A(s1, sn) = -rows.mu[normal];
  ws.A(s2, s1) += soft * e[0];
  ws.A(s2, s2) += soft * e[1];
  ws.x[s2] = k * (e[0] * ws.x[s1] + e[1] * ws.x[s2]);
  ws.x[s1] = 0;
}

// The guess's linear system in ws.A and ws.x: column by column (W symmetric: W(ri, rj) =
// W(rj, ri), read down column rj), then each sliding contact's friction equations.
template <class Cols>
void active_system(Cols& W, const VecX& c, const ConstraintRows& rows, int m, SolverWorkspace& ws,
                   double regularization) {
  for (int j = 0; j < m; ++j) {
    const int rj = ws.var[j];
    double* a = &ws.A(0, j);
    const double* wj = W.col(rj);
    for (int i = 0; i < m; ++i) a[i] = wj[ws.var[i]];
    a[j] += regularization * W.diag(rj) + 1e-300;
    ws.x[j] = -c[rj];
  }
  for (int j = 0; j < m; ++j) {
    const int r = ws.var[j];
    if (rows.type[r] == RowType::ContactNormal && ws.state[r] == kSlide) {
      sliding_rows(W, rows, r, m, ws);
    }
  }
}

// A unilateral row's guess from its impulses p and residuals r (Alart and Curnier's
// classification): an active row whose impulse pulls (p < 0) separates, an inactive one that
// approaches (r < 0) becomes active; an active contact sticks while its augmented friction
// z = p_t - r_t / w lies in the disc of radius mu z_n (z_n = p_n - r_n / W_nn, the normal's
// augmented impulse), and slides along u = z / |z| with k = mu z_n / |z| otherwise. `solved`:
// p solves the guess's system, so an active row's r_n and a sticking contact's r_t are zero
// (z_n = p_n, z = p_t, read without W). True when the guess changed or a sliding direction
// moved by more than kDirTol.
template <class Cols>
bool classify(Cols& W, const ConstraintRows& rows, const VecX& p, const VecX& r, int row,
              bool solved, SolverWorkspace& ws) {
  int& s = ws.state[row];
  const int before = s;
  if (s != kInactive && p[row] < -kImpTol) {
    s = kInactive;
    return true;
  }
  if (s == kInactive && !(r[row] < -kVelTol)) return false;
  const int f1 = rows.friction[row], f2 = rows.friction2[row];
  if (f1 == ConstraintRows::kNone) {
    s = kStick;
    return s != before;
  }
  double zn = p[row];
  if (!(solved && before != kInactive)) {
    const double wnn = W.diag(row);
    zn = std::max(0.0, p[row] - (wnn > kTinyPivot ? r[row] / wnn : 0.0));
  }
  Eigen::Vector2d z(p[f1], p[f2]);
  if (!(solved && before == kStick)) {
    z = augmented_friction(rows, row, p, r, friction_scale(W, rows, row));
  }
  const double lim = rows.mu[row] * zn, len = z.norm();
  if (len <= lim * (1 + 1e-9) + kImpTol) {
    s = kStick;
    return s != before;
  }
  const Eigen::Vector2d u = z / len;
  const bool moved = before != kSlide || (u - ws.dir[row]).norm() > kDirTol;
  s = kSlide;
  ws.dir[row] = u;
  ws.shrink[row] = lim / len;
  return moved;
}

// c_j + (W p)_j (W symmetric: column j in place of row j).
template <class Cols>
double residual(Cols& W, const VecX& c, const VecX& p, int n, int j) {
  const double* w = W.col(j);
  double s = c[j];
  for (int i = 0; i < n; ++i) s += w[i] * p[i];
  return s;
}

// The first guess from the warm start: a row with warm impulse or approaching (c < 0) is
// active. A contact whose warm friction lies on the disc's edge slid in the last step: it is
// classified from its residuals under the warm start (r = c + W p, its three rows), so that it
// starts sliding where it still slides instead of sticking for one update.
template <class Cols>
void first_guess(Cols& W, const VecX& c, const ConstraintRows& rows, const VecX& p,
                 SolverWorkspace& ws) {
  const int n = rows.count;
  for (int r = 0; r < n; ++r) {
    if (!unilateral(rows.type[r])) continue;
    ws.state[r] = starts_active(c, p, r) ? kStick : kInactive;
    const int f1 = rows.friction[r], f2 = rows.friction2[r];
    if (f1 == ConstraintRows::kNone || !(p[r] > 0)) continue;
    const double edge = rows.mu[r] * p[r] * (1 - kEdge);
    if (p[f1] * p[f1] + p[f2] * p[f2] < edge * edge) continue;
    for (int j : {r, f1, f2}) ws.r[j] = residual(W, c, p, n, j);
    classify(W, rows, p, ws.r, r, false, ws);
  }
}

// Updates the guess from the last solve's p and residuals ws.r (classify, every row that no
// two-cycle froze); true when it changed.
template <class Cols>
bool update_guess(Cols& W, const ConstraintRows& rows, const VecX& p, SolverWorkspace& ws) {
  bool changed = false;
  for (int r = 0; r < rows.count; ++r) {
    if (!unilateral(rows.type[r]) || ws.frozen[r]) continue;
    changed = classify(W, rows, p, ws.r, r, true, ws) || changed;
  }
  return changed;
}

// The two-cycle: the new guess differs from the one just solved but is the one of the update
// before. Its flipping rows (those the update changed) keep the new guess from then on.
void freeze_two_cycle(const ConstraintRows& rows, SolverWorkspace& ws) {
  bool back = true, moved = false;
  for (int r = 0; r < rows.count && back; ++r) {
    if (!unilateral(rows.type[r])) continue;
    back = ws.state[r] == ws.state2[r];
    moved = moved || ws.state[r] != ws.state1[r];
  }
  if (!back || !moved) return;
  for (int r = 0; r < rows.count; ++r) {
    if (unilateral(rows.type[r]) && ws.state[r] != ws.state1[r]) ws.frozen[r] = 1;
  }
}

// The active-set updates from the first guess; true when a guess settled (p solves its system
// and ws.r = c + W p). st.iterations counts the updates.
template <class Cols>
bool active_set_updates(Cols& W, const VecX& c, const ConstraintRows& rows, VecX& p,
                        SolverWorkspace& ws, const SolverOptions& opt, SolverStats& st) {
  const int n = rows.count;
  first_guess(W, c, rows, p, ws);
  for (int r = 0; r < n; ++r) ws.frozen[r] = 0;
  bool converged = false;
  int it = 0;
  for (it = 1; it <= opt.active_set_iterations; ++it) {
    const int m = active_variables(rows, ws);
    active_system(W, c, rows, m, ws, opt.regularization);
    // LU, not Cholesky, also when no contact slides: on panda_push the Cholesky solution of the
    // same (nearly singular) system sent the box flying (110 m in 2 s) where LU's does not.
    if (m > 0 && !lu_solve(ws.A, m, ws.piv, ws.x)) break;  // the caller's fallback
    for (int r = 0; r < n; ++r) p[r] = 0;
    for (int i = 0; i < m; ++i) p[ws.var[i]] = ws.x[i];
    residuals(W, c, p, n, ws.r);
    for (int r = 0; r < n; ++r) ws.state1[r] = ws.state[r];  // the guess just solved
    if (!update_guess(W, rows, p, ws)) {
      converged = true;
      break;
    }
    if (it >= 2) freeze_two_cycle(rows, ws);
    for (int r = 0; r < n; ++r) ws.state2[r] = ws.state1[r];
  }
  st.iterations = std::min(it, opt.active_set_iterations);
  for (int r = 0; r < n && converged; ++r) converged = std::isfinite(p[r]);
  return converged;
}

// Whether the impulses p do no positive work on the rows' velocities r = c + W p. A solution of
// the rows' laws has p.r <= 0: p.r = 0 on complementary normals, limits and bilateral rows,
// p.r < 0 where friction opposes a slip. A settled guess with frozen two-cycle rows need not be
// a solution: on a stack whose top box lands tumbling at steps of 4 ms one had impulses of
// 1.8e6 N s (2e3 after the polish) and threw the box at 2 km/s.
bool does_no_work(const VecX& p, const VecX& r, const VecX& c, int n) {
  double work = 0, scale = 0;
  for (int i = 0; i < n; ++i) {
    work += p[i] * r[i];
    scale += std::abs(p[i] * c[i]);
  }
  return work <= kWorkTol * scale + kImpTol * kVelTol;
}

void check_workspace(const ConstraintRows& rows, const SolverWorkspace& ws) {
  if (static_cast<int>(ws.state.size()) < rows.count) {
    throw std::length_error("solve_active_set: workspace smaller than the rows");
  }
}

}  // namespace

// Guesses that never settle (a sliding contact's direction cycling, a singular system) leave an
// iterate that is not a solution: sliding boxes on a stack were thrown kilometres. Then
// projected Gauss-Seidel from the warm start with its full sweeps solves the step instead;
// otherwise a few sweeps from the direct solution make it feasible to rounding.
SolverStats solve_active_set(const MatX& W, const VecX& c, const ConstraintRows& rows, VecX& p,
                             SolverWorkspace& ws, const SolverOptions& opt) {
  SolverStats st;
  const int n = rows.count;
  if (n == 0) return st;
  check_workspace(rows, ws);
  st.columns = n;
  for (int r = 0; r < n; ++r) ws.p0[r] = p[r];  // the warm start, for the fallback
  DenseColumns cols{W};
  SolverOptions polish = opt;
  polish.iterations = std::max(1, opt.polish_sweeps);
  if (active_set_updates(cols, c, rows, p, ws, opt, st)) {
    st.change = pgs_on_residuals(cols, rows, p, ws.r, polish).change;
    if (does_no_work(p, ws.r, c, n)) return st;
  }
  for (int r = 0; r < n; ++r) p[r] = ws.p0[r];
  st.fallback = true;
  st.change = solve_pgs(W, c, rows, p, opt).change;
  return st;
}

SolverStats solve_active_set(DelassusColumns& W, const VecX& c, const ConstraintRows& rows, VecX& p,
                             SolverWorkspace& ws, const SolverOptions& opt) {
  const int n = rows.count;
  if (n == 0) return SolverStats{};
  check_workspace(rows, ws);
  if (!lazy_columns_pay(c, rows, p)) {
    delassus_complete(W);
    SolverStats st = solve_active_set(*W.W, c, rows, p, ws, opt);
    st.columns = W.formed;
    return st;
  }
  SolverStats st;
  for (int r = 0; r < n; ++r) ws.p0[r] = p[r];
  LazyColumns cols{W};
  SolverOptions polish = opt;
  polish.iterations = std::max(1, opt.polish_sweeps);
  bool settled = active_set_updates(cols, c, rows, p, ws, opt, st);
  if (settled) {
    st.change = pgs_on_residuals(cols, rows, p, ws.r, polish).change;
    settled = does_no_work(p, ws.r, c, n);
  }
  if (!settled) {
    delassus_complete(W);
    for (int r = 0; r < n; ++r) p[r] = ws.p0[r];
    st.fallback = true;
    st.change = solve_pgs(*W.W, c, rows, p, opt).change;
  }
  st.columns = W.formed;
  return st;
}

int starting_active_rows(const VecX& c, const ConstraintRows& rows, const VecX& p) {
  int active = 0;
  for (int r = 0; r < rows.count; ++r) {
    const RowType t = rows.type[r];
    if (t == RowType::Equality) {
      ++active;
    } else if (unilateral(t) && starts_active(c, p, r)) {
      active += rows.friction[r] == ConstraintRows::kNone ? 1 : 3;
    }
  }
  return active;
}

bool lazy_columns_pay(const VecX& c, const ConstraintRows& rows, const VecX& p) {
  return 2 * starting_active_rows(c, rows, p) <= rows.count;
}

ContactSolver contact_solver_from_name(const std::string& name) {
  if (name == "pgs") return ContactSolver::PGS;
  if (name == "active_set") return ContactSolver::ActiveSet;
  throw std::invalid_argument("contact solver '" + name + "': known are pgs, active_set");
}

}  // namespace se3
