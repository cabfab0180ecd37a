// The geometry layer: shapes, triangle meshes, materials, and the visual and collision geometry
// of every body, kept in a GeometryModel beside the Model (as Pinocchio keeps its
// GeometryModel beside its Model). The renderer and the collision layer both read it; nothing
// else in the library describes shapes.
//
// ---- What a GeometryModel holds
//
//   GeometryModel g = geometry_from_urdf_file(model, "robot.urdf");   // visuals and collisions
//   for (const GeometryObject& o : g.collisions) {
//     o.body;        // Model body index (0 = base) the shape moves with
//     o.placement;   // shape frame in that body's frame (link offset * URDF <origin>)
//     o.shape.type;  // Box, Sphere, Cylinder, Capsule or Mesh
//     o.shape.box;   // Box: full extents (m); Sphere/Cylinder/Capsule: o.shape.radius, .length
//     o.shape.mesh;  // Mesh: triangles in the shape frame, metres; multiply by o.shape.scale
//   }
//
// A world point of a shape is oMb[o.body] * o.placement * (o.shape.scale .* v), with oMb from
// forward_kinematics (dynamics layer). Cylinders and capsules have their axis along z and are
// centred at the shape frame (URDF's convention); a capsule's length is between the centres of
// its two caps. A body may carry any number of objects; a link merged into a body by a fixed
// joint contributes its objects to that body, placed through the link's offset.
//
// Scene objects (boxes, spheres, cylinders, capsules, meshes; free or fixed in the world) are
// GeometryObjects too: make_box / make_sphere / ... or load_mesh_shape (a mesh from a resource
// name with the same resolver as the URDF's) give the shape, and the caller sets `body` and
// `placement`; GeometryObject::kWorld as body means fixed in the world frame (placement in
// world). The collision layer owns their body numbering; this layer only describes shapes.
//
// ---- Meshes
//
// Loaded with assimp: binary and ASCII STL, Collada (.dae) and Wavefront OBJ (with its .mtl),
// and whatever else assimp reads. Collada files are read the way RViz reads them: node
// transforms applied, the <unit meter="..."> scale applied, the <up_axis> rotation NOT applied
// (RViz drops the rotation assimp puts in the root node; ROS meshes are authored for that). A
// loaded mesh is triangulated, has unit per-vertex normals (STL's face normals are replaced by
// smoothed ones, creases above 60 degrees kept sharp) and one SubMesh per material with the
// file's diffuse colour where the file has one (STL has none). Meshes are cached by resolved
// path, so links sharing a file share one TriangleMesh.
//
// decode_mesh() is the pure entry point (bytes in, mesh or a reason out, bounded by MeshLimits)
// that load_mesh() and the fuzz target use.
//
// ---- Resource names (the ROS way)
//
//   package://PKG/rel/path   PKG's folder: the first folder on the search path (ResourcePaths::
//                            package_path, then $ROS_PACKAGE_PATH) holding a package.xml whose
//                            <name> is PKG (folders are searched recursively as rospack does:
//                            not below a package, not into CATKIN_IGNORE'd folders)
//   file:///abs/path         that file
//   /abs/path                that file
//   rel/path                 relative to ResourcePaths::base_dir (the URDF's own folder)
//
// resolve_resource() does this and is public (scene files use it for their mesh objects). A
// node can inject ROS's own resolution (ros::package) as a ResourceResolver.
//
// ---- Missing and broken meshes
//
// A mesh that cannot be resolved or read gives one warning naming the link and the resource
// (GeometryModel::warnings, also on GeometryObject::warning) and a stand-in shape: the link's
// collision primitive if it has one, else a small sphere at the visual's origin. Never a crash,
// never a silent skip.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "se3_sim/lie/lie.h"
#include "se3_sim/model/model.h"

namespace se3 {

using Vec3f = Eigen::Vector3f;
using Vec4f = Eigen::Vector4f;

/// A colour and where it came from.
struct Material {
  std::string name;  ///< URDF material name or the mesh file's material name
  Vec4f rgba = Vec4f(0.7f, 0.7f, 0.7f, 1.0f);  ///< linear 0..1
  bool has_color = false;                      ///< false: the renderer's default applies
};

/// Triangles with per-vertex normals, split into sub-meshes of one material each.
struct TriangleMesh {
  std::vector<Vec3f> positions;   ///< shape frame, metres (file units converted)
  std::vector<Vec3f> normals;     ///< unit, one per position
  std::vector<Vec4f> colors;      ///< optional per-vertex rgba (empty, or one per position)
  std::vector<uint32_t> indices;  ///< three per triangle, counter-clockwise seen from outside
                                  ///< where the file says so (the renderer draws either winding)
  struct SubMesh {
    uint32_t first_triangle = 0;
    uint32_t triangle_count = 0;
    Material material;
    bool closed = false;  ///< the mesh is closed, or this sub-mesh is closed on its own
    bool outward = true;  ///< (when closed) counter-clockwise faces out
  };
  std::vector<SubMesh> submeshes;                      ///< cover all triangles in order
  Vec3f lower = Vec3f::Zero(), upper = Vec3f::Zero();  ///< axis-aligned bounds of positions
  /// Every edge (vertices matched by position) is shared by exactly two triangles that run it
  /// in opposite directions: a closed, consistently wound surface. Only then may a renderer
  /// cull back faces; `outward` tells which winding faces out (signed volume >= 0).
  bool closed = false;
  bool outward = true;
  std::string source;  ///< resolved path, or a description ("box", "<memory>.stl")
  /// What the loader dropped or simplified, one line ("" when nothing): duplicate or degenerate
  /// faces, smoothing skipped (its work bounded), a material file not read.
  std::string warning;

  std::size_t triangle_count() const { return indices.size() / 3; }
};

/// Recomputes lower/upper, closed and outward from positions and indices (after editing).
void finish_mesh(TriangleMesh& mesh);

enum class ShapeType { Box, Sphere, Cylinder, Capsule, Mesh };
const char* shape_name(ShapeType t);

struct Shape {
  ShapeType type = ShapeType::Box;
  Vec3 box = Vec3::Zero();  ///< Box: full extents x, y, z (m)
  double radius = 0;        ///< Sphere, Cylinder, Capsule
  double length = 0;        ///< Cylinder, Capsule: along z (capsule: between cap centres)
  /// Mesh: the triangles (shared, read-only; cached by path). Null for primitives.
  std::shared_ptr<const TriangleMesh> mesh;
  Vec3 scale = Vec3::Ones();  ///< Mesh: per-axis scale (URDF <mesh scale>)
  std::string resource;       ///< Mesh: the name as written (package://, file://, relative)
  std::string path;           ///< Mesh: the resolved file ("" when unresolved)
};

Shape make_box(const Vec3& full_extents);
Shape make_sphere(double radius);
Shape make_cylinder(double radius, double length);
Shape make_capsule(double radius, double length);

/// A triangle mesh of a primitive shape in its frame (Mesh: a copy of its mesh, scaled), with
/// outward normals; `segments` around the axis (cylinder, capsule, sphere longitudes).
TriangleMesh tessellate(const Shape& shape, int segments = 32);
/// The unit cone of arrow heads: base radius 0.5 at z = 0, apex at z = 1.
TriangleMesh cone_mesh(int segments = 24);

/// A shape placed on a body.
struct GeometryObject {
  static constexpr int kWorld = -1;  ///< body of geometry fixed in the world frame
  std::string name;                  ///< unique in its list: "<link>_<k>"
  std::string link;                  ///< frame name of the URDF link (leading '/' stripped)
  int body = 0;                      ///< Model body index, or kWorld
  SE3 placement;                     ///< shape frame in the body frame
  Shape shape;
  Material material;      ///< URDF material (visuals); mesh sub-meshes may carry their own
  bool stand_in = false;  ///< the mesh could not be loaded; `shape` is its stand-in
  std::string warning;    ///< why (when stand_in), as in GeometryModel::warnings
};

struct GeometryModel {
  std::vector<GeometryObject> visuals;
  std::vector<GeometryObject> collisions;
  std::vector<std::string> warnings;  ///< one line each: missing or broken meshes, ...
  /// Triangles of all mesh visuals (primitives not counted).
  std::size_t visual_mesh_triangles() const;
};

// ---------------------------------------------------------------- resources

/// Where resource names are looked up.
struct ResourcePaths {
  std::string base_dir;                   ///< for relative names (the URDF's folder)
  std::vector<std::string> package_path;  ///< searched before ROS_PACKAGE_PATH
  bool use_ros_package_path = true;       ///< also search $ROS_PACKAGE_PATH
};

/// The file a resource name denotes, or "" with a one-line reason in *error (unknown scheme,
/// package not found, file not found). Thread-safe; package folders are cached.
std::string resolve_resource(const std::string& uri, const ResourcePaths& paths,
                             std::string* error = nullptr);
/// The file `rel` (the part of a package:// name after the package) inside the package folder
/// `dir`: "" and a reason when, after lexical normalisation, it is absolute or starts with ".."
/// (package://pkg/../../etc/x would leave the package). No file access.
std::string package_file(const std::string& dir, const std::string& rel,
                         std::string* error = nullptr);
/// Whether the file's extension names a mesh format the loader reads (.stl, .dae, .obj, .ply,
/// .off, .3ds, .fbx, .gltf, .glb, .3mf, .amf, .ac, .lwo, .ms3d where assimp has the importer;
/// not assimp's generic names such as .xml); no file access. The renderer reads only such
/// files for markers.
bool is_mesh_file_type(const std::string& path);
/// Folder of package `name` on the search path, or "".
std::string find_package(const std::string& name, const ResourcePaths& paths);
/// Splits "a:b:c" (ROS_PACKAGE_PATH syntax); empty entries dropped.
std::vector<std::string> split_path_list(const std::string& list);

/// Maps a resource name to a file; returns "" and sets *error when it cannot. The default is
/// resolve_resource with the given paths; a ROS node may use ros::package instead.
using ResourceResolver = std::function<std::string(const std::string& uri, std::string* error)>;

/// GeometryModel::warnings with the meshes whose package was not found folded into one line
/// per package: how many meshes, which links, and how to add the package to ROS_PACKAGE_PATH
/// (a robot whose mesh package is missing gives one line, not two per link). Other lines as
/// they were, in order.
std::vector<std::string> summarize_mesh_warnings(const std::vector<std::string>& warnings);

// ---------------------------------------------------------------- meshes

/// Bounds on what a mesh file may make the loader do.
struct MeshLimits {
  /// Work of the normal smoothing and vertex joining (assimp's, quadratic in the number of
  /// vertices at one position): the sum over distinct positions of (vertices there)^2, after
  /// duplicate and degenerate faces are dropped. Beyond it the mesh keeps one normal a face.
  std::size_t max_smoothing_work = 20'000'000;
  std::size_t max_bytes = std::size_t(256) << 20;  ///< file size
  std::size_t max_triangles = 20'000'000;
  /// load_mesh imports in a child process (POSIX fork), so that an importer that crashes on a
  /// malformed file (assimp 5.2 does on some) or hangs gives a reason instead of ending the
  /// process; after `seconds` the child is killed. decode_mesh always runs in-process.
  bool isolate = true;
  double seconds = 60;
};

/// Decodes a mesh from memory. `hint` is the file extension ("stl", "dae", "obj", ...), which
/// picks the importer and the normal handling. Returns null and a one-line reason in *error
/// for anything it cannot use (empty or truncated data, no triangles, too many triangles,
/// non-finite coordinates). Pure: no file access (an OBJ's .mtl is not read from memory).
std::shared_ptr<TriangleMesh> decode_mesh(const void* data, std::size_t size,
                                          const std::string& hint, const MeshLimits& limits = {},
                                          std::string* error = nullptr);
/// Loads a mesh file (an OBJ reads its .mtl beside it), in a child process unless
/// limits.isolate is false. Only a regular file is read (a FIFO, device or directory is named
/// as such in *error), and an OBJ's material files only if they are regular files in the
/// mesh's folder or below (others: a line in TriangleMesh::warning, the default material).
/// Cached by path: a second call returns the same mesh (a failure is cached too, with its
/// reason); past 1024 paths the entries no one else holds are dropped. Thread-safe.
std::shared_ptr<const TriangleMesh> load_mesh(const std::string& path, std::string* error = nullptr,
                                              const MeshLimits& limits = {});
/// Empties the cache of load_mesh (meshes in use stay alive through their shared pointers).
void clear_mesh_cache();

/// A Mesh shape from a resource name (as a scene file's {mesh: PATH, scale: [...]}): resolved
/// with `resolver`, loaded through the cache. On failure returns false, fills *error and
/// leaves `out` a Mesh shape without triangles.
bool load_mesh_shape(const std::string& uri, const Vec3& scale, const ResourceResolver& resolver,
                     Shape& out, std::string* error = nullptr);

// ---------------------------------------------------------------- from URDF

struct GeometryOptions {
  ResourcePaths paths;        ///< used when resolver is empty
  ResourceResolver resolver;  ///< optional: resolution of mesh names (e.g. ROS's own)
  bool load_meshes = true;    ///< false: every mesh becomes its stand-in, no file is read
  MeshLimits limits;
};

/// Visual and collision geometry of `model` from the parsed URDF it was built from
/// (model_from_urdf, model.h; link names are matched through model.links). Materials: a
/// visual's inline <material><color>, or the robot-level material it names. Never throws for a
/// missing or broken mesh (see above). Relative mesh names resolve against the folder of
/// doc.file unless opt.paths.base_dir is set.
GeometryModel geometry_from_urdf(const Model& model, const UrdfDocument& doc,
                                 GeometryOptions opt = {});
/// As above from URDF text (parsed again through parse_urdf_document; throws ModelError if it
/// does not parse). Parse once and use geometry_from_urdf when the model is built too.
GeometryModel geometry_from_urdf_string(const Model& model, const std::string& xml,
                                        const GeometryOptions& opt = {});
/// As above from a file (read_urdf_document); relative mesh names resolve against the file's
/// folder unless opt.paths.base_dir is set.
GeometryModel geometry_from_urdf_file(const Model& model, const std::string& path,
                                      GeometryOptions opt = {});

/// Geometry of a make_chain model: on every body a slender box from its origin to the next
/// joint (length |X_tree[1].p|, along the body's x axis), as make_chain's links are shaped.
GeometryModel chain_geometry(const Model& chain);

}  // namespace se3
