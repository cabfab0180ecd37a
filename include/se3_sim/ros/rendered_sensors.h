// The simulator node's cameras, depth cameras and laser scans (sensors.h: SensorType::Camera,
// DepthCamera, Ray), drawn and published on a thread of their own so that the physics step never
// waits for a frame (docs/ros.md, "Cameras and laser scans").
//
// After a step whose count is a multiple of a sensor's period (round(1 / (rate dt)); rate 0:
// every step), after_step() copies the bodies' and objects' poses and the simulated time under
// the simulator's lock (no allocation) and wakes the thread, which renders (render/
// camera_sensor.h) or casts (laser.h) and publishes, stamped with that time. Free running, a
// frame not yet taken when the next one is due is replaced (the newest state wins; the sensors
// it carried lose that frame, counted in dropped(), so that every stamp stays on its sensor's
// rate); with `wait` (lockstep) after_step() waits for the thread to take the previous one, so
// that every due frame is published and the same commands give the same messages.
#pragma once

#include <geometry_msgs/TransformStamped.h>
#include <ros/ros.h>

#include <memory>
#include <string>
#include <vector>

#include "se3_sim/sim/sensors.h"
#include "se3_sim/sim/sim.h"

namespace se3_ros {

class RenderedSensors {
 public:
  /// specs: the rendered ones only (sensor_is_rendered). geometry: the robot's visuals (cameras)
  /// and collisions (lasers). Throws se3::SensorError naming a sensor whose link is unknown or
  /// whose camera or scan is unusable.
  RenderedSensors(ros::NodeHandle& nh, const se3::Scene& scene, const se3::Model& model,
                  const se3::GeometryModel& geometry, const std::vector<se3::SensorSpec>& specs,
                  const std::string& world_frame, bool use_sim_time, bool wait);
  ~RenderedSensors();
  RenderedSensors(const RenderedSensors&) = delete;
  RenderedSensors& operator=(const RenderedSensors&) = delete;

  /// Link -> sensor frame (cameras: `<name>_optical_frame`) for /tf_static; none for a sensor
  /// whose frame is given (`frame`, frameName).
  const std::vector<geometry_msgs::TransformStamped>& static_transforms() const;
  /// After each step, under the simulator's lock.
  void after_step(se3::Simulator& sim);
  /// Waits until every frame handed over has been published.
  void flush();
  /// After Simulator::reset, under the simulator's lock: a frame not yet taken is dropped, and
  /// the cameras' and lasers' noise restarts from its seeds (a run after a reset repeats the
  /// images and scans bit for bit).
  void reset();
  /// Sensor frames replaced before the thread took them.
  long dropped() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace se3_ros
