// The collision layer (collision.h) on FCL 0.7: objects as fcl::CollisionObjectd (meshes as the
// fcl::Convexd of their hull), a dynamic AABB tree for the broad phase, FCL's distance and
// collide for the narrow phase; half-spaces (the ground) are tested here in closed form.
#include "se3_sim/collision/collision.h"

#include <fcl/fcl.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>

#include "../lie/simd.h"
#ifdef __SSE2__
#include <emmintrin.h>
#endif
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define SE3_COLLISION_AVX 1  // four-lane versions of the two hot loops, chosen at run time
#endif
#include <map>
#include <set>
#include <stdexcept>

namespace se3 {
namespace {

// An FCL object whose world AABB can be grown by the margin (the broad phase must report
// pairs that are apart by less than the margin).
struct Object : fcl::CollisionObjectd {
  using fcl::CollisionObjectd::CollisionObjectd;
  void inflate(double m) {
    aabb.min_.array() -= m;
    aabb.max_.array() += m;
  }
};

fcl::Transform3d to_fcl(const SE3& f) {
  fcl::Transform3d t = fcl::Transform3d::Identity();
  t.linear() = f.R;
  t.translation() = f.p;
  return t;
}

bool positive(double x) {
  return x > 0 && std::isfinite(x);
}

}  // namespace

struct CollisionModel::Impl {
  int n = 0;
  std::vector<std::unique_ptr<Object>> fcl;              ///< null for half-spaces
  std::vector<std::shared_ptr<const ConvexHull>> hulls;  ///< meshes only
  std::vector<int> halfspaces;
  std::vector<int> moving;             ///< objects on a frame other than kWorld
  std::vector<SE3> world;              ///< shape frames in the world, from the last collide()
  std::vector<unsigned char> allowed;  ///< n x n: may_collide
  int max_frame = -1;
  bool tree_pairs = false;  ///< two objects of the broad phase may collide (else it is skipped)
  fcl::DynamicAABBTreeCollisionManagerd manager;
  fcl::CollisionRequestd request;
  fcl::CollisionResultd result;
  fcl::DistanceRequestd dist_request;
  fcl::DistanceResultd dist_result;
  // Per call.
  CollisionData* data = nullptr;
  double margin = 0;
  int max_contacts = 4;
  // Meshes only: the hull's vertices as three arrays (all x, then all y, then all z) for the
  // half-space test's one vectorised pass.
  std::vector<std::vector<double>> hull_soa;
  // Every object but half-spaces: the centre and half extents of a box around it in its shape
  // frame (a hull's vertices' box; a primitive's own).
  std::vector<std::array<Vec3, 2>> box;
  // Half-space candidates: points and their signed distances (reserved once).
  std::vector<Vec3> points;
  std::vector<double> gaps;
  std::vector<int> picked, cand;
  std::vector<double> dist, tu, tv;
  // Per half-space (in the order of halfspaces), the objects that may touch it grouped by frame,
  // in order of their first object (CollisionOptions::ground_contacts_per_body; else one group per
  // object).
  std::vector<std::vector<std::vector<int>>> ground_groups;
  // A body's candidates against a half-space (groups of more than one object): gap, coordinates
  // across the normal, owner object and its point (a hull vertex, or an entry of gpts).
  std::vector<double> ggap, gu, gv;
  std::vector<int> gobj, gidx;
  std::vector<Vec3> gpts;

  bool ok(int i, int j) const { return allowed[std::size_t(i) * n + j] != 0; }
};

namespace {

// Points of shape i (world) that may touch the plane n.x = offset (n unit, solid below): the
// deepest point of a sphere, the 8 corners of a box, 4 points on each rim of a cylinder (the
// lowest, the highest and the two between), the two cap bottoms of a capsule. (A hull's
// vertices are used in place.)
void halfspace_candidates(const CollisionObject& o, const SE3& T, const Vec3& n,
                          std::vector<Vec3>& pts) {
  pts.clear();
  const Shape& s = o.shape;
  switch (s.type) {
    case ShapeType::Sphere:
      pts.push_back(T.p - s.radius * n);
      break;
    case ShapeType::Box: {
      const Vec3 h = s.box / 2;
      for (int k = 0; k < 8; ++k) {
        const Vec3 c((k & 1) ? h.x() : -h.x(), (k & 2) ? h.y() : -h.y(), (k & 4) ? h.z() : -h.z());
        pts.push_back(T.p + T.R * c);
      }
      break;
    }
    case ShapeType::Cylinder: {
      const Vec3 a = T.R.col(2);
      Vec3 u = -(n - n.dot(a) * a);  // towards the plane, across the axis
      if (u.norm() < 1e-9) {
        u = T.R.col(0);
      } else {
        u.normalize();
      }
      const Vec3 e = a.cross(u);
      for (double side : {-1.0, 1.0}) {
        const Vec3 c = T.p + side * s.length / 2 * a;
        pts.push_back(c + s.radius * u);
        pts.push_back(c - s.radius * u);
        pts.push_back(c + s.radius * e);
        pts.push_back(c - s.radius * e);
      }
      break;
    }
    case ShapeType::Capsule: {
      const Vec3 a = T.R.col(2);
      pts.push_back(T.p + s.length / 2 * a - s.radius * n);
      pts.push_back(T.p - s.length / 2 * a - s.radius * n);
      break;
    }
    case ShapeType::Mesh:  // the hull's vertices, used in place
      break;
  }
}

// d[k] = min(d[k], (u[k] - lu)^2 + (v[k] - lv)^2) over k < n, the distance of each candidate to
// the nearest picked point after picking (lu, lv); returns the largest d[k] (-inf for n = 0).
// Two candidates at a time where SSE2 is there, with the same operations in each lane as the
// scalar loop (no fused multiply-add), so both give the same bits.
#ifdef SE3_COLLISION_AVX
using detail::have_avx;  // the four-lane loops below (lie/simd.h)

// nearest_picked's loop four candidates at a time (k from 0, while k + 4 <= n); returns the
// largest d[k] of those, and the count done in done.
__attribute__((target("avx"))) double nearest_picked_avx(const double* u, const double* v,
                                                         double lu, double lv, double* d, int n,
                                                         int& done) {
  const __m256d pu = _mm256_set1_pd(lu), pv = _mm256_set1_pd(lv);
  __m256d fars = _mm256_set1_pd(-INFINITY);
  int k = 0;
  for (; k + 4 <= n; k += 4) {
    const __m256d du = _mm256_sub_pd(_mm256_loadu_pd(u + k), pu);
    const __m256d dv = _mm256_sub_pd(_mm256_loadu_pd(v + k), pv);
    const __m256d dk = _mm256_add_pd(_mm256_mul_pd(du, du), _mm256_mul_pd(dv, dv));
    const __m256d m = _mm256_min_pd(dk, _mm256_loadu_pd(d + k));
    _mm256_storeu_pd(d + k, m);
    fars = _mm256_max_pd(m, fars);
  }
  double lanes[4];
  _mm256_storeu_pd(lanes, fars);
  done = k;
  const double a = lanes[0] > lanes[1] ? lanes[0] : lanes[1];
  const double b = lanes[2] > lanes[3] ? lanes[2] : lanes[3];
  return a > b ? a : b;
}
#endif

double nearest_picked(const double* u, const double* v, double lu, double lv, double* d, int n) {
  double far = -INFINITY;
  int k = 0;
#ifdef SE3_COLLISION_AVX
  if (n >= 16 && have_avx()) far = nearest_picked_avx(u, v, lu, lv, d, n, k);
#endif
#ifdef __SSE2__
  // (A few candidates, a box's corners: the scalar loop below costs less than the set-up.)
  if (n >= 16 && k == 0) {
    const __m128d pu = _mm_set1_pd(lu), pv = _mm_set1_pd(lv);
    __m128d fars = _mm_set1_pd(-INFINITY);
    for (; k + 2 <= n; k += 2) {
      const __m128d du = _mm_sub_pd(_mm_loadu_pd(u + k), pu);
      const __m128d dv = _mm_sub_pd(_mm_loadu_pd(v + k), pv);
      const __m128d dk = _mm_add_pd(_mm_mul_pd(du, du), _mm_mul_pd(dv, dv));
      // min(new, old) keeps old when equal, as std::min(old, new); max(d, far) skips a NaN d.
      const __m128d m = _mm_min_pd(dk, _mm_loadu_pd(d + k));
      _mm_storeu_pd(d + k, m);
      fars = _mm_max_pd(m, fars);
    }
    double lanes[2];
    _mm_storeu_pd(lanes, fars);
    far = lanes[0] > lanes[1] ? lanes[0] : lanes[1];
  }
#endif
  for (; k < n; ++k) {
    const double du = u[k] - lu, dv = v[k] - lv;
    d[k] = std::min(d[k], du * du + dv * dv);
    if (d[k] > far) far = d[k];
  }
  return far;
}

#ifdef SE3_COLLISION_AVX
// first_equal four entries at a time: the first k < n (from 0, four at a time) with d[k] == x,
// or the count done (a multiple of four) when none is.
__attribute__((target("avx"))) int first_equal_avx(const double* d, int n, double x) {
  const __m256d vx = _mm256_set1_pd(x);
  int k = 0;
  for (; k + 4 <= n; k += 4) {
    const int eq = _mm256_movemask_pd(_mm256_cmp_pd(_mm256_loadu_pd(d + k), vx, _CMP_EQ_OQ));
    if (eq) return k + __builtin_ctz(unsigned(eq));
  }
  return k;
}
#endif

// The first k < n with d[k] == x (x one of them: the farthest candidate's distance).
int first_equal(const double* d, int n, double x) {
  int k = 0;
#ifdef SE3_COLLISION_AVX
  if (n >= 16 && have_avx()) k = first_equal_avx(d, n, x);
#endif
  while (!(d[k] == x)) ++k;
  return k;
}

// The gaps of a hull's vertices to a plane, g[i] = ((n_x X[i] + n_y Y[i]) + n_z Z[i]) + d0 for
// i < np (X, Y, Z: the vertices' three coordinate arrays, one after the other), and in the same
// pass the candidates: cs gets the indices of the gaps below the margin, in order (room for
// np + 1 entries); returns their count, and the smallest gap in lowest. Two vertices at a time
// where SSE2 is there, with the scalar loop's operations in each lane (the same bits).
#ifdef SE3_COLLISION_AVX
// hull_gaps' loop eight vertices a step (i from 0, while i + 8 <= np): the gaps, the candidates
// (their count in k), the smallest gap in low; returns the vertices done.
__attribute__((target("avx"))) int hull_gaps_avx(const double* X, const double* Y, const double* Z,
                                                 int np, const Vec3& n, double d0, double margin,
                                                 double* g, int* cs, int& k, double& low) {
  const __m256d vx = _mm256_set1_pd(n.x()), vy = _mm256_set1_pd(n.y()), vz = _mm256_set1_pd(n.z());
  const __m256d vd = _mm256_set1_pd(d0), vm = _mm256_set1_pd(margin);
  __m256d lows = _mm256_set1_pd(INFINITY);
  int i = 0;
  // Two of a pair's lanes below the margin, the second or neither: as in hull_gaps.
  auto append = [&](int below, int j) {
    cs[k] = j + 1 - (below & 1);
    cs[k + 1] = j + 1;
    k += (below & 1) + (below >> 1);
  };
  for (; i + 8 <= np; i += 8) {
    const __m256d g0 =
        _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(vx, _mm256_loadu_pd(X + i)),
                                                  _mm256_mul_pd(vy, _mm256_loadu_pd(Y + i))),
                                    _mm256_mul_pd(vz, _mm256_loadu_pd(Z + i))),
                      vd);
    const __m256d g1 =
        _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(vx, _mm256_loadu_pd(X + i + 4)),
                                                  _mm256_mul_pd(vy, _mm256_loadu_pd(Y + i + 4))),
                                    _mm256_mul_pd(vz, _mm256_loadu_pd(Z + i + 4))),
                      vd);
    _mm256_storeu_pd(g + i, g0);
    _mm256_storeu_pd(g + i + 4, g1);
    lows = _mm256_min_pd(g0, lows);
    lows = _mm256_min_pd(g1, lows);
    const int b0 = _mm256_movemask_pd(_mm256_cmp_pd(g0, vm, _CMP_LT_OQ));
    const int b1 = _mm256_movemask_pd(_mm256_cmp_pd(g1, vm, _CMP_LT_OQ));
    if (b0 | b1) {
      append(b0 & 3, i);
      append(b0 >> 2, i + 2);
      append(b1 & 3, i + 4);
      append(b1 >> 2, i + 6);
    }
  }
  double lanes[4];
  _mm256_storeu_pd(lanes, lows);
  for (double l : lanes) low = l < low ? l : low;
  return i;
}
#endif

int hull_gaps(const double* X, int np, const Vec3& n, double d0, double margin, double* g, int* cs,
              double& lowest) {
  const double *Y = X + np, *Z = Y + np;
  const double nx = n.x(), ny = n.y(), nz = n.z();
  int k = 0, i = 0;
  double low = INFINITY;
#ifdef SE3_COLLISION_AVX
  if (have_avx()) i = hull_gaps_avx(X, Y, Z, np, n, d0, margin, g, cs, k, low);
#endif
#ifdef __SSE2__
  const __m128d vx = _mm_set1_pd(nx), vy = _mm_set1_pd(ny), vz = _mm_set1_pd(nz);
  const __m128d vd = _mm_set1_pd(d0), vm = _mm_set1_pd(margin);
  __m128d lows = _mm_set1_pd(INFINITY);
  // Four vertices a step, and their candidates appended only when there are some: a hull's
  // vertices near the plane come in runs (qhull's order is mostly spatial: of Solo-12's foot's
  // 168 blocks of four standing on the ground, 79 hold a candidate; of its lower leg's 72, 18).
  for (; i + 4 <= np; i += 4) {
    const __m128d g0 = _mm_add_pd(_mm_add_pd(_mm_add_pd(_mm_mul_pd(vx, _mm_loadu_pd(X + i)),
                                                        _mm_mul_pd(vy, _mm_loadu_pd(Y + i))),
                                             _mm_mul_pd(vz, _mm_loadu_pd(Z + i))),
                                  vd);
    const __m128d g1 = _mm_add_pd(_mm_add_pd(_mm_add_pd(_mm_mul_pd(vx, _mm_loadu_pd(X + i + 2)),
                                                        _mm_mul_pd(vy, _mm_loadu_pd(Y + i + 2))),
                                             _mm_mul_pd(vz, _mm_loadu_pd(Z + i + 2))),
                                  vd);
    _mm_storeu_pd(g + i, g0);
    _mm_storeu_pd(g + i + 2, g1);
    lows = _mm_min_pd(g0, lows);
    lows = _mm_min_pd(g1, lows);
    const int b0 = _mm_movemask_pd(_mm_cmplt_pd(g0, vm));
    const int b1 = _mm_movemask_pd(_mm_cmplt_pd(g1, vm));
    if (b0 | b1) {  // as below, twice
      cs[k] = i + 1 - (b0 & 1);
      cs[k + 1] = i + 1;
      k += (b0 & 1) + (b0 >> 1);
      cs[k] = i + 3 - (b1 & 1);
      cs[k + 1] = i + 3;
      k += (b1 & 1) + (b1 >> 1);
    }
  }
  for (; i + 2 <= np; i += 2) {
    const __m128d gi = _mm_add_pd(_mm_add_pd(_mm_add_pd(_mm_mul_pd(vx, _mm_loadu_pd(X + i)),
                                                        _mm_mul_pd(vy, _mm_loadu_pd(Y + i))),
                                             _mm_mul_pd(vz, _mm_loadu_pd(Z + i))),
                                  vd);
    _mm_storeu_pd(g + i, gi);
    lows = _mm_min_pd(gi, lows);  // a NaN gap is skipped (and never a candidate)
    // Both, the second or neither below the margin: without a branch (an entry past the
    // count is overwritten by the next).
    const int below = _mm_movemask_pd(_mm_cmplt_pd(gi, vm));
    cs[k] = i + 1 - (below & 1);
    cs[k + 1] = i + 1;
    k += (below & 1) + (below >> 1);
  }
  double two[2];
  _mm_storeu_pd(two, lows);
  for (double l : two) low = l < low ? l : low;
#endif
  for (; i < np; ++i) {
    g[i] = ((nx * X[i] + ny * Y[i]) + nz * Z[i]) + d0;
    cs[k] = i;
    k += g[i] < margin;
    if (g[i] < low) low = g[i];
  }
  lowest = low;
  return k;
}

// Up to max of the nc candidates cand (indices into pts and gaps, below the margin, in order;
// deepest is the first of the deepest): the deepest first, then each next the one farthest
// (across the normal) from those already picked, so that a resting face keeps its corners
// (farthest-point sampling: O(max * candidates)). picked gets indices, deepest first; dist, tu
// and tv are workspaces of at least nc entries.
void pick_points(const std::vector<Vec3>& pts, const std::vector<double>& gaps, const Vec3& n,
                 int nc, int deepest, int max, std::vector<int>& picked, std::vector<int>& cand,
                 std::vector<double>& dist, std::vector<double>& tu, std::vector<double>& tv) {
  picked.clear();
  if (nc == 0) return;
  const int* cs = cand.data();
  picked.push_back(deepest);
  if (max > 1 && nc > 1) {
    // Distances across the normal from the candidates' coordinates in the plane (t1, t2).
    int axis = 0;  // the world axis least along n
    n.cwiseAbs().minCoeff(&axis);
    const Vec3 t1 = n.cross(Vec3::Unit(axis)).normalized(), t2 = n.cross(t1);
    double* cu = tu.data();
    double* cv = tv.data();
    for (int k = 0; k < nc; ++k) {
      cu[k] = t1.dot(pts[cs[k]]);
      cv[k] = t2.dot(pts[cs[k]]);
    }
    double* d = dist.data();
    std::fill(d, d + nc, INFINITY);
    double lu = t1.dot(pts[deepest]), lv = t2.dot(pts[deepest]);
    while (int(picked.size()) < max) {
      // The first of the farthest, if farther than 1e-12 (a point that coincides with a picked
      // one adds nothing).
      const double far = nearest_picked(cu, cv, lu, lv, d, nc);
      if (!(far > 1e-12)) break;
      const int best = first_equal(d, nc, far);
      picked.push_back(cs[best]);
      lu = cu[best];
      lv = cv[best];
    }
  }
  std::sort(picked.begin(), picked.end(), [&](int x, int y) { return gaps[x] < gaps[y]; });
}

// Contacts of object b against half-space h: a = h, normal = the plane's outward normal.
void collide_halfspace(CollisionModel& model, int h, int b) {
  CollisionModel::Impl& m = model.impl();
  const SE3& P = m.world[h];
  const Vec3 n = P.R.col(2);
  const double offset = n.dot(P.p);
  const CollisionObject& o = model.objects()[b];
  const SE3& T = m.world[b];
  // Early out on the shape's bounding sphere (FCL's AABB of the object, inflated; kept up to
  // date only with a broad phase, else the box test below).
  if (m.tree_pairs && m.fcl[b]) {
    const fcl::AABBd& box = m.fcl[b]->getAABB();
    const Vec3 c = (box.min_ + box.max_) / 2, r = (box.max_ - box.min_) / 2;
    if (n.dot(c) - offset - r.cwiseProduct(n.cwiseAbs()).sum() > m.margin) return;
  }
  ++m.data->pairs_tested;
  // In the shape's frame: gap = n_l . v + d0 per candidate point v (one dot product per hull
  // vertex; only the picked points are carried to the world).
  const Vec3 nl = T.R.transpose() * n;
  const double d0 = n.dot(T.p) - offset;
  const std::vector<Vec3>* pts = &m.points;
  // The candidates below the margin, and the deepest of them (the first of equal ones).
  int nc = 0, deepest = 0;
  int* cs = m.cand.data();
  const double* g = m.gaps.data();
  if (o.shape.type == ShapeType::Mesh) {
    // No vertex is nearer the plane than the nearest corner of the hull's box.
    const std::array<Vec3, 2>& box = m.box[b];
    if (nl.dot(box[0]) + d0 - box[1].dot(nl.cwiseAbs()) >= m.margin) return;
    pts = &m.hulls[b]->vertices;
    double lowest = 0;
    nc = hull_gaps(m.hull_soa[b].data(), int(pts->size()), nl, d0, m.margin, m.gaps.data(), cs,
                   lowest);
    if (nc == 0) return;
    int k = 0;
    while (!(g[cs[k]] == lowest)) ++k;
    deepest = cs[k];
  } else {
    const std::array<Vec3, 2>& box = m.box[b];
    if (!m.tree_pairs && nl.dot(box[0]) + d0 - box[1].dot(nl.cwiseAbs()) >= m.margin) return;
    halfspace_candidates(o, SE3(), nl, m.points);
    const int np = int(m.points.size());
    for (int i = 0; i < np; ++i) m.gaps[i] = nl.dot(m.points[i]) + d0;
    for (int i = 0; i < np; ++i) {
      cs[nc] = i;
      nc += g[i] < m.margin;
    }
    if (nc == 0) return;
    deepest = cs[0];
    for (int k = 1; k < nc; ++k) {
      if (g[cs[k]] < g[deepest]) deepest = cs[k];
    }
  }
  pick_points(*pts, m.gaps, nl, nc, deepest, m.max_contacts, m.picked, m.cand, m.dist, m.tu, m.tv);
  for (int i : m.picked) {
    Contact c;
    c.a = h;
    c.b = b;
    c.normal = n;
    c.depth = -m.gaps[i];
    // Midway between the shape's point and the plane.
    c.point = T.p + T.R * (*pts)[i] + c.depth / 2 * n;
    m.data->contacts.push_back(c);
  }
}

// A point's coordinates across the normal: u = (a_x x + a_y y) + a_z z + u0, v likewise.
struct Across {
  double ax, ay, az, u0, bx, by, bz, v0;
  void at(double x, double y, double z, double& u, double& v) const {
    u = ((ax * x + ay * y) + az * z) + u0;
    v = ((bx * x + by * y) + bz * z) + v0;
  }
};

#ifdef SE3_COLLISION_AVX
// The candidates cs of a hull (coordinate arrays X, Y, Z, gaps g) four at a time (k from 0,
// while k + 4 <= k1): gg their gaps, gu and gv their coordinates across the normal (Across::at's
// operations in each lane); returns the count done.
__attribute__((target("avx"))) int gather_avx(const double* X, const double* Y, const double* Z,
                                              const double* g, const int* cs, int k1,
                                              const Across& c, double* gg, double* gu, double* gv) {
  const __m256d ax = _mm256_set1_pd(c.ax), ay = _mm256_set1_pd(c.ay), az = _mm256_set1_pd(c.az);
  const __m256d bx = _mm256_set1_pd(c.bx), by = _mm256_set1_pd(c.by), bz = _mm256_set1_pd(c.bz);
  const __m256d u0 = _mm256_set1_pd(c.u0), v0 = _mm256_set1_pd(c.v0);
  int k = 0;
  for (; k + 4 <= k1; k += 4) {
    const int i0 = cs[k], i1 = cs[k + 1], i2 = cs[k + 2], i3 = cs[k + 3];
    const __m256d x = _mm256_set_pd(X[i3], X[i2], X[i1], X[i0]);
    const __m256d y = _mm256_set_pd(Y[i3], Y[i2], Y[i1], Y[i0]);
    const __m256d z = _mm256_set_pd(Z[i3], Z[i2], Z[i1], Z[i0]);
    _mm256_storeu_pd(gg + k, _mm256_set_pd(g[i3], g[i2], g[i1], g[i0]));
    _mm256_storeu_pd(
        gu + k,
        _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(ax, x), _mm256_mul_pd(ay, y)),
                                    _mm256_mul_pd(az, z)),
                      u0));
    _mm256_storeu_pd(
        gv + k,
        _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(bx, x), _mm256_mul_pd(by, y)),
                                    _mm256_mul_pd(bz, z)),
                      v0));
  }
  return k;
}
#endif

// Contacts of one body's objects (`group`, all on one frame, at least two) against half-space h,
// picked together: every object's candidates as collide_halfspace takes them, then of their union
// the deepest (the first of equal ones), each next the farthest across the normal from those
// picked, at most max_contacts for the body, deepest first. A body of overlapping shapes (Solo-12's
// lower leg, whose hull holds its foot's) then spends its budget on points spread over its whole
// footprint instead of one set per shape. Each contact names the object its point belongs to.
void collide_halfspace_body(CollisionModel& model, int h, const std::vector<int>& group) {
  CollisionModel::Impl& m = model.impl();
  const SE3& P = m.world[h];
  const Vec3 n = P.R.col(2);
  const double offset = n.dot(P.p);
  // The candidates' coordinates across the normal, in one world basis for every object.
  int axis = 0;  // the world axis least along n
  n.cwiseAbs().minCoeff(&axis);
  const Vec3 t1 = n.cross(Vec3::Unit(axis)).normalized(), t2 = n.cross(t1);
  int nc = 0;
  double low = INFINITY;  // the deepest gap
  m.gpts.clear();
  for (int b : group) {
    const CollisionObject& o = model.objects()[b];
    const SE3& T = m.world[b];
    if (m.tree_pairs) {  // Early out on the object's box (FCL's AABB, inflated).
      const fcl::AABBd& box = m.fcl[b]->getAABB();
      const Vec3 c = (box.min_ + box.max_) / 2, r = (box.max_ - box.min_) / 2;
      if (n.dot(c) - offset - r.cwiseProduct(n.cwiseAbs()).sum() > m.margin) continue;
    }
    ++m.data->pairs_tested;
    const Vec3 nl = T.R.transpose() * n;
    const double d0 = n.dot(T.p) - offset;
    const Vec3* pts = nullptr;
    int first = 0, k1 = 0;  // this object's candidates: k1 of them, in cs
    double* g = m.gaps.data();
    int* cs = m.cand.data();
    if (o.shape.type == ShapeType::Mesh) {
      const std::array<Vec3, 2>& box = m.box[b];
      if (nl.dot(box[0]) + d0 - box[1].dot(nl.cwiseAbs()) >= m.margin) continue;
      pts = m.hulls[b]->vertices.data();
      double lowest = 0;
      k1 = hull_gaps(m.hull_soa[b].data(), int(m.hulls[b]->vertices.size()), nl, d0, m.margin, g,
                     cs, lowest);
      if (lowest < low) low = lowest;
    } else {
      const std::array<Vec3, 2>& box = m.box[b];
      if (!m.tree_pairs && nl.dot(box[0]) + d0 - box[1].dot(nl.cwiseAbs()) >= m.margin) continue;
      halfspace_candidates(o, SE3(), nl, m.points);
      first = int(m.gpts.size());
      m.gpts.insert(m.gpts.end(), m.points.begin(), m.points.end());  // reserved: 8 per object
      pts = m.gpts.data() + first;
      const int np = int(m.points.size());
      for (int i = 0; i < np; ++i) g[i] = nl.dot(pts[i]) + d0;
      for (int i = 0; i < np; ++i) {
        cs[k1] = i;
        k1 += g[i] < m.margin;
        if (g[i] < low) low = g[i];
      }
    }
    // Their entries: gap, coordinates across the normal (a hull's from its coordinate arrays,
    // four at a time with AVX), owner and point.
    const Vec3 l1 = T.R.transpose() * t1, l2 = T.R.transpose() * t2;
    const Across across{l1.x(), l1.y(), l1.z(), t1.dot(T.p), l2.x(), l2.y(), l2.z(), t2.dot(T.p)};
    double *gg = m.ggap.data() + nc, *gu = m.gu.data() + nc, *gv = m.gv.data() + nc;
    int k = 0;
    if (o.shape.type == ShapeType::Mesh) {
      const int nv = int(m.hulls[b]->vertices.size());
      const double* X = m.hull_soa[b].data();
#ifdef SE3_COLLISION_AVX
      if (k1 >= 8 && have_avx())
        k = gather_avx(X, X + nv, X + 2 * nv, g, cs, k1, across, gg, gu, gv);
#endif
      for (; k < k1; ++k) {
        const int i = cs[k];
        gg[k] = g[i];
        across.at(X[i], X[nv + i], X[2 * nv + i], gu[k], gv[k]);
      }
    } else {
      for (; k < k1; ++k) {
        const int i = cs[k];
        gg[k] = g[i];
        across.at(pts[i].x(), pts[i].y(), pts[i].z(), gu[k], gv[k]);
      }
    }
    for (k = 0; k < k1; ++k) {
      m.gobj[nc + k] = b;
      m.gidx[nc + k] = first + cs[k];
    }
    nc += k1;
  }
  if (nc == 0) return;
  const double* gap = m.ggap.data();
  int deepest = 0;  // the first of the deepest
  while (!(gap[deepest] == low)) ++deepest;
  m.picked.clear();
  m.picked.push_back(deepest);
  if (m.max_contacts > 1 && nc > 1) {
    const double* cu = m.gu.data();
    const double* cv = m.gv.data();
    double* d = m.dist.data();
    std::fill(d, d + nc, INFINITY);
    double lu = cu[deepest], lv = cv[deepest];
    while (int(m.picked.size()) < m.max_contacts) {
      // The first of the farthest, if farther than 1e-12 (as pick_points).
      const double far = nearest_picked(cu, cv, lu, lv, d, nc);
      if (!(far > 1e-12)) break;
      const int best = first_equal(d, nc, far);
      m.picked.push_back(best);
      lu = cu[best];
      lv = cv[best];
    }
  }
  std::sort(m.picked.begin(), m.picked.end(), [&](int x, int y) { return gap[x] < gap[y]; });
  for (int k : m.picked) {
    const int b = m.gobj[k];
    const SE3& T = m.world[b];
    const Vec3& v = model.objects()[b].shape.type == ShapeType::Mesh
                        ? m.hulls[b]->vertices[std::size_t(m.gidx[k])]
                        : m.gpts[std::size_t(m.gidx[k])];
    Contact c;
    c.a = h;
    c.b = b;
    c.normal = n;
    c.depth = -gap[k];
    c.point = T.p + T.R * v + c.depth / 2 * n;  // midway between the shape's point and the plane
    m.data->contacts.push_back(c);
  }
}

// The point of object o (world pose T) farthest along u (unit): its support point.
Vec3 support(const CollisionObject& o, const ConvexHull* hull, const SE3& T, const Vec3& u) {
  const Shape& s = o.shape;
  const Vec3 a = T.R.col(2);
  switch (s.type) {
    case ShapeType::Sphere:
      return T.p + s.radius * u;
    case ShapeType::Box: {
      const Vec3 l = T.R.transpose() * u;
      const Vec3 c(l.x() >= 0 ? s.box.x() / 2 : -s.box.x() / 2,
                   l.y() >= 0 ? s.box.y() / 2 : -s.box.y() / 2,
                   l.z() >= 0 ? s.box.z() / 2 : -s.box.z() / 2);
      return T.p + T.R * c;
    }
    case ShapeType::Cylinder: {
      Vec3 perp = u - u.dot(a) * a;
      const double pn = perp.norm();
      perp = pn > 1e-12 ? Vec3(perp / pn) : Vec3::Zero();
      return T.p + (u.dot(a) >= 0 ? 0.5 : -0.5) * s.length * a + s.radius * perp;
    }
    case ShapeType::Capsule:
      return T.p + (u.dot(a) >= 0 ? 0.5 : -0.5) * s.length * a + s.radius * u;
    case ShapeType::Mesh: {
      const Vec3 l = T.R.transpose() * u;
      Vec3 best = Vec3::Zero();
      double far = -INFINITY;
      if (hull) {
        for (const Vec3& v : hull->vertices) {
          if (v.dot(l) > far) {
            far = v.dot(l);
            best = v;
          }
        }
      }
      return T.p + T.R * best;
    }
  }
  return T.p;
}

// Whether the boxes a and b (centre, half extents in the frames Ta, Tb) are apart by more than
// gap along one of the 15 separating axes of two boxes (their face normals and the cross
// products of their edges): the distance of anything inside them is then more than gap.
bool boxes_apart(const std::array<Vec3, 2>& a, const SE3& Ta, const std::array<Vec3, 2>& b,
                 const SE3& Tb, double gap) {
  const Mat3 R = Ta.R.transpose() * Tb.R;  // b's axes in a's frame
  const Vec3 t = Ta.R.transpose() * (Tb.act(b[0]) - Ta.act(a[0]));
  const Vec3 &ha = a[1], &hb = b[1];
  // |R| with a little added, so that near-parallel edges give no false separation.
  const Mat3 AR = R.cwiseAbs().array() + 1e-12;
  for (int k = 0; k < 3; ++k) {  // a's axes
    if (std::abs(t[k]) - ha[k] - AR.row(k).dot(hb) > gap) return true;
  }
  for (int k = 0; k < 3; ++k) {  // b's axes
    if (std::abs(R.col(k).dot(t)) - AR.col(k).dot(ha) - hb[k] > gap) return true;
  }
  for (int i = 0; i < 3; ++i) {  // a_i x b_j, of length sin(angle) <= 1: the gap scaled by it
    const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;
    for (int j = 0; j < 3; ++j) {
      const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
      const double len = std::sqrt(std::max(0.0, 1.0 - R(i, j) * R(i, j)));
      const double ra = ha[i1] * AR(i2, j) + ha[i2] * AR(i1, j);
      const double rb = hb[j1] * AR(i, j2) + hb[j2] * AR(i, j1);
      if (std::abs(t[i2] * R(i1, j) - t[i1] * R(i2, j)) - ra - rb > gap * len + 1e-12) return true;
    }
  }
  return false;
}

// Narrow phase of a pair that passed the filter and the broad phase: FCL's collide first (a
// penetrating pair: FCL's contacts, EPA or the closed forms FCL has for primitives); a pair it
// finds apart, FCL's distance (GJK): apart by less than the margin gives one contact of negative
// depth between the nearest points.
void collide_pair(CollisionModel& model, int i, int j) {
  CollisionModel::Impl& m = model.impl();
  if (i > j) std::swap(i, j);
  ++m.data->pairs_tested;
  // Pairs whose boxes are apart by more than the margin touch nowhere: no narrow phase.
  if (boxes_apart(m.box[i], m.world[i], m.box[j], m.world[j], m.margin)) return;
  const Object& oa = *m.fcl[i];
  const Object& ob = *m.fcl[j];
  // Two primitives: collide() first, as a penetrating pair (resting contact: most pairs that
  // matter) needs it alone, and the distance query only when it finds them apart. A hull
  // (GJK/EPA either way) is mostly apart (self-collision): distance first, collide when touching.
  const bool hulls = model.objects()[i].shape.type == ShapeType::Mesh ||
                     model.objects()[j].shape.type == ShapeType::Mesh;
  bool touching = false;
  if (hulls) {
    m.dist_result.clear();
    touching = !(fcl::distance(&oa, &ob, m.dist_request, m.dist_result) > 0);
  }
  m.result.clear();
  if (!hulls || touching) fcl::collide(&oa, &ob, m.request, m.result);
  if (m.result.numContacts() == 0) {
    if (touching) return;
    if (!hulls) m.dist_result.clear();
    const double d =
        hulls ? m.dist_result.min_distance : fcl::distance(&oa, &ob, m.dist_request, m.dist_result);
    if (!(d > 0) || d > m.margin) return;
    const Vec3 pa = m.dist_result.nearest_points[0], pb = m.dist_result.nearest_points[1];
    const Vec3 ab = pb - pa;
    if (ab.norm() < 1e-12) return;
    Contact c;
    c.a = i;
    c.b = j;
    c.normal = ab / ab.norm();
    c.depth = -d;
    c.point = (pa + pb) / 2;
    m.data->contacts.push_back(c);
    return;
  }
  const std::size_t first = m.data->contacts.size();
  for (std::size_t k = 0; k < m.result.numContacts(); ++k) {
    const fcl::Contactd& fc = m.result.getContact(k);
    const bool swapped = fc.o1 != oa.collisionGeometry().get();
    Contact c;
    c.a = i;
    c.b = j;
    c.normal = swapped ? Vec3(-fc.normal) : Vec3(fc.normal);
    const double nn = c.normal.norm();
    if (!(nn > 0.5)) continue;
    c.normal /= nn;
    c.depth = fc.penetration_depth;
    c.point = fc.pos;
    m.data->contacts.push_back(c);
  }
  if (m.data->contacts.size() == first) return;
  std::sort(m.data->contacts.begin() + first, m.data->contacts.end(),
            [](const Contact& x, const Contact& y) { return x.depth > y.depth; });
  // FCL's points lie on one surface or the other, or between, depending on the algorithm
  // (sphere-sphere weights by radius; EPA gives a witness point). For convex shapes the
  // overlap along the normal is [n.s_b(-n), n.s_a(n)] (s the support points): move the points
  // along n to its middle, by the shift that puts the deepest one there.
  const CollisionObject& A = model.objects()[i];
  const CollisionObject& B = model.objects()[j];
  Contact& deepest = m.data->contacts[first];
  const Vec3 n = deepest.normal;
  const double mid = 0.5 * (n.dot(support(A, m.hulls[i].get(), m.world[i], n)) +
                            n.dot(support(B, m.hulls[j].get(), m.world[j], -n)));
  const double shift = mid - n.dot(deepest.point);
  for (std::size_t k = first; k < m.data->contacts.size(); ++k) {
    m.data->contacts[k].point += shift * n;
  }
}

bool broadphase_callback(fcl::CollisionObjectd* o1, fcl::CollisionObjectd* o2, void* cdata) {
  auto* model = static_cast<CollisionModel*>(cdata);
  const int i = int(reinterpret_cast<std::intptr_t>(o1->getUserData()));
  const int j = int(reinterpret_cast<std::intptr_t>(o2->getUserData()));
  if (model->impl().ok(i, j)) collide_pair(*model, i, j);
  return false;
}

std::shared_ptr<fcl::CollisionGeometryd> fcl_shape(const CollisionObject& o,
                                                   const std::shared_ptr<const ConvexHull>& hull) {
  const Shape& s = o.shape;
  auto bad = [&](const char* what) {
    throw std::invalid_argument("collision object '" + o.name + "': " + what);
  };
  switch (s.type) {
    case ShapeType::Box:
      if (!(positive(s.box.x()) && positive(s.box.y()) && positive(s.box.z()))) {
        bad("a box needs three positive extents");
      }
      return std::make_shared<fcl::Boxd>(s.box.x(), s.box.y(), s.box.z());
    case ShapeType::Sphere:
      if (!positive(s.radius)) bad("a sphere needs a positive radius");
      return std::make_shared<fcl::Sphered>(s.radius);
    case ShapeType::Cylinder:
      if (!positive(s.radius) || !positive(s.length)) {
        bad("a cylinder needs a positive radius and length");
      }
      return std::make_shared<fcl::Cylinderd>(s.radius, s.length);
    case ShapeType::Capsule:
      if (!positive(s.radius) || !(s.length >= 0)) bad("a capsule needs a positive radius");
      return std::make_shared<fcl::Capsuled>(s.radius, s.length);
    case ShapeType::Mesh: {
      auto verts = std::make_shared<std::vector<fcl::Vector3d>>(hull->vertices.begin(),
                                                                hull->vertices.end());
      auto faces = std::make_shared<std::vector<int>>();
      faces->reserve(hull->triangles.size() * 4);
      for (const auto& t : hull->triangles) {
        faces->push_back(3);
        faces->insert(faces->end(), t.begin(), t.end());
      }
      return std::make_shared<fcl::Convexd>(verts, int(hull->triangles.size()), faces);
    }
  }
  bad("unknown shape");
  return nullptr;
}

}  // namespace

namespace {
std::atomic<std::uint64_t> models_constructed{0};
}  // namespace

std::uint64_t CollisionModel::constructed() {
  return models_constructed.load(std::memory_order_relaxed);
}

CollisionModel::CollisionModel(std::vector<CollisionObject> objects, CollisionOptions options)
    : objects_(std::move(objects)), options_(std::move(options)), impl_(std::make_unique<Impl>()) {
  if (!objects_.empty()) models_constructed.fetch_add(1, std::memory_order_relaxed);
  Impl& m = *impl_;
  const int n = int(objects_.size());
  m.n = n;
  m.fcl.resize(n);
  m.hulls.resize(n);
  m.hull_soa.resize(n);
  m.box.resize(n);
  m.world.resize(n);
  if (!(options_.margin >= 0) || !std::isfinite(options_.margin)) {
    throw std::invalid_argument("collision options: the margin must be >= 0");
  }
  if (options_.max_contacts_per_pair < 1) {
    throw std::invalid_argument("collision options: max_contacts_per_pair must be >= 1");
  }
  // Hulls, once per (mesh, scale).
  std::map<std::pair<const TriangleMesh*, std::array<double, 3>>, std::shared_ptr<const ConvexHull>>
      hull_cache;
  for (int i = 0; i < n; ++i) {
    const CollisionObject& o = objects_[i];
    if (o.frame < CollisionObject::kWorld) {
      throw std::invalid_argument("collision object '" + o.name + "': frame " +
                                  std::to_string(o.frame) + " is not a frame");
    }
    m.max_frame = std::max(m.max_frame, o.frame);
    if (o.frame != CollisionObject::kWorld) m.moving.push_back(i);
    if (o.halfspace) {
      m.halfspaces.push_back(i);
      continue;
    }
    if (o.shape.type == ShapeType::Mesh) {
      if (!o.shape.mesh || o.shape.mesh->triangle_count() == 0) {
        throw std::invalid_argument("collision object '" + o.name + "'" +
                                    (o.link.empty() ? "" : " (link '" + o.link + "')") +
                                    ": mesh '" +
                                    (o.shape.path.empty() ? o.shape.resource : o.shape.path) +
                                    "' has no triangles (not loaded)");
      }
      const std::array<double, 3> sc{o.shape.scale.x(), o.shape.scale.y(), o.shape.scale.z()};
      auto& h = hull_cache[{o.shape.mesh.get(), sc}];
      if (!h) {
        h = std::make_shared<const ConvexHull>(
            convex_hull(*o.shape.mesh, o.shape.scale, "collision object '" + o.name + "'"));
      }
      m.hulls[i] = h;
      const std::vector<Vec3>& v = h->vertices;
      const std::size_t nv = v.size();
      std::vector<double>& soa = m.hull_soa[i];
      soa.resize(3 * nv);
      Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
      for (std::size_t k = 0; k < nv; ++k) {
        for (int c = 0; c < 3; ++c) soa[c * nv + k] = v[k][c];
        lo = lo.cwiseMin(v[k]);
        hi = hi.cwiseMax(v[k]);
      }
      m.box[i] = {Vec3((lo + hi) / 2), Vec3((hi - lo) / 2)};
    } else {
      const Shape& sh = o.shape;
      Vec3 half = Vec3::Zero();
      switch (sh.type) {
        case ShapeType::Box:
          half = sh.box / 2;
          break;
        case ShapeType::Sphere:
          half = Vec3::Constant(sh.radius);
          break;
        case ShapeType::Cylinder:
          half = Vec3(sh.radius, sh.radius, sh.length / 2);
          break;
        case ShapeType::Capsule:
          half = Vec3(sh.radius, sh.radius, sh.length / 2 + sh.radius);
          break;
        case ShapeType::Mesh:
          break;
      }
      m.box[i] = {Vec3::Zero(), half};
    }
    m.fcl[i] = std::make_unique<Object>(fcl_shape(o, m.hulls[i]));
    m.fcl[i]->setUserData(reinterpret_cast<void*>(std::intptr_t(i)));
  }
  // The filter.
  std::set<std::pair<std::string, std::string>> disabled;
  for (const auto& p : options_.disabled_links) {
    disabled.insert(p);
    disabled.insert({p.second, p.first});
  }
  std::set<std::pair<int, int>> adjacent;
  for (const FramePair& p : options_.adjacent) {
    adjacent.insert({p.a, p.b});
    adjacent.insert({p.b, p.a});
  }
  m.allowed.assign(std::size_t(n) * n, 0);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const CollisionObject& a = objects_[i];
      const CollisionObject& b = objects_[j];
      bool ok = i != j;
      ok = ok && !(a.halfspace && b.halfspace);
      ok = ok && a.frame != b.frame;  // also static-static: both on kWorld
      ok = ok && !adjacent.count({a.frame, b.frame});
      ok = ok && !(a.group == 0 && b.group == 0 && !options_.self_collision && !a.self_collide &&
                   !b.self_collide);
      // Another robot's links against each other: its own self-collision rule.
      ok = ok &&
           !(a.group >= 2 && a.group == b.group && !a.self_collide && !b.self_collide &&
             std::find(options_.self_colliding_groups.begin(), options_.self_colliding_groups.end(),
                       a.group) == options_.self_colliding_groups.end());
      ok = ok && !(!a.link.empty() && !b.link.empty() && disabled.count({a.link, b.link}));
      m.allowed[std::size_t(i) * n + j] = ok;
    }
  }
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      if (m.fcl[i] && m.fcl[j] && m.ok(i, j)) m.tree_pairs = true;
    }
  }
  reset_broad_phase();
  m.request.enable_contact = true;
  m.request.num_max_contacts = std::size_t(options_.max_contacts_per_pair);
  m.dist_request.enable_nearest_points = true;
  m.dist_request.enable_signed_distance = false;
  m.margin = options_.margin;
  m.max_contacts = options_.max_contacts_per_pair;
  m.picked.reserve(std::size_t(options_.max_contacts_per_pair) + 1);
  std::size_t most = 8;
  for (const auto& h : m.hulls) {
    if (h) most = std::max(most, h->vertices.size());
  }
  m.points.reserve(most);
  m.gaps.assign(most, 0.0);    // sized once: at least as many as any object's candidates
  m.cand.assign(most + 1, 0);  // sized once: hull_gaps writes into it by index, one past
  // The objects each half-space may touch, grouped by frame (in order of their first object),
  // with room for the candidates of the largest group.
  std::size_t group_most = 0, group_objects = 0;
  m.ground_groups.assign(m.halfspaces.size(), {});
  for (std::size_t k = 0; k < m.halfspaces.size(); ++k) {
    std::vector<std::vector<int>>& groups = m.ground_groups[k];
    for (int b = 0; b < n; ++b) {
      if (!m.fcl[b] || !m.ok(m.halfspaces[k], b)) continue;
      std::vector<int>* into = nullptr;
      if (options_.ground_contacts_per_body && objects_[b].frame != CollisionObject::kWorld) {
        for (std::vector<int>& g : groups) {
          if (objects_[g[0]].frame == objects_[b].frame) into = &g;
        }
      }
      if (!into) into = &groups.emplace_back();
      into->push_back(b);
    }
    for (const std::vector<int>& g : groups) {
      if (g.size() < 2) continue;
      std::size_t points = 0;
      for (int b : g) points += m.hulls[b] ? m.hulls[b]->vertices.size() : 8;
      group_most = std::max(group_most, points);
      group_objects = std::max(group_objects, g.size());
    }
  }
  m.ggap.assign(group_most, 0.0);
  m.gu.assign(group_most, 0.0);
  m.gv.assign(group_most, 0.0);
  m.gobj.assign(group_most, 0);
  m.gidx.assign(group_most, 0);
  m.gpts.reserve(8 * group_objects);
  most = std::max(most, group_most);
  m.dist.assign(most, 0.0);
  m.tu.assign(most, 0.0);
  m.tv.assign(most, 0.0);
}

CollisionModel::~CollisionModel() = default;
void CollisionModel::reset_broad_phase() {
  Impl& m = *impl_;
  // Static objects are placed once, the others start at the identity; the broad phase holds
  // every non-half-space object.
  m.manager.clear();
  std::vector<fcl::CollisionObjectd*> all;
  for (int i = 0; i < m.n; ++i) {
    m.world[i] = objects_[i].frame == CollisionObject::kWorld ? objects_[i].placement : SE3();
    if (!m.fcl[i]) continue;
    m.fcl[i]->setTransform(to_fcl(m.world[i]));
    m.fcl[i]->computeAABB();
    m.fcl[i]->inflate(options_.margin / 2);
    all.push_back(m.fcl[i].get());
  }
  m.manager.registerObjects(all);
  m.manager.setup();
}

CollisionModel::CollisionModel(CollisionModel&&) noexcept = default;
CollisionModel& CollisionModel::operator=(CollisionModel&&) noexcept = default;

bool CollisionModel::may_collide(int i, int j) const {
  const int n = int(objects_.size());
  if (i < 0 || j < 0 || i >= n || j >= n) return false;
  return impl_->ok(i, j);
}

const ConvexHull* CollisionModel::hull(int i) const {
  if (i < 0 || i >= int(objects_.size())) return nullptr;
  return impl_->hulls[i].get();
}

void collide(CollisionModel& model, CollisionData& data, const std::vector<SE3>& frame_poses) {
  CollisionModel::Impl& m = model.impl();
  if (int(frame_poses.size()) <= m.max_frame) {
    throw std::invalid_argument("collide: " + std::to_string(frame_poses.size()) +
                                " frame poses for frames up to " + std::to_string(m.max_frame));
  }
  data.contacts.clear();
  data.pairs_tested = 0;
  m.data = &data;
  const std::vector<CollisionObject>& objs = model.objects();
  for (int i : m.moving) {
    m.world[i] = frame_poses[objs[i].frame] * objs[i].placement;
    // FCL's transforms and AABBs: for the broad phase, and the half-space tests' first early out.
    if (!m.fcl[i] || !m.tree_pairs) continue;
    m.fcl[i]->setTransform(to_fcl(m.world[i]));
    m.fcl[i]->computeAABB();
    m.fcl[i]->inflate(m.margin / 2);
  }
  // The broad phase, unless no two of its objects may collide (a robot on the ground without
  // self-collision: its pairs are all against the half-space, tested below).
  if (m.tree_pairs) {
    m.manager.update();
    m.manager.collide(&model, broadphase_callback);
  }
  for (std::size_t k = 0; k < m.halfspaces.size(); ++k) {
    const int h = m.halfspaces[k];
    for (const std::vector<int>& group : m.ground_groups[k]) {
      if (group.size() == 1) {
        collide_halfspace(model, h, group[0]);
      } else {
        collide_halfspace_body(model, h, group);
      }
    }
  }
  m.data = nullptr;
}

}  // namespace se3
