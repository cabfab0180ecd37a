// The simulator node (simulator_node.h; interface in docs/ros.md).
#include "se3_sim/ros/simulator_node.h"

#include <geometry_msgs/WrenchStamped.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/JointState.h>
#include <std_msgs/Float64.h>
#include <std_msgs/Float64MultiArray.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>
#include <trajectory_msgs/JointTrajectory.h>
#include <visualization_msgs/MarkerArray.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <map>
#include <mutex>
#include <thread>

#include "se3_sim/ApplyWrench.h"
#include "se3_sim/ChainState.h"
#include "se3_sim/ConstraintForces.h"
#include "se3_sim/ContactsState.h"
#include "se3_sim/JointTorques.h"
#include "se3_sim/SetState.h"
#include "se3_sim/SimStats.h"
#include "se3_sim/Step.h"
#include "se3_sim/lie/format.h"
#include "se3_sim/model/limits.h"
#include "se3_sim/ros/controller_states.h"
#include "se3_sim/ros/convert.h"
#include "se3_sim/ros/params.h"
#include "se3_sim/ros/rendered_sensors.h"
#include "se3_sim/ros/robot_interfaces.h"
#include "se3_sim/ros/robot_sensors.h"
#include "se3_sim/ros/sim_markers.h"
#include "se3_sim/ros/simulator_config.h"
#include "se3_sim/ros/world_services.h"
#include "se3_sim/sim/gain_check.h"
#include "se3_sim/sim/ground.h"
#include "se3_sim/sim/scene_collision.h"
#include "se3_sim/sim/sim.h"
#include "se3_sim/sim/transmissions.h"

namespace se3_ros {

namespace {

using Clock = std::chrono::steady_clock;

double seconds(Clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

// A robot file (se3::read_file: regular files only, never blocking on a FIFO).
std::string read_file(const std::string& path) {
  std::string text, why;
  if (!se3::read_file(path, text, &why, se3::limits::kMaxUrdfBytes)) {
    throw std::runtime_error("cannot read URDF file '" + path + "': " + why);
  }
  return text;
}

// A step request slice holds the simulator at most this long before the node publishes and
// serves again.
constexpr double kSliceSeconds = 0.002;

// A mutex taken in the order asked for (a ticket lock). The main loop lets go of the simulator
// between the slices of a step request and at once wants it back; std::mutex may hand it back to
// the loop again and again while a service callback waits (answers took up to 4 s). In turn,
// every waiting callback gets the simulator before the loop's next slice.
class TurnMutex {
 public:
  void lock() {
    std::unique_lock<std::mutex> l(m_);
    const std::uint64_t ticket = next_++;
    turn_.wait(l, [&] { return serving_ == ticket; });
  }
  void unlock() {
    {
      std::lock_guard<std::mutex> l(m_);
      ++serving_;
    }
    turn_.notify_all();
  }

 private:
  std::mutex m_;
  std::condition_variable turn_;
  std::uint64_t next_ = 0, serving_ = 0;
};

}  // namespace

class SimulatorNodeImpl {
 public:
  SimulatorNodeImpl() : pnh_("~") {}

  bool init();
  void run();

 private:
  // ---- setup
  void configure();
  void set_initial_positions(const std::vector<std::pair<std::string, double>>& values);
  void setup_controllers();

  // ---- commands
  void on_torques(const ros::MessageEvent<se3_sim::JointTorques const>& event);
  void on_group_command(int c, const std_msgs::Float64MultiArray::ConstPtr& msg);
  void on_single_command(int c, const std_msgs::Float64::ConstPtr& msg);
  void on_trajectory(int c, const trajectory_msgs::JointTrajectory::ConstPtr& msg);
  void controller_command(int c, const double* values, size_t n);
  /// Under mu_: after an accepted command, lockstep's advance and state.
  void after_command();
  void reject(const std::string& what, const std::string& why);
  void count_drops(const std::string& publisher, std::uint32_t seq);

  // ---- services
  bool on_reset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  bool on_pause(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  bool on_resume(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  bool on_step(se3_sim::Step::Request& req, se3_sim::Step::Response& res);
  bool on_set_state(se3_sim::SetState::Request& req, se3_sim::SetState::Response& res);
  bool on_apply_wrench(se3_sim::ApplyWrench::Request& req, se3_sim::ApplyWrench::Response& res);
  bool on_clear_wrenches(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);

  // ---- stepping (under mu_)
  bool physics_step();
  void run_step_slice();
  void end_step_request(bool ok, const std::string& why);

  // ---- publishing
  ros::Time stamp() const;
  /// Under mu_: joint_states, /tf, chain_state (and /clock).
  void publish_state();
  void publish_clock();
  /// Under mu_: each trajectory controller's NAME/state at its state_publish_rate (simulated
  /// time), and a log line when its status changes.
  void publish_controller_states();
  /// Under mu_: sim_stats, markers, constraint forces.
  void publish_stats_and_markers(Clock::time_point now);
  /// Under mu_: the sensors' readings that are ready (after physics_step).
  void publish_sensors();
  /// The sensors of the scene and the URDF's Gazebo tags, their publishers and frames.
  void setup_sensors(const std::string& urdf_xml);

  ros::NodeHandle nh_, pnh_, ctl_nh_;
  SimulatorConfig config_;  ///< the private parameters (simulator_config.h)
  ros::Publisher joint_pub_, chain_pub_, stats_pub_, marker_pub_, clock_pub_, constraint_pub_;
  ros::Subscriber cmd_sub_;
  std::vector<ros::Subscriber> ctl_subs_;
  std::unique_ptr<ControllerStates> ctl_states_;  ///< trajectory controllers' NAME/state
  std::string urdf_text_;  ///< the robot's URDF (transmissions, sensors), "" for chain:N
  std::unique_ptr<se3::UrdfXml> urdf_tree_;  ///< urdf_text_ parsed, for both
  std::vector<ros::ServiceServer> services_;
  std::unique_ptr<tf2_ros::TransformBroadcaster> tf_;
  std::unique_ptr<tf2_ros::StaticTransformBroadcaster> tf_static_;

  TurnMutex mu_;
  std::condition_variable_any step_done_;
  se3::Scene scene_;
  std::unique_ptr<se3::Simulator> sim_;
  const se3::Model* model_ = nullptr;  ///< the simulator's (immutable after init)
  JointTable joints_;
  TfTree tree_;
  std::string world_frame_ = "world";
  std::string robot_source_;  ///< where the robot came from, for the log
  double rtf_ = 1.0, rate_ = 100.0, command_timeout_ = 0.5;
  double max_wrench_ = 1e4, max_effort_ = 1e4;
  bool use_sim_time_ = false;
  bool lockstep_ = false;
  int lockstep_steps_ = 1;
  bool paused_ = false;
  std::string status_;

  // A simulator/step request run by the main loop in slices; the answer goes to the waiting
  // service call's own result.
  struct StepResult {
    bool finished = false, ok = false;
    std::string message;
  };
  struct StepRequest {
    bool active = false;
    std::uint64_t remaining = 0, done = 0;
    StepResult* result = nullptr;
  } request_;

  std::atomic<std::uint64_t> accepted_{0}, rejected_{0}, dropped_{0};
  std::map<std::string, std::uint32_t> last_seq_;  ///< per torque_command publisher
  Clock::time_point anchor_, period_start_;
  std::uint64_t anchored_ = 0;  ///< steps taken since anchor_
  std::uint64_t period_steps_ = 0;
  Clock::duration step_wall_{0};
  double T_max_ = 0, energy_time_ = 0;
  bool fast_warned_ = false;  ///< largest kinetic energy seen at a publication
  se3::VecX effort_;
  std::vector<se3::SE3> links_;
  sensor_msgs::JointState js_;
  se3_sim::ChainState cs_;
  std::vector<geometry_msgs::TransformStamped> tfs_;
  TorqueCommand torque_;
  // Sensors (docs/ros.md, "Sensors"): one publisher and frame_id each.
  std::unique_ptr<se3::SensorSet> sensors_;
  std::unique_ptr<se3_ros::RenderedSensors> rendered_;  ///< cameras and lasers
  std::vector<ros::Publisher> sensor_pubs_;
  std::vector<std::string> sensor_frames_;
  std::vector<geometry_msgs::TransformStamped> sensor_tfs_;  ///< link -> sensor frame (static)
  std::string urdf_xml_;
  std::unique_ptr<WorldServices> world_;  ///< simulator/spawn_entity etc., model_states
  void setup_world_services();
  /// The scene's robots 1.. (robot_interfaces.h): their topics under their namespaces.
  std::unique_ptr<RobotInterfaces> robots_;
};

// ------------------------------------------------------------------ setup

void SimulatorNodeImpl::configure() {
  config_ = read_simulator_config(NodeParams(pnh_));
  const SimulatorConfig& c = config_;
  // The robot: ~urdf_file (sim.launch's robot:=), else robot_description (loaded by the user,
  // e.g. xacro's output; sim.launch empties it unless use_robot_description), else the scene's
  // robot. ~urdf_file (robot:=) wins over the robot_description sim.launch loaded from it.
  const std::string& urdf_file = c.urdf_file;
  std::string urdf_xml =
      urdf_file.empty() ? get_text(nh_, "robot_description").value_or("") : read_file(urdf_file);
  const bool had_description = urdf_file.empty() && !urdf_xml.empty();
  const std::string scene_path = c.scene.empty() ? "" : scene_file(c, !urdf_xml.empty());
  if (!scene_path.empty()) scene_ = se3::load_scene(scene_path);
  // Relative mesh names: beside ~urdf_file (robot:=), or in robot_description_dir when the
  // robot_description was loaded by the user; the renderer reads the same parameter.
  if (had_description) {
    scene_.urdf_dir = get_text(nh_, "robot_description_dir").value_or("");
  } else {
    const std::string& robot = !urdf_xml.empty() ? urdf_file : scene_.robot_path;
    const std::size_t slash = robot.find_last_of('/');
    const std::string dir = slash == std::string::npos ? std::string(".") : robot.substr(0, slash);
    if (!urdf_xml.empty()) scene_.urdf_dir = dir;
    nh_.setParam("robot_description_dir", dir);
  }
  // A scene of objects alone runs without a robot (an empty one: a fixed base without mass).
  const bool objects_only =
      urdf_xml.empty() && scene_.robot_path.empty() && !scene_.objects.empty();
  if (urdf_xml.empty() && scene_.robot_path.empty() && !objects_only) {
    throw std::runtime_error(
        "no robot: give robot:=FILE.urdf, load robot_description, or a scene that names a robot "
        "(scene:=satellite_arm)" +
        (scene_path.empty() ? std::string() : "; scene " + scene_path + " names none"));
  }
  robot_source_ = objects_only ? "no robot, the scene's objects only"
                  : !urdf_xml.empty()
                      ? (had_description ? "robot_description" : "~urdf_file " + urdf_file)
                      : "the scene's robot " + scene_.robot;
  // The generic defaults (docs/design.md, "Launch files") and the overrides (set and not "";
  // sim.launch always sets them, "" meaning the scene's).
  apply_scene_overrides(c, scene_);
  const auto& initial = c.initial_positions;
  command_timeout_ = c.command_timeout;
  world_frame_ = c.world_frame;
  lockstep_ = c.lockstep;
  max_wrench_ = c.max_wrench;
  max_effort_ = c.max_effort;
  use_sim_time_ = get_bool(nh_, "/use_sim_time").value_or(false);
  lockstep_steps_ = lockstep_steps(c, scene_.dt);

  sim_ = se3::make_simulator(scene_, urdf_xml);
  urdf_xml_ = urdf_xml;
  sim_->set_command_timeout(command_timeout_);
  model_ = &sim_->model();
  const se3::Model& m = *model_;
  for (const auto& w : m.warnings) ROS_WARN("simulator: %s", w.c_str());
  const std::string ground =
      se3::ground_ignores_robot_warning(scene_, !(urdf_xml.empty() && scene_.robot_path.empty()));
  if (!ground.empty()) ROS_WARN("simulator: %s", ground.c_str());
  set_initial_positions(initial);
  const std::string deep = sim_->deep_penetration_warning();
  if (!deep.empty()) ROS_WARN("simulator: %s", deep.c_str());
  if (m.floating && !m.links.empty() && m.links[0].name == world_frame_) {
    throw std::runtime_error("the free base's root link is named '" + world_frame_ +
                             "', as the world frame: give world_frame:=<another name>");
  }
  rtf_ = scene_.real_time_factor;
  rate_ = scene_.publish_rate;
  if (!had_description) {
    // Others (renderer, teleop, robot_state_publisher) read the robot from robot_description.
    const se3::GeometryModel chain = se3::chain_geometry(m);  // chain:N has no file
    // A scene of objects: the empty robot's URDF (its one link is the world frame), so that the
    // renderer finds a description and frames the objects' markers.
    const std::string text = !urdf_xml.empty() ? urdf_xml
                             : objects_only || scene_.robot_path.compare(0, 6, "chain:") == 0
                                 ? se3::model_to_urdf(m, objects_only ? nullptr : &chain)
                                 : read_file(scene_.robot_path);
    nh_.setParam("robot_description", text);
  }
  joints_ = joint_table(m, scene_.locked_joints);
  tree_ = tf_tree(m, world_frame_);
  urdf_text_ = !urdf_xml.empty() ? urdf_xml
               : scene_.robot_path.empty() || scene_.robot_path.compare(0, 6, "chain:") == 0
                   ? std::string()
                   : read_file(scene_.robot_path);
  urdf_tree_ = std::make_unique<se3::UrdfXml>(urdf_text_);
  setup_controllers();
  // The scene's objects (free and static; make_simulator set them and their contact): on /tf
  // (a frame each, parent the world) and on sim_markers (namespace objects).
  for (const se3::SceneObject& o : scene_.objects) {
    if (m.link_index(o.name) >= 0 || o.name == world_frame_) {
      throw std::runtime_error("scene object '" + o.name +
                               "' has the name of a robot link or of the world frame");
    }
  }
  const se3::Vec3 g = m.gravity;
  ROS_INFO(
      "simulator: %s (%s), scene %s: %d joints, %s base, gravity [%g %g %g], joint limits %s, "
      "%s, dt %g s, real-time factor %g, publishing at %g Hz%s",
      m.name.c_str(), robot_source_.c_str(),
      scene_.name.empty() ? scene_path.c_str() : scene_.name.c_str(), m.n,
      m.floating ? "free" : "fixed", g.x(), g.y(), g.z(),
      scene_.constraints.joint_limits ? "on" : "off",
      sim_->constraints() && sim_->constraints()->has_unilateral()
          ? "velocity-level time stepping (limits or contact)"
          : sim_->integrator().c_str(),
      sim_->dt(), rtf_, rate_,
      lockstep_ ? (", lockstep: " + std::to_string(lockstep_steps_) + " steps per command").c_str()
                : "");
}

// ~initial_positions (a YAML map joint: value) over the scene's, then every joint inside its
// limits when they are on (the zero configuration of a real URDF may lie outside them: such a
// joint starts at its nearest limit, with one warning).
void SimulatorNodeImpl::set_initial_positions(
    const std::vector<std::pair<std::string, double>>& values) {
  const se3::Model& m = *model_;
  se3::State x = sim_->state();
  for (const auto& kv : values) {
    const int i = m.joint_index(kv.first);
    if (i < 1) {
      throw std::runtime_error("~initial_positions names joint '" + kv.first + "', which " +
                               m.name + " does not move");
    }
    x.q[i - 1] = kv.second;
  }
  if (scene_.constraints.joint_limits) {
    std::string clamped;
    for (int i = 1; i <= m.n; ++i) {
      const double q = std::clamp(x.q[i - 1], m.lower[i], m.upper[i]);
      if (q != x.q[i - 1]) {
        clamped += (clamped.empty() ? "" : ", ") + m.joint_name[i];
        x.q[i - 1] = q;
      }
    }
    if (!clamped.empty()) {
      ROS_WARN(
          "simulator: the initial position of %s lies outside its URDF limits: starts at the "
          "nearest limit",
          clamped.c_str());
    }
  }
  if (!values.empty() || scene_.constraints.joint_limits) {
    x.base = se3::base_on_ground(scene_, m, x, urdf_xml_);  // the new pose's lowest shape on it
    sim_->set_initial_state(x);
    sim_->reset();
    // Constraints anchor at (and project) the new initial state; controllers are set after.
    if (!scene_.constraints.empty()) {
      // The spec as set here, with the collision geometry ground: {from_collisions} needs.
      se3::Scene as_set = scene_;
      as_set.constraints.joint_limits_given = true;
      se3::ConstraintSpec spec = se3::scene_constraints(as_set, sim_->model(), urdf_xml_);
      if (se3::uses_scene_collision(scene_)) {
        // With the scene collision (the robot's shapes too) in place of the objects' own model.
        const se3::GeometryModel none;
        const bool robot = !(urdf_xml_.empty() && scene_.robot_path.empty());
        sim_->set_constraints(
            spec, se3::scene_collision(scene_, &sim_->model(), robot ? nullptr : &none, urdf_xml_,
                                       sim_->extra_robot_models()));
      } else {
        sim_->set_constraints(spec);
      }
    }
  }
}

// The scene's controllers, plus those named in ~controllers from the parameter server (under
// ~controller_namespace, default this node's namespace); a name in both: the parameter
// server's. Each listens on <namespace>/NAME/command.
void SimulatorNodeImpl::setup_controllers() {
  std::string ns = config_.controller_namespace;
  const std::vector<std::string>& names = config_.controllers;
  if (ns.empty()) ns = controllers_namespace(nh_, urdf_text_, *model_, names);
  ctl_nh_ = ns.empty() ? nh_ : ros::NodeHandle(nh_, ns);
  std::vector<se3::ControllerSpec> specs;
  // A controller that cannot be read fails alone, as Gazebo's spawner does it.
  std::vector<std::string> failed;
  std::vector<se3::ControllerSpec> from_params = controllers_from_params(ctl_nh_, names, &failed);
  for (const std::string& e : failed) ROS_ERROR("simulator: controller not started: %s", e.c_str());
  for (const auto& s : scene_.controllers) {
    bool replaced = false;
    for (const auto& p : from_params) replaced = replaced || p.name == s.name;
    if (!replaced) specs.push_back(s);
  }
  for (const auto& p : from_params) specs.push_back(p);
  // The position and velocity interfaces' PIDs, where gazebo_ros_control reads them.
  const ros::NodeHandle gz(ctl_nh_, "gazebo_ros_control");
  XmlRpc::XmlRpcValue pid_gains;
  if (gz.getParam("pid_gains", pid_gains)) {
    se3::set_interface_gains(
        specs, se3::parse_interface_gains(to_yaml(pid_gains), gz.resolveName("pid_gains")));
  }
  // Each controller's interface against the joint's <transmission>s, and its joints: the
  // scene's must fit, one named in ~controllers that does not fails alone.
  const auto transmissions = se3::parse_transmissions(*urdf_tree_);
  for (auto it = specs.begin(); it != specs.end();) {
    try {
      se3::check_interfaces({*it}, transmissions);
      if (std::find(names.begin(), names.end(), it->name) != names.end()) {
        const se3::ControllerSet alone(sim_->model(), {*it});  // its joints and keys
      }
      ++it;
    } catch (const se3::ControllerError& e) {
      if (std::find(names.begin(), names.end(), it->name) == names.end()) throw;
      ROS_ERROR("simulator: controller not started: %s", e.what());
      it = specs.erase(it);
    }
  }
  sim_->set_controllers(specs);
  for (const std::string& w :
       se3::gain_stability_warnings(sim_->model(), sim_->state(), specs, sim_->dt())) {
    ROS_WARN("simulator: %s", w.c_str());
  }
}

bool SimulatorNodeImpl::init() {
  try {
    configure();
  } catch (const std::exception& e) {
    ROS_FATAL("simulator: %s", e.what());
    return false;
  }
  joint_pub_ = nh_.advertise<sensor_msgs::JointState>("joint_states", 10);
  chain_pub_ = nh_.advertise<se3_sim::ChainState>("chain_state", 10);
  stats_pub_ = nh_.advertise<se3_sim::SimStats>("sim_stats", 10);
  marker_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("sim_markers", 10);
  constraint_pub_ = nh_.advertise<se3_sim::ConstraintForces>("constraint_forces", 10);
  if (use_sim_time_) clock_pub_ = nh_.advertise<rosgraph_msgs::Clock>("/clock", 100);
  try {
    setup_sensors(urdf_xml_);
  } catch (const std::exception& e) {
    ROS_FATAL("simulator: %s", e.what());
    return false;
  }
  tf_ = std::make_unique<tf2_ros::TransformBroadcaster>();
  tf_static_ = std::make_unique<tf2_ros::StaticTransformBroadcaster>();
  std::vector<geometry_msgs::TransformStamped> fixed =
      tf_static_transforms(*model_, tree_, ros::Time::now());
  for (geometry_msgs::TransformStamped t : sensor_tfs_) {
    t.header.stamp = ros::Time::now();
    fixed.push_back(t);
  }
  {  // robots 1.. of the scene, and those spawned later (world services)
    try {
      robots_ = std::make_unique<RobotInterfaces>(
          nh_, *sim_, scene_, world_frame_, max_effort_, max_wrench_,
          [this](const std::function<void(se3::Simulator&)>& f) {
            std::lock_guard<TurnMutex> lock(mu_);
            f(*sim_);
          });
    } catch (const std::exception& e) {
      ROS_FATAL("simulator: %s", e.what());
      return false;
    }
    const auto more = robots_->static_transforms(ros::Time::now());
    fixed.insert(fixed.end(), more.begin(), more.end());
  }
  if (!fixed.empty()) tf_static_->sendTransform(fixed);

  // Queues of 1000: a 10 kHz stream is held for 0.1 s; whatever is lost anyway is counted from
  // the header sequence numbers (torque_command).
  cmd_sub_ = nh_.subscribe("torque_command", 1000, &SimulatorNodeImpl::on_torques, this,
                           ros::TransportHints().tcpNoDelay());
  if (se3::ControllerSet* set = sim_->controllers()) {
    for (int c = 0; c < set->size(); ++c) {
      const se3::ControllerSpec& s = set->spec(c);
      const std::string topic = s.name + "/command";
      if (s.kind == se3::ControllerKind::Trajectory) {
        ctl_subs_.push_back(ctl_nh_.subscribe<trajectory_msgs::JointTrajectory>(
            topic, 100,
            [this, c](const trajectory_msgs::JointTrajectory::ConstPtr& msg) {
              on_trajectory(c, msg);
            },
            ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay()));
      } else if (se3::single_joint(s.kind)) {
        ctl_subs_.push_back(ctl_nh_.subscribe<std_msgs::Float64>(
            topic, 1000,
            [this, c](const std_msgs::Float64::ConstPtr& msg) { on_single_command(c, msg); },
            ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay()));
      } else {
        ctl_subs_.push_back(ctl_nh_.subscribe<std_msgs::Float64MultiArray>(
            topic, 1000,
            [this, c](const std_msgs::Float64MultiArray::ConstPtr& msg) {
              on_group_command(c, msg);
            },
            ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay()));
      }
      ROS_INFO("simulator: controller %s (%s, %zu joints) on %s", s.name.c_str(), s.type.c_str(),
               s.joints.size(), ctl_subs_.back().getTopic().c_str());
    }
    ctl_states_ = std::make_unique<ControllerStates>(ctl_nh_, *set, "");
  }
  services_.push_back(nh_.advertiseService("simulator/reset", &SimulatorNodeImpl::on_reset, this));
  services_.push_back(nh_.advertiseService("simulator/pause", &SimulatorNodeImpl::on_pause, this));
  services_.push_back(
      nh_.advertiseService("simulator/resume", &SimulatorNodeImpl::on_resume, this));
  services_.push_back(nh_.advertiseService("simulator/step", &SimulatorNodeImpl::on_step, this));
  services_.push_back(
      nh_.advertiseService("simulator/set_state", &SimulatorNodeImpl::on_set_state, this));
  services_.push_back(
      nh_.advertiseService("simulator/apply_wrench", &SimulatorNodeImpl::on_apply_wrench, this));
  services_.push_back(nh_.advertiseService("simulator/clear_wrenches",
                                           &SimulatorNodeImpl::on_clear_wrenches, this));
  setup_world_services();
  return true;
}

// The world services (world_services.h) over this node's simulator, lock, pause, step and reset.
void SimulatorNodeImpl::setup_world_services() {
  WorldHooks h;
  h.with_sim = [this](const std::function<void(se3::Simulator&)>& f) {
    std::lock_guard<TurnMutex> lock(mu_);
    f(*sim_);
  };
  h.paused = [this] { return paused_; };
  h.set_paused = [this](bool pause) {
    if (request_.active) end_step_request(false, "interrupted by simulator/set_simulation_state");
    if (!pause) {
      anchor_ = Clock::now();
      anchored_ = 0;
    }
    paused_ = pause;
  };
  h.step = [this](std::uint64_t n, std::string* why) {
    se3_sim::Step::Request req;
    se3_sim::Step::Response res;
    req.steps = n;
    on_step(req, res);
    *why = res.message;
    return static_cast<bool>(res.success);
  };
  h.after_reset = [this](bool) {
    if (request_.active) end_step_request(false, "interrupted by simulator/reset_simulation");
    if (sensors_) sensors_->reset();
    if (robots_) robots_->reset_sensors();
    if (rendered_) rendered_->reset();
    status_.clear();
    anchor_ = Clock::now();
    anchored_ = 0;
    publish_clock();
  };
  const std::string dir = scene_.file.empty()
                              ? (config_.cwd.empty() ? std::string(".") : config_.cwd)
                          : scene_.file.find('/') == std::string::npos
                              ? std::string(".")
                              : scene_.file.substr(0, scene_.file.find_last_of('/'));
  h.robots = robots_.get();
  world_ = std::make_unique<WorldServices>(nh_, pnh_, std::move(h), world_frame_, dir);
}

// ------------------------------------------------------------------ main loop

void SimulatorNodeImpl::run() {
  ros::AsyncSpinner spinner(4);  // a step request waiting for the main loop holds one
  spinner.start();
  const Clock::duration pub_period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate_));
  Clock::time_point next_pub = Clock::now();
  period_start_ = anchor_ = Clock::now();
  while (ros::ok()) {
    Clock::time_point now = Clock::now();
    Clock::time_point wake = next_pub;
    {
      std::lock_guard<TurnMutex> lock(mu_);
      if (request_.active) {
        run_step_slice();
        wake = now;  // come back at once (after publishing, if due)
      } else if (!paused_ && !lockstep_) {
        if (rtf_ > 0) {
          // Steps due by now at the real-time factor; a backlog of more than 0.2 s of wall
          // time is dropped (the simulation slows instead of racing to catch up).
          const double due_f = seconds(now - anchor_) * rtf_ / sim_->dt();
          auto due = static_cast<std::int64_t>(due_f) - static_cast<std::int64_t>(anchored_);
          const std::int64_t backlog = static_cast<std::int64_t>(0.2 * rtf_ / sim_->dt()) + 1;
          if (due > backlog) {
            anchor_ = now;
            anchored_ = 0;
            due = 1;
          }
          for (std::int64_t k = 0; k < due && !paused_; ++k) {
            if (physics_step()) publish_clock();
          }
          const double next_s = (anchored_ + 1) * sim_->dt() / rtf_;
          wake = std::min(wake, anchor_ + std::chrono::duration_cast<Clock::duration>(
                                              std::chrono::duration<double>(next_s)));
        } else {
          // As fast as possible, in chunks, until the next publication is due.
          for (int k = 0; k < 64 && !paused_; ++k) physics_step();
          publish_clock();
          wake = now;
        }
      }
    }
    now = Clock::now();
    if (now >= next_pub) {
      {
        std::lock_guard<TurnMutex> lock(mu_);
        if (!lockstep_) publish_state();
        publish_stats_and_markers(now);
        publish_controller_states();
        if (world_) world_->publish(*sim_, now, stamp());
      }
      next_pub += pub_period;
      if (next_pub <= now) next_pub = now + pub_period;  // fell behind: skip, keep the rate
    }
    if (wake > now) std::this_thread::sleep_until(std::min(wake, next_pub));
  }
  {
    std::lock_guard<TurnMutex> lock(mu_);
    if (request_.active) end_step_request(false, "the simulator is shutting down");
  }
  spinner.stop();
}

// Under mu_. One physics step with timing; the guard pauses the simulator.
bool SimulatorNodeImpl::physics_step() {
  const Clock::time_point t0 = Clock::now();
  if (sensors_) sensors_->before_step(*sim_);
  if (robots_) robots_->before_step(*sim_);
  const bool ok = sim_->step();
  if (sensors_) sensors_->after_step(*sim_, ok);
  if (robots_) robots_->after_step(*sim_, ok);
  step_wall_ += Clock::now() - t0;
  if (sensors_) publish_sensors();
  if (rendered_ && ok) rendered_->after_step(*sim_);
  ++period_steps_;
  if (ok) {
    ++anchored_;
    return true;
  }
  paused_ = true;
  status_ = sim_->failure();
  ROS_ERROR("simulator paused by the divergence guard: %s", status_.c_str());
  return false;
}

// Under mu_. Up to kSliceSeconds of the pending step request.
void SimulatorNodeImpl::run_step_slice() {
  const Clock::time_point t0 = Clock::now();
  while (request_.remaining > 0) {
    if (!physics_step()) {
      end_step_request(false,
                       "stopped after " + std::to_string(request_.done) + " steps: " + status_);
      return;
    }
    --request_.remaining;
    ++request_.done;
    if ((request_.done & 63) == 0 && seconds(Clock::now() - t0) > kSliceSeconds) break;
  }
  publish_clock();
  if (request_.remaining == 0) end_step_request(true, "stepped " + std::to_string(request_.done));
}

// Under mu_.
void SimulatorNodeImpl::end_step_request(bool ok, const std::string& why) {
  request_.active = false;
  if (request_.result) {
    request_.result->finished = true;
    request_.result->ok = ok;
    request_.result->message = why;
    request_.result = nullptr;
  }
  if (lockstep_) publish_state();
  step_done_.notify_all();
}

// ------------------------------------------------------------------ commands

void SimulatorNodeImpl::reject(const std::string& what, const std::string& why) {
  const std::uint64_t n = ++rejected_;
  ROS_WARN_THROTTLE(1.0, "simulator: %s rejected (%s); %llu rejected so far", what.c_str(),
                    why.c_str(), static_cast<unsigned long long>(n));
}

// Gaps in a publisher's header.seq (roscpp and rospy number every message they publish) are
// messages lost on the way: a full subscriber queue here or a full queue at the publisher.
void SimulatorNodeImpl::count_drops(const std::string& publisher, std::uint32_t seq) {
  auto it = last_seq_.find(publisher);
  if (it == last_seq_.end()) {
    if (last_seq_.size() >= 1000) last_seq_.clear();  // bounded: forget old publishers
    last_seq_.emplace(publisher, seq);
    return;
  }
  if (seq > it->second) dropped_ += seq - it->second - 1;
  it->second = seq;  // lower: the publisher restarted
}

void SimulatorNodeImpl::on_torques(const ros::MessageEvent<se3_sim::JointTorques const>& event) {
  const se3_sim::JointTorques& msg = *event.getConstMessage();
  count_drops(event.getPublisherName(), msg.header.seq);
  // Checked against the model, which does not change, before taking the simulator.
  const std::string why =
      check_torque_command(*model_, joints_, msg, max_effort_, max_wrench_, torque_);
  if (!why.empty()) {
    reject("torque command", why);
    return;
  }
  std::lock_guard<TurnMutex> lock(mu_);
  for (const auto& ie : torque_.efforts) {
    if (ie.first > 0) sim_->set_joint_effort(ie.first, ie.second);
  }
  if (torque_.has_base_wrench) {
    if (!model_->floating) {
      ROS_WARN_THROTTLE(5.0, "simulator: base wrench ignored (the base is fixed)");
    }
    sim_->set_base_wrench(torque_.base_wrench);
  }
  ++accepted_;
  after_command();
}

void SimulatorNodeImpl::on_group_command(int c, const std_msgs::Float64MultiArray::ConstPtr& msg) {
  controller_command(c, msg->data.data(), msg->data.size());
}

void SimulatorNodeImpl::on_single_command(int c, const std_msgs::Float64::ConstPtr& msg) {
  controller_command(c, &msg->data, 1);
}

// header.stamp zero: now; else with use_sim_time the stamp is simulated time, and without it a
// wall-clock time, taken as that far from now in simulated time (scaled by the real-time factor).
void SimulatorNodeImpl::on_trajectory(int c,
                                      const trajectory_msgs::JointTrajectory::ConstPtr& msg) {
  se3::TrajectoryCommand cmd = from_trajectory(*msg);
  std::unique_lock<TurnMutex> lock(mu_);
  const double now = sim_->time();
  if (!msg->header.stamp.isZero()) {
    cmd.start = use_sim_time_ ? msg->header.stamp.toSec()
                              : now + (msg->header.stamp - ros::Time::now()).toSec() *
                                          (rtf_ > 0 ? rtf_ : 1.0);
  }
  const std::string why = sim_->controllers()->set_trajectory(c, cmd, now);
  if (!why.empty()) {
    lock.unlock();
    reject("trajectory", why);
    return;
  }
  ++accepted_;
  after_command();
}

void SimulatorNodeImpl::controller_command(int c, const double* values, size_t n) {
  std::unique_lock<TurnMutex> lock(mu_);
  const std::string why = sim_->controllers()->set_command(c, values, n);
  if (!why.empty()) {
    lock.unlock();
    reject("controller command", why);
    return;
  }
  ++accepted_;
  after_command();
}

// Under mu_. Lockstep: one control period, then one state, for every accepted command (a paused
// or diverged simulation does not advance, and still answers with its state).
void SimulatorNodeImpl::after_command() {
  if (!lockstep_) return;
  if (!paused_) {
    for (int k = 0; k < lockstep_steps_; ++k) {
      if (!physics_step()) break;
    }
  }
  publish_state();
}

// ------------------------------------------------------------------ services

bool SimulatorNodeImpl::on_reset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  std::lock_guard<TurnMutex> lock(mu_);
  if (request_.active) end_step_request(false, "interrupted by simulator/reset");
  sim_->reset();
  if (sensors_) sensors_->reset();
  if (robots_) robots_->reset_sensors();
  if (rendered_) rendered_->reset();
  status_.clear();
  anchor_ = Clock::now();
  anchored_ = 0;
  publish_clock();
  res.success = true;
  res.message = "reset to the initial state (time 0)";
  ROS_INFO("simulator: reset to the initial state");
  return true;
}

bool SimulatorNodeImpl::on_pause(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  std::lock_guard<TurnMutex> lock(mu_);
  if (request_.active) end_step_request(false, "interrupted by simulator/pause");
  res.success = true;
  res.message = paused_ ? "already paused" : "paused";
  paused_ = true;
  return true;
}

bool SimulatorNodeImpl::on_resume(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  std::lock_guard<TurnMutex> lock(mu_);
  if (!sim_->failure().empty()) {
    res.success = false;
    res.message = "cannot resume after divergence (" + sim_->failure() + "); call simulator/reset";
    return true;
  }
  if (request_.active) end_step_request(false, "interrupted by simulator/resume");
  res.success = true;
  res.message = lockstep_ ? "resumed (lockstep: commands advance the simulation)" : "resumed";
  paused_ = false;
  anchor_ = Clock::now();
  anchored_ = 0;
  return true;
}

bool SimulatorNodeImpl::on_step(se3_sim::Step::Request& req, se3_sim::Step::Response& res) {
  std::unique_lock<TurnMutex> lock(mu_);
  if (!paused_ && !lockstep_) {
    res.success = false;
    res.message = "the simulator is running; call simulator/pause first";
  } else if (!sim_->failure().empty()) {
    res.success = false;
    res.message = "diverged: " + sim_->failure() + "; call simulator/reset";
  } else if (request_.active) {
    res.success = false;
    res.message = "a step request is running (" + std::to_string(request_.remaining) +
                  " steps left); wait, or call simulator/pause to end it";
  } else {
    StepResult result;
    request_ = StepRequest();
    request_.active = true;
    request_.remaining = req.steps;
    request_.result = &result;
    if (req.steps == 0) end_step_request(true, "stepped 0");  // lockstep: publishes the state
    // The main loop runs it in slices; wait for the end (or an interruption).
    step_done_.wait(lock, [&result] { return result.finished; });
    res.success = result.ok;
    res.message = result.message;
  }
  res.sim_time = sim_->time();
  return true;
}

bool SimulatorNodeImpl::on_set_state(se3_sim::SetState::Request& req,
                                     se3_sim::SetState::Response& res) {
  res.success = false;
  const se3::Model& m = *model_;
  if (req.name.size() != req.position.size()) {
    res.message = "name and position lengths differ";
    return true;
  }
  if (!req.velocity.empty() && req.velocity.size() != req.name.size()) {
    res.message = "velocity needs one value per name (or none)";
    return true;
  }
  std::lock_guard<TurnMutex> lock(mu_);
  se3::State x = sim_->state();
  std::vector<bool> seen(m.n + 1, false);
  for (size_t k = 0; k < req.name.size(); ++k) {
    const int i = joints_.index(m, req.name[k]);
    if (i < 0) {
      res.message = "unknown joint '" + req.name[k] + "'";
      return true;
    }
    if (i == 0) {
      res.message = "joint '" + req.name[k] + "' is locked by the scene";
      return true;
    }
    if (seen[i]) {
      res.message = "joint '" + req.name[k] + "' is named twice";
      return true;
    }
    seen[i] = true;
    const double q = req.position[k], v = req.velocity.empty() ? 0.0 : req.velocity[k];
    if (!std::isfinite(q) || !std::isfinite(v)) {
      res.message = "non-finite value for '" + req.name[k] + "'";
      return true;
    }
    if (q < m.lower[i] || q > m.upper[i]) {
      res.message = "position " + se3::num(q) + " of '" + req.name[k] +
                    "' is outside its limits [" + se3::num(m.lower[i]) + ", " +
                    se3::num(m.upper[i]) + "]";
      return true;
    }
    x.q[i - 1] = q;
    x.v[m.idx_v(i)] = v;
  }
  if (req.set_base_pose) {
    const std::string why = from_pose(req.base_pose, x.base);
    if (!why.empty()) {
      res.message = "base_pose: " + why;
      return true;
    }
  }
  if (req.set_base_twist) {
    if (!m.floating) {
      res.message = "the base is fixed: it has no twist to set";
      return true;
    }
    const se3::Vec6 t = from_twist(req.base_twist);
    if (!t.allFinite()) {
      res.message = "base_twist has a non-finite number";
      return true;
    }
    x.v.head<6>() = t;
  }
  try {
    sim_->set_state(x);
  } catch (const std::exception& e) {
    res.message = e.what();
    return true;
  }
  res.success = true;
  res.message = "state set";
  return true;
}

bool SimulatorNodeImpl::on_apply_wrench(se3_sim::ApplyWrench::Request& req,
                                        se3_sim::ApplyWrench::Response& res) {
  res.success = false;
  if (!req.reference_frame.empty() && req.reference_frame != world_frame_) {
    res.message = "reference_frame '" + req.reference_frame + "': only the world frame ('" +
                  world_frame_ + "' or '') is taken";
    return true;
  }
  const se3::Vec6 w = from_wrench(req.wrench);
  const se3::Vec3 p(req.reference_point.x, req.reference_point.y, req.reference_point.z);
  if (!w.allFinite() || !p.allFinite() || std::isnan(req.duration)) {
    res.message = "non-finite wrench, point or duration";
    return true;
  }
  if (w.head<3>().norm() > max_wrench_ || w.tail<3>().norm() > max_wrench_) {
    res.message = "torque or force above ~max_wrench " + std::to_string(max_wrench_);
    return true;
  }
  std::lock_guard<TurnMutex> lock(mu_);
  int robot = 0, link = -1;  // robots 1.. by their TF frame names NS/LINK
  if (!find_robot_link(*sim_, req.link, robot, link)) {
    res.message = "unknown link '" + req.link + "' (another robot's link: NS/LINK, its TF frame)";
    return true;
  }
  try {
    sim_->apply_robot_link_wrench(robot, link, p, w, req.duration);
  } catch (const std::exception& e) {
    res.message = e.what();
    return true;
  }
  res.success = true;
  res.message =
      req.duration < 0 ? "applied until cleared" : "applied for " + se3::num(req.duration) + " s";
  return true;
}

bool SimulatorNodeImpl::on_clear_wrenches(std_srvs::Trigger::Request&,
                                          std_srvs::Trigger::Response& res) {
  std::lock_guard<TurnMutex> lock(mu_);
  const int n = sim_->link_wrench_count();
  sim_->clear_link_wrenches();
  res.success = true;
  res.message = "cleared " + std::to_string(n) + " wrench" + (n == 1 ? "" : "es");
  return true;
}

// ------------------------------------------------------------------ publishing

void SimulatorNodeImpl::setup_sensors(const std::string& urdf_xml) {
  std::vector<std::string> warnings;
  std::vector<se3::SensorSpec> specs =
      se3::scene_sensors(scene_, urdf_text_.empty() ? nullptr : urdf_tree_.get(), &warnings);
  for (const std::string& w : warnings) ROS_WARN("simulator: %s", w.c_str());
  // Cameras and lasers: drawn on a thread of their own (rendered_sensors.h).
  std::vector<se3::SensorSpec> drawn;
  for (const se3::SensorSpec& s : specs) {
    if (se3::sensor_is_rendered(s.type)) drawn.push_back(s);
  }
  specs.erase(
      std::remove_if(specs.begin(), specs.end(),
                     [](const se3::SensorSpec& s) { return se3::sensor_is_rendered(s.type); }),
      specs.end());
  if (!drawn.empty()) {
    rendered_ = std::make_unique<se3_ros::RenderedSensors>(
        nh_, scene_, *model_, se3::scene_geometry(scene_, *model_, urdf_xml), drawn, world_frame_,
        use_sim_time_, lockstep_);
    for (const auto& t : rendered_->static_transforms()) sensor_tfs_.push_back(t);
  }
  if (specs.empty()) return;
  sensors_ = std::make_unique<se3::SensorSet>(*model_, specs, urdf_text_);
  const se3::Model& m = *model_;
  for (const se3::SensorSpec& s : specs) {
    const std::string topic = s.topic.empty() ? s.name : s.topic;
    // The frame: the sensor's `frame`, else its link (force-torque: the joint's child link)
    // when it sits at the link's origin, else a frame of its own name on /tf_static.
    std::string link = s.link;
    if (s.type == se3::SensorType::ForceTorque) {
      for (const se3::LinkFrame& l : m.links) {
        if (l.joint == s.joint) link = l.name;
      }
    }
    link = se3::frame_name(link);
    std::string frame = s.frame;
    const bool at_link = s.pose.isApprox(se3::SE3(), 1e-12);
    if (s.type == se3::SensorType::Contact) {
      if (frame.empty()) frame = world_frame_;
    } else if (frame.empty()) {
      frame = at_link ? link : s.name;
    }
    if (s.type != se3::SensorType::Contact && frame != link && s.frame.empty()) {
      geometry_msgs::TransformStamped t;
      t.header.frame_id = link;
      t.child_frame_id = frame;
      t.transform = to_transform(s.pose);
      sensor_tfs_.push_back(t);
    }
    sensor_frames_.push_back(frame);
    const char* type = "";
    if (s.type == se3::SensorType::Imu) {
      sensor_pubs_.push_back(nh_.advertise<sensor_msgs::Imu>(topic, 100));
      type = "imu (sensor_msgs/Imu)";
    } else if (s.type == se3::SensorType::ForceTorque) {
      sensor_pubs_.push_back(nh_.advertise<geometry_msgs::WrenchStamped>(topic, 100));
      type = "force_torque (geometry_msgs/WrenchStamped)";
    } else {
      sensor_pubs_.push_back(nh_.advertise<se3_sim::ContactsState>(topic, 100));
      type = "contact (se3_sim/ContactsState)";
    }
    ROS_INFO("simulator: sensor %s, %s on %s in frame %s at %g Hz", s.name.c_str(), type,
             sensor_pubs_.back().getTopic().c_str(), frame.c_str(), s.rate);
  }
}

// Under mu_. Every reading is stamped with the simulated time of the state it shows (with
// use_sim_time; else the wall clock, as the node's other stamps).
void SimulatorNodeImpl::publish_sensors() {
  for (int i = 0; i < sensors_->size(); ++i) {
    const se3::SensorReading& r = sensors_->reading(i);
    if (!r.ready) continue;
    sensors_->take(i);
    std_msgs::Header h;
    h.stamp = use_sim_time_ ? ros::Time(r.stamp) : ros::Time::now();
    h.frame_id = sensor_frames_[i];
    publish_reading(sensors_->specs()[i], r, h, world_frame_, sensor_pubs_[i]);
  }
}

ros::Time SimulatorNodeImpl::stamp() const {
  return use_sim_time_ ? ros::Time(sim_->time()) : ros::Time::now();
}

void SimulatorNodeImpl::publish_clock() {
  if (!use_sim_time_) return;
  rosgraph_msgs::Clock c;
  c.clock = ros::Time(sim_->time());
  clock_pub_.publish(c);
}

void SimulatorNodeImpl::publish_state() {
  const se3::Model& m = *model_;
  const se3::State& x = sim_->state();
  const ros::Time t = stamp();
  sim_->applied_joint_efforts(effort_);
  fill_joint_state(m, joints_, x, effort_, js_);
  js_.header.stamp = t;
  sim_->link_poses(links_);
  tf_transforms(m, tree_, links_, world_frame_, t, tfs_);
  append_object_transforms(sim_->object_specs(), sim_->objects(), world_frame_, t, tfs_);
  fill_chain_state(m, js_, x, sim_->kinetic_energy(), sim_->potential_energy(), cs_);
  cs_.header.stamp = t;
  cs_.header.frame_id = world_frame_;
  if (lockstep_) publish_clock();
  joint_pub_.publish(js_);
  tf_->sendTransform(tfs_);
  chain_pub_.publish(cs_);
  if (robots_) robots_->publish(*sim_, t, *tf_);
}

void SimulatorNodeImpl::publish_controller_states() {
  se3::ControllerSet* set = sim_->controllers();
  if (set && ctl_states_) ctl_states_->publish(*set, sim_->time(), stamp());
  if (robots_) robots_->publish_controller_states(*sim_, stamp());
}

void SimulatorNodeImpl::publish_stats_and_markers(Clock::time_point now) {
  const se3::Model& m = *model_;
  const ros::Time t = stamp();
  se3_sim::SimStats st;
  const double wall = seconds(now - period_start_);
  st.header.stamp = t;
  st.integrator = sim_->schemes_used();
  {
    const std::string own = sim_->integrator();
    const std::uint64_t contact = sim_->velocity_level_steps();
    if (own != se3::kContactStepper && sim_->steps() > contact) {
      st.schemes.push_back(own);
      st.scheme_steps.push_back(sim_->steps() - contact);
    }
    if (contact > 0 || own == se3::kContactStepper) {
      st.schemes.push_back(se3::kContactStepper);
      st.scheme_steps.push_back(own == se3::kContactStepper ? sim_->steps() : contact);
    }
    st.events = sim_->events();
  }
  st.dt = sim_->dt();
  st.sim_time = sim_->time();
  st.step_time_mean = period_steps_ ? seconds(step_wall_) / period_steps_ : 0.0;
  st.real_time_factor = wall > 0 ? period_steps_ * sim_->dt() / wall : 0.0;
  const double T = sim_->kinetic_energy(), U = sim_->potential_energy();
  const double T0 = sim_->initial_kinetic_energy();
  if (sim_->time() < energy_time_ || !(T_max_ >= 0)) T_max_ = 0;  // reset since the last one
  energy_time_ = sim_->time();
  T_max_ = std::max(T_max_, T);
  const double scale = se3::energy_drift_scale(sim_->energy_scale0(), T_max_);
  st.energy_drift_rel = finite_or_zero(std::abs(T + U - T0) / scale);
  st.energy_balance_rel = finite_or_zero(std::abs(T + U - T0 - sim_->work()) / scale);
  st.steps = sim_->steps();
  st.fast_steps = sim_->fast_steps();
  if (st.fast_steps > 0 && !fast_warned_) {
    ROS_WARN("simulator: %s", sim_->fast_step_warning().c_str());
    fast_warned_ = true;
  } else if (st.fast_steps == 0) {
    fast_warned_ = false;  // after a reset, warn again
  }
  st.accepted_commands = accepted_;
  st.rejected_commands = rejected_;
  st.dropped_commands = dropped_;
  st.spawned = sim_->spawned();
  st.deleted = sim_->deleted();
  st.paused = paused_;
  st.status = status_;
  period_steps_ = 0;
  step_wall_ = Clock::duration::zero();
  period_start_ = now;

  // Markers (sim_markers.h): centre of mass, objects, the scene's base box, an arrow along each
  // joint axis with an effort, and the constraint forces.
  std_msgs::Header header;
  header.stamp = t;
  header.frame_id = world_frame_;
  visualization_msgs::MarkerArray markers;
  sim_markers(*sim_, scene_, header, markers);
  if (const se3::ConstraintSystem* sys = sim_->constraints()) {
    se3_sim::ConstraintForces cf;
    append_constraint_forces(m, sys->forces(), header, cf, markers);
    constraint_pub_.publish(cf);
  }
  stats_pub_.publish(st);
  marker_pub_.publish(markers);
}

// ------------------------------------------------------------------ public face

SimulatorNode::SimulatorNode() : impl_(std::make_unique<SimulatorNodeImpl>()) {}
// /use_sim_time is sim.launch's for the simulator's /clock: it goes with the simulator (after a
// run or a failed start), so that a later node on the same master does not wait for a /clock
// no one publishes.
SimulatorNode::~SimulatorNode() {
  bool sim_time = false;
  if (ros::param::get("/use_sim_time", sim_time) && sim_time) ros::param::del("/use_sim_time");
}
bool SimulatorNode::init() {
  return impl_->init();
}
void SimulatorNode::run() {
  impl_->run();
}

}  // namespace se3_ros
