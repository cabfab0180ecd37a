// A URDF's XML tree (tinyxml2) parsed once, for the readers of the tags urdfdom drops (<gazebo>
// sensors, <transmission>s): each takes the tree instead of parsing the text again.
#pragma once

#include <memory>
#include <string>

namespace tinyxml2 {
class XMLDocument;
class XMLElement;
}  // namespace tinyxml2

namespace se3 {

class UrdfXml {
 public:
  /// Parses `xml` (tinyxml2; "" does not parse).
  explicit UrdfXml(const std::string& xml);
  ~UrdfXml();
  UrdfXml(UrdfXml&&) noexcept;
  UrdfXml& operator=(UrdfXml&&) noexcept;

  /// "" when the XML parsed, else tinyxml2's name of the error.
  const std::string& error() const { return error_; }
  /// The <robot> element, or null (none, or the XML did not parse).
  const tinyxml2::XMLElement* robot() const;

 private:
  std::unique_ptr<tinyxml2::XMLDocument> doc_;
  std::string error_;
};

}  // namespace se3
