// Guards around urdfdom (urdf_model.cpp): what outside URDF text may not do to the process.
//  - check_urdf_text: size, element nesting, attributes per element and the number of links and
//    joints, found in one pass without recursion before tinyxml (which recurses once per
//    element level, and looks each attribute up among the previous ones) sees the text.
//  - parse_urdf: urdfdom's parser with console_bridge set up so that no text of the URDF can
//    reach it as a format string (urdfdom hands messages that quote attributes to
//    console_bridge's printf-style log; a "%n" in an attribute wrote to memory).
//  - UrdfRelease: takes urdfdom's link tree apart without recursion (a long chain of links
//    held by shared pointers is otherwise freed one nested call per link).
//  - check_urdf_joints: numbers urdfdom accepts that the dynamics cannot use (negative
//    damping, friction, effort or velocity limits; non-finite values).
#pragma once

#include <urdf_parser/urdf_parser.h>

#include <cstddef>
#include <string>
#include <vector>

namespace se3 {

/// What one pass over XML text finds (upper bounds of what tinyxml will build).
struct XmlShape {
  int max_depth = 0;            ///< deepest element nesting
  int max_depth_line = 0;       ///< the line where it is reached
  int max_attributes = 0;       ///< most attributes on one element
  int max_attributes_line = 0;  ///< the line of that element
  std::size_t links = 0;        ///< <link> elements
  std::size_t joints = 0;       ///< <joint> elements
};

/// Scans XML text the way tinyxml 2.6 tokenizes it (comments, CDATA, declarations, unknown
/// "<!...>" and quoted attribute values skipped as tinyxml skips them); never recurses.
XmlShape xml_shape(const std::string& xml);

/// Refuses URDF text that is not UTF-8, or beyond limits.h (bytes, depth, attributes, links,
/// joints) with a ModelError naming the limit and the line.
void check_urdf_text(const std::string& xml);

/// urdf::parseURDF without console_bridge formatting any text of the URDF. Returns nullptr and
/// sets error (one line) when urdfdom rejects the text; what urdfdom complained about while
/// accepting it (e.g. an inertial it could not read and left out) goes to messages.
urdf::ModelInterfaceSharedPtr parse_urdf(const std::string& xml, std::string& error,
                                         std::vector<std::string>* messages = nullptr);

/// Throws ModelError for a joint whose dynamics or limits urdfdom accepted but the simulator
/// cannot use: negative damping, friction, effort or velocity; a non-finite number.
void check_urdf_joints(const urdf::ModelInterface& u);

/// Clears every link's child and joint lists while the model's maps still own each link, so
/// that releasing the model frees links one by one instead of recursively down a chain.
class UrdfRelease {
 public:
  explicit UrdfRelease(urdf::ModelInterfaceSharedPtr& u) : u_(u) {}
  ~UrdfRelease();
  UrdfRelease(const UrdfRelease&) = delete;
  UrdfRelease& operator=(const UrdfRelease&) = delete;

 private:
  urdf::ModelInterfaceSharedPtr& u_;
};

}  // namespace se3
