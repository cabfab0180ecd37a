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
//
// Hardware interfaces (gazebo_ros_control's DefaultRobotHWSim): effort_controllers/* write an
// effort. position_controllers/* and velocity_controllers/* write a position or a velocity,
// which a PID of the interface turns into an effort: e = position error (as above) or
// v_cmd - v, effort = PID(e) with the derivative from the last error, clamped to the effort
// limit. Its gains are the joint's /gazebo_ros_control/pid_gains/JOINT (set_interface_gains),
// else the controller's own pid/gains when the type has no other use for them
// (position_controllers/*, velocity_controllers/JointVelocityController and
// JointGroupVelocityController); a joint with neither is an error (gazebo_ros_control would
// then set the joint's state directly, which a dynamics simulator does not do).
//
// JointTrajectoryController (ros_controllers' joint_trajectory_controller, trajectory.h for the
// sampling): desired position, velocity and acceleration sampled at every step; the effort
// flavour writes PID(e_pos, e_vel) (gains: required), the velocity flavour
// velocity_ff * v_des + PID(e_pos, e_vel) to the velocity interface, the position flavour the
// desired position to the position interface. YAML keys:
//     joints: [...]
//     gains: {j1: {p: 100, i: 0, d: 10, i_clamp: 1}, ...}   (effort and velocity flavours)
//     velocity_ff: {j1: 1.0}                                 (velocity flavour, default 0)
//     constraints: {goal_time: 0.5, stopped_velocity_tolerance: 0.01,
//                   j1: {trajectory: 0.1, goal: 0.05}}      (0: not checked)
//     state_publish_rate: 50, action_monitor_rate: 20, stop_trajectory_duration: 0,
//     allow_partial_joints_goal: false
#pragma once

#include <limits>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "se3_sim/dynamics/dynamics.h"
#include "se3_sim/sim/trajectory.h"

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
  GroupPosition,  ///< {effort,position}_controllers/JointGroupPositionController
  Effort,         ///< effort_controllers/JointEffortController
  Position,       ///< {effort,position}_controllers/JointPositionController
  Velocity,       ///< {effort,velocity}_controllers/JointVelocityController
  GroupVelocity,  ///< velocity_controllers/JointGroupVelocityController
  Trajectory,     ///< {effort,velocity,position}_controllers/JointTrajectoryController
  JointState,     ///< joint_state_controller/JointStateController (does nothing here)
};

/// The hardware interface a controller writes (hardware_interface::*JointInterface).
enum class JointInterface { Effort, Velocity, Position };
/// "EffortJointInterface", "VelocityJointInterface", "PositionJointInterface".
const char* interface_name(JointInterface iface);

/// A trajectory controller's `constraints`: per joint position tolerances along the way
/// (`trajectory`) and at the end (`goal`), 0 meaning not checked.
struct TrajectoryConstraints {
  double goal_time = 0;                      ///< s after the last point (0: no limit)
  double stopped_velocity_tolerance = 0.01;  ///< rad/s or m/s at the goal (0: not checked)
  std::vector<double> trajectory, goal;      ///< per joint
};

/// One controller's configuration, as read from YAML (joints by name; not yet bound to a model).
struct ControllerSpec {
  std::string name;
  std::string type;  ///< as written, e.g. "effort_controllers/JointGroupPositionController"
  ControllerKind kind = ControllerKind::GroupEffort;
  JointInterface iface = JointInterface::Effort;  ///< the interface the type writes
  std::vector<std::string> joints;                ///< one for single-joint types
  std::vector<PidGains> gains;  ///< per joint (PID types; may be empty where optional)
  /// Per joint: the interface's PID (/gazebo_ros_control/pid_gains/JOINT), when set.
  std::vector<std::optional<PidGains>> interface_gains;
  // JointTrajectoryController only
  TrajectoryConstraints constraints;
  std::vector<double> velocity_ff;  ///< per joint (velocity flavour)
  double state_publish_rate = 50, action_monitor_rate = 20, stop_trajectory_duration = 0;
  bool allow_partial_joints_goal = false;
  /// Where it was read ("file:line" of its entry; "" when built in code), and each joint's
  /// entry: binding errors (ControllerSet) name them.
  std::string where;
  std::vector<std::string> joint_where;
};

/// The kind of a type name; throws ControllerError for a type this simulator does not run, naming
/// it and listing the ones it runs.
ControllerKind controller_kind(const std::string& type, const std::string& controller);
/// The hardware interface a type writes (its package: effort_, velocity_, position_controllers).
JointInterface controller_interface(const std::string& type);
/// Every type this simulator runs, comma-separated.
std::string supported_controller_types();
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

/// gazebo_ros_control's `pid_gains` map {JOINT: {p, i, d, i_clamp}, ...}.
std::map<std::string, PidGains> parse_interface_gains(const YAML::Node& map,
                                                      const std::string& where = "pid_gains");
/// Sets every position- and velocity-interface joint's interface_gains from the map.
void set_interface_gains(std::vector<ControllerSpec>& specs,
                         const std::map<std::string, PidGains>& by_joint);

/// A trajectory (trajectory_msgs/JointTrajectory without ROS): points in time from `start`.
struct TrajectoryCommand {
  std::vector<std::string> joint_names;
  /// Simulated time of time_from_start 0; NaN: now (a header.stamp of zero).
  double start = std::numeric_limits<double>::quiet_NaN();
  struct Point {
    double time_from_start = 0;
    std::vector<double> positions, velocities, accelerations;  ///< per joint; v, a may be empty
  };
  std::vector<Point> points;
};

/// Where a trajectory controller stands (ros_controllers' action results, without the action).
enum class TrajectoryStatus {
  Idle,                   ///< holding a position (no trajectory since the start or a reset)
  Active,                 ///< following a trajectory
  Succeeded,              ///< past the last point, within the goal tolerances
  PathToleranceViolated,  ///< a joint left its `trajectory` tolerance: stopped
  GoalToleranceViolated,  ///< not within the `goal` tolerances goal_time after the last point
};
const char* status_name(TrajectoryStatus s);

/// A trajectory controller's state at its last update (control_msgs'
/// JointTrajectoryControllerState): per joint.
struct TrajectoryState {
  std::vector<double> desired_q, desired_v, desired_a, actual_q, actual_v, error_q, error_v;
  TrajectoryStatus status = TrajectoryStatus::Idle;
  int status_joint = -1;  ///< the joint (index into joints) a violation names
  double time = 0;        ///< simulated time of the last update
  double end_time = 0;    ///< simulated time of the last point
};

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

  /// Every controller's effort at state x and simulated time t over a period dt, added to tau
  /// (size nv, the model's velocity coordinates) on the joints they drive, the sum clamped to
  /// the URDF effort limit; the other entries are left as they are. Allocates nothing.
  void update(const State& x, double t, double dt, VecX& tau);
  /// ros_control's starting(): position controllers hold x's positions (trajectory controllers
  /// hold them as their trajectory), other commands 0, PID states cleared.
  void reset(const State& x);

  /// Gives trajectory controller c a new trajectory at simulated time `now` (not inside a step:
  /// this allocates). It replaces the rest of the current one from its start time (or now, if
  /// later): the new motion starts from the current desired position, velocity and
  /// acceleration there, continuous in position and velocity; points at or before that time are
  /// dropped; joints it does not name keep their trajectory (allow_partial_joints_goal). No
  /// points: stop (hold, ramping down over stop_trajectory_duration). Returns "" when taken,
  /// else the reason it was refused (nothing changed).
  std::string set_trajectory(int c, const TrajectoryCommand& cmd, double now);
  /// Trajectory controller c's desired position, velocity, acceleration of its joint j at time
  /// t (the splines as they stand).
  void sample(int c, int j, double t, double& q, double& v, double& a) const;
  /// Trajectory controller c's state at its last update.
  const TrajectoryState& trajectory_state(int c) const { return ctl_[c].state; }

 private:
  /// One joint's trajectory: segments in time order; sampling past a segment's end holds its
  /// end position (zero velocity) when it ends its trajectory, else evaluates its end.
  struct Track {
    std::vector<double> t0;
    std::vector<Spline> seg;
  };
  struct Ctl {
    ControllerSpec spec;
    std::vector<int> joint;  ///< body indices 1..n
    std::vector<double> command;
    std::vector<Pid> pid;  ///< the controller's PID (effort_controllers, trajectory)
    std::vector<Pid> hw;   ///< the interface's PID (position and velocity interfaces)
    std::vector<Track> track;
    TrajectoryState state;
  };
  double position_error(int i, double target, double q) const;
  void hold(Ctl& c, int j, double q, double t);
  void stop(Ctl& c, double now);
  void check_tolerances(Ctl& c, double t);
  const Model& model_;
  std::vector<Ctl> ctl_;
  std::vector<int> owner_;  ///< per body: controller index or -1
};

}  // namespace se3
