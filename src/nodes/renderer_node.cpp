// renderer_node: se3_sim's renderer on ROS (the class: src/ros/renderer_node.cpp; topics,
// parameters and the service in docs/ros.md).
#include "se3_sim/ros/renderer_node.h"

#include <ros/ros.h>

#include <exception>

int main(int argc, char** argv) {
  // The node's boundary: whatever escapes (a ros::Exception is a std::exception) ends it with
  // one line and exit code 1, never an abort.
  try {
    ros::init(argc, argv, "renderer");
    se3_ros::RendererNode node;
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("renderer: %s", e.what());
    return 1;
  }
  return 0;
}
