// A URDF's XML parsed once (urdf_xml.h).
#include "se3_sim/model/urdf_xml.h"

#include <tinyxml2.h>

namespace se3 {

UrdfXml::UrdfXml(const std::string& xml) : doc_(std::make_unique<tinyxml2::XMLDocument>()) {
  if (doc_->Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS) {
    error_ = doc_->ErrorName();
  }
}

UrdfXml::~UrdfXml() = default;
UrdfXml::UrdfXml(UrdfXml&&) noexcept = default;
UrdfXml& UrdfXml::operator=(UrdfXml&&) noexcept = default;

const tinyxml2::XMLElement* UrdfXml::robot() const {
  return error_.empty() ? doc_->FirstChildElement("robot") : nullptr;
}

}  // namespace se3
