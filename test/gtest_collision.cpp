// The collision layer (collision.h): closed-form contacts between primitives, the ground and
// mesh hulls, the pair filter, margin contacts, SRDF pairs and bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

#include "se3_sim/collision/collision.h"
#include "source_paths.h"

using namespace se3;

namespace {

const std::string kRoot = se3_sim_test::source_dir();

CollisionObject object(const std::string& name, const Shape& s, int frame, int group = 1,
                       const SE3& placement = SE3()) {
  CollisionObject o;
  o.name = name;
  o.shape = s;
  o.frame = frame;
  o.group = group;
  o.placement = placement;
  return o;
}

CollisionObject ground(double height = 0) {
  CollisionObject o;
  o.name = "ground";
  o.halfspace = true;
  o.placement.p = Vec3(0, 0, height);
  return o;
}

SE3 at(double x, double y, double z, const Mat3& R = Mat3::Identity()) {
  return SE3(R, Vec3(x, y, z));
}

Mat3 rot(const Vec3& axis, double angle) {
  return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
}

CollisionOptions no_margin() {
  CollisionOptions o;
  o.margin = 0;
  return o;
}

std::string read_file(const std::string& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

TEST(Collision, SphereSphere) {
  CollisionModel m({object("a", make_sphere(0.5), 0), object("b", make_sphere(0.3), 1)},
                   no_margin());
  CollisionData d;
  collide(m, d, {at(0, 0, 0), at(0.7, 0, 0)});
  ASSERT_EQ(d.contacts.size(), 1u);
  const Contact& c = d.contacts[0];
  EXPECT_EQ(c.a, 0);
  EXPECT_EQ(c.b, 1);
  EXPECT_NEAR(c.depth, 0.1, 1e-9);
  EXPECT_TRUE(c.normal.isApprox(Vec3::UnitX(), 1e-9)) << c.normal.transpose();
  // Surfaces at x = 0.5 (a) and 0.4 (b): midway 0.45.
  EXPECT_TRUE(c.point.isApprox(Vec3(0.45, 0, 0), 1e-9)) << c.point.transpose();
  // Apart: nothing; b on the other side: the normal turns.
  collide(m, d, {at(0, 0, 0), at(0, 0.81, 0)});
  EXPECT_TRUE(d.contacts.empty());
  collide(m, d, {at(0, 0, 0), at(0, -0.75, 0)});
  ASSERT_EQ(d.contacts.size(), 1u);
  EXPECT_TRUE(d.contacts[0].normal.isApprox(-Vec3::UnitY(), 1e-9));
  EXPECT_NEAR(d.contacts[0].depth, 0.05, 1e-9);
}

TEST(Collision, SphereHalfspace) {
  CollisionModel m({ground(), object("ball", make_sphere(0.1), 0)}, no_margin());
  CollisionData d;
  collide(m, d, {at(0.3, -0.2, 0.08)});
  ASSERT_EQ(d.contacts.size(), 1u);
  const Contact& c = d.contacts[0];
  EXPECT_EQ(c.a, 0);  // the ground
  EXPECT_EQ(c.b, 1);
  EXPECT_NEAR(c.depth, 0.02, 1e-12);
  EXPECT_TRUE(c.normal.isApprox(Vec3::UnitZ(), 1e-12));
  EXPECT_TRUE(c.point.isApprox(Vec3(0.3, -0.2, -0.01), 1e-12)) << c.point.transpose();
  // A tilted, raised ground: normal (0, sin, cos), through (0, 0, 1).
  CollisionObject g = ground();
  g.placement = SE3(rot(Vec3::UnitX(), -0.3), Vec3(0, 0, 1));
  CollisionModel tilted({g, object("ball", make_sphere(0.1), 0)}, no_margin());
  const Vec3 n = g.placement.R.col(2);
  collide(tilted, d, {at(0, 0, 1.05)});
  ASSERT_EQ(d.contacts.size(), 1u);
  EXPECT_NEAR(d.contacts[0].depth, 0.1 - 0.05 * n.z(), 1e-12);
  EXPECT_TRUE(d.contacts[0].normal.isApprox(n, 1e-12));
}

TEST(Collision, BoxHalfspaceGivesItsFourLowCorners) {
  const Mat3 R = rot(Vec3::UnitZ(), 0.5);
  CollisionModel m({ground(), object("box", make_box(Vec3(0.2, 0.4, 0.1)), 0)}, no_margin());
  CollisionData d;
  collide(m, d, {at(1, 2, 0.04, R)});
  ASSERT_EQ(d.contacts.size(), 4u);
  for (const Contact& c : d.contacts) {
    EXPECT_NEAR(c.depth, 0.01, 1e-12);
    EXPECT_NEAR(c.point.z(), -0.005, 1e-12);
    const Vec3 local = R.transpose() * (c.point - Vec3(1, 2, c.point.z()));
    EXPECT_NEAR(std::abs(local.x()), 0.1, 1e-12);
    EXPECT_NEAR(std::abs(local.y()), 0.2, 1e-12);
  }
  // The four are distinct corners.
  for (int i = 0; i < 4; ++i) {
    for (int j = i + 1; j < 4; ++j) {
      EXPECT_GT((d.contacts[i].point - d.contacts[j].point).norm(), 0.1);
    }
  }
  // On an edge (tilted 45 degrees about x): the two corners of the lowest edge.
  const Mat3 Rx = rot(Vec3::UnitX(), M_PI / 4);
  const double low = (0.4 / 2 + 0.1 / 2) / std::sqrt(2.0);  // centre height over the edge
  collide(m, d, {at(0, 0, low - 0.002, Rx)});
  ASSERT_EQ(d.contacts.size(), 2u);
  for (const Contact& c : d.contacts) EXPECT_NEAR(c.depth, 0.002, 1e-12);
  // Deepest first: tilted about y as well, the corners differ.
  collide(m, d, {at(0, 0, 0.04, rot(Vec3::UnitY(), 0.05))});
  ASSERT_GE(d.contacts.size(), 2u);
  for (std::size_t i = 1; i < d.contacts.size(); ++i) {
    EXPECT_GE(d.contacts[i - 1].depth, d.contacts[i].depth);
  }
}

TEST(Collision, CylinderHalfspace) {
  const double r = 0.05, l = 0.2;
  CollisionModel m({ground(), object("can", make_cylinder(r, l), 0)}, no_margin());
  CollisionData d;
  // Upright: four points of the bottom rim, 3 mm deep.
  collide(m, d, {at(0, 0, l / 2 - 0.003)});
  ASSERT_EQ(d.contacts.size(), 4u);
  for (const Contact& c : d.contacts) {
    EXPECT_NEAR(c.depth, 0.003, 1e-12);
    EXPECT_NEAR(std::hypot(c.point.x(), c.point.y()), r, 1e-12);
  }
  // On its side: the two ends of the lowest line.
  collide(m, d, {at(0, 0, r - 0.001, rot(Vec3::UnitX(), M_PI / 2))});
  ASSERT_EQ(d.contacts.size(), 2u);
  for (const Contact& c : d.contacts) {
    EXPECT_NEAR(c.depth, 0.001, 1e-12);
    EXPECT_NEAR(std::abs(c.point.y()), l / 2, 1e-12);
  }
  // Tilted by t: the lowest rim point is at z - (l/2) cos t - r sin t.
  const double t = 0.3, z = 0.1;
  collide(m, d, {at(0, 0, z, rot(Vec3::UnitY(), t))});
  ASSERT_GE(d.contacts.size(), 1u);
  EXPECT_NEAR(d.contacts[0].depth, l / 2 * std::cos(t) + r * std::sin(t) - z, 1e-12);
}

TEST(Collision, CapsuleBox) {
  // A capsule lying along x on the top face (z = 0.5) of a unit box, 5 mm into it.
  const double r = 0.05, l = 0.3;
  CollisionModel m({object("box", make_box(Vec3(1, 1, 1)), CollisionObject::kWorld),
                    object("pill", make_capsule(r, l), 0)},
                   no_margin());
  CollisionData d;
  collide(m, d, {at(0.1, 0, 0.5 + r - 0.005, rot(Vec3::UnitY(), M_PI / 2))});
  ASSERT_GE(d.contacts.size(), 1u);
  const Contact& c = d.contacts[0];
  EXPECT_EQ(c.a, 0);
  EXPECT_EQ(c.b, 1);
  EXPECT_NEAR(c.depth, 0.005, 1e-6);
  EXPECT_TRUE(c.normal.isApprox(Vec3::UnitZ(), 1e-6)) << c.normal.transpose();
  EXPECT_NEAR(c.point.z(), 0.5 - 0.0025, 1e-4) << c.point.transpose();
  // Upright on an edge of the box top: the lower cap's centre 2 mm above the face
  // (x = 0.45), 3 mm deep.
  collide(m, d, {at(0.45, 0, 0.5 + l / 2 + r - 0.003)});
  ASSERT_GE(d.contacts.size(), 1u);
  EXPECT_NEAR(d.contacts[0].depth, 0.003, 1e-6);
  EXPECT_TRUE(d.contacts[0].normal.isApprox(Vec3::UnitZ(), 1e-6));
}

TEST(Collision, MeshHullOnTheGroundToAMicrometre) {
  // Solo-12's foot mesh (as its URDF uses it), turned, with its lowest vertex 2.5 mm below z = 0.
  Shape foot;
  std::string err;
  const std::string path =
      kRoot +
      "/data/meshes/example-robot-data/robots/solo_description/meshes/stl/with_foot/"
      "solo_foot.stl";
  ASSERT_TRUE(load_mesh_shape(
      path, Vec3::Ones(), [](const std::string& u, std::string*) { return u; }, foot, &err))
      << err;
  const Mat3 R = rot(Vec3(1, 2, 3), 0.7);
  double lowest = INFINITY;
  for (const Vec3f& v : foot.mesh->positions) lowest = std::min(lowest, (R * v.cast<double>()).z());
  const double z = -lowest - 0.0025;
  CollisionModel m({ground(), object("foot", foot, 0)}, no_margin());
  ASSERT_NE(m.hull(1), nullptr);
  EXPECT_LE(m.hull(1)->vertices.size(), foot.mesh->positions.size());
  CollisionData d;
  collide(m, d, {at(0.2, 0.1, z, R)});
  ASSERT_GE(d.contacts.size(), 1u);
  EXPECT_NEAR(d.contacts[0].depth, 0.0025, 1e-6);
  EXPECT_TRUE(d.contacts[0].normal.isApprox(Vec3::UnitZ(), 1e-12));
  EXPECT_NEAR(d.contacts[0].point.z(), -0.00125, 1e-6);
  for (const Contact& c : d.contacts) EXPECT_GT(c.depth, 0);  // no margin: penetrating only
  // Raised 1 mm above the ground: nothing without a margin.
  collide(m, d, {at(0.2, 0.1, z + 0.0035, R)});
  EXPECT_TRUE(d.contacts.empty());
}

// A mesh cylinder (the hull of 48 rim vertices a cap) standing on the ground, 1 mm deep: the
// contacts are spread over its bottom rim by farthest-point sampling, the deepest first, then
// the one opposite it, then the two between: every pair at least r sqrt(2) apart across the
// normal (a sampler that took neighbouring rim vertices would give 2 r sin(pi / 48)).
TEST(Collision, MeshHullOnItsFaceGivesSpreadContacts) {
  const double r = 0.05, l = 0.1;
  Shape cyl;
  cyl.type = ShapeType::Mesh;
  cyl.mesh = std::make_shared<TriangleMesh>(tessellate(make_cylinder(r, l), 48));
  CollisionOptions opt = no_margin();
  opt.max_contacts_per_pair = 4;
  CollisionModel m({ground(), object("can", cyl, 0)}, opt);
  CollisionData d;
  // Tilted by 1e-4 rad so that one rim vertex is the deepest.
  collide(m, d, {at(0.3, -0.2, 0.5 * l - 0.001, rot(Vec3(1, 0.3, 0), 1e-4))});
  ASSERT_EQ(d.contacts.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_NEAR(d.contacts[i].depth, 0.001, 1e-5);
    if (i) {
      EXPECT_GE(d.contacts[i - 1].depth + 1e-15, d.contacts[i].depth) << "deepest first";
    }
    for (std::size_t j = 0; j < i; ++j) {
      const Vec3 dp = d.contacts[i].point - d.contacts[j].point;
      EXPECT_GE(std::hypot(dp.x(), dp.y()), 0.99 * std::sqrt(2.0) * r) << i << " " << j;
    }
  }
}

namespace {

// The contacts a hull on the ground z = 0 should give, by the plain rule (collision.md): every
// vertex below the margin a candidate, the deepest first (the first of equal ones), then each next
// the candidate farthest across the normal from those picked (the first of equal ones, if farther
// than 1e-12 in squared distance), at most max, sorted deepest first; each point midway between
// the vertex and the plane. The arithmetic is the layer's (gaps in the shape's frame), so the
// contacts must agree to the bit.
std::vector<Contact> reference_ground_contacts(const ConvexHull& h, const SE3& T, double margin,
                                               int max) {
  const Vec3 n = Vec3::UnitZ();
  const Vec3 nl = T.R.transpose() * n;
  const double d0 = n.dot(T.p);
  const int nv = int(h.vertices.size());
  std::vector<double> g(nv);
  for (int i = 0; i < nv; ++i) {
    const Vec3& v = h.vertices[i];
    g[i] = ((nl.x() * v.x() + nl.y() * v.y()) + nl.z() * v.z()) + d0;
  }
  std::vector<int> cand;
  for (int i = 0; i < nv; ++i) {
    if (g[i] < margin) cand.push_back(i);
  }
  std::vector<int> picked;
  if (cand.empty()) return {};
  int deepest = cand[0];
  for (int i : cand) {
    if (g[i] < g[deepest]) deepest = i;
  }
  picked.push_back(deepest);
  int axis = 0;
  nl.cwiseAbs().minCoeff(&axis);
  const Vec3 t1 = nl.cross(Vec3::Unit(axis)).normalized(), t2 = nl.cross(t1);
  std::vector<double> d(cand.size(), INFINITY);
  while (int(picked.size()) < max && cand.size() > 1) {
    const Vec3& last = h.vertices[picked.back()];
    const double lu = t1.dot(last), lv = t2.dot(last);
    int best = -1;
    double best_d = 1e-12;
    for (std::size_t k = 0; k < cand.size(); ++k) {
      const Vec3& v = h.vertices[cand[k]];
      const double du = t1.dot(v) - lu, dv = t2.dot(v) - lv;
      d[k] = std::min(d[k], du * du + dv * dv);
      if (d[k] > best_d) best_d = d[k], best = int(k);
    }
    if (best < 0) break;
    picked.push_back(cand[best]);
  }
  std::sort(picked.begin(), picked.end(), [&](int x, int y) { return g[x] < g[y]; });
  std::vector<Contact> out;
  for (int i : picked) {
    Contact c;
    c.depth = -g[i];
    c.normal = n;
    c.point = T.p + T.R * h.vertices[i] + c.depth / 2 * n;
    out.push_back(c);
  }
  return out;
}

}  // namespace

// Hulls on the ground at random turns and heights (the lowest vertex 3 mm deep to 12 mm up,
// 1 cm margin), 1 to 6 contacts a pair: the contacts are the plain rule's above, to the bit.
// Solo-12's foot and lower leg (hundreds of vertices, most of the foot's bottom within the
// margin), and a cylinder and a box, upright too, whose equal gaps and equal distances test that
// the first of equal candidates is picked.
TEST(Collision, HullOnTheGroundPicksThePlainRulesContacts) {
  const std::string dir =
      kRoot + "/data/meshes/example-robot-data/robots/solo_description/meshes/stl/with_foot/";
  std::vector<Shape> shapes;
  for (const char* f : {"solo_foot.stl", "solo_lower_leg_left_side.stl"}) {
    Shape s;
    std::string err;
    ASSERT_TRUE(load_mesh_shape(
        dir + f, Vec3::Ones(), [](const std::string& u, std::string*) { return u; }, s, &err))
        << err;
    shapes.push_back(s);
  }
  Shape cyl;
  cyl.type = ShapeType::Mesh;
  cyl.mesh = std::make_shared<TriangleMesh>(tessellate(make_cylinder(0.05, 0.1), 48));
  shapes.push_back(cyl);
  Shape box;
  box.type = ShapeType::Mesh;
  box.mesh = std::make_shared<TriangleMesh>(tessellate(make_box(Vec3(0.1, 0.06, 0.04))));
  shapes.push_back(box);
  std::srand(7);
  auto uniform = [](double a, double b) { return a + (b - a) * std::rand() / double(RAND_MAX); };
  int compared = 0, many = 0;
  for (std::size_t s = 0; s < shapes.size(); ++s) {
    for (int max = 1; max <= 6; ++max) {
      CollisionOptions opt;
      opt.margin = 0.01;
      opt.max_contacts_per_pair = max;
      CollisionModel m({ground(), object("hull", shapes[s], 0)}, opt);
      const ConvexHull& h = *m.hull(1);
      CollisionData data;
      for (int trial = 0; trial < 40; ++trial) {
        const Mat3 R =
            trial < 4 ? Mat3::Identity()
                      : rot(Vec3(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)), uniform(0, 3.1));
        double lowest = INFINITY;
        for (const Vec3& v : h.vertices) lowest = std::min(lowest, (R * v).z());
        const SE3 T = at(uniform(-1, 1), uniform(-1, 1), -lowest + uniform(-0.003, 0.012), R);
        collide(m, data, {T});
        const std::vector<Contact> want = reference_ground_contacts(h, T, opt.margin, max);
        ASSERT_EQ(data.contacts.size(), want.size()) << s << " " << max << " " << trial;
        for (std::size_t k = 0; k < want.size(); ++k) {
          EXPECT_EQ(data.contacts[k].depth, want[k].depth) << s << " " << max << " " << trial;
          EXPECT_EQ(data.contacts[k].point, want[k].point) << s << " " << max << " " << trial;
          EXPECT_EQ(data.contacts[k].a, 0);
          EXPECT_EQ(data.contacts[k].b, 1);
        }
        ++compared;
        many += want.size() >= 3;
      }
    }
  }
  EXPECT_EQ(compared, 4 * 6 * 40);
  EXPECT_GT(many, compared / 3);  // most placements sample three or more contacts
}

// One body's shapes against the ground pick their contacts together (CollisionOptions::
// ground_contacts_per_body, on by default): Solo-12's lower leg and its foot on one frame, as
// the URDF places them (the foot 0.16 m down the leg, on a fixed joint), at random turns and
// heights with the lowest vertex 3 mm deep to 8 mm up. The body gets at most
// max_contacts_per_pair contacts, among them the deepest vertex of either hull (naming the hull
// it belongs to), the rest by farthest-point sampling over the union of
// both hulls' candidates (checked against the plain rule over world points, to 1e-12), each
// point a vertex of the hull the contact names. Off, each hull is a pair of its own (up to
// twice as many contacts); a hull on another frame is never pooled with them.
TEST(Collision, ABodysShapesShareOneContactBudgetOnTheGround) {
  const std::string dir =
      kRoot + "/data/meshes/example-robot-data/robots/solo_description/meshes/stl/with_foot/";
  Shape leg, foot;
  std::string err;
  auto same = [](const std::string& u, std::string*) { return u; };
  ASSERT_TRUE(load_mesh_shape(dir + "solo_lower_leg_left_side.stl", Vec3::Ones(), same, leg, &err))
      << err;
  ASSERT_TRUE(load_mesh_shape(dir + "solo_foot.stl", Vec3::Ones(), same, foot, &err)) << err;
  const SE3 foot_on_leg = at(0, 0.008, -0.16);
  std::srand(11);
  auto uniform = [](double a, double b) { return a + (b - a) * std::rand() / double(RAND_MAX); };
  int pooled = 0, from_leg = 0, from_foot = 0;
  for (int max : {1, 2, 3, 4, 6}) {
    CollisionOptions opt;
    opt.margin = 0.01;
    opt.max_contacts_per_pair = max;
    const std::vector<CollisionObject> objs = {ground(), object("leg", leg, 0),
                                               object("foot", foot, 0, 1, foot_on_leg),
                                               object("other foot", foot, 1)};
    CollisionModel m(objs, opt);
    opt.ground_contacts_per_body = false;
    CollisionModel apart(objs, opt);
    CollisionData d, da;
    for (int trial = 0; trial < 60; ++trial) {
      // Foot down, turned up to 0.8 rad off the vertical at random, or at any turn.
      const Vec3 axis(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
      const Mat3 R = rot(axis, trial < 40 ? uniform(0, 0.8) : uniform(0, 3.1));
      // World points of both hulls (object 1 and 2) and their owners.
      std::vector<Vec3> pts;
      std::vector<int> owner;
      for (int o : {1, 2}) {
        const SE3 P = o == 1 ? SE3() : foot_on_leg;
        for (const Vec3& v : m.hull(o)->vertices) {
          pts.push_back(R * P.act(v));
          owner.push_back(o);
        }
      }
      double lowest = INFINITY;
      for (const Vec3& p : pts) lowest = std::min(lowest, p.z());
      const Vec3 at_xy(uniform(-1, 1), uniform(-1, 1), -lowest + uniform(-0.003, 0.008));
      const SE3 T(R, at_xy);
      const SE3 far = at(5, 5, 1);  // the other foot, in the air
      collide(m, d, {T, far});
      collide(apart, da, {T, far});
      // The plain rule over the union, in world points (the deepest first, then farthest).
      std::vector<int> cand;
      for (std::size_t i = 0; i < pts.size(); ++i) {
        if (pts[i].z() + at_xy.z() < opt.margin) cand.push_back(int(i));
      }
      if (cand.empty()) {
        EXPECT_TRUE(d.contacts.empty());
        continue;
      }
      int deepest = cand[0];
      for (int i : cand) {
        if (pts[i].z() < pts[deepest].z()) deepest = i;
      }
      std::vector<int> picked = {deepest};
      std::vector<double> dist(cand.size(), INFINITY);
      while (int(picked.size()) < max) {
        const Vec3& last = pts[picked.back()];
        int best = -1;
        double best_d = 1e-12;
        for (std::size_t k = 0; k < cand.size(); ++k) {
          const Vec3 dp = pts[cand[k]] - last;
          dist[k] = std::min(dist[k], dp.x() * dp.x() + dp.y() * dp.y());
          if (dist[k] > best_d) best_d = dist[k], best = int(k);
        }
        if (best < 0) break;
        picked.push_back(cand[best]);
      }
      ASSERT_EQ(d.contacts.size(), picked.size()) << max << " " << trial;
      ASSERT_LE(int(d.contacts.size()), max);
      // The deepest first, on the hull it belongs to (the layer's gaps are taken in each hull's
      // frame: the same to rounding).
      EXPECT_NEAR(d.contacts[0].depth, -(pts[deepest].z() + at_xy.z()), 1e-12)
          << max << " " << trial;
      EXPECT_EQ(d.contacts[0].b, owner[deepest]);
      for (const Contact& c : d.contacts) {
        EXPECT_EQ(c.a, 0);
        ASSERT_TRUE(c.b == 1 || c.b == 2);
        (c.b == 1 ? from_leg : from_foot) += 1;
        // Its point is a vertex of the hull it names, raised by half its depth.
        const Vec3 v = c.point - c.depth / 2 * Vec3::UnitZ();
        bool found = false, listed = false;
        for (std::size_t i = 0; i < pts.size(); ++i) {
          if (owner[i] != c.b || (pts[i] + at_xy - v).norm() > 1e-12) continue;
          found = true;
          listed = listed || std::find(picked.begin(), picked.end(), int(i)) != picked.end();
        }
        EXPECT_TRUE(found && listed) << max << " " << trial;
      }
      for (std::size_t k = 1; k < d.contacts.size(); ++k) {
        EXPECT_GE(d.contacts[k - 1].depth, d.contacts[k].depth) << "deepest first";
      }
      // Each hull on its own: up to max each; the pooled set never more than max.
      int leg_n = 0, foot_n = 0;
      for (const Contact& c : da.contacts) (c.b == 1 ? leg_n : foot_n) += 1;
      EXPECT_LE(leg_n, max);
      EXPECT_LE(foot_n, max);
      pooled += int(da.contacts.size()) > max;
    }
  }
  EXPECT_GT(pooled, 100);   // most placements: both hulls within the margin, more than max apart
  EXPECT_GT(from_leg, 50);  // both hulls give contacts to the pooled set
  EXPECT_GT(from_foot, 50);
}

// The narrow phase is skipped for pairs whose bounding boxes are farther apart than the margin
// (boxes_apart in collision.cpp): it must never skip a pair that is nearer. A box's hull (a
// mesh) turned at random against a capsule turned at random, placed near each other's faces,
// edges and corners: a margin contact is reported exactly when the true gap (the capsule's
// segment against the box, sampled finely, minus its radius) is below the margin.
TEST(Collision, BoxPrefilterNeverDropsAPairWithinTheMargin) {
  const Vec3 half(0.1, 0.06, 0.03);
  Shape box;
  box.type = ShapeType::Mesh;
  box.mesh = std::make_shared<TriangleMesh>(tessellate(make_box(2 * half)));
  const double r = 0.02, l = 0.15;
  CollisionOptions opt;
  opt.margin = 0.01;
  CollisionModel m({object("box", box, 0), object("capsule", make_capsule(r, l), 1)}, opt);
  auto box_distance = [&](const Vec3& p) {  // p in the box's frame
    return (p.cwiseAbs() - half).cwiseMax(0.0).norm();
  };
  std::srand(7);
  auto uni = [] { return 2.0 * std::rand() / RAND_MAX - 1.0; };
  int near = 0, far = 0;
  CollisionData d;
  for (int trial = 0; trial < 4000; ++trial) {
    const Mat3 Ra = rot(Vec3(uni(), uni(), uni()), 3 * uni());
    const Mat3 Rb = rot(Vec3(uni(), uni(), uni()), 3 * uni());
    const Vec3 pb = 0.16 * Vec3(uni(), uni(), uni());
    // The true gap in the box's frame.
    const Vec3 c = Ra.transpose() * pb, a = Ra.transpose() * Rb.col(2);
    double gap = INFINITY;
    for (int k = 0; k <= 2000; ++k)
      gap = std::min(gap, box_distance(c + (k / 2000.0 - 0.5) * l * a));
    gap -= r;
    if (!(gap > 5e-4) || gap > 0.02 || std::abs(gap - opt.margin) < 2e-4) continue;
    collide(m, d, {SE3(Ra, Vec3::Zero()), SE3(Rb, pb)});
    const bool expect = gap < opt.margin;
    (expect ? near : far) += 1;
    ASSERT_EQ(!d.contacts.empty(), expect) << "trial " << trial << ": gap " << gap;
    if (expect) {
      EXPECT_NEAR(-d.contacts[0].depth, gap, 1e-4) << "trial " << trial;
    }
  }
  EXPECT_GT(near, 100);
  EXPECT_GT(far, 100);
}

TEST(Collision, HullAgainstASphereMatchesTheMesh) {
  // A box mesh's hull against a sphere: the same contact as the box primitive.
  Shape boxmesh;
  boxmesh.type = ShapeType::Mesh;
  boxmesh.mesh = std::make_shared<TriangleMesh>(tessellate(make_box(Vec3(0.4, 0.4, 0.4))));
  CollisionModel m(
      {object("box", boxmesh, CollisionObject::kWorld), object("ball", make_sphere(0.1), 0)},
      no_margin());
  ASSERT_EQ(m.hull(0)->vertices.size(), 8u);
  EXPECT_NEAR(m.hull(0)->volume, 0.064, 1e-7);  // float vertices
  EXPECT_NEAR(m.hull(0)->inertia(0, 0), 0.064 * (0.16 + 0.16) / 12, 1e-9);
  EXPECT_NEAR(m.hull(0)->inertia(0, 1), 0, 1e-9);
  EXPECT_TRUE(m.hull(0)->centroid.norm() < 1e-7);
  CollisionData d;
  collide(m, d, {at(0.05, -0.03, 0.2 + 0.1 - 0.004)});
  ASSERT_GE(d.contacts.size(), 1u);
  EXPECT_NEAR(d.contacts[0].depth, 0.004, 1e-6);
  EXPECT_TRUE(d.contacts[0].normal.isApprox(Vec3::UnitZ(), 1e-5)) << d.contacts[0].normal;
  EXPECT_NEAR(d.contacts[0].point.z(), 0.2 - 0.002, 1e-6);
}

TEST(Collision, BoxOnBox) {
  // A 0.2 box resting on a unit box's top, 2 mm into it, turned about z.
  CollisionModel m({object("table", make_box(Vec3(1, 1, 1)), CollisionObject::kWorld),
                    object("box", make_box(Vec3(0.2, 0.2, 0.2)), 0)},
                   no_margin());
  CollisionData d;
  collide(m, d, {at(0.1, 0.1, 0.5 + 0.1 - 0.002, rot(Vec3::UnitZ(), 0.4))});
  ASSERT_GE(d.contacts.size(), 1u);
  for (const Contact& c : d.contacts) {
    EXPECT_NEAR(c.depth, 0.002, 1e-9);
    EXPECT_TRUE(c.normal.isApprox(Vec3::UnitZ(), 1e-9)) << c.normal.transpose();
    EXPECT_NEAR(c.point.z(), 0.5 - 0.001, 1e-9);
  }
}

TEST(Collision, MarginContactsHaveNegativeDepth) {
  CollisionOptions opt;
  opt.margin = 0.01;
  CollisionModel m({ground(), object("a", make_sphere(0.5), 0), object("b", make_sphere(0.3), 1)},
                   opt);
  CollisionData d;
  // a 4 mm above the ground, b 6 mm from a (along x), b 1 m up: two margin contacts.
  collide(m, d, {at(0, 0, 0.504), at(0.806, 0, 0.504)});
  std::vector<Contact> ab, ground_a;
  for (const Contact& c : d.contacts) {
    if (c.a == 1 && c.b == 2) ab.push_back(c);
    if (c.a == 0 && c.b == 1) ground_a.push_back(c);
  }
  ASSERT_EQ(ab.size(), 1u);
  EXPECT_NEAR(ab[0].depth, -0.006, 1e-9);
  EXPECT_TRUE(ab[0].normal.isApprox(Vec3::UnitX(), 1e-9));
  EXPECT_TRUE(ab[0].point.isApprox(Vec3(0.503, 0, 0.504), 1e-9)) << ab[0].point.transpose();
  ASSERT_EQ(ground_a.size(), 1u);
  EXPECT_NEAR(ground_a[0].depth, -0.004, 1e-12);
  EXPECT_NEAR(ground_a[0].point.z(), 0.002, 1e-12);
  // b is 0.504 - 0.3 above the ground: no contact; beyond the margin nothing at all.
  collide(m, d, {at(0, 0, 0.52), at(0.82, 0, 0.52)});
  EXPECT_TRUE(d.contacts.empty());
}

TEST(Collision, FilterSameFrameAdjacentSelfStaticAndSrdf) {
  // Robot: frames 0 - 1 - 2 (a chain), each with a sphere at the origin; all overlap.
  auto robot = [](const std::string& link, int frame) {
    CollisionObject o = object(link, make_sphere(1.0), frame, 0);
    o.link = link;
    return o;
  };
  std::vector<CollisionObject> objs = {robot("l0", 0),
                                       robot("l1", 1),
                                       robot("l2", 2),
                                       robot("l2", 2),  // a second shape of l2
                                       object("table", make_sphere(1), CollisionObject::kWorld),
                                       object("shelf", make_sphere(1), CollisionObject::kWorld)};
  CollisionOptions opt = no_margin();
  opt.adjacent = {{0, 1}, {1, 2}};
  const std::vector<SE3> poses = {at(0, 0, 0), at(0.1, 0, 0), at(0.2, 0, 0)};
  {
    opt.self_collision = false;
    CollisionModel m(objs, opt);
    EXPECT_FALSE(m.may_collide(0, 2));  // self-collision off
    EXPECT_FALSE(m.may_collide(4, 5));  // static-static
    EXPECT_TRUE(m.may_collide(0, 4));   // robot - object
    CollisionData d;
    collide(m, d, poses);
    for (const Contact& c : d.contacts) EXPECT_TRUE(c.a >= 4 || c.b >= 4);
  }
  opt.self_collision = true;
  {
    CollisionModel m(objs, opt);
    EXPECT_TRUE(m.may_collide(0, 2));   // not adjacent
    EXPECT_FALSE(m.may_collide(0, 1));  // adjacent
    EXPECT_FALSE(m.may_collide(1, 2));
    EXPECT_FALSE(m.may_collide(2, 3));  // same frame
    EXPECT_FALSE(m.may_collide(4, 5));
    CollisionData d;
    collide(m, d, poses);
    int self = 0;
    for (const Contact& c : d.contacts) {
      EXPECT_TRUE(m.may_collide(c.a, c.b));
      if (c.a < 4 && c.b < 4) ++self;
    }
    EXPECT_EQ(self, 2);  // l0-l2 twice (two shapes)
  }
  opt.disabled_links = {{"l2", "l0"}};
  {
    CollisionModel m(objs, opt);
    EXPECT_FALSE(m.may_collide(0, 2));
    EXPECT_FALSE(m.may_collide(3, 0));
    CollisionData d;
    collide(m, d, poses);
    for (const Contact& c : d.contacts) EXPECT_TRUE(c.a >= 4 || c.b >= 4);
  }
}

TEST(Collision, SrdfPairs) {
  const auto panda = srdf_disabled_pairs(read_file(
      kRoot + "/data/meshes/example-robot-data/robots/panda_description/srdf/panda.srdf"));
  EXPECT_GT(panda.size(), 10u);
  EXPECT_NE(std::find(panda.begin(), panda.end(),
                      std::make_pair(std::string("panda_link0"), std::string("panda_link1"))),
            panda.end());
  const auto pairs = srdf_disabled_pairs(
      "<robot name='r'><group name='g'/>\n<disable_collisions link1='a' link2='b' "
      "reason='Adjacent'/><disable_collisions link1='b' link2='c'/></robot>");
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[1].first, "b");
  EXPECT_EQ(pairs[1].second, "c");
  EXPECT_THROW(srdf_disabled_pairs("<robot><disable_collisions link1='a'"), std::invalid_argument);
  try {
    srdf_disabled_pairs("<robot>\n\n<disable_collisions link1='a'/></robot>");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("line 3"), std::string::npos) << e.what();
  }
  EXPECT_THROW(srdf_disabled_pairs("<notrobot/>"), std::invalid_argument);
}

TEST(Collision, BadInput) {
  EXPECT_THROW(CollisionModel({object("b", make_box(Vec3(1, 0, 1)), 0)}, {}),
               std::invalid_argument);
  EXPECT_THROW(CollisionModel({object("s", make_sphere(-1), 0)}, {}), std::invalid_argument);
  Shape empty;
  empty.type = ShapeType::Mesh;
  EXPECT_THROW(CollisionModel({object("m", empty, 0)}, {}), std::invalid_argument);
  // A flat mesh has no hull.
  Shape flat;
  flat.type = ShapeType::Mesh;
  auto tm = std::make_shared<TriangleMesh>();
  tm->positions = {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 1, 0), Vec3f(1, 1, 0)};
  tm->indices = {0, 1, 2, 1, 3, 2};
  finish_mesh(*tm);
  flat.mesh = tm;
  try {
    CollisionModel bad({object("flat", flat, 0)}, {});
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("flat"), std::string::npos) << e.what();
  }
  CollisionModel m({object("a", make_sphere(1), 3)}, {});
  CollisionData d;
  EXPECT_THROW(collide(m, d, {SE3(), SE3()}), std::invalid_argument);
  CollisionOptions neg;
  neg.margin = -1;
  EXPECT_THROW(CollisionModel({}, neg), std::invalid_argument);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
