#include "se3_sim/ros/renderer_convert.h"

#include <fcntl.h>
#include <ros/package.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <set>
#include <utility>

namespace se3 {
namespace ros_renderer {
namespace {

SE3 nan_pose() {
  return SE3(Mat3::Constant(std::nan("")), Vec3::Constant(std::nan("")));
}

}  // namespace

SE3 to_se3(const geometry_msgs::Transform& t) {
  const auto& q = t.rotation;
  const double n = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (!(n > 1e-9) || !std::isfinite(n) || !std::isfinite(t.translation.x) ||
      !std::isfinite(t.translation.y) || !std::isfinite(t.translation.z)) {
    return nan_pose();
  }
  return SE3(rotation_from_quaternion(q.x / n, q.y / n, q.z / n, q.w / n),
             Vec3(t.translation.x, t.translation.y, t.translation.z));
}

SE3 to_se3(const geometry_msgs::Pose& p) {
  geometry_msgs::Transform t;
  t.translation.x = p.position.x;
  t.translation.y = p.position.y;
  t.translation.z = p.position.z;
  t.rotation = p.orientation;
  if (p.orientation.x == 0 && p.orientation.y == 0 && p.orientation.z == 0 &&
      p.orientation.w == 0) {
    t.rotation.w = 1;
  }
  return to_se3(t);
}

geometry_msgs::Pose to_pose(const SE3& f) {
  geometry_msgs::Pose p;
  p.position.x = f.p.x();
  p.position.y = f.p.y();
  p.position.z = f.p.z();
  const Eigen::Vector4d q = quaternion_from_rotation(f.R);
  p.orientation.x = q(0);
  p.orientation.y = q(1);
  p.orientation.z = q(2);
  p.orientation.w = q(3);
  return p;
}

MarkerMeshes::MarkerMeshes(ResourceResolver resolver, const render::DrawOptions& opt)
    : resolver_(std::move(resolver)), opt_(opt) {}

MarkerMeshes::KeyRef MarkerMeshes::key(const visualization_msgs::Marker& m) {
  auto bits = [](double x) {
    std::uint64_t b;
    std::memcpy(&b, &x, sizeof b);
    return b;
  };
  return KeyRef(m.mesh_resource, bits(m.scale.x), bits(m.scale.y), bits(m.scale.z));
}

bool MarkerMeshes::load(const visualization_msgs::Marker& m, std::string* warning) {
  if (m.type != visualization_msgs::Marker::MESH_RESOURCE) return false;
  const KeyRef k = key(m);
  const auto found = meshes_.find(k);
  if (found != meshes_.end()) {
    used_.splice(used_.begin(), used_, found->second.used);  // most recently used
    return false;
  }
  const Vec3 scale(m.scale.x, m.scale.y, m.scale.z);
  std::string err;
  Shape shape;
  std::shared_ptr<const render::RenderMesh> mesh;
  // Checks of the name alone first: nothing is looked up on disk for a name that fails them.
  if (!scale.allFinite() || !(scale.cwiseAbs().minCoeff() > 0)) {
    err = "scale is not finite and non-zero";
  } else if (m.mesh_resource.empty()) {
    err = "no mesh_resource";
  } else if (!is_mesh_file_type(m.mesh_resource)) {
    err = "not a mesh file type (by its extension: .stl, .dae, .obj, .ply, ...)";
  } else if (m.mesh_resource.compare(0, 10, "package://") == 0 &&
             package_file("", m.mesh_resource.substr(std::min(m.mesh_resource.size(),
                                                              m.mesh_resource.find('/', 10) + 1)))
                 .empty()) {
    err = "it leaves its package (a '..' escape)";
  } else if (load_mesh_shape(m.mesh_resource, scale, resolver_, shape, &err) && shape.mesh &&
             shape.mesh->triangle_count() > 0) {
    mesh = std::make_shared<render::RenderMesh>(
        render::make_render_mesh(*shape.mesh, scale, Eigen::Vector3f::Constant(0.75f), opt_));
  } else {
    // The same words whatever the reason, so that /rosout does not tell whether a file exists.
    err = "not found, not readable or not a mesh";
  }
  std::size_t bytes = m.mesh_resource.size() + sizeof(Entry);
  if (mesh) {
    bytes += sizeof(float) * 6 * mesh->px.size() + sizeof(uint32_t) * mesh->indices.size() +
             sizeof(render::RenderMesh::Run) * mesh->runs.size();
  }
  const auto ins = meshes_.emplace(Key(k), Entry{mesh, bytes, used_.end()}).first;
  used_.push_front(&ins->first);
  ins->second.used = used_.begin();
  bytes_ += bytes;
  evict();
  if (mesh) return false;
  if (warning) {
    *warning = "marker " + m.ns + "/" + std::to_string(m.id) + ": mesh '" + m.mesh_resource +
               "' not drawn (" + err + "); a stand-in cube is drawn instead";
  }
  return true;
}

void MarkerMeshes::evict() {
  // Least recently used first; the newest entry stays even when it alone is over the bounds.
  while (used_.size() > 1 && (meshes_.size() > kMaxMeshes || bytes_ > kMaxBytes)) {
    const auto it = meshes_.find(*used_.back());
    used_.pop_back();
    if (it == meshes_.end()) continue;
    bytes_ -= it->second.bytes;
    meshes_.erase(it);
  }
}

MarkerMeshes::Lookup MarkerMeshes::lookup(const visualization_msgs::Marker& m) const {
  Lookup out;
  if (m.type != visualization_msgs::Marker::MESH_RESOURCE) return out;
  const auto it = meshes_.find(key(m));
  if (it == meshes_.end()) {
    out.stand_in = true;  // evicted (SimMarkers::apply loads every mesh marker it keeps)
  } else {
    out.mesh = it->second.mesh;
    out.stand_in = !it->second.mesh;
  }
  return out;
}

SimMarkers::Update SimMarkers::apply(const visualization_msgs::MarkerArray& msg,
                                     MarkerMeshes& meshes) {
  using VM = visualization_msgs::Marker;
  Update up;
  for (const auto& m : msg.markers) {
    if (m.action == VM::DELETEALL) {
      markers_.clear();
      continue;
    }
    const auto key = std::make_pair(m.ns, m.id);
    if (m.action == VM::DELETE) {
      markers_.erase(key);
      continue;
    }
    const auto it = markers_.find(key);
    if (it == markers_.end()) {
      if (markers_.size() >= kMaxMarkers) {
        ++up.dropped;
        continue;
      }
      if (m.type == VM::CUBE || m.type == VM::MESH_RESOURCE) up.new_solid = true;
    }
    std::string warning;
    if (meshes.load(m, &warning)) up.warnings.push_back(warning);
    if (it == markers_.end()) {
      markers_.emplace(key, m);
    } else {
      it->second = m;
    }
  }
  return up;
}

void append_markers(const visualization_msgs::Marker& m, const SE3& frame,
                    std::vector<render::Marker>& out, const MarkerMeshes* meshes) {
  const SE3 pose = frame * to_se3(m.pose);
  if (!pose.R.allFinite() || !pose.p.allFinite()) return;
  const Eigen::Vector3d color(m.color.r, m.color.g, m.color.b);
  if (!color.allFinite()) return;
  auto pt = [&](const geometry_msgs::Point& p) { return pose.act(Vec3(p.x, p.y, p.z)); };
  render::Marker r;
  r.color = color;
  using VM = visualization_msgs::Marker;
  switch (m.type) {
    case VM::SPHERE:
      r.type = render::Marker::Type::Sphere;
      r.a = pose.p;
      r.size = m.scale.x;
      out.push_back(r);
      break;
    case VM::CUBE:
    case VM::CYLINDER:
      r.type = m.type == VM::CUBE ? render::Marker::Type::Box : render::Marker::Type::Cylinder;
      r.a = pose.p;
      r.R = pose.R;
      r.size3 = Vec3(m.scale.x, m.scale.y, m.scale.z);
      out.push_back(r);
      break;
    case VM::ARROW:
      r.type = render::Marker::Type::Arrow;
      if (m.points.size() >= 2) {
        r.a = pt(m.points[0]);
        r.b = pt(m.points[1]);
        r.size = m.scale.x;
      } else {
        r.a = pose.p;
        r.b = pose.act(Vec3(m.scale.x, 0, 0));
        r.size = m.scale.y;
      }
      out.push_back(r);
      break;
    case VM::POINTS:
    case VM::SPHERE_LIST:
      for (const auto& p : m.points) {
        r.type = m.type == VM::POINTS ? render::Marker::Type::Point : render::Marker::Type::Sphere;
        r.a = pt(p);
        r.size = m.type == VM::POINTS ? 6.0 : m.scale.x;
        out.push_back(r);
      }
      break;
    case VM::LINE_STRIP:
    case VM::LINE_LIST: {
      const bool strip = m.type == VM::LINE_STRIP;
      for (std::size_t i = 0; i + 1 < m.points.size(); i += strip ? 1 : 2) {
        r.type = render::Marker::Type::Line;
        r.a = pt(m.points[i]);
        r.b = pt(m.points[i + 1]);
        r.size = 2.0;
        out.push_back(r);
      }
      break;
    }
    case VM::MESH_RESOURCE: {
      if (!meshes) break;
      r.a = pose.p;
      r.R = pose.R;
      MarkerMeshes::Lookup found = meshes->lookup(m);
      if (found.mesh) {
        r.type = render::Marker::Type::Mesh;
        r.mesh = std::move(found.mesh);
        r.mesh_colors = m.mesh_use_embedded_materials;
        out.push_back(r);
      } else if (found.stand_in) {
        r.type = render::Marker::Type::Box;
        r.size3 = 0.1 * Vec3(m.scale.x, m.scale.y, m.scale.z).cwiseAbs();
        r.color = Eigen::Vector3d::Constant(0.6);
        if (r.size3.allFinite()) out.push_back(r);
      }
      break;
    }
    default:
      break;
  }
}

void apply_camera_command(const geometry_msgs::Twist& cmd, render::Camera& cam) {
  const double zoom_delta = std::isfinite(cmd.linear.x) ? cmd.linear.x : 0.0;
  const double zoom = std::min(10.0, std::max(0.1, 1.0 - zoom_delta));
  const Vec3 right = cam.R_wc.col(0);
  Vec3 pan = Vec3::Zero();
  if (std::isfinite(cmd.linear.y)) pan += cmd.linear.y * right;
  if (std::isfinite(cmd.linear.z)) pan += cmd.linear.z * Vec3::UnitZ();
  if (pan.allFinite() && pan.norm() < 100) {
    cam.eye += pan;
    cam.target += pan;
  }
  cam.orbit(std::isfinite(cmd.angular.z) ? cmd.angular.z : 0.0,
            std::isfinite(cmd.angular.y) ? cmd.angular.y : 0.0, zoom);
}

sensor_msgs::CameraInfo camera_info(const render::Camera& cam, const std::string& frame,
                                    const ros::Time& stamp) {
  sensor_msgs::CameraInfo info;
  info.header.stamp = stamp;
  info.header.frame_id = frame;
  info.width = cam.width;
  info.height = cam.height;
  info.distortion_model = "plumb_bob";
  info.D.assign(5, 0.0);
  const double cx = cam.cx() - 0.5, cy = cam.cy() - 0.5;
  info.K = {cam.focal_px, 0, cx, 0, cam.focal_px, cy, 0, 0, 1};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.P = {cam.focal_px, 0, cx, 0, 0, cam.focal_px, cy, 0, 0, 0, 1, 0};
  return info;
}

visualization_msgs::MarkerArray rviz_markers(const std::vector<render::DrawItem>& items,
                                             const std::vector<SE3>& link_offset_inv,
                                             const ros::Time& stamp, const std::string& ns) {
  using VM = visualization_msgs::Marker;
  visualization_msgs::MarkerArray arr;
  int id = 0;
  for (std::size_t k = 0; k < items.size(); ++k) {
    const render::DrawItem& it = items[k];
    const SE3 local = (k < link_offset_inv.size() ? link_offset_inv[k] : SE3()) * it.local;
    VM m;
    m.header.stamp = stamp;
    m.header.frame_id = it.link;
    m.ns = ns;
    m.action = VM::ADD;
    m.frame_locked = true;
    m.color.r = float(it.color.x());
    m.color.g = float(it.color.y());
    m.color.b = float(it.color.z());
    m.color.a = 1.0f;
    m.pose = to_pose(local);
    auto push = [&](VM mk) {
      mk.id = id++;
      arr.markers.push_back(std::move(mk));
    };
    if (!it.mesh_resource.empty()) {
      m.type = VM::MESH_RESOURCE;
      m.mesh_resource = it.mesh_resource;
      m.mesh_use_embedded_materials = it.mesh_colors;
      m.scale.x = it.mesh_scale.x();
      m.scale.y = it.mesh_scale.y();
      m.scale.z = it.mesh_scale.z();
      push(m);
      continue;
    }
    m.scale.x = it.size.x();
    m.scale.y = it.size.y();
    m.scale.z = it.size.z();
    switch (it.shape) {
      case ShapeType::Box:
        m.type = VM::CUBE;
        push(m);
        break;
      case ShapeType::Sphere:
        m.type = VM::SPHERE;
        push(m);
        break;
      case ShapeType::Cylinder:
        m.type = VM::CYLINDER;
        push(m);
        break;
      case ShapeType::Capsule: {  // RViz has no capsule: a cylinder and its two end balls
        m.type = VM::CYLINDER;
        push(m);
        const double h = 0.5 * it.size.z();
        for (int s = -1; s <= 1; s += 2) {
          VM ball = m;
          ball.type = VM::SPHERE;
          ball.scale.z = ball.scale.x;
          ball.pose = to_pose(local * SE3(Mat3::Identity(), Vec3(0, 0, s * h)));
          push(ball);
        }
        break;
      }
      case ShapeType::Mesh:  // a mesh without a resource (in code): as its box
        m.type = VM::CUBE;
        if (it.mesh) {
          const Eigen::Vector3d lo = it.mesh->lower.cast<double>(),
                                hi = it.mesh->upper.cast<double>();
          m.scale.x = hi.x() - lo.x();
          m.scale.y = hi.y() - lo.y();
          m.scale.z = hi.z() - lo.z();
          m.pose = to_pose(local * SE3(Mat3::Identity(), 0.5 * (lo + hi)));
        }
        push(m);
        break;
    }
  }
  return arr;
}

render::Camera FollowCamera::update(const render::Camera& cam, const Vec3& origin) {
  if (!origin.allFinite()) return cam;
  if (!started_) set_camera(cam, origin);
  render::Camera c = cam;
  c.eye = origin + eye_offset_;
  c.target = origin + target_offset_;
  c.update();
  return c;
}

void FollowCamera::set_camera(const render::Camera& cam, const Vec3& origin) {
  if (!origin.allFinite()) return;
  eye_offset_ = cam.eye - origin;
  target_offset_ = cam.target - origin;
  started_ = true;
}

std::string reserve_frame_path(const std::string& dir, int& counter, std::string* error) {
  for (int tries = 0; tries < 100000; ++tries, ++counter) {
    char name[64];
    std::snprintf(name, sizeof name, "/se3_sim_frame_%06d.png", counter);
    const std::string path = dir + name;
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0644);
    if (fd >= 0) {
      ::close(fd);
      ++counter;
      return path;
    }
    if (errno != EEXIST) {
      if (error) *error = "cannot create " + path + ": " + std::strerror(errno);
      return "";
    }
  }
  if (error) *error = "no free frame name in " + dir;
  return "";
}

namespace {

// ros::package::getPath, asked once per missing package: rospack prints an error line for each
// call that does not find it (two per link of a robot whose mesh package is missing).
std::string rospack_path(const std::string& pkg) {
  static std::mutex mu;
  static std::set<std::string> missing;
  {
    std::lock_guard<std::mutex> lock(mu);
    if (missing.count(pkg)) return "";
  }
  std::string dir = ros::package::getPath(pkg);
  if (dir.empty()) {
    std::lock_guard<std::mutex> lock(mu);
    if (missing.size() < 1024) missing.insert(pkg);
  }
  return dir;
}

}  // namespace

ResourceResolver ros_resolver(const std::string& base_dir) {
  return [base_dir](const std::string& uri, std::string* error) -> std::string {
    if (uri.compare(0, 10, "package://") == 0) {
      const std::size_t slash = uri.find('/', 10);
      const std::string pkg =
          uri.substr(10, slash == std::string::npos ? std::string::npos : slash - 10);
      std::string dir = pkg.empty() ? std::string() : rospack_path(pkg);
      if (dir.empty() && !pkg.empty()) {
        // se3_sim carries the meshes of its own robots (data/meshes) for a node started
        // without the launch files' ROS_PACKAGE_PATH.
        const std::string own = ros::package::getPath("se3_sim");
        ResourcePaths paths;
        paths.use_ros_package_path = false;
        if (!own.empty()) paths.package_path = {own + "/data/meshes"};
        dir = find_package(pkg, paths);
      }
      if (dir.empty()) {
        if (error) *error = "package '" + pkg + "' not found by rospack (ROS_PACKAGE_PATH)";
        return "";
      }
      const std::string path =
          package_file(dir, slash == std::string::npos ? "" : uri.substr(slash + 1), error);
      if (path.empty()) return "";
      // The library resolver checks that the file exists (a plain path now).
      ResourcePaths none;
      none.use_ros_package_path = false;
      return resolve_resource(path, none, error);
    }
    ResourcePaths paths;
    paths.base_dir = base_dir;
    return resolve_resource(uri, paths, error);
  };
}

}  // namespace ros_renderer
}  // namespace se3
