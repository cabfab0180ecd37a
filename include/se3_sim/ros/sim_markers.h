// The simulator node's sim_markers and constraint_forces (docs/ros.md, "Markers"), built from
// the simulator's state alone: no node handle, no publisher.
#pragma once

#include <std_msgs/Header.h>
#include <visualization_msgs/MarkerArray.h>

#include <vector>

#include "se3_sim/ConstraintForces.h"
#include "se3_sim/sim/sim.h"

namespace se3_ros {

/// The centre of mass `c`: an orange sphere of 5 cm (namespace "com", id 0).
visualization_msgs::Marker com_marker(const se3::Vec3& c, const std_msgs::Header& header);

/// The scene's box on the base link (e.g. a satellite bus) for a base at `base` (namespace
/// "base_visual", id 0, the scene's colour); false when the scene has none.
bool base_visual_marker(const se3::Scene& scene, const se3::SE3& base,
                        const std_msgs::Header& header, visualization_msgs::Marker& out);

/// An arrow along each joint's axis (z of its body at `oMb[i]`) for its actuation `act` (size nv):
/// namespace "torque", id the joint's index, 5 to 30 cm long as |effort| goes to the URDF's
/// limit (10 if none), red for positive and blue for negative; DELETE for a zero effort.
void append_torque_markers(const se3::Model& m, const std::vector<se3::SE3>& oMb,
                           const se3::VecX& act, const std_msgs::Header& header,
                           visualization_msgs::MarkerArray& out);

/// The constraint and contact forces as a message and as arrows (namespace "constraint", id the
/// force's index): from the application point along the force, 0.3 m for a force equal to the
/// robot's weight (at least 2 cm, at most 0.6 m), green-yellow for contact and cyan for the
/// others; DELETE for an inactive, zero or non-finite one (its message fields read 0).
void append_constraint_forces(const se3::Model& m, const std::vector<se3::ConstraintForce>& forces,
                              const std_msgs::Header& header, se3_sim::ConstraintForces& cf,
                              visualization_msgs::MarkerArray& markers);

/// sim_markers of the simulator's present state, in this order: the centre of mass, the scene's
/// objects, the base box, the torque arrows (header: the world frame and the stamp).
void sim_markers(se3::Simulator& sim, const se3::Scene& scene, const std_msgs::Header& header,
                 visualization_msgs::MarkerArray& out);

}  // namespace se3_ros
