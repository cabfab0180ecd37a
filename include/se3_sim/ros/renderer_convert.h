// The renderer node's logic that needs ROS types but no master: message conversions, the
// camera command and camera_info, the RViz MarkerArray of the draw list, following a frame,
// where save_frame writes, and mesh resolution through ROS's own package lookup.
#pragma once

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Transform.h>
#include <geometry_msgs/Twist.h>
#include <ros/time.h>
#include <sensor_msgs/CameraInfo.h>
#include <visualization_msgs/Marker.h>
#include <visualization_msgs/MarkerArray.h>

#include <cstdint>
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "se3_sim/geometry/geometry.h"
#include "se3_sim/render/render.h"

namespace se3 {
namespace ros_renderer {

/// A pose from a transform; a zero or non-finite quaternion or translation gives NaNs (the
/// renderer hides what has no valid pose).
SE3 to_se3(const geometry_msgs::Transform& t);
/// A marker pose; an all-zero orientation means identity (as RViz reads it).
SE3 to_se3(const geometry_msgs::Pose& p);
geometry_msgs::Pose to_pose(const SE3& f);

/// Mesh names resolved the ROS way: package:// through ros::package (rospack), file:// and
/// paths by the library's resolver (relative ones against base_dir).
ResourceResolver ros_resolver(const std::string& base_dir = "");

/// The triangles of MESH_RESOURCE markers (the simulator's mesh objects), loaded once per
/// resource and scale through the geometry layer (load_mesh_shape, its cache and limits) and
/// made into RenderMeshes (make_render_mesh, simplified as DrawOptions say). A resource that
/// cannot be used gives one warning and, from then on, a stand-in: a grey cube of 0.1 m times
/// the marker's scale, so the object stays visible where it is.
///
/// Any node may publish on sim_markers, so a resource is read only when, from its name alone,
/// it is a mesh file type (is_mesh_file_type) and a package:// name stays inside its package
/// (package_file); the mesh loader reads an OBJ's material file only beside the mesh and only
/// regular files. Every other failure (not found, unreadable, not a mesh) gives the same
/// words, so that the warnings on /rosout do not tell whether a file exists. The cache keeps
/// the most recently used meshes, at most kMaxMeshes of them and kMaxBytes of triangles
/// (least recently used evicted first; an evicted resource is read again when it is sent
/// again, and drawn as a stand-in until then).
class MarkerMeshes {
 public:
  explicit MarkerMeshes(ResourceResolver resolver = ros_resolver(),
                        const render::DrawOptions& opt = render::DrawOptions());
  MarkerMeshes(const MarkerMeshes&) = delete;
  MarkerMeshes& operator=(const MarkerMeshes&) = delete;
  MarkerMeshes(MarkerMeshes&&) = default;
  MarkerMeshes& operator=(MarkerMeshes&&) = default;
  /// Loads m's mesh if it is a MESH_RESOURCE marker not in the cache (allocates; call it when
  /// the marker arrives, not per frame), else marks it used. Returns true and the warning in
  /// *warning when a resource fails.
  bool load(const visualization_msgs::Marker& m, std::string* warning = nullptr);
  /// What to draw for m: its loaded mesh, or a stand-in (its resource failed to load, or was
  /// evicted), or neither (not a mesh marker, not loaded yet). One map lookup, no
  /// allocation: append_markers calls it per marker and frame.
  struct Lookup {
    std::shared_ptr<const render::RenderMesh> mesh;
    bool stand_in = false;
  };
  Lookup lookup(const visualization_msgs::Marker& m) const;
  /// The loaded mesh of m, or null (lookup(m).mesh).
  std::shared_ptr<const render::RenderMesh> find(const visualization_msgs::Marker& m) const {
    return lookup(m).mesh;
  }
  /// Whether m is drawn as a stand-in (lookup(m).stand_in).
  bool failed(const visualization_msgs::Marker& m) const { return lookup(m).stand_in; }
  std::size_t size() const { return meshes_.size(); }
  std::size_t bytes() const { return bytes_; }
  /// Distinct (resource, scale) pairs kept at most (failures included).
  static constexpr std::size_t kMaxMeshes = 256;
  /// Bytes of RenderMesh arrays kept at most.
  static constexpr std::size_t kMaxBytes = std::size_t(256) << 20;

 private:
  // (resource, the scale's three doubles as bits: a total order, NaN included).
  using Key = std::tuple<std::string, std::uint64_t, std::uint64_t, std::uint64_t>;
  using KeyRef = std::tuple<const std::string&, std::uint64_t, std::uint64_t, std::uint64_t>;
  static KeyRef key(const visualization_msgs::Marker& m);
  struct Entry {
    std::shared_ptr<const render::RenderMesh> mesh;  ///< null: failed
    std::size_t bytes = 0;
    std::list<const Key*>::iterator used;  ///< its place in used_
  };
  void evict();
  ResourceResolver resolver_;
  render::DrawOptions opt_;
  std::map<Key, Entry, std::less<>> meshes_;
  std::list<const Key*> used_;  ///< most recently used first
  std::size_t bytes_ = 0;
};

/// The markers the renderer draws from sim_markers, kept by (ns, id) as RViz keeps them: ADD
/// (and MODIFY) replaces, DELETE removes, DELETEALL empties; at most kMaxMarkers are kept (a new
/// one past the cap is dropped). Mesh markers' triangles are loaded into `meshes` on arrival.
class SimMarkers {
 public:
  static constexpr std::size_t kMaxMarkers = 10000;
  struct Update {
    bool new_solid = false;             ///< a CUBE or MESH_RESOURCE not seen before (worth framing)
    std::size_t dropped = 0;            ///< new markers past the cap
    std::vector<std::string> warnings;  ///< meshes that could not be read (once each)
  };
  Update apply(const visualization_msgs::MarkerArray& msg, MarkerMeshes& meshes);
  const std::map<std::pair<std::string, int>, visualization_msgs::Marker>& markers() const {
    return markers_;
  }

 private:
  std::map<std::pair<std::string, int>, visualization_msgs::Marker> markers_;
};

/// Appends the render markers of one visualization_msgs/Marker whose frame is at `frame` in
/// the renderer's fixed frame: SPHERE, CUBE, CYLINDER, ARROW, POINTS, SPHERE_LIST, LINE_STRIP,
/// LINE_LIST, and MESH_RESOURCE when `meshes` holds its mesh (a failed one as its stand-in
/// cube; others, and meshes not loaded, are ignored). Non-finite input adds nothing.
void append_markers(const visualization_msgs::Marker& m, const SE3& frame,
                    std::vector<render::Marker>& out, const MarkerMeshes* meshes = nullptr);

/// One camera_command step (the convention in render.h) applied to cam.
void apply_camera_command(const geometry_msgs::Twist& cmd, render::Camera& cam);

/// camera_info of the renderer's pinhole (ROS puts the centre of the top-left pixel at 0, 0).
sensor_msgs::CameraInfo camera_info(const render::Camera& cam, const std::string& frame,
                                    const ros::Time& stamp);

/// The draw list for RViz: one marker per item, in its link's frame (frame_locked), namespace
/// ns, ids from 0: MESH_RESOURCE with the mesh's URI and scale where the item is a mesh,
/// CUBE / SPHERE / CYLINDER for primitives, a capsule as a cylinder and two spheres.
/// `link_offset_inv[k]` maps item k's body frame to its link frame (link = body * offset).
visualization_msgs::MarkerArray rviz_markers(const std::vector<render::DrawItem>& items,
                                             const std::vector<SE3>& link_offset_inv,
                                             const ros::Time& stamp, const std::string& ns);

/// Keeps the camera's offset from a moving frame: the first update() records eye and target
/// relative to the frame's origin; later ones move both with it. A camera changed by the user
/// (set_camera) keeps its new offset.
class FollowCamera {
 public:
  /// Returns the camera to draw with, given the frame origin (world) now.
  render::Camera update(const render::Camera& cam, const Vec3& origin);
  /// The user moved the camera while following at `origin`.
  void set_camera(const render::Camera& cam, const Vec3& origin);
  bool started() const { return started_; }

 private:
  bool started_ = false;
  Vec3 eye_offset_ = Vec3::Zero(), target_offset_ = Vec3::Zero();
};

/// A new file dir/se3_sim_frame_NNNNNN.png that did not exist (created empty, exclusively, so
/// two renderers never pick the same name): the counter advances past taken names. Returns ""
/// with a reason in *error when dir is not writable.
std::string reserve_frame_path(const std::string& dir, int& counter, std::string* error);

}  // namespace ros_renderer
}  // namespace se3
