// Conversions between the library (poses, states, commands) and ROS messages, with the
// validation of what arrives from other nodes. No master needed: every function is pure.
#pragma once

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Transform.h>
#include <geometry_msgs/TransformStamped.h>
#include <geometry_msgs/Twist.h>
#include <geometry_msgs/Wrench.h>
#include <sensor_msgs/JointState.h>
#include <trajectory_msgs/JointTrajectory.h>
#include <visualization_msgs/MarkerArray.h>

#include <string>
#include <utility>
#include <vector>

#include "se3_sim/ChainState.h"
#include "se3_sim/JointTorques.h"
#include "se3_sim/dynamics/dynamics.h"
#include "se3_sim/sim/sim.h"

namespace se3_ros {

/// x, or 0 when it is not finite: a published field never carries NaN or infinity.
double finite_or_zero(double x);

geometry_msgs::Transform to_transform(const se3::SE3& f);
geometry_msgs::Pose to_pose(const se3::SE3& f);
/// [N; F] (torque first, as the library) <-> geometry_msgs/Wrench.
se3::Vec6 from_wrench(const geometry_msgs::Wrench& w);
/// [w; v] (angular first) <-> geometry_msgs/Twist.
se3::Vec6 from_twist(const geometry_msgs::Twist& t);
geometry_msgs::Twist to_twist(const se3::Vec6& v);
/// A pose into an SE3: "" when usable, else why not (a non-finite number, or a quaternion whose
/// norm is off 1 by more than 1e-3; within that it is normalized).
std::string from_pose(const geometry_msgs::Pose& p, se3::SE3& out);
/// A trajectory controller's command (its points' times from start, positions, velocities and
/// accelerations as sent; the controller checks them).
se3::TrajectoryCommand from_trajectory(const trajectory_msgs::JointTrajectory& msg);

/// The joints a simulator reports: the model's moving joints (1..n, in order) and then its
/// locked ones (names and fixed positions), as joint_states and chain_state list them.
struct JointTable {
  std::vector<std::string> names;  ///< moving joints, then locked ones
  std::vector<std::pair<std::string, double>> locked;
  /// Model joint index (1..n) of a name, 0 for a locked joint, -1 when unknown.
  int index(const se3::Model& m, const std::string& name) const;
};
JointTable joint_table(const se3::Model& m,
                       const std::vector<std::pair<std::string, double>>& locked);

/// A torque_command message, checked: per named joint its model index (0 = locked: accepted,
/// no effect) and effort; the base wrench when the message has one.
struct TorqueCommand {
  std::vector<std::pair<int, double>> efforts;
  bool has_base_wrench = false;
  se3::Vec6 base_wrench = se3::Vec6::Zero();
};
/// "" when msg is usable, else the reason it is refused: name and effort lengths differ, a joint
/// unknown or named twice, an effort not finite or (for a joint without a URDF effort limit)
/// above max_effort, a base wrench not finite or with a torque or force norm above max_wrench.
std::string check_torque_command(const se3::Model& m, const JointTable& joints,
                                 const se3_sim::JointTorques& msg, double max_effort,
                                 double max_wrench, TorqueCommand& out);

/// joint_states at a state: every joint of the table, positions (locked: their value),
/// velocities and efforts (size n; non-finite ones as 0). Reuses js's vectors.
void fill_joint_state(const se3::Model& m, const JointTable& joints, const se3::State& x,
                      const se3::VecX& efforts, sensor_msgs::JointState& js);
/// chain_state: base pose (world) and twist (base frame; zero for a fixed base) and the joints
/// as in fill_joint_state; energies as given (non-finite as 0).
void fill_chain_state(const se3::Model& m, const sensor_msgs::JointState& js, const se3::State& x,
                      double kinetic, double potential, se3_sim::ChainState& cs);

/// TF as robot_state_publisher publishes it (REP 105): `world_frame` -> the root link, then
/// parent link -> child link for every URDF joint; moving (and locked) joints on /tf, fixed
/// joints once on /tf_static. Built from Model::links, whose names are the model's.
struct TfTree {
  std::vector<int> moving;  ///< links (index into Model::links) whose parent edge goes on /tf
  std::vector<int> fixed;   ///< links whose parent edge goes on /tf_static
  bool world_edge = true;   ///< false when the root link is itself called world_frame
};
TfTree tf_tree(const se3::Model& m, const std::string& world_frame);
/// The /tf transforms at the given link poses (Simulator::link_poses): world -> root first, then
/// the moving edges in link order. Reuses out's storage.
void tf_transforms(const se3::Model& m, const TfTree& tree, const std::vector<se3::SE3>& link_pose,
                   const std::string& world_frame, const ros::Time& stamp,
                   std::vector<geometry_msgs::TransformStamped>& out);
/// The /tf_static transforms (fixed joints: constant, from the links' offsets on their body).
std::vector<geometry_msgs::TransformStamped> tf_static_transforms(const se3::Model& m,
                                                                  const TfTree& tree,
                                                                  const ros::Time& stamp);

/// Appends one /tf transform per scene object (world_frame -> the object's name) at its state.
/// Reuses out's storage past its first size on later calls.
void append_object_transforms(const std::vector<se3::SceneObject>& specs,
                              const std::vector<se3::ObjectState>& states,
                              const std::string& world_frame, const ros::Time& stamp,
                              std::vector<geometry_msgs::TransformStamped>& out);
/// Appends the scene objects as markers (namespace "objects", in world_frame): CUBE, SPHERE,
/// CYLINDER, a capsule as a cylinder and two spheres, a mesh as MESH_RESOURCE (file://), in the
/// object's colour.
void append_object_markers(const std::vector<se3::SceneObject>& specs,
                           const std::vector<se3::ObjectState>& states,
                           const std::string& world_frame, const ros::Time& stamp,
                           visualization_msgs::MarkerArray& out);

}  // namespace se3_ros
