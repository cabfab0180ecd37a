// Joint controllers run inside the simulator at every physics step, with ros_control's
// conventions (the `effort_controllers` package and control_toolbox's Pid), but no roscpp: the
// sim layer reads their configuration from a YAML tree of ros_control's shape and the ROS layer
// feeds them commands.
//
// Configuration, one map entry per controller (the YAML a Gazebo user already has):
//   NAME:
//     type: effort_controllers/JointGroupPositionController   (or one of the types below)
//     joints: [j1, j2]            group controllers
//     joint: j1                   single-joint controllers
//     pid: {p: 100, i: 0, d: 10, i_clamp: 0}       gains of every joint (single-joint: its gains)
//     j1: {pid: {p: 100, d: 10}}                   gains of one joint (overrides pid:)
//     gains: {j1: {p: 100, d: 10}}                 ros_controllers' spelling of the same
// Types (effort_controllers/...): JointGroupEffortController and JointEffortController pass the
// commanded effort through; JointGroupPositionController and JointPositionController track a
// position, JointVelocityController a velocity, with a PID. joint_state_controller/
// JointStateController is accepted and does nothing (the simulator always publishes
// joint_states). Every effort is clamped to the joint's URDF effort limit.
//
// PID (control_toolbox): e = target - measured; p_term = p e; the integral I += e dt, and
// i_term = i I clamped to [i_clamp_min, i_clamp_max] (without antiwindup) or I itself clamped to
// [i_clamp_min / i, i_clamp_max / i] (antiwindup: true); d_term = d (e - e_last) / dt. The
// clamp is i_clamp_max = |i_clamp|, i_clamp_min = -|i_clamp| unless given on its own, and it is
// 0 by default: without an i_clamp the integral term stays 0, as in control_toolbox. p is
// required for PID types; i, d default to 0. A non-finite error gives 0, as there.
//
// Position errors (ros_controllers): a revolute joint with limits clamps the target into them
// and takes target - q; a continuous joint (no limits) takes the shortest angle; a prismatic
// joint target - q. After a reset a position controller holds the positions it starts from
// (ros_control's starting()), velocity and effort commands are 0.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "se3_sim/dynamics.h"

namespace YAML {
class Node;
}

namespace se3 {

/// Thrown for a controller configuration that cannot be used; the message names the controller
/// and the key.
struct ControllerError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// control_toolbox's Pid gains.
struct PidGains {
  double p = 0, i = 0, d = 0;
  double i_clamp_min = 0, i_clamp_max = 0;
  bool antiwindup = false;
};

/// control_toolbox's Pid (computeCommand with and without a given error derivative).
class Pid {
 public:
  Pid() = default;
  explicit Pid(const PidGains& g) : gains_(g) {}
  const PidGains& gains() const { return gains_; }
  void set_gains(const PidGains& g) { gains_ = g; }
  /// Clears the integral and the last error.
  void reset();
  /// The command for error e over a period dt, the derivative from the last error.
  double compute(double error, double dt);
  /// The command with a given error derivative.
  double compute(double error, double error_dot, double dt);
  double integral() const { return i_error_; }

 private:
  PidGains gains_;
  double p_error_last_ = 0, i_error_ = 0, d_error_ = 0;
};

enum class ControllerKind {
  GroupEffort,    ///< effort_controllers/JointGroupEffortController
  GroupPosition,  ///< effort_controllers/JointGroupPositionController
  Effort,         ///< effort_controllers/JointEffortController
  Position,       ///< effort_controllers/JointPositionController
  Velocity,       ///< effort_controllers/JointVelocityController
  JointState,     ///< joint_state_controller/JointStateController (does nothing here)
};

/// One controller's configuration, as read from YAML (joints by name; not yet bound to a model).
struct ControllerSpec {
  std::string name;
  std::string type;  ///< as written, e.g. "effort_controllers/JointGroupPositionController"
  ControllerKind kind = ControllerKind::GroupEffort;
  std::vector<std::string> joints;  ///< one for single-joint types
  std::vector<PidGains> gains;      ///< per joint (PID types), else empty
};

/// The kind of a type name; throws ControllerError for a type this simulator does not run.
ControllerKind controller_kind(const std::string& type, const std::string& controller);
/// True for the kinds that take one joint and a std_msgs/Float64 command.
bool single_joint(ControllerKind kind);
/// True for position and velocity kinds (they need gains).
bool uses_pid(ControllerKind kind);

/// Whether name can name a controller: its topic NAME/command and parameters NAME/... are ROS
/// names relative to the controllers' namespace (ros::names::validate's rules, without the
/// leading '/' or '~' that would move them out of it): an ASCII letter, then letters, digits,
/// '_' or '/' (no "//", no '/' at the end).
bool is_controller_name(const std::string& name);
/// "" for a good controller name, else why not (one phrase, the name quoted at most 60 bytes).
std::string controller_name_problem(const std::string& name);

/// One controller from its YAML map (NAME: {type: ..., ...}). Throws ControllerError naming
/// `where` (a file or "scene x.yaml"), the controller and the key.
ControllerSpec parse_controller(const std::string& name, const YAML::Node& node,
                                const std::string& where = "controllers");
/// Controllers from a YAML map {NAME: {...}, ...}: the ones named in `names` (in that order; a
/// missing name is an error), or every entry when `names` is empty.
std::vector<ControllerSpec> parse_controllers(const YAML::Node& map,
                                              const std::vector<std::string>& names = {},
                                              const std::string& where = "controllers");
/// The same from YAML text (a controller_config file's contents).
std::vector<ControllerSpec> parse_controllers_text(const std::string& yaml_text,
                                                   const std::vector<std::string>& names = {},
                                                   const std::string& where = "controllers");

/// Controllers bound to a model: joint indices resolved, commands and PID states preallocated,
/// so update() allocates nothing.
class ControllerSet {
 public:
  /// Throws ControllerError for a joint not in the model (or locked), a joint claimed by two
  /// controllers (ros_control refuses that too), or two controllers of one name.
  ControllerSet(const Model& model, const std::vector<ControllerSpec>& specs);

  int size() const { return static_cast<int>(ctl_.size()); }
  const ControllerSpec& spec(int c) const { return ctl_[c].spec; }
  /// Index of a controller by name, or -1.
  int find(const std::string& name) const;
  /// Number of values controller c's command holds (its joints).
  int command_size(int c) const { return static_cast<int>(ctl_[c].joint.size()); }
  /// Sets controller c's command (positions, velocities or efforts of its joints, in its joint
  /// order). Returns "" when taken, else the reason it was refused (wrong length, a non-finite
  /// value); a refused command changes nothing.
  std::string set_command(int c, const double* values, size_t n);
  const std::vector<double>& command(int c) const { return ctl_[c].command; }
  /// True when joint i (1..n) is driven by a controller.
  bool controls(int i) const { return owner_[i] >= 0; }

  /// Every controller's effort at state x over a period dt, added to tau (size nv, the model's
  /// velocity coordinates) on the joints they drive, the sum clamped to the URDF effort limit;
  /// the other entries are left as they are.
  void update(const State& x, double dt, VecX& tau);
  /// ros_control's starting(): position controllers hold x's positions, other commands 0, PID
  /// states cleared.
  void reset(const State& x);

 private:
  struct Ctl {
    ControllerSpec spec;
    std::vector<int> joint;  ///< body indices 1..n
    std::vector<double> command;
    std::vector<Pid> pid;
  };
  double position_error(int i, double target, double q) const;
  const Model& model_;
  std::vector<Ctl> ctl_;
  std::vector<int> owner_;  ///< per body: controller index or -1
};

}  // namespace se3
