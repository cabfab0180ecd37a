// Convex hulls of meshes (collision.h), by qhull (libqhull_r, Debian's libqhull-dev), and the
// mass properties of a hull as a uniform solid.
extern "C" {
#include <libqhull_r/qhull_ra.h>
}

#include <cstdio>
#include <stdexcept>

#include "se3_sim/collision/collision.h"

namespace se3 {
namespace {

// Volume, centroid and inertia (about the centroid) of a closed, outward-wound triangle surface
// as a solid of density 1: the sum over tetrahedra (origin, a, b, c) of their signed moments.
void mass_properties(ConvexHull& h) {
  double vol = 0;
  Vec3 first = Vec3::Zero();
  Mat3 second = Mat3::Zero();  // integral of x x^T
  for (const auto& t : h.triangles) {
    const Vec3& a = h.vertices[t[0]];
    const Vec3& b = h.vertices[t[1]];
    const Vec3& c = h.vertices[t[2]];
    const double v = a.dot(b.cross(c)) / 6;  // signed tetrahedron volume
    vol += v;
    first += v * (a + b + c) / 4;
    // integral over the tetrahedron of x x^T = v/20 (sum_i x_i x_i^T + (sum_i x_i)(sum_i x_i)^T)
    const Vec3 s = a + b + c;
    second +=
        v / 20 * (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose());
  }
  h.volume = vol;
  h.centroid = vol > 0 ? Vec3(first / vol) : Vec3::Zero();
  const Mat3 C = second - vol * h.centroid * h.centroid.transpose();  // about the centroid
  h.inertia = C.trace() * Mat3::Identity() - C;
}

}  // namespace

ConvexHull convex_hull(const TriangleMesh& mesh, const Vec3& scale, const std::string& name) {
  const std::size_t n = mesh.positions.size();
  if (n < 4) throw std::invalid_argument(name + ": a mesh needs 4 or more vertices for a hull");
  std::vector<coordT> pts(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) pts[3 * i + k] = double(mesh.positions[i][k]) * scale[k];
  }
  qhT qh_qh;
  qhT* qh = &qh_qh;
  FILE* err = std::fopen("/dev/null", "w");
  qh_zero(qh, err);
  char options[] = "qhull Qt";  // triangulated output
  const int code = qh_new_qhull(qh, 3, int(n), pts.data(), False, options, nullptr, err);
  ConvexHull h;
  if (code == 0) {
    std::vector<int> index(n, -1);
    facetT* facet;
    FORALLfacets {
      if (facet->upperdelaunay) continue;
      std::array<int, 3> tri{};
      int k = 0;
      vertexT* vertex;
      vertexT** vertexp;
      FOREACHvertex_(facet->vertices) {
        if (k == 3) break;
        const int id = qh_pointid(qh, vertex->point);
        if (index[id] < 0) {
          index[id] = int(h.vertices.size());
          h.vertices.push_back(Vec3(pts[3 * id], pts[3 * id + 1], pts[3 * id + 2]));
        }
        tri[k++] = index[id];
      }
      if (k != 3) continue;
      // Wind counter-clockwise seen from outside (along the facet's outward normal).
      const Vec3 nrm(facet->normal[0], facet->normal[1], facet->normal[2]);
      const Vec3& a = h.vertices[tri[0]];
      if ((h.vertices[tri[1]] - a).cross(h.vertices[tri[2]] - a).dot(nrm) < 0) {
        std::swap(tri[1], tri[2]);
      }
      h.triangles.push_back(tri);
    }
  }
  qh_freeqhull(qh, !qh_ALL);
  int curlong, totlong;
  qh_memfreeshort(qh, &curlong, &totlong);
  std::fclose(err);
  if (code != 0 || h.triangles.size() < 4) {
    throw std::invalid_argument(name + ": no convex hull (the mesh '" + mesh.source +
                                "' is flat or degenerate)");
  }
  mass_properties(h);
  return h;
}

}  // namespace se3
