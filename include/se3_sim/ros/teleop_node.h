// The teleop node: joint torques (and the renderer's camera) from the keyboard and the mouse of
// the terminal it runs in (parameters and keys in src/ros/teleop_node.cpp and the README).
#pragma once

namespace se3_ros {

/// Runs the teleop node in this process (it calls ros::init itself): 0 on a normal end or when
/// stdin is no terminal, 1 with a one-line reason on stderr when it cannot run. The terminal is
/// restored on every way out.
int run_teleop(int argc, char** argv);

}  // namespace se3_ros
