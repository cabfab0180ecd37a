// The simulation layer (no roscpp): scenes from YAML, a Simulator with commands, passive joint
// forces, effort limits and a divergence guard, and the headless run behind `se3_dyn simulate`.
#pragma once

#include <algorithm>
#include <cstdint>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "se3_sim/integrate/integrate.h"
#include "se3_sim/model/limits.h"
#include "se3_sim/sim/controllers.h"
#include "se3_sim/sim/scene_objects.h"
#include "se3_sim/sim/sensors.h"
#include "se3_sim/sim/world.h"
#include "se3_sim/solver/constraints.h"

namespace se3 {

/// Thrown for a scene file that cannot be used; the message names the file, line and key.
struct SceneError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// A scene (config/scenes/*.yaml): standard YAML (yaml-cpp), one document, a map of these keys,
/// all optional; unknown keys, wrong types and values out of range are errors naming the line.
///   name: text                      robot: data/robots/panda.urdf | chain:N
///       without robot, the robot comes from outside (scene_model's urdf_xml, e.g. the
///       robot_description parameter); a scene that names no joints fits any robot
///   base: free | fixed              base_pose: {position: [x,y,z], orientation: [x,y,z,w]}
///   base_twist: [wx,wy,wz,vx,vy,vz] (base frame; free base only)
///   base_inertia: {mass: m, com: [x,y,z], inertia: [ixx,iyy,izz(,ixy,ixz,iyz)]}
///       a rigid body added to the base link (e.g. a satellite bus), inertia about its com
///   base_visual: {box: [x,y,z], origin: [x,y,z], color: [r,g,b]}
///       a box drawn on the base link (centre at origin, base link frame; colour in [0, 1]):
///       what base_inertia adds has no URDF geometry. The simulator node publishes it on
///       sim_markers (namespace base_visual), and `se3_dyn render --scene` draws it.
///   initial_positions: {joint: value, ...}   initial_velocities: {joint: value, ...}
///   locked_joints: {joint: value, ...}       (treated as fixed at that value)
///   gravity: [gx,gy,gz]             integrator: rkmk4     dt: 0.001    tol: 1e-6
///   real_time_factor: 1.0           publish_rate: 100     friction_eps: 0.01
///   chain: {length: 0.3, masses: [1.0]}      (for robot: chain:N)
///   constraints, joint_limits, ground, contacts, constraint_options: see constraints.h and
///       src/sim/contact_scene.cpp (read into Scene::constraints)
///   controllers: {NAME: {type: effort_controllers/..., joints: [...], pid: {...}}, ...}
///       ros_control-style controllers (controllers.h), every one listed runs at every step
///   objects: [{name, shape, mass, inertia, pose, twist, mu, restitution, color}, ...]
///       rigid bodies beside the robot (scene_objects.h); a scene may have objects and no robot
///   srdf: robot.srdf                self_collision: false
///   sensors: [{name, type: imu | force_torque | contact, link | joint, pose, rate, noise,
///       topic, frame}, ...]  (sensors.h, docs/ros.md "Sensors")
///   contact: {margin: 0.01, max_contacts_per_pair: 4, ground_per_body: true}
///       (the collision layer's options; ground_per_body: a body's shapes share one budget of
///       max_contacts_per_pair on the ground, CollisionOptions::ground_contacts_per_body)
///   robot_on_ground: false          (true: Scene::robot_on_ground, ground.h)
/// A relative robot path is looked up next to the scene file, then under the package root
/// (the nearest directory above the scene holding package.xml).
struct Scene {
  std::string file;  ///< the scene file ("" when parsed from text)
  std::string name;
  std::string robot;       ///< as written ("" when the scene names none)
  std::string robot_path;  ///< resolved file, or "chain:N" ("" when the scene names no robot)
  /// The folder relative mesh names of a URDF given as text (robot_description) are resolved
  /// against ("": none; sim.launch's robot_description_dir).
  std::string urdf_dir;
  bool floating = true;
  bool base_given = false;  ///< the scene says base: free or fixed
  bool has_base_inertia = false;
  double base_mass = 0;
  Vec3 base_com = Vec3::Zero();
  Mat3 base_inertia = Mat3::Zero();  ///< about base_com, base link axes
  bool has_base_visual = false;
  Vec3 base_visual_box = Vec3::Zero();     ///< full extents (m)
  Vec3 base_visual_origin = Vec3::Zero();  ///< box centre, base link frame
  Vec3 base_visual_color = Vec3(0.8, 0.72, 0.4);
  SE3 base_pose;
  bool base_pose_given = false;  ///< the scene says base_pose (robot_on_ground then keeps it)
  /// `robot_on_ground: true` (the generic scene): the base is placed so that the robot's lowest
  /// collision shape touches the ground (ground.h, base_on_ground) unless base_pose is given,
  /// and a collision mesh that cannot be loaded is left out of contact (its warning says so)
  /// instead of refusing the scene.
  bool robot_on_ground = false;
  Vec6 base_twist = Vec6::Zero();
  std::vector<std::pair<std::string, double>> initial_positions;
  std::vector<std::pair<std::string, double>> initial_velocities;
  std::vector<std::pair<std::string, double>> locked_joints;
  Vec3 gravity = Vec3(0, 0, -9.81);
  std::string integrator = "rkmk4";
  double dt = 1e-3;
  double tol = 1e-6;
  double real_time_factor = 1.0;
  double publish_rate = 100.0;
  double friction_eps = 1e-2;
  double chain_length = 0.3;
  std::vector<double> chain_masses = {1.0};
  ConstraintSpec constraints;  ///< bilateral constraints, limits, ground contact (empty: none)
  std::vector<ControllerSpec> controllers;  ///< run inside the simulator (empty: none)
  /// `objects:` (scene_objects.h, src/sim/scene_objects.cpp), in file order.
  std::vector<SceneObject> objects;
  std::string srdf;               ///< `srdf:` resolved against the scene's folder ("": none)
  bool self_collision = false;    ///< `self_collision:` robot links against each other
  double contact_margin = 0.01;   ///< `contact: {margin}` m: gaps reported as contacts
  int max_contacts_per_pair = 4;  ///< `contact: {max_contacts_per_pair}`
  bool ground_per_body = true;    ///< `contact: {ground_per_body}`: one budget a body
  /// `sensors:` (sensors.h), in file order; the URDF's Gazebo sensor tags are not in it
  /// (scene_sensors adds them).
  std::vector<SensorSpec> sensors;
  /// `robots:` (docs/multi_robot.md): a list of robots, each a map of name, urdf, namespace,
  /// base, base_pose, base_twist, initial_positions, initial_velocities, locked_joints,
  /// controllers, srdf, self_collision, joint_limits, sensors. The first is the scene's robot (its
  /// keys land in the fields above, as `robot:` would set them); the others are in
  /// extra_robots, each a Scene with only those keys set. Not with `robot:`.
  std::string robot_name;       ///< a `robots:` entry's name ("": the model's name)
  std::string robot_namespace;  ///< a `robots:` entry's namespace ("" = none)
  std::vector<Scene> extra_robots;
};

/// Reads a scene file (at most limits::kMaxSceneBytes). Throws SceneError.
Scene load_scene(const std::string& path);
/// Parses scene text; relative robot paths are resolved against base_dir. The text is checked
/// against the limits of limits.h (size, nesting, items) before yaml-cpp parses it.
Scene parse_scene(const std::string& text, const std::string& base_dir,
                  const std::string& file_for_messages = "<scene>");

/// The model a scene names: its robot (or urdf_xml when not empty, e.g. robot_description),
/// base free or fixed, locked joints, base inertia and gravity. Throws ModelError/SceneError
/// (no robot at all; a locked joint the robot lacks, naming the scene). gazebo, when given,
/// receives the URDF's <gazebo> tags from the same parse (empty for chain:N and no robot).
Model scene_model(const Scene& scene, const std::string& urdf_xml = "",
                  GazeboTags* gazebo = nullptr);
/// The scene's initial state for model (a joint the model does not move is a SceneError naming
/// the scene and the joint); continuous joints' angles wrapped into (-pi, pi].
State scene_state(const Scene& scene, const Model& model);
/// A random state: joints uniform within their limits ([-pi, pi] when unlimited), joint rates
/// and base twist uniform in [-1, 1], base at the identity. Fixed by seed.
State random_state(const Model& model, unsigned seed);
/// Minimal URDF text of a model (links, joints, inertials, and the visuals of `geometry` when
/// given), for robots that exist only in code (chain:N), so robot_description can be published.
std::string model_to_urdf(const Model& model, const GeometryModel* geometry = nullptr);

/// The geometry of a scene's robot (geometry.h): from urdf_xml when not empty, else from the
/// scene's robot file (relative meshes beside it), or chain_geometry for chain:N.
GeometryModel scene_geometry(const Scene& scene, const Model& model,
                             const std::string& urdf_xml = "", const GeometryOptions& opt = {});
/// scene.constraints with the collision geometry that contacts_from_collisions needs attached
/// (primitives only: meshes are not loaded, as contacts skip them).
ConstraintSpec scene_constraints(const Scene& scene, const Model& model,
                                 const std::string& urdf_xml = "");

/// An upper bound of the kinetic energy that needs no kinematics, for the divergence guard.
/// Body i's angular speed is at most |w0| plus the revolute joint rates on its path, and its
/// centre of mass moves at most |v0| + |w0| r + sum over revolute joints j on the path of
/// |qdot_j| r_j + sum over prismatic ones of |qdot_j|, where r, r_j bound the distances from the
/// base origin and from joint j to the centre of mass by path lengths through the tree (joint
/// offsets, prismatic displacements). Then T <= sum_i (m_i |v_ci|^2 + tr(I_i) |w_i|^2) / 2,
/// I_i the rotational inertia about the body origin (its largest eigenvalue is at most its
/// trace, and at least that of the inertia about the centre of mass). O(n), allocation-free.
class KineticEnergyBound {
 public:
  explicit KineticEnergyBound(const Model& model);
  /// >= kinetic_energy(model, data, base, q, v) for every base pose (inf or NaN when q or v
  /// are not finite).
  double operator()(const VecX& q, const VecX& v);

 private:
  struct Body {
    int parent = -1;
    int iv = 0;         ///< index of the joint rate in v
    int iq = 0;         ///< index of the joint position in q
    double turn = 0;    ///< |angular part of S|: 1 for a revolute joint, 0 for a prismatic one
    double slide = 0;   ///< |linear part of S|: 0 for a revolute joint, 1 for a prismatic one
    double offset = 0;  ///< |joint origin| in the parent's frame
    double com = 0;     ///< |centre of mass| in the body frame
    double mass = 0;
    double trace = 0;  ///< trace of the rotational inertia about the body origin
  };
  /// Per body, along its path from the base: length L from the base origin to the body origin,
  /// sums W of |qdot| and P of |qdot| L over the revolute joints, S of |qdot| over the prismatic
  /// (each joint counted by its turn and slide).
  struct Path {
    double L = 0, W = 0, P = 0, S = 0;
  };
  bool floating_;
  std::vector<Body> body_;  ///< index 0 = base
  std::vector<Path> path_;
};

struct GuardOptions {
  /// |v| (any component, rad/s or m/s) above this is divergence.
  double max_rate = 1e4;
  /// Kinetic energy above energy_growth * E_ref is divergence, with
  /// E_ref = max(T(0), m_total / 2 * 1 m^2/s^2) + m_total |g| * 1 m.
  double energy_growth = 1e4;
  /// Energy is checked every this many steps (finiteness and rates every step).
  int energy_check_every = 8;
};

/// m: the smallest length of the gravity energy scale (Simulator::energy_scale0).
constexpr double kMinEnergyLength = 0.1;

/// The scale of a run's relative energy drift: max(energy_scale0, the largest kinetic energy
/// reached, T_max). Drift relative to this stays meaningful when the run starts at rest
/// (T(0) = 0); NaN when it is 0 (nothing with mass moves and no gravity).
inline double energy_drift_scale(double scale0, double T_max) {
  const double s = std::max(scale0, T_max);
  return s > 0 ? s : std::numeric_limits<double>::quiet_NaN();
}

struct SimConfig {
  std::string integrator = "rkmk4";
  double dt = 1e-3;
  StepperOptions stepper;
  GuardOptions guard;
  /// The model's <mimic> joints (Model::mimics) held by joint_coupling constraint rows beside
  /// the scene's constraints; false: each moves as a joint of its own.
  bool mimic_joints = true;
};

struct SceneCollision;  // scene_collision.h

/// The state of one scene object (Simulator::objects()): free objects move, static ones stay.
struct ObjectState {
  std::string name;
  bool is_static = true;
  SE3 pose;                   ///< world pose of the object's frame (the shape's centre)
  Vec6 twist = Vec6::Zero();  ///< body frame [w; v]; zero for static objects
};

/// One simulated system: model, state, stepper, commands and the divergence guard.
class Simulator {
 public:
  /// Throws std::invalid_argument for an unknown integrator or a bad dt.
  Simulator(Model model, const State& initial, const SimConfig& config);
  ~Simulator();

  const Model& model() const { return *model_; }
  const State& state() const { return state_; }
  const SimConfig& config() const { return config_; }
  double dt() const { return config_.dt; }
  std::string integrator() const { return stepper_->name(); }
  Stepper& stepper() { return *stepper_; }
  /// Simulated time since the last reset.
  double time() const { return time_; }
  std::uint64_t steps() const { return steps_; }

  // ---- commands (kept until changed, or for command_timeout() of simulated time)
  /// Sets joint i's (1..n) commanded effort, clamped to its URDF effort limit (when that is
  /// finite and positive); the other joints keep theirs. Returns the clamped value.
  double set_joint_effort(int i, double effort);
  /// Wrench on a free base (base frame, about its origin); ignored for a fixed base. Throws
  /// std::invalid_argument (nothing changed) for a non-finite value.
  void set_base_wrench(const Vec6& wrench);
  /// A command (each joint's effort, the base wrench) stops acting after this many simulated
  /// seconds unless set again: it acts on the next ceil(timeout / dt) steps, so a paused
  /// simulation keeps it until it has stepped. inf (the default) or <= 0: kept until changed.
  void set_command_timeout(double seconds);
  double command_timeout() const { return command_timeout_; }

  // ---- controllers (controllers.h), run at every step on the state the step starts from
  /// Replaces the controllers (an empty list removes them) and resets them to the current
  /// state. Throws ControllerError (nothing changed) for a joint the model lacks or one claimed
  /// twice.
  void set_controllers(const std::vector<ControllerSpec>& specs);
  /// nullptr without controllers; set_command() on it changes their targets.
  ControllerSet* controllers() { return controllers_.get(); }
  /// The controllers update every `steps` physics steps (>= 1; a URDF's gazebo_ros_control
  /// controlPeriod over dt), with that period as their dt, and their efforts are held in
  /// between (commands still act at every step).
  void set_control_every(int steps) { control_every_ = steps < 1 ? 1 : steps; }
  int control_every() const { return control_every_; }

  // ---- external wrenches on links (as Gazebo's apply_body_wrench)
  static constexpr int kMaxLinkWrenches = 16;
  /// Applies wrench = [torque; force] (world axes, torque about the point) at a point fixed on
  /// URDF link `link` (index into Model::links; point in that link's frame) for `duration`
  /// simulated seconds (ceil(duration / dt) steps; < 0: until cleared or reset). It enters as the
  /// generalized force J^T wrench (J the point's Jacobian, joints on the link's path and a free
  /// base), evaluated at the start of each step. Wrenches add up. Throws std::invalid_argument
  /// (nothing changed) for a bad link, a non-finite value, or more than kMaxLinkWrenches.
  void apply_link_wrench(int link, const Vec3& point, const Vec6& wrench, double duration);
  /// apply_link_wrench on robot k's link (an index into robot_model(k).links): J^T wrench on
  /// robot k's joints and free base. The wrenches of every robot share kMaxLinkWrenches, count
  /// down together and end with reset(); a deleted robot's go with it. Throws
  /// std::invalid_argument (nothing changed) for a bad robot index too.
  void apply_robot_link_wrench(int k, int link, const Vec3& point, const Vec6& wrench,
                               double duration);
  /// Removes the wrenches on one link of robot 0 (-1: every wrench, on every robot).
  void clear_link_wrenches(int link = -1);
  int link_wrench_count() const { return static_cast<int>(wrenches_.size()); }
  /// Links that feel no gravity (<gazebo reference="LINK"><gravity>false</gravity>): each
  /// carries a constant force -m g at its body's centre of mass, m the body's mass (its fixed
  /// children's included), held over each step as commands are; kept through reset() and
  /// clear_link_wrenches. A link merged into its parent by a fixed joint is not a body of its
  /// own: returned (not applied), as are unknown names. Replaces the previous list.
  std::vector<std::string> set_links_without_gravity(const std::vector<std::string>& links);

  // ---- constraints (constraints.h); none unless set
  /// Adds constraints (an empty spec removes them): anchors point_world constraints at the
  /// initial state, projects the initial state onto the constraints and resets.
  void set_constraints(const ConstraintSpec& spec);
  /// set_constraints, then set_scene_collision, without building the objects' own collision
  /// model that the scene collision replaces (a node's new initial state in a contact scene).
  void set_constraints(const ConstraintSpec& spec, SceneCollision&& collision);
  /// nullptr when unconstrained; forces() and report() of the last step.
  const ConstraintSystem* constraints() const { return constraints_.get(); }
  /// Largest constraint error at the current state (ConstraintSystem::error), NaN if none.
  double constraint_error();
  /// Zeroes the commanded efforts and base wrench (controllers and link wrenches stay).
  void clear_command();
  /// The commanded generalized force (size nv): torque commands and base wrench.
  const VecX& command() const { return command_; }
  /// The actuation of the last step (size nv): command plus controller efforts, clamped to the
  /// effort limits (without controllers: the command as it stands). Link wrenches are not in it.
  const VecX& actuation() const { return controllers_ ? actuation_ : command_; }
  /// Joint efforts acting at the current state (size n): the command (a controlled joint: its
  /// actuation of the last step) plus damping and friction.
  void applied_joint_efforts(VecX& out);

  // ---- scene objects (scene_objects.h): each free object is a single-body free-floating
  // system of its own (frame model().n + 1 + j for the j-th free one), stepped with the robot
  /// Replaces the scene objects (resets them to their initial poses and twists). Throws
  /// std::invalid_argument (nothing changed) for a free object with a non-positive mass or a
  /// non-finite pose or twist.
  void set_objects(const std::vector<SceneObject>& objects);
  /// Contact from the collision layer for the whole scene (scene_collision.h: the robot's
  /// collision shapes, its contact spheres, the objects, the ground; its frames are this
  /// simulator's: bodies 0..n, free object j at n + 1 + j). Replaces the sim's own model of
  /// the objects and the constraint system's own contact spheres (which the scene collision
  /// holds). Call after set_objects and set_constraints; resets.
  void set_scene_collision(SceneCollision&& collision);
  /// set_objects, then set_scene_collision, without building the objects' own collision model
  /// (and its hulls) that the scene collision replaces: make_simulator's order.
  void set_objects(const std::vector<SceneObject>& objects, SceneCollision&& collision);
  /// The objects as set, in the order given (static ones included).
  const std::vector<SceneObject>& object_specs() const { return object_specs_; }
  /// The contacts of the last step's end (the collision layer's; empty without objects or a
  /// scene collision), their objects in contact_objects().
  const std::vector<Contact>& contacts() const;
  const std::vector<CollisionObject>* contact_objects() const;
  /// Every object's state after the last step, in the order of object_specs().
  const std::vector<ObjectState>& objects() const { return objects_; }
  /// Deepest contact penetration at the end of the last step (m, >= 0; 0 without contact).
  double penetration() const { return penetration_; }
  /// Deepest contact penetration at the end of any step since the last reset (m, >= 0).
  double penetration_max() const { return penetration_max_; }
  /// At the current state: "" or one line naming the deepest contact that is deeper than the
  /// margin and than one step of position correction removes at max_correction_velocity (such
  /// a contact is pushed out at that speed over several steps: a scene that starts so is
  /// probably wrong).
  std::string deep_penetration_warning();
  /// Steps since the last reset in which a free object moved farther than its smallest extent
  /// (counted once per object and step): contact is found at the step's end positions only, so
  /// such an object may pass through a thin one (tunnelling). The first is described by
  /// fast_step_warning() ("" when none).
  std::uint64_t fast_steps() const { return fast_steps_; }
  const std::string& fast_step_warning() const { return fast_step_warning_; }

  // ---- several robots (src/sim/robots.cpp, docs/multi_robot.md). Robot 0 is the one of
  // model(), state(), set_joint_effort() and the rest above; robots 1.. are added beside it,
  // each with its own state, integrator (the simulator's), commands, controllers and joint
  // limits. With a scene collision (set_scene_collision after the robots are added) every robot
  // touches the others, the objects and the ground through robot 0's velocity step
  // (docs/contact.md, "Several robots in one contact step"); without one each robot steps alone.
  /// Adds a robot; returns its index (robot_count() - 1). Throws std::invalid_argument (nothing
  /// changed) for a name in use or not a frame name, a state that does not fit the model or is
  /// not finite, and ControllerError for a bad controller.
  int add_robot(const std::string& name, const std::string& ns, Model model, const State& initial,
                const std::vector<ControllerSpec>& controllers = {}, bool joint_limits = true);
  int robot_count() const { return 1 + static_cast<int>(extra_.size()); }
  /// -1 when no robot has this name.
  int robot_index(const std::string& name) const;
  const Model& robot_model(int k) const;
  const State& robot_state(int k) const;
  const std::string& robot_name(int k) const;
  const std::string& robot_namespace(int k) const;
  /// set_joint_effort of robot k (the effort limits of its model). Throws std::out_of_range for
  /// a bad robot or joint index, std::invalid_argument for a non-finite effort.
  double set_robot_joint_effort(int k, int i, double effort);
  /// set_base_wrench of robot k (ignored for a fixed base; throws for a non-finite wrench).
  void set_robot_base_wrench(int k, const Vec6& wrench);
  /// Robot k's actuation of the last step (size nv): as actuation() for robot 0.
  const VecX& robot_actuation(int k) const;
  /// applied_joint_efforts of robot k (size its n): its command (a controlled joint: its
  /// actuation of the last step) plus its damping and friction.
  void robot_applied_joint_efforts(int k, VecX& out);
  /// set_state of robot k (same checks).
  void set_robot_state(int k, const State& s);
  /// Robot k's controllers (nullptr without); replaced by set_robot_controllers.
  ControllerSet* robot_controllers(int k);
  void set_robot_controllers(int k, const std::vector<ControllerSpec>& specs);
  /// The models of robots 1.. (for scene_collision's robots).
  std::vector<const Model*> extra_robot_models() const;
  /// World pose of every entry of robot k's Model::links, into out.
  void robot_link_poses(int k, std::vector<SE3>& out);
  /// Robot k's world spatial momentum and kinetic energy.
  Vec6 robot_momentum(int k);
  double robot_kinetic_energy(int k);
  /// Robot k's potential energy relative to its initial configuration (as potential_energy()
  /// for robot 0).
  double robot_potential_energy(int k);

  // ---- world interface (world.h, src/sim/world.cpp; docs/design.md "World interface"). Models
  // are the robot (when the simulator has one: a scene of objects alone has none) and the
  // objects, by name. Objects are spawned and deleted in two parts: prepare_* builds everything
  // new (shapes, free bodies, collision model, constraint system) and may run in another thread
  // beside step() (it reads only what commit() and set_objects() change); commit() swaps it in
  // between two steps (the steps after it allocate nothing once the first has run).
  /// The robot's model name and namespace (default: Model::name, else "robot"; "" for an
  /// empty robot, a scene of objects alone). Throws std::invalid_argument for a name an object
  /// has or one that is not a frame name.
  void set_robot_name(const std::string& name, const std::string& ns = "");
  const std::string& robot_name() const { return robot_name_; }
  /// Every model: the robot first, then the objects in their order.
  std::vector<WorldModel> world_models() const;
  /// Throws std::invalid_argument (one line naming the field) for a name in use, a name that is
  /// not a frame name, a non-finite or absurd pose or twist (|position| > 1e6 m, a rate above
  /// the guard's max_rate), a free object without a positive mass and inertia.
  WorldEditPtr prepare_spawn(const SceneObject& object) const;
  /// A robot spawn (src/sim/world.cpp): the URDF parsed and the model built here, off
  /// the step; the commit adds it through add_robot (it steps from the next step on). Throws
  /// WorldError (nothing changed), one line naming the field: `urdf` malformed or not a robot
  /// the dynamics take (Kind::Resource), `name` in use or not a frame name, `namespace` in use
  /// or not a ROS name, `pose` not finite, not a rotation or absurd. With a scene collision the
  /// robot's collision shapes (meshes and hulls) and the new collision model and constraint
  /// system are built here too (a mesh that does not load: Kind::Resource naming the link).
  WorldEditPtr prepare_spawn_robot(const RobotSpawn& spawn) const;
  /// prepare_spawn_robot and commit; returns the robot's name.
  std::string spawn_robot(const RobotSpawn& spawn);
  /// Throws std::invalid_argument for an unknown model and for robot 0 (not deletable); robots
  /// 1.. are deleted (the later ones move down one index; with a scene collision their shapes
  /// leave it and the later robots' frames move down).
  WorldEditPtr prepare_delete(const std::string& name) const;
  /// Applies a prepared edit: the objects kept keep their states, a spawned one starts at its
  /// pose and twist at the next step, time runs on. Throws std::invalid_argument (nothing
  /// changed) when the world changed since the edit was prepared. Returns "" or the
  /// interpenetration the new world starts with (interpenetration_report).
  std::string commit(WorldEditPtr edit);
  /// prepare_spawn and commit.
  std::string spawn_object(const SceneObject& object);
  /// prepare_delete and commit.
  void delete_model(const std::string& name);
  /// Counts of committed edits (every commit changes the generation).
  std::uint64_t world_generation() const { return world_generation_; }
  std::uint64_t spawned() const { return spawned_; }
  std::uint64_t deleted() const { return deleted_; }
  /// The state of a model (world.h ModelState). Throws std::invalid_argument for an unknown one.
  ModelState model_state(const std::string& name);
  /// Sets a model's state: a robot's base pose and twist (a fixed base: its pose, twist zero)
  /// and joints (sizes n; continuous joints wrapped), a free object's pose and twist, a static
  /// object's pose (its new place, also after a reset). Throws std::invalid_argument (nothing
  /// changed) for an unknown model, wrong sizes, a non-finite or absurd value, a twist for what
  /// cannot move. Accepted when it interpenetrates: returns interpenetration_report().
  std::string set_model_state(const std::string& name, const ModelState& state);
  /// Every link's name: the robot's URDF links, then each object's (its name), then robots
  /// 1..'s links as NAME::LINK.
  std::vector<std::string> link_names() const;
  /// A link's state in the world, or relative to link `reference` ("" for the world). Names
  /// are link names, or MODEL::LINK. Throws std::invalid_argument for an unknown link.
  LinkState link_state(const std::string& link, const std::string& reference = "");
  /// Sets the state (world frame) of a model's root link: the robot's base link, an object.
  /// Another link is refused (its pose follows from the joints: set_model_state).
  std::string set_link_state(const std::string& link, const LinkState& state);
  /// "" or one line naming the deepest pair of the collision layer that interpenetrates (depth
  /// > 0) at the current state, and by how much.
  std::string interpenetration_report();
  /// Reset of the world: the robot's state, the objects' poses and twists (spawned ones to
  /// their spawn states), commands and controllers as reset() does, but the time and the step
  /// count run on (reset() sets them to 0).
  void reset_world();

  // ---- stepping
  /// One step of dt. On divergence returns false, rolls the state back to the last good one
  /// and keeps the reason in failure() until reset().
  bool step();
  /// Up to k steps; stops at the first failure. Returns the steps taken.
  int step_n(int k);
  const std::string& failure() const { return failure_; }
  /// Back to the initial state, commands cleared, failure cleared, time 0.
  void reset();
  /// The state reset() goes back to; continuous joints' angles wrapped into (-pi, pi]
  /// (wrap_continuous_joints).
  void set_initial_state(const State& s);
  /// Replaces the current state, continuous joints' angles wrapped into (-pi, pi]. Throws
  /// std::invalid_argument (state unchanged) when the sizes do not match or the state is not
  /// finite (State::finite).
  void set_state(const State& s);
  /// Changes the integrator (state kept).
  void set_integrator(const std::string& name);
  /// Sum of accepted internal steps, rejected steps and dynamics calls since reset.
  std::uint64_t substeps() const { return substeps_; }
  std::uint64_t rejected() const { return rejected_; }
  std::uint64_t evaluations() const { return evaluations_; }
  /// Steps since reset taken (wholly or in part) by the velocity-level contact scheme, and the
  /// joint-limit impacts located inside steps (StepInfo); steps() - velocity_level_steps() were
  /// the integrator's own.
  std::uint64_t velocity_level_steps() const { return velocity_level_steps_; }
  std::uint64_t events() const { return events_; }
  /// The schemes that took the steps since reset: the integrator's name, the contact scheme's,
  /// or both as "A+B" (the integrator first); the integrator's name before the first step.
  std::string schemes_used() const;

  // ---- diagnostics (own workspace; not the stepper's)
  double kinetic_energy();
  /// Potential energy relative to the initial configuration.
  double potential_energy();
  /// Total spatial momentum, world frame.
  Vec6 momentum();
  /// The whole scene's: the robot's with every free object's kinetic energy, potential energy
  /// (from the initial configuration and the objects' initial poses) and world momentum.
  double scene_kinetic_energy();
  double scene_potential_energy();
  Vec6 scene_momentum();
  Vec3 center_of_mass();
  /// Initial kinetic energy (after the last reset).
  double initial_kinetic_energy() const { return T0_; }
  /// The energy a relative energy drift is measured against, from the initial state:
  /// max(T(0), M |g| L), M the robot's mass, L the largest distance of a body origin from its
  /// centre of mass (at least kMinEnergyLength). A run's scale is the larger of this and the
  /// largest kinetic energy it reached (energy_drift_scale); 0 for a massless robot.
  double energy_scale0() const { return energy_scale0_; }
  /// Work done on the system since the last reset by the commanded forces and the joint damping
  /// and friction (gravity is in the potential), J: per step the trapezoidal rule on the power
  /// (command + passive forces) . v at the step's ends, so O(dt^2) accurate. The energy drift
  /// of the integrator is then E(t) - E(0) - work(), E = kinetic + potential_energy(); it holds
  /// between resets (set_state is a jump it does not count; constraint forces are not in it).
  double work() const { return W_; }
  /// World pose of every entry of Model::links, into out (resized to links.size()).
  void link_poses(std::vector<SE3>& out);
  /// World pose of every body (after link_poses or center_of_mass; valid until the next call).
  const std::vector<SE3>& body_poses() const { return diag_.oMb; }

 private:
  void refresh_reference();
  /// The guard's checks (cheap; the reason is found again only after a failure).
  bool rates_ok() const;
  /// The first free object (index into bodies_) the rate guard refuses, or -1.
  int first_bad_object() const;
  bool energy_ok();
  void roll_back(const StepInfo& info);
  /// The generalized force of the next step: expires stale commands, runs the controllers,
  /// adds the link wrenches.
  const VecX& step_forces();
  void add_link_wrenches(VecX& tau);
  /// Whether a link wrench acts on robot k.
  bool has_link_wrenches(int k) const;
  void count_down_link_wrenches();
  /// The step count from which a command set now no longer acts.
  std::uint64_t command_expiry() const;

  struct LinkWrench {
    int robot = 0;  ///< robot index (robots 1..: remove_robot renumbers)
    int link = 0;
    Vec3 point = Vec3::Zero();
    Vec6 wrench = Vec6::Zero();
    std::int64_t steps_left = -1;  ///< -1: until cleared
  };
  /// The power of the joint damping and friction at the current state, W.
  double passive_power() const;

  /// A free scene object as a system of its own: a single free body (Model n = 0).
  struct ObjectBody {
    int index = 0;  ///< into object_specs_ / objects_
    std::unique_ptr<Model> model;
    State initial;
    double size = 0;  ///< smallest extent of its shape (m)
  };
  void note_fast_step(size_t j, double moved);
  /// set_objects without its constraint rebuild and reset; own_collision: the objects' own
  /// collision model (none when a scene collision follows).
  void place_objects(const std::vector<SceneObject>& objects, bool own_collision);
  void reset_objects();
  /// The constraint system the step needs (the scene's, or an empty one for free objects).
  void rebuild_constraints();
  /// The contacts of the objects' collision model at the current state (collision_data_);
  /// returns the deepest penetration (m, >= 0).
  double collide_objects();

  friend struct WorldEdit;
  /// The robot's index in world_models (0) or -1; objects by name (index into object_specs_).
  int object_index(const std::string& name) const;
  /// An object's body (index into bodies_) or -1 for a static one.
  int body_of(int object) const;
  /// Checks a new model name (unique, a frame name); throws std::invalid_argument.
  void check_new_name(const std::string& name) const;
  /// The edit that replaces the objects by `specs` (kept ones by name keep their states).
  WorldEditPtr prepare_objects(std::vector<SceneObject> specs) const;

  /// Robots 1.. (robot 0 is in the members below): each stepped by its own stepper, with its
  /// own joint-limit constraints.
  struct ExtraRobot {
    std::string name, ns;
    std::unique_ptr<Model> model;
    std::unique_ptr<Stepper> stepper;
    std::unique_ptr<ConstraintSystem> constraints, constraints_start;
    std::unique_ptr<ControllerSet> controllers;
    State initial, state, last_good;
    VecX command, actuation;
    const VecX* tau = &command;  ///< this step's generalized force (command or actuation)
    /// Per velocity coordinate: the step count from which its command no longer acts (the
    /// simulator's command_timeout, as robot 0's), and the least of them.
    std::vector<std::uint64_t> command_until;
    std::uint64_t next_expiry = std::numeric_limits<std::uint64_t>::max();
    VecX forces;    ///< tau plus its link wrenches (size nv), when some act on it
    double U0 = 0;  ///< potential energy at its initial state
    Data diag;
    explicit ExtraRobot(const Model& m) : diag(m) {}
  };
  /// Steps robots 1..; false (every extra robot back at its last good state, failure_ set) when
  /// one fails.
  bool step_extra_robots();
  void reset_extra_robots();
  /// Resets one robot 1.. to its initial state (reset_extra_robots does every one).
  void reset_extra_robot(ExtraRobot& r);
  /// Removes robot k >= 1 (a committed delete).
  void remove_robot(int k);
  /// commit() of a robot spawn or delete (src/sim/world.cpp).
  std::string commit_robot(WorldEdit& e);
  /// A robot 1.. built for add_robot or a spawn (its name checked by the caller): its stepper,
  /// its joint-limit and mimic constraints, its controllers. Touches nothing of the simulator.
  std::unique_ptr<ExtraRobot> make_extra_robot(const std::string& name, const std::string& ns,
                                               std::unique_ptr<Model> model, const State& initial,
                                               const std::vector<ControllerSpec>& controllers,
                                               bool joint_limits) const;
  /// A robot edit's new scene collision and constraint system: with the spawned robot e.extra
  /// (geometry g, meshes loaded, and Gazebo tags gz), or without robot k (src/sim/world.cpp).
  void with_robot_collision(const RobotSpawn& spawn, const GeometryModel& g, const GazeboTags& gz,
                            WorldEdit& e) const;
  void without_robot_collision(int k, WorldEdit& e) const;
  /// Swaps in a robot edit's scene collision and constraint system (when it has them).
  void swap_robot_collision(WorldEdit& e);
  /// Appends a robot built by make_extra_robot, at its initial state; returns its index.
  int insert_robot(std::unique_ptr<ExtraRobot> r);
  /// Robot 0's constraint system with the free objects `bodies` and `robots` (robots 1.., their
  /// joint limits as rows where `limits` says) in its contact step: rebuild_constraints' system
  /// for a world edit in a scene collision, anchored at the initial state (src/sim/world.cpp).
  std::unique_ptr<ConstraintSystem> coupled_constraints(const std::vector<const Model*>& bodies,
                                                        const std::vector<const Model*>& robots,
                                                        const std::vector<bool>& limits) const;
  /// Zeroes robot r's commands that ran out (command_timeout) before a step.
  void expire_commands(ExtraRobot& r) const;
  /// Robot k >= 1's generalized force of this step: tau, or tau plus its link wrenches in
  /// r.forces.
  const VecX* extra_robot_forces(ExtraRobot& r, int k, const VecX* tau);
  /// Rolls robots 1.. back to their last good states.
  void roll_back_extra_robots();
  ExtraRobot& extra(int k) const;
  /// Whether robots 1.. are in the scene collision (their contacts in robot 0's velocity step).
  bool coupled_robots() const;
  /// Coupled: every extra robot's force, free acceleration and state into extra_states_.
  void prepare_coupled_robots();
  /// Coupled, after robot 0's step: a robot a contact row touched moves with its new velocity,
  /// the others take their own step. False (info says why) when one fails.
  bool finish_coupled_robots(StepInfo& info);
  std::vector<std::unique_ptr<ExtraRobot>> extra_;
  std::vector<State> extra_states_;  ///< coupled steps: the robots' states (ConstraintStepInput)
  std::vector<VecX> extra_a_;        ///< and their free accelerations

  std::string robot_name_, robot_ns_;
  std::uint64_t world_generation_ = 0, spawned_ = 0, deleted_ = 0;
  std::unique_ptr<Model> model_;
  SimConfig config_;
  std::vector<SceneObject> object_specs_;
  std::vector<ObjectState> objects_;
  std::vector<ObjectBody> bodies_;
  std::vector<const Model*> body_models_;
  std::vector<State> body_states_, body_last_good_;
  std::vector<VecX> body_a_;
  /// The objects (free and static) and the ground as a collision model (the robot's own
  /// geometry is not in it yet: the contact spheres of the constraints stand for it).
  std::unique_ptr<CollisionModel> collision_;
  std::unique_ptr<SceneCollision> scene_collision_;  ///< set_scene_collision's (replaces it)
  CollisionModel* collider() const;
  std::vector<SE3> free_poses_;
  CollisionData collision_data_;
  std::vector<SE3> frame_poses_;  ///< frames 0..n the robot's bodies, n + 1 + j free object j
  bool contacts_fresh_ = false;   ///< collision_data_ is at the current state
  ConstraintSpec spec_;           ///< as set_constraints got it
  double penetration_ = 0, penetration_max_ = 0;
  std::uint64_t fast_steps_ = 0;
  std::string fast_step_warning_;
  std::unique_ptr<Stepper> stepper_;
  std::unique_ptr<ConstraintSystem> constraints_;
  std::unique_ptr<ConstraintSystem> constraints_start_;  ///< as set, to restart from on reset
  std::unique_ptr<ControllerSet> controllers_;
  std::vector<LinkWrench> wrenches_;    ///< capacity kMaxLinkWrenches, reserved once
  std::vector<LinkWrench> weightless_;  ///< set_links_without_gravity: their weight cancelled
  Data diag_;
  KineticEnergyBound energy_bound_;
  State initial_, state_, last_good_, last_checked_;
  VecX command_, actuation_, forces_;
  VecX held_;              ///< the controllers' efforts between updates (set_control_every)
  int control_every_ = 1;  ///< physics steps per controller update
  /// Per velocity coordinate: the step count from which its command no longer acts.
  std::vector<std::uint64_t> command_until_;
  std::uint64_t next_expiry_ = std::numeric_limits<std::uint64_t>::max();  ///< min of those
  double command_timeout_ = std::numeric_limits<double>::infinity();
  double time_ = 0, last_checked_time_ = 0;
  std::uint64_t steps_ = 0, substeps_ = 0, rejected_ = 0, evaluations_ = 0;
  std::uint64_t velocity_level_steps_ = 0, events_ = 0;
  std::uint64_t last_checked_steps_ = 0;
  int steps_to_energy_check_ = 1;  ///< the energy is checked on the step that takes it to 0
  std::string failure_;
  double T0_ = 0, U0_ = 0, E_ref_ = 1, energy_scale0_ = 0;
  double W_ = 0, W_checked_ = 0;  ///< work(), and its value at last_checked_
  /// Joints with damping (c = d) and with friction (c = f): the terms of passive_power().
  struct PassiveJoint {
    int k;
    double c;
  };
  std::vector<PassiveJoint> damped_, rubbing_;
  double passive_power_ = 0;  ///< passive_power() at state_
};

/// Adds to tau (size nv) the generalized force J^T w of a wrench w = [torque; force] (world
/// axes, torque about the point) acting at `point` (in the frame of Model::links[link]), J the
/// point's Jacobian: joint j on the link's path (world axis a through o_j) gets a . (N + (p - o_j)
/// x F) when revolute, a . F when prismatic; a free base the wrench moved to its origin, in its
/// frame. data holds forward_kinematics at the pose. O(depth), allocation-free.
void add_link_wrench_force(const Model& model, const Data& data, int link, const Vec3& point,
                           const Vec6& wrench, VecX& tau);

/// The scene's sensors, then those of the robot URDF's Gazebo tags (sensors_from_urdf on
/// urdf_xml, or on the scene's robot file) whose names the scene does not use; the URDF's
/// warnings into *warnings.
std::vector<SensorSpec> scene_sensors(const Scene& scene, const std::string& urdf_xml,
                                      std::vector<std::string>* warnings);
/// The same with the robot's URDF parsed (null: no URDF).
std::vector<SensorSpec> scene_sensors(const Scene& scene, const UrdfXml* urdf,
                                      std::vector<std::string>* warnings);
/// The URDF text of a scene's robot: urdf_xml when not empty, else the robot file's text ("" for
/// chain:N or no robot).
std::string scene_urdf_text(const Scene& scene, const std::string& urdf_xml = "");

/// Whether a scene's contact comes from the collision layer (scene_collision.h): it has
/// objects, self_collision, or ground: {from_collisions: true} (the robot's own collision
/// shapes, meshes included, on the ground). Otherwise contact is the `contacts:` spheres on the
/// ground plane of the constraint system.
bool uses_scene_collision(const Scene& scene);
/// Builds a simulator for a scene (urdf_xml as in scene_model): the model, its constraints
/// (joint limits on unless the scene turns them off), objects, the scene collision (when
/// uses_scene_collision) and controllers.
std::unique_ptr<Simulator> make_simulator(const Scene& scene, const std::string& urdf_xml = "");
/// Adds the scene's robots 1.. (Scene::extra_robots) to sim (make_simulator does). Throws
/// SceneError naming the scene and the `robots:` entry (a name in use, a bad controller).
void add_scene_robots(Simulator& sim, const Scene& scene);
/// The URDF's <gazebo reference="LINK"><gravity>false</gravity> links on sim
/// (Simulator::set_links_without_gravity) and its gazebo_ros_control controlPeriod
/// (Simulator::set_control_every, rounded to steps of dt); make_simulator does it. One line per
/// link it could not apply.
std::vector<std::string> set_gazebo_gravity(Simulator& sim, const std::string& urdf_xml);
/// The same from tags already read (UrdfDocument::gazebo, scene_model's gazebo).
std::vector<std::string> set_gazebo_gravity(Simulator& sim, const GazeboTags& tags);

// ------------------------------------------------------------------ `se3_dyn simulate`
/// Options of a headless run (the command line's `simulate`).
struct SimulateOptions {
  std::string model;            ///< MODEL.urdf or chain:N (with a scene: replaces its robot)
  bool floating = false;        ///< free base (with a scene: when it does not say base:)
  std::string scene;            ///< SCENE.yaml: robot, base, initial state, gravity, integrator, dt
  std::string integrator;       ///< "" = the scene's, else rkmk4
  double dt = 0;                ///< 0 = the scene's, else 0.001
  double duration = 1.0;        ///< simulated seconds; round(duration / dt) >= 1
  double tol = 0;               ///< rkmk45 tolerance; 0 = the scene's, else 1e-6
  unsigned seed = 1;            ///< random initial state (model runs, or random_initial)
  bool random_initial = false;  ///< with a scene: random state instead of the scene's
  bool has_gravity = false;     ///< override gravity with `gravity`
  Vec3 gravity = Vec3(0, 0, -9.81);
  /// Trajectory file ("" = none): t, base pose and twist, q:, v:, energies, then every free
  /// object's pose and twist (obj:NAME:x ... obj:NAME:vz; docs/design.md).
  std::string out_csv;
  /// Most body-steps (steps x bodies; an adaptive stepper's internal steps count) of the run.
  double max_body_steps = limits::kMaxBodySteps;
};

/// The figures `se3_dyn simulate --json` prints. NaN where a figure does not apply (print null).
struct SimulateResult {
  std::string integrator;
  double dt = 0;
  double sim_s = 0;   ///< simulated time reached
  double wall_s = 0;  ///< wall time of the steps only (diagnostics and output excluded)
  std::uint64_t steps = 0;
  /// max |E(t) - E(0)| / S, potential measured from the initial configuration (damping and
  /// friction count as drift), S = energy_drift_scale: max(T(0), M |g| L, max_t T(t)) (a run
  /// from rest is not divided by T(0) = 0); NaN if S = 0.
  double energy_drift_rel = std::numeric_limits<double>::quiet_NaN();
  /// max |E(t) - E(0) - W(t)| / S (same scale): the drift alone, W the work of commands,
  /// damping and friction (Simulator::work); energy_drift_rel counts dissipation as drift.
  double energy_balance_rel = std::numeric_limits<double>::quiet_NaN();
  /// max |h(t) - h(0)| / |h(0)| (world-frame spatial momentum); free base and zero gravity only.
  double momentum_drift_rel = std::numeric_limits<double>::quiet_NaN();
  /// max over the run of Simulator::constraint_error() (scenes with constraints; else NaN).
  double constraint_error_max = std::numeric_limits<double>::quiet_NaN();
  /// max |c(t) - c(0) - t p(0) / m| of the centre of mass in m, p the linear momentum (free
  /// base and zero gravity; else NaN): the centre of mass moves uniformly.
  double com_drift_max = std::numeric_limits<double>::quiet_NaN();
  std::uint64_t substeps = 0, rejected = 0, evaluations = 0;
  /// Steps taken by the contact scheme (the rest by the integrator), and joint-limit impacts
  /// located inside steps; `integrator` names the schemes that took steps (schemes_used).
  std::uint64_t velocity_level_steps = 0, events = 0;
  bool diverged = false;
  /// The run was stopped at SimulateOptions::max_body_steps (adaptive internal steps).
  bool stopped = false;
  std::string status;  ///< why the run ended early ("" when it completed)
  /// Scenes with objects: every object's final state (Scene::objects order), for the JSON's
  /// "objects" key (twist in the object's frame).
  struct FinalObject {
    std::string name;
    SE3 pose;
    Vec6 twist = Vec6::Zero();
  };
  std::vector<FinalObject> objects;
  /// Deepest contact penetration over the run (m), Simulator::penetration_max(); NaN (null) for
  /// a scene without contact (no objects, no ground, no contact points).
  double penetration_max = std::numeric_limits<double>::quiet_NaN();
  /// Simulator::fast_steps(): object-steps that moved farther than the object's size (possible
  /// tunnelling; the first is described in a warning on stderr).
  std::uint64_t fast_steps = 0;
};

/// Runs a scene or model headless with zero commanded torques (a model and a scene together: the
/// model replaces the scene's robot). Throws SceneError, ModelError or std::invalid_argument on
/// bad input, and on a run beyond limits::kMaxSteps or kMaxBodySteps (refused before anything is
/// built or stepped); a divergence ends the run early with diverged = true.
SimulateResult simulate_headless(const SimulateOptions& options);
/// One-line JSON object of the `simulate --json` keys (docs/design.md; NaN printed as null),
/// "penetration_max", "fast_steps", "objects" (scenes with objects: {"NAME": {"position": [x,y,z],
/// "orientation": [x,y,z,w], "twist": [wx,wy,wz,vx,vy,vz]}}), and "diverged" (true/false) and
/// "status" (why the run ended early, or null).
std::string simulate_result_json(const SimulateResult& r);
/// The steps by scheme as JSON members, e.g. "rkmk4": 9800, "contact_semi_implicit": 200.
std::string steps_by_scheme(const SimulateResult& r);

}  // namespace se3
