// The scene's `objects:`, `srdf:`, `self_collision:` and `contact:` keys
// (src/sim/scene_objects.cpp).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <string>

#include "se3_sim/collision/collision.h"
#include "se3_sim/dynamics/dynamics.h"
#include "se3_sim/render/render.h"
#include "se3_sim/sim/scene_collision.h"
#include "se3_sim/sim/sim.h"
#include "source_paths.h"

using namespace se3;

namespace {

const std::string kRoot = se3_sim_test::source_dir();
const std::string kData = kRoot + "/data";

// The SceneError message of parsing text (with base_dir data/), or "" when it parses.
std::string error_of(const std::string& text) {
  try {
    parse_scene(text, kData, "s.yaml");
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(SceneObjects, BlockListOfEveryShape) {
  const std::string text =
      "# objects only, no robot\n"
      "objects:\n"
      "  - name: crate\n"
      "    shape: {box: [0.2, 0.4, 0.6]}\n"
      "    mass: 2.0\n"
      "    pose: {position: [1, 2, 3], orientation: [0, 0, 0.7071067811865476, "
      "0.7071067811865476]}\n"
      "    twist: [0, 0, 1, 0.5, 0, 0]\n"
      "    mu: 0.4\n"
      "    restitution: 0.5\n"
      "    color: [1, 0, 0]\n"
      "  - name: ball\n"
      "    shape: {sphere: 0.1}\n"
      "    mass: 1\n"
      "  - name: can\n"
      "    shape: {cylinder: [0.05, 0.2]}\n"
      "    mass: 0.5\n"
      "    inertia: [0.01, 0.02, 0.03]\n"
      "  - name: pill\n"
      "    shape: {capsule: [0.05, 0.1]}\n"
      "    mass: 0.3\n"
      "    inertia: [[0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.005]]\n"
      "  - name: table\n"
      "    shape: {box: [1, 1, 0.05]}\n"
      "    color: [0.5, 0.4, 0.3, 0.8]\n"
      "  - name: foot\n"
      "    shape: {mesh: meshes/example-robot-data/robots/solo_description/meshes/stl/with_foot/"
      "solo_foot.stl, scale: [2, 2, 2]}\n"
      "    mass: 0.1\n"
      "self_collision: true\n"
      "contact: {margin: 0.02, max_contacts_per_pair: 8, ground_per_body: false}\n"
      "srdf: meshes/example-robot-data/robots/panda_description/srdf/panda.srdf\n";
  const Scene s = parse_scene(text, kData, "s.yaml");
  EXPECT_TRUE(s.robot.empty());
  ASSERT_EQ(s.objects.size(), 6u);
  const SceneObject& crate = s.objects[0];
  EXPECT_EQ(crate.name, "crate");
  EXPECT_EQ(crate.shape.type, ShapeType::Box);
  EXPECT_TRUE(crate.shape.box.isApprox(Vec3(0.2, 0.4, 0.6)));
  EXPECT_FALSE(crate.is_static);
  EXPECT_DOUBLE_EQ(crate.mass, 2.0);
  EXPECT_DOUBLE_EQ(crate.inertia.m, 2.0);
  EXPECT_TRUE(crate.inertia.h.isZero());
  // Uniform box about its centre: m/12 (b^2 + c^2), ...
  EXPECT_NEAR(crate.inertia.I(0, 0), 2.0 / 12 * (0.16 + 0.36), 1e-12);
  EXPECT_NEAR(crate.inertia.I(1, 1), 2.0 / 12 * (0.04 + 0.36), 1e-12);
  EXPECT_NEAR(crate.inertia.I(2, 2), 2.0 / 12 * (0.04 + 0.16), 1e-12);
  EXPECT_TRUE(crate.pose.p.isApprox(Vec3(1, 2, 3)));
  EXPECT_TRUE((crate.pose.R * Vec3::UnitX()).isApprox(Vec3::UnitY(), 1e-9));
  EXPECT_DOUBLE_EQ(crate.twist[2], 1);
  EXPECT_DOUBLE_EQ(crate.twist[3], 0.5);
  EXPECT_DOUBLE_EQ(crate.mu, 0.4);
  EXPECT_DOUBLE_EQ(crate.restitution, 0.5);
  EXPECT_TRUE(crate.material.has_color);
  EXPECT_FLOAT_EQ(crate.material.rgba[0], 1.0f);
  EXPECT_EQ(crate.line, 3);

  EXPECT_EQ(s.objects[1].shape.type, ShapeType::Sphere);
  EXPECT_NEAR(s.objects[1].inertia.I(1, 1), 0.4 * 0.01, 1e-12);
  EXPECT_DOUBLE_EQ(s.objects[1].mu, 0.8);  // default
  EXPECT_EQ(s.objects[2].shape.type, ShapeType::Cylinder);
  EXPECT_NEAR(s.objects[2].inertia.I(2, 2), 0.03, 1e-12);
  EXPECT_EQ(s.objects[3].shape.type, ShapeType::Capsule);
  EXPECT_NEAR(s.objects[3].inertia.I(2, 2), 0.005, 1e-12);
  EXPECT_TRUE(s.objects[4].is_static);
  EXPECT_FLOAT_EQ(s.objects[4].material.rgba[3], 0.8f);
  const SceneObject& foot = s.objects[5];
  ASSERT_EQ(foot.shape.type, ShapeType::Mesh);
  ASSERT_TRUE(foot.shape.mesh);
  EXPECT_GT(foot.shape.mesh->triangle_count(), 10u);
  EXPECT_TRUE(foot.shape.scale.isApprox(Vec3(2, 2, 2)));
  // Its hull's inertia (scale 2: volume x 8), about the hull's centroid.
  const ConvexHull h = convex_hull(*foot.shape.mesh, Vec3(2, 2, 2));
  EXPECT_TRUE(foot.inertia.com().isApprox(h.centroid, 1e-12));
  EXPECT_NEAR(foot.inertia.I(0, 0),
              (h.inertia(0, 0) * 0.1 / h.volume) +
                  0.1 * (h.centroid.y() * h.centroid.y() + h.centroid.z() * h.centroid.z()),
              1e-15);

  EXPECT_TRUE(s.self_collision);
  EXPECT_DOUBLE_EQ(s.contact_margin, 0.02);
  EXPECT_EQ(s.max_contacts_per_pair, 8);
  EXPECT_FALSE(s.ground_per_body);
  EXPECT_TRUE(parse_scene("name: x\n", kData, "d.yaml").ground_per_body);  // the default
  EXPECT_NE(s.srdf.find("panda.srdf"), std::string::npos);
  EXPECT_EQ(s.srdf[0], '/');  // resolved against the scene's folder
}

TEST(SceneObjects, DefaultsWithoutTheKeys) {
  const Scene s = parse_scene("robot: chain:2\n", kData, "s.yaml");
  EXPECT_TRUE(s.objects.empty());
  EXPECT_FALSE(s.self_collision);
  EXPECT_TRUE(s.srdf.empty());
  EXPECT_DOUBLE_EQ(s.contact_margin, 0.01);
  // A flow list parses as well, and an empty objects key is no objects.
  EXPECT_EQ(parse_scene("objects: [{name: a, shape: {sphere: 1}}]\n", kData, "s").objects.size(),
            1u);
  EXPECT_TRUE(parse_scene("objects:\n", kData, "s").objects.empty());
}

TEST(SceneObjects, UniformDensityInertiaOfCylinderAndCapsule) {
  // Cylinder axis z: Izz = m r^2 / 2, Ixx = m (3 r^2 + l^2) / 12.
  const Mat3 Ic = uniform_density_inertia(make_cylinder(0.1, 0.4), 3.0);
  EXPECT_NEAR(Ic(2, 2), 3.0 * 0.01 / 2, 1e-12);
  EXPECT_NEAR(Ic(0, 0), 3.0 * (0.03 + 0.16) / 12, 1e-12);
  // A capsule of zero length is a sphere; a very long thin one is a rod (m l^2 / 12).
  const Mat3 Is = uniform_density_inertia(make_capsule(0.1, 1e-12), 2.0);
  EXPECT_NEAR(Is(0, 0), 0.4 * 2.0 * 0.01, 1e-12);
  EXPECT_NEAR(Is(2, 2), 0.4 * 2.0 * 0.01, 1e-12);
  const Mat3 Ir = uniform_density_inertia(make_capsule(1e-4, 1.0), 1.0);
  EXPECT_NEAR(Ir(0, 0), 1.0 / 12, 1e-4);
  // Capsule by numeric integration of the solid (points of a grid inside it).
  const double r = 0.1, l = 0.3;
  const int n = 120;
  double ixx = 0, izz = 0, count = 0;
  const double zmax = l / 2 + r;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      for (int k = 0; k < 2 * n; ++k) {
        const double x = -r + (i + 0.5) * 2 * r / n, y = -r + (j + 0.5) * 2 * r / n;
        const double z = -zmax + (k + 0.5) * 2 * zmax / (2 * n);
        const double dz = std::max(0.0, std::abs(z) - l / 2);
        if (x * x + y * y + dz * dz > r * r) continue;
        ixx += y * y + z * z;
        izz += x * x + y * y;
        ++count;
      }
    }
  }
  const Mat3 Ik = uniform_density_inertia(make_capsule(r, l), 1.0);
  EXPECT_NEAR(Ik(0, 0), ixx / count, 2e-3 * Ik(0, 0));
  EXPECT_NEAR(Ik(2, 2), izz / count, 2e-3 * Ik(2, 2));
}

TEST(SceneObjects, BadInputIsOneLineNamingLineAndKey) {
  struct Case {
    const char* text;
    const char* expect;  // part of the message
  };
  const Case cases[] = {
      {"objects:\n  - name: a\n    shape: {cone: 1}\n",
       "s.yaml:3: unknown key 'cone' in objects[0].shape"},
      {"objects:\n  - name: a\n    shape: {}\n", "s.yaml:3: 'objects[0].shape' needs one of box"},
      {"objects:\n  - name: a\n    shape: {box: [1, 0, 1]}\n",
       "s.yaml:3: 'objects[0].shape.box' needs three positive"},
      {"objects:\n  - name: a\n    shape: {box: [1, -1, 1]}\n", "positive extents"},
      {"objects:\n  - name: a\n    shape: {sphere: -1}\n",
       "s.yaml:3: 'objects[0].shape.sphere' needs a positive radius"},
      {"objects:\n  - name: a\n    shape: {sphere: 0}\n", "positive radius"},
      {"objects:\n  - name: a\n    shape: {cylinder: [0.1, 0]}\n", "positive length"},
      {"objects:\n  - name: a\n    shape: {capsule: [-0.1, 1]}\n", "positive radius"},
      {"objects:\n  - name: a\n    shape: {sphere: 1, box: [1, 1, 1]}\n", "has two shapes"},
      {"objects:\n  - name: a\n    shape: {sphere: 1, scale: [1, 1, 1]}\n", "for meshes only"},
      {"objects:\n  - name: a\n    shape: {sphere: 1}\n    mass: -2\n",
       "s.yaml:4: 'objects[0].mass' must be positive"},
      {"objects:\n  - name: a\n    shape: {sphere: 1}\n    mass: 0\n",
       "'objects[0].mass' must be positive"},
      {"objects:\n  - name: a\n    shape: {mesh: nothere.stl}\n",
       "s.yaml:3: 'objects[0].shape.mesh'"},
      {"objects:\n  - name: a\n    shape: {sphere: 1}\n  - name: a\n    shape: {sphere: 2}\n",
       "s.yaml:4: 'objects[1]': duplicate object name 'a'"},
      {"objects:\n  - name: a\n    shape: {sphere: 1}\n    pose: {orientation: [0, 0, 0, 2]}\n",
       "s.yaml:4: 'objects[0].pose.orientation' (x, y, z, w) is not a unit quaternion"},
      {"objects:\n  - shape: {sphere: 1}\n", "s.yaml:2: 'objects[0]' needs a name"},
      {"objects:\n  - name: a\n", "s.yaml:2: 'objects[0]' (a) needs a shape"},
      {"objects:\n  - name: a b\n    shape: {sphere: 1}\n", "not a TF frame name"},
      {"objects:\n  - name: a\n    shape: {sphere: 1}\n    colour: [1, 0, 0]\n",
       "s.yaml:4: unknown key 'colour'"},
      {"objects:\n  - name: a\n    shape: {sphere: 1}\n    color: [2, 0, 0]\n", "values in [0, 1]"},
      {"objects:\n  - name: a\n    shape: {sphere: 1}\n    restitution: 1.5\n",
       "objects[0].restitution"},
      {"objects:\n  - name: a\n    shape: {sphere: 1}\n    mu: -1\n", "objects[0].mu"},
      {"objects:\n  - name: a\n    shape: {sphere: 1}\n    inertia: [1, 1, 1]\n", "needs a mass"},
      {"objects:\n  - name: a\n    shape: {sphere: 1}\n    twist: [0, 0, 1, 0, 0, 0]\n",
       "needs a mass"},
      {"objects:\n  - name: a\n    shape: {sphere: 1}\n    mass: 1\n    inertia: [1, 1, 3]\n",
       "s.yaml:5: 'objects[0].inertia' is not a physical inertia"},
      {"objects:\n  - name: a\n    shape: {sphere: 1}\n    mass: 1\n    inertia: [[1, 0.5, 0], [0, "
       "1, 0], [0, 0, 1]]\n",
       "is not symmetric"},
      {"objects: {name: a}\n", "s.yaml:1: 'objects' needs a list"},
      {"srdf: nothere.srdf\n", "s.yaml:1: 'srdf' file"},
      {"self_collision: maybe\n", "s.yaml:1:"},
      {"contact: {margin: -1}\n", "s.yaml:1: 'contact.margin'"},
      {"contact: {gap: 1}\n", "unknown key 'gap'"},
  };
  for (const Case& c : cases) {
    const std::string e = error_of(c.text);
    EXPECT_NE(e.find(c.expect), std::string::npos) << c.text << "\n  gave: '" << e << "'";
    EXPECT_EQ(e.find('\n'), std::string::npos) << e;
  }
}

TEST(SceneCollision, FramesOfRobotAndObjects) {
  const Scene s = parse_scene(
      "robot: chain:2\nbase: fixed\nground: {mu: 0.5}\nobjects:\n"
      "  - {name: table, shape: {box: [1, 1, 0.1]}}\n"
      "  - {name: a, shape: {sphere: 0.1}, mass: 1, mu: 0.3}\n"
      "  - {name: b, shape: {box: [0.1, 0.1, 0.1]}, mass: 1}\n",
      kData, "s.yaml");
  const Model m = scene_model(s);
  const SceneCollision sc = scene_collision(s, &m);
  EXPECT_EQ(sc.robot_bodies, 3);  // chain:2 fixed: bodies 0, 1, 2
  EXPECT_EQ(sc.free_objects, 2);
  ASSERT_EQ(sc.object_frame.size(), 3u);
  EXPECT_EQ(sc.object_frame[0], CollisionObject::kWorld);
  EXPECT_EQ(sc.object_frame[1], 3);
  EXPECT_EQ(sc.object_frame[2], 4);
  ASSERT_GE(sc.ground, 0);
  const auto& objs = sc.model.objects();
  EXPECT_TRUE(objs[sc.ground].halfspace);
  EXPECT_DOUBLE_EQ(objs[sc.ground].mu, 0.5);
  std::size_t robot = 0;
  for (std::size_t i = 0; i < objs.size(); ++i) {
    if (sc.body[i] >= 0) {
      ++robot;
      EXPECT_EQ(objs[i].group, 0);
      EXPECT_EQ(objs[i].frame, sc.body[i]);
    }
    if (sc.scene_object[i] == 1) {
      EXPECT_DOUBLE_EQ(objs[i].mu, 0.3);
    }
  }
  EXPECT_EQ(robot, scene_geometry(s, m).collisions.size());
  // Objects only: frames start at 0.
  const Scene o = parse_scene(
      "objects:\n  - {name: a, shape: {sphere: 0.1}, mass: 1}\n"
      "  - {name: b, shape: {sphere: 0.1}, pose: {position: [0, 1, 0]}}\n  - {name: c, shape: "
      "{sphere: 0.1}, mass: 2}\n",
      kData, "o.yaml");
  const SceneCollision oc = scene_collision(o, nullptr);
  EXPECT_EQ(oc.robot_bodies, 0);
  EXPECT_EQ(oc.object_frame, (std::vector<int>{0, CollisionObject::kWorld, 1}));
  std::vector<SE3> frames;
  scene_frame_poses(
      {}, {SE3(Mat3::Identity(), Vec3(0, 0, 0)), SE3(Mat3::Identity(), Vec3(0.15, 0, 0))}, frames);
  CollisionData d;
  collide(const_cast<CollisionModel&>(oc.model), d, frames);
  ASSERT_EQ(d.contacts.size(), 1u);  // a and c, 0.15 apart: overlapping by 5 cm
  EXPECT_NEAR(d.contacts[0].depth, 0.05, 1e-9);
}

// Solo-12's collision shapes are all meshes: on the ground they must touch it (the humanoid of
// issue 14 fell 18 m because meshes were skipped). Each shape a pair of its own here
// (ground_per_body: false), so that the meshes' contacts are not pooled with the scene's contact
// spheres on the same links (lower still); pooled, each body keeps its deepest point.
TEST(SceneCollision, MeshOnlyRobotTouchesTheGround) {
  Scene s = load_scene(kRoot + "/config/scenes/quadruped_ground.yaml");
  s.ground_per_body = false;
  const Model m = scene_model(s);
  SceneCollision sc = scene_collision(s, &m);
  EXPECT_TRUE(sc.warnings.empty()) << sc.warnings[0];
  const auto& objs = sc.model.objects();
  int meshes = 0;
  for (std::size_t i = 0; i < objs.size(); ++i) {
    if (sc.body[i] >= 0 && objs[i].shape.type == ShapeType::Mesh) {
      ++meshes;
      ASSERT_NE(sc.model.hull(int(i)), nullptr);
    }
  }
  EXPECT_EQ(meshes, 17);
  // At the scene's initial joint angles, lower the base until the lowest hull vertex is 1 mm
  // below the ground.
  State x = scene_state(s, m);
  Data data(m);
  x.base.p.z() = 0;
  forward_kinematics(m, data, x.base, x.q);
  double lowest = INFINITY;
  for (std::size_t i = 0; i < objs.size(); ++i) {
    if (sc.body[i] < 0 || objs[i].shape.type != ShapeType::Mesh) continue;
    const SE3 T = data.oMb[sc.body[i]] * objs[i].placement;
    for (const Vec3& v : sc.model.hull(int(i))->vertices) {
      if ((T.R * v + T.p).z() < lowest) {
        lowest = (T.R * v + T.p).z();
      }
    }
  }
  x.base.p.z() = -lowest - 0.001;
  forward_kinematics(m, data, x.base, x.q);
  std::vector<SE3> frames;
  scene_frame_poses(data.oMb, {}, frames);
  CollisionData d;
  collide(sc.model, d, frames);
  double deepest = -INFINITY;
  std::set<int> touching;                // bodies whose meshes touch the ground
  for (const Contact& c : d.contacts) {  // (the scene's contacts: spheres are lower still)
    if (c.a != sc.ground || objs[c.b].shape.type != ShapeType::Mesh) continue;
    deepest = std::max(deepest, c.depth);
    if (c.depth > 0) touching.insert(sc.body[c.b]);
  }
  EXPECT_NEAR(deepest, 0.001, 1e-9);
  EXPECT_EQ(touching.size(), 4u);  // the four feet, equally low at the scene's joint angles
  // Pooled by body (the default): at most 4 contacts a body, each body's deepest contact that of
  // its deepest shape above (the spheres' where they are lower), the same four feet touching.
  {
    Scene pooled_scene = s;
    pooled_scene.ground_per_body = true;
    SceneCollision pc = scene_collision(pooled_scene, &m);
    ASSERT_EQ(pc.model.objects().size(), objs.size());
    CollisionData pd;
    collide(pc.model, pd, frames);
    std::vector<double> apart(m.n + 1, -INFINITY), pooled(m.n + 1, -INFINITY);
    std::vector<int> count(m.n + 1, 0);
    std::set<int> touching_pooled;
    for (const Contact& c : d.contacts) {
      if (c.a == sc.ground) apart[sc.body[c.b]] = std::max(apart[sc.body[c.b]], c.depth);
    }
    for (const Contact& c : pd.contacts) {
      if (c.a != pc.ground) continue;
      const int b = pc.body[c.b];
      pooled[b] = std::max(pooled[b], c.depth);
      ++count[b];
      if (c.depth > 0) touching_pooled.insert(b);
    }
    for (int b = 0; b <= m.n; ++b) {
      EXPECT_LE(count[b], 4) << b;
      EXPECT_EQ(pooled[b], apart[b]) << b;
    }
    EXPECT_LT(pd.contacts.size(), d.contacts.size());
    EXPECT_EQ(touching_pooled, touching);  // the four feet
  }
  // 5 cm up, beyond the margin: no ground contact.
  x.base.p.z() += 0.05;
  forward_kinematics(m, data, x.base, x.q);
  scene_frame_poses(data.oMb, {}, frames);
  collide(sc.model, d, frames);
  for (const Contact& c : d.contacts) EXPECT_NE(c.a, sc.ground);
}

TEST(SceneCollision, PandaSrdfAndSelfCollision) {
  const std::string srdf = "meshes/example-robot-data/robots/panda_description/srdf/panda.srdf";
  auto contacts_at_home = [&](const std::string& extra, int* self) {
    const Scene s = parse_scene("robot: robots/panda.urdf\nbase: fixed\nground: true\n" + extra,
                                kData, "panda.yaml");
    const Model m = scene_model(s);
    SceneCollision sc = scene_collision(s, &m);
    State x = scene_state(s, m);
    Data data(m);
    forward_kinematics(m, data, x.base, x.q);
    std::vector<SE3> frames;
    scene_frame_poses(data.oMb, {}, frames);
    CollisionData d;
    collide(sc.model, d, frames);
    *self = 0;
    for (const Contact& c : d.contacts) {
      EXPECT_NE(c.a, sc.ground) << "the fixed base touches the ground";
      if (sc.body[c.a] >= 0 && sc.body[c.b] >= 0 && c.depth > 0) ++*self;  // penetrating
    }
    return d.contacts.size();
  };
  int off = 0, on = 0, srdf_on = 0;
  contacts_at_home("", &off);
  contacts_at_home("self_collision: true\n", &on);
  contacts_at_home("self_collision: true\nsrdf: " + srdf + "\n", &srdf_on);
  EXPECT_EQ(off, 0);
  EXPECT_GT(on, 0);       // hulls of non-adjacent links overlap at q = 0 (hand and link 6, ...)
  EXPECT_EQ(srdf_on, 0);  // the SRDF disables exactly those
}

TEST(SceneCollision, SrdfNamingUnknownLinksIsOneLine) {
  const std::string path = testing::TempDir() + "/bad.srdf";
  {
    std::ofstream out(path);
    out << "<robot name='panda'>\n<disable_collisions link1='panda_link0' link2='no_such_link'/>\n"
           "</robot>\n";
  }
  const Scene s = parse_scene("robot: chain:2\nsrdf: " + path + "\n", kData, "s.yaml");
  const Model m = scene_model(s);
  try {
    scene_collision(s, &m);
    FAIL();
  } catch (const SceneError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("s.yaml"), std::string::npos) << w;
    EXPECT_NE(w.find("bad.srdf"), std::string::npos) << w;
    EXPECT_NE(w.find("'panda_link0'"), std::string::npos) << w;  // the first unknown
    EXPECT_EQ(w.find('\n'), std::string::npos) << w;
  }
  std::remove(path.c_str());
}

// The renderer draws the scene's objects (world-fixed geometry at their poses).
TEST(SceneObjectsPresentation, RendererDrawsObjects) {
  const Scene s = parse_scene(
      "objects:\n  - {name: crate, shape: {box: [0.4, 0.4, 0.4]}, color: [1, 0, 0],"
      " pose: {position: [1, 0, 0.5]}}\n"
      "  - {name: ball, shape: {sphere: 0.2}, mass: 1, pose: {position: [-1, 0, 0.5]}}\n",
      kData, "s.yaml");
  const Model m = make_chain(1, false, {1.0}, 0.3);
  GeometryModel g;
  g.visuals = scene_object_geometry(s.objects,
                                    {s.objects[0].pose, SE3(Mat3::Identity(), Vec3(-1, 0, 0.8))});
  ASSERT_EQ(g.visuals.size(), 2u);
  EXPECT_EQ(g.visuals[0].body, GeometryObject::kWorld);
  EXPECT_EQ(g.visuals[0].name, "crate");
  const auto items = render::make_draw_items(m, g);
  ASSERT_EQ(items.size(), 2u);
  render::Camera c;
  c.eye = Vec3(0, -4, 0.5);
  c.target = Vec3(0, 0, 0.5);
  c.update();
  render::Renderer r(c);
  r.style().grid = false;
  r.style().overlay = false;
  r.set_items(items);
  Data d(m);
  forward_kinematics(m, d, SE3(), VecX::Zero(m.nq));
  r.render(d.oMb);
  for (const Vec3& p : {Vec3(1, 0, 0.5), Vec3(-1, 0, 0.8)}) {  // the centres: drawn
    render::Vec2 px;
    ASSERT_TRUE(c.project(p, px));
    EXPECT_NE(r.framebuffer().pixel(int(px.x()), int(px.y())),
              r.background(int(px.x()), int(px.y())))
        << p.transpose();
  }
  render::Vec2 px;
  ASSERT_TRUE(c.project(Vec3(-1, 0, 0.45), px));  // where the ball starts, not where it is
  EXPECT_EQ(r.framebuffer().pixel(int(px.x()), int(px.y())),
            r.background(int(px.x()), int(px.y())));
}

TEST(SceneObjectsPresentation, SimulateJsonReportsObjectsAndPenetration) {
  const std::string path = testing::TempDir() + "/drop.yaml";
  {
    std::ofstream out(path);
    out << "ground: true\ndt: 0.001\nobjects:\n"
           "  - {name: ball, shape: {sphere: 0.1}, mass: 1, pose: {position: [0, 0, 0.3]},"
           " twist: [0, 0, 0, 0.5, 0, 0]}\n"
           "  - {name: post, shape: {box: [0.1, 0.1, 1]}, pose: {position: [5, 0, 0.5]}}\n";
  }
  SimulateOptions o;
  o.scene = path;
  o.duration = 0.1;
  const SimulateResult r = simulate_headless(o);
  ASSERT_EQ(r.objects.size(), 2u);
  EXPECT_EQ(r.objects[0].name, "ball");
  // In flight for 0.1 s: x = 0.05 (body-frame v = world v, no rotation), z = 0.3 - g t^2 / 2.
  EXPECT_NEAR(r.objects[0].pose.p.x(), 0.05, 1e-3);
  EXPECT_NEAR(r.objects[0].pose.p.z(), 0.3 - 9.81 * 0.01 / 2, 2e-3);
  EXPECT_TRUE(r.objects[1].pose.p.isApprox(Vec3(5, 0, 0.5)));
  EXPECT_TRUE(std::isfinite(r.penetration_max));
  EXPECT_GE(r.penetration_max, 0);
  const std::string j = simulate_result_json(r);
  EXPECT_NE(j.find("\"penetration_max\": "), std::string::npos) << j;
  EXPECT_NE(j.find("\"objects\": {\"ball\": {\"position\": ["), std::string::npos) << j;
  EXPECT_NE(j.find("\"orientation\": [0, 0, 0, 1]"), std::string::npos) << j;
  EXPECT_NE(j.find("\"twist\": ["), std::string::npos) << j;
  EXPECT_NE(j.find("\"post\": {"), std::string::npos) << j;
  std::remove(path.c_str());
  // No contact at all: null.
  SimulateOptions c;
  c.model = "chain:2";
  c.duration = 0.01;
  const std::string jc = simulate_result_json(simulate_headless(c));
  EXPECT_NE(jc.find("\"penetration_max\": null"), std::string::npos) << jc;
  EXPECT_EQ(jc.find("\"objects\""), std::string::npos) << jc;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}

// make_simulator builds a scene's collision model (shapes, hulls) once: the scene collision, not
// first the objects' own model that the scene collision replaced (issue 36). The steps are those
// of the former order (objects, then the scene collision over them) bit for bit.
// New constraints in a scene with the scene collision (the simulator node's new initial state):
// one collision model, not the objects' own and then the scene's; the same steps as that order.
TEST(SceneCollision, NewConstraintsBuildItOnce) {
  for (const char* name : {"panda_push.yaml", "ball_on_table.yaml"}) {
    SCOPED_TRACE(name);
    const Scene s = load_scene(kRoot + "/config/scenes/" + name);
    auto once = make_simulator(s);
    auto twice = make_simulator(s);
    const GeometryModel none;
    const GeometryModel* geometry = s.robot_path.empty() ? &none : nullptr;
    const ConstraintSpec spec = scene_constraints(s, once->model());

    const std::uint64_t before = CollisionModel::constructed();
    once->set_constraints(spec, scene_collision(s, &once->model(), geometry));
    EXPECT_EQ(CollisionModel::constructed() - before, 1u);
    const std::uint64_t before2 = CollisionModel::constructed();
    twice->set_constraints(spec);
    twice->set_scene_collision(scene_collision(s, &twice->model(), geometry));
    EXPECT_EQ(CollisionModel::constructed() - before2, 2u);

    std::size_t touches = 0;
    for (int k = 0; k < 500; ++k) {
      ASSERT_TRUE(once->step()) << once->failure();
      ASSERT_TRUE(twice->step()) << twice->failure();
      touches += once->contacts().size();
    }
    EXPECT_EQ(once->state().q, twice->state().q);
    EXPECT_EQ(once->state().v, twice->state().v);
    for (size_t j = 0; j < s.objects.size(); ++j) {
      EXPECT_EQ(once->objects()[j].pose.p, twice->objects()[j].pose.p) << j;
    }
    EXPECT_GT(touches, 0u);
  }
}

TEST(SceneCollision, BuiltOnceWithTheFormerSteps) {
  for (const char* name : {"box_stack.yaml", "ball_on_table.yaml", "panda_push.yaml"}) {
    SCOPED_TRACE(name);
    const Scene s = load_scene(kRoot + "/config/scenes/" + name);
    const std::uint64_t before = CollisionModel::constructed();
    auto once = make_simulator(s);
    EXPECT_EQ(CollisionModel::constructed() - before, 1u);

    // The former order over another one: the objects with their own model, then the scene
    // collision in its place.
    auto twice = make_simulator(s);
    const std::uint64_t before2 = CollisionModel::constructed();
    twice->set_objects(s.objects);
    const GeometryModel none;
    twice->set_scene_collision(
        scene_collision(s, &twice->model(), s.robot_path.empty() ? &none : nullptr));
    EXPECT_EQ(CollisionModel::constructed() - before2, 2u);

    std::size_t touches = 0;         // contacts over the run: the collision model is in use
    for (int k = 0; k < 500; ++k) {  // 0.5 s: the ball lands on its table
      ASSERT_TRUE(once->step()) << once->failure();
      ASSERT_TRUE(twice->step()) << twice->failure();
      touches += once->contacts().size();
    }
    EXPECT_EQ(once->state().q, twice->state().q);
    EXPECT_EQ(once->state().v, twice->state().v);
    EXPECT_EQ(once->contacts().size(), twice->contacts().size());
    ASSERT_EQ(once->objects().size(), s.objects.size());
    for (size_t j = 0; j < s.objects.size(); ++j) {
      EXPECT_EQ(once->objects()[j].pose.p, twice->objects()[j].pose.p) << j;
      EXPECT_EQ(once->objects()[j].twist, twice->objects()[j].twist) << j;
    }
    EXPECT_GT(touches, 0u);
  }
}
