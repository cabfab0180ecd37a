// The simulator node's world services and topics (docs/ros.md "World services"), shaped after
// ROS 2's simulation_interfaces 1.0 in se3_sim's own srv files: spawn, delete, list, get and set
// entity states, step, reset, play/pause, features; and the model_states and link_states topics
// as gazebo_ros publishes them. Over the library's world interface (se3_sim/sim/world.h); the node
// lends its simulator, its lock and its pause, step and reset through WorldHooks.
#pragma once

#include <ros/ros.h>

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "se3_sim/ros/robot_interfaces.h"
#include "se3_sim/sim/sim.h"

namespace se3_ros {

struct WorldHooks {
  /// Runs f with the simulator held (the node's lock).
  std::function<void(const std::function<void(se3::Simulator&)>&)> with_sim;
  /// Under the lock: whether the simulation is paused; pausing or playing it.
  std::function<bool()> paused;
  std::function<void(bool)> set_paused;
  /// Without the lock: steps a paused simulation (the node's simulator/step); false with why.
  std::function<bool(std::uint64_t, std::string*)> step;
  /// Under the lock: the node's reset (time 0) after the simulator's own; its reset of the world
  /// (time runs on) when keep_time.
  std::function<void(bool keep_time)> after_reset;
  /// The topics and TF of robots 1.. (robot_interfaces.h): a spawned robot's are added, a
  /// deleted one's removed (nullptr: robots are not spawned).
  RobotInterfaces* robots = nullptr;
};

class WorldServices {
 public:
  /// Advertises the services under nh's simulator/ and the topics model_states, link_states
  /// (at ~world_states_rate Hz, default 50; 0: not published). base_dir: where relative mesh
  /// paths of spawned objects are looked up.
  WorldServices(ros::NodeHandle nh, ros::NodeHandle pnh, WorldHooks hooks, std::string world_frame,
                std::string base_dir);
  ~WorldServices();
  /// Under the node's lock, at its publication: model_states and link_states when due.
  void publish(se3::Simulator& sim, std::chrono::steady_clock::time_point now,
               const ros::Time& stamp);

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace se3_ros
