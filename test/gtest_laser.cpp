// Laser scans by ray casts (issue 38): a scan in a box room reads the walls' distances within
// the range resolution; each shape's ray distance against its analytic value; REP 117's
// infinities.
#include <gtest/gtest.h>

#include <cmath>

#include "se3_sim/collision/laser.h"

using namespace se3;

namespace {

CollisionObject wall(const std::string& name, const Vec3& centre, const Vec3& size) {
  CollisionObject o;
  o.name = name;
  o.frame = CollisionObject::kWorld;
  o.placement = SE3(Mat3::Identity(), centre);
  o.shape = make_box(size);
  o.group = 1;
  return o;
}

// Inner faces at x = 2, x = -1.5, y = 3, y = -1 (walls 0.2 m thick, 2 m high), and the ground.
std::vector<CollisionObject> room() {
  std::vector<CollisionObject> v = {
      wall("east", Vec3(2.1, 0, 1), Vec3(0.2, 10, 2)),
      wall("west", Vec3(-1.6, 0, 1), Vec3(0.2, 10, 2)),
      wall("north", Vec3(0, 3.1, 1), Vec3(10, 0.2, 2)),
      wall("south", Vec3(0, -1.1, 1), Vec3(10, 0.2, 2)),
  };
  CollisionObject g;
  g.name = "ground";
  g.halfspace = true;
  g.group = 1;
  v.push_back(g);
  return v;
}

double room_distance(double c, double s) {
  const double tx = c > 1e-12 ? 2.0 / c : (c < -1e-12 ? 1.5 / -c : INFINITY);
  const double ty = s > 1e-12 ? 3.0 / s : (s < -1e-12 ? 1.0 / -s : INFINITY);
  return std::min(tx, ty);
}

}  // namespace

TEST(Laser, BoxRoomReadsTheWallsWithinTheResolution) {
  CollisionModel model(room(), CollisionOptions());
  LaserSpec spec;
  spec.samples = 720;
  spec.angle_min = -M_PI;
  spec.angle_max = M_PI;
  spec.range_min = 0.1;
  spec.range_max = 10;
  spec.resolution = 0.01;
  std::string err;
  ASSERT_TRUE(check_laser_spec(spec, &err)) << err;
  LaserScanner scanner(model, spec);
  // Level, 0.5 m above the ground at the origin, turned by 0.3 rad about z.
  const double yaw = 0.3;
  const SE3 oMs(Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix(), Vec3(0, 0, 0.5));
  scanner.scan(oMs, {});
  ASSERT_EQ(scanner.ranges().size(), 720u);
  for (int k = 0; k < 720; ++k) {
    const double a = yaw + spec.angle_min + k * spec.increment();
    const double want = room_distance(std::cos(a), std::sin(a));
    const float r = scanner.ranges()[k];
    if (want > spec.range_max) {
      EXPECT_TRUE(std::isinf(r) && r > 0) << k;
    } else {
      EXPECT_NEAR(r, want, 0.5 * spec.resolution + 1e-6) << k;
    }
  }
  // Without rounding: the distances themselves.
  spec.resolution = 0;
  LaserScanner exact(model, spec);
  exact.scan(oMs, {});
  for (int k = 0; k < 720; k += 7) {
    const double a = yaw + spec.angle_min + k * spec.increment();
    const double want = room_distance(std::cos(a), std::sin(a));
    if (want <= spec.range_max) {
      EXPECT_NEAR(exact.ranges()[k], want, 1e-5 * want) << k;
    }
  }
  // Tilted down, the rays meet the ground; far walls beyond range_max read +Inf, and a wall
  // nearer than range_min -Inf.
  spec.samples = 1;
  spec.angle_min = spec.angle_max = 0;
  LaserScanner one(model, spec);
  const Mat3 down = Eigen::AngleAxisd(0.5, Vec3::UnitY()).toRotationMatrix();
  one.scan(SE3(down, Vec3(0, 0, 0.5)), {});
  EXPECT_NEAR(one.ranges()[0], 0.5 / std::sin(0.5), 1e-5);
  one.scan(SE3(Mat3::Identity(), Vec3(1.95, 0, 0.5)), {});
  EXPECT_TRUE(std::isinf(one.ranges()[0]) && one.ranges()[0] < 0);
  spec.range_max = 1.0;
  LaserScanner short_range(model, spec);
  short_range.scan(SE3(Mat3::Identity(), Vec3(0, 0, 0.5)), {});
  EXPECT_TRUE(std::isinf(short_range.ranges()[0]) && short_range.ranges()[0] > 0);
}

TEST(Laser, ShapesAgainstTheirAnalyticDistances) {
  const SE3 at(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix(),
               Vec3(3, 0.1, 0.2));
  const Vec3 o(0, 0, 0);
  CollisionObject obj;
  // Sphere of radius 0.5 at distance |p|: along the ray through its centre, |p| - 0.5.
  obj.shape = make_sphere(0.5);
  const Vec3 dc = at.p.normalized();
  EXPECT_NEAR(ray_distance(obj, nullptr, at, o, dc), at.p.norm() - 0.5, 1e-12);
  EXPECT_TRUE(std::isinf(ray_distance(obj, nullptr, at, o, -dc)));    // behind
  EXPECT_TRUE(std::isinf(ray_distance(obj, nullptr, at, at.p, dc)));  // from inside
  // Cylinder along the ray's normal: its side at |p| - r; along its axis: its cap.
  obj.shape = make_cylinder(0.3, 1.0);
  const SE3 upright(Mat3::Identity(), Vec3(3, 0, 0));
  EXPECT_NEAR(ray_distance(obj, nullptr, upright, o, Vec3::UnitX()), 2.7, 1e-12);
  EXPECT_NEAR(ray_distance(obj, nullptr, upright, Vec3(3.1, 0, -2), Vec3::UnitZ()), 1.5, 1e-12);
  EXPECT_TRUE(std::isinf(ray_distance(obj, nullptr, upright, Vec3(0, 0, 0.6), Vec3::UnitX())));
  // Capsule: the same, but a ray just above the cylinder part meets the cap sphere.
  obj.shape = make_capsule(0.3, 1.0);
  EXPECT_NEAR(ray_distance(obj, nullptr, upright, o, Vec3::UnitX()), 2.7, 1e-12);
  const double h = 0.6;  // 0.1 above the top cap's centre
  EXPECT_NEAR(ray_distance(obj, nullptr, upright, Vec3(0, 0, h), Vec3::UnitX()),
              3 - std::sqrt(0.09 - 0.01), 1e-12);
  EXPECT_NEAR(ray_distance(obj, nullptr, upright, Vec3(3, 0, -3), Vec3::UnitZ()), 3 - 0.8, 1e-12);
  // A box turned by 45 deg about z, seen along x: its edge at 3 - sqrt(2) / 2.
  obj.shape = make_box(Vec3(1, 1, 1));
  const SE3 diamond(Eigen::AngleAxisd(M_PI / 4, Vec3::UnitZ()).toRotationMatrix(), Vec3(3, 0, 0));
  EXPECT_NEAR(ray_distance(obj, nullptr, diamond, o, Vec3::UnitX()), 3 - std::sqrt(0.5), 1e-12);
  // A mesh as its convex hull: a tessellated unit box's hull behaves as the box.
  const TriangleMesh cube = tessellate(make_box(Vec3(1, 1, 1)));
  const ConvexHull hull = convex_hull(cube);
  obj.shape.type = ShapeType::Mesh;
  EXPECT_NEAR(ray_distance(obj, &hull, diamond, o, Vec3::UnitX()), 3 - std::sqrt(0.5), 1e-9);
  EXPECT_NEAR(ray_distance(obj, &hull, diamond, Vec3(3, 0, 5), -Vec3::UnitZ()), 4.5, 1e-9);
  EXPECT_TRUE(std::isinf(ray_distance(obj, &hull, diamond, Vec3(0, 2, 0), Vec3::UnitX())));
}

TEST(Laser, SpecChecks) {
  std::string err;
  LaserSpec s;
  EXPECT_TRUE(check_laser_spec(s, &err));
  s.samples = 0;
  EXPECT_FALSE(check_laser_spec(s, &err));
  EXPECT_NE(err.find("samples"), std::string::npos);
  s = LaserSpec();
  s.range_max = 0.05;
  EXPECT_FALSE(check_laser_spec(s, &err));
  EXPECT_NE(err.find("range max"), std::string::npos);
  s = LaserSpec();
  s.angle_min = 1;
  s.angle_max = 0;
  EXPECT_FALSE(check_laser_spec(s, &err));
  EXPECT_NE(err.find("min_angle"), std::string::npos);
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
