// Ray casts against the collision layer's shapes, and the laser scanner built on them.
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "se3_sim/collision/laser.h"

namespace se3 {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// The ray's parameter interval [t0, t1] inside a convex solid; each clip narrows it.
struct Span {
  double t0 = -kInfinity, t1 = kInfinity;
  bool empty() const { return !(t0 <= t1); }
  /// Keeps the t with a + t b <= 0 (a half-space along the ray).
  void clip(double a, double b) {
    if (b == 0) {
      if (a > 0) t1 = -kInfinity;
    } else if (b > 0) {
      t1 = std::min(t1, -a / b);
    } else {
      t0 = std::max(t0, -a / b);
    }
  }
};

// Entry distance of a span: +Inf when missed, behind the origin, or the origin is inside.
double entry(const Span& s) {
  if (s.empty() || s.t1 < 0 || s.t0 < 0) return kInfinity;
  return s.t0;
}

Span box_span(const Vec3& half, const Vec3& o, const Vec3& d) {
  Span s;
  for (int k = 0; k < 3; ++k) {
    s.clip(o[k] - half[k], d[k]);
    s.clip(-o[k] - half[k], -d[k]);
  }
  return s;
}

Span sphere_span(double r, const Vec3& o, const Vec3& d) {
  // |o + t d|^2 = r^2, d unit.
  const double b = o.dot(d), c = o.squaredNorm() - r * r;
  const double disc = b * b - c;
  Span s;
  if (disc < 0) {
    s.t0 = kInfinity;
    return s;
  }
  const double q = std::sqrt(disc);
  s.t0 = -b - q;
  s.t1 = -b + q;
  return s;
}

// Finite cylinder about z, |z| <= h.
Span cylinder_span(double r, double h, const Vec3& o, const Vec3& d) {
  Span s;
  const double a = d.x() * d.x() + d.y() * d.y();
  const double b = o.x() * d.x() + o.y() * d.y();
  const double c = o.x() * o.x() + o.y() * o.y() - r * r;
  if (a < 1e-300) {
    if (c > 0) s.t0 = kInfinity;
  } else {
    const double disc = b * b - a * c;
    if (disc < 0) {
      s.t0 = kInfinity;
      return s;
    }
    const double q = std::sqrt(disc);
    s.t0 = (-b - q) / a;
    s.t1 = (-b + q) / a;
  }
  s.clip(o.z() - h, d.z());
  s.clip(-o.z() - h, -d.z());
  return s;
}

double local_distance(const CollisionObject& obj, const Vec3* normals, const double* offsets,
                      std::size_t planes, const Vec3& o, const Vec3& d) {
  if (obj.halfspace) {
    if (o.z() <= 0 || d.z() >= 0) return kInfinity;
    return -o.z() / d.z();
  }
  const Shape& sh = obj.shape;
  switch (sh.type) {
    case ShapeType::Box:
      return entry(box_span(0.5 * sh.box, o, d));
    case ShapeType::Sphere:
      return entry(sphere_span(sh.radius, o, d));
    case ShapeType::Cylinder:
      return entry(cylinder_span(sh.radius, 0.5 * sh.length, o, d));
    case ShapeType::Capsule: {
      const double h = 0.5 * sh.length;
      const Span parts[3] = {cylinder_span(sh.radius, h, o, d),
                             sphere_span(sh.radius, o - Vec3(0, 0, h), d),
                             sphere_span(sh.radius, o + Vec3(0, 0, h), d)};
      double t = kInfinity;
      for (const Span& s : parts) {
        if (!s.empty() && s.t0 < 0 && s.t1 >= 0) return kInfinity;  // the origin is inside
        t = std::min(t, entry(s));
      }
      return t;
    }
    case ShapeType::Mesh: {
      if (planes == 0) return kInfinity;
      Span s;
      for (std::size_t k = 0; k < planes && !s.empty(); ++k) {
        s.clip(normals[k].dot(o) - offsets[k], normals[k].dot(d));
      }
      return entry(s);
    }
  }
  return kInfinity;
}

void hull_planes(const ConvexHull& hull, std::vector<Vec3>& normals, std::vector<double>& offsets) {
  normals.clear();
  offsets.clear();
  for (const auto& t : hull.triangles) {
    const Vec3& a = hull.vertices[t[0]];
    Vec3 n = (hull.vertices[t[1]] - a).cross(hull.vertices[t[2]] - a);
    const double len = n.norm();
    if (!(len > 0)) continue;
    n /= len;
    normals.push_back(n);
    offsets.push_back(n.dot(a));
  }
}

double bounding_radius(const CollisionObject& obj, const ConvexHull* hull) {
  const Shape& sh = obj.shape;
  switch (sh.type) {
    case ShapeType::Box:
      return 0.5 * sh.box.norm();
    case ShapeType::Sphere:
      return sh.radius;
    case ShapeType::Cylinder:
      return std::hypot(sh.radius, 0.5 * sh.length);
    case ShapeType::Capsule:
      return sh.radius + 0.5 * sh.length;
    case ShapeType::Mesh: {
      double r = 0;
      if (hull) {
        for (const Vec3& v : hull->vertices) r = std::max(r, v.norm());
      }
      return r;
    }
  }
  return kInfinity;
}

}  // namespace

bool check_laser_spec(const LaserSpec& s, std::string* error) {
  auto fail = [&](const std::string& why) {
    if (error) *error = why;
    return false;
  };
  if (s.samples < 1 || s.samples > 100000) return fail("samples must be in [1, 100000]");
  if (!std::isfinite(s.angle_min) || !std::isfinite(s.angle_max) || s.angle_min > s.angle_max ||
      s.angle_min < -2 * M_PI || s.angle_max > 2 * M_PI) {
    return fail("min_angle <= max_angle must hold, both within [-2 pi, 2 pi] rad");
  }
  if (!(s.range_min >= 0) || !std::isfinite(s.range_min)) return fail("range min must be >= 0 (m)");
  if (!(s.range_max > s.range_min) || !std::isfinite(s.range_max)) {
    return fail("range max must be finite and > range min");
  }
  if (!(s.resolution >= 0) || !std::isfinite(s.resolution)) {
    return fail("range resolution must be >= 0 (m)");
  }
  return true;
}

double ray_distance(const CollisionObject& obj, const ConvexHull* hull, const SE3& oMs,
                    const Vec3& o, const Vec3& d) {
  std::vector<Vec3> normals;
  std::vector<double> offsets;
  if (obj.shape.type == ShapeType::Mesh && hull) hull_planes(*hull, normals, offsets);
  const Vec3 ol = oMs.R.transpose() * (o - oMs.p), dl = oMs.R.transpose() * d;
  return local_distance(obj, normals.data(), offsets.data(), normals.size(), ol, dl);
}

LaserScanner::LaserScanner(const CollisionModel& model, const LaserSpec& spec)
    : model_(&model), spec_(spec) {
  const auto& objects = model.objects();
  for (int i = 0; i < int(objects.size()); ++i) {
    Shape s;
    s.object = i;
    const ConvexHull* hull = model.hull(i);
    s.radius = objects[i].halfspace ? kInfinity : bounding_radius(objects[i], hull);
    if (objects[i].shape.type == ShapeType::Mesh && hull && !objects[i].halfspace) {
      hull_planes(*hull, s.normals, s.offsets);
    }
    shapes_.push_back(std::move(s));
  }
  const int n = std::max(spec_.samples, 1);
  ranges_.assign(n, float(kInfinity));
  poses_.resize(shapes_.size());
  near_.resize(shapes_.size());
  cos_.resize(n);
  sin_.resize(n);
  for (int k = 0; k < n; ++k) {
    const double a = spec_.angle_min + k * spec_.increment();
    cos_[k] = std::cos(a);
    sin_[k] = std::sin(a);
  }
}

void LaserScanner::scan(const SE3& oMs, const std::vector<SE3>& frame_poses) {
  const auto& objects = model_->objects();
  const Vec3 o = oMs.p, ex = oMs.R.col(0), ey = oMs.R.col(1), ez = oMs.R.col(2);
  // Shapes whose bounding sphere can meet a ray: it must cross the scan plane within range.
  for (std::size_t s = 0; s < shapes_.size(); ++s) {
    const CollisionObject& obj = objects[shapes_[s].object];
    const bool world = obj.frame == CollisionObject::kWorld;
    if (!world && (obj.frame < 0 || obj.frame >= int(frame_poses.size()))) {
      near_[s] = 0;
      continue;
    }
    poses_[s] = world ? obj.placement : frame_poses[obj.frame] * obj.placement;
    const double r = shapes_[s].radius;
    const Vec3 c = poses_[s].p - o;
    near_[s] = std::isinf(r) || (std::abs(c.dot(ez)) <= r && c.norm() <= spec_.range_max + r);
  }
  const double res = spec_.resolution;
  for (int k = 0; k < int(ranges_.size()); ++k) {
    const Vec3 d = cos_[k] * ex + sin_[k] * ey;
    double best = kInfinity;
    for (std::size_t s = 0; s < shapes_.size(); ++s) {
      if (!near_[s]) continue;
      const Shape& sh = shapes_[s];
      const SE3& P = poses_[s];
      const Vec3 c = P.p - o;
      if (!std::isinf(sh.radius)) {
        // Ray against the bounding sphere: skip when it passes wide or lies behind.
        const double along = c.dot(d);
        if (along < -sh.radius || (c - along * d).squaredNorm() > sh.radius * sh.radius) continue;
        if (along - sh.radius > best) continue;
      }
      const Vec3 ol = -(P.R.transpose() * c), dl = P.R.transpose() * d;
      const double t = local_distance(objects[sh.object], sh.normals.data(), sh.offsets.data(),
                                      sh.normals.size(), ol, dl);
      best = std::min(best, t);
    }
    double r;
    if (!(best <= spec_.range_max)) {
      r = kInfinity;
    } else if (best < spec_.range_min) {
      r = -kInfinity;
    } else {
      r = res > 0 ? std::round(best / res) * res : best;
    }
    ranges_[k] = float(r);
  }
}

}  // namespace se3
