// Sensors a robot's software reads (no roscpp): an IMU on a link, a force-torque sensor on a
// joint (fixed joints too), a contact sensor on a link, with Gaussian noise; declared in a scene's
// `sensors:` list or by Gazebo's <gazebo reference><sensor> tags in a URDF. The ros layer
// publishes the readings (docs/ros.md, "Sensors").
//
// When: a sensor of rate r samples the state k of every round(1 / (r dt))-th step (k a multiple
// of it; rate 0: every step). A reading shows the state k it samples and is stamped with its
// time t_k; it is ready once the step k -> k + 1 has been taken, since the acceleration and the
// forces are those of that step.
//
// How: a = (v_{k+1} - v_k) / dt, the generalized acceleration of the step (for the contact
// scheme, semi-implicit Euler with velocity-level impulses, exactly the acceleration its dynamics
// gave at state k, the impulses included as impulse / dt; for the explicit integrators the mean
// acceleration over the step, within O(dt) of that at t_k). One recursive Newton-Euler pass at
// (q_k, v_k, a) gives every body's twist, its acceleration with gravity folded in as a base
// acceleration -g (so the linear part is already the specific force an accelerometer measures)
// and the wrench each moving joint transmits with no external force counted; the contact forces
// of the step are subtracted for force-torque sensors. Cost: one rnea and a few transforms per
// sample (measured per step in docs/ros.md).
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "se3_sim/collision/collision.h"
#include "se3_sim/collision/laser.h"
#include "se3_sim/dynamics/dynamics.h"
#include "se3_sim/model/urdf_xml.h"

namespace se3 {

class Simulator;

enum class SensorType { Imu, ForceTorque, Contact, Camera, DepthCamera, Ray };

/// Whether a type is drawn or cast (camera, depth_camera, ray) rather than computed from the
/// dynamics: SensorSet leaves those out, the ros layer's sensor thread serves them.
inline bool sensor_is_rendered(SensorType t) {
  return t == SensorType::Camera || t == SensorType::DepthCamera || t == SensorType::Ray;
}

/// A camera's image (render/camera_sensor.h turns it into a CameraSensorSpec).
struct CameraParams {
  int width = 640;
  int height = 480;
  double hfov = 1.047;  ///< rad
  double near = 0.05;   ///< m
  double far = 10.0;    ///< m
};

/// Gaussian noise of a sensor's channels: each component gets mean + bias_k + N(0, stddev^2),
/// bias_k drawn once per component (at construction and reset) from N(0, bias^2). All zero: no
/// noise (the default).
struct SensorNoise {
  double mean = 0;
  double stddev = 0;
  double bias = 0;  ///< standard deviation of the constant per-component offset (IMU)
  bool any() const { return mean != 0 || stddev != 0 || bias != 0; }
};

/// One declared sensor (a scene's `sensors:` item, or a URDF's Gazebo tags).
struct SensorSpec {
  std::string name;
  SensorType type = SensorType::Imu;
  std::string link;   ///< IMU, contact: the URDF link it is fixed on
  std::string joint;  ///< force-torque: the URDF joint (fixed or moving) it measures
  SE3 pose;           ///< sensor frame in the link's frame (force-torque: the child link's)
  double rate = 0;    ///< Hz of simulated time; 0: every step
  SensorNoise noise;  ///< IMU: angular velocity and linear acceleration; F/T: force and torque
  std::string topic;  ///< ROS topic ("" = the sensor's name)
  std::string frame;  ///< frame_id of its messages ("" = the link: see sensor_frame below)
  std::string where;  ///< "file:line" for messages
  /// camera, depth_camera: the image; link may be "world" (pose then in the world). Topics
  /// relative to the camera's namespace (topic, default its name) as gazebo_ros names them.
  CameraParams camera;
  std::string image_topic = "image_raw";
  std::string info_topic = "camera_info";
  std::string depth_topic = "depth/image_raw";
  std::string depth_info_topic = "depth/camera_info";
  std::string points_topic = "depth/points";
  LaserSpec ray;  ///< ray: the scan
};

/// Gazebo's tags in URDF text: every <gazebo reference="LINK"> holding a <sensor type="imu"> or
/// <sensor type="contact"> (with <update_rate>, <noise> or <imu><noise>), and the gazebo_ros
/// plugins libgazebo_ros_imu_sensor.so, libgazebo_ros_imu.so (bodyName, topicName, frameName,
/// updateRate / updateRateHZ, gaussianNoise), libgazebo_ros_ft_sensor.so (jointName, topicName,
/// updateRate, gaussianNoise) and libgazebo_ros_bumper.so (bumperTopicName, frameName). Other
/// sensors and plugins: one line each in *warnings naming them. Malformed XML: one warning.
std::vector<SensorSpec> sensors_from_urdf(const std::string& urdf_xml,
                                          std::vector<std::string>* warnings);
/// The same from a parsed URDF (one parse for every reader of its tags).
std::vector<SensorSpec> sensors_from_urdf(const UrdfXml& urdf, std::vector<std::string>* warnings);

/// One reading (preallocated; ready says it is new since the last take()).
struct SensorReading {
  bool ready = false;
  double stamp = 0;  ///< simulated time of the state shown
  // IMU
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< sensor frame in the world
  Vec3 angular_velocity = Vec3::Zero();                             ///< rad/s, sensor frame
  Vec3 linear_acceleration = Vec3::Zero();  ///< specific force a - g, m/s^2, sensor frame
  // force-torque: the wrench the child side applies on the parent side, sensor frame
  Vec3 force = Vec3::Zero(), torque = Vec3::Zero();
  // contact
  struct Touch {
    std::string other;  ///< the other collision object's name (a link, an object, "ground")
    std::string self;   ///< this link's collision object
    Vec3 position = Vec3::Zero();  ///< world
    Vec3 normal = Vec3::UnitZ();   ///< world, pointing into this link's body from the other
    double depth = 0;              ///< m, > 0 penetration
    Vec3 force = Vec3::Zero();     ///< N, world, on this link
  };
  std::vector<Touch> touches;  ///< first `count` valid (capacity kept)
  int count = 0;
  Vec3 total_force = Vec3::Zero();  ///< N, world
};

/// Thrown for a sensor the model cannot carry (unknown link or joint); names the sensor.
struct SensorError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// The sensors of one simulator. Call before_step() and after_step() around each
/// Simulator::step(); a reading is ready after the step that completes it.
class SensorSet {
 public:
  /// urdf_xml gives the per-link inertias a force-torque sensor on a fixed joint needs (fixed
  /// joints are merged in the model); "" is allowed when no sensor is on a fixed joint. robot:
  /// "" for the simulator's robot 0, else the name of the robot 1.. whose sensors these are
  /// (model is its model; its collision shapes are NAME/LINK, sim.h add_robot). A robot the
  /// simulator no longer has (deleted) gives no readings.
  SensorSet(const Model& model, const std::vector<SensorSpec>& specs,
            const std::string& urdf_xml = "", const std::string& robot = "");
  const std::vector<SensorSpec>& specs() const { return specs_; }
  int size() const { return static_cast<int>(specs_.size()); }
  /// Noise generators back to their seeds (the sensor name's FNV-1a hash), readings cleared.
  void reset();

  /// Keeps the state when a sensor samples it (steps() a multiple of its period).
  void before_step(const Simulator& sim);
  /// Computes the readings of the step just taken (ok: Simulator::step's result; a failed step
  /// drops them).
  void after_step(const Simulator& sim, bool ok = true);
  /// Reading i (ready until take(i)).
  const SensorReading& reading(int i) const { return readings_[i]; }
  void take(int i) { readings_[i].ready = false; }
  /// Steps between samples of sensor i.
  int period(int i) const { return sensors_[i].period; }

  /// The seed of a sensor's noise: FNV-1a (64-bit) of its name.
  static std::uint64_t seed_of(const std::string& name);

 private:
  struct Resolved {
    int body = 0;
    SE3 in_body;  ///< sensor frame in the body frame
    int period = 1;
    // force-torque
    bool whole_body = false;    ///< the joint is body `body`'s moving joint
    Inertia part;               ///< (fixed joint) the subtree's links on `body`, body frame
    std::vector<int> children;  ///< (fixed joint) child bodies hung from the subtree's links
    std::vector<int> links;     ///< link indices in the subtree (for contacts)
    std::vector<char> in_subtree_body;  ///< per body: wholly in the subtree
    std::mt19937_64 rng;
    Vec6 bias = Vec6::Zero();
    std::string collision_link;  ///< contact: its link's name in the scene collision
  };
  void sample(const Simulator& sim, int i);
  Vec6 external_wrench(const Simulator& sim, const Resolved& s) const;
  void fill_contacts(const Simulator& sim, int i);
  void draw_biases();
  /// The robot's index in sim (-1: deleted) and its link of collision object obj (-1: not
  /// the robot's).
  int robot_index(const Simulator& sim) const;
  int link_of(const CollisionObject& obj) const;
  double noise(Resolved& s, const SensorNoise& n);

  const Model* model_;
  std::string robot_;   ///< "" for robot 0, else the robot's name
  std::string prefix_;  ///< robot_ + "/" (its collision objects' link names), "" for robot 0
  std::vector<SensorSpec> specs_;
  std::vector<Resolved> sensors_;
  std::vector<SensorReading> readings_;
  Data data_;
  State x0_;
  VecX a_;
  double t0_ = 0;
  double dt_ = 0;  ///< the step size the periods were computed for
  bool pending_ = false;
  bool contact_step_ = false;  ///< the step was a velocity step (its contact forces are new)
  std::uint64_t step0_ = 0, velocity_steps0_ = 0;
};

}  // namespace se3
