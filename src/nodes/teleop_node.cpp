// teleop_node: joint torques and the renderer's camera from this terminal
// (src/ros/teleop_node.cpp).
#include "se3_sim/ros/teleop_node.h"

int main(int argc, char** argv) {
  return se3_ros::run_teleop(argc, argv);
}
