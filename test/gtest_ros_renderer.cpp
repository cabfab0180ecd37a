// The renderer node's logic without a master (src/ros/renderer_convert.h): camera_info, the
// RViz MarkerArray (MESH_RESOURCE with the URDF's package:// names), sim markers, the camera
// command, following a frame, save_frame's paths, mesh resolution through rospack.
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include "se3_sim/ros/convert.h"
#include "se3_sim/ros/renderer_convert.h"
#include "source_paths.h"

using namespace se3;
namespace rr = se3::ros_renderer;
namespace fs = std::filesystem;

namespace {

// The sim_markers a scene object of this shape, colour and pose gives (the simulator's
// append_object_markers), as the renderer node receives them.
visualization_msgs::MarkerArray object_markers(const Shape& shape, const Vec4f& rgba,
                                               const SE3& pose) {
  SceneObject o;
  o.name = "thing";
  o.shape = shape;
  o.material.rgba = rgba;
  o.material.has_color = true;
  ObjectState st;
  st.name = o.name;
  st.pose = pose;
  visualization_msgs::MarkerArray arr;
  se3_ros::append_object_markers({o}, {st}, "world", ros::Time(), arr);
  return arr;
}

// A 320 x 240 pinhole of focal length 300 px looking from eye at target.
render::Camera small_camera(const Vec3& eye, const Vec3& target) {
  render::Camera cam;
  cam.width = 320;
  cam.height = 240;
  cam.focal_px = 300;
  cam.eye = eye;
  cam.target = target;
  cam.update();
  return cam;
}

}  // namespace

TEST(RosRenderer, CameraInfoIsThePinhole) {
  render::Camera cam;
  cam.focal_px = 900;
  cam.update();
  const sensor_msgs::CameraInfo info = rr::camera_info(cam, "cam", ros::Time(3, 0));
  EXPECT_EQ(info.width, 1280u);
  EXPECT_EQ(info.height, 1024u);
  EXPECT_EQ(info.header.frame_id, "cam");
  EXPECT_EQ(info.K[0], 900);
  EXPECT_EQ(info.K[4], 900);
  // ROS puts the centre of pixel (0, 0) at (0, 0); ours is at (0.5, 0.5).
  EXPECT_EQ(info.K[2], 639.5);
  EXPECT_EQ(info.K[5], 511.5);
  EXPECT_EQ(info.P[2], 639.5);
  EXPECT_EQ(info.distortion_model, "plumb_bob");
}

TEST(RosRenderer, RvizMarkersNameTheMeshes) {
  const std::string urdf = se3_sim_test::source_dir() + "/data/robots/panda.urdf";
  const Model m = model_from_urdf_file(urdf);
  GeometryOptions go;
  go.paths.package_path = {se3_sim_test::source_dir() + "/data/meshes"};
  const GeometryModel g = geometry_from_urdf_file(m, urdf, go);
  const auto items = render::make_draw_items(m, g);
  std::vector<SE3> inv;
  for (const auto& it : items) inv.push_back(m.links[m.link_index(it.link)].offset.inverse());
  const auto arr = rr::rviz_markers(items, inv, ros::Time(1, 0), "robot");
  ASSERT_EQ(arr.markers.size(), items.size());
  std::set<int> ids;
  for (const auto& mk : arr.markers) {
    ids.insert(mk.id);
    EXPECT_EQ(mk.type, visualization_msgs::Marker::MESH_RESOURCE);
    EXPECT_EQ(mk.mesh_resource.rfind(
                  "package://example-robot-data/robots/panda_description/meshes/visual/", 0),
              0u)
        << mk.mesh_resource;
    EXPECT_TRUE(mk.mesh_use_embedded_materials);  // the Collada files carry colours
    EXPECT_TRUE(mk.frame_locked);
    EXPECT_NE(mk.header.frame_id, "");
    EXPECT_EQ(mk.scale.x, 1.0);
  }
  EXPECT_EQ(ids.size(), arr.markers.size());
  // A link's visual at the link's own origin (panda_link1's mesh has no URDF origin).
  for (std::size_t k = 0; k < items.size(); ++k) {
    if (items[k].link != "panda_link1") continue;
    const auto& p = arr.markers[k].pose;
    EXPECT_NEAR(p.position.x, 0, 1e-12);
    EXPECT_NEAR(p.position.z, 0, 1e-12);
    EXPECT_NEAR(std::abs(p.orientation.w), 1, 1e-12);
  }

  // Primitives and stand-ins: a capsule is a cylinder and two balls.
  const std::string xml = R"(<robot name="p"><link name="a">
    <visual><geometry><box size="1 2 3"/></geometry></visual>
    <visual><geometry><mesh filename="package://nowhere/x.stl"/></geometry></visual></link>
    <link name="b"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
    <joint name="j" type="continuous"><parent link="a"/><child link="b"/><origin xyz="0 0 1"/></joint></robot>)";
  const Model pm = model_from_urdf_string(xml);
  GeometryOptions none;
  none.paths.use_ros_package_path = false;
  const GeometryModel pg = geometry_from_urdf_string(pm, xml, none);
  const auto pitems = render::make_draw_items(pm, pg);
  const auto parr = rr::rviz_markers(pitems, std::vector<SE3>(pitems.size()), ros::Time(), "p");
  ASSERT_EQ(parr.markers.size(), 4u);
  EXPECT_EQ(parr.markers[0].type, visualization_msgs::Marker::CUBE);
  EXPECT_EQ(parr.markers[0].scale.y, 2.0);
  EXPECT_EQ(parr.markers[1].type, visualization_msgs::Marker::CYLINDER);
  EXPECT_EQ(parr.markers[2].type, visualization_msgs::Marker::SPHERE);
  EXPECT_EQ(parr.markers[3].type, visualization_msgs::Marker::SPHERE);
  EXPECT_NEAR(parr.markers[3].pose.position.z - parr.markers[2].pose.position.z, 1.0, 1e-12);
}

TEST(RosRenderer, SimMarkersAndCameraCommand) {
  visualization_msgs::Marker m;
  m.type = visualization_msgs::Marker::CUBE;
  m.pose.position.x = 1;
  m.scale.x = 0.5;
  m.scale.y = 0.6;
  m.scale.z = 0.7;
  m.color.r = 1;
  std::vector<render::Marker> out;
  rr::append_markers(m, SE3(Mat3::Identity(), Vec3(0, 0, 2)), out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].type, render::Marker::Type::Box);
  EXPECT_TRUE(out[0].a.isApprox(Vec3(1, 0, 2)));
  EXPECT_TRUE(out[0].size3.isApprox(Vec3(0.5, 0.6, 0.7)));
  m.pose.position.x = std::nan("");
  rr::append_markers(m, SE3(), out);
  EXPECT_EQ(out.size(), 1u);  // non-finite: nothing
  m.type = visualization_msgs::Marker::LINE_STRIP;
  m.pose.position.x = 0;
  m.points.resize(3);
  rr::append_markers(m, SE3(), out);
  EXPECT_EQ(out.size(), 3u);

  render::Camera cam;
  cam.update();
  const double d0 = (cam.eye - cam.target).norm();
  geometry_msgs::Twist t;
  t.linear.x = 0.5;
  t.angular.z = std::nan("");
  rr::apply_camera_command(t, cam);
  EXPECT_NEAR((cam.eye - cam.target).norm(), 0.5 * d0, 1e-9);
  EXPECT_TRUE(cam.P.allFinite());
}

// Scene objects as the simulator publishes them on sim_markers (append_object_markers: a
// cylinder as CYLINDER, a capsule as a CYLINDER and two SPHEREs) and the renderer node draws
// them (append_markers, Renderer): the pixels that differ from the background are the
// object's colour and their bounding box is the projection of the exact shape (points on its
// rims and end spheres through the camera) within 2 px; the capsule's middle is filled, not
// only its end balls.
TEST(RosRenderer, SceneCylindersAndCapsulesAreDrawnWhereTheyProject) {
  const render::Camera cam = small_camera(Vec3(3, 0, 0.6), Vec3(0, 0, 0.6));
  const double r = 0.2, l = 0.6;
  // Axis z of the shape along world y, then turned 0.4 rad about world z.
  const Mat3 R =
      (Eigen::AngleAxisd(0.4, Vec3::UnitZ()) * Eigen::AngleAxisd(M_PI / 2, Vec3::UnitX()))
          .toRotationMatrix();
  const SE3 pose(R, Vec3(0, 0, 0.6));
  for (const bool capsule : {false, true}) {
    SCOPED_TRACE(capsule ? "capsule" : "cylinder");
    const visualization_msgs::MarkerArray arr = object_markers(
        capsule ? make_capsule(r, l) : make_cylinder(r, l), Vec4f(0.9f, 0.1f, 0.1f, 1.0f), pose);
    ASSERT_EQ(arr.markers.size(), capsule ? 3u : 1u);
    std::vector<render::Marker> markers;
    for (const auto& m : arr.markers) rr::append_markers(m, SE3(), markers);
    ASSERT_EQ(markers.size(), arr.markers.size());

    render::Renderer ren(cam);
    ren.style().grid = false;
    ren.style().overlay = false;
    ren.render({}, markers);
    // The drawn pixels: their bounding box, all of them red.
    int x0 = cam.width, y0 = cam.height, x1 = -1, y1 = -1, drawn = 0, red = 0;
    for (int y = 0; y < cam.height; ++y) {
      for (int x = 0; x < cam.width; ++x) {
        if (ren.framebuffer().pixel(x, y) == ren.background(x, y)) continue;
        ++drawn;
        const render::Rgb q = ren.framebuffer().rgb(x, y);
        red += int(q.r) > int(q.g) + 40 && int(q.r) > int(q.b) + 40;
        x0 = std::min(x0, x);
        y0 = std::min(y0, y);
        x1 = std::max(x1, x);
        y1 = std::max(y1, y);
      }
    }
    ASSERT_GT(drawn, 0);
    EXPECT_EQ(red, drawn);
    // The exact silhouette's bounding box: a cylinder is the hull of its two rims, a capsule
    // the hull of its two end spheres.
    double px0 = 1e9, py0 = 1e9, px1 = -1e9, py1 = -1e9;
    auto add = [&](const Vec3& local) {
      render::Vec2 px;
      ASSERT_TRUE(cam.project(pose.act(local), px));
      px0 = std::min(px0, px.x());
      py0 = std::min(py0, px.y());
      px1 = std::max(px1, px.x());
      py1 = std::max(py1, px.y());
    };
    const int n = 360;
    for (int i = 0; i < n; ++i) {
      const double t = 2 * M_PI * i / n;
      for (const double z : {-0.5 * l, 0.5 * l}) {
        if (!capsule) {
          add(Vec3(r * std::cos(t), r * std::sin(t), z));
          continue;
        }
        for (int j = 0; j <= n / 2; ++j) {
          const double u = M_PI * j / (n / 2);
          add(Vec3(r * std::sin(u) * std::cos(t), r * std::sin(u) * std::sin(t),
                   z + r * std::cos(u)));
        }
      }
    }
    // Pixel x covers [x, x + 1): the drawn box spans the predicted one to within 2 px.
    EXPECT_NEAR(x0, px0, 2);
    EXPECT_NEAR(y0, py0, 2);
    EXPECT_NEAR(x1 + 1, px1, 2);
    EXPECT_NEAR(y1 + 1, py1, 2);
    // The middle of the axis and the points a quarter of the length from it are covered.
    for (const double z : {-0.25 * l, 0.0, 0.25 * l}) {
      render::Vec2 px;
      ASSERT_TRUE(cam.project(pose.act(Vec3(0, 0, z)), px));
      const int x = int(px.x()), y = int(px.y());
      EXPECT_NE(ren.framebuffer().pixel(x, y), ren.background(x, y)) << "z " << z;
    }
  }
}

// A scene's mesh object as the simulator publishes it (MESH_RESOURCE, file:// of the resolved
// path, the scene's scale) is drawn by the renderer node with its own triangles (MarkerMeshes,
// append_markers): an STL box of 0.2 x 0.15 x 0.1 m scaled by (1, 2, 3) covers the same pixels as
// a box marker of 0.2 x 0.3 x 0.3 m at the same pose (intersection over union >= 0.98, in the
// object's colour); without the mesh cache the marker draws nothing, and a resource that cannot
// be read warns once, naming it, and is drawn as the stand-in cube.
TEST(RosRenderer, SceneMeshObjectsAreDrawnWithTheirTriangles) {
  const fs::path dir = fs::temp_directory_path() / ("se3_marker_mesh_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string stl = (dir / "box.stl").string();
  {
    // Twelve triangles of an axis-aligned box centred at the origin, outward normals.
    const double h[3] = {0.1, 0.075, 0.05};
    std::ofstream f(stl);
    f << "solid box\n";
    for (int axis = 0; axis < 3; ++axis) {
      for (int side = -1; side <= 1; side += 2) {
        const int u = (axis + 1) % 3, v = (axis + 2) % 3;
        auto corner = [&](int a, int b) {
          double c[3];
          c[axis] = side * h[axis];
          c[u] = a * h[u];
          c[v] = b * h[v];
          return Vec3(c[0], c[1], c[2]);
        };
        Vec3 quad[4] = {corner(-1, -1), corner(1, -1), corner(1, 1), corner(-1, 1)};
        if (side < 0) std::swap(quad[1], quad[3]);
        for (const auto& tri : {std::array<int, 3>{0, 1, 2}, std::array<int, 3>{0, 2, 3}}) {
          f << "facet normal 0 0 0\nouter loop\n";
          for (int k : tri) f << "vertex " << quad[k].transpose() << "\n";
          f << "endloop\nendfacet\n";
        }
      }
    }
    f << "endsolid box\n";
  }
  const render::Camera cam = small_camera(Vec3(1.6, -1.2, 1.0), Vec3(0, 0, 0.3));
  const SE3 pose(Eigen::AngleAxisd(0.5, Vec3(1, 2, 3).normalized()).toRotationMatrix(),
                 Vec3(0.05, 0.0, 0.3));
  const Vec3 scale(1, 2, 3);

  Shape crate;
  std::string err;
  ASSERT_TRUE(load_mesh_shape(stl, scale, ResourceResolver(), crate, &err)) << err;
  const visualization_msgs::MarkerArray arr =
      object_markers(crate, Vec4f(0.1f, 0.2f, 0.9f, 1.0f), pose);
  ASSERT_EQ(arr.markers.size(), 1u);
  const visualization_msgs::Marker& m = arr.markers[0];
  ASSERT_EQ(m.type, visualization_msgs::Marker::MESH_RESOURCE);

  auto drawn_pixels = [&](const std::vector<render::Marker>& markers, int* blue) {
    render::Renderer ren(cam);
    ren.style().grid = false;
    ren.style().overlay = false;
    ren.render({}, markers);
    std::vector<bool> on(std::size_t(cam.width) * cam.height, false);
    if (blue) *blue = 0;
    for (int y = 0; y < cam.height; ++y) {
      for (int x = 0; x < cam.width; ++x) {
        if (ren.framebuffer().pixel(x, y) == ren.background(x, y)) continue;
        on[std::size_t(y) * cam.width + x] = true;
        const render::Rgb q = ren.framebuffer().rgb(x, y);
        if (blue) *blue += int(q.b) > int(q.r) + 40 && int(q.b) > int(q.g) + 40;
      }
    }
    return on;
  };

  std::vector<render::Marker> none;
  rr::append_markers(m, SE3(), none);
  EXPECT_TRUE(none.empty()) << "a MESH_RESOURCE marker without the mesh cache";

  rr::MarkerMeshes meshes(rr::ros_resolver());
  std::string warning;
  EXPECT_FALSE(meshes.load(m, &warning)) << warning;
  EXPECT_FALSE(meshes.load(m, &warning)) << "loaded once";
  EXPECT_EQ(meshes.size(), 1u);
  std::vector<render::Marker> mesh_markers;
  rr::append_markers(m, SE3(), mesh_markers, &meshes);
  ASSERT_EQ(mesh_markers.size(), 1u);
  EXPECT_EQ(mesh_markers[0].type, render::Marker::Type::Mesh);

  render::Marker box;
  box.type = render::Marker::Type::Box;
  box.a = pose.p;
  box.R = pose.R;
  box.size3 = Vec3(0.2, 0.3, 0.3);
  box.color = Eigen::Vector3d(0.1, 0.2, 0.9);
  int blue = 0;
  const std::vector<bool> a = drawn_pixels(mesh_markers, &blue), b = drawn_pixels({box}, nullptr);
  int both = 0, either = 0, count = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    both += a[i] && b[i];
    either += a[i] || b[i];
    count += a[i];
  }
  ASSERT_GT(count, 2000);
  EXPECT_GE(double(both) / either, 0.98) << both << " of " << either;
  EXPECT_EQ(blue, count);

  // A resource that cannot be read: one warning naming it, then the stand-in cube.
  visualization_msgs::Marker missing = m;
  missing.mesh_resource = "file://" + (dir / "no_such.stl").string();
  missing.id = 7;
  warning.clear();
  EXPECT_TRUE(meshes.load(missing, &warning));
  EXPECT_NE(warning.find("no_such.stl"), std::string::npos) << warning;
  EXPECT_NE(warning.find("stand-in"), std::string::npos) << warning;
  EXPECT_FALSE(meshes.load(missing, &warning)) << "warned once";
  std::vector<render::Marker> stand_in;
  rr::append_markers(missing, SE3(), stand_in, &meshes);
  ASSERT_EQ(stand_in.size(), 1u);
  EXPECT_EQ(stand_in[0].type, render::Marker::Type::Box);
  EXPECT_TRUE(stand_in[0].size3.isApprox(0.1 * scale));

  // A flood of distinct resources: the cache keeps the kMaxMeshes most recently used. The box,
  // sent again between them (as the simulator republishes its objects), is marked used each
  // time and stays, without being read again; the oldest failure is evicted and is a stand-in
  // until it is sent again.
  for (std::size_t k = 0; k < 2 * rr::MarkerMeshes::kMaxMeshes; ++k) {
    visualization_msgs::Marker flood = missing;
    flood.mesh_resource = "file://" + (dir / ("flood" + std::to_string(k) + ".stl")).string();
    EXPECT_TRUE(meshes.load(flood));
    EXPECT_FALSE(meshes.load(m));
    ASSERT_LE(meshes.size(), rr::MarkerMeshes::kMaxMeshes);
  }
  EXPECT_EQ(meshes.size(), rr::MarkerMeshes::kMaxMeshes);
  EXPECT_LE(meshes.bytes(), rr::MarkerMeshes::kMaxBytes);
  EXPECT_FALSE(meshes.find(m) == nullptr) << "the mesh in use stays";
  EXPECT_TRUE(meshes.failed(missing)) << "evicted: drawn as a stand-in";
  fs::remove_all(dir);
}

// Any node may publish on sim_markers: the renderer reads a marker's resource only when its
// name is a mesh file type and a package:// name stays in its package, and its warnings are the
// same for a file that does not exist and one that cannot be read as a mesh (a directory named
// like a mesh here), so /rosout tells nothing about the file system.
TEST(RosRenderer, MarkerMeshesReadOnlyMeshFilesInsideTheirPackage) {
  rr::MarkerMeshes meshes(rr::ros_resolver());
  visualization_msgs::Marker mk;
  mk.type = visualization_msgs::Marker::MESH_RESOURCE;
  mk.scale.x = mk.scale.y = mk.scale.z = 1;
  auto warning_of = [&](const std::string& resource) {
    mk.mesh_resource = resource;
    ++mk.id;
    std::string w;
    EXPECT_TRUE(meshes.load(mk, &w)) << resource;
    EXPECT_TRUE(meshes.failed(mk)) << resource;
    return w;
  };
  for (const std::string r :
       {"/etc/shadow", "file:///etc/passwd", "package://se3_sim/package.xml", "/etc/hostname"}) {
    const std::string w = warning_of(r);
    EXPECT_NE(w.find("not a mesh file type"), std::string::npos) << w;
  }
  for (const std::string r :
       {"package://se3_sim/../../../../../../etc/shadow.stl", "package://se3_sim/a/../../x.dae"}) {
    const std::string w = warning_of(r);
    EXPECT_NE(w.find("leaves its package"), std::string::npos) << w;
  }
  const fs::path dir = fs::temp_directory_path() / ("se3_marker_probe_" + std::to_string(getpid()));
  fs::create_directories(dir / "dir.stl");
  const std::string missing = warning_of("file://" + (dir / "none.stl").string());
  const std::string directory = warning_of("file://" + (dir / "dir.stl").string());
  EXPECT_EQ(missing.substr(missing.find("' not drawn")),
            directory.substr(directory.find("' not drawn")));
  fs::remove_all(dir);
}

// sim_markers kept as RViz keeps them (ADD replaces by ns and id, DELETE, DELETEALL), new solid
// markers reported for framing, mesh warnings once, and a flood of new ids capped.
TEST(RosRenderer, SimMarkersAreKeptByNamespaceAndIdWithACap) {
  using VM = visualization_msgs::Marker;
  rr::SimMarkers sm;
  rr::MarkerMeshes meshes(rr::ros_resolver());
  auto marker = [](const std::string& ns, int id, int type, int action = VM::ADD) {
    VM m;
    m.ns = ns;
    m.id = id;
    m.type = type;
    m.action = action;
    m.scale.x = m.scale.y = m.scale.z = 1;
    return m;
  };
  visualization_msgs::MarkerArray a;
  a.markers = {marker("objects", 0, VM::SPHERE), marker("objects", 1, VM::CUBE),
               marker("effort", 0, VM::ARROW)};
  rr::SimMarkers::Update up = sm.apply(a, meshes);
  EXPECT_TRUE(up.new_solid);
  EXPECT_EQ(sm.markers().size(), 3u);
  a.markers = {marker("objects", 1, VM::CUBE)};  // the same cube again: not new
  up = sm.apply(a, meshes);
  EXPECT_FALSE(up.new_solid);
  EXPECT_EQ(sm.markers().size(), 3u);
  VM mesh = marker("objects", 2, VM::MESH_RESOURCE);
  mesh.mesh_resource = "file:///nonexistent/se3_sim_none.stl";
  a.markers = {mesh, mesh, marker("effort", 0, VM::ARROW, VM::DELETE)};
  up = sm.apply(a, meshes);
  EXPECT_TRUE(up.new_solid);
  ASSERT_EQ(up.warnings.size(), 1u) << "one warning for the unreadable mesh";
  EXPECT_NE(up.warnings[0].find("se3_sim_none.stl"), std::string::npos);
  EXPECT_EQ(sm.markers().size(), 3u);
  EXPECT_EQ(sm.markers().count({"effort", 0}), 0u);
  a.markers = {marker("", 0, VM::SPHERE, VM::DELETEALL)};
  sm.apply(a, meshes);
  EXPECT_TRUE(sm.markers().empty());
  // A flood: kMaxMarkers kept, the rest dropped and counted; updates of kept ones still apply.
  a.markers.clear();
  for (std::size_t k = 0; k < rr::SimMarkers::kMaxMarkers + 25; ++k) {
    a.markers.push_back(marker("flood", int(k), VM::SPHERE));
  }
  up = sm.apply(a, meshes);
  EXPECT_EQ(sm.markers().size(), rr::SimMarkers::kMaxMarkers);
  EXPECT_EQ(up.dropped, 25u);
  VM moved = marker("flood", 3, VM::SPHERE);
  moved.pose.position.x = 2.5;
  a.markers = {moved};
  up = sm.apply(a, meshes);
  EXPECT_EQ(up.dropped, 0u);
  EXPECT_EQ(sm.markers().at({"flood", 3}).pose.position.x, 2.5);
}

// follow_frame: the camera keeps its offset from a moving frame, and a user's change of view
// is kept as the new offset.
TEST(RosRenderer, FollowCameraKeepsItsOffset) {
  render::Camera cam;
  cam.eye = Vec3(2, -2, 1);
  cam.target = Vec3(0, 0, 0.5);
  cam.update();
  rr::FollowCamera follow;
  EXPECT_FALSE(follow.started());
  render::Camera c = follow.update(cam, Vec3(0, 0, 0));
  EXPECT_TRUE(c.eye.isApprox(cam.eye));
  c = follow.update(cam, Vec3(0, 0, -3));  // the robot fell 3 m
  EXPECT_TRUE(c.eye.isApprox(Vec3(2, -2, -2)));
  EXPECT_TRUE(c.target.isApprox(Vec3(0, 0, -2.5)));
  render::Camera user = c;
  user.eye = Vec3(1, -1, -2);
  follow.set_camera(user, Vec3(0, 0, -3));
  c = follow.update(user, Vec3(1, 0, -3));
  EXPECT_TRUE(c.eye.isApprox(Vec3(2, -1, -2)));
  c = follow.update(user, Vec3::Constant(std::nan("")));  // no TF: as it is
  EXPECT_TRUE(c.eye.isApprox(user.eye));
}

TEST(RosRenderer, SaveFramePathsNeverRepeat) {
  const fs::path dir = fs::path(::testing::TempDir()) / "se3_save_frames";
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "se3_sim_frame_000001.png") << "earlier";
  int counter = 0;
  std::set<std::string> paths;
  for (int i = 0; i < 4; ++i) {
    std::string err;
    const std::string p = rr::reserve_frame_path(dir.string(), counter, &err);
    ASSERT_FALSE(p.empty()) << err;
    EXPECT_TRUE(fs::exists(p));
    paths.insert(p);
  }
  EXPECT_EQ(paths.size(), 4u);
  EXPECT_EQ(paths.count((dir / "se3_sim_frame_000001.png").string()), 0u);  // taken before
  std::ifstream earlier(dir / "se3_sim_frame_000001.png");
  std::string text;
  earlier >> text;
  EXPECT_EQ(text, "earlier");
  int c2 = 0;
  std::string err;
  EXPECT_EQ(rr::reserve_frame_path("/nonexistent-dir-for-se3", c2, &err), "");
  EXPECT_FALSE(err.empty());
}

// package:// through rospack (ROS_PACKAGE_PATH), as the node resolves meshes.
TEST(RosRenderer, RosResolverUsesRospack) {
  const std::string meshes = se3_sim_test::source_dir() + "/data/meshes";
  setenv("ROS_PACKAGE_PATH", meshes.c_str(), 1);
  const ResourceResolver resolve = rr::ros_resolver();
  std::string err;
  const std::string p = resolve(
      "package://example-robot-data/robots/panda_description/meshes/visual/link1.dae", &err);
  ASSERT_FALSE(p.empty()) << err;
  EXPECT_TRUE(fs::exists(p));
  EXPECT_EQ(resolve("package://no_such_package_here/x.stl", &err), "");
  EXPECT_NE(err.find("no_such_package_here"), std::string::npos) << err;
  EXPECT_EQ(resolve("package://example-robot-data/none.stl", &err), "");
  EXPECT_NE(err.find("not found"), std::string::npos) << err;
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
