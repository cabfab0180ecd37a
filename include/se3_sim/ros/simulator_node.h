// The simulator node (docs/ros.md): se3::Simulator behind ROS topics and services.
//
// Physics runs in the caller's thread (run()), paced by the steady clock at ~real_time_factor
// (0: as fast as possible); callbacks (commands, services) run on an AsyncSpinner and share the
// simulator under one mutex. State (joint_states, /tf, chain_state) is published at
// ~publish_rate (wall clock), or with ~lockstep once after every command; /clock (with
// use_sim_time) after every physics step. A long simulator/step request runs in slices of at
// most a few milliseconds between which the node publishes and serves; a reset, pause or resume
// ends it.
#pragma once

#include <memory>

namespace se3_ros {

class SimulatorNodeImpl;

class SimulatorNode {
 public:
  /// Uses the global and private ("~") node handles of the current process (ros::init first).
  SimulatorNode();
  ~SimulatorNode();
  /// Reads parameters, builds the simulator, advertises everything. false (after a ROS_FATAL
  /// line naming the cause) when it cannot start.
  bool init();
  /// Steps and publishes until ROS shuts down.
  void run();

 private:
  std::unique_ptr<SimulatorNodeImpl> impl_;
};

}  // namespace se3_ros
