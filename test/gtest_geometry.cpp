// The geometry layer: meshes through assimp (Collada's unit, up axis, node transforms and
// material colours; STL; OBJ with its .mtl), URDF materials, resource resolution (package://,
// file://, relative, missing package, missing file) with stand-ins and their warnings,
// malformed mesh files, leading-'/' link names, primitives, the cache.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "se3_sim/geometry/geometry.h"
#include "source_paths.h"

using namespace se3;
namespace fs = std::filesystem;

namespace {

std::string source(const std::string& rel) {
  return se3_sim_test::source_dir() + "/" + rel;
}

// A fresh folder under the test's temporary directory.
fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::path(::testing::TempDir()) / ("se3_geometry_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

void write(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << text;
}

// A Collada file: one triangle (0,0,0) (10,0,0) (0,20,0) in a node translated by (0,0,30),
// with the given unit, up axis and diffuse colour.
std::string collada(const std::string& unit_meter, const std::string& up, const char* rgb) {
  return std::string(R"(<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="u" meter=")") +
         unit_meter + R"("/><up_axis>)" + up + R"(</up_axis></asset>
  <library_effects><effect id="fx"><profile_COMMON><technique sid="common"><phong>
    <diffuse><color sid="diffuse">)" +
         rgb + R"( 1</color></diffuse>
  </phong></technique></profile_COMMON></effect></library_effects>
  <library_materials><material id="paint" name="paint"><instance_effect url="#fx"/></material>
  </library_materials>
  <library_geometries><geometry id="tri" name="tri"><mesh>
    <source id="pos"><float_array id="pos-a" count="9">0 0 0 10 0 0 0 20 0</float_array>
      <technique_common><accessor source="#pos-a" count="3" stride="3">
        <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
      </accessor></technique_common></source>
    <vertices id="v"><input semantic="POSITION" source="#pos"/></vertices>
    <triangles material="m" count="1"><input semantic="VERTEX" source="#v" offset="0"/>
      <p>0 1 2</p></triangles>
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="scene"><node id="n" name="n">
    <translate>0 0 30</translate>
    <instance_geometry url="#tri"><bind_material><technique_common>
      <instance_material symbol="m" target="#paint"/></technique_common></bind_material>
    </instance_geometry></node></visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#scene"/></scene>
</COLLADA>
)";
}

// Binary STL of the given triangles (normals left zero; the loader makes its own).
std::string binary_stl(const std::vector<std::array<float, 9>>& tris, uint32_t claimed) {
  std::string s(80, ' ');
  s.append(reinterpret_cast<const char*>(&claimed), 4);
  for (const auto& t : tris) {
    const float n[3] = {0, 0, 0};
    s.append(reinterpret_cast<const char*>(n), 12);
    s.append(reinterpret_cast<const char*>(t.data()), 36);
    s.append(2, '\0');
  }
  return s;
}

// The 12 triangles of the unit cube [0, 1]^3, counter-clockwise from outside.
std::vector<std::array<float, 9>> cube() {
  const TriangleMesh m = tessellate(make_box(Vec3::Ones()));
  std::vector<std::array<float, 9>> out;
  for (std::size_t t = 0; t < m.triangle_count(); ++t) {
    std::array<float, 9> a;
    for (int k = 0; k < 3; ++k)
      for (int c = 0; c < 3; ++c) a[3 * k + c] = m.positions[m.indices[3 * t + k]][c] + 0.5f;
    out.push_back(a);
  }
  return out;
}

const char* kOneLinkUrdf = R"(<robot name="one">
  <material name="robot_blue"><color rgba="0.1 0.2 0.9 1"/></material>
  <link name="base">
    <visual><geometry><box size="0.2 0.2 0.2"/></geometry>
      <material name="inline_red"><color rgba="0.9 0.1 0.1 1"/></material></visual>
    <visual><origin xyz="0 0 0.5"/><geometry><sphere radius="0.1"/></geometry>
      <material name="robot_blue"/></visual>
    <visual><origin xyz="0.5 0 0"/><geometry><mesh filename="MESH" scale="2 2 2"/></geometry>
    </visual>
    <collision><geometry><cylinder radius="0.05" length="0.3"/></geometry></collision>
  </link>
</robot>)";

std::string one_link(const std::string& mesh) {
  std::string s = kOneLinkUrdf;
  s.replace(s.find("MESH"), 4, mesh);
  return s;
}

}  // namespace

// ---------------------------------------------------------------- Collada

// RViz's rule: node transforms and <unit> applied, the <up_axis> rotation not. A Y_UP file in
// centimetres: the triangle scaled by 0.01 with its node's translation, and not turned.
TEST(GeometryCollada, UnitAndNodeTransformAppliedUpAxisNot) {
  const fs::path d = temp_dir("collada");
  for (const char* up : {"Y_UP", "Z_UP", "X_UP"}) {
    const fs::path f = d / (std::string("tri_") + up + ".dae");
    write(f, collada("0.01", up, "0.1 0.8 0.2"));
    std::string err;
    const auto m = load_mesh(f.string(), &err);
    ASSERT_TRUE(m) << err;
    ASSERT_EQ(m->triangle_count(), 1u);
    std::vector<Vec3f> p = m->positions;
    std::sort(p.begin(), p.end(), [](const Vec3f& a, const Vec3f& b) {
      return std::make_tuple(a.x(), a.y()) < std::make_tuple(b.x(), b.y());
    });
    EXPECT_TRUE(p[0].isApprox(Vec3f(0, 0, 0.3f), 1e-6f)) << up << ": " << p[0].transpose();
    EXPECT_TRUE(p[1].isApprox(Vec3f(0, 0.2f, 0.3f), 1e-6f)) << up << ": " << p[1].transpose();
    EXPECT_TRUE(p[2].isApprox(Vec3f(0.1f, 0, 0.3f), 1e-6f)) << up << ": " << p[2].transpose();
  }
  // In metres: the numbers as written.
  write(d / "m.dae", collada("1", "Z_UP", "1 1 1"));
  const auto m = load_mesh((d / "m.dae").string());
  ASSERT_TRUE(m);
  EXPECT_NEAR(m->upper.y(), 20.0f, 1e-5f);
  EXPECT_NEAR(m->lower.z(), 30.0f, 1e-5f);
}

// A Collada material colour comes out as that colour (and STL, which has none, as none).
TEST(GeometryCollada, MaterialColour) {
  const fs::path d = temp_dir("colour");
  write(d / "green.dae", collada("1", "Z_UP", "0.1 0.8 0.2"));
  const auto m = load_mesh((d / "green.dae").string());
  ASSERT_TRUE(m);
  ASSERT_EQ(m->submeshes.size(), 1u);
  const Material& mat = m->submeshes[0].material;
  EXPECT_TRUE(mat.has_color);
  EXPECT_EQ(mat.name, "paint");
  EXPECT_TRUE(mat.rgba.isApprox(Vec4f(0.1f, 0.8f, 0.2f, 1.0f), 1e-5f)) << mat.rgba.transpose();

  write(d / "cube.stl", binary_stl(cube(), 12));
  const auto s = load_mesh((d / "cube.stl").string());
  ASSERT_TRUE(s);
  EXPECT_FALSE(s->submeshes[0].material.has_color);
}

namespace {

// Orthographic silhouette (1 mm cells) along axis a of world triangles over the box [lo, hi].
std::vector<char> silhouette(const std::vector<Vec3>& P, int a, const Vec3& lo, const Vec3& hi,
                             int& nu, int& nv) {
  const double h = 1e-3;
  const int u = (a + 1) % 3, v = (a + 2) % 3;
  nu = int((hi[u] - lo[u]) / h) + 1;
  nv = int((hi[v] - lo[v]) / h) + 1;
  std::vector<char> img(std::size_t(nu) * nv, 0);
  for (std::size_t t = 0; t + 2 < P.size(); t += 3) {
    double x[3], y[3];
    for (int k = 0; k < 3; ++k) {
      x[k] = (P[t + k][u] - lo[u]) / h;
      y[k] = (P[t + k][v] - lo[v]) / h;
    }
    const int i0 = std::max(0, int(std::floor(std::min({x[0], x[1], x[2]}))));
    const int i1 = std::min(nu - 1, int(std::ceil(std::max({x[0], x[1], x[2]}))));
    const int j0 = std::max(0, int(std::floor(std::min({y[0], y[1], y[2]}))));
    const int j1 = std::min(nv - 1, int(std::ceil(std::max({y[0], y[1], y[2]}))));
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        const double px = i + 0.5, py = j + 0.5;
        const double w0 = (x[1] - px) * (y[2] - py) - (x[2] - px) * (y[1] - py);
        const double w1 = (x[2] - px) * (y[0] - py) - (x[0] - px) * (y[2] - py);
        const double w2 = (x[0] - px) * (y[1] - py) - (x[1] - px) * (y[0] - py);
        if ((w0 >= 0 && w1 >= 0 && w2 >= 0) || (w0 <= 0 && w1 <= 0 && w2 <= 0))
          img[std::size_t(j) * nu + i] = 1;
      }
  }
  return img;
}

std::vector<Vec3> placed_triangles(const GeometryObject& o) {
  std::vector<Vec3> P;
  for (uint32_t i : o.shape.mesh->indices) {
    P.push_back(
        o.placement.act(o.shape.mesh->positions[i].cast<double>().cwiseProduct(o.shape.scale)));
  }
  return P;
}

}  // namespace

// The Panda's visual Collada files (12 nodes with transforms in link0, materials) against its
// collision STL hulls of the same links: seen along each axis, the visual lies inside the hull
// (at least 99 % of its silhouette) and covers most of it. A wrong unit, a dropped node
// transform or an applied up-axis turn would move the visual out of its hull.
TEST(GeometryCollada, PandaVisualsLieInTheirCollisionHulls) {
  const std::string urdf = source("data/robots/panda.urdf");
  const Model m = model_from_urdf_file(urdf);
  GeometryOptions go;
  go.paths.package_path = {source("data/meshes")};
  go.paths.use_ros_package_path = false;
  const GeometryModel g = geometry_from_urdf_file(m, urdf, go);
  ASSERT_TRUE(g.warnings.empty()) << g.warnings[0];
  int pairs = 0;
  for (const GeometryObject& v : g.visuals) {
    for (const GeometryObject& c : g.collisions) {
      if (c.link != v.link || !v.shape.mesh || !c.shape.mesh) continue;
      ++pairs;
      const std::vector<Vec3> A = placed_triangles(v), B = placed_triangles(c);
      Vec3 lo = Vec3::Constant(1e9), hi = Vec3::Constant(-1e9);
      for (const auto* S : {&A, &B})
        for (const Vec3& p : *S) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
      lo.array() -= 0.005;
      hi.array() += 0.005;
      for (int a = 0; a < 3; ++a) {
        int nu, nv;
        const auto sa = silhouette(A, a, lo, hi, nu, nv), sb = silhouette(B, a, lo, hi, nu, nv);
        std::size_t in = 0, un = 0, va = 0;
        for (std::size_t i = 0; i < sa.size(); ++i) {
          in += sa[i] && sb[i];
          un += sa[i] || sb[i];
          va += sa[i];
        }
        EXPECT_GT(double(in) / va, 0.99) << v.link << " axis " << a;
        EXPECT_GT(double(in) / un, 0.6) << v.link << " axis " << a;
      }
    }
  }
  EXPECT_EQ(pairs, 9);
}

// ---------------------------------------------------------------- STL, OBJ, shapes

TEST(GeometryMesh, BinaryAndAsciiStlClosedAndSmooth) {
  const std::string bin = binary_stl(cube(), 12);
  std::string err;
  const auto b = decode_mesh(bin.data(), bin.size(), "stl", {}, &err);
  ASSERT_TRUE(b) << err;
  EXPECT_EQ(b->triangle_count(), 12u);
  EXPECT_TRUE(b->closed);
  EXPECT_TRUE(b->outward);
  for (const Vec3f& n : b->normals) EXPECT_NEAR(n.norm(), 1.0f, 1e-5f);
  // A cube's corners are 90-degree creases: each face keeps its own normal.
  for (std::size_t t = 0; t < b->triangle_count(); ++t) {
    const Vec3f& n = b->normals[b->indices[3 * t]];
    EXPECT_NEAR(n.cwiseAbs().maxCoeff(), 1.0f, 1e-5f);
  }
  std::string ascii = "solid c\n";
  for (const auto& t : cube()) {
    ascii += " facet normal 0 0 0\n  outer loop\n";
    for (int k = 0; k < 3; ++k) {
      ascii += "   vertex " + std::to_string(t[3 * k]) + " " + std::to_string(t[3 * k + 1]) + " " +
               std::to_string(t[3 * k + 2]) + "\n";
    }
    ascii += "  endloop\n endfacet\n";
  }
  ascii += "endsolid c\n";
  const auto a = decode_mesh(ascii.data(), ascii.size(), "stl", {}, &err);
  ASSERT_TRUE(a) << err;
  EXPECT_EQ(a->triangle_count(), 12u);
  EXPECT_TRUE(a->closed);
  EXPECT_TRUE((a->upper - Vec3f::Ones()).norm() < 1e-5f);
}

TEST(GeometryMesh, ObjWithItsMtlColour) {
  const fs::path d = temp_dir("obj");
  write(d / "c.mtl", "newmtl orange\nKd 1.0 0.5 0.0\n");
  write(d / "c.obj",
        "mtllib c.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nusemtl orange\n"
        "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
  std::string err;
  const auto m = load_mesh((d / "c.obj").string(), &err);
  ASSERT_TRUE(m) << err;
  EXPECT_EQ(m->triangle_count(), 4u);
  EXPECT_TRUE(m->closed);
  bool orange = false;
  for (const auto& s : m->submeshes) {
    orange = orange || (s.material.has_color &&
                        s.material.rgba.head<3>().isApprox(Vec3f(1.0f, 0.5f, 0.0f), 1e-5f));
  }
  EXPECT_TRUE(orange);
}

TEST(GeometryMesh, PrimitivesAreClosedOutwardAndTheRightSize) {
  auto volume = [](const TriangleMesh& m) {
    double v = 0;
    for (std::size_t t = 0; t < m.triangle_count(); ++t) {
      const Vec3 a = m.positions[m.indices[3 * t]].cast<double>();
      const Vec3 b = m.positions[m.indices[3 * t + 1]].cast<double>();
      const Vec3 c = m.positions[m.indices[3 * t + 2]].cast<double>();
      v += a.dot(b.cross(c)) / 6;
    }
    return v;
  };
  const TriangleMesh box = tessellate(make_box(Vec3(0.2, 0.3, 0.4)));
  EXPECT_TRUE(box.closed && box.outward);
  EXPECT_NEAR(volume(box), 0.024, 1e-7);
  const TriangleMesh sph = tessellate(make_sphere(0.5), 64);
  EXPECT_TRUE(sph.closed && sph.outward);
  EXPECT_NEAR(volume(sph), 4.0 / 3 * M_PI * 0.125, 0.02 * 0.52);
  const TriangleMesh cyl = tessellate(make_cylinder(0.1, 1.0), 64);
  EXPECT_TRUE(cyl.closed && cyl.outward);
  EXPECT_NEAR(volume(cyl), M_PI * 0.01, 0.01 * M_PI * 0.01);
  const TriangleMesh cap = tessellate(make_capsule(0.1, 1.0), 64);
  EXPECT_TRUE(cap.closed && cap.outward);
  EXPECT_NEAR(volume(cap), M_PI * 0.01 + 4.0 / 3 * M_PI * 0.001, 0.02 * 0.036);
  EXPECT_NEAR(cap.upper.z(), 0.6f, 1e-6f);
  const TriangleMesh cone = cone_mesh();
  EXPECT_TRUE(cone.closed && cone.outward);
  // A mirrored mesh keeps its faces outward.
  Shape mirrored;
  mirrored.type = ShapeType::Mesh;
  mirrored.mesh = std::make_shared<TriangleMesh>(box);
  mirrored.scale = Vec3(-1, 1, 1);
  const TriangleMesh mb = tessellate(mirrored);
  EXPECT_TRUE(mb.closed && mb.outward);
  EXPECT_NEAR(volume(mb), 0.024, 1e-7);
}

// An open surface is not closed; a cube with one face missing neither.
TEST(GeometryMesh, OpenSurfacesAreNotClosed) {
  std::vector<std::array<float, 9>> tris = cube();
  tris.pop_back();
  tris.pop_back();
  const std::string bin = binary_stl(tris, uint32_t(tris.size()));
  const auto m = decode_mesh(bin.data(), bin.size(), "stl");
  ASSERT_TRUE(m);
  EXPECT_FALSE(m->closed);
  EXPECT_FALSE(m->submeshes[0].closed);
}

TEST(GeometryMesh, CacheByPath) {
  const fs::path d = temp_dir("cache");
  write(d / "a.stl", binary_stl(cube(), 12));
  const auto a = load_mesh((d / "a.stl").string());
  const auto b = load_mesh((d / "sub" / ".." / "a.stl").string());
  ASSERT_TRUE(a);
  EXPECT_EQ(a.get(), b.get());
}

// ---------------------------------------------------------------- malformed files

TEST(GeometryMesh, MalformedFilesGiveAReason) {
  struct Case {
    std::string name, bytes, hint, reason;
  };
  std::string truncated = binary_stl(cube(), 12);
  truncated.resize(truncated.size() - 30);
  const std::string absurd = binary_stl(cube(), 0xffffffffu);
  const std::string no_geometry = R"(<?xml version="1.0"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit meter="1"/></asset>
  <library_visual_scenes><visual_scene id="s"><node id="n"/></visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>)";
  const std::vector<Case> cases = {
      {"truncated STL", truncated, "stl", "truncated"},
      {"absurd STL count", absurd, "stl", "claims 4294967295 triangles"},
      {"short STL", "abc", "stl", "truncated"},
      {"Collada without geometry", no_geometry, "dae", ""},
      {"garbage Collada", "<COLLADA><<<", "dae", ""},
      {"garbage OBJ", "v 1 2\nf 9 9 9\n", "obj", ""},
      {"empty", "", "stl", "empty"},
  };
  for (const Case& c : cases) {
    std::string err;
    const auto m = decode_mesh(c.bytes.data(), c.bytes.size(), c.hint, {}, &err);
    EXPECT_FALSE(m) << c.name;
    EXPECT_FALSE(err.empty()) << c.name;
    if (!c.reason.empty()) {
      EXPECT_NE(err.find(c.reason), std::string::npos) << c.name << ": " << err;
    }
  }
  MeshLimits small;
  small.max_triangles = 10;
  const std::string bin = binary_stl(cube(), 12);
  std::string err;
  EXPECT_FALSE(decode_mesh(bin.data(), bin.size(), "stl", small, &err));
  EXPECT_NE(err.find("limit"), std::string::npos) << err;
}

// assimp 5.2 dereferences null on a Collada <float_array count="0"> with numbers in it (found
// by fuzz/fuzz_mesh.cpp): loading it runs in a child process, so the crash is a reason.
TEST(GeometryMesh, AnImporterCrashIsAReasonNotTheEnd) {
  const fs::path d = temp_dir("importer_crash");
  std::string text = collada("1", "Z_UP", "1 1 1");
  text.replace(text.find("count=\"9\""), 9, "count=\"0\"");
  write(d / "crash.dae", text);
  std::string err;
  EXPECT_FALSE(load_mesh((d / "crash.dae").string(), &err));
  EXPECT_NE(err.find("crashed"), std::string::npos) << err;
  const std::string xml = one_link("crash.dae");
  GeometryOptions go;
  go.paths.base_dir = d.string();
  const GeometryModel g = geometry_from_urdf_string(model_from_urdf_string(xml), xml, go);
  ASSERT_EQ(g.warnings.size(), 1u);
  EXPECT_NE(g.warnings[0].find("crash.dae"), std::string::npos) << g.warnings[0];
  EXPECT_TRUE(g.visuals[2].stand_in);
}

// In a URDF: a warning naming the link, the resource and the reason, a stand-in, no crash.
TEST(GeometryMesh, MalformedMeshInAUrdfGivesAWarningAndAStandIn) {
  const fs::path d = temp_dir("malformed_urdf");
  std::string truncated = binary_stl(cube(), 12);
  truncated.resize(200);
  write(d / "broken.stl", truncated);
  const std::string xml = one_link("broken.stl");
  const Model m = model_from_urdf_string(xml);
  GeometryOptions go;
  go.paths.base_dir = d.string();
  const GeometryModel g = geometry_from_urdf_string(m, xml, go);
  ASSERT_EQ(g.warnings.size(), 1u);
  EXPECT_NE(g.warnings[0].find("link 'base'"), std::string::npos) << g.warnings[0];
  EXPECT_NE(g.warnings[0].find("broken.stl"), std::string::npos) << g.warnings[0];
  EXPECT_NE(g.warnings[0].find("truncated"), std::string::npos) << g.warnings[0];
  int stand_ins = 0;
  for (const GeometryObject& o : g.visuals) {
    if (!o.stand_in) continue;
    ++stand_ins;
    EXPECT_EQ(o.shape.type, ShapeType::Cylinder);  // the link's collision shape
  }
  EXPECT_EQ(stand_ins, 1);
  EXPECT_EQ(g.visuals.size(), 3u);
}

// ---------------------------------------------------------------- resources

TEST(GeometryResource, PackageFileAndRelativeNames) {
  const fs::path root = temp_dir("resource");
  write(root / "ws" / "deep" / "my_pkg" / "package.xml",
        "<?xml version=\"1.0\"?>\n<package format=\"2\">\n  <name> my_pkg </name>\n</package>\n");
  write(root / "ws" / "deep" / "my_pkg" / "meshes" / "c.stl", binary_stl(cube(), 12));
  write(root / "ws" / "ignored" / "CATKIN_IGNORE", "");
  write(root / "ws" / "ignored" / "other" / "package.xml", "<package><name>other</name></package>");
  write(root / "urdf" / "rel.stl", binary_stl(cube(), 12));
  ResourcePaths paths;
  paths.package_path = {(root / "ws").string()};
  paths.use_ros_package_path = false;
  paths.base_dir = (root / "urdf").string();
  std::string err;
  const std::string pkg = resolve_resource("package://my_pkg/meshes/c.stl", paths, &err);
  EXPECT_EQ(fs::canonical(pkg), fs::canonical(root / "ws" / "deep" / "my_pkg" / "meshes" / "c.stl"))
      << err;
  EXPECT_EQ(find_package("other", paths), "");  // below a CATKIN_IGNORE
  const std::string file =
      resolve_resource("file://" + (root / "urdf" / "rel.stl").string(), paths);
  EXPECT_EQ(file, (root / "urdf" / "rel.stl").string());
  EXPECT_EQ(fs::canonical(resolve_resource("rel.stl", paths)),
            fs::canonical(root / "urdf" / "rel.stl"));
  EXPECT_EQ(resolve_resource("package://nopkg/x.stl", paths, &err), "");
  EXPECT_NE(err.find("package 'nopkg' not found"), std::string::npos) << err;
  EXPECT_EQ(resolve_resource("package://my_pkg/meshes/none.stl", paths, &err), "");
  EXPECT_NE(err.find("not found"), std::string::npos) << err;
  EXPECT_EQ(resolve_resource("http://example.org/x.stl", paths, &err), "");
  EXPECT_NE(err.find("scheme"), std::string::npos) << err;
  EXPECT_EQ(split_path_list("a::b:"), (std::vector<std::string>{"a", "b"}));

  // Through a URDF: each name loads, or gives its warning and a stand-in.
  struct Case {
    std::string name, reason;
    bool loads;
  };
  const std::vector<Case> cases = {
      {"package://my_pkg/meshes/c.stl", "", true},
      {"file://" + (root / "urdf" / "rel.stl").string(), "", true},
      {"rel.stl", "", true},
      {"package://nopkg/meshes/c.stl", "package 'nopkg' not found", false},
      {"package://my_pkg/meshes/missing.stl", "missing.stl' not found", false},
      {"missing.stl", "missing.stl' not found", false},
  };
  GeometryOptions go;
  go.paths = paths;
  for (const Case& c : cases) {
    const std::string xml = one_link(c.name);
    const Model m = model_from_urdf_string(xml);
    const GeometryModel g = geometry_from_urdf_string(m, xml, go);
    const GeometryObject& mesh_visual = g.visuals[2];
    if (c.loads) {
      EXPECT_TRUE(g.warnings.empty()) << c.name << ": " << g.warnings[0];
      ASSERT_TRUE(mesh_visual.shape.mesh) << c.name;
      EXPECT_FALSE(mesh_visual.stand_in);
      EXPECT_EQ(mesh_visual.shape.resource, c.name);
      EXPECT_EQ(mesh_visual.shape.scale, Vec3(2, 2, 2));
      EXPECT_TRUE(mesh_visual.placement.p.isApprox(Vec3(0.5, 0, 0)));
    } else {
      ASSERT_EQ(g.warnings.size(), 1u) << c.name;
      EXPECT_NE(g.warnings[0].find("link 'base'"), std::string::npos) << g.warnings[0];
      EXPECT_NE(g.warnings[0].find(c.name), std::string::npos) << g.warnings[0];
      EXPECT_NE(g.warnings[0].find(c.reason), std::string::npos) << g.warnings[0];
      EXPECT_TRUE(mesh_visual.stand_in) << c.name;
    }
  }

  // An injected resolver is used instead.
  int calls = 0;
  go.resolver = [&](const std::string& uri, std::string* e) {
    ++calls;
    return resolve_resource(uri, paths, e);
  };
  const std::string xml = one_link("package://my_pkg/meshes/c.stl");
  const GeometryModel g = geometry_from_urdf_string(model_from_urdf_string(xml), xml, go);
  EXPECT_EQ(calls, 1);
  EXPECT_TRUE(g.warnings.empty());
}

// ---------------------------------------------------------------- URDF geometry

TEST(GeometryUrdf, MaterialsPlacementsAndCollisions) {
  const std::string xml = one_link("none.stl");
  const Model m = model_from_urdf_string(xml);
  GeometryOptions go;
  go.load_meshes = false;
  const GeometryModel g = geometry_from_urdf_string(m, xml, go);
  EXPECT_TRUE(g.warnings.empty());  // not loading meshes is asked for, not a failure
  ASSERT_GE(g.visuals.size(), 2u);
  EXPECT_EQ(g.visuals[0].shape.type, ShapeType::Box);
  EXPECT_TRUE(g.visuals[0].material.has_color);
  EXPECT_TRUE(g.visuals[0].material.rgba.isApprox(Vec4f(0.9f, 0.1f, 0.1f, 1.0f)));
  EXPECT_EQ(g.visuals[1].shape.type, ShapeType::Sphere);
  EXPECT_TRUE(g.visuals[1].material.rgba.isApprox(Vec4f(0.1f, 0.2f, 0.9f, 1.0f)))
      << "named material declared at robot level";
  EXPECT_TRUE(g.visuals[1].placement.p.isApprox(Vec3(0, 0, 0.5)));
  ASSERT_EQ(g.collisions.size(), 1u);
  EXPECT_EQ(g.collisions[0].shape.type, ShapeType::Cylinder);
  EXPECT_EQ(g.collisions[0].shape.radius, 0.05);
  EXPECT_EQ(g.collisions[0].shape.length, 0.3);
  EXPECT_EQ(g.collisions[0].body, 0);
}

// A link named "/link1" (ROS 1 before tf2) is the frame "link1" everywhere.
TEST(GeometryUrdf, LeadingSlashLinkNamesAreStripped) {
  const std::string xml = R"(<robot name="slash">
  <link name="/base"><visual><geometry><box size="0.1 0.1 0.1"/></geometry></visual></link>
  <link name="/link1">
    <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><sphere radius="0.05"/></geometry></visual>
  </link>
  <joint name="j" type="revolute"><parent link="/base"/><child link="/link1"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>)";
  const Model m = model_from_urdf_string(xml);
  EXPECT_EQ(m.root_link, "base");
  ASSERT_EQ(m.body_name.size(), 2u);
  EXPECT_EQ(m.body_name[1], "link1");
  EXPECT_EQ(m.link_index("link1"), m.link_index("/link1"));
  EXPECT_GE(m.link_index("link1"), 0);
  const GeometryModel g = geometry_from_urdf_string(m, xml);
  ASSERT_EQ(g.visuals.size(), 2u);
  EXPECT_EQ(g.visuals[1].link, "link1");
  EXPECT_EQ(g.visuals[1].body, 1);
  EXPECT_EQ(frame_name("/a/b"), "a/b");
  // "/a" and "a" would be one frame: refused.
  const std::string clash = R"(<robot name="c"><link name="a"/><link name="/a"/>
  <joint name="j" type="fixed"><parent link="a"/><child link="/a"/></joint></robot>)";
  EXPECT_THROW(model_from_urdf_string(clash), ModelError);
}

TEST(GeometryUrdf, ChainGeometry) {
  const Model m = make_chain(3, false, {1.0}, 0.4);
  const GeometryModel g = chain_geometry(m);
  ASSERT_EQ(g.visuals.size(), 4u);
  for (int i = 0; i <= 3; ++i) {
    EXPECT_EQ(g.visuals[i].body, i);
    EXPECT_TRUE(g.visuals[i].shape.box.isApprox(Vec3(0.4, 0.04, 0.04)));
    EXPECT_TRUE(g.visuals[i].placement.p.isApprox(Vec3(0.2, 0, 0)));
  }
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
