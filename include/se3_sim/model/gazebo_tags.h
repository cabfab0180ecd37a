// The <gazebo> extension tags of a URDF (Gazebo classic's, as gazebo_ros users write them), read
// once by parse_urdf_document (UrdfDocument::gazebo) and mapped onto se3_sim's own parameters
// (docs/gazebo.md has the table):
//   <gazebo reference="LINK">  mu1, mu2, kp, kd, minDepth, maxVel, selfCollide, material, gravity
//   <gazebo reference="JOINT"> provideFeedback, implicitSpringDamper
//   <gazebo>                   static, <plugin filename="libgazebo_ros_control.so"> with
//                              robotNamespace and controlPeriod
// <sensor> elements and the sensor plugins are the sensors' (src/sim/sensor_reader.cpp). Any
// other tag, a value that is not a number or a boolean, or a reference that names neither a link
// nor a joint is a warning, never a refusal: the kinds of unknown tag in one line.
#pragma once

#include <array>
#include <limits>
#include <string>
#include <vector>

namespace se3 {

/// <gazebo reference="LINK">: NaN (numbers) or -1 (booleans) where the URDF does not say.
struct GazeboLink {
  std::string link;
  int line = 0;  ///< of its first <gazebo> element
  double mu1 = std::numeric_limits<double>::quiet_NaN();
  double mu2 = std::numeric_limits<double>::quiet_NaN();
  double kp = std::numeric_limits<double>::quiet_NaN();         ///< N/m
  double kd = std::numeric_limits<double>::quiet_NaN();         ///< N s/m
  double min_depth = std::numeric_limits<double>::quiet_NaN();  ///< m
  double max_vel = std::numeric_limits<double>::quiet_NaN();    ///< m/s
  int self_collide = -1;
  int gravity = -1;
  std::string material;  ///< e.g. "Gazebo/Orange" ("" when not given)

  /// The isotropic Coulomb coefficient of the link: the smaller of mu1 and mu2 given (NaN:
  /// neither).
  double mu() const;
};

/// <gazebo reference="JOINT">.
struct GazeboJoint {
  std::string joint;
  int line = 0;
  int provide_feedback = -1;
  int implicit_spring_damper = -1;
};

struct GazeboTags {
  std::vector<GazeboLink> links;
  std::vector<GazeboJoint> joints;
  int is_static = -1;           ///< <gazebo><static>
  bool control_plugin = false;  ///< a libgazebo_ros_control.so plugin is declared
  std::string robot_namespace;  ///< its <robotNamespace> ("" when not given)
  double control_period = std::numeric_limits<double>::quiet_NaN();  ///< its <controlPeriod> (s)
  std::vector<std::string> warnings;                                 ///< one line each

  /// The tags of a link (nullptr: none).
  const GazeboLink* link(const std::string& name) const;
  const GazeboJoint* joint(const std::string& name) const;
  bool empty() const { return links.empty() && joints.empty() && is_static < 0 && !control_plugin; }
};

/// Reads the <gazebo> elements of URDF text (already accepted by the URDF guard). links and
/// joints are the URDF's names, to tell a link's reference from a joint's. Never throws.
GazeboTags read_gazebo_tags(const std::string& urdf_xml, const std::vector<std::string>& links,
                            const std::vector<std::string>& joints);

/// The colour (linear RGBA, 0..1) Gazebo's stock material script gives a named material
/// ("Gazebo/Orange", ...); false for a name it does not ship.
bool gazebo_material_rgba(const std::string& name, std::array<float, 4>& rgba);

}  // namespace se3
