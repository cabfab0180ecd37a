// Primitive shapes, their triangle meshes, and the closed/outward test of a mesh.
#include <cmath>
#include <cstring>
#include <unordered_map>

#include "se3_sim/geometry/geometry.h"

namespace se3 {
namespace {

struct Vec3fHash {
  std::size_t operator()(const Vec3f& v) const {
    uint32_t b[3];
    std::memcpy(b, v.data(), sizeof b);
    return std::size_t(b[0]) * 73856093u ^ std::size_t(b[1]) * 19349663u ^
           std::size_t(b[2]) * 83492791u;
  }
};
struct Vec3fEq {
  bool operator()(const Vec3f& a, const Vec3f& b) const { return a == b; }
};

// Appends vertex (p, n) and returns its index.
uint32_t add_vertex(TriangleMesh& m, const Vec3f& p, const Vec3f& n) {
  m.positions.push_back(p);
  m.normals.push_back(n);
  return uint32_t(m.positions.size() - 1);
}

void add_tri(TriangleMesh& m, uint32_t a, uint32_t b, uint32_t c) {
  m.indices.push_back(a);
  m.indices.push_back(b);
  m.indices.push_back(c);
}

void box_into(TriangleMesh& m, const Vec3& e) {
  const Vec3f h = (0.5 * e).cast<float>();
  for (int axis = 0; axis < 3; ++axis) {
    for (int s = -1; s <= 1; s += 2) {
      Vec3f n = Vec3f::Zero();
      n[axis] = float(s);
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      uint32_t id[4];
      const int cu[4] = {-1, 1, 1, -1}, cv[4] = {-1, -1, 1, 1};
      for (int k = 0; k < 4; ++k) {
        Vec3f p;
        p[axis] = s * h[axis];
        p[u] = cu[k] * h[u];
        p[v] = cv[k] * h[v];
        id[k] = add_vertex(m, p, n);
      }
      // (u, v, axis) is right-handed: counter-clockwise about +axis; reversed for -axis.
      if (s > 0) {
        add_tri(m, id[0], id[1], id[2]);
        add_tri(m, id[0], id[2], id[3]);
      } else {
        add_tri(m, id[0], id[2], id[1]);
        add_tri(m, id[0], id[3], id[2]);
      }
    }
  }
}

// A surface of revolution about z: profile points (r_k, z_k) with outward profile normals
// (nr_k, nz_k), from the bottom (k = 0) to the top; r = 0 at an end makes a pole.
void revolve(TriangleMesh& m, const std::vector<Eigen::Vector4d>& prof, int seg) {
  std::vector<uint32_t> ring_start;
  for (const auto& q : prof) {
    ring_start.push_back(uint32_t(m.positions.size()));
    const int count = q[0] == 0 ? 1 : seg;
    for (int j = 0; j < count; ++j) {
      const double a = 2 * M_PI * j / seg;
      const double c = std::cos(a), s = std::sin(a);
      add_vertex(m, Vec3f(float(q[0] * c), float(q[0] * s), float(q[1])),
                 Vec3(q[2] * c, q[2] * s, q[3]).normalized().cast<float>());
    }
  }
  for (std::size_t k = 0; k + 1 < prof.size(); ++k) {
    const bool pole0 = prof[k][0] == 0, pole1 = prof[k + 1][0] == 0;
    for (int j = 0; j < seg; ++j) {
      const int jn = (j + 1) % seg;
      const uint32_t a0 = ring_start[k] + (pole0 ? 0 : j), a1 = ring_start[k] + (pole0 ? 0 : jn);
      const uint32_t b0 = ring_start[k + 1] + (pole1 ? 0 : j);
      const uint32_t b1 = ring_start[k + 1] + (pole1 ? 0 : jn);
      if (!pole0) add_tri(m, a0, a1, b1);
      if (!pole1) add_tri(m, a0, b1, b0);
    }
  }
}

// A flat disc at height z facing +z (up) or -z.
void disc(TriangleMesh& m, double r, double z, bool up, int seg) {
  const Vec3f n(0, 0, up ? 1.0f : -1.0f);
  const uint32_t c = add_vertex(m, Vec3f(0, 0, float(z)), n);
  const uint32_t first = uint32_t(m.positions.size());
  for (int j = 0; j < seg; ++j) {
    const double a = 2 * M_PI * j / seg;
    add_vertex(m, Vec3f(float(r * std::cos(a)), float(r * std::sin(a)), float(z)), n);
  }
  for (int j = 0; j < seg; ++j) {
    const uint32_t a = first + j, b = first + (j + 1) % seg;
    if (up) {
      add_tri(m, c, a, b);
    } else {
      add_tri(m, c, b, a);
    }
  }
}

}  // namespace

const char* shape_name(ShapeType t) {
  switch (t) {
    case ShapeType::Box:
      return "box";
    case ShapeType::Sphere:
      return "sphere";
    case ShapeType::Cylinder:
      return "cylinder";
    case ShapeType::Capsule:
      return "capsule";
    case ShapeType::Mesh:
      return "mesh";
  }
  return "?";
}

Shape make_box(const Vec3& e) {
  Shape s;
  s.type = ShapeType::Box;
  s.box = e;
  return s;
}
Shape make_sphere(double r) {
  Shape s;
  s.type = ShapeType::Sphere;
  s.radius = r;
  return s;
}
Shape make_cylinder(double r, double l) {
  Shape s;
  s.type = ShapeType::Cylinder;
  s.radius = r;
  s.length = l;
  return s;
}
Shape make_capsule(double r, double l) {
  Shape s;
  s.type = ShapeType::Capsule;
  s.radius = r;
  s.length = l;
  return s;
}

void finish_mesh(TriangleMesh& m) {
  if (m.positions.empty()) {
    m.lower = m.upper = Vec3f::Zero();
  } else {
    m.lower = m.upper = m.positions[0];
    for (const Vec3f& p : m.positions) {
      m.lower = m.lower.cwiseMin(p);
      m.upper = m.upper.cwiseMax(p);
    }
  }
  if (m.submeshes.empty() && !m.indices.empty()) {
    TriangleMesh::SubMesh s;
    s.triangle_count = uint32_t(m.triangle_count());
    m.submeshes.push_back(s);
  }
  // Weld by position, then every directed edge must appear once and its reverse once: over
  // the whole mesh, and over each sub-mesh on its own.
  std::unordered_map<Vec3f, uint32_t, Vec3fHash, Vec3fEq> weld;
  weld.reserve(m.positions.size());
  std::vector<uint32_t> id(m.positions.size());
  std::vector<Vec3f> weld_pos;
  for (std::size_t i = 0; i < m.positions.size(); ++i) {
    const auto r = weld.emplace(m.positions[i], uint32_t(weld.size()));
    if (r.second) weld_pos.push_back(m.positions[i]);
    id[i] = r.first->second;
  }
  const double tol = 1e-5 * (1.0 + (m.upper - m.lower).cast<double>().norm());
  auto closed_range = [&](std::size_t t0, std::size_t t1, double& volume) {
    std::unordered_map<uint64_t, int> edges;
    edges.reserve(3 * (t1 - t0));
    volume = 0;
    bool ok = t1 > t0;
    for (std::size_t t = t0; t < t1 && 3 * t + 2 < m.indices.size(); ++t) {
      const uint32_t* ix = &m.indices[3 * t];
      const uint32_t v[3] = {id[ix[0]], id[ix[1]], id[ix[2]]};
      if (v[0] == v[1] || v[1] == v[2] || v[2] == v[0]) continue;  // degenerate: no surface
      for (int k = 0; k < 3; ++k) {
        const uint64_t e = uint64_t(v[k]) << 32 | v[(k + 1) % 3];
        if (++edges[e] > 1) ok = false;
      }
      const Vec3 a = m.positions[ix[0]].cast<double>();
      const Vec3 b = m.positions[ix[1]].cast<double>();
      const Vec3 c = m.positions[ix[2]].cast<double>();
      volume += a.dot(b.cross(c));
    }
    if (!ok || edges.empty()) return false;
    std::vector<std::pair<Vec3, Vec3>> boundary;  // edges without a partner
    for (const auto& kv : edges) {
      const uint64_t rev = (kv.first << 32) | (kv.first >> 32);
      const auto r = edges.find(rev);
      if (r != edges.end()) {
        if (r->second != 1) return false;
        continue;
      }
      if (boundary.size() >= 4000) return false;  // an open surface, not a few T-junctions
      const Vec3f& pa = weld_pos[kv.first >> 32];
      const Vec3f& pb = weld_pos[kv.first & 0xffffffffu];
      boundary.emplace_back(pa.cast<double>(), pb.cast<double>());
    }
    // CAD tessellations meet in T-junctions: an edge on one side runs along several shorter
    // ones on the other, in the opposite direction. Closed if every unpartnered edge is
    // covered that way (the surface has no gap, only unshared vertices).
    for (const auto& e : boundary) {
      const Vec3 d = e.second - e.first;
      const double len = d.norm();
      if (!(len > 0)) return false;
      const Vec3 u = d / len;
      double covered = 0;
      for (const auto& f : boundary) {
        const Vec3 c = f.first - e.first, g = f.second - e.first;
        if (u.cross(c).norm() > tol || u.cross(g).norm() > tol) continue;  // not on e's line
        const double tc = u.dot(c), tg = u.dot(g);
        if (tg >= tc) continue;  // same direction
        covered += std::max(0.0, std::min(len, tc) - std::max(0.0, tg));
      }
      if (covered < len - tol) return false;
    }
    return true;
  };
  double volume = 0;
  m.closed = closed_range(0, m.triangle_count(), volume);
  m.outward = volume >= 0;
  for (TriangleMesh::SubMesh& s : m.submeshes) {
    double v = 0;
    s.closed = m.closed || closed_range(s.first_triangle, s.first_triangle + s.triangle_count, v);
    s.outward = m.closed ? m.outward : v >= 0;
  }
}

TriangleMesh tessellate(const Shape& s, int seg) {
  seg = std::max(seg, 3);
  TriangleMesh m;
  switch (s.type) {
    case ShapeType::Box:
      box_into(m, s.box);
      m.source = "box";
      break;
    case ShapeType::Sphere: {
      std::vector<Eigen::Vector4d> prof;
      const int lat = std::max(2, seg / 2);
      for (int k = 0; k <= lat; ++k) {
        const double th = -M_PI / 2 + M_PI * k / lat;
        const double c = k == 0 || k == lat ? 0.0 : std::cos(th);
        prof.emplace_back(s.radius * c, s.radius * std::sin(th), c, std::sin(th));
      }
      revolve(m, prof, seg);
      m.source = "sphere";
      break;
    }
    case ShapeType::Cylinder: {
      const double h = 0.5 * s.length;
      revolve(m, {{s.radius, -h, 1, 0}, {s.radius, h, 1, 0}}, seg);
      disc(m, s.radius, -h, false, seg);
      disc(m, s.radius, h, true, seg);
      m.source = "cylinder";
      break;
    }
    case ShapeType::Capsule: {
      const double h = 0.5 * s.length;
      std::vector<Eigen::Vector4d> prof;
      const int q = std::max(2, seg / 4);  // rings on each quarter circle
      for (int k = 0; k <= q; ++k) {       // bottom cap, pole first
        const double th = -M_PI / 2 + (M_PI / 2) * k / q;
        const double c = k == 0 ? 0.0 : std::cos(th);
        prof.emplace_back(s.radius * c, -h + s.radius * std::sin(th), c, std::sin(th));
      }
      for (int k = 0; k <= q; ++k) {  // top cap, equator first
        const double th = (M_PI / 2) * k / q;
        const double c = k == q ? 0.0 : std::cos(th);
        prof.emplace_back(s.radius * c, h + s.radius * std::sin(th), c, std::sin(th));
      }
      revolve(m, prof, seg);
      m.source = "capsule";
      break;
    }
    case ShapeType::Mesh: {
      if (!s.mesh) break;
      m = *s.mesh;
      const Vec3f sc = s.scale.cast<float>();
      for (Vec3f& p : m.positions) p = p.cwiseProduct(sc);
      // Normals by the inverse transpose of diag(scale).
      for (Vec3f& n : m.normals) {
        Vec3f t = n.cwiseQuotient(sc);
        const float len = t.norm();
        n = len > 0 && std::isfinite(len) ? Vec3f(t / len) : Vec3f(0, 0, 1);
      }
      if (sc.prod() < 0) {
        for (std::size_t t = 0; t + 2 < m.indices.size(); t += 3) {
          std::swap(m.indices[t + 1], m.indices[t + 2]);
        }
      }
      break;
    }
  }
  finish_mesh(m);
  return m;
}

TriangleMesh cone_mesh(int seg) {
  seg = std::max(seg, 3);
  TriangleMesh m;
  // Side: normals of the cone (slope of radius 0.5 over height 1).
  const double nr = 1.0, nz = 0.5;
  revolve(m, {{0.5, 0.0, nr, nz}, {0.0, 1.0, nr, nz}}, seg);
  disc(m, 0.5, 0.0, false, seg);
  finish_mesh(m);
  m.source = "cone";
  return m;
}

std::size_t GeometryModel::visual_mesh_triangles() const {
  std::size_t n = 0;
  for (const GeometryObject& o : visuals) {
    if (o.shape.type == ShapeType::Mesh && o.shape.mesh) n += o.shape.mesh->triangle_count();
  }
  return n;
}

GeometryModel chain_geometry(const Model& chain) {
  GeometryModel g;
  const double L = chain.n >= 1 ? chain.X_tree[1].p.norm() : 0.3;
  const double w = 0.04;
  for (int i = 0; i <= chain.n; ++i) {
    GeometryObject o;
    o.link = i < int(chain.body_name.size()) ? chain.body_name[i] : "body" + std::to_string(i);
    o.name = o.link + "_0";
    o.body = i;
    o.placement = SE3(Mat3::Identity(), Vec3(0.5 * L, 0, 0));
    o.shape = make_box(Vec3(L, w, w));
    g.visuals.push_back(o);
  }
  return g;
}

}  // namespace se3
