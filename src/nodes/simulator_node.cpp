// simulator_node: the ROS adapter of se3::Simulator (DESIGN.md, ROS interface).
//
// Physics runs in the main thread, paced by the steady clock at ~real_time_factor (0: as fast
// as possible); callbacks (commands, services) run on an AsyncSpinner and share the simulator
// under one mutex. State is published at ~publish_rate (wall clock).
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/JointState.h>
#include <std_srvs/Empty.h>
#include <tf2_ros/transform_broadcaster.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <memory>
#include <mutex>
#include <sstream>
#include <thread>

#include "se3_sim/ChainState.h"
#include "se3_sim/ConstraintForces.h"
#include "se3_sim/JointTorques.h"
#include "se3_sim/SimStats.h"
#include "se3_sim/Step.h"
#include "se3_sim/sim.h"

namespace {

using Clock = std::chrono::steady_clock;

double seconds(Clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read '" + path + "'");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

geometry_msgs::Transform to_transform(const se3::SE3& f) {
  geometry_msgs::Transform t;
  t.translation.x = f.p.x();
  t.translation.y = f.p.y();
  t.translation.z = f.p.z();
  const Eigen::Vector4d q = se3::quaternion_from_rotation(f.R);
  t.rotation.x = q[0];
  t.rotation.y = q[1];
  t.rotation.z = q[2];
  t.rotation.w = q[3];
  return t;
}

geometry_msgs::Pose to_pose(const se3::SE3& f) {
  const geometry_msgs::Transform t = to_transform(f);
  geometry_msgs::Pose p;
  p.position.x = t.translation.x;
  p.position.y = t.translation.y;
  p.position.z = t.translation.z;
  p.orientation = t.rotation;
  return p;
}

double finite_or_zero(double x) {
  return std::isfinite(x) ? x : 0.0;
}

class SimulatorNode {
 public:
  SimulatorNode() : pnh_("~") {}

  bool init() {
    try {
      configure();
    } catch (const std::exception& e) {
      ROS_FATAL("simulator: %s", e.what());
      return false;
    }
    joint_pub_ = nh_.advertise<sensor_msgs::JointState>("joint_states", 10);
    chain_pub_ = nh_.advertise<se3_sim::ChainState>("chain_state", 10);
    stats_pub_ = nh_.advertise<se3_sim::SimStats>("sim_stats", 10);
    marker_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("sim_markers", 10);
    constraint_pub_ = nh_.advertise<se3_sim::ConstraintForces>("constraint_forces", 10);
    if (use_sim_time_) clock_pub_ = nh_.advertise<rosgraph_msgs::Clock>("/clock", 10);
    tf_ = std::make_unique<tf2_ros::TransformBroadcaster>();
    cmd_sub_ = nh_.subscribe("torque_command", 20, &SimulatorNode::on_command, this,
                             ros::TransportHints().tcpNoDelay());
    srv_reset_ = nh_.advertiseService("simulator/reset", &SimulatorNode::on_reset, this);
    srv_pause_ = nh_.advertiseService("simulator/pause", &SimulatorNode::on_pause, this);
    srv_resume_ = nh_.advertiseService("simulator/resume", &SimulatorNode::on_resume, this);
    srv_step_ = nh_.advertiseService("simulator/step", &SimulatorNode::on_step, this);
    return true;
  }

  void run() {
    ros::AsyncSpinner spinner(2);
    spinner.start();
    const Clock::duration pub_period =
        std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate_));
    Clock::time_point next_pub = Clock::now();
    period_start_ = Clock::now();
    anchor_ = Clock::now();
    while (ros::ok()) {
      Clock::time_point now = Clock::now();
      Clock::time_point wake = next_pub;
      {
        std::lock_guard<std::mutex> lock(mu_);
        expire_command(now);
        if (!paused_) {
          if (rtf_ > 0) {
            // Steps due by now at the real-time factor; a backlog of more than 0.2 s of wall
            // time is dropped (the simulation slows instead of racing to catch up).
            const double due_f = seconds(now - anchor_) * rtf_ / sim_->dt();
            auto due = static_cast<std::int64_t>(due_f) - static_cast<std::int64_t>(anchored_);
            const std::int64_t backlog = static_cast<std::int64_t>(0.2 * rtf_ / sim_->dt()) + 1;
            if (due > backlog) {
              anchor_ = now;
              anchored_ = 0;
              due = 1;
            }
            for (std::int64_t k = 0; k < due && !paused_; ++k) physics_step();
            const double next_s = (anchored_ + 1) * sim_->dt() / rtf_;
            wake = std::min(wake, anchor_ + std::chrono::duration_cast<Clock::duration>(
                                                std::chrono::duration<double>(next_s)));
          } else {
            // As fast as possible, in chunks, until the next publication is due.
            for (int k = 0; k < 64 && !paused_; ++k) physics_step();
            wake = now;
          }
        }
      }
      now = Clock::now();
      if (now >= next_pub) {
        publish(now);
        next_pub += pub_period;
        if (next_pub <= now) next_pub = now + pub_period;  // fell behind: skip, keep the rate
      }
      if (wake > now) std::this_thread::sleep_until(std::min(wake, next_pub));
    }
    spinner.stop();
  }

 private:
  void configure() {
    std::string scene_path;
    pnh_.param<std::string>("scene", scene_path, "");
    if (!scene_path.empty()) {
      scene_ = se3::load_scene(scene_path);
    }
    std::string urdf_file, urdf_xml;
    pnh_.param<std::string>("urdf_file", urdf_file, "");
    nh_.param<std::string>("robot_description", urdf_xml, "");
    const bool had_description = !urdf_xml.empty();
    if (urdf_xml.empty() && !urdf_file.empty()) urdf_xml = read_file(urdf_file);
    if (urdf_xml.empty() && scene_path.empty()) {
      throw std::runtime_error(
          "no robot: set robot_description, ~urdf_file or ~scene (a scene YAML)");
    }
    override_bool("floating", scene_.floating);
    override_string("integrator", scene_.integrator);
    override_double("dt", scene_.dt);
    override_double("tol", scene_.tol);
    override_double("real_time_factor", scene_.real_time_factor);
    override_double("publish_rate", scene_.publish_rate);
    pnh_.param("command_timeout", command_timeout_, 0.5);
    pnh_.param<std::string>("world_frame", world_frame_, "world");
    world_frame_ = se3::frame_name(world_frame_);  // tf2 frame names have no leading '/'
    nh_.param("/use_sim_time", use_sim_time_, false);
    if (!(scene_.dt > 0) || !std::isfinite(scene_.dt)) throw std::runtime_error("~dt must be > 0");
    if (!(scene_.real_time_factor >= 0) || !std::isfinite(scene_.real_time_factor)) {
      throw std::runtime_error("~real_time_factor must be >= 0");
    }
    if (!(scene_.publish_rate > 0) || !std::isfinite(scene_.publish_rate)) {
      throw std::runtime_error("~publish_rate must be > 0");
    }
    if (!(command_timeout_ > 0)) throw std::runtime_error("~command_timeout must be > 0");
    sim_ = se3::make_simulator(scene_, urdf_xml);
    rtf_ = scene_.real_time_factor;
    rate_ = scene_.publish_rate;
    const se3::Model& m = sim_->model();
    if (!had_description) {
      // Others (renderer, teleop) read the robot from robot_description.
      const se3::GeometryModel chain = se3::chain_geometry(m);  // chain:N has no file
      const std::string text = !urdf_xml.empty() ? urdf_xml
                               : scene_.robot_path.compare(0, 6, "chain:") == 0
                                   ? se3::model_to_urdf(m, &chain)
                                   : read_file(scene_.robot_path);
      nh_.setParam("robot_description", text);
    }
    for (const auto& kv : scene_.locked_joints) locked_.push_back(kv);
    names_.clear();
    for (int i = 1; i <= m.n; ++i) names_.push_back(m.joint_name[i]);
    for (const auto& kv : locked_) names_.push_back(kv.first);
    ROS_INFO(
        "simulator: %s, %d joints (%s base), %s, dt %g s, real-time factor %g, publishing "
        "at %g Hz",
        scene_.name.empty() ? m.name.c_str() : scene_.name.c_str(), m.n,
        m.floating ? "free" : "fixed", sim_->integrator().c_str(), sim_->dt(), rtf_, rate_);
  }

  // Scene overrides: a private parameter that is set and not the empty string (sim.launch
  // always sets them, empty meaning "the scene's", so stale values on a running master from an
  // earlier launch do not leak into this one).
  bool override_value(const std::string& name, std::string& text) {
    XmlRpc::XmlRpcValue v;
    if (!pnh_.getParam(name, v)) return false;
    switch (v.getType()) {
      case XmlRpc::XmlRpcValue::TypeString:
        text = static_cast<std::string>(v);
        return !text.empty();
      case XmlRpc::XmlRpcValue::TypeDouble:
        text = std::to_string(static_cast<double>(v));
        return true;
      case XmlRpc::XmlRpcValue::TypeInt:
        text = std::to_string(static_cast<int>(v));
        return true;
      case XmlRpc::XmlRpcValue::TypeBoolean:
        text = static_cast<bool>(v) ? "true" : "false";
        return true;
      default:
        throw std::runtime_error("~" + name + " has an unusable type");
    }
  }
  void override_string(const std::string& name, std::string& out) {
    std::string t;
    if (override_value(name, t)) out = t;
  }
  void override_double(const std::string& name, double& out) {
    std::string t;
    if (!override_value(name, t)) return;
    char* end = nullptr;
    const double x = std::strtod(t.c_str(), &end);
    if (*end != '\0' || !std::isfinite(x)) {
      throw std::runtime_error("~" + name + " needs a number, got '" + t + "'");
    }
    out = x;
  }
  void override_bool(const std::string& name, bool& out) {
    std::string t;
    if (!override_value(name, t)) return;
    if (t == "true" || t == "True" || t == "1") {
      out = true;
    } else if (t == "false" || t == "False" || t == "0") {
      out = false;
    } else {
      throw std::runtime_error("~" + name + " needs true or false, got '" + t + "'");
    }
  }

  // Under mu_. One physics step with timing; the guard pauses the simulator.
  void physics_step() {
    const Clock::time_point t0 = Clock::now();
    const bool ok = sim_->step();
    step_wall_ += Clock::now() - t0;
    ++period_steps_;
    if (ok) {
      ++anchored_;
      clock_ += sim_->dt();
      return;
    }
    paused_ = true;
    status_ = sim_->failure();
    ROS_ERROR("simulator paused by the divergence guard: %s", status_.c_str());
  }

  // Under mu_. A command older than command_timeout (by receive time) stops acting.
  void expire_command(Clock::time_point now) {
    if (command_active_ && seconds(now - command_time_) > command_timeout_) {
      sim_->clear_command();
      command_active_ = false;
    }
  }

  void reject(const std::string& why) {
    ++rejected_;
    ROS_WARN_THROTTLE(1.0, "simulator: torque command rejected (%s); %llu rejected so far",
                      why.c_str(), static_cast<unsigned long long>(rejected_));
  }

  void on_command(const se3_sim::JointTorques::ConstPtr& msg) {
    std::lock_guard<std::mutex> lock(mu_);
    const se3::Model& m = sim_->model();
    if (msg->name.size() != msg->effort.size()) {
      reject("name/effort lengths differ: " + std::to_string(msg->name.size()) + " vs " +
             std::to_string(msg->effort.size()));
      return;
    }
    std::vector<int> idx(msg->name.size(), 0);
    for (size_t k = 0; k < msg->name.size(); ++k) {
      if (!std::isfinite(msg->effort[k])) {
        reject("non-finite effort for '" + msg->name[k] + "'");
        return;
      }
      idx[k] = m.joint_index(msg->name[k]);
      if (idx[k] < 1) {
        bool locked = false;
        for (const auto& kv : locked_) locked = locked || kv.first == msg->name[k];
        if (!locked) {
          reject("unknown joint '" + msg->name[k] + "'");
          return;
        }
        idx[k] = 0;  // a locked joint: known, but it cannot move
      }
    }
    se3::Vec6 w = se3::Vec6::Zero();
    if (msg->has_base_wrench) {
      const auto& b = msg->base_wrench;
      w << b.torque.x, b.torque.y, b.torque.z, b.force.x, b.force.y, b.force.z;
      if (!w.allFinite()) {
        reject("non-finite base wrench");
        return;
      }
      if (!m.floating) {
        ROS_WARN_THROTTLE(5.0, "simulator: base wrench ignored (the base is fixed)");
      }
    }
    sim_->clear_command();
    for (size_t k = 0; k < idx.size(); ++k) {
      if (idx[k] > 0) sim_->set_joint_effort(idx[k], msg->effort[k]);
    }
    sim_->set_base_wrench(w);
    command_active_ = true;
    command_time_ = Clock::now();
  }

  bool on_reset(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
    std::lock_guard<std::mutex> lock(mu_);
    sim_->reset();
    command_active_ = false;
    status_.clear();
    anchor_ = Clock::now();
    anchored_ = 0;
    ROS_INFO("simulator: reset to the initial state");
    return true;
  }

  bool on_pause(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
    std::lock_guard<std::mutex> lock(mu_);
    paused_ = true;
    return true;
  }

  bool on_resume(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
    std::lock_guard<std::mutex> lock(mu_);
    if (!sim_->failure().empty()) {
      ROS_WARN("simulator: cannot resume after divergence (%s); call simulator/reset",
               sim_->failure().c_str());
      return true;
    }
    paused_ = false;
    anchor_ = Clock::now();
    anchored_ = 0;
    return true;
  }

  bool on_step(se3_sim::Step::Request& req, se3_sim::Step::Response& res) {
    std::lock_guard<std::mutex> lock(mu_);
    if (!paused_) {
      res.success = false;
      res.message = "the simulator is running; call simulator/pause first";
    } else if (!sim_->failure().empty()) {
      res.success = false;
      res.message = "diverged: " + sim_->failure() + "; call simulator/reset";
    } else {
      expire_command(Clock::now());
      std::uint32_t done = 0;
      while (done < req.steps && sim_->failure().empty()) {
        physics_step();
        if (sim_->failure().empty()) ++done;
      }
      res.success = done == req.steps;
      res.message = res.success ? "stepped " + std::to_string(done)
                                : "stopped after " + std::to_string(done) + ": " + status_;
    }
    res.sim_time = sim_->time();
    return true;
  }

  // Constraint and contact forces as a message and as arrows on sim_markers (namespace
  // "constraint"): one arrow per constraint row group, from the application point along the
  // force, 0.3 m for a force equal to the robot's weight (at least 2 cm, at most 0.6 m).
  void add_constraint_forces(const se3::ConstraintSystem& sys, const se3::Model& m,
                             const std_msgs::Header& header, se3_sim::ConstraintForces& cf,
                             visualization_msgs::MarkerArray& markers) const {
    cf.header = header;
    const double weight = std::max(m.total_mass() * 9.81, 1e-6);
    const std::vector<se3::ConstraintForce>& forces = sys.forces();
    for (size_t k = 0; k < forces.size(); ++k) {
      const se3::ConstraintForce& f = forces[k];
      const bool ok = f.point.allFinite() && f.force.allFinite() && f.torque.allFinite();
      geometry_msgs::Point p;
      geometry_msgs::Vector3 F, T;
      if (ok) {
        p.x = f.point.x(), p.y = f.point.y(), p.z = f.point.z();
        F.x = f.force.x(), F.y = f.force.y(), F.z = f.force.z();
        T.x = f.torque.x(), T.y = f.torque.y(), T.z = f.torque.z();
      }
      cf.name.push_back(f.name);
      cf.kind.push_back(static_cast<uint8_t>(f.kind));
      cf.link.push_back(f.body >= 0 && f.body <= m.n ? m.body_name[f.body] : std::string());
      cf.point.push_back(p);
      cf.force.push_back(F);
      cf.torque.push_back(T);
      cf.joint_force.push_back(finite_or_zero(f.joint_force));
      cf.gap.push_back(finite_or_zero(f.gap));
      cf.active.push_back(ok && f.active);

      visualization_msgs::Marker a;
      a.header = header;
      a.ns = "constraint";
      a.id = static_cast<int>(k);
      a.type = visualization_msgs::Marker::ARROW;
      const double mag = ok ? f.force.norm() : 0.0;
      if (!(ok && f.active) || mag <= 0) {
        a.action = visualization_msgs::Marker::DELETE;
        markers.markers.push_back(a);
        continue;
      }
      a.action = visualization_msgs::Marker::ADD;
      const double len = std::min(0.6, std::max(0.02, 0.3 * mag / weight));
      const se3::Vec3 tip = f.point + f.force / mag * len;
      geometry_msgs::Point p1;
      p1.x = tip.x(), p1.y = tip.y(), p1.z = tip.z();
      a.points = {p, p1};
      a.pose.orientation.w = 1;
      a.scale.x = 0.008;
      a.scale.y = 0.016;
      a.scale.z = 0.024;
      a.color.g = 0.9;
      a.color.b = f.kind == se3::ConstraintForce::Contact ? 0.2 : 0.9;
      a.color.a = 1.0;
      markers.markers.push_back(a);
    }
  }

  void publish(Clock::time_point now) {
    sensor_msgs::JointState js;
    se3_sim::ChainState cs;
    se3_sim::SimStats st;
    visualization_msgs::MarkerArray markers;
    se3_sim::ConstraintForces cf;
    bool constrained = false;
    std::vector<geometry_msgs::TransformStamped> tfs;
    rosgraph_msgs::Clock clock_msg;
    {
      std::lock_guard<std::mutex> lock(mu_);
      const se3::Model& m = sim_->model();
      const se3::State& x = sim_->state();
      const ros::Time stamp = use_sim_time_ ? ros::Time(clock_) : ros::Time::now();
      clock_msg.clock = ros::Time(clock_);
      sim_->applied_joint_efforts(effort_);
      const int off = m.floating ? 6 : 0;
      js.header.stamp = stamp;
      js.name = names_;
      js.position.resize(names_.size(), 0.0);
      js.velocity.resize(names_.size(), 0.0);
      js.effort.resize(names_.size(), 0.0);
      for (int i = 0; i < m.n; ++i) {
        js.position[i] = x.q[i];
        js.velocity[i] = x.v[off + i];
        js.effort[i] = finite_or_zero(effort_[i]);
      }
      for (size_t k = 0; k < locked_.size(); ++k) js.position[m.n + k] = locked_[k].second;
      // TF: every URDF link in the world frame.
      sim_->link_poses(links_);
      for (size_t k = 0; k < links_.size(); ++k) {
        if (m.links[k].name == world_frame_) continue;
        geometry_msgs::TransformStamped t;
        t.header.stamp = stamp;
        t.header.frame_id = world_frame_;
        t.child_frame_id = m.links[k].name;
        t.transform = to_transform(links_[k]);
        tfs.push_back(t);
      }
      // Chain state.
      cs.header.stamp = stamp;
      cs.header.frame_id = world_frame_;
      cs.base_pose = to_pose(x.base);
      if (m.floating) {
        cs.base_twist.angular.x = x.v[0];
        cs.base_twist.angular.y = x.v[1];
        cs.base_twist.angular.z = x.v[2];
        cs.base_twist.linear.x = x.v[3];
        cs.base_twist.linear.y = x.v[4];
        cs.base_twist.linear.z = x.v[5];
      }
      cs.name = js.name;
      cs.position = js.position;
      cs.velocity = js.velocity;
      cs.effort = js.effort;
      const double T = sim_->kinetic_energy();
      const double U = sim_->potential_energy();
      cs.kinetic_energy = finite_or_zero(T);
      cs.potential_energy = finite_or_zero(U);
      // Stats over the last publish period.
      const double wall = seconds(now - period_start_);
      st.header.stamp = stamp;
      st.integrator = sim_->integrator();
      st.dt = sim_->dt();
      st.sim_time = sim_->time();
      st.step_time_mean = period_steps_ ? seconds(step_wall_) / period_steps_ : 0.0;
      st.real_time_factor = wall > 0 ? period_steps_ * sim_->dt() / wall : 0.0;
      const double T0 = sim_->initial_kinetic_energy();
      st.energy_drift_rel = finite_or_zero(std::abs(T + U - T0) / std::max(T0, 1e-12));
      st.steps = sim_->steps();
      st.rejected_commands = rejected_;
      st.paused = paused_;
      st.status = status_;
      period_steps_ = 0;
      step_wall_ = Clock::duration::zero();
      period_start_ = now;
      // Markers: centre of mass, and an arrow along each joint axis with a commanded effort.
      const se3::Vec3 c = sim_->center_of_mass();
      visualization_msgs::Marker com;
      com.header.stamp = stamp;
      com.header.frame_id = world_frame_;
      com.ns = "com";
      com.id = 0;
      com.type = visualization_msgs::Marker::SPHERE;
      com.action = visualization_msgs::Marker::ADD;
      com.pose.position.x = c.x();
      com.pose.position.y = c.y();
      com.pose.position.z = c.z();
      com.pose.orientation.w = 1;
      com.scale.x = com.scale.y = com.scale.z = 0.05;
      com.color.r = 1.0;
      com.color.g = 0.8;
      com.color.a = 1.0;
      markers.markers.push_back(com);
      if (scene_.has_base_visual) {  // the scene's box on the base link (e.g. a satellite bus)
        visualization_msgs::Marker bus;
        bus.header = com.header;
        bus.ns = "base_visual";
        bus.id = 0;
        bus.type = visualization_msgs::Marker::CUBE;
        bus.action = visualization_msgs::Marker::ADD;
        bus.pose = to_pose(se3::SE3(x.base.R, x.base.act(scene_.base_visual_origin)));
        bus.scale.x = scene_.base_visual_box.x();
        bus.scale.y = scene_.base_visual_box.y();
        bus.scale.z = scene_.base_visual_box.z();
        bus.color.r = scene_.base_visual_color.x();
        bus.color.g = scene_.base_visual_color.y();
        bus.color.b = scene_.base_visual_color.z();
        bus.color.a = 1.0;
        markers.markers.push_back(bus);
      }
      const std::vector<se3::SE3>& oMb = sim_->body_poses();
      for (int i = 1; i <= m.n; ++i) {
        visualization_msgs::Marker a;
        a.header = com.header;
        a.ns = "torque";
        a.id = i;
        a.type = visualization_msgs::Marker::ARROW;
        const double e = sim_->command()[off + i - 1];
        if (e == 0) {
          a.action = visualization_msgs::Marker::DELETE;
          markers.markers.push_back(a);
          continue;
        }
        a.action = visualization_msgs::Marker::ADD;
        const double lim = std::isfinite(m.effort[i]) && m.effort[i] > 0 ? m.effort[i] : 10.0;
        const se3::Vec3 o = oMb[i].p, axis = oMb[i].R.col(2) * (e > 0 ? 1.0 : -1.0);
        const se3::Vec3 tip = o + axis * (0.05 + 0.25 * std::min(1.0, std::abs(e) / lim));
        geometry_msgs::Point p0, p1;
        p0.x = o.x();
        p0.y = o.y();
        p0.z = o.z();
        p1.x = tip.x();
        p1.y = tip.y();
        p1.z = tip.z();
        a.points = {p0, p1};
        a.pose.orientation.w = 1;
        a.scale.x = 0.01;
        a.scale.y = 0.02;
        a.scale.z = 0.03;
        a.color.r = e > 0 ? 1.0 : 0.2;
        a.color.b = e > 0 ? 0.2 : 1.0;
        a.color.a = 1.0;
        markers.markers.push_back(a);
      }
      if (const se3::ConstraintSystem* cs_sys = sim_->constraints()) {
        constrained = true;
        add_constraint_forces(*cs_sys, m, com.header, cf, markers);
      }
    }
    if (use_sim_time_) clock_pub_.publish(clock_msg);
    if (constrained) constraint_pub_.publish(cf);
    joint_pub_.publish(js);
    tf_->sendTransform(tfs);
    chain_pub_.publish(cs);
    stats_pub_.publish(st);
    marker_pub_.publish(markers);
  }

  ros::NodeHandle nh_, pnh_;
  ros::Publisher joint_pub_, chain_pub_, stats_pub_, marker_pub_, clock_pub_, constraint_pub_;
  ros::Subscriber cmd_sub_;
  ros::ServiceServer srv_reset_, srv_pause_, srv_resume_, srv_step_;
  std::unique_ptr<tf2_ros::TransformBroadcaster> tf_;

  std::mutex mu_;
  se3::Scene scene_;
  std::unique_ptr<se3::Simulator> sim_;
  std::vector<std::pair<std::string, double>> locked_;
  std::vector<std::string> names_;
  std::string world_frame_ = "world";
  double rtf_ = 1.0, rate_ = 100.0, command_timeout_ = 0.5;
  bool use_sim_time_ = false;
  bool paused_ = false;
  std::string status_;
  bool command_active_ = false;
  Clock::time_point command_time_;
  std::uint64_t rejected_ = 0;
  double clock_ = 0;  ///< monotonic simulated time for /clock and stamps (not reset)
  Clock::time_point anchor_, period_start_;
  std::uint64_t anchored_ = 0;  ///< steps taken since anchor_
  std::uint64_t period_steps_ = 0;
  Clock::duration step_wall_{0};
  se3::VecX effort_;
  std::vector<se3::SE3> links_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "simulator");
  SimulatorNode node;
  if (!node.init()) return 1;
  node.run();
  return 0;
}
