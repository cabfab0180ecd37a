// The library's layers depend one way (docs/design.md, "Layers"): no header or source file of a
// layer includes a header of a layer above it or beside it. Read from the sources, so that an
// upward include fails here before it becomes a cycle. render depends on dynamics as well (it poses
// the robot at joint positions q by forward kinematics, which docs/design.md puts in dynamics).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "source_paths.h"

namespace {

namespace fs = std::filesystem;

// Public headers (under include/se3_sim/) and internal ones (under src/) by layer.
const std::map<std::string, std::string> kHeaderLayer = {
    {"se3_sim/lie/lie.h", "lie"},
    {"lie/simd.h", "lie"},
    {"se3_sim/lie/format.h", "lie"},  // numbers in messages; depends on nothing
    {"se3_sim/model/model.h", "model"},
    {"se3_sim/model/limits.h", "model"},
    {"se3_sim/geometry/geometry.h", "geometry"},
    {"se3_sim/dynamics/dynamics.h", "dynamics"},
    {"se3_sim/solver/constraints.h", "solver"},
    {"se3_sim/constraint/constraint.h", "constraint"},
    {"se3_sim/solver/solver.h", "solver"},
    {"se3_sim/collision/collision.h", "collision"},
    {"se3_sim/sim/scene_objects.h", "sim"},
    {"se3_sim/integrate/integrate.h", "integrate"},
    {"se3_sim/render/render.h", "render"},
    {"se3_sim/render/camera.h", "render"},
    {"se3_sim/render/raster.h", "render"},
    {"se3_sim/teleop/teleop.h", "teleop"},
    {"se3_sim/sim/sim.h", "sim"},
    {"se3_sim/sim/controllers.h", "sim"},
    {"se3_sim/sim/gain_check.h", "sim"},
    {"se3_sim/sim/ground.h", "sim"},
    {"se3_sim/sim/scene_collision.h", "sim"},
    {"se3_sim/sim/sensors.h", "sim"},
    {"se3_sim/sim/trajectory.h", "sim"},
    {"se3_sim/sim/transmissions.h", "sim"},
    {"se3_sim/ros/convert.h", "ros"},
    {"se3_sim/ros/params.h", "ros"},
    {"se3_sim/ros/simulator_node.h", "ros"},
    {"se3_sim/ros/renderer_node.h", "ros"},
    {"se3_sim/ros/teleop_node.h", "ros"},
    {"se3_sim/ros/renderer_convert.h", "ros"},
    {"se3_sim/ros/rendered_sensors.h", "ros"},
    {"se3_sim/ros/world_services.h", "ros"},
    {"se3_sim/ros/robot_interfaces.h", "ros"},
    {"se3_sim/ros/robot_sensors.h", "ros"},
    {"se3_sim/ros/simulator_config.h", "ros"},
    {"se3_sim/ros/sim_markers.h", "ros"},
    {"se3_sim/ros/controller_states.h", "ros"},
    {"se3_sim/model/gazebo_tags.h", "model"},
    {"se3_sim/model/urdf_xml.h", "model"},
    {"se3_sim/collision/laser.h", "collision"},
    {"se3_sim/sim/laser_world.h", "sim"},
    {"se3_sim/render/camera_sensor.h", "render"},
    {"se3_sim/sim/world.h", "sim"},
};

// What each layer may include: itself and the layers below it.
const std::map<std::string, std::set<std::string>> kAllowed = {
    {"lie", {"lie"}},
    {"model", {"lie", "model"}},
    {"geometry", {"lie", "model", "geometry"}},
    {"dynamics", {"lie", "model", "geometry", "dynamics"}},
    {"collision", {"lie", "model", "geometry", "dynamics", "collision"}},
    {"constraint", {"lie", "model", "geometry", "dynamics", "collision", "constraint"}},
    {"solver", {"lie", "model", "geometry", "dynamics", "collision", "constraint", "solver"}},
    {"integrate",
     {"lie", "model", "geometry", "dynamics", "collision", "constraint", "solver", "integrate"}},
    {"render", {"lie", "model", "geometry", "dynamics", "render"}},
    {"teleop", {"lie", "model", "teleop"}},
    {"sim",
     {"lie", "model", "geometry", "dynamics", "collision", "constraint", "solver", "integrate",
      "sim"}},
    {"ros",
     {"lie", "model", "geometry", "dynamics", "collision", "constraint", "solver", "integrate",
      "sim", "render", "teleop", "ros"}},
};

// The files of a layer: its public headers and src/<layer>/.
std::vector<fs::path> layer_files(const fs::path& root, const std::string& layer) {
  std::vector<fs::path> files;
  for (const auto& hl : kHeaderLayer) {
    if (hl.second == layer && hl.first.rfind("se3_sim/", 0) == 0) {
      files.push_back(root / "include" / hl.first);
    }
  }
  if (!fs::exists(root / "src" / layer)) return files;  // a layer of headers alone (so far)
  for (const auto& e : fs::recursive_directory_iterator(root / "src" / layer)) {
    const std::string ext = e.path().extension().string();
    if (ext == ".cpp" || ext == ".h") files.push_back(e.path());
  }
  return files;
}

std::vector<std::string> quoted_includes(const fs::path& file) {
  static const std::regex include_re(R"re(^\s*#\s*include\s*"([^"]+)")re");
  std::vector<std::string> out;
  std::ifstream in(file);
  std::string line;
  std::smatch m;
  while (std::getline(in, line)) {
    if (std::regex_search(line, m, include_re)) out.push_back(m[1]);
  }
  return out;
}

TEST(Layers, NoFileIncludesALayerAboveItsOwn) {
  const fs::path root = se3_sim_test::source_dir();
  int checked = 0;
  for (const auto& la : kAllowed) {
    const std::string& layer = la.first;
    const auto files = layer_files(root, layer);
    EXPECT_FALSE(files.empty()) << layer;
    for (const fs::path& f : files) {
      for (const std::string& inc : quoted_includes(f)) {
        static const std::regex message_re(R"re(^se3_sim/[A-Z][A-Za-z]*\.h$)re");
        if (std::regex_search(inc, message_re)) {  // generated messages: the ros layer's
          ++checked;
          EXPECT_TRUE(la.second.count("ros")) << f << " (layer " << layer << ") includes " << inc;
          continue;
        }
        const auto it = kHeaderLayer.find(inc);
        if (it == kHeaderLayer.end()) {
          // Anything else must be a file of the same directory (a layer's internal header).
          EXPECT_TRUE(fs::exists(f.parent_path() / inc))
              << f << " includes \"" << inc << "\", which is no layer's header";
          continue;
        }
        ++checked;
        EXPECT_TRUE(la.second.count(it->second))
            << f << " (layer " << layer << ") includes " << inc << " of layer " << it->second;
      }
    }
  }
  EXPECT_GT(checked, 20);
}

// The public headers mirror src/: include/se3_sim/LAYER/NAME.h belongs to LAYER, and every header
// there is in the table above.
TEST(Layers, EachPublicHeaderLivesInItsLayersFolder) {
  const fs::path root = se3_sim_test::source_dir();
  int headers = 0;
  for (const auto& e : fs::recursive_directory_iterator(root / "include" / "se3_sim")) {
    if (e.path().extension() != ".h") continue;
    ++headers;
    const std::string rel = fs::relative(e.path(), root / "include").generic_string();
    const auto it = kHeaderLayer.find(rel);
    ASSERT_NE(it, kHeaderLayer.end()) << rel << " is in no layer of the table";
    EXPECT_EQ(rel.substr(0, 9 + it->second.size()), "se3_sim/" + it->second + "/")
        << rel << " belongs to layer " << it->second;
  }
  EXPECT_GT(headers, 30);
}

// roscpp and ROS messages only in the ros layer (src/ros, include/se3_sim/ros) and the nodes:
// the library builds and is tested without them.
TEST(Layers, OnlyTheRosLayerIncludesRos) {
  const fs::path root = se3_sim_test::source_dir();
  static const std::regex ros_re(
      R"re(^\s*#\s*include\s*[<"](ros|tf2_ros|tf2_msgs|std_msgs|std_srvs|sensor_msgs|geometry_msgs|visualization_msgs|rosgraph_msgs|xmlrpcpp|image_transport|se3_sim/[A-Z][A-Za-z]*\.h)[/">])re");
  int files = 0;
  for (const auto& la : kAllowed) {
    if (la.first == "ros") continue;
    for (const fs::path& f : layer_files(root, la.first)) {
      ++files;
      std::ifstream in(f);
      std::string line;
      while (std::getline(in, line)) {
        EXPECT_FALSE(std::regex_search(line, ros_re))
            << f << " (layer " << la.first << ") includes ROS: " << line;
      }
    }
  }
  EXPECT_GT(files, 30);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
