// The world interface of a Simulator (sim.h, docs/design.md "World interface"): the models it
// holds (the robot and the scene objects), spawning and deleting objects between steps, and the
// state of a model or a link, read and set. Shaped after ROS 2's simulation_interfaces (entities,
// entity states), which the ROS layer serves (docs/ros.md).
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "se3_sim/dynamics/dynamics.h"
#include "se3_sim/sim/scene_objects.h"

namespace se3 {

/// A refused world request (a std::invalid_argument: one line naming the field), with its kind
/// (the ROS layer's result codes follow it).
struct WorldError : std::invalid_argument {
  enum class Kind { NotFound, NameInUse, NameInvalid, InvalidPose, Invalid, Stale, Resource };
  WorldError(Kind k, const std::string& what) : std::invalid_argument(what), kind(k) {}
  Kind kind;
};

/// One model of the world (Simulator::world_models).
struct WorldModel {
  std::string name;
  std::string kind;        ///< "robot" or "object"
  std::string ns;          ///< the robot's namespace ("" for objects and the node's own robot)
  bool is_static = false;  ///< a static object (fixed in the world) or a fixed-base robot
};

/// The state of a model (Simulator::model_state / set_model_state): its root frame (the robot's
/// base link, an object's frame) in the world, its twist in world axes ([angular; linear], the
/// linear part the velocity of the frame's origin, as gazebo_ros's model states), and a robot's
/// joint positions and velocities (Model joint order 1..n; empty for objects).
struct ModelState {
  SE3 pose;
  Vec6 twist = Vec6::Zero();
  VecX q, v;
};

/// The pose and twist of a link (Simulator::link_state): in the world, or relative to another
/// link (its pose in that link's frame, its twist the derivative of that pose: angular and
/// origin velocity relative to the reference link, in the reference link's axes).
struct LinkState {
  SE3 pose;
  Vec6 twist = Vec6::Zero();
};

/// A change of the world's objects made ready off the step (Simulator::prepare_spawn,
/// prepare_delete): the new object list, the free bodies' models, the collision model and the
/// constraint system are built; Simulator::commit swaps them in between two steps. Opaque.
struct WorldEdit;
struct WorldEditDeleter {
  void operator()(WorldEdit* edit) const;
};
using WorldEditPtr = std::unique_ptr<WorldEdit, WorldEditDeleter>;

/// A robot to spawn at run time (Simulator::prepare_spawn_robot): a URDF, its model name and
/// namespace, its base pose and whether the base is free or fixed. Its joints start at 0, each
/// clamped into its position limits, at rest.
struct RobotSpawn {
  enum class Base {
    FromUrdf,  ///< fixed when the URDF's root link is `world` or it says <static>true</static>
    Free,
    Fixed
  };
  std::string urdf;  ///< the URDF's XML text
  std::string name;  ///< "": the URDF's robot name
  std::string ns;    ///< its namespace (letters, digits, '_', '/'; "": none, the ROS layer's name)
  SE3 pose;          ///< the base's pose in the world
  Base base = Base::FromUrdf;
  bool joint_limits = true;  ///< the joint-limit constraints, as a scene's robots have them
  /// In a scene with collision (the robot's <collision> shapes join it, meshes as convex
  /// hulls): how its mesh names resolve (GeometryOptions::paths or resolver; relative names
  /// against paths.base_dir), its links colliding with each other (a scene's self_collision)
  /// and the SRDF text whose <disable_collisions> pairs never collide ("": none).
  GeometryOptions geometry;
  bool self_collision = false;
  std::string srdf;
};

/// What a prepared edit does: the model it adds or removes ("" if none), whether that is a
/// robot, and the robot's model a spawn adds (nullptr for the other edits; owned by the edit,
/// valid until the commit).
struct WorldEditInfo {
  std::string spawned, deleted;
  bool robot = false;
  const Model* robot_model = nullptr;
};
WorldEditInfo edit_info(const WorldEditPtr& edit);

/// An object from YAML text with the keys of one `objects:` entry of a scene (name, shape, mass,
/// inertia, pose, twist, mu, restitution, color; scene_objects.cpp); mesh paths relative to
/// base_dir. `name` not empty: the object's name (the text then needs none). Throws SceneError
/// naming `source`, the line and the key.
SceneObject parse_scene_object(const std::string& yaml, const std::string& base_dir,
                               const std::string& source = "<object>",
                               const std::string& name = "");

}  // namespace se3
