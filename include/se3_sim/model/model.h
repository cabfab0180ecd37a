// The kinematic tree: bodies joined by joints, built from a URDF (urdfdom) or in code.
//
// Body 0 is the base: fixed to the world at a given pose, or free (6 dof, integrated on SE(3)).
// Bodies 1..n each hang on one moving joint (revolute, continuous or prismatic) and are stored
// in topological order (parent[i] < i). Links attached by fixed joints are merged into the
// body they hang on: only what moves is modelled.
//
// Each body's frame is the URDF joint frame turned so that the joint axis is its z axis; then
// the joint motion is exp(S q) with S = e_z (revolute) or the linear e_z (prismatic), as in the
// paper's eq. (26), and every link frame of the URDF is recovered as body frame * offset.
//
// Joints (JointModel below) are the one place that knows joint types: every algorithm asks the
// joint of a body for its coordinates, transform and motion subspace.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "se3_sim/lie/lie.h"
#include "se3_sim/model/gazebo_tags.h"

namespace urdf {
class ModelInterface;
class Pose;
}  // namespace urdf

namespace se3 {

/// What a joint lets its body do relative to its parent. Bodies 1..n have Revolute or Prismatic
/// joints; body 0's joint is the base's: Free or Fixed.
enum class JointType {
  Revolute,   ///< rotation about the body's z axis, S = e_3 (twist order [w; v]); also continuous
  Prismatic,  ///< translation along the body's z axis, S = e_6
  Free,       ///< the free-floating base: 6 dof, S = 1; its pose is State::base (on SE(3))
  Fixed,      ///< the fixed base: no dof, bolted to the world at State::base
};

/// One joint, as spatial_v2's jcalc or Pinocchio's JointModel: its type, how many coordinates it
/// has in q (nq) and in the generalized velocity v (nv), where they start (idx_q, idx_v), its
/// transform X_tree exp(S q) and its motion subspace S (the body-frame twist per unit rate).
/// The recursions dispatch on it once per body; src/dynamics/joint.h holds the hot-path forms of
/// the one-dof joints (S a unit vector e_k: the joint-axis sparsity).
///
/// The base's pose is not in q: a free base has nq = 0 and nv = 6 (State::base is its group
/// coordinate, integrated as f <- f exp(h V0)); a fixed base has nq = nv = 0.
struct JointModel {
  JointType type = JointType::Revolute;
  int nq = 1;     ///< coordinates in State::q
  int nv = 1;     ///< coordinates in the generalized velocity v
  int idx_q = 0;  ///< first of them in q (Model::finalize sets it)
  int idx_v = 0;  ///< first of them in v (Model::finalize sets it)
  /// X_tree's rotation turns about z only, R = [Q 0; 0 1] with exact zeros and one (the identity
  /// among them): then so does X_tree exp(S q), and the recursions transform by its 2x2 block Q
  /// (src/dynamics/joint.h). Model::finalize sets it from X_tree, after snapping the rotation's
  /// entries within 4 ulp of 0 or +-1 onto them.
  bool z_rotation = false;
  /// k when X_tree's rotation maps the joint's z axis exactly onto the parent's axis +-e_k
  /// (R(k, 0) = R(k, 1) = 0, R(k, 2) = +-1, R(r, 2) = 0 for r != k) and the joint is not a
  /// z_rotation; else -1. Then so does X_tree exp(S q), and its rotations skip those entries
  /// (src/dynamics/joint.h). Model::finalize sets it.
  signed char axis_row = -1;
  /// The components of X_tree's offset p that are nonzero, bit k for p[k] (7: all): a revolute
  /// joint's cross products with p skip the others (src/dynamics/joint.h). Model::finalize sets it.
  unsigned char offset_axes = 7;
  /// The recursions' dispatch index (src/dynamics/joint.h, with_joint): the type, the form and
  /// offset_axes above in one byte, so that a body's step is reached by one indexed jump instead
  /// of a test per field. Revolute: 8 form + offset_axes, form 0 (general), 1 (z_rotation) or
  /// 2 + axis_row; prismatic: 40 + z_rotation; the base's joints: 42. Model::finalize sets it
  /// (dispatch_kind()); whoever changes the fields above calls it again.
  unsigned char kind = 7;

  JointModel() = default;
  explicit JointModel(JointType t);
  /// For a one-dof joint, the index k of S = e_k in twist coordinates: 2 (revolute), 5
  /// (prismatic); -1 for the base's joints.
  int axis() const {
    static constexpr int k[] = {2, 5, -1, -1};  // in the order of JointType
    return k[static_cast<int>(type)];
  }
  /// Whether the joint's coordinate is an angle (a revolute joint; without limits it wraps at
  /// 2 pi, URDF's continuous joint).
  bool angular() const { return type == JointType::Revolute; }
  /// kind as the type, z_rotation, axis_row and offset_axes give it.
  unsigned char dispatch_kind() const;
  /// S in the body frame, 6 x nv: e_3, e_6, the identity (free base), empty (fixed base).
  Eigen::Matrix<double, 6, Eigen::Dynamic> motion_subspace() const;
  /// X_tree exp(S q), the body's frame in its parent's, for the joint's nq coordinates at q (the
  /// base's joints: X_tree). Reference form; the recursions use src/dynamics/joint.h's.
  SE3 transform(const SE3& X_tree, const double* q) const;
  /// "revolute", "prismatic", "free", "fixed".
  const char* name() const;
  /// The URDF joint type that writes it: "revolute" (or "continuous" when it has no limits),
  /// "prismatic"; nullptr for the base's joints.
  const char* urdf_type(bool limited) const;
};

/// Thrown for a model that cannot be simulated: the message names the link or joint.
struct ModelError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// A URDF link and where it sits on its (merged) body.
struct LinkFrame {
  LinkFrame(std::string name_ = "", int body_ = 0, const SE3& offset_ = SE3(), int parent_ = -1,
            std::string joint_ = "", bool fixed_ = false)
      : name(std::move(name_)),
        body(body_),
        offset(offset_),
        parent(parent_),
        joint(std::move(joint_)),
        fixed(fixed_) {}
  std::string name;
  int body = 0;  ///< body index
  SE3 offset;    ///< link frame = body frame * offset
  // The URDF tree (for TF as robot_state_publisher publishes it):
  int parent = -1;     ///< index in Model::links of the URDF parent link (-1: the root)
  std::string joint;   ///< URDF joint from the parent link ("" for the root)
  bool fixed = false;  ///< that joint is fixed in the URDF (a locked moving joint is not)
};

/// A URDF <mimic> joint: q[joint] = multiplier q[leader] + offset. The joint keeps its own
/// coordinate (and its inertia); the simulator holds the relation as a bilateral constraint row
/// (constraints.h, ConstraintType::JointCoupling), so that the dynamics and every per-joint
/// array stay as they are and joint_states lists the joint.
struct JointMimic {
  int joint = 0;   ///< the mimic joint's body (1..n)
  int leader = 0;  ///< the joint it follows (1..n; itself possibly a mimic joint)
  double multiplier = 1;
  double offset = 0;
};

struct Model {
  // ---- structure (sizes: n+1 for per-body arrays, index 0 = base)
  bool floating = false;    ///< the base's joint: Free, else Fixed (finalize() sets joints[0])
  int n = 0;                ///< number of moving bodies (1..n), each on one joint
  int nq = 0;               ///< size of State::q: the joints' nq summed (n: every joint has one)
  int nv = 0;               ///< size of v: the joints' nv summed (n, plus 6 when floating)
  std::vector<int> parent;  ///< parent[0] = -1
  std::vector<std::vector<int>> children;
  /// The joint of every body: [0] the base's (Free or Fixed, from `floating`), [i] body i's.
  std::vector<JointModel> joints;
  /// Joint frame of body i in its parent's body frame; [0]: the base's rest pose in the world
  /// (identity, or the origin of a URDF floating joint from the world), State(model)'s base.
  std::vector<SE3> X_tree;
  std::vector<Inertia> inertia;  ///< body inertia in its body frame (merged links)
  /// First coordinate of body i's joint in the generalized velocity v (its joint's idx_v).
  int idx_v(int i) const { return joints[i].idx_v; }
  /// First coordinate of body i's joint in q (its joint's idx_q).
  int idx_q(int i) const { return joints[i].idx_q; }
  /// Coordinates of the base in v: 6 for a free base, else 0 (the joints' rates follow them).
  int nv_base() const { return joints[0].nv; }
  /// Last body of the subtree rooted at i (bodies i..subtree_end[i] form the subtree).
  std::vector<int> subtree_end;

  // ---- names and URDF data kept for the simulator, renderer and constraints
  std::string name;
  std::string root_link;
  std::vector<std::string> body_name;    ///< URDF link that carries the body (first merged link)
  std::vector<std::string> joint_name;   ///< [i] for i >= 1; [0] = "" (base)
  std::vector<double> lower, upper;      ///< position limits (-inf, inf) when none
  std::vector<double> effort, velocity;  ///< effort/velocity limits (inf when none)
  std::vector<double> damping, friction;
  std::vector<LinkFrame> links;  ///< every URDF link, root first (shapes: geometry.h)
  /// The URDF's <mimic> joints whose joint and leader both move, leaders before their mimics.
  std::vector<JointMimic> mimics;
  std::vector<std::string> warnings;  ///< e.g. inertias that break the triangle inequality

  Vec3 gravity = Vec3(0, 0, -9.81);  ///< world frame

  /// Index (1..n) of a joint by name, or -1.
  int joint_index(const std::string& joint) const;
  /// Index into links of a link by name (a leading '/' ignored), or -1.
  int link_index(const std::string& link) const;
  double total_mass() const;
  /// Whether body i's joint is continuous: revolute without a finite lower and upper limit, so
  /// that its configuration space is the circle and q and q + 2 pi are the same configuration.
  bool continuous(int i) const;
  /// Checks sizes and numbers; throws ModelError naming the culprit.
  void validate() const;
  /// Fills joints[0] (from floating), every joint's idx_q, idx_v, z_rotation and offset_axes, nq,
  /// nv, children and subtree_end; call after building a model by hand (and after changing X_tree).
  void finalize();
  /// Starts a model by hand: only the base body 0 (link `root`, the given inertia), no joints.
  void start_with_base(const std::string& root, const Inertia& base_inertia = Inertia());
  /// Adds body n + 1 on a joint of the given type (no limits, damping or friction; change them
  /// after) and returns its index; finalize() when done.
  int add_body(int parent, JointType type, const SE3& X_tree, const Inertia& inertia,
               const std::string& body, const std::string& joint);
};

/// The angle q as the same point of the circle in (-pi, pi] (q finite; NaN and inf pass as they
/// are, for the callers' own checks).
double wrap_angle(double q);
/// Wraps every continuous joint's coordinate of q (Model::continuous) into (-pi, pi], as the
/// joint's configuration space says (q of an angle 1e15 rad kept as it is would lose every
/// digit of the step's increments); joints with limits and prismatic joints are left as they
/// are. Returns how many coordinates changed.
int wrap_continuous_joints(const Model& model, Eigen::VectorXd& q);

/// The frame name of a URDF link: a leading '/' (ROS 1 URDFs from before tf2) stripped, as
/// tf2 and robot_state_publisher do. Model names (links, body_name, root_link) are frame names.
std::string frame_name(const std::string& urdf_link);

/// URDF joints: revolute, continuous and prismatic joints become bodies, fixed joints are merged.
/// A floating joint from the URDF's root link (the world: it must carry no inertia, geometry or
/// other joint) to the robot's base makes that base free, as `floating` does, and its origin the
/// base's rest pose (X_tree[0]). Planar joints and floating joints deeper in the tree are
/// rejected with a ModelError naming the joint.
struct UrdfOptions {
  /// The URDF's root link (merged with what is fixed to it, even one named "world") becomes the
  /// free base.
  bool floating = false;
  /// Joints listed here are locked (treated as fixed) at the given positions.
  std::vector<std::pair<std::string, double>> locked;
};

/// A URDF parsed once, through the guards of src/model/urdf_guard.h (size, nesting and UTF-8
/// before tinyxml; urdfdom's messages never formatted printf-style; its link tree released
/// without recursion) and the quirk readings of src/model/urdf_quirks.h. The model
/// (model_from_urdf) and the geometry (geometry_from_urdf, geometry.h) are both built from it;
/// the document is shared and read-only.
struct UrdfDocument {
  std::shared_ptr<const urdf::ModelInterface> urdf;  ///< never null in a returned document
  std::string file;                                  ///< the file it was read from ("" for text)
  std::vector<std::string> warnings;                 ///< the quirks read, one line each
  std::vector<std::string> complaints;               ///< what urdfdom said while accepting the text
  /// Joints that move only massless links, with the position they are locked at.
  std::vector<std::pair<std::string, double>> massless;
  /// The <gazebo> tags (gazebo_tags.h); their warnings are in `warnings`.
  GazeboTags gazebo;
};

/// Parses URDF text. Throws ModelError with a one-line reason (refused text, urdfdom's error,
/// a joint the dynamics cannot use).
UrdfDocument parse_urdf_document(const std::string& xml);
/// Reads and parses a URDF file: only a regular file is read (read_file, limits.h); every
/// error names the file.
UrdfDocument read_urdf_document(const std::string& path);

/// A URDF origin (urdfdom's Pose: position and unit quaternion) as a rigid transform.
SE3 se3_from_urdf(const urdf::Pose& p);

/// Builds a model from a parsed URDF. Throws ModelError with a one-line reason.
Model model_from_urdf(const UrdfDocument& doc, const UrdfOptions& opt = {});
/// parse_urdf_document (or read_urdf_document), then model_from_urdf.
Model model_from_urdf_string(const std::string& xml, const UrdfOptions& opt = {});
Model model_from_urdf_file(const std::string& path, const UrdfOptions& opt = {});

/// A generated serial chain of n bodies (test and benchmark subject): revolute joints whose
/// axes cycle through z, y, x, each link a slender box of length `length` and mass
/// masses[i % masses.size()].
Model make_chain(int n, bool floating, const std::vector<double>& masses = {1.0},
                 double length = 0.3);

}  // namespace se3
