// What the simulator's laser scanners (laser.h) cast their rays against: the collision layer's
// objects for the robot's collision shapes, the world's objects (the scene's and the spawned
// ones) and the ground.
#pragma once

#include <vector>

#include "se3_sim/collision/collision.h"
#include "se3_sim/geometry/geometry.h"
#include "se3_sim/sim/scene_objects.h"
#include "se3_sim/solver/constraints.h"

namespace se3 {

/// The robot's collision shapes (stand-ins left out) on their bodies, object j of `objects`
/// (Simulator::object_specs()) on frame nbodies + j (its pose in Simulator::objects()), and
/// the ground half-space when `ground` has one. Frames as Simulator::body_poses(), then the
/// objects.
std::vector<CollisionObject> laser_world(const GeometryModel& geometry, int nbodies,
                                         const std::vector<SceneObject>& objects,
                                         const ConstraintSpec& ground);

}  // namespace se3
