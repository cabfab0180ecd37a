// The state topics of a robot's trajectory controllers (docs/ros.md "Controllers"): NAME/state
// (se3_sim/JointTrajectoryControllerState, control_msgs' layout) at each controller's
// state_publish_rate of simulated time, and its status changes in the log. One per robot: the
// node's own under its controllers' namespace, robots 1.. under NS (robot_interfaces.h).
#pragma once

#include <ros/ros.h>

#include <string>
#include <vector>

#include "se3_sim/JointTrajectoryControllerState.h"
#include "se3_sim/sim/controllers.h"

namespace se3_ros {

class ControllerStates {
 public:
  /// Advertises NAME/state under nh for every trajectory controller of specs (or of set, the
  /// same specs bound to a model). `robot` names the
  /// robot in log lines ("" for the node's own).
  ControllerStates(ros::NodeHandle nh, const std::vector<se3::ControllerSpec>& specs,
                   std::string robot);
  ControllerStates(ros::NodeHandle nh, const se3::ControllerSet& set, std::string robot);
  /// Under the node's lock, at simulated time t: logs the status changes and publishes each
  /// trajectory controller's state that is due (stamp as header stamp). set is the one given
  /// to the constructor (the same controllers).
  void publish(const se3::ControllerSet& set, double t, const ros::Time& stamp);

 private:
  std::vector<ros::Publisher> pubs_;  ///< per controller (trajectory ones: NAME/state)
  std::vector<double> last_;          ///< simulated time of the last NAME/state
  std::vector<se3::TrajectoryStatus> status_;
  se3_sim::JointTrajectoryControllerState msg_;
  std::string robot_;
};

}  // namespace se3_ros
