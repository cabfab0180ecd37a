// The ground of a scene and the robot on it: how low the robot's collision shapes reach, where
// a base goes so that they touch the ground (the generic scene, as Gazebo's empty world holds a
// spawned robot), and the warning for a ground the robot's shapes do not touch.
#pragma once

#include <string>

#include "se3_sim/dynamics/dynamics.h"
#include "se3_sim/geometry/geometry.h"
#include "se3_sim/sim/sim.h"

namespace se3 {

/// The least n . p over the points p of `geometry`'s robot collision shapes at state x (boxes,
/// spheres, cylinders and capsules exactly; meshes by their scaled vertices; a mesh without
/// triangles is skipped), n a unit vector. +infinity when there is no such shape.
double lowest_collision_point(const Model& model, const GeometryModel& geometry, const State& x,
                              const Vec3& n);

/// The base pose that puts the lowest collision point of the robot at state x on the scene's
/// ground plane (x.base moved along the ground's normal); x.base when the scene does not ask for
/// it (Scene::place_on_ground and a ground), says where the base goes (base_pose), or the robot
/// has no collision shape. geometry: the robot's (scene_robot_geometry), else loaded here from
/// urdf_xml as scene_geometry does.
SE3 base_on_ground(const Scene& scene, const Model& model, const State& x,
                   const std::string& urdf_xml = "", const GeometryModel* geometry = nullptr);
/// Whether base_on_ground moves the base for this scene (robot_on_ground, a ground, no base_pose).
bool places_on_ground(const Scene& scene);

/// One line when the scene has a ground that holds no part of its robot (neither the robot's
/// collision shapes, ground: {from_collisions: true}, nor contacts: points), naming the scene
/// and the keys to set; "" otherwise (or without a robot).
std::string ground_ignores_robot_warning(const Scene& scene, bool has_robot);

}  // namespace se3
