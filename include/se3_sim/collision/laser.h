// A planar laser scanner (sensor_msgs/LaserScan semantics) by ray casts against the collision
// layer's shapes: boxes, spheres, cylinders, capsules, the ground half-space and meshes as the
// convex hulls the layer collides them as. Why ray casts rather than depth rendering of the
// sweep: docs/ros.md, "Cameras and laser scans" (measured).
//
// Sample k of `samples` has the angle angle_min + k * increment about the sensor frame's z axis
// (0 along x), increment = (angle_max - angle_min) / (samples - 1) (one sample: angle_min). Its
// range is the distance from the sensor's origin to the first surface along that ray, rounded
// to a multiple of `resolution` (when > 0); REP 117: +Inf when nothing is hit within
// range_max, -Inf when the first surface is nearer than range_min. Shapes that contain the
// sensor's origin (its own housing) are not seen.
#pragma once

#include <vector>

#include "se3_sim/collision/collision.h"

namespace se3 {

struct LaserSpec {
  int samples = 720;
  double angle_min = -M_PI;
  double angle_max = M_PI;
  double range_min = 0.1;    ///< m
  double range_max = 10.0;   ///< m
  double resolution = 0.01;  ///< m; 0: no rounding
  double increment() const { return samples > 1 ? (angle_max - angle_min) / (samples - 1) : 0.0; }
};

/// Whether spec is usable (samples in [1, 100000], angle_min <= angle_max within +-2 pi,
/// 0 <= range_min < range_max finite, resolution >= 0); on false *error names the field.
bool check_laser_spec(const LaserSpec& spec, std::string* error);

/// Distance t >= 0 along the unit ray o + t d (world) to where it enters object `obj` at
/// world shape pose oMs (hull: its convex hull for a mesh, else null); +Inf when it misses or
/// starts inside.
double ray_distance(const CollisionObject& obj, const ConvexHull* hull, const SE3& oMs,
                    const Vec3& o, const Vec3& d);

class LaserScanner {
 public:
  /// Keeps a reference to model (it must outlive the scanner); allocates here only.
  LaserScanner(const CollisionModel& model, const LaserSpec& spec);
  const LaserSpec& spec() const { return spec_; }
  /// One sweep from the sensor frame at world pose oMs, the model's frames at frame_poses (as
  /// collide() takes them). Allocates nothing.
  void scan(const SE3& oMs, const std::vector<SE3>& frame_poses);
  /// Metres (see the header comment), `samples` of them.
  const std::vector<float>& ranges() const { return ranges_; }

 private:
  struct Shape {
    int object = 0;
    double radius = 0;  ///< bounding sphere about the shape frame's origin
    /// Meshes: the hull's face planes n . x <= c (shape frame).
    std::vector<Vec3> normals;
    std::vector<double> offsets;
  };
  const CollisionModel* model_;
  LaserSpec spec_;
  std::vector<Shape> shapes_;
  std::vector<float> ranges_;
  std::vector<SE3> poses_;  ///< per shape, world, this sweep
  std::vector<char> near_;  ///< per shape, whether its bounding sphere meets the sweep's disc
  std::vector<double> cos_, sin_;
};

}  // namespace se3
