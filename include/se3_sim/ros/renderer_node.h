// The renderer node (docs/ros.md): draws the robot described by `robot_description` (its visual
// meshes, resolved through ROS's package lookup), posed from TF, and publishes the image through
// image_transport as renderer/image with renderer/camera_info (1280x1024 rgb8 by default), only
// while someone subscribes; the same geometry goes to RViz as renderer/markers. Parameters,
// topics and the service: src/ros/renderer_node.cpp and docs/ros.md.
#pragma once

#include <memory>

namespace se3_ros {

class RendererNodeImpl;

class RendererNode {
 public:
  /// Reads the private ("~") parameters and advertises everything (ros::init first).
  RendererNode();
  ~RendererNode();

 private:
  std::unique_ptr<RendererNodeImpl> impl_;
};

}  // namespace se3_ros
