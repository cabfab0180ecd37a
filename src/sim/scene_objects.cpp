// The scene's `objects:` key (scene_objects.h) and the collision keys beside it (`srdf:`,
// `self_collision:`, `contact:`), read through the SceneReader:
//   objects:
//     - name: box1
//       shape: {box: [0.2, 0.2, 0.2]}       # or {sphere: r}, {cylinder: [r, l]},
//                                           #    {capsule: [r, l]}, {mesh: PATH, scale: [..]}
//       mass: 1.0                            # absent: static (fixed in the world)
//       inertia: [ixx, iyy, izz]             # or six values, or a 3x3 list; about the centre
//       pose: {position: [0, 0, 0.1], orientation: [0, 0, 0, 1]}
//       twist: [0, 0, 0, 0, 0, 0]            # body frame [w; v]
//       mu: 0.8
//       restitution: 0
//       color: [0.8, 0.2, 0.2]               # or [r, g, b, a], in [0, 1]
//   srdf: data/robots/panda.srdf             # relative to the scene file
//   self_collision: false
//   contact: {margin: 0.01, max_contacts_per_pair: 4, ground_per_body: true}
// The default inertia is that of the shape at uniform density; a mesh's is that of its convex
// hull (the shape it collides as), about the hull's centroid.
#include <sys/stat.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <unordered_set>

#include "scene_objects_reader.h"
#include "se3_sim/collision/collision.h"

namespace se3 {
namespace {

using Field = SceneReader::Field;

bool regular_file(const std::string& p) {
  struct stat st;
  return ::stat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

// Rotational inertia about the centre of a uniform solid of mass m.
Mat3 shape_inertia(const Shape& s, double m) {
  Vec3 d = Vec3::Zero();
  switch (s.type) {
    case ShapeType::Box:
      d = m / 12 *
          Vec3(s.box.y() * s.box.y() + s.box.z() * s.box.z(),
               s.box.x() * s.box.x() + s.box.z() * s.box.z(),
               s.box.x() * s.box.x() + s.box.y() * s.box.y());
      break;
    case ShapeType::Sphere:
      d.setConstant(0.4 * m * s.radius * s.radius);
      break;
    case ShapeType::Cylinder: {
      const double r2 = s.radius * s.radius, l2 = s.length * s.length;
      d = Vec3(m * (3 * r2 + l2) / 12, m * (3 * r2 + l2) / 12, m * r2 / 2);
      break;
    }
    case ShapeType::Capsule: {
      // The cylinder and the two hemispherical caps share the mass by volume; each cap's
      // inertia about the capsule's centre by the parallel-axis theorem from its own centroid.
      const double r = s.radius, l = s.length;
      const double vc = M_PI * r * r * l, vs = 4.0 / 3.0 * M_PI * r * r * r;
      const double mc = m * vc / (vc + vs), ms = m * vs / (vc + vs);
      const double ixx =
          mc * (l * l / 12 + r * r / 4) + ms * (0.4 * r * r + l * l / 4 + 3 * l * r / 8);
      d = Vec3(ixx, ixx, mc * r * r / 2 + ms * 0.4 * r * r);
      break;
    }
    case ShapeType::Mesh: {
      Vec3 e = Vec3::Zero();
      if (s.mesh)
        e = (s.mesh->upper - s.mesh->lower).cast<double>().cwiseProduct(s.scale).cwiseAbs();
      d = m / 12 *
          Vec3(e.y() * e.y() + e.z() * e.z(), e.x() * e.x() + e.z() * e.z(),
               e.x() * e.x() + e.y() * e.y());
      break;
    }
  }
  return d.asDiagonal();
}

Shape read_shape(const SceneReader& r, const Field& v, const std::string& base_dir) {
  const std::vector<Field> fs =
      r.fields(v, {"box", "sphere", "cylinder", "capsule", "mesh", "scale"});
  const Field* kind = nullptr;
  const Field* scale = nullptr;
  for (const Field& f : fs) {
    if (f.name == "scale") {
      scale = &f;
    } else if (kind) {
      r.fail(f, "'" + v.key + "' has two shapes (" + kind->name + ", " + f.name + ")");
    } else {
      kind = &f;
    }
  }
  if (!kind) {
    r.fail(v, "'" + v.key + "' needs one of box, sphere, cylinder, capsule, mesh");
  }
  if (scale && kind->name != "mesh") r.fail(*scale, "'" + scale->key + "' is for meshes only");
  const std::string& k = kind->name;
  auto pos = [&](double x, const char* what) {
    if (!(x > 0)) r.fail(*kind, "'" + kind->key + "' needs a positive " + what);
  };
  if (k == "box") {
    const Vec3 e = r.vec3(*kind);
    if (!(e.minCoeff() > 0)) r.fail(*kind, "'" + kind->key + "' needs three positive extents");
    return make_box(e);
  }
  if (k == "sphere") {
    const double rad = r.number(*kind);
    pos(rad, "radius");
    return make_sphere(rad);
  }
  if (k == "cylinder" || k == "capsule") {
    const auto rl = r.numbers(*kind, 2, 2);
    pos(rl[0], "radius");
    pos(rl[1], "length");
    return k == "cylinder" ? make_cylinder(rl[0], rl[1]) : make_capsule(rl[0], rl[1]);
  }
  // mesh
  std::string uri = r.text(*kind);
  if (uri.compare(0, 7, "$(find ") == 0) {  // as package:// (scene_reader.h)
    std::string file, error;
    scene_ros_reference(uri, base_dir, &file, &error);
    if (file.empty()) r.fail(*kind, "'" + kind->key + "': " + error);
    uri = file;
  }
  Vec3 sc = Vec3::Ones();
  if (scale) {
    sc = r.vec3(*scale);
    if (!(sc.minCoeff() > 0)) r.fail(*scale, "'" + scale->key + "' needs three positive factors");
  }
  ResourcePaths paths;
  paths.base_dir = base_dir;
  const ResourceResolver resolver = [paths](const std::string& u, std::string* err) {
    return resolve_resource(u, paths, err);
  };
  Shape s;
  std::string err;
  if (!load_mesh_shape(uri, sc, resolver, s, &err)) {
    r.fail(*kind, "'" + kind->key + "': " + err);
  }
  return s;
}

SceneObject read_object(const SceneReader& r, const Field& item, const std::string& base_dir,
                        const std::string& default_name = "") {
  SceneObject o;
  o.line = item.line;
  bool has_shape = false;
  const Field* inertia = nullptr;
  const Field* twist = nullptr;
  const std::vector<Field> fs = r.fields(
      item, {"name", "shape", "mass", "inertia", "pose", "twist", "mu", "restitution", "color"});
  for (const Field& f : fs) {
    if (f.name == "name") {
      o.name = r.text(f);
      for (char c : o.name) {
        if (std::isspace(static_cast<unsigned char>(c)) || c == '/' || c == '#') {
          r.fail(f,
                 "'" + f.key + "' '" + o.name + "' is not a TF frame name (no spaces, '/' or '#')");
        }
      }
    } else if (f.name == "shape") {
      o.shape = read_shape(r, f, base_dir);
      has_shape = true;
    } else if (f.name == "mass") {
      o.mass = r.number(f);
      if (!(o.mass > 0)) r.fail(f, "'" + f.key + "' must be positive (no mass: a static object)");
      o.is_static = false;
    } else if (f.name == "inertia") {
      inertia = &f;
    } else if (f.name == "pose") {
      for (const Field& p : r.fields(f, {"position", "orientation"})) {
        if (p.name == "position") {
          o.pose.p = r.vec3(p);
        } else {
          const auto q = r.numbers(p, 4, 4);
          const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
          if (std::abs(n - 1) > 1e-3) {
            r.fail(p, "'" + p.key + "' (x, y, z, w) is not a unit quaternion (norm " +
                          std::to_string(n) + ")");
          }
          o.pose.R = rotation_from_quaternion(q[0] / n, q[1] / n, q[2] / n, q[3] / n);
        }
      }
    } else if (f.name == "twist") {
      const auto t = r.numbers(f, 6, 6);
      for (int i = 0; i < 6; ++i) o.twist[i] = t[i];
      twist = &f;
    } else if (f.name == "mu") {
      o.mu = r.non_negative(f);
    } else if (f.name == "restitution") {
      o.restitution = r.in_range(f, 0, 1);
    } else if (f.name == "color") {
      const auto c = r.numbers(f, 3, 4);
      for (double x : c) {
        if (!(x >= 0 && x <= 1)) r.fail(f, "'" + f.key + "' needs values in [0, 1]");
      }
      o.material.rgba =
          Vec4f(float(c[0]), float(c[1]), float(c[2]), c.size() == 4 ? float(c[3]) : 1.f);
      o.material.has_color = true;
    }
  }
  if (o.name.empty()) o.name = default_name;
  if (o.name.empty()) r.fail(item, "'" + item.key + "' needs a name");
  if (!has_shape) r.fail(item, "'" + item.key + "' (" + o.name + ") needs a shape");
  o.material.name = o.name;
  if (o.is_static) {
    if (inertia) r.fail(*inertia, "'" + inertia->key + "' needs a mass (a static object has none)");
    if (twist && !o.twist.isZero()) {
      r.fail(*twist, "'" + twist->key + "' needs a mass (a static object does not move)");
    }
  } else {
    if (inertia) {
      o.inertia = Inertia::from_com(o.mass, Vec3::Zero(), read_inertia(r, *inertia));
    } else if (o.shape.type == ShapeType::Mesh) {
      // The convex hull as a uniform solid (the shape it collides as): its centroid may lie
      // off the mesh's origin, the object's frame.
      try {
        const ConvexHull h = convex_hull(*o.shape.mesh, o.shape.scale, o.name);
        o.inertia = Inertia::from_com(o.mass, h.centroid, h.inertia * (o.mass / h.volume));
      } catch (const std::invalid_argument& e) {
        r.fail(item, "'" + item.key + "': " + e.what());
      }
    } else {
      o.inertia = Inertia::from_com(o.mass, Vec3::Zero(), shape_inertia(o.shape, o.mass));
    }
    // A free body needs a spatial inertia it can be accelerated by: positive definite, with a
    // finite inverse (a 1e-300 m box or a 1e-300 kg mass underflow to a singular one).
    const Mat6 M = o.inertia.matrix();
    const Eigen::LLT<Mat6> llt(M);
    if (!M.allFinite() || llt.info() != Eigen::Success || !M.inverse().allFinite()) {
      char buf[120];
      std::snprintf(buf, sizeof buf, "mass %g kg, rotational inertia %g to %g kg m^2", o.mass,
                    o.inertia.I.diagonal().minCoeff(), o.inertia.I.diagonal().maxCoeff());
      r.fail(item, "'" + item.key + "' (object '" + o.name + "'): " + buf +
                       ": a free object needs an inertia that is positive definite and "
                       "invertible in double precision (check the shape's size and the mass)");
    }
  }
  return o;
}

}  // namespace

SceneObject read_scene_object(const SceneReader& r, const Field& v, const std::string& base_dir,
                              const std::string& default_name) {
  return read_object(r, v, base_dir, default_name);
}

void read_scene_objects(const SceneReader& r, const Field& v, const std::string& base_dir,
                        std::vector<SceneObject>& out) {
  out.clear();
  std::unordered_set<std::string> names;
  for (const Field& item : r.items(v, 100000, true)) {
    SceneObject o = read_object(r, item, base_dir);
    if (!names.insert(o.name).second) {
      r.fail(item, "'" + item.key + "': duplicate object name '" + o.name + "'");
    }
    out.push_back(std::move(o));
  }
}

std::string read_scene_srdf(const SceneReader& r, const Field& v, const std::string& base_dir) {
  const std::string p = r.text(v);
  std::string ros_file, ros_error;
  if (scene_ros_reference(p, base_dir, &ros_file, &ros_error)) {
    if (ros_file.empty()) r.fail(v, "'srdf' '" + p + "': " + ros_error);
    return ros_file;
  }
  const std::string full = p[0] == '/' ? p : base_dir + "/" + p;
  if (!regular_file(full)) r.fail(v, "'srdf' file '" + full + "' not found");
  return full;
}

Mat3 read_inertia(const SceneReader& r, const SceneReader::Field& f) {
  Mat3 M = Mat3::Zero();
  if (f.node.IsSequence() && f.node.size() == 3 && f.node[0].IsSequence()) {
    int i = 0;
    for (const Field& row : r.items(f, 3)) {
      const auto v = r.numbers(row, 3, 3);
      for (int j = 0; j < 3; ++j) M(i, j) = v[j];
      ++i;
    }
    if (!(M - M.transpose()).isZero(1e-12 * (1 + M.cwiseAbs().maxCoeff()))) {
      r.fail(f, "'" + f.key + "' is not symmetric");
    }
  } else {
    const auto I = r.numbers(f, 3, 6);
    if (I.size() != 3 && I.size() != 6) {
      r.fail(f, "'" + f.key + "' needs [ixx, iyy, izz], six values or a 3x3 list");
    }
    M(0, 0) = I[0];
    M(1, 1) = I[1];
    M(2, 2) = I[2];
    if (I.size() == 6) {
      M(0, 1) = M(1, 0) = I[3];
      M(0, 2) = M(2, 0) = I[4];
      M(1, 2) = M(2, 1) = I[5];
    }
  }
  const Eigen::SelfAdjointEigenSolver<Mat3> es(M);
  const Vec3 ev = es.eigenvalues();
  if (!(ev.minCoeff() > 0) || ev[0] + ev[1] < ev[2] * (1 - 1e-9)) {
    r.fail(f, "'" + f.key + "' is not a physical inertia (positive, triangle inequality)");
  }
  return M;
}

Mat3 uniform_density_inertia(const Shape& shape, double mass) {
  return shape_inertia(shape, mass);
}

}  // namespace se3
