// The collision model of a scene (sim layer): the robot's URDF <collision> shapes (meshes as
// hulls), the scene's `contacts:` spheres, its objects and its ground, with the model's
// adjacency, the SRDF pairs and `self_collision` (collision.h for the layer itself).
//
// Frames (the numbering collide() takes poses in, shared with the multi-body step):
//   0..n         the robot's bodies (frame k = body k; poses Data::oMb after forward kinematics)
//   n+1+j        the j-th free object of Scene::objects (static ones are skipped in the count)
//   n+1+B+o_k+i  body i of the scene's robot k >= 1 (Scene::extra_robots; B free objects,
//                o_k the bodies of the robots before it)
//   kWorld (-1)  static objects and the ground
// Without a robot n = -1: frames start at 0 with the first free object.
#pragma once

#include <string>
#include <vector>

#include "se3_sim/collision/collision.h"
#include "se3_sim/sim/sim.h"

namespace se3 {

struct SceneCollision {
  CollisionModel model;
  int robot_bodies = 0;  ///< n + 1 (0 without a robot): the first free object's frame
  int free_objects = 0;  ///< free objects of the scene (frames robot_bodies .. + free_objects - 1)
  /// Per Scene::objects entry: its frame (robot_bodies + j for the j-th free one, or kWorld).
  std::vector<int> object_frame;
  /// Per collision object: the Scene::objects index it came from, or -1 (robot, ground).
  std::vector<int> scene_object;
  /// Per collision object: the robot body it moves with (its frame), or -1.
  std::vector<int> body;
  int ground = -1;                    ///< index of the ground's collision object, or -1
  std::vector<std::string> warnings;  ///< meshes that could not be loaded (stand-ins used)
  /// The other robots' frames (after the free objects'): their bodies' count in all.
  int robot_frames = 0;
};

/// The robot's geometry as scene_collision reads it (urdf_xml as scene_geometry; meshes also
/// on the package path of data/meshes of the package holding the robot or scene file).
GeometryModel scene_robot_geometry(const Scene& scene, const Model& model,
                                   const std::string& urdf_xml = "");

/// The collision model of `scene` with robot `model` (null: objects only). `geometry` is the
/// robot's (scene_geometry with meshes loaded); when null it is loaded here (package:// names
/// on the package path of data/meshes of the package holding the robot file, then
/// ROS_PACKAGE_PATH). Robot shapes get
/// group 0 and the ground's mu (scene.constraints.mu); objects group 1 and their own mu and
/// restitution. A fixed base never collides with the world's static geometry. Throws
/// SceneError (one line naming the scene) for an SRDF that names a link the robot lacks, a
/// `contacts:` link it lacks, or a mesh without a hull.
/// robots: the models of Scene::extra_robots (Simulator::extra_robot_models): their collision
/// shapes in group 2 + k, link names "NAME/LINK" (their SRDF pairs too), each robot's
/// self_collision its own; a robot's links collide with every other robot's and the objects.
SceneCollision scene_collision(const Scene& scene, const Model* model,
                               const GeometryModel* geometry = nullptr,
                               const std::string& urdf_xml = "",
                               const std::vector<const Model*>& robots = {});

/// frames = body_poses (Data::oMb, or empty without a robot) followed by the free objects'
/// poses (their centres in the world, in Scene::objects order). Allocation-free once frames
/// has the capacity.
void scene_frame_poses(const std::vector<SE3>& body_poses,
                       const std::vector<SE3>& free_object_poses, std::vector<SE3>& frames);

/// The scene objects as geometry the renderer draws (geometry.h): one GeometryObject each, body
/// GeometryObject::kWorld, placement = its pose (poses[j] when given, one per object; else the
/// scene's initial pose), its shape and colour; name and link are the object's name.
std::vector<GeometryObject> scene_object_geometry(const std::vector<SceneObject>& objects,
                                                  const std::vector<SE3>& poses = {});

}  // namespace se3
