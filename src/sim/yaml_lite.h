// A small YAML reader for scene files: block maps by indentation, block lists of scalars,
// flow lists [a, b] and flow maps {k: v}, plain or quoted scalars, comments. Anything else
// (anchors, multi-line strings, tabs) is an error with the line number.
#pragma once

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace se3 {
namespace yaml_lite {

struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Node {
  enum class Kind { Scalar, Map, List };
  Kind kind = Kind::Scalar;
  std::string value;  ///< scalar text (quotes removed)
  bool quoted = false;
  std::vector<std::pair<std::string, Node>> map;
  std::vector<Node> list;
  int line = 0;

  bool is_map() const { return kind == Kind::Map; }
  bool is_list() const { return kind == Kind::List; }
  bool is_scalar() const { return kind == Kind::Scalar; }
};

/// Parses a document whose top level is a map. Throws Error("line N: ...").
Node parse(const std::string& text);

}  // namespace yaml_lite
}  // namespace se3
