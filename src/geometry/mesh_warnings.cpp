// Mesh warnings folded per missing package (geometry.h, summarize_mesh_warnings).
#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include "se3_sim/geometry/geometry.h"

namespace se3 {

std::vector<std::string> summarize_mesh_warnings(const std::vector<std::string>& warnings) {
  struct Missing {
    std::size_t first = 0;  // where its line goes: at the first warning of the package
    int meshes = 0;
    std::vector<std::string> links;
  };
  std::map<std::string, Missing> packages;
  std::vector<std::string> out;
  for (const std::string& w : warnings) {
    // "link 'L': visual mesh 'URI' not loaded: package 'P' not found ..."
    const std::size_t at = w.find("not loaded: package '");
    const std::size_t name = at + 21;
    const std::size_t end = at == std::string::npos ? at : w.find('\'', name);
    if (at == std::string::npos || end == std::string::npos ||
        w.compare(end, 12, "' not found ") != 0 || w.compare(0, 6, "link '") != 0) {
      out.push_back(w);
      continue;
    }
    const std::string pkg = w.substr(name, end - name);
    const std::string link = w.substr(6, w.find('\'', 6) - 6);
    auto it = packages.find(pkg);
    if (it == packages.end()) {
      it = packages.emplace(pkg, Missing{out.size(), 0, {}}).first;
      out.emplace_back();  // filled below
    }
    ++it->second.meshes;
    auto& links = it->second.links;
    if (std::find(links.begin(), links.end(), link) == links.end()) links.push_back(link);
  }
  for (const auto& [pkg, m] : packages) {
    std::string links;
    for (std::size_t i = 0; i < m.links.size() && i < 4; ++i) {
      links += (i ? ", " : "") + m.links[i];
    }
    if (m.links.size() > 4) links += " and " + std::to_string(m.links.size() - 4) + " more";
    out[m.first] = "package '" + pkg + "' not found: " + std::to_string(m.meshes) +
                   (m.meshes == 1 ? " mesh" : " meshes") + " of " + std::to_string(m.links.size()) +
                   (m.links.size() == 1 ? " link (" : " links (") + links +
                   ") not loaded (visuals drawn as stand-ins, collision meshes left out); add "
                   "the folder holding " +
                   pkg + "/package.xml to ROS_PACKAGE_PATH: export ROS_PACKAGE_PATH=/that/folder:" +
                   "$ROS_PACKAGE_PATH";
  }
  return out;
}

}  // namespace se3
