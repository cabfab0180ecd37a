// The sensors of one robot on ROS (robot_sensors.h).
#include "se3_sim/ros/robot_sensors.h"

#include <geometry_msgs/WrenchStamped.h>
#include <sensor_msgs/Imu.h>

#include <utility>

#include "se3_sim/ContactsState.h"
#include "se3_sim/ros/convert.h"

namespace se3_ros {

void publish_reading(const se3::SensorSpec& s, const se3::SensorReading& r,
                     const std_msgs::Header& h, const std::string& world_frame,
                     ros::Publisher& pub) {
  const double var = s.noise.stddev * s.noise.stddev;
  if (s.type == se3::SensorType::Imu) {
    sensor_msgs::Imu msg;
    msg.header = h;
    msg.orientation.x = r.orientation.x();
    msg.orientation.y = r.orientation.y();
    msg.orientation.z = r.orientation.z();
    msg.orientation.w = r.orientation.w();
    msg.angular_velocity.x = r.angular_velocity.x();
    msg.angular_velocity.y = r.angular_velocity.y();
    msg.angular_velocity.z = r.angular_velocity.z();
    msg.linear_acceleration.x = r.linear_acceleration.x();
    msg.linear_acceleration.y = r.linear_acceleration.y();
    msg.linear_acceleration.z = r.linear_acceleration.z();
    for (int k = 0; k < 3; ++k) {
      msg.orientation_covariance[4 * k] = 0;  // exact
      msg.angular_velocity_covariance[4 * k] = var;
      msg.linear_acceleration_covariance[4 * k] = var;
    }
    pub.publish(msg);
  } else if (s.type == se3::SensorType::ForceTorque) {
    geometry_msgs::WrenchStamped msg;
    msg.header = h;
    msg.wrench.force.x = r.force.x();
    msg.wrench.force.y = r.force.y();
    msg.wrench.force.z = r.force.z();
    msg.wrench.torque.x = r.torque.x();
    msg.wrench.torque.y = r.torque.y();
    msg.wrench.torque.z = r.torque.z();
    pub.publish(msg);
  } else {
    se3_sim::ContactsState msg;
    msg.header = h;
    msg.header.frame_id = world_frame;
    msg.states.resize(r.count);
    auto vec = [](const se3::Vec3& v) {
      geometry_msgs::Vector3 o;
      o.x = v.x();
      o.y = v.y();
      o.z = v.z();
      return o;
    };
    for (int k = 0; k < r.count; ++k) {
      const se3::SensorReading::Touch& t = r.touches[k];
      se3_sim::ContactState& c = msg.states[k];
      c.info = "depth " + std::to_string(t.depth) + " m";
      c.collision1_name = t.self;
      c.collision2_name = t.other;
      geometry_msgs::Wrench w;
      w.force = vec(t.force);
      c.wrenches.push_back(w);
      c.total_wrench = w;
      c.contact_positions.push_back(vec(t.position));
      c.contact_normals.push_back(vec(t.normal));
      c.depths.push_back(t.depth);
    }
    pub.publish(msg);
  }
}

RobotSensors::RobotSensors(ros::NodeHandle nh, const se3::Model& model,
                           std::vector<se3::SensorSpec> specs, const std::string& urdf_xml,
                           const std::string& robot, const std::string& prefix,
                           std::string world_frame, bool use_sim_time)
    : world_frame_(std::move(world_frame)), use_sim_time_(use_sim_time) {
  std::vector<se3::SensorSpec> kept;
  for (se3::SensorSpec& s : specs) {
    if (se3::sensor_is_rendered(s.type)) {
      ROS_WARN(
          "simulator: robot %s: sensor %s: cameras and lasers are drawn for the first robot "
          "only; left out",
          robot.c_str(), s.name.c_str());
      continue;
    }
    kept.push_back(std::move(s));
  }
  if (kept.empty()) return;
  set_ = std::make_unique<se3::SensorSet>(model, kept, urdf_xml, robot);
  auto tf_name = [&](const std::string& name) {
    const std::string bare = se3::frame_name(name);
    return prefix.empty() ? bare : prefix + "/" + bare;
  };
  for (const se3::SensorSpec& s : kept) {
    const std::string topic = s.topic.empty() ? s.name : s.topic;
    std::string link = s.link;
    if (s.type == se3::SensorType::ForceTorque) {
      for (const se3::LinkFrame& l : model.links) {
        if (l.joint == s.joint) link = l.name;
      }
    }
    link = tf_name(link);
    std::string frame = s.frame;
    const bool at_link = s.pose.isApprox(se3::SE3(), 1e-12);
    if (s.type == se3::SensorType::Contact) {
      if (frame.empty()) frame = world_frame_;
    } else if (frame.empty()) {
      frame = at_link ? link : tf_name(s.name);
      if (!at_link) {
        geometry_msgs::TransformStamped t;
        t.header.frame_id = link;
        t.child_frame_id = frame;
        t.transform = to_transform(s.pose);
        tfs_.push_back(t);
      }
    }
    frames_.push_back(frame);
    if (s.type == se3::SensorType::Imu) {
      pubs_.push_back(nh.advertise<sensor_msgs::Imu>(topic, 100));
    } else if (s.type == se3::SensorType::ForceTorque) {
      pubs_.push_back(nh.advertise<geometry_msgs::WrenchStamped>(topic, 100));
    } else {
      pubs_.push_back(nh.advertise<se3_sim::ContactsState>(topic, 100));
    }
    ROS_INFO("simulator: robot %s: sensor %s on %s in frame %s at %g Hz", robot.c_str(),
             s.name.c_str(), pubs_.back().getTopic().c_str(), frame.c_str(), s.rate);
  }
}

void RobotSensors::before_step(const se3::Simulator& sim) {
  if (set_) set_->before_step(sim);
}

void RobotSensors::after_step(const se3::Simulator& sim, bool ok) {
  if (!set_) return;
  set_->after_step(sim, ok);
  for (int i = 0; i < set_->size(); ++i) {
    const se3::SensorReading& r = set_->reading(i);
    if (!r.ready) continue;
    set_->take(i);
    std_msgs::Header h;
    h.stamp = use_sim_time_ ? ros::Time(r.stamp) : ros::Time::now();
    h.frame_id = frames_[i];
    publish_reading(set_->specs()[i], r, h, world_frame_, pubs_[i]);
  }
}

void RobotSensors::reset() {
  if (set_) set_->reset();
}

}  // namespace se3_ros
