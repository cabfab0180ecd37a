// The sensors of one robot of a simulator on ROS (docs/ros.md "Sensors", "Several robots"): its
// IMU, force-torque and contact sensors (a scene's sensors:, a URDF's Gazebo tags) sampled around
// each step and published under the robot's node handle, as gazebo_ros's plugins publish under
// their robotNamespace. Cameras and lasers are not here (rendered_sensors.h).
#pragma once

#include <geometry_msgs/TransformStamped.h>
#include <ros/ros.h>

#include <memory>
#include <string>
#include <vector>

#include "se3_sim/sim/sensors.h"
#include "se3_sim/sim/sim.h"

namespace se3_ros {

/// One reading on its publisher: sensor_msgs/Imu, geometry_msgs/WrenchStamped or
/// se3_sim/ContactsState (its frame the world frame) by the spec's type.
void publish_reading(const se3::SensorSpec& spec, const se3::SensorReading& reading,
                     const std_msgs::Header& header, const std::string& world_frame,
                     ros::Publisher& pub);

class RobotSensors {
 public:
  /// Robot `robot`'s sensors (its name; "" for robot 0) of model, those of specs that are not
  /// drawn (the others: one warning each). Topics relative to nh; frames the links' TF names
  /// (prefix + "/" + LINK, prefix "" for bare names), a sensor off its link's origin in a frame
  /// of its own name (its transform in static_transforms). Throws se3::SensorError for a
  /// sensor on a link or joint the model lacks.
  RobotSensors(ros::NodeHandle nh, const se3::Model& model, std::vector<se3::SensorSpec> specs,
               const std::string& urdf_xml, const std::string& robot, const std::string& prefix,
               std::string world_frame, bool use_sim_time);
  int size() const { return set_ ? set_->size() : 0; }
  /// Around each Simulator::step (under the node's lock); after_step publishes the readings
  /// that are ready.
  void before_step(const se3::Simulator& sim);
  void after_step(const se3::Simulator& sim, bool ok);
  void reset();
  /// Link -> sensor frame of each sensor off its link's origin.
  const std::vector<geometry_msgs::TransformStamped>& static_transforms() const { return tfs_; }

 private:
  std::unique_ptr<se3::SensorSet> set_;
  std::vector<ros::Publisher> pubs_;
  std::vector<std::string> frames_;
  std::vector<geometry_msgs::TransformStamped> tfs_;
  std::string world_frame_;
  bool use_sim_time_ = false;
};

}  // namespace se3_ros
