// simulator_node: se3_sim's simulator on ROS (topics, services and parameters in docs/ros.md).
#include "se3_sim/ros/simulator_node.h"

#include <ros/ros.h>

#include <exception>

int main(int argc, char** argv) {
  // The node's boundary: whatever escapes (a ros::Exception such as InvalidNameException is a
  // std::exception) ends it with one line and exit code 1, never an abort.
  try {
    ros::init(argc, argv, "simulator");
    se3_ros::SimulatorNode node;
    if (!node.init()) return 1;
    node.run();
  } catch (const std::exception& e) {
    ROS_FATAL("simulator: %s", e.what());
    return 1;
  }
  return 0;
}
