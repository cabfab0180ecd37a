// The rows of one step and their builders (constraint.h).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "se3_sim/constraint.h"

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

void delassus_begin(DelassusColumns& d, int rows) {
  d.rows = rows;
  d.formed = 0;
  std::fill(d.done.begin(), d.done.begin() + rows, 0);
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
    const double reach = p.margin + std::abs(vfree[col]) * h;
    for (int side = 0; side < 2; ++side) {
      const double limit = side == 0 ? m.lower[i] : m.upper[i];
      if (!std::isfinite(limit)) continue;
      const double g = side == 0 ? qi - limit : limit - qi;
      if (g >= reach) continue;
      const int r = rows.add(RowType::JointLimit, i);
      rows.J(r, s.col0 + col) = side == 0 ? 1.0 : -1.0;
      rows.b[r] = gap_reference(g, h, p);
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
    for (int j = 0; j < 3; ++j) {
      if (sb) point_jacobian(*sb, fb.body, c.point, *dirs[j], 1.0, rows.row(r3[j]));
      if (sa) point_jacobian(*sa, fa.body, c.point, *dirs[j], -1.0, rows.row(r3[j]));
    }
    rows.friction[n] = f1;
    rows.friction2[n] = f2;
    rows.normal[f1] = rows.normal[f2] = n;
    rows.mu[n] = std::max(objects[c.a].mu, objects[c.b].mu);
    const double g = -c.depth;
    rows.gap[n] = g;
    double ref = gap_reference(g, h, p);
    const double e = std::max(objects[c.a].restitution, objects[c.b].restitution);
    if (e > 0) {  // an impact within this step bounces: its velocity reversed, times e
      const double vn = rows.J.row(n).dot(vfree);
      if (vn < -p.restitution_velocity && g + h * vn <= p.slop) ref = std::max(ref, -e * vn);
    }
    rows.b[n] = ref;
  }
}

}  // namespace se3
