// <transmission> elements of a URDF (transmissions.h).
#include "se3_sim/sim/transmissions.h"

#include <tinyxml2.h>

#include <cstdlib>

#include "../model/xml_text.h"
#include "se3_sim/model/urdf_xml.h"

namespace se3 {

namespace {

using xml_text::trimmed;

std::string interface_of(const tinyxml2::XMLElement* e) {
  std::string s = trimmed(e->GetText());
  const std::string prefix = "hardware_interface/";
  if (s.compare(0, prefix.size(), prefix) == 0) s = s.substr(prefix.size());
  return s;
}

void add_interfaces(const tinyxml2::XMLElement* parent, std::vector<std::string>& out) {
  for (auto* h = parent->FirstChildElement("hardwareInterface"); h;
       h = h->NextSiblingElement("hardwareInterface")) {
    const std::string s = interface_of(h);
    if (!s.empty()) out.push_back(s);
  }
}

double reduction_of(const tinyxml2::XMLElement* parent, double fallback) {
  const auto* r = parent->FirstChildElement("mechanicalReduction");
  if (!r) return fallback;
  double x = 0;
  return xml_text::finite_number(trimmed(r->GetText()), x) ? x : fallback;
}

}  // namespace

std::vector<JointTransmission> parse_transmissions(const std::string& urdf_xml) {
  return parse_transmissions(UrdfXml(urdf_xml));
}

std::vector<JointTransmission> parse_transmissions(const UrdfXml& urdf) {
  std::vector<JointTransmission> out;
  const tinyxml2::XMLElement* robot = urdf.robot();
  if (!robot) return out;
  for (auto* t = robot->FirstChildElement("transmission"); t;
       t = t->NextSiblingElement("transmission")) {
    const char* name = t->Attribute("name");
    // Old format: the interfaces (and the reduction) of the actuators apply to every joint.
    std::vector<std::string> actuator_ifaces;
    double reduction = reduction_of(t, 1.0);
    for (auto* a = t->FirstChildElement("actuator"); a; a = a->NextSiblingElement("actuator")) {
      add_interfaces(a, actuator_ifaces);
      reduction = reduction_of(a, reduction);
    }
    for (auto* j = t->FirstChildElement("joint"); j; j = j->NextSiblingElement("joint")) {
      JointTransmission jt;
      jt.joint = trimmed(j->Attribute("name"));
      if (jt.joint.empty()) continue;
      jt.transmission = name ? name : "";
      jt.line = t->GetLineNum();
      add_interfaces(j, jt.interfaces);
      if (jt.interfaces.empty()) jt.interfaces = actuator_ifaces;
      jt.reduction = reduction;
      out.push_back(std::move(jt));
    }
  }
  return out;
}

void check_interfaces(const std::vector<ControllerSpec>& specs,
                      const std::vector<JointTransmission>& transmissions) {
  for (const ControllerSpec& s : specs) {
    if (s.kind == ControllerKind::JointState) continue;
    const std::string needed = interface_name(s.iface);
    for (const std::string& joint : s.joints) {
      for (const JointTransmission& t : transmissions) {
        if (t.joint != joint || t.interfaces.empty()) continue;
        bool ok = false;
        std::string declared;
        for (const std::string& i : t.interfaces) {
          ok = ok || i == needed;
          declared += (declared.empty() ? "" : ", ") + i;
        }
        if (ok) continue;
        throw ControllerError("controller '" + s.name + "' (" + s.type + ") on joint '" + joint +
                              "': no matching hardware interface: the controller needs " + needed +
                              ", the transmission '" + t.transmission + "' (URDF line " +
                              std::to_string(t.line) + ") declares " + declared);
      }
    }
  }
}

}  // namespace se3
