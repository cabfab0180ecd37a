// What cameras and lasers see of the simulator's world (issue 38): the objects it holds now,
// spawned ones included (render::shape_item for cameras, laser_world for lasers, both over
// Simulator::object_specs(), frames after the bodies as Simulator::objects() poses them).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "se3_sim/collision/laser.h"
#include "se3_sim/render/camera_sensor.h"
#include "se3_sim/sim/laser_world.h"
#include "se3_sim/sim/sim.h"
#include "se3_sim/sim/world.h"
#include "source_paths.h"

using namespace se3;

namespace {

const std::string kRoot = se3_sim_test::source_dir();

// A free-base chain high above, the ground and a low table far off: nothing at the sensors'
// height (0.5 m) along +x until a crate is spawned at x = 2 (its near face at x = 1.8).
const char* kScene =
    "robot: chain:3\nbase: free\nbase_pose: {position: [0, 0, 3]}\n"
    "integrator: contact_semi_implicit\ndt: 0.001\n"
    "ground: {normal: [0, 0, 1], offset: 0.0, mu: 0.8}\n"
    "objects:\n"
    "  - {name: table, shape: {box: [1, 1, 0.1]}, pose: {position: [3, 0, 0.05]}}\n";

const char* kCrate = "shape: {box: [0.4, 0.4, 0.4]}\npose: {position: [2, 0, 0.5]}\n";

// The frames sensors see: the bodies, then the objects.
std::vector<SE3> frame_poses(Simulator& sim) {
  std::vector<SE3> links;
  sim.link_poses(links);
  std::vector<SE3> poses = sim.body_poses();
  for (const ObjectState& o : sim.objects()) poses.push_back(o.pose);
  return poses;
}

struct Seen {
  double camera_centre;  ///< depth of the camera's centre pixel (NaN: nothing)
  double laser_ahead;    ///< range of the laser's sample along +x
};

// A level camera and a level laser at (0, 0, 0.5) looking along +x.
Seen look(Simulator& sim, const Scene& scene) {
  const int nbodies = sim.model().n + 1;
  const std::vector<SE3> poses = frame_poses(sim);
  render::CameraSensorSpec cs;
  cs.width = 81;
  cs.height = 61;
  cs.ground = false;
  render::CameraSensor cam(cs);
  std::vector<render::DrawItem> items;
  for (std::size_t j = 0; j < sim.object_specs().size(); ++j) {
    items.push_back(render::shape_item(sim.object_specs()[j].shape,
                                       Eigen::Vector3f(0.5f, 0.5f, 0.5f), nbodies + int(j),
                                       sim.object_specs()[j].name));
  }
  cam.set_items(items);
  cam.render(SE3(render::optical_in_body(), Vec3(0, 0, 0.5)), poses);
  const CollisionModel model(
      laser_world(GeometryModel(), nbodies, sim.object_specs(), scene.constraints),
      CollisionOptions());
  LaserSpec ls;
  ls.samples = 3;
  ls.angle_min = -0.1;
  ls.angle_max = 0.1;
  ls.resolution = 0;
  LaserScanner laser(model, ls);
  laser.scan(SE3(Mat3::Identity(), Vec3(0, 0, 0.5)), poses);
  return {cam.depth()[30 * 81 + 40], laser.ranges()[1]};
}

}  // namespace

TEST(SensorWorld, SpawnedObjectsAreSeenByCamerasAndLasers) {
  const Scene scene = parse_scene(kScene, kRoot, "w.yaml");
  auto sim = make_simulator(scene);
  ASSERT_TRUE(sim->step());
  const Seen before = look(*sim, scene);
  EXPECT_TRUE(std::isnan(before.camera_centre));
  EXPECT_TRUE(std::isinf(before.laser_ahead) && before.laser_ahead > 0);
  sim->spawn_object(parse_scene_object(kCrate, kRoot, "<spawn>", "crate"));
  ASSERT_TRUE(sim->step());
  const Seen after = look(*sim, scene);
  EXPECT_NEAR(after.camera_centre, 1.8, 1e-4);
  EXPECT_NEAR(after.laser_ahead, 1.8, 1e-6);
  // Deleted: gone again.
  sim->delete_model("crate");
  ASSERT_TRUE(sim->step());
  const Seen gone = look(*sim, scene);
  EXPECT_TRUE(std::isnan(gone.camera_centre));
  EXPECT_TRUE(std::isinf(gone.laser_ahead));
}

// The laser's world: the robot's collision shapes on their bodies, each object on its frame
// after the bodies, the ground last.
TEST(SensorWorld, LaserWorldFramesAndGround) {
  const Scene scene = parse_scene(kScene, kRoot, "w.yaml");
  auto sim = make_simulator(scene);
  const int nbodies = sim->model().n + 1;
  const std::vector<CollisionObject> objs =
      laser_world(GeometryModel(), nbodies, sim->object_specs(), scene.constraints);
  ASSERT_EQ(objs.size(), 2u);
  EXPECT_EQ(objs[0].name, "table");
  EXPECT_EQ(objs[0].frame, nbodies);
  EXPECT_TRUE(objs[1].halfspace);
  ConstraintSpec none;
  EXPECT_EQ(laser_world(GeometryModel(), nbodies, sim->object_specs(), none).size(), 1u);
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
