// The ROS interface of a simulator's robots 1.. (docs/ros.md "Several robots"; robot 0 is the
// node's own): per robot, under its namespace NS, the parameter NS/robot_description, the topics
// NS/joint_states, NS/chain_state and NS/torque_command, its controllers' NS/NAME/command (and a
// trajectory controller's NS/NAME/state), its TF frames NS/LINK (REP 105: its root link NS/ROOT
// hangs on the world frame; no tf_prefix), and its sensors' topics NS/TOPIC (its robots: entry's
// sensors: and its URDF's Gazebo sensor tags; robot_sensors.h).
#pragma once

#include <geometry_msgs/TransformStamped.h>
#include <ros/ros.h>
#include <tf2_ros/transform_broadcaster.h>

#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "se3_sim/sim/sim.h"

namespace se3_ros {

/// Robot k's namespace on ROS: its scene namespace, else its name.
std::string robot_ros_namespace(const se3::Simulator& sim, int k);
/// A copy of model whose link names carry prefix + "/" (prefix "" leaves them), for TF.
se3::Model prefixed_links(const se3::Model& model, const std::string& prefix);
/// The robot and link (index into its Model::links) that a TF frame name names: robot 0's links
/// by their bare names, robot k >= 1's as NS/LINK (NS its robot_ros_namespace). False when no
/// robot has that link.
bool find_robot_link(const se3::Simulator& sim, const std::string& frame, int& robot, int& link);

class RobotInterfaces {
 public:
  using WithSim = std::function<void(const std::function<void(se3::Simulator&)>&)>;
  /// Advertises the topics of sim's robots 1.. under nh (and sets each NS/robot_description to
  /// its URDF file's text). with_sim runs a function with the simulator held (the node's lock).
  /// Commands are checked as the node's own (max_effort, max_wrench). Throws
  /// std::runtime_error for an unreadable URDF file.
  RobotInterfaces(ros::NodeHandle nh, const se3::Simulator& sim, const se3::Scene& scene,
                  std::string world_frame, double max_effort, double max_wrench, WithSim with_sim);
  ~RobotInterfaces();
  /// The fixed joints' transforms of every robot, for /tf_static.
  std::vector<geometry_msgs::TransformStamped> static_transforms(const ros::Time& stamp) const;
  /// Under the node's lock: every robot's joint_states, chain_state and /tf.
  void publish(se3::Simulator& sim, const ros::Time& stamp, tf2_ros::TransformBroadcaster& tf);
  /// Under the node's lock: every robot's trajectory controllers' NAME/state that is due
  /// (controller_states.h).
  void publish_controller_states(se3::Simulator& sim, const ros::Time& stamp);
  /// Under the node's lock, around each Simulator::step: every robot's sensors (after_step
  /// publishes the readings that are ready); reset_sensors after a reset of the simulator.
  void before_step(const se3::Simulator& sim);
  void after_step(const se3::Simulator& sim, bool ok);
  void reset_sensors();

  struct Robot;
  struct RobotDeleter {
    void operator()(Robot* r) const;
  };
  using RobotPtr = std::unique_ptr<Robot, RobotDeleter>;
  // A robot spawned or deleted at run time (world_services.h): the slow parts (advertising,
  // parameters, shutting down) off the node's lock, the swaps under it.
  /// Off the lock: the interface of a robot about to be spawned, under namespace ns (name when
  /// ""): NS/robot_description set to urdf, its topics advertised, all its TF frames (fixed
  /// joints too) on /tf so that they stop with it. Idle until insert(). Throws
  /// ros::InvalidNameException for a namespace ROS refuses.
  RobotPtr prepare(const se3::Model& model, const std::string& name, const std::string& ns,
                   const std::string& urdf);
  /// Under the lock, after the simulator committed the spawn: it publishes from the next
  /// publication on.
  void insert(RobotPtr r, const se3::Simulator& sim);
  /// Under the lock, after the simulator committed the delete of robot `name`: its interface
  /// out (idle; nullptr when it has none), the others' indices renewed. discard() it off the
  /// lock.
  RobotPtr remove(const std::string& name, const se3::Simulator& sim);
  /// Off the lock: deletes a removed robot's robot_description and shuts its topics down.
  void discard(RobotPtr r);

 private:
  /// The robot's joint table, TF tree, topics and controllers' subscribers under R.rnh.
  void connect(Robot& R, const std::vector<std::pair<std::string, double>>& locked,
               const std::vector<se3::ControllerSpec>& specs,
               const std::vector<se3::SensorSpec>& sensors, const std::string& urdf);
  std::vector<RobotPtr> robots_;
  ros::NodeHandle nh_;
  std::string world_frame_;
  double max_effort_, max_wrench_;
  WithSim with_sim_;
  bool use_sim_time_ = false;
};

}  // namespace se3_ros
