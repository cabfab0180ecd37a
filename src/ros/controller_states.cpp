// Trajectory controllers' NAME/state topics and status log lines (controller_states.h).
#include "se3_sim/ros/controller_states.h"

#include <algorithm>
#include <utility>

namespace se3_ros {

namespace {

std::vector<se3::ControllerSpec> specs_of(const se3::ControllerSet& set) {
  std::vector<se3::ControllerSpec> out;
  for (int c = 0; c < set.size(); ++c) out.push_back(set.spec(c));
  return out;
}

}  // namespace

ControllerStates::ControllerStates(ros::NodeHandle nh,
                                   const std::vector<se3::ControllerSpec>& specs, std::string robot)
    : robot_(std::move(robot)) {
  for (const se3::ControllerSpec& s : specs) {
    pubs_.emplace_back();
    if (s.kind == se3::ControllerKind::Trajectory) {
      pubs_.back() = nh.advertise<se3_sim::JointTrajectoryControllerState>(s.name + "/state", 10);
    }
  }
  last_.assign(specs.size(), -1.0);
  status_.assign(specs.size(), se3::TrajectoryStatus::Idle);
}

ControllerStates::ControllerStates(ros::NodeHandle nh, const se3::ControllerSet& set,
                                   std::string robot)
    : ControllerStates(std::move(nh), specs_of(set), std::move(robot)) {}

void ControllerStates::publish(const se3::ControllerSet& set, double t, const ros::Time& stamp) {
  const std::string who = robot_.empty() ? std::string() : "robot " + robot_ + ": ";
  const int n = std::min(set.size(), static_cast<int>(pubs_.size()));
  for (int c = 0; c < n; ++c) {
    const se3::ControllerSpec& s = set.spec(c);
    if (s.kind != se3::ControllerKind::Trajectory) continue;
    const se3::TrajectoryState& st = set.trajectory_state(c);
    if (st.status != status_[c]) {
      status_[c] = st.status;
      const std::string joint =
          st.status_joint >= 0 ? " (joint " + s.joints[st.status_joint] + ")" : std::string();
      if (st.status == se3::TrajectoryStatus::PathToleranceViolated ||
          st.status == se3::TrajectoryStatus::GoalToleranceViolated) {
        ROS_WARN("simulator: %scontroller %s: %s%s", who.c_str(), s.name.c_str(),
                 se3::status_name(st.status), joint.c_str());
      } else if (st.status == se3::TrajectoryStatus::Succeeded) {
        ROS_INFO("simulator: %scontroller %s: trajectory %s", who.c_str(), s.name.c_str(),
                 se3::status_name(st.status));
      }
    }
    if (!(s.state_publish_rate > 0)) continue;
    // Due once per period of simulated time; a reset (time going back) publishes at once.
    if (t >= last_[c] && t - last_[c] < 1.0 / s.state_publish_rate - 1e-9) continue;
    last_[c] = t;
    se3_sim::JointTrajectoryControllerState& m = msg_;
    m.header.stamp = stamp;
    m.joint_names = s.joints;
    m.desired.positions = st.desired_q;
    m.desired.velocities = st.desired_v;
    m.desired.accelerations = st.desired_a;
    m.actual.positions = st.actual_q;
    m.actual.velocities = st.actual_v;
    m.error.positions = st.error_q;
    m.error.velocities = st.error_v;
    pubs_[c].publish(m);
  }
}

}  // namespace se3_ros
