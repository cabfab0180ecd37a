// From geometry to what the rasterizer draws: RenderMeshes (scaled, coloured, simplified once
// with meshoptimizer where they are finer than they can show), the draw list and its framing.
#include <meshoptimizer.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <tuple>

#include "se3_sim/render/render.h"

namespace se3 {
namespace render {
namespace {

const Eigen::Vector3f kDefaultColor(0.74f, 0.76f, 0.80f);

bool finite_pose(const SE3& f) {
  return f.R.allFinite() && f.p.allFinite();
}

// Simplifies the triangles [first, first + count) of idx in place of out (appended), keeping
// sub-mesh borders so that neighbouring runs still meet.
void simplify_run(const std::vector<float>& xyz, const uint32_t* tri, std::size_t count,
                  float target_error, std::vector<uint32_t>& out) {
  std::vector<uint32_t> dst(3 * count);
  const std::size_t n =
      meshopt_simplify(dst.data(), tri, 3 * count, xyz.data(), xyz.size() / 3, 3 * sizeof(float), 0,
                       target_error, meshopt_SimplifyLockBorder, nullptr);
  out.insert(out.end(), dst.begin(), dst.begin() + long(n));
}

}  // namespace

RenderMesh make_render_mesh(const TriangleMesh& mesh, const Vec3& scale_in,
                            const Eigen::Vector3f& rgb, const DrawOptions& opt) {
  RenderMesh r;
  const std::size_t nv = mesh.positions.size();
  const Eigen::Vector3f sc = scale_in.cast<float>();
  const bool mirror = sc.prod() < 0;
  // Scaled positions (array of structures for meshoptimizer) and normals by the inverse
  // transpose of the scale.
  std::vector<float> xyz(3 * nv);
  std::vector<Eigen::Vector3f> nrm(nv);
  for (std::size_t i = 0; i < nv; ++i) {
    const Eigen::Vector3f p = mesh.positions[i].cwiseProduct(sc);
    xyz[3 * i] = p.x();
    xyz[3 * i + 1] = p.y();
    xyz[3 * i + 2] = p.z();
    const Eigen::Vector3f n0 = i < mesh.normals.size() ? mesh.normals[i] : Eigen::Vector3f(0, 0, 1);
    const Eigen::Vector3f t = n0.cwiseQuotient(sc);
    const float len = t.norm();
    nrm[i] = len > 0 && std::isfinite(len) ? Eigen::Vector3f(t / len) : Eigen::Vector3f(0, 0, 1);
  }
  // Runs: one per sub-mesh; per-vertex colours give each triangle its vertices' mean colour.
  struct Src {
    uint32_t first, count;
    Eigen::Vector3f rgb;
    bool cull, outward;
  };
  std::vector<Src> src;
  const std::size_t nt = mesh.triangle_count();
  for (const TriangleMesh::SubMesh& s : mesh.submeshes) {
    if (s.first_triangle >= nt) continue;
    const uint32_t count = uint32_t(std::min<std::size_t>(s.triangle_count, nt - s.first_triangle));
    const Eigen::Vector3f c =
        s.material.has_color ? Eigen::Vector3f(s.material.rgba.head<3>()) : rgb;
    if (mesh.colors.size() == nv) {
      for (uint32_t t = s.first_triangle; t < s.first_triangle + count; ++t) {
        Eigen::Vector3f m = Eigen::Vector3f::Zero();
        for (int k = 0; k < 3; ++k) m += mesh.colors[mesh.indices[3 * t + k]].head<3>() / 3.0f;
        if (!src.empty() && src.back().first + src.back().count == t && src.back().rgb == m &&
            src.back().cull == s.closed) {
          ++src.back().count;
        } else {
          src.push_back({t, 1, m, s.closed, s.outward});
        }
      }
    } else {
      src.push_back({s.first_triangle, count, c, s.closed, s.outward});
    }
  }
  r.source_triangles = nt;
  // Triangles, simplified run by run where asked.
  const float extent = nv ? meshopt_simplifyScale(xyz.data(), nv, 3 * sizeof(float)) : 0.0f;
  const bool simplify = opt.simplify_error > 0 && extent > 0;
  const float target = simplify ? float(opt.simplify_error / extent) : 0.0f;
  std::vector<uint32_t> idx;
  idx.reserve(3 * nt);
  for (const Src& s : src) {
    RenderMesh::Run run;
    run.first = uint32_t(idx.size() / 3);
    run.rgb = s.rgb.cwiseMax(0.0f).cwiseMin(1.0f);
    run.cull = s.cull;
    run.outward = s.outward;
    const uint32_t* tri = mesh.indices.data() + 3 * std::size_t(s.first);
    bool ok = true;
    for (std::size_t k = 0; k < 3 * std::size_t(s.count); ++k) ok = ok && tri[k] < nv;
    if (!ok) continue;  // a mesh that indexes past its vertices: its runs are left out
    if (simplify && s.count > 8) {
      simplify_run(xyz, tri, s.count, target, idx);
    } else {
      idx.insert(idx.end(), tri, tri + 3 * std::size_t(s.count));
    }
    if (mirror) {
      for (std::size_t k = 3 * std::size_t(run.first); k + 2 < idx.size(); k += 3) {
        std::swap(idx[k + 1], idx[k + 2]);
      }
    }
    run.count = uint32_t(idx.size() / 3) - run.first;
    if (run.count) r.runs.push_back(run);
  }
  // Only the vertices still used, in first-use order.
  std::vector<uint32_t> remap(nv, UINT32_MAX);
  uint32_t used = 0;
  for (uint32_t& i : idx) {
    if (remap[i] == UINT32_MAX) remap[i] = used++;
    i = remap[i];
  }
  for (auto* v : {&r.px, &r.py, &r.pz, &r.nx, &r.ny, &r.nz}) v->resize(used);
  for (std::size_t i = 0; i < nv; ++i) {
    const uint32_t j = remap[i];
    if (j == UINT32_MAX) continue;
    r.px[j] = xyz[3 * i];
    r.py[j] = xyz[3 * i + 1];
    r.pz[j] = xyz[3 * i + 2];
    r.nx[j] = nrm[i].x();
    r.ny[j] = nrm[i].y();
    r.nz[j] = nrm[i].z();
  }
  r.indices = std::move(idx);
  if (used) {
    r.lower = r.upper = Eigen::Vector3f(r.px[0], r.py[0], r.pz[0]);
    for (uint32_t j = 0; j < used; ++j) {
      const Eigen::Vector3f p(r.px[j], r.py[j], r.pz[j]);
      r.lower = r.lower.cwiseMin(p);
      r.upper = r.upper.cwiseMax(p);
    }
  }
  return r;
}

std::vector<DrawItem> make_draw_items(const Model& model, const GeometryModel& geometry,
                                      const DrawOptions& opt) {
  std::vector<DrawItem> items;
  const int nb = int(model.parent.size());
  // Visuals sharing a mesh file, scale and colour share one RenderMesh.
  std::map<std::tuple<const TriangleMesh*, double, double, double, float, float, float>,
           std::shared_ptr<const RenderMesh>>
      shared;
  for (const GeometryObject& o : geometry.visuals) {
    // Body kWorld: fixed in the world (scene objects), placement in the world.
    const bool world = o.body == GeometryObject::kWorld;
    if ((!world && (o.body < 0 || o.body >= nb)) || !finite_pose(o.placement)) continue;
    DrawItem it;
    it.body = o.body;
    it.local = o.placement;
    it.link = o.link;
    it.name = o.name;
    it.shape = o.shape.type;
    it.stand_in = o.stand_in;
    const Eigen::Vector3f rgb =
        o.material.has_color ? Eigen::Vector3f(o.material.rgba.head<3>()) : kDefaultColor;
    it.color = rgb.cast<double>();
    const Shape& s = o.shape;
    switch (s.type) {
      case ShapeType::Box:
        it.size = s.box;
        break;
      case ShapeType::Sphere:
        it.size = Vec3::Constant(2 * s.radius);
        break;
      case ShapeType::Cylinder:
      case ShapeType::Capsule:
        it.size = Vec3(2 * s.radius, 2 * s.radius, s.length);
        break;
      case ShapeType::Mesh:
        it.size = s.scale;
        break;
    }
    if (s.type == ShapeType::Mesh) {
      if (!s.mesh || !s.scale.allFinite()) continue;
      const auto key = std::make_tuple(s.mesh.get(), s.scale.x(), s.scale.y(), s.scale.z(), rgb.x(),
                                       rgb.y(), rgb.z());
      auto found = shared.find(key);
      if (found == shared.end()) {
        found =
            shared
                .emplace(key,
                         std::make_shared<RenderMesh>(make_render_mesh(*s.mesh, s.scale, rgb, opt)))
                .first;
      }
      it.mesh = found->second;
      it.mesh_scale = s.scale;
      if (s.resource.compare(0, 10, "package://") == 0 ||
          s.resource.compare(0, 7, "file://") == 0) {
        it.mesh_resource = s.resource;
      } else if (!s.path.empty()) {
        it.mesh_resource = "file://" + std::filesystem::absolute(s.path).string();
      }
      for (const auto& sub : s.mesh->submeshes)
        it.mesh_colors = it.mesh_colors || sub.material.has_color;
    } else {
      if (!s.box.allFinite() || !std::isfinite(s.radius) || !std::isfinite(s.length)) continue;
      DrawOptions plain = opt;
      plain.simplify_error = 0;
      it.mesh = std::make_shared<RenderMesh>(
          make_render_mesh(tessellate(s, opt.segments), Vec3::Ones(), rgb, plain));
    }
    if (!it.mesh || it.mesh->triangle_count() == 0) continue;
    items.push_back(std::move(it));
  }
  return items;
}

void frame_items(const std::vector<DrawItem>& items, const std::vector<SE3>& oMb, Camera& cam,
                 const std::vector<Marker>& boxes) {
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  int cnt = 0;
  auto add = [&](const Vec3& p) {
    if (!p.allFinite()) return;
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
    ++cnt;
  };
  for (const DrawItem& it : items) {
    if (!it.mesh) continue;
    const bool world = it.body == GeometryObject::kWorld;
    if (!world && (it.body < 0 || it.body >= int(oMb.size()) || !finite_pose(oMb[it.body]))) {
      continue;
    }
    const SE3 pose = world ? it.local : oMb[it.body] * it.local;
    const Eigen::Vector3d l = it.mesh->lower.cast<double>(), u = it.mesh->upper.cast<double>();
    for (int c = 0; c < 8; ++c) {
      add(pose.act(
          Vec3((c & 1) ? u.x() : l.x(), (c & 2) ? u.y() : l.y(), (c & 4) ? u.z() : l.z())));
    }
  }
  for (std::size_t i = 0; i < oMb.size(); ++i) {
    if (finite_pose(oMb[i])) add(oMb[i].p);
  }
  // The corners of box and mesh markers (solid geometry, like a body).
  for (const Marker& m : boxes) {
    if (!m.R.allFinite() || !m.a.allFinite()) continue;
    if (m.type == Marker::Type::Box && m.size3.allFinite()) {
      for (int c = 0; c < 8; ++c) {
        const Vec3 s((c & 1) ? 0.5 : -0.5, (c & 2) ? 0.5 : -0.5, (c & 4) ? 0.5 : -0.5);
        add(m.a + m.R * s.cwiseProduct(m.size3));
      }
    } else if (m.type == Marker::Type::Mesh && m.mesh && m.mesh->triangle_count()) {
      const Eigen::Vector3d l = m.mesh->lower.cast<double>(), u = m.mesh->upper.cast<double>();
      for (int c = 0; c < 8; ++c) {
        add(m.a +
            m.R * Vec3((c & 1) ? u.x() : l.x(), (c & 2) ? u.y() : l.y(), (c & 4) ? u.z() : l.z()));
      }
    }
  }
  if (!cnt) add(Vec3::Zero());
  const Vec3 center = 0.5 * (lo + hi);
  const double radius = std::max(0.5 * (hi - lo).norm(), 0.3) + 0.05;
  const double half_fov = std::atan(0.5 * std::min(cam.width, cam.height) / cam.focal_px);
  const double dist = radius / std::sin(half_fov) * 1.02;
  const double az = -55.0 * M_PI / 180.0, el = 20.0 * M_PI / 180.0;
  cam.target = center;
  cam.eye =
      center + dist * Vec3(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
  cam.up = Vec3(0, 0, 1);
  cam.update();
}

}  // namespace render
}  // namespace se3
