// A robot's shapes in a scene collision beside robot 0 (scene_collision.h): the scene's robots
// 1.. (scene_collision.cpp) and robots spawned at run time (world.cpp) take them the same way.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "se3_sim/collision/collision.h"
#include "se3_sim/geometry/geometry.h"
#include "se3_sim/model/gazebo_tags.h"
#include "se3_sim/model/model.h"

namespace se3 {

/// How a robot joins a scene collision: its model name (its shapes and links are "NAME/..."),
/// its first frame (body i on frame first + i), its group (>= 2, one a robot), whether its links
/// collide with each other, its SRDF's disabled link pairs (names the model has), the friction
/// of its shapes and the scene's step (a Gazebo kp/kd as an error reduction).
struct RobotCollisionSpec {
  std::string name;
  int first = 0;
  int group = 2;
  bool self_collision = false;
  std::vector<std::pair<std::string, std::string>> disabled_links;
  double mu = 0.8;
  double dt = 1e-3;
};

/// Appends robot m's collision shapes (geometry g, meshes loaded; its <gazebo> surface tags gz)
/// to objects, and its joints' adjacency, a fixed base's immunity to the world's static
/// geometry, its self-collision and its SRDF pairs to options. Throws std::invalid_argument
/// ("robot 'NAME': link ...") for a mesh that did not load.
void append_robot_collision(const Model& m, const GeometryModel& g, const GazeboTags& gz,
                            const RobotCollisionSpec& spec, std::vector<CollisionObject>& objects,
                            CollisionOptions& options);

}  // namespace se3
