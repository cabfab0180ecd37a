// What the laser scanners see: the robot's collision shapes, the objects and the ground.
#include "se3_sim/sim/laser_world.h"

#include <cmath>

namespace se3 {

namespace {

// A frame whose z axis is the unit normal n, at n * offset.
SE3 plane_frame(const Vec3& normal, double offset) {
  const Vec3 z = normal.normalized();
  const Vec3 helper = std::abs(z.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  const Vec3 x = helper.cross(z).normalized();
  Mat3 R;
  R.col(0) = x;
  R.col(1) = z.cross(x);
  R.col(2) = z;
  return SE3(R, offset * z);
}

}  // namespace

std::vector<CollisionObject> laser_world(const GeometryModel& geometry, int nbodies,
                                         const std::vector<SceneObject>& objects,
                                         const ConstraintSpec& ground) {
  std::vector<CollisionObject> out;
  for (const GeometryObject& g : geometry.collisions) {
    if (g.stand_in) continue;
    CollisionObject c;
    c.name = g.name;
    c.link = g.link;
    c.frame = g.body;
    c.placement = g.placement;
    c.shape = g.shape;
    out.push_back(c);
  }
  for (std::size_t j = 0; j < objects.size(); ++j) {
    CollisionObject c;
    c.name = objects[j].name;
    c.frame = nbodies + int(j);
    c.shape = objects[j].shape;
    c.group = 1;
    out.push_back(c);
  }
  if (ground.ground) {
    CollisionObject c;
    c.name = "ground";
    c.halfspace = true;
    c.group = 1;
    c.placement = plane_frame(ground.ground_normal, ground.ground_offset);
    out.push_back(c);
  }
  return out;
}

}  // namespace se3
