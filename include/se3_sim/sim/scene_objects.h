// Scene objects (the `objects:` key of a scene, docs/design.md): rigid bodies beside the robot,
// free (with a mass: a free-floating body of its own) or static (fixed in the world). Parsed by
// the sim layer's scene reader; simulated as one single-body free-floating system each; their
// shapes touch through the collision layer.
#pragma once

#include <string>
#include <vector>

#include "se3_sim/geometry/geometry.h"
#include "se3_sim/lie/lie.h"

namespace se3 {

struct SceneObject {
  std::string name;       ///< unique in the scene; also its TF frame and marker name
  Shape shape;            ///< box, sphere, cylinder, capsule (axis z, as URDF), mesh
  bool is_static = true;  ///< no `mass` key: fixed in the world
  double mass = 0;        ///< kg (free objects, > 0)
  /// Spatial inertia about the object's frame origin, which is the shape's centre (eq. 23);
  /// from `inertia` (about the centre) or the shape's uniform density.
  Inertia inertia;
  SE3 pose;                   ///< the object's frame (the shape's centre) in the world
  Vec6 twist = Vec6::Zero();  ///< body frame [w; v], initial
  double mu = 0.8;
  double restitution = 0;
  Material material;  ///< `color`
  int line = 0;       ///< line in the scene file (for errors)
};

/// Rotational inertia about the centre of a uniform solid `shape` of `mass`: box, sphere,
/// cylinder and capsule (axis z) exactly; a mesh as its scaled axis-aligned bounding box (the
/// scene reader gives mesh objects their convex hull's inertia instead, collision.h).
Mat3 uniform_density_inertia(const Shape& shape, double mass);

}  // namespace se3
