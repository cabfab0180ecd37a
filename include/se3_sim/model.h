// The kinematic tree: bodies joined by one-dof joints, built from a URDF (urdfdom) or in code.
//
// Body 0 is the base: fixed to the world at a given pose, or free (6 dof, integrated on SE(3)).
// Bodies 1..n each hang on one moving joint (revolute, continuous or prismatic) and are stored
// in topological order (parent[i] < i). Links attached by fixed joints are merged into the
// body they hang on: only what moves is modelled.
//
// Each body's frame is the URDF joint frame turned so that the joint axis is its z axis; then
// the joint motion is exp(S q) with S = e_z (revolute) or the linear e_z (prismatic), as in the
// paper's eq. (26), and every link frame of the URDF is recovered as body frame * offset.
#pragma once

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "se3_sim/lie.h"

namespace se3 {

enum class JointType { Revolute, Prismatic };

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

struct Model {
  // ---- structure (sizes: n+1 for per-body arrays, index 0 = base)
  bool floating = false;
  int n = 0;                ///< number of moving joints = moving bodies
  int nv = 0;               ///< n, plus 6 when floating
  std::vector<int> parent;  ///< parent[0] = -1
  std::vector<std::vector<int>> children;
  std::vector<JointType> joint_type;  ///< [i] for i >= 1
  std::vector<SE3> X_tree;            ///< joint frame of body i in its parent's body frame
  std::vector<Inertia> inertia;       ///< body inertia in its body frame (merged links)
  /// Coordinate index of body i's joint in the generalized velocity (i - 1, + 6 if floating).
  int idx_v(int i) const { return floating ? i + 5 : i - 1; }
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
  std::vector<LinkFrame> links;       ///< every URDF link, root first (shapes: geometry.h)
  std::vector<std::string> warnings;  ///< e.g. inertias that break the triangle inequality

  Vec3 gravity = Vec3(0, 0, -9.81);  ///< world frame

  /// Index (1..n) of a joint by name, or -1.
  int joint_index(const std::string& joint) const;
  /// Index into links of a link by name (a leading '/' ignored), or -1.
  int link_index(const std::string& link) const;
  double total_mass() const;
  /// Checks sizes and numbers; throws ModelError naming the culprit.
  void validate() const;
  /// Fills children and subtree_end from parent; call after building a model by hand.
  void finalize();
  /// Starts a model by hand: only the base body 0 (link `root`, the given inertia), no joints.
  void start_with_base(const std::string& root, const Inertia& base_inertia = Inertia());
};

/// The frame name of a URDF link: a leading '/' (ROS 1 URDFs from before tf2) stripped, as
/// tf2 and robot_state_publisher do. Model names (links, body_name, root_link) are frame names.
std::string frame_name(const std::string& urdf_link);

struct UrdfOptions {
  bool floating = false;
  /// Joints listed here are locked (treated as fixed) at the given positions.
  std::vector<std::pair<std::string, double>> locked;
};

/// Builds a model from URDF text. Throws ModelError with a one-line reason.
Model model_from_urdf_string(const std::string& xml, const UrdfOptions& opt = {});
Model model_from_urdf_file(const std::string& path, const UrdfOptions& opt = {});

/// A generated serial chain of n bodies (test and benchmark subject): revolute joints whose
/// axes cycle through z, y, x, each link a slender box of length `length` and mass
/// masses[i % masses.size()].
Model make_chain(int n, bool floating, const std::vector<double>& masses = {1.0},
                 double length = 0.3);

}  // namespace se3
