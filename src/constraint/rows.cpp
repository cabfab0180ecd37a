// The rows of one step and their builders (constraint.h).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>

#ifdef __SSE2__
#include <emmintrin.h>
#endif
#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

#include "../lie/simd.h"
#include "se3_sim/constraint/constraint.h"

namespace se3 {

void SystemKinematics::reset(const Model& m, const std::vector<SE3>& poses, int first_column) {
  model = &m;
  oMb = &poses;
  col0 = first_column;
  Sw.assign(m.nv, Vec6::Zero());
}

void SystemKinematics::update_world_axes() {
  const Model& m = *model;
  const std::vector<SE3>& X = *oMb;
  if (m.floating) {
    for (int k = 0; k < 6; ++k) Sw[k] = act_motion(X[0], Vec6::Unit(k));
  }
  for (int i = 1; i <= m.n; ++i) Sw[m.idx_v(i)] = act_motion(X[i], Vec6::Unit(m.joints[i].axis()));
}

void ConstraintRows::reserve(int columns, int cap) {
  nv = columns;
  count = 0;
  J = RowMat::Zero(cap, columns);
  b = VecX::Zero(cap);
  type.assign(cap, RowType::Equality);
  id.assign(cap, kNone);
  friction.assign(cap, kNone);
  friction2.assign(cap, kNone);
  normal.assign(cap, kNone);
  mu.assign(cap, 0.0);
  gap.assign(cap, 0.0);
  touched.assign(cap, 0);
}

int ConstraintRows::add(RowType t, int producer) {
  if (count >= capacity()) throw std::length_error("constraint rows: capacity exceeded");
  const int r = count++;
  J.row(r).setZero();
  b[r] = 0;
  type[r] = t;
  id[r] = producer;
  friction[r] = friction2[r] = normal[r] = kNone;
  mu[r] = 0;
  gap[r] = 0;
  touched[r] = 0;
  return r;
}

void DelassusWorkspace::reserve(int nv, int capacity) {
  mask.assign(capacity, 0);
  const int c = std::min(nv, 64);
  Jc = MatX::Zero(capacity, c);
  Mc = MatX::Zero(nv, c);
  Yc = MatX::Zero(c, capacity);
}

namespace {

// The dense products, for every row's columns.
void dense_delassus(const ConstraintRows::RowMat& J, int rows, int nv, const MatX& Minv, MatX& Y,
                    MatX& W) {
  if (nv == 0) {
    // No robot dofs (a scene of objects alone): the block is zero. Eigen's triangular product
    // divides by its inner dimension when it sizes its blocks, and 0 is SIGFPE.
    W.topLeftCorner(rows, rows).triangularView<Eigen::Lower>().setZero();
    return;
  }
  auto Jr = J.topLeftCorner(rows, nv);
  Y.topLeftCorner(nv, rows).noalias() = Minv * Jr.transpose();
  W.topLeftCorner(rows, rows).triangularView<Eigen::Lower>() = Jr * Y.topLeftCorner(nv, rows);
}

// The end of the group of consecutive rows that share row g0's mask.
int group_end(const std::vector<std::uint64_t>& mask, int g0, int rows) {
  int g1 = g0 + 1;
  while (g1 < rows && mask[g1] == mask[g0]) ++g1;
  return g1;
}

}  // namespace

void robot_delassus(const ConstraintRows::RowMat& J, int rows, int nv, const MatX& Minv, MatX& Y,
                    MatX& W, DelassusWorkspace& ws) {
  // A mask holds 64 columns. Up to 2 nv rows the sparse products could save a few thousand
  // multiply-adds at most, less than finding the masks and groups costs.
  if (nv > 64 || rows <= 2 * nv) return dense_delassus(J, rows, nv, Minv, Y, W);
  for (int r = 0; r < rows; ++r) {
    const double* j = J.row(r).data();  // row-major: row r is contiguous
    std::uint64_t m = 0;
    for (int a = 0; a < nv; ++a) {
      if (j[a] != 0) m |= std::uint64_t(1) << a;
    }
    ws.mask[r] = m;
  }
  // The multiply-adds of both ways; a group's gathers and product calls cost about as much as
  // kGroupCost of them, so few rows in many groups (small problems) go dense.
  constexpr double kGroupCost = 2000;
  const double dense = double(rows) * nv * (0.5 * (rows + 1) + nv);
  double sparse = 0;
  for (int g0 = 0; g0 < rows;) {
    const int g1 = group_end(ws.mask, g0, rows);
    sparse += double(g1 - g0) * __builtin_popcountll(ws.mask[g0]) * (g1 + nv) + kGroupCost;
    g0 = g1;
  }
  if (sparse >= dense) return dense_delassus(J, rows, nv, Minv, Y, W);

  int cols[64];
  for (int g0 = 0; g0 < rows;) {
    const std::uint64_t mask = ws.mask[g0];
    const int g1 = group_end(ws.mask, g0, rows);
    const int n = g1 - g0;
    int s = 0;
    for (std::uint64_t m = mask; m; m &= m - 1) cols[s++] = __builtin_ctzll(m);
    // The group's rows of the lower triangle: left of its diagonal block, and that block's own.
    auto Yg = Y.block(0, g0, nv, n);
    auto Wl = W.block(g0, 0, n, g0);
    auto Wd = W.block(g0, g0, n, n).triangularView<Eigen::Lower>();
    if (s == 0) {
      Yg.setZero();
      Wl.setZero();
      Wd.setZero();
      g0 = g1;
      continue;
    }
    auto Jc = ws.Jc.topLeftCorner(n, s);
    auto Mc = ws.Mc.leftCols(s);
    for (int k = 0; k < s; ++k) {
      Jc.col(k) = J.col(cols[k]).segment(g0, n);
      Mc.col(k) = Minv.col(cols[k]);
    }
    // Y(:, group) = D^-1(:, S) J(group, S)^T; W(group, 0..g1) = J(group, S) Y(S, 0..g1).
    Yg.noalias() = Mc * Jc.transpose();
    auto Yc = ws.Yc.topLeftCorner(s, g1);
    for (int k = 0; k < s; ++k) Yc.row(k) = Y.row(cols[k]).head(g1);
    if (g0 > 0) Wl.noalias() = Jc * Yc.leftCols(g0);
    Wd = Jc * Yc.rightCols(n);
    g0 = g1;
  }
}

void DelassusColumns::reserve(int capacity, int systems) {
  first.assign(systems, 0);
  width.assign(systems, 0);
  dinv.assign(systems, nullptr);
  done.assign(capacity, 0);
}

void DelassusColumns::reserve_factored(int capacity, int nv) {
  Z = MatX::Zero(capacity, nv);
  zmask.assign(capacity, 0);
  lo.assign(nv, 0);
  hi.assign(nv, 0);
  g = VecX::Zero(nv);
  ptr.assign(nv, nullptr);
  coef.assign(nv, 0.0);
}

namespace {

// The factored Delassus's two inner loops, over a block of rows with several of Z's columns at
// once, so that each row's entry is loaded and stored once for all of them (a loop per column
// would reload it for each). Each destination gets its terms in the column order given, as a
// loop per column would: the same rounding. M columns at a time, unrolled.
//   gather:  out[r] += sum_t c[t] z[t][r]
//   scatter: z[t][r] -= c[t] src[r]
constexpr int kFuse = 8;

template <int M>
void gather_fixed(double* out, const double* const* z, const double* c, int n) {
  int r = 0;
#ifdef __SSE2__
  __m128d ct[M];
  for (int t = 0; t < M; ++t) ct[t] = _mm_set1_pd(c[t]);
  for (; r + 2 <= n; r += 2) {
    __m128d acc = _mm_loadu_pd(out + r);
    for (int t = 0; t < M; ++t) acc = _mm_add_pd(acc, _mm_mul_pd(ct[t], _mm_loadu_pd(z[t] + r)));
    _mm_storeu_pd(out + r, acc);
  }
#endif
  for (; r < n; ++r) {
    double acc = out[r];
    for (int t = 0; t < M; ++t) acc += c[t] * z[t][r];
    out[r] = acc;
  }
}

template <int M>
void scatter_fixed(double* const* z, const double* c, const double* src, int n) {
  int r = 0;
#ifdef __SSE2__
  __m128d ct[M];
  for (int t = 0; t < M; ++t) ct[t] = _mm_set1_pd(c[t]);
  for (; r + 2 <= n; r += 2) {
    const __m128d s = _mm_loadu_pd(src + r);
    for (int t = 0; t < M; ++t) {
      _mm_storeu_pd(z[t] + r, _mm_sub_pd(_mm_loadu_pd(z[t] + r), _mm_mul_pd(ct[t], s)));
    }
  }
#endif
  for (; r < n; ++r) {
    for (int t = 0; t < M; ++t) z[t][r] -= c[t] * src[r];
  }
}

#ifdef SE3_SIM_RUNTIME_AVX
#define SE3_ROWS_AVX 1
// The same loops four rows at a time (AVX, no FMA: the same products and sums, the same bits),
// chosen at run time (detail::have_avx).

template <int M>
__attribute__((target("avx"))) void gather_fixed_avx(double* out, const double* const* z,
                                                     const double* c, int n) {
  int r = 0;
  __m256d ct[M];
  for (int t = 0; t < M; ++t) ct[t] = _mm256_set1_pd(c[t]);
  for (; r + 4 <= n; r += 4) {
    __m256d acc = _mm256_loadu_pd(out + r);
    for (int t = 0; t < M; ++t) {
      acc = _mm256_add_pd(acc, _mm256_mul_pd(ct[t], _mm256_loadu_pd(z[t] + r)));
    }
    _mm256_storeu_pd(out + r, acc);
  }
  for (; r < n; ++r) {
    double acc = out[r];
    for (int t = 0; t < M; ++t) acc += c[t] * z[t][r];
    out[r] = acc;
  }
}

template <int M>
__attribute__((target("avx"))) void scatter_fixed_avx(double* const* z, const double* c,
                                                      const double* src, int n) {
  int r = 0;
  __m256d ct[M];
  for (int t = 0; t < M; ++t) ct[t] = _mm256_set1_pd(c[t]);
  for (; r + 4 <= n; r += 4) {
    const __m256d s = _mm256_loadu_pd(src + r);
    for (int t = 0; t < M; ++t) {
      _mm256_storeu_pd(z[t] + r, _mm256_sub_pd(_mm256_loadu_pd(z[t] + r), _mm256_mul_pd(ct[t], s)));
    }
  }
  for (; r < n; ++r) {
    for (int t = 0; t < M; ++t) z[t][r] -= c[t] * src[r];
  }
}
#endif

// One instantiation of kernel K<M> per count 1..kFuse: m columns, kFuse at a time.
#define SE3_FUSED_SWITCH(K, ...)   \
  switch (m < kFuse ? m : kFuse) { \
    case 1:                        \
      K<1>(__VA_ARGS__);           \
      break;                       \
    case 2:                        \
      K<2>(__VA_ARGS__);           \
      break;                       \
    case 3:                        \
      K<3>(__VA_ARGS__);           \
      break;                       \
    case 4:                        \
      K<4>(__VA_ARGS__);           \
      break;                       \
    case 5:                        \
      K<5>(__VA_ARGS__);           \
      break;                       \
    case 6:                        \
      K<6>(__VA_ARGS__);           \
      break;                       \
    case 7:                        \
      K<7>(__VA_ARGS__);           \
      break;                       \
    default:                       \
      K<8>(__VA_ARGS__);           \
      break;                       \
  }

void gather(double* out, const double* const* z, const double* c, int m, int n) {
#ifdef SE3_ROWS_AVX
  if (detail::have_avx()) {
    for (; m > 0; m -= kFuse, z += kFuse, c += kFuse) {
      SE3_FUSED_SWITCH(gather_fixed_avx, out, z, c, n)
    }
    return;
  }
#endif
  for (; m > 0; m -= kFuse, z += kFuse, c += kFuse) {
    SE3_FUSED_SWITCH(gather_fixed, out, z, c, n)
  }
}

void scatter(double* const* z, const double* c, const double* src, int m, int n) {
#ifdef SE3_ROWS_AVX
  if (detail::have_avx()) {
    for (; m > 0; m -= kFuse, z += kFuse, c += kFuse) {
      SE3_FUSED_SWITCH(scatter_fixed_avx, z, c, src, n)
    }
    return;
  }
#endif
  for (; m > 0; m -= kFuse, z += kFuse, c += kFuse) {
    SE3_FUSED_SWITCH(scatter_fixed, z, c, src, n)
  }
}
#undef SE3_FUSED_SWITCH

// The robot's columns of row r that are non-zero, as a mask.
std::uint64_t nonzero_columns(const double* j, int nv) {
  std::uint64_t m = 0;
  int a = 0;
#ifdef __SSE2__
  const __m128d zero = _mm_setzero_pd();
  for (; a + 2 <= nv; a += 2) {
    const int bits = _mm_movemask_pd(_mm_cmpneq_pd(_mm_loadu_pd(j + a), zero));
    m |= static_cast<std::uint64_t>(bits) << a;
  }
#endif
  for (; a < nv; ++a) m |= std::uint64_t(j[a] != 0) << a;
  return m;
}

// Z = J L^-T over the robot's columns of the step's rows, with each row's dofs and each dof's
// rows (DelassusColumns::factor). Consecutive rows with the same non-zero columns (a contact's
// three, a leg's contacts) form a group: its dofs are found once, and L^-T runs over its rows
// as one block, a column (dof) at a time.
__attribute__((noinline)) void factor_rows(DelassusColumns& d, int rows) {
  const Data& f = *d.factor;
  const int nv = d.width[0], c0 = d.first[0];
  const int* lam = f.v_parent.data();
  const MatX& L = f.LD;
  double* Z = d.Z.data();
  const std::ptrdiff_t ld = d.Z.rows();  // column-major: Z(r, a) = Z[r + ld a]
  for (int a = 0; a < nv; ++a) d.lo[a] = rows, d.hi[a] = 0;
  std::uint64_t* jm = d.zmask.data();  // first the rows' non-zero columns, then their dofs
  const std::uint64_t robot = nv == 64 ? ~std::uint64_t(0) : (std::uint64_t(1) << nv) - 1;
  for (int r = 0; r < rows; ++r) {
    if (!(d.mask[r] & 1)) {
      jm[r] = 0;
    } else if (d.touched && d.touched[r] && c0 == 0) {
      jm[r] = d.touched[r] & robot;  // the columns the builder wrote (closed: its ancestors)
    } else {
      jm[r] = nonzero_columns(d.J->row(r).data() + c0, nv);
    }
  }
  for (int g0 = 0; g0 < rows;) {
    const std::uint64_t cols = jm[g0];
    int g1 = g0 + 1;
    while (g1 < rows && jm[g1] == cols) ++g1;
    const int n = g1 - g0;
    // L^-T fills in the ancestors of a touched dof, and nothing else.
    std::uint64_t m = cols;
    for (std::uint64_t t = m; t;) {
      const int a = 63 - __builtin_clzll(t);
      t &= ~(std::uint64_t(1) << a);
      const int p = lam[a];
      if (p >= 0 && !(m >> p & 1)) {
        m |= std::uint64_t(1) << p;
        t |= std::uint64_t(1) << p;
      }
    }
    // Z's block: zero off the group's dofs (they may lie in other dofs' row ranges), J on them.
    for (int a = 0; a < nv; ++a) {
      double* z = Z + g0 + ld * a;
      if (!(m >> a & 1)) {
        for (int i = 0; i < n; ++i) z[i] = 0;
        continue;
      }
      for (int i = 0; i < n; ++i) z[i] = (*d.J)(g0 + i, c0 + a);
      if (d.lo[a] == rows) d.lo[a] = g0;
      d.hi[a] = g1;
    }
    // L^T Z^T = J^T over the group, the leaves first (a dof's parent has a lower index): dof k's
    // column into all its ancestors' at once.
    for (std::uint64_t t = m; t;) {
      const int k = 63 - __builtin_clzll(t);
      t &= ~(std::uint64_t(1) << k);
      int na = 0;
      for (int i = lam[k]; i >= 0; i = lam[i], ++na) {
        d.ptr[na] = Z + g0 + ld * i;
        d.coef[na] = L(k, i);
      }
      scatter(d.ptr.data(), d.coef.data(), Z + g0 + ld * k, na, n);
    }
    for (int r = g0; r < g1; ++r) jm[r] = m;
    g0 = g1;
  }
}

}  // namespace

void delassus_begin(DelassusColumns& d, int rows) {
  d.rows = rows;
  d.formed = 0;
  std::fill(d.done.begin(), d.done.begin() + rows, 0);
  if (d.factor) factor_rows(d, rows);
}

const double* delassus_column(DelassusColumns& d, int j) {
  MatX& W = *d.W;
  if (d.done[j]) return &W(0, j);
  const int n = d.rows;
  const double* jr = d.J->row(j).data();
  auto y = d.Y->col(j);
  auto w = W.col(j).head(n);
  y.setZero();
  w.setZero();
  for (std::uint64_t m = d.mask[j]; m; m &= m - 1) {
    const int s = __builtin_ctzll(m), c0 = d.first[s], ws = d.width[s];
    if (s == 0 && d.factor) {
      // W(:, j) += Z Diag^-1 Z(j, :)^T, a dof of row j at a time over the rows that touch it.
      // The dofs that share their rows (a free base's six, a leg's joints) go together.
      const double* dinv = d.factor->Dinv.data();
      const double* Z = d.Z.data();
      const std::ptrdiff_t ld = d.Z.rows();
      for (std::uint64_t t = d.zmask[j]; t;) {
        const int a0 = __builtin_ctzll(t), lo = d.lo[a0], hi = d.hi[a0];
        int na = 0;
        for (; t; t &= t - 1, ++na) {
          const int a = __builtin_ctzll(t);
          if (d.lo[a] != lo || d.hi[a] != hi) break;
          d.ptr[na] = const_cast<double*>(Z + lo + ld * a);
          d.coef[na] = Z[j + ld * a] * dinv[a];
        }
        gather(w.data() + lo, d.ptr.data(), d.coef.data(), na, hi - lo);
      }
      continue;
    }
    // Y(s, j) = D^-1_s J(j, s)^T over the row's non-zero entries (D^-1 symmetric: its column a
    // is its row a), then W(:, j) += J(:, s) Y(s, j).
    double* ys = y.data() + c0;
    for (int a = 0; a < ws; ++a) {
      if (jr[c0 + a] == 0) continue;
      const double* col = d.dinv[s] + static_cast<std::ptrdiff_t>(a) * ws;
      const double v = jr[c0 + a];
      for (int i = 0; i < ws; ++i) ys[i] += v * col[i];
    }
    w.noalias() += d.J->block(0, c0, n, ws) * y.segment(c0, ws);
  }
  d.done[j] = 1;
  ++d.formed;
  return &W(0, j);
}

void delassus_complete(DelassusColumns& d) {
  for (int j = 0; j < d.rows; ++j) delassus_column(d, j);
}

void delassus_impulse_velocity(DelassusColumns& d, const VecX& p, VecX& v) {
  const int n = d.rows;
  // Columns after the robot's: Y's (the free bodies' blocks); the robot's through its factor.
  const int c1 = d.factor ? d.first[0] + d.width[0] : 0;
  for (int r = 0; r < n; ++r) {
    if (p[r] == 0) continue;
    delassus_column(d, r);
    v.tail(v.size() - c1).noalias() += p[r] * d.Y->col(r).tail(v.size() - c1);
  }
  if (!d.factor) return;
  // D^-1 J^T p = L^-1 Diag^-1 (Z^T p).
  const int nv = d.width[0];
  const double* dinv = d.factor->Dinv.data();
  for (int a = 0; a < nv; ++a) {
    const int lo = d.lo[a], len = d.hi[a] - lo;
    d.g[a] = len > 0 ? dinv[a] * d.Z.col(a).segment(lo, len).dot(p.segment(lo, len)) : 0.0;
  }
  ltdl_solve_l(*d.factor, d.g.data());
  v.segment(d.first[0], nv) += d.g;
}

void point_jacobian(const SystemKinematics& sys, int body, const Vec3& p, const Vec3& d, double s,
                    double* row) {
  if (body < 0 || !sys.model) return;
  const Model& m = *sys.model;
  const Vec3 pxd = p.cross(d);  // d . (v + w x p) = d . v + w . (p x d)
  double* out = row + sys.col0;
  auto add = [&](int col) {
    const Vec6& S = sys.Sw[col];
    out[col] += s * (d.dot(S.tail<3>()) + pxd.dot(S.head<3>()));
  };
  for (int j = body; j >= 1; j = m.parent[j]) add(m.idx_v(j));
  if (m.floating) {
    for (int k = 0; k < 6; ++k) add(k);
  }
}

void point_jacobian3(const SystemKinematics& sys, int body, const Vec3& p, const Vec3* const d[3],
                     double s, ConstraintRows& rows, const int r[3]) {
  if (body < 0 || !sys.model) return;
  const Model& m = *sys.model;
  const Vec3 pxd[3] = {p.cross(*d[0]), p.cross(*d[1]), p.cross(*d[2])};
  double* out[3] = {rows.row(r[0]) + sys.col0, rows.row(r[1]) + sys.col0,
                    rows.row(r[2]) + sys.col0};
  std::uint64_t bits = 0;
  auto add = [&](int col) {
    const Vec6& S = sys.Sw[col];
    for (int k = 0; k < 3; ++k)
      out[k][col] += s * (d[k]->dot(S.tail<3>()) + pxd[k].dot(S.head<3>()));
    if (sys.col0 + col < 64) bits |= std::uint64_t(1) << (sys.col0 + col);
  };
  for (int j = body; j >= 1; j = m.parent[j]) add(m.idx_v(j));
  if (m.floating) {
    for (int k = 0; k < 6; ++k) add(k);
  }
  for (int k = 0; k < 3; ++k) rows.touched[r[k]] |= bits;
}

void angular_jacobian(const SystemKinematics& sys, int body, const Vec3& c, double s, double* row) {
  if (body < 0 || !sys.model) return;
  const Model& m = *sys.model;
  double* out = row + sys.col0;
  for (int j = body; j >= 1; j = m.parent[j]) {
    const int col = m.idx_v(j);
    out[col] += s * c.dot(sys.Sw[col].head<3>());
  }
  if (m.floating) {
    for (int k = 0; k < 6; ++k) out[k] += s * c.dot(sys.Sw[k].head<3>());
  }
}

double gap_reference(double g, double h, const RowParams& p) {
  if (g >= 0) return -g / h;  // may close the gap within the step, no further (no tunnelling)
  if (g >= -p.slop) return 0.0;
  return -p.erp * (g + p.slop) / h;
}

// The row parameters of a contact between a and b: p with the objects' own erp, slop and
// max_correction_velocity where given (both: the softer erp, larger slop, smaller speed).
// Returns p itself when neither gives any (the common case: no copy).
static const RowParams& pair_params(const CollisionObject& a, const CollisionObject& b,
                                    const RowParams& p) {
  thread_local RowParams own;
  const bool any = !std::isnan(a.erp) || !std::isnan(b.erp) || !std::isnan(a.slop) ||
                   !std::isnan(b.slop) || !std::isnan(a.max_correction_velocity) ||
                   !std::isnan(b.max_correction_velocity);
  if (!any) return p;
  auto pick = [](double x, double y, double fallback, bool smaller) {
    if (std::isnan(x) && std::isnan(y)) return fallback;
    if (std::isnan(x)) return y;
    if (std::isnan(y)) return x;
    return smaller ? std::min(x, y) : std::max(x, y);
  };
  own = p;
  own.erp = pick(a.erp, b.erp, p.erp, true);
  own.slop = pick(a.slop, b.slop, p.slop, false);
  own.max_correction_velocity =
      pick(a.max_correction_velocity, b.max_correction_velocity, p.max_correction_velocity, true);
  return own;
}

void tangent_basis(const Vec3& n, Vec3& t1, Vec3& t2) {
  const Vec3 seed = std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  t1 = seed.cross(n).normalized();
  t2 = n.cross(t1);
}

void add_point_rows(ConstraintRows& rows, const SystemKinematics& sa, int body_a, const Vec3& pa,
                    const SystemKinematics* sb, int body_b, const Vec3& pb,
                    const std::vector<Vec3>& dirs, double h, const RowParams& p, int id) {
  const Vec3 d_ab = pa - pb;
  for (const Vec3& d : dirs) {
    const int r = rows.add(RowType::Equality, id);
    point_jacobian(sa, body_a, pa, d, 1.0, rows.row(r));
    if (sb) point_jacobian(*sb, body_b, pb, d, -1.0, rows.row(r));
    rows.b[r] = -p.bilateral_erp * d.dot(d_ab) / h;
  }
}

void add_axis_rows(ConstraintRows& rows, const SystemKinematics& s, int body, const Vec3& u,
                   const Vec3& e1, const Vec3& e2, double h, const RowParams& p, int id) {
  for (const Vec3* e : {&e1, &e2}) {
    const int r = rows.add(RowType::Equality, id);
    // d/dt (e . u) = e . (w x u) = (u x e) . w
    angular_jacobian(s, body, u.cross(*e), 1.0, rows.row(r));
    rows.b[r] = -p.bilateral_erp * e->dot(u) / h;
  }
}

void add_joint_limit_rows(ConstraintRows& rows, const SystemKinematics& s, const VecX& q,
                          const VecX& vfree, double h, const RowParams& p) {
  const Model& m = *s.model;
  for (int i = 1; i <= m.n; ++i) {
    const int col = m.idx_v(i);
    const double qi = q[m.idx_q(i)];
    const double reach = p.margin + std::abs(vfree[s.col0 + col]) * h;
    for (int side = 0; side < 2; ++side) {
      const double limit = side == 0 ? m.lower[i] : m.upper[i];
      if (!std::isfinite(limit)) continue;
      const double g = side == 0 ? qi - limit : limit - qi;
      if (g >= reach) continue;
      const int r = rows.add(RowType::JointLimit, i);
      rows.J(r, s.col0 + col) = side == 0 ? 1.0 : -1.0;
      double ref = gap_reference(g, h, p);
      if (p.limit_restitution > 0) {  // an impact within this step bounces, as contacts do
        const double vn = side == 0 ? vfree[s.col0 + col] : -vfree[s.col0 + col];
        if (vn < -p.restitution_velocity && g + h * vn <= p.slop) {
          ref = std::max(ref, -p.limit_restitution * vn);
        }
      }
      rows.b[r] = ref;
      rows.gap[r] = g;
    }
  }
}

void add_contact_rows(ConstraintRows& rows, const std::vector<Contact>& contacts,
                      const std::vector<CollisionObject>& objects,
                      const std::vector<FrameRef>& frames,
                      const std::vector<const SystemKinematics*>& systems, const VecX& vfree,
                      double h, const RowParams& p) {
  auto frame_of = [&](int object) {
    const int f = objects[object].frame;
    return f < 0 || f >= static_cast<int>(frames.size()) ? FrameRef{} : frames[f];
  };
  for (size_t k = 0; k < contacts.size(); ++k) {
    const Contact& c = contacts[k];
    const FrameRef fa = frame_of(c.a), fb = frame_of(c.b);
    if (fa.system < 0 && fb.system < 0) continue;
    const SystemKinematics* sa = fa.system >= 0 ? systems[fa.system] : nullptr;
    const SystemKinematics* sb = fb.system >= 0 ? systems[fb.system] : nullptr;
    Vec3 t1, t2;
    tangent_basis(c.normal, t1, t2);
    const int n = rows.add(RowType::ContactNormal, static_cast<int>(k));
    const int f1 = rows.add(RowType::ContactFriction, static_cast<int>(k));
    const int f2 = rows.add(RowType::ContactFriction, static_cast<int>(k));
    const Vec3* dirs[3] = {&c.normal, &t1, &t2};
    const int r3[3] = {n, f1, f2};
    if (sb) point_jacobian3(*sb, fb.body, c.point, dirs, 1.0, rows, r3);
    if (sa) point_jacobian3(*sa, fa.body, c.point, dirs, -1.0, rows, r3);
    rows.friction[n] = f1;
    rows.friction2[n] = f2;
    rows.normal[f1] = rows.normal[f2] = n;
    const CollisionObject &oa = objects[c.a], &ob = objects[c.b];
    rows.mu[n] = oa.mu_own && ob.mu_own ? std::min(oa.mu, ob.mu)
                 : oa.mu_own            ? oa.mu
                 : ob.mu_own            ? ob.mu
                                        : std::max(oa.mu, ob.mu);
    const double g = -c.depth;
    rows.gap[n] = g;
    // The pair's own correction (a URDF's Gazebo kp, kd, minDepth, maxVel), else the scene's.
    const RowParams& pp = pair_params(oa, ob, p);
    // A penetration is removed at erp per step, but no faster than max_correction_velocity: the
    // push-out velocity stays in the bodies after they separate, so a deep start (a box spawned
    // 0.3 m into the ground asked for 60 m/s at dt = 1 ms) would otherwise launch them.
    double ref = std::min(gap_reference(g, h, pp), std::max(0.0, pp.max_correction_velocity));
    const double e = std::max(objects[c.a].restitution, objects[c.b].restitution);
    if (e > 0) {  // an impact within this step bounces: its velocity reversed, times e
      const double vn = rows.J.row(n).dot(vfree);
      if (vn < -p.restitution_velocity && g + h * vn <= p.slop) ref = std::max(ref, -e * vn);
    }
    rows.b[n] = ref;
  }
}

}  // namespace se3
