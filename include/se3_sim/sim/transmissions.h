// A URDF's <transmission> elements (ros_control's transmission_interface), as far as a
// simulator needs them: which hardware interface each joint offers its controllers.
//   new format:  <transmission name="t"><type>transmission_interface/SimpleTransmission</type>
//                  <joint name="j"><hardwareInterface>hardware_interface/EffortJointInterface
//                  </hardwareInterface></joint>
//                  <actuator name="m"><mechanicalReduction>50</mechanicalReduction></actuator>
//                </transmission>
//   old format:  the <hardwareInterface> inside <actuator> (and <joint name="j"/> empty); the
//                oldest (pr2) one: type as an attribute, <mechanicalReduction> directly inside.
// Interface names are kept without the "hardware_interface/" prefix. The mechanical reduction is
// read and reported, not applied (gazebo_ros_control's DefaultRobotHWSim does not apply it
// either: the controllers see and command the joint).
#pragma once

#include <string>
#include <vector>

#include "se3_sim/model/urdf_xml.h"
#include "se3_sim/sim/controllers.h"

namespace se3 {

struct JointTransmission {
  std::string joint;
  std::string transmission;             ///< its name
  int line = 0;                         ///< of the <transmission> in the URDF text
  std::vector<std::string> interfaces;  ///< e.g. "EffortJointInterface"
  double reduction = 1;
};

/// Every joint's transmission in a URDF text (one entry per joint of each transmission); none
/// when the URDF has no <transmission> or cannot be parsed (the URDF parser reports that).
std::vector<JointTransmission> parse_transmissions(const std::string& urdf_xml);
/// The same from a parsed URDF (one parse for every reader of its tags).
std::vector<JointTransmission> parse_transmissions(const UrdfXml& urdf);

/// Throws ControllerError, as gazebo_ros_control's controller manager refuses it ("no matching
/// hardware interface"), for a controller on a joint whose transmission declares interfaces
/// that do not include the one the controller's type writes; names the joint, the controller
/// (and its type) and both interfaces. A joint without a transmission, or one declaring no
/// interface, accepts every controller.
void check_interfaces(const std::vector<ControllerSpec>& specs,
                      const std::vector<JointTransmission>& transmissions);

}  // namespace se3
