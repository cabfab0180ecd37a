// The ROS interface of robots 1.. of a simulator (robot_interfaces.h, docs/ros.md "Several
// robots").
#include "se3_sim/ros/robot_interfaces.h"

#include <sensor_msgs/JointState.h>
#include <std_msgs/Float64.h>
#include <std_msgs/Float64MultiArray.h>
#include <trajectory_msgs/JointTrajectory.h>

#include <algorithm>
#include <stdexcept>

#include "se3_sim/ChainState.h"
#include "se3_sim/JointTorques.h"
#include "se3_sim/model/limits.h"
#include "se3_sim/ros/controller_states.h"
#include "se3_sim/ros/convert.h"
#include "se3_sim/ros/params.h"
#include "se3_sim/ros/robot_sensors.h"

namespace se3_ros {

struct RobotInterfaces::Robot {
  /// The robot's index in the simulator: -1 before insert() and after remove() (its callbacks
  /// then do nothing); read and written under the node's lock.
  int k = -1;
  std::string name, ns;
  const se3::Model* model = nullptr;  ///< the simulator's, or `own` for a spawned robot
  se3::Model own;
  bool spawned = false;  ///< its fixed joints on /tf too, so that all its frames stop with it
  ros::NodeHandle rnh;
  se3::Model tf_model;  ///< its links named NS/LINK
  JointTable joints;
  TfTree tree;
  ros::Publisher joint_pub, chain_pub;
  ros::Subscriber cmd_sub;
  std::vector<ros::Subscriber> ctl_subs;
  TorqueCommand torque;
  sensor_msgs::JointState js;
  se3_sim::ChainState cs;
  std::unique_ptr<ControllerStates> ctl_states;  ///< null without controllers
  se3::VecX effort;
  std::vector<se3::SE3> links;
  std::vector<geometry_msgs::TransformStamped> tfs;
  std::unique_ptr<RobotSensors> sensors;  ///< null without sensors
};

std::string robot_ros_namespace(const se3::Simulator& sim, int k) {
  const std::string& ns = sim.robot_namespace(k);
  return ns.empty() ? sim.robot_name(k) : ns;
}

bool find_robot_link(const se3::Simulator& sim, const std::string& frame, int& robot, int& link) {
  if (sim.robot_count() > 0) {
    link = sim.robot_model(0).link_index(frame);
    if (link >= 0) {
      robot = 0;
      return true;
    }
  }
  for (int k = 1; k < sim.robot_count(); ++k) {
    const std::string ns = robot_ros_namespace(sim, k) + "/";
    if (frame.size() <= ns.size() || frame.compare(0, ns.size(), ns) != 0) continue;
    link = sim.robot_model(k).link_index(frame.substr(ns.size()));
    if (link >= 0) {
      robot = k;
      return true;
    }
  }
  robot = link = -1;
  return false;
}

se3::Model prefixed_links(const se3::Model& model, const std::string& prefix) {
  se3::Model m = model;
  if (prefix.empty()) return m;
  for (se3::LinkFrame& L : m.links) L.name = prefix + "/" + L.name;
  return m;
}

RobotInterfaces::RobotInterfaces(ros::NodeHandle nh, const se3::Simulator& sim,
                                 const se3::Scene& scene, std::string world_frame,
                                 double max_effort, double max_wrench, WithSim with_sim)
    : nh_(nh),
      world_frame_(std::move(world_frame)),
      max_effort_(max_effort),
      max_wrench_(max_wrench),
      with_sim_(std::move(with_sim)) {
  use_sim_time_ = get_bool(nh, "/use_sim_time").value_or(false);
  for (int k = 1; k < sim.robot_count(); ++k) {
    RobotPtr r(new Robot);
    Robot& R = *r;
    R.k = k;
    R.name = sim.robot_name(k);
    R.ns = robot_ros_namespace(sim, k);
    R.model = &sim.robot_model(k);
    const se3::Scene* entry =
        k - 1 < static_cast<int>(scene.extra_robots.size()) ? &scene.extra_robots[k - 1] : nullptr;
    R.rnh = ros::NodeHandle(nh, R.ns);
    std::string text;
    if (entry && !entry->robot_path.empty()) {
      std::string why;
      if (!se3::read_file(entry->robot_path, text, &why)) {
        throw std::runtime_error("robot '" + sim.robot_name(k) + "': cannot read " +
                                 entry->robot_path + ": " + why);
      }
      R.rnh.setParam("robot_description", text);
    }
    // Its robots: entry's sensors, then its URDF's Gazebo tags (as robot 0's: scene_sensors).
    std::vector<std::string> warnings;
    const std::vector<se3::SensorSpec> sensors =
        entry ? se3::scene_sensors(*entry, text, &warnings) : std::vector<se3::SensorSpec>{};
    for (const std::string& w : warnings) {
      ROS_WARN("simulator: robot %s: %s", R.name.c_str(), w.c_str());
    }
    connect(R, entry ? entry->locked_joints : std::vector<std::pair<std::string, double>>{},
            entry ? entry->controllers : std::vector<se3::ControllerSpec>{}, sensors, text);
    robots_.push_back(std::move(r));
  }
}

void RobotInterfaces::RobotDeleter::operator()(Robot* r) const {
  delete r;
}

RobotInterfaces::RobotPtr RobotInterfaces::prepare(const se3::Model& model, const std::string& name,
                                                   const std::string& ns, const std::string& urdf) {
  RobotPtr r(new Robot);
  Robot& R = *r;
  R.name = name;
  R.ns = ns.empty() ? name : ns;
  R.own = model;
  R.model = &R.own;
  R.spawned = true;
  R.rnh = ros::NodeHandle(nh_, R.ns);  // throws ros::InvalidNameException
  R.rnh.setParam("robot_description", urdf);
  std::vector<std::string> warnings;
  const std::vector<se3::SensorSpec> sensors = se3::sensors_from_urdf(urdf, &warnings);
  for (const std::string& w : warnings)
    ROS_WARN("simulator: robot %s: %s", name.c_str(), w.c_str());
  connect(R, {}, {}, sensors, urdf);
  return r;
}

void RobotInterfaces::insert(RobotPtr r, const se3::Simulator& sim) {
  r->k = sim.robot_index(r->name);
  robots_.push_back(std::move(r));
}

RobotInterfaces::RobotPtr RobotInterfaces::remove(const std::string& name,
                                                  const se3::Simulator& sim) {
  RobotPtr out;
  for (auto it = robots_.begin(); it != robots_.end(); ++it) {
    if ((*it)->name != name) continue;
    out = std::move(*it);
    out->k = -1;
    robots_.erase(it);
    break;
  }
  for (const RobotPtr& r : robots_) r->k = sim.robot_index(r->name);
  return out;
}

void RobotInterfaces::discard(RobotPtr r) {
  if (!r) return;
  if (r->spawned) r->rnh.deleteParam("robot_description");
  r.reset();  // its publishers and subscribers shut down
}

void RobotInterfaces::connect(Robot& R, const std::vector<std::pair<std::string, double>>& locked,
                              const std::vector<se3::ControllerSpec>& specs,
                              const std::vector<se3::SensorSpec>& sensors,
                              const std::string& urdf) {
  ros::NodeHandle& rnh = R.rnh;
  if (!sensors.empty()) {
    try {
      R.sensors = std::make_unique<RobotSensors>(rnh, *R.model, sensors, urdf, R.name, R.ns,
                                                 world_frame_, use_sim_time_);
    } catch (const se3::SensorError& e) {
      if (!R.spawned) throw std::runtime_error("robot '" + R.name + "': " + e.what());
      ROS_WARN("simulator: robot %s: %s; its sensors are left out", R.name.c_str(), e.what());
    }
  }
  R.tf_model = prefixed_links(*R.model, R.ns);
  R.joints = joint_table(*R.model, locked);
  R.tree = tf_tree(R.tf_model, world_frame_);
  if (R.spawned) {
    // Its fixed joints on /tf as well: /tf_static would keep them after a delete.
    R.tree.moving.insert(R.tree.moving.end(), R.tree.fixed.begin(), R.tree.fixed.end());
    std::sort(R.tree.moving.begin(), R.tree.moving.end());
    R.tree.fixed.clear();
  }
  R.joint_pub = rnh.advertise<sensor_msgs::JointState>("joint_states", 10);
  R.chain_pub = rnh.advertise<se3_sim::ChainState>("chain_state", 10);
  R.cmd_sub = rnh.subscribe<se3_sim::JointTorques>(
      "torque_command", 1000,
      [this, &R](const se3_sim::JointTorques::ConstPtr& msg) {
        TorqueCommand cmd;
        const std::string why =
            check_torque_command(*R.model, R.joints, *msg, max_effort_, max_wrench_, cmd);
        if (!why.empty()) {
          ROS_WARN_THROTTLE(1.0, "simulator: %s/torque_command refused: %s", R.ns.c_str(),
                            why.c_str());
          return;
        }
        with_sim_([&](se3::Simulator& s) {
          if (R.k < 1) return;  // not inserted yet, or removed
          for (const auto& ie : cmd.efforts) {
            if (ie.first > 0) s.set_robot_joint_effort(R.k, ie.first, ie.second);
          }
          if (cmd.has_base_wrench) s.set_robot_base_wrench(R.k, cmd.base_wrench);
        });
      },
      ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  // The scene's controllers of this robot: NS/NAME/command.
  for (size_t c = 0; c < specs.size(); ++c) {
    const se3::ControllerSpec& s = specs[c];
    const int ci = static_cast<int>(c);
    const std::string topic = s.name + "/command";
    auto set_command = [this, &R, ci](const double* values, size_t n) {
      std::string why;
      with_sim_([&](se3::Simulator& s) {
        if (R.k < 1) return;
        if (se3::ControllerSet* set = s.robot_controllers(R.k)) {
          why = set->set_command(ci, values, n);
        }
      });
      if (!why.empty()) {
        ROS_WARN_THROTTLE(1.0, "simulator: %s controller command refused: %s", R.ns.c_str(),
                          why.c_str());
      }
    };
    if (s.kind == se3::ControllerKind::Trajectory) {
      R.ctl_subs.push_back(rnh.subscribe<trajectory_msgs::JointTrajectory>(
          topic, 100,
          [this, &R, ci](const trajectory_msgs::JointTrajectory::ConstPtr& msg) {
            se3::TrajectoryCommand cmd = from_trajectory(*msg);
            std::string why;
            with_sim_([&](se3::Simulator& s) {
              // header.stamp is taken as simulated time when not zero (use_sim_time).
              if (!msg->header.stamp.isZero()) cmd.start = msg->header.stamp.toSec();
              if (R.k < 1) return;
              if (se3::ControllerSet* set = s.robot_controllers(R.k)) {
                why = set->set_trajectory(ci, cmd, s.time());
              }
            });
            if (!why.empty()) {
              ROS_WARN_THROTTLE(1.0, "simulator: %s trajectory refused: %s", R.ns.c_str(),
                                why.c_str());
            }
          },
          ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay()));
    } else if (se3::single_joint(s.kind)) {
      R.ctl_subs.push_back(rnh.subscribe<std_msgs::Float64>(
          topic, 1000,
          [set_command](const std_msgs::Float64::ConstPtr& msg) { set_command(&msg->data, 1); },
          ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay()));
    } else {
      R.ctl_subs.push_back(rnh.subscribe<std_msgs::Float64MultiArray>(
          topic, 1000,
          [set_command](const std_msgs::Float64MultiArray::ConstPtr& msg) {
            set_command(msg->data.data(), msg->data.size());
          },
          ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay()));
    }
    ROS_INFO("simulator: robot %s: controller %s (%s) on %s", R.name.c_str(), s.name.c_str(),
             s.type.c_str(), R.ctl_subs.back().getTopic().c_str());
  }
  if (!specs.empty()) R.ctl_states = std::make_unique<ControllerStates>(rnh, specs, R.name);
  ROS_INFO("simulator: robot %s (%d joints, %s base) on %s/joint_states, TF frames %s/LINK",
           R.name.c_str(), R.model->n, R.model->floating ? "free" : "fixed",
           rnh.getNamespace().c_str(), R.ns.c_str());
}

RobotInterfaces::~RobotInterfaces() = default;

std::vector<geometry_msgs::TransformStamped> RobotInterfaces::static_transforms(
    const ros::Time& stamp) const {
  std::vector<geometry_msgs::TransformStamped> out;
  for (const auto& r : robots_) {
    const auto t = tf_static_transforms(r->tf_model, r->tree, stamp);
    out.insert(out.end(), t.begin(), t.end());
    if (!r->sensors) continue;
    for (geometry_msgs::TransformStamped s : r->sensors->static_transforms()) {
      s.header.stamp = stamp;
      out.push_back(s);
    }
  }
  return out;
}

void RobotInterfaces::before_step(const se3::Simulator& sim) {
  for (const auto& r : robots_) {
    if (r->k >= 1 && r->sensors) r->sensors->before_step(sim);
  }
}

void RobotInterfaces::after_step(const se3::Simulator& sim, bool ok) {
  for (const auto& r : robots_) {
    if (r->k >= 1 && r->sensors) r->sensors->after_step(sim, ok);
  }
}

void RobotInterfaces::reset_sensors() {
  for (const auto& r : robots_) {
    if (r->sensors) r->sensors->reset();
  }
}

void RobotInterfaces::publish(se3::Simulator& sim, const ros::Time& stamp,
                              tf2_ros::TransformBroadcaster& tf) {
  for (const auto& rp : robots_) {
    Robot& R = *rp;
    if (R.k < 1) continue;
    const se3::Model& m = *R.model;
    const se3::State& x = sim.robot_state(R.k);
    sim.robot_applied_joint_efforts(R.k, R.effort);  // as the first robot's
    fill_joint_state(m, R.joints, x, R.effort, R.js);
    R.js.header.stamp = stamp;
    sim.robot_link_poses(R.k, R.links);
    tf_transforms(R.tf_model, R.tree, R.links, world_frame_, stamp, R.tfs);
    fill_chain_state(m, R.js, x, sim.robot_kinetic_energy(R.k), sim.robot_potential_energy(R.k),
                     R.cs);
    R.cs.header.stamp = stamp;
    R.cs.header.frame_id = world_frame_;
    R.joint_pub.publish(R.js);
    tf.sendTransform(R.tfs);
    R.chain_pub.publish(R.cs);
  }
}

void RobotInterfaces::publish_controller_states(se3::Simulator& sim, const ros::Time& stamp) {
  for (const auto& rp : robots_) {
    Robot& R = *rp;
    if (R.k < 1 || !R.ctl_states) continue;
    if (const se3::ControllerSet* set = sim.robot_controllers(R.k)) {
      R.ctl_states->publish(*set, sim.time(), stamp);
    }
  }
}

}  // namespace se3_ros
