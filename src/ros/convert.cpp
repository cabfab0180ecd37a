// Library <-> ROS message conversions and the checks of incoming commands (convert.h).
#include "se3_sim/ros/convert.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "se3_sim/lie/format.h"

namespace se3_ros {

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

se3::Vec6 from_wrench(const geometry_msgs::Wrench& w) {
  se3::Vec6 v;
  v << w.torque.x, w.torque.y, w.torque.z, w.force.x, w.force.y, w.force.z;
  return v;
}

se3::Vec6 from_twist(const geometry_msgs::Twist& t) {
  se3::Vec6 v;
  v << t.angular.x, t.angular.y, t.angular.z, t.linear.x, t.linear.y, t.linear.z;
  return v;
}

geometry_msgs::Twist to_twist(const se3::Vec6& v) {
  geometry_msgs::Twist t;
  t.angular.x = v[0];
  t.angular.y = v[1];
  t.angular.z = v[2];
  t.linear.x = v[3];
  t.linear.y = v[4];
  t.linear.z = v[5];
  return t;
}

std::string from_pose(const geometry_msgs::Pose& p, se3::SE3& out) {
  const auto& o = p.orientation;
  const double v[7] = {p.position.x, p.position.y, p.position.z, o.x, o.y, o.z, o.w};
  for (double x : v) {
    if (!std::isfinite(x)) return "the pose has a non-finite number";
  }
  const double norm = std::sqrt(o.x * o.x + o.y * o.y + o.z * o.z + o.w * o.w);
  if (std::abs(norm - 1) > 1e-3) {
    return "the orientation (x, y, z, w) is not a unit quaternion (norm " + se3::num(norm) + ")";
  }
  out.R = se3::rotation_from_quaternion(o.x / norm, o.y / norm, o.z / norm, o.w / norm);
  out.p = se3::Vec3(p.position.x, p.position.y, p.position.z);
  return "";
}

// ------------------------------------------------------------------ joints and commands

int JointTable::index(const se3::Model& m, const std::string& name) const {
  const int i = m.joint_index(name);
  if (i >= 1) return i;
  for (const auto& kv : locked) {
    if (kv.first == name) return 0;
  }
  return -1;
}

JointTable joint_table(const se3::Model& m,
                       const std::vector<std::pair<std::string, double>>& locked) {
  JointTable t;
  t.locked = locked;
  for (int i = 1; i <= m.n; ++i) t.names.push_back(m.joint_name[i]);
  for (const auto& kv : locked) t.names.push_back(kv.first);
  return t;
}

std::string check_torque_command(const se3::Model& m, const JointTable& joints,
                                 const se3_sim::JointTorques& msg, double max_effort,
                                 double max_wrench, TorqueCommand& out) {
  out.efforts.clear();
  out.has_base_wrench = false;
  if (msg.name.size() != msg.effort.size()) {
    return "name/effort lengths differ: " + std::to_string(msg.name.size()) + " vs " +
           std::to_string(msg.effort.size());
  }
  std::set<std::string> seen;
  for (size_t k = 0; k < msg.name.size(); ++k) {
    const std::string& name = msg.name[k];
    const double e = msg.effort[k];
    if (!seen.insert(name).second) return "joint '" + name + "' is named twice";
    const int i = joints.index(m, name);
    if (i < 0) return "unknown joint '" + name + "'";
    if (!std::isfinite(e)) return "non-finite effort for '" + name + "'";
    const bool limited = i >= 1 && std::isfinite(m.effort[i]) && m.effort[i] > 0;
    if (!limited && std::abs(e) > max_effort) {
      return "effort " + se3::num(e) + " for '" + name +
             "' (no URDF effort limit) exceeds ~max_effort " + se3::num(max_effort);
    }
    out.efforts.emplace_back(i, e);
  }
  if (msg.has_base_wrench) {
    const se3::Vec6 w = from_wrench(msg.base_wrench);
    if (!w.allFinite()) return "non-finite base wrench";
    if (w.head<3>().norm() > max_wrench || w.tail<3>().norm() > max_wrench) {
      // The norm scaled by the largest component: 1e300 squared would print as inf.
      auto size = [](const se3::Vec3& v) {
        const double big = v.cwiseAbs().maxCoeff();
        return big > 0 ? big * (v / big).norm() : 0.0;
      };
      return "base wrench (|torque| " + se3::num(size(w.head<3>())) + ", |force| " +
             se3::num(size(w.tail<3>())) + ") exceeds ~max_wrench " + se3::num(max_wrench);
    }
    out.has_base_wrench = true;
    out.base_wrench = w;
  }
  return "";
}

double finite_or_zero(double x) {
  return std::isfinite(x) ? x : 0.0;
}

void fill_joint_state(const se3::Model& m, const JointTable& joints, const se3::State& x,
                      const se3::VecX& efforts, sensor_msgs::JointState& js) {
  const size_t n = joints.names.size();
  js.name = joints.names;
  js.position.assign(n, 0.0);
  js.velocity.assign(n, 0.0);
  js.effort.assign(n, 0.0);
  for (int i = 1; i <= m.n; ++i) {
    js.position[i - 1] = x.q[m.idx_q(i)];
    js.velocity[i - 1] = x.v[m.idx_v(i)];
    js.effort[i - 1] = i - 1 < efforts.size() ? finite_or_zero(efforts[i - 1]) : 0.0;
  }
  for (size_t k = 0; k < joints.locked.size(); ++k) js.position[m.n + k] = joints.locked[k].second;
}

void fill_chain_state(const se3::Model& m, const sensor_msgs::JointState& js, const se3::State& x,
                      double kinetic, double potential, se3_sim::ChainState& cs) {
  cs.base_pose = to_pose(x.base);
  cs.base_twist = to_twist(m.floating ? se3::Vec6(x.v.head<6>()) : se3::Vec6::Zero());
  cs.name = js.name;
  cs.position = js.position;
  cs.velocity = js.velocity;
  cs.effort = js.effort;
  cs.kinetic_energy = finite_or_zero(kinetic);
  cs.potential_energy = finite_or_zero(potential);
}

// ------------------------------------------------------------------ TF

TfTree tf_tree(const se3::Model& m, const std::string& world_frame) {
  TfTree t;
  // No links (the empty robot of a scene of objects alone): no robot frame to hang on the world.
  t.world_edge = !m.links.empty() && m.links[0].name != world_frame;
  for (size_t k = 1; k < m.links.size(); ++k) {
    const se3::LinkFrame& L = m.links[k];
    if (L.parent < 0) continue;  // a model built in code without the URDF tree
    (L.fixed ? t.fixed : t.moving).push_back(static_cast<int>(k));
  }
  return t;
}

namespace {

geometry_msgs::TransformStamped stamped(const std::string& parent, const std::string& child,
                                        const se3::SE3& T, const ros::Time& stamp) {
  geometry_msgs::TransformStamped s;
  s.header.stamp = stamp;
  s.header.frame_id = parent;
  s.child_frame_id = child;
  s.transform = to_transform(T);
  return s;
}

}  // namespace

void tf_transforms(const se3::Model& m, const TfTree& tree, const std::vector<se3::SE3>& link_pose,
                   const std::string& world_frame, const ros::Time& stamp,
                   std::vector<geometry_msgs::TransformStamped>& out) {
  out.resize((tree.world_edge ? 1 : 0) + tree.moving.size());
  size_t n = 0;
  if (tree.world_edge) out[n++] = stamped(world_frame, m.links[0].name, link_pose[0], stamp);
  for (int k : tree.moving) {
    const se3::LinkFrame& L = m.links[k];
    out[n++] = stamped(m.links[L.parent].name, L.name, link_pose[L.parent].inverse() * link_pose[k],
                       stamp);
  }
}

std::vector<geometry_msgs::TransformStamped> tf_static_transforms(const se3::Model& m,
                                                                  const TfTree& tree,
                                                                  const ros::Time& stamp) {
  std::vector<geometry_msgs::TransformStamped> out;
  for (int k : tree.fixed) {
    const se3::LinkFrame& L = m.links[k];
    const se3::LinkFrame& P = m.links[L.parent];
    // A fixed joint's child is merged into its parent's body: both offsets are on one body.
    out.push_back(stamped(P.name, L.name, P.offset.inverse() * L.offset, stamp));
  }
  return out;
}

void append_object_transforms(const std::vector<se3::SceneObject>& specs,
                              const std::vector<se3::ObjectState>& states,
                              const std::string& world_frame, const ros::Time& stamp,
                              std::vector<geometry_msgs::TransformStamped>& out) {
  const std::size_t n = std::min(specs.size(), states.size());
  for (std::size_t j = 0; j < n; ++j) {
    geometry_msgs::TransformStamped t;
    t.header.stamp = stamp;
    t.header.frame_id = world_frame;
    t.child_frame_id = specs[j].name;
    t.transform = to_transform(states[j].pose);
    out.push_back(std::move(t));
  }
}

void append_object_markers(const std::vector<se3::SceneObject>& specs,
                           const std::vector<se3::ObjectState>& states,
                           const std::string& world_frame, const ros::Time& stamp,
                           visualization_msgs::MarkerArray& out) {
  const std::size_t n = std::min(specs.size(), states.size());
  for (std::size_t j = 0; j < n; ++j) {
    const se3::SceneObject& o = specs[j];
    const se3::Shape& s = o.shape;
    visualization_msgs::Marker mk;
    mk.header.stamp = stamp;
    mk.header.frame_id = world_frame;
    mk.ns = "objects";
    mk.id = int(3 * j);
    mk.action = visualization_msgs::Marker::ADD;
    mk.pose = to_pose(states[j].pose);
    const se3::Vec4f c = o.material.has_color ? o.material.rgba : se3::Vec4f(0.7f, 0.7f, 0.7f, 1.f);
    mk.color.r = c[0];
    mk.color.g = c[1];
    mk.color.b = c[2];
    mk.color.a = c[3];
    switch (s.type) {
      case se3::ShapeType::Box:
        mk.type = visualization_msgs::Marker::CUBE;
        mk.scale.x = s.box.x();
        mk.scale.y = s.box.y();
        mk.scale.z = s.box.z();
        break;
      case se3::ShapeType::Sphere:
        mk.type = visualization_msgs::Marker::SPHERE;
        mk.scale.x = mk.scale.y = mk.scale.z = 2 * s.radius;
        break;
      case se3::ShapeType::Cylinder:
      case se3::ShapeType::Capsule:
        mk.type = visualization_msgs::Marker::CYLINDER;
        mk.scale.x = mk.scale.y = 2 * s.radius;
        mk.scale.z = s.length;
        break;
      case se3::ShapeType::Mesh:
        mk.type = visualization_msgs::Marker::MESH_RESOURCE;
        mk.mesh_resource = s.path.empty() ? s.resource : "file://" + s.path;
        mk.mesh_use_embedded_materials = !o.material.has_color;
        mk.scale.x = s.scale.x();
        mk.scale.y = s.scale.y();
        mk.scale.z = s.scale.z();
        break;
    }
    out.markers.push_back(mk);
    if (s.type == se3::ShapeType::Capsule) {  // the two caps
      for (int end = 0; end < 2; ++end) {
        visualization_msgs::Marker cap = mk;
        cap.id = int(3 * j) + 1 + end;
        cap.type = visualization_msgs::Marker::SPHERE;
        cap.scale.x = cap.scale.y = cap.scale.z = 2 * s.radius;
        const se3::SE3& P = states[j].pose;
        cap.pose =
            to_pose(se3::SE3(P.R, P.p + (end ? 0.5 : -0.5) * s.length * se3::Vec3(P.R.col(2))));
        out.markers.push_back(cap);
      }
    }
  }
}

se3::TrajectoryCommand from_trajectory(const trajectory_msgs::JointTrajectory& msg) {
  se3::TrajectoryCommand cmd;
  cmd.joint_names = msg.joint_names;
  cmd.points.resize(msg.points.size());
  for (size_t p = 0; p < msg.points.size(); ++p) {
    const trajectory_msgs::JointTrajectoryPoint& in = msg.points[p];
    se3::TrajectoryCommand::Point& out = cmd.points[p];
    out.time_from_start = in.time_from_start.toSec();
    out.positions = in.positions;
    out.velocities = in.velocities;
    out.accelerations = in.accelerations;
  }
  return cmd;
}

}  // namespace se3_ros
