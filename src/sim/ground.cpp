// The robot on the scene's ground (ground.h).
#include "se3_sim/sim/ground.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "se3_sim/sim/scene_collision.h"

namespace se3 {
namespace {

// The least n . p over the points p of a shape placed at T (world).
double lowest_point(const Shape& s, const SE3& T, const Vec3& n) {
  const Vec3 nl = T.R.transpose() * n;  // n in the shape frame
  const double c = n.dot(T.p);
  switch (s.type) {
    case ShapeType::Box:
      return c - 0.5 * (std::abs(nl.x()) * s.box.x() + std::abs(nl.y()) * s.box.y() +
                        std::abs(nl.z()) * s.box.z());
    case ShapeType::Sphere:
      return c - s.radius;
    case ShapeType::Cylinder: {
      const double a = std::min(1.0, std::abs(nl.z()));
      return c - 0.5 * s.length * a - s.radius * std::sqrt(std::max(0.0, 1 - a * a));
    }
    case ShapeType::Capsule:
      return c - 0.5 * s.length * std::abs(nl.z()) - s.radius;
    case ShapeType::Mesh: {
      double low = std::numeric_limits<double>::infinity();
      if (!s.mesh) return low;
      for (const Vec3f& v : s.mesh->positions) {
        low = std::min(low, nl.dot(s.scale.cwiseProduct(v.cast<double>())));
      }
      return c + low;
    }
  }
  return std::numeric_limits<double>::infinity();
}

}  // namespace

double lowest_collision_point(const Model& model, const GeometryModel& geometry, const State& x,
                              const Vec3& n) {
  Data data(model);
  forward_kinematics(model, data, x.base, x.q);
  double low = std::numeric_limits<double>::infinity();
  for (const GeometryObject& g : geometry.collisions) {
    if (g.body < 0 || g.body > model.n) continue;  // world geometry: not the robot's
    low = std::min(low, lowest_point(g.shape, data.oMb[g.body] * g.placement, n));
  }
  return low;
}

bool places_on_ground(const Scene& scene) {
  return scene.robot_on_ground && scene.constraints.ground && !scene.base_pose_given;
}

SE3 base_on_ground(const Scene& scene, const Model& model, const State& x,
                   const std::string& urdf_xml, const GeometryModel* geometry) {
  const ConstraintSpec& c = scene.constraints;
  if (!places_on_ground(scene)) return x.base;
  if (urdf_xml.empty() && scene.robot_path.empty()) return x.base;
  const Vec3 n = c.ground_normal.normalized();
  const double low = lowest_collision_point(
      model, geometry ? *geometry : scene_robot_geometry(scene, model, urdf_xml), x, n);
  if (!std::isfinite(low)) return x.base;
  SE3 base = x.base;
  base.p += (c.ground_offset - low) * n;
  return base;
}

std::string ground_ignores_robot_warning(const Scene& scene, bool has_robot) {
  const ConstraintSpec& c = scene.constraints;
  if (!has_robot || !c.ground || c.contacts_from_collisions || !c.contacts.empty()) return "";
  return (scene.file.empty() ? std::string("the scene") : scene.file) +
         ": the ground holds no part of the robot (its collision shapes are used with ground: "
         "{from_collisions: true}, points with contacts:); the robot passes through it";
}

}  // namespace se3
