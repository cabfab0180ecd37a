// Resource names the ROS way: package://, file://, absolute and relative paths.
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <mutex>
#include <set>
#include <sstream>

#include "se3_sim/geometry/geometry.h"
#include "se3_sim/model/limits.h"

namespace se3 {
namespace {

namespace fs = std::filesystem;

// The <name> of a package.xml, or "".
std::string package_name(const fs::path& manifest) {
  std::string text;  // the name comes early; a huge file is not read whole
  if (!read_file(manifest.string(), text, nullptr, 4096, true)) return "";
  const std::size_t a = text.find("<name>");
  if (a == std::string::npos) return "";
  const std::size_t b = text.find("</name>", a);
  if (b == std::string::npos) return "";
  std::string name = text.substr(a + 6, b - a - 6);
  const auto not_space = [](char c) { return c != ' ' && c != '\t' && c != '\n' && c != '\r'; };
  while (!name.empty() && !not_space(name.back())) name.pop_back();
  std::size_t k = 0;
  while (k < name.size() && !not_space(name[k])) ++k;
  return name.substr(k);
}

// Every package under root, found as rospack crawls: a folder with a package.xml is a package
// and is not searched further; folders holding CATKIN_IGNORE or rospack_nosubdirs, and hidden
// ones, are skipped. Bounded in depth and in folders visited. First found wins.
void crawl(const fs::path& root, std::map<std::string, std::string>& out) {
  constexpr int kMaxDepth = 12;
  constexpr int kMaxFolders = 20000;
  int visited = 0;
  std::set<std::string> seen;  // canonical folders (symlink loops)
  std::vector<std::pair<fs::path, int>> stack{{root, 0}};
  while (!stack.empty() && visited < kMaxFolders) {
    const auto [dir, depth] = stack.back();
    stack.pop_back();
    std::error_code ec;
    const fs::path canon = fs::canonical(dir, ec);
    if (ec || !seen.insert(canon.string()).second) continue;
    ++visited;
    if (fs::exists(dir / "package.xml", ec)) {
      const std::string name = package_name(dir / "package.xml");
      if (!name.empty() && !out.count(name)) out[name] = dir.string();
      continue;
    }
    if (depth > 0 &&
        (fs::exists(dir / "CATKIN_IGNORE", ec) || fs::exists(dir / "rospack_nosubdirs", ec))) {
      continue;
    }
    if (depth >= kMaxDepth) continue;
    fs::directory_iterator it(dir, fs::directory_options::skip_permission_denied, ec);
    if (ec) continue;
    std::vector<fs::path> subdirs;
    for (const auto& e : it) {
      const std::string fname = e.path().filename().string();
      if (fname.empty() || fname[0] == '.') continue;
      std::error_code ec2;
      if (e.is_directory(ec2)) subdirs.push_back(e.path());
    }
    // Depth-first in name order, so the first package found is deterministic.
    std::sort(subdirs.rbegin(), subdirs.rend());
    for (const auto& s : subdirs) stack.emplace_back(s, depth + 1);
  }
}

std::mutex g_mutex;
std::map<std::string, std::map<std::string, std::string>> g_roots;  // root -> packages

const std::map<std::string, std::string>& packages_under(const std::string& root) {
  // Under g_mutex.
  auto it = g_roots.find(root);
  if (it != g_roots.end()) return it->second;
  std::map<std::string, std::string> pk;
  crawl(root, pk);
  return g_roots.emplace(root, std::move(pk)).first->second;
}

std::vector<std::string> search_roots(const ResourcePaths& paths) {
  std::vector<std::string> roots = paths.package_path;
  if (paths.use_ros_package_path) {
    const char* env = std::getenv("ROS_PACKAGE_PATH");
    if (env) {
      for (const std::string& d : split_path_list(env)) roots.push_back(d);
    }
  }
  return roots;
}

// "" when p is a regular file that can be read, else "file 'p' " and what it is.
std::string not_a_file(const std::string& p) {
  const std::string what = not_a_regular_file(p);
  if (what.empty()) return "";
  return "file '" + p + "' " + (what == "not found" ? what : "is " + what);
}

}  // namespace

std::vector<std::string> split_path_list(const std::string& list) {
  std::vector<std::string> out;
  std::stringstream ss(list);
  std::string item;
  while (std::getline(ss, item, ':')) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

std::string package_file(const std::string& dir, const std::string& rel, std::string* error) {
  const fs::path norm = fs::path(rel).lexically_normal();
  if (norm.is_absolute() || (!norm.empty() && *norm.begin() == "..")) {
    if (error) *error = "'" + rel + "' leaves its package folder '" + dir + "' (a '..' escape)";
    return "";
  }
  return norm.empty() || norm == "." ? dir : (fs::path(dir) / norm).string();
}

std::string find_package(const std::string& name, const ResourcePaths& paths) {
  std::lock_guard<std::mutex> lock(g_mutex);
  for (const std::string& root : search_roots(paths)) {
    const auto& pk = packages_under(root);
    const auto it = pk.find(name);
    if (it != pk.end()) return it->second;
  }
  return "";
}

std::string resolve_resource(const std::string& uri, const ResourcePaths& paths,
                             std::string* error) {
  auto fail = [&](const std::string& why) {
    if (error) *error = why;
    return std::string();
  };
  if (uri.empty()) return fail("empty resource name");
  std::string path;
  const std::size_t scheme_end = uri.find("://");
  if (uri.compare(0, 10, "package://") == 0) {
    const std::size_t slash = uri.find('/', 10);
    const std::string pkg =
        uri.substr(10, slash == std::string::npos ? std::string::npos : slash - 10);
    if (pkg.empty()) return fail("'" + uri + "' names no package");
    const std::string dir = find_package(pkg, paths);
    if (dir.empty()) {
      std::string where;
      for (const std::string& r : search_roots(paths)) where += (where.empty() ? "" : ":") + r;
      return fail("package '" + pkg + "' not found on the package path (" +
                  (where.empty() ? std::string("empty; set ROS_PACKAGE_PATH") : where) + ")");
    }
    path = package_file(dir, slash == std::string::npos ? std::string() : uri.substr(slash + 1),
                        error);
    if (path.empty()) return "";
    const std::string bad = not_a_file(path);
    if (!bad.empty()) return fail(bad + " (package '" + pkg + "')");
    return path;
  }
  if (uri.compare(0, 7, "file://") == 0) {
    path = uri.substr(7);
    if (path.empty() || path[0] != '/') {
      path = (fs::path(paths.base_dir.empty() ? "." : paths.base_dir) / path).string();
    }
  } else if (scheme_end != std::string::npos && scheme_end > 0 && uri.find('/') > scheme_end) {
    return fail("'" + uri + "': unsupported scheme (package://, file:// or a path)");
  } else if (uri[0] == '/') {
    path = uri;
  } else {
    if (paths.base_dir.empty()) {
      return fail("relative name '" + uri + "' and no base folder (a URDF read from text)");
    }
    path = (fs::path(paths.base_dir) / uri).string();
  }
  const std::string bad = not_a_file(path);
  if (!bad.empty()) return fail(bad);
  return path;
}

}  // namespace se3
