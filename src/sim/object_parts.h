// What the Simulator's scene objects (simulator.cpp) and the objects spawned at run time
// (world.cpp) share: a shape's smallest extent and an object's collision object.
#pragma once

#include <algorithm>
#include <limits>

#include "se3_sim/collision/collision.h"
#include "se3_sim/geometry/geometry.h"
#include "se3_sim/sim/scene_objects.h"

namespace se3 {

/// The smallest extent of a shape (m): what a body may move in one step before it can pass
/// through something as thin as itself unseen (the tunnelling warning).
inline double smallest_extent(const Shape& s) {
  switch (s.type) {
    case ShapeType::Box:
      return s.box.minCoeff();
    case ShapeType::Sphere:
    case ShapeType::Capsule:
      return 2 * s.radius;
    case ShapeType::Cylinder:
      return std::min(2 * s.radius, s.length);
    case ShapeType::Mesh:
      break;
  }
  if (!s.mesh || s.mesh->positions.empty()) return 0;
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const Vec3f& p : s.mesh->positions) {
    const Vec3 q = p.cast<double>().cwiseProduct(s.scale);
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  return (hi - lo).cwiseAbs().minCoeff();
}

/// The collision object of scene object o: static ones placed in the world, free ones on their
/// body's frame.
inline CollisionObject object_collider(const SceneObject& o, int frame) {
  CollisionObject c;
  c.name = o.name;
  c.shape = o.shape;
  c.group = 1;
  c.mu = o.mu;
  c.restitution = o.restitution;
  if (o.is_static) {
    c.frame = CollisionObject::kWorld;
    c.placement = o.pose;
  } else {
    c.frame = frame;
  }
  return c;
}

}  // namespace se3
