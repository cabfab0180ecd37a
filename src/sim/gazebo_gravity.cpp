// The <gazebo> tags that act on a simulator (sim.h, set_gazebo_gravity): per-link gravity and
// gazebo_ros_control's controlPeriod.
#include <algorithm>
#include <cmath>

#include "se3_sim/model/gazebo_tags.h"
#include "se3_sim/sim/sim.h"

namespace se3 {

std::vector<std::string> set_gazebo_gravity(Simulator& sim, const std::string& urdf_xml) {
  if (urdf_xml.empty()) return {};
  const Model& m = sim.model();
  std::vector<std::string> links, joints;
  for (const LinkFrame& lf : m.links) {
    links.push_back(lf.name);
    if (!lf.joint.empty()) joints.push_back(lf.joint);
  }
  return set_gazebo_gravity(sim, read_gazebo_tags(urdf_xml, links, joints));
}

std::vector<std::string> set_gazebo_gravity(Simulator& sim, const GazeboTags& tags) {
  // gazebo_ros_control's controlPeriod: the controllers update every so many steps.
  if (tags.control_period > 0) {
    sim.set_control_every(
        static_cast<int>(std::max(1.0, std::round(tags.control_period / sim.dt()))));
  }
  std::vector<std::string> off;
  for (const GazeboLink& g : tags.links) {
    if (g.gravity == 0) off.push_back(g.link);
  }
  if (off.empty()) return {};
  std::vector<std::string> warnings;
  for (const std::string& l : sim.set_links_without_gravity(off)) {
    warnings.push_back("<gazebo reference=\"" + l +
                       "\"><gravity>false: not applied, the link is fixed to its parent (its "
                       "parent's body feels gravity)");
  }
  return warnings;
}

}  // namespace se3
