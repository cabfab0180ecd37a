// Typed reading of scene YAML (yaml-cpp) with errors that name the file and the line: the
// scene keys (scene.cpp), the constraint keys (contact_scene.cpp) and every later key
// (objects, controllers) read their values through one SceneReader.
//
//   const SceneReader r(file);
//   const SceneReader::Field root = r.document(text);        // limits, then yaml-cpp
//   for (const SceneReader::Field& f : r.fields(root, {"dt", "base_pose"})) {
//     if (f.name == "dt") dt = r.positive(f);
//     if (f.name == "base_pose")
//       for (const auto& p : r.fields(f, {"position", "orientation"})) ...
//   }
//
// A Field is one value with its dotted key ("base_pose.position", "objects[2].mass") and its
// line, so that a message reads "scene.yaml:12: 'base_pose.position' needs 3 numbers".
#pragma once

#include <yaml-cpp/yaml.h>

#include <string>
#include <utility>
#include <vector>

#include "se3_sim/sim/sim.h"

namespace se3 {

/// Checks scene text against limits::kMaxSceneBytes, kMaxYamlDepth and kMaxYamlItems and
/// refuses control characters, before yaml-cpp (which recurses once per nesting level) sees it.
/// The depth and item counts are upper bounds found in one pass without recursion. Throws
/// SceneError("file:line: ...").
void check_scene_text(const std::string& text, const std::string& file);

/// The bounds check_scene_text compares with the limits: nesting depth (counted as there) and
/// items, whatever their size (for tests and the fuzz target, which check them against what
/// yaml-cpp builds).
struct SceneTextShape {
  int depth = 0;
  std::size_t items = 0;
};
SceneTextShape scene_text_shape(const std::string& text);

/// The text with YAML's line ends (LF, CRLF, CR alone) as LF: what yaml-cpp is given (it reads a
/// CR alone as text).
std::string with_lf_line_ends(const std::string& text);

/// A file a scene names the ROS way: `package://PKG/path` and `$(find PKG)/path` (the folder of
/// PKG on ROS_PACKAGE_PATH), or `file:///abs/path`. Returns false for any other text (a plain
/// path: the caller's relative rules apply); otherwise the file in *out, or "" and a one-line
/// reason in *error when it cannot be found.
bool scene_ros_reference(const std::string& written, const std::string& base_dir, std::string* out,
                         std::string* error);

class SceneReader {
 public:
  /// One value of the scene: its key path for messages, the YAML node and its line.
  struct Field {
    std::string name;  ///< the last key ("position"), or "[i]" for a list item
    std::string key;   ///< the whole path ("base_pose.position", "objects[2]"); "" for the root
    YAML::Node node;
    int line = 0;  ///< 1-based; for an empty value, the line of its key
  };

  explicit SceneReader(std::string file) : file_(std::move(file)) {}
  const std::string& file() const { return file_; }

  /// The scene text as one YAML document whose top level is a map (an empty text is an empty
  /// map). check_scene_text first; YAML errors carry their line. Throws SceneError.
  Field document(const std::string& text) const;

  [[noreturn]] void fail(const Field& f, const std::string& what) const;
  [[noreturn]] void fail(int line, const std::string& what) const;

  // ---- structure
  /// `key:` with nothing after it, `~` or `null`.
  static bool is_null(const Field& f) { return !f.node || f.node.IsNull(); }
  /// The entries of a map in file order. Keys must be scalars and unique; with `known` not
  /// empty, each must be one of them (the message lists them). An empty value is an empty map
  /// when allow_null.
  std::vector<Field> fields(const Field& map, const std::vector<std::string>& known = {},
                            bool allow_null = false) const;
  /// The items of a list ("key[0]", "key[1]", ...); at most max_items of them.
  std::vector<Field> items(const Field& list, std::size_t max_items = 100000,
                           bool allow_null = false) const;

  // ---- values
  /// A finite number (YAML int or float; quoted numbers are accepted as well).
  double number(const Field& f) const;
  double positive(const Field& f) const;      ///< > 0
  double non_negative(const Field& f) const;  ///< >= 0
  /// A number in [lo, hi].
  double in_range(const Field& f, double lo, double hi) const;
  /// A whole number in [lo, hi].
  long integer(const Field& f, long lo, long hi) const;
  /// A non-empty scalar.
  std::string text(const Field& f) const;
  /// true/false (also True/TRUE, yes/no, on/off).
  bool boolean(const Field& f) const;
  /// A list of min_size..max_size numbers.
  std::vector<double> numbers(const Field& f, std::size_t min_size, std::size_t max_size) const;
  Vec3 vec3(const Field& f) const;
  /// {joint: value, ...} in file order (an empty value is an empty map).
  std::vector<std::pair<std::string, double>> joint_map(const Field& f) const;

 private:
  std::string file_;
};

/// The `sensors:` list (sensors.h): every key checked, one line naming the file, line and key.
void read_scene_sensors(const SceneReader& r, const SceneReader::Field& v,
                        std::vector<SensorSpec>& out);

}  // namespace se3
