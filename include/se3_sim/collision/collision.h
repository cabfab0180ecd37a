// The collision layer: which geometries touch, where, and how deep (docs/design.md, layers).
//
// A CollisionModel is a flat list of CollisionObjects, each a Shape placed on a *frame*: frames
// are numbered by the caller (the sim layer numbers the robot's bodies first, then the scene's
// free objects) and their world poses are passed to collide() each step; frame kWorld is the
// world itself (static geometry: the ground, tables, static objects). The layer knows nothing of
// models, objects or dynamics beyond that: the sim layer builds the list (the robot's URDF
// <collision> shapes from its GeometryModel, the scene's objects, the ground) and maps frames
// back to bodies when it builds constraint rows.
//
// Narrow phase and broad phase are FCL 0.7's (a dynamic AABB tree over the objects). Pairs that
// never collide are filtered before the narrow phase: two objects on the same frame, objects
// whose frames are adjacent (a joint between them), pairs disabled by an SRDF, robot-robot pairs
// when self-collision is off, and static-static pairs.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "se3_sim/geometry/geometry.h"
#include "se3_sim/lie/lie.h"

namespace se3 {

/// One geometry that may touch another.
struct CollisionObject {
  static constexpr int kWorld = -1;
  std::string name;        ///< for errors, reports and SRDF matching (the robot: its link name)
  std::string link;        ///< the robot's URDF link (frame name) for SRDF pairs; "" for objects
  int frame = kWorld;      ///< index into collide()'s poses, or kWorld (fixed in the world)
  SE3 placement;           ///< shape frame in the frame
  Shape shape;             ///< Box, Sphere, Cylinder, Capsule, Mesh (see CollisionOptions::mesh)
  bool halfspace = false;  ///< the ground: the solid z <= 0 of the shape frame (shape ignored)
  /// 0: the robot (self-collision rules apply), 1: scene objects, 2 + k: another robot k (its
  /// own self-collision rule: CollisionOptions::self_colliding_groups)
  int group = 0;
  double mu = 0.8;  ///< Coulomb friction; a pair uses the larger of its two (as MuJoCo)
  double restitution = 0;
  /// mu is the link's own (a URDF's Gazebo mu1/mu2): a pair with such an object uses its mu
  /// (the smaller of two), as Gazebo's ground (mu 100) leaves a link's own coefficient to count.
  bool mu_own = false;
  /// Group 0: collides with the robot's other links even without CollisionOptions::
  /// self_collision (a URDF's Gazebo selfCollide: a pair collides when either link says so).
  bool self_collide = false;
  /// The contact's correction of a penetration (a URDF's Gazebo kp and kd as ERP = h kp /
  /// (h kp + kd), minDepth, maxVel), NaN: the scene's constraint_options. A pair takes the
  /// link's where one side gives it; where both do, the softer erp, the larger slop and the
  /// smaller speed.
  double erp = std::numeric_limits<double>::quiet_NaN();
  double slop = std::numeric_limits<double>::quiet_NaN();
  double max_correction_velocity = std::numeric_limits<double>::quiet_NaN();
};

/// A pair the sim layer says never collides (by frame: adjacency).
struct FramePair {
  int a = 0, b = 0;
};

struct CollisionOptions {
  double margin = 0.01;         ///< m: pairs closer than this report a contact with depth < 0
  bool self_collision = false;  ///< group-0 pairs (robot link against robot link)
  int max_contacts_per_pair = 4;
  /// Against a half-space (the ground), the shapes of one frame (a body's) pick their contacts
  /// together: max_contacts_per_pair for the body, from the union of their candidate points
  /// (the deepest always kept). Off: each shape is a pair of its own.
  bool ground_contacts_per_body = true;
  /// SRDF <disable_collisions link1 link2>: link-name pairs never tested.
  std::vector<std::pair<std::string, std::string>> disabled_links;
  /// Frames joined by a joint (parent, child); their objects never collide.
  std::vector<FramePair> adjacent;
  /// Groups >= 2 (other robots) whose objects collide with each other (their self_collision).
  std::vector<int> self_colliding_groups;
};

/// A contact between objects a and b (indices into CollisionModel::objects()).
struct Contact {
  int a = -1, b = -1;
  Vec3 point = Vec3::Zero();    ///< world, on the surface midway between the two
  Vec3 normal = Vec3::UnitZ();  ///< world, unit, from a towards b
  double depth = 0;             ///< > 0 penetration, <= 0 separation (within the margin), m
};

class CollisionModel;

/// The convex hull of a mesh (vertices times a per-axis scale), with its mass properties as a
/// uniform solid of density 1: what a mesh collision shape is in this layer.
struct ConvexHull {
  std::vector<Vec3> vertices;                 ///< hull vertices, shape frame (scaled)
  std::vector<std::array<int, 3>> triangles;  ///< counter-clockwise seen from outside
  double volume = 0;                          ///< m^3
  Vec3 centroid = Vec3::Zero();               ///< shape frame
  Mat3 inertia = Mat3::Zero();                ///< about the centroid, per unit density
};

/// The hull by qhull (libqhull_r). Throws std::invalid_argument naming `name` for fewer than 4
/// vertices or a flat (degenerate) mesh.
ConvexHull convex_hull(const TriangleMesh& mesh, const Vec3& scale = Vec3::Ones(),
                       const std::string& name = "mesh");

/// Per-step workspace: the contacts of the last collide() (capacity kept between steps).
struct CollisionData {
  std::vector<Contact> contacts;
  int pairs_tested = 0;  ///< narrow-phase pairs of the last call
};

/// The objects with their FCL counterparts and the pair filter, built once. Throws
/// std::invalid_argument with one line naming the object for a shape it cannot use (a mesh
/// without triangles, a non-positive size).
class CollisionModel {
 public:
  CollisionModel(std::vector<CollisionObject> objects, CollisionOptions options);
  ~CollisionModel();
  /// The broad phase as a new model has it. Its tree's shape, and so the order in which it
  /// reports pairs (and the contact solver meets its rows), follows the history of its updates:
  /// after this, the same motions give the same contacts bit for bit (Simulator::reset).
  void reset_broad_phase();
  CollisionModel(CollisionModel&&) noexcept;
  CollisionModel& operator=(CollisionModel&&) noexcept;

  const std::vector<CollisionObject>& objects() const { return objects_; }
  const CollisionOptions& options() const { return options_; }
  /// Whether objects i and j may ever collide (the filter).
  bool may_collide(int i, int j) const;
  /// The convex hull object i collides as (meshes), or null.
  const ConvexHull* hull(int i) const;
  /// Models of at least one object constructed in this process (each builds its shapes' FCL
  /// objects and hulls): how tests see that a scene's model is built once.
  static std::uint64_t constructed();

  struct Impl;
  const Impl& impl() const { return *impl_; }
  Impl& impl() { return *impl_; }

 private:
  std::vector<CollisionObject> objects_;
  CollisionOptions options_;
  std::unique_ptr<Impl> impl_;
};

/// The contacts at the given frame poses (world; poses[k] is frame k), deepest first per pair.
void collide(CollisionModel& model, CollisionData& data, const std::vector<SE3>& frame_poses);

/// Link-name pairs <disable_collisions link1=".." link2=".."/> of an SRDF text; throws
/// std::invalid_argument with a one-line reason for malformed XML.
std::vector<std::pair<std::string, std::string>> srdf_disabled_pairs(const std::string& xml);

}  // namespace se3
