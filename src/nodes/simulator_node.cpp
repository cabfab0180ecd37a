// simulator_node: se3_sim's simulator on ROS (topics, services and parameters in docs/ros.md).
#include "se3_sim/ros/simulator_node.h"

#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "simulator");
  se3_ros::SimulatorNode node;
  if (!node.init()) return 1;
  node.run();
  return 0;
}
