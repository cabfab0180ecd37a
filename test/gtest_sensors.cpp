// Sensors (sensors.h): an IMU resting on the ground reads +g upward, a spinning free body's IMU
// its body rate and zero acceleration at its centre, a wrist force-torque sensor on a fixed
// joint the weight and moment of what hangs below it, a contact sensor the push's contacts;
// the scene's `sensors:` keys and a URDF's Gazebo tags; seeded noise.
#include <gtest/gtest.h>
#include <urdf_parser/urdf_parser.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "se3_sim/sim/sensors.h"
#include "se3_sim/sim/sim.h"
#include "se3_sim/sim/transmissions.h"
#include "source_paths.h"

using namespace se3;

namespace {

const std::string kScenes = se3_sim_test::source_dir() + "/config/scenes/";
const std::string kRobots = se3_sim_test::source_dir() + "/data/robots/";

std::string file_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string scene_text(const std::string& name) {
  return file_text(kScenes + name + ".yaml");
}

// Steps sim with the sensors for `seconds`.
void run(Simulator& sim, SensorSet& sensors, double seconds) {
  const int steps = static_cast<int>(std::lround(seconds / sim.dt()));
  for (int k = 0; k < steps; ++k) {
    sensors.before_step(sim);
    const bool ok = sim.step();
    sensors.after_step(sim, ok);
    ASSERT_TRUE(ok) << sim.failure();
  }
}

std::string error_of(const std::string& text) {
  try {
    parse_scene(text, kScenes, "s.yaml");
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Sensors, ImuOnRobotRestingOnGroundReadsPlusG) {
  const Scene scene = parse_scene(
      scene_text("quadruped_ground") + "sensors:\n  - {name: imu, type: imu, link: base_link}\n",
      kScenes, "quadruped_ground.yaml");
  auto sim = make_simulator(scene);
  SensorSet sensors(sim->model(), scene.sensors);
  run(*sim, sensors, 3.0);
  const SensorReading& r = sensors.reading(0);
  ASSERT_TRUE(r.ready);
  EXPECT_NEAR(r.stamp, sim->time() - sim->dt(), 1e-12);
  // In a level frame (the reading rotated by its own orientation): (0, 0, +9.81).
  const Vec3 level = r.orientation * r.linear_acceleration;
  EXPECT_NEAR(level.x(), 0, 1e-3);
  EXPECT_NEAR(level.y(), 0, 1e-3);
  EXPECT_NEAR(level.z(), 9.81, 1e-3);
  EXPECT_LT(r.angular_velocity.norm(), 1e-3);
  const Eigen::Quaterniond q(sim->state().base.R);
  EXPECT_LT(q.angularDistance(r.orientation), 1e-3);
}

TEST(Sensors, ImuOnSpinningFreeBodyReadsBodyRateAndZeroAtCentre) {
  const std::string urdf =
      "<robot name='b'><link name='body'><inertial><origin xyz='0 0 0'/><mass value='2'/>"
      "<inertia ixx='0.1' iyy='0.2' izz='0.3' ixy='0' ixz='0' iyz='0'/></inertial></link>"
      "</robot>";
  const Scene scene = parse_scene(
      "base: free\ngravity: [0, 0, 0]\nintegrator: rkmk4\ndt: 0.001\n"
      "base_twist: [1.0, 2.0, 3.0, 0.0, 0.0, 0.0]\n"
      "sensors:\n  - {name: centre, type: imu, link: body}\n"
      "  - {name: off, type: imu, link: body, pose: {position: [0.1, 0.0, 0.0]}}\n",
      kScenes, "spin.yaml");
  auto sim = make_simulator(scene, urdf);
  SensorSet sensors(sim->model(), scene.sensors, urdf);
  for (int k = 0; k < 200; ++k) {
    const Vec6 V = sim->state().v.head<6>();
    sensors.before_step(*sim);
    ASSERT_TRUE(sim->step());
    sensors.after_step(*sim);
    const SensorReading& c = sensors.reading(0);
    ASSERT_TRUE(c.ready);
    EXPECT_LT((c.angular_velocity - V.head<3>()).norm(), 1e-12);
    EXPECT_LT(c.linear_acceleration.norm(), 1e-9);
    // Off the centre: the point's acceleration, w x (w x r) + alpha x r, alpha from Euler's
    // equations I alpha = -w x I w (the step's mean, within O(dt) of it).
    const Vec3 w = V.head<3>(), r(0.1, 0, 0);
    const Vec3 I(0.1, 0.2, 0.3);
    const Vec3 alpha = -(w.cross(I.cwiseProduct(w))).cwiseQuotient(I);
    const Vec3 expect = w.cross(w.cross(r)) + alpha.cross(r);
    EXPECT_LT((sensors.reading(1).linear_acceleration - expect).norm(), 0.05 * expect.norm());
  }
}

namespace {

// The fixed Panda held still by a position controller on every arm joint.
Scene resting_panda(const std::string& sensors) {
  return parse_scene(
      scene_text("fixed_panda") +
          "controllers:\n  arm:\n    type: effort_controllers/JointGroupPositionController\n"
          "    joints: [panda_joint1, panda_joint2, panda_joint3, panda_joint4, panda_joint5,"
          " panda_joint6, panda_joint7]\n    pid: {p: 2000.0, i: 0.0, d: 100.0}\n"
          "    gains: {panda_joint5: {p: 100.0, d: 4.0}, panda_joint6: {p: 100.0, d: 4.0},"
          " panda_joint7: {p: 50.0, d: 1.0}}\n" +
          sensors,
      kScenes, "fixed_panda.yaml");
}

// What hangs below link `top` (its URDF subtree): mass and centre of mass in the world.
void hanging(const Simulator& sim_c, const std::string& top, double* mass, Vec3* com) {
  Simulator& sim = const_cast<Simulator&>(sim_c);
  const Model& m = sim.model();
  static const auto urdf = urdf::parseURDF(file_text(kRobots + "panda.urdf"));
  std::vector<SE3> poses;
  sim.link_poses(poses);
  const int top_i = m.link_index(top);
  *mass = 0;
  Vec3 h = Vec3::Zero();
  for (size_t l = 0; l < m.links.size(); ++l) {
    bool in = false;
    for (int k = static_cast<int>(l); k >= 0; k = m.links[k].parent) in = in || k == top_i;
    if (!in) continue;
    auto link = urdf->getLink(m.links[l].name);
    if (!link->inertial) continue;
    const auto& p = link->inertial->origin.position;
    *mass += link->inertial->mass;
    h += link->inertial->mass * poses[l].act(Vec3(p.x, p.y, p.z));
  }
  *com = h / *mass;
}

}  // namespace

TEST(Sensors, ForceTorqueOnFixedWristJointReadsWhatHangsBelow) {
  const Scene scene = resting_panda(
      "sensors:\n  - {name: wrist, type: force_torque, joint: panda_hand_joint}\n"
      "  - {name: flange, type: force_torque, joint: panda_joint8, rate: 100}\n"
      "  - {name: j7, type: force_torque, joint: panda_joint7}\n");
  auto sim = make_simulator(scene);
  SensorSet sensors(sim->model(), scene.sensors, file_text(kRobots + "panda.urdf"));
  run(*sim, sensors, 2.0);
  EXPECT_LT(sim->state().v.norm(), 1e-6);
  std::vector<SE3> poses;
  sim->link_poses(poses);
  const char* child[] = {"panda_hand", "panda_link8", "panda_link7"};
  for (int i = 0; i < 3; ++i) {
    SCOPED_TRACE(child[i]);
    double mass = 0;
    Vec3 com;
    hanging(*sim, child[i], &mass, &com);
    const SE3& S = poses[sim->model().link_index(child[i])];
    // Child on parent: the weight, and its moment about the sensor's origin.
    const Vec3 weight = mass * Vec3(0, 0, -9.81);
    const Vec3 f = S.R.transpose() * weight;
    const Vec3 t = S.R.transpose() * (com - S.p).cross(weight);
    const SensorReading& r = sensors.reading(i);
    ASSERT_TRUE(r.ready);
    EXPECT_LT((r.force - f).norm(), 1e-6 * weight.norm()) << r.force.transpose();
    EXPECT_LT((r.torque - t).norm(), 1e-6 * weight.norm()) << r.torque.transpose();
  }
  EXPECT_EQ(sensors.period(1), 10);
}

// The force-torque sensor on a fixed joint reads the merged links' inertias from the URDF text:
// through the guarded parse, so a "%n" that urdfdom quotes in a message (a material's rgba) is
// never formatted printf-style (it crashed here when the sensor parsed the text itself).
TEST(Sensors, ForceTorqueUrdfWithPercentNInAMaterialIsReadSafely) {
  const Scene scene =
      resting_panda("sensors:\n  - {name: wrist, type: force_torque, joint: panda_hand_joint}\n");
  const std::string clean = file_text(kRobots + "panda.urdf");
  std::string text = clean;
  const size_t robot = text.find('>', text.find("<robot"));
  ASSERT_NE(robot, std::string::npos);
  text.insert(robot + 1, "<material name=\"bad\"><color rgba=\"1 %n%n%s%s 1\"/></material>");
  // The same readings as from the clean text: the material changes no inertia.
  Vec3 force[2], torque[2];
  for (int k = 0; k < 2; ++k) {
    auto sim = make_simulator(scene);
    SensorSet sensors(sim->model(), scene.sensors, k == 0 ? clean : text);
    run(*sim, sensors, 0.05);
    ASSERT_TRUE(sensors.reading(0).ready);
    force[k] = sensors.reading(0).force;
    torque[k] = sensors.reading(0).torque;
  }
  EXPECT_GT(force[0].norm(), 1.0);
  EXPECT_EQ(force[1], force[0]);
  EXPECT_EQ(torque[1], torque[0]);
}

TEST(Sensors, ForceTorqueDuringPushMatchesContactForce) {
  // The shipped scene's sensors sample at 100 Hz: these sample every step.
  std::string text = scene_text("panda_push");
  text = text.substr(0, text.find("\nsensors:") + 1);
  const Scene scene =
      parse_scene(text +
                      "sensors:\n  - {name: wrist, type: force_torque, joint: panda_hand_joint}\n"
                      "  - {name: left, type: contact, link: panda_leftfinger}\n"
                      "  - {name: right, type: contact, link: panda_rightfinger}\n"
                      "  - {name: hand, type: contact, link: panda_hand}\n",
                  kScenes, "panda_push.yaml");
  auto sim = make_simulator(scene);
  SensorSet sensors(sim->model(), scene.sensors, file_text(kRobots + "panda.urdf"));
  double mass = 0;
  Vec3 com;
  hanging(*sim, "panda_hand", &mass, &com);
  // Per step k: the centre of mass of what hangs below the wrist (before the step), the
  // reading's force in the world and the contact sensors' total.
  const int steps = 1500;
  std::vector<Vec3> c(steps + 1), measured(steps), contact(steps, Vec3::Zero());
  std::vector<SE3> poses;
  for (int k = 0; k <= steps; ++k) {
    double m = 0;
    hanging(*sim, "panda_hand", &m, &c[k]);
    if (k == steps) break;
    sim->link_poses(poses);
    const SE3 S = poses[sim->model().link_index("panda_hand")];
    sensors.before_step(*sim);
    ASSERT_TRUE(sim->step());
    sensors.after_step(*sim);
    ASSERT_NEAR(sensors.reading(0).stamp, k * sim->dt(), 1e-12);
    measured[k] = S.R * sensors.reading(0).force;
    for (int i = 1; i <= 3; ++i) contact[k] += sensors.reading(i).total_force;
  }
  // Child on parent = -(m (a - g) - F_contact), a the centre of mass's acceleration: here the
  // second difference of its positions, the scheme's (v_{k+1} - v_k) / dt to O(dt).
  int touching = 0;
  double worst = 0, largest = 0;
  const double dt = sim->dt();
  for (int k = 1; k + 1 < steps; ++k) {
    if (contact[k].norm() < 1.0) continue;
    ++touching;
    const Vec3 a = (c[k + 1] - 2 * c[k] + c[k - 1]) / (dt * dt);
    const Vec3 expect = contact[k] - mass * (a - Vec3(0, 0, -9.81));
    worst = std::max(worst, (measured[k] - expect).norm() / (1 + contact[k].norm()));
    largest = std::max(largest, contact[k].norm());
  }
  EXPECT_GT(touching, 300);
  EXPECT_GT(largest, 5.0);
  EXPECT_LT(worst, 0.02);
}

TEST(Sensors, NoiseIsSeededByNameAndOffByDefault) {
  const std::string base =
      "sensors:\n  - {name: quiet, type: force_torque, joint: panda_joint7}\n"
      "  - {name: noisy, type: force_torque, joint: panda_joint7, noise: {stddev: 0.5}}\n"
      "  - {name: other, type: force_torque, joint: panda_joint7, noise: {stddev: 0.5}}\n";
  const Scene scene = resting_panda(base);
  std::vector<Vec3> first;
  for (int run_i = 0; run_i < 2; ++run_i) {
    auto sim = make_simulator(scene);
    SensorSet sensors(sim->model(), scene.sensors);
    for (int k = 0; k < 20; ++k) {
      sensors.before_step(*sim);
      ASSERT_TRUE(sim->step());
      sensors.after_step(*sim);
      const Vec3 q = sensors.reading(0).force, n = sensors.reading(1).force,
                 o = sensors.reading(2).force;
      EXPECT_GT((n - q).norm(), 1e-3);
      EXPECT_GT((o - n).norm(), 1e-3);  // another name, another stream
      if (run_i == 0) {
        first.push_back(n);
      } else {
        EXPECT_EQ(first[k], n);  // the same bits run after run
      }
    }
  }
  EXPECT_NE(SensorSet::seed_of("noisy"), SensorSet::seed_of("other"));
  EXPECT_EQ(SensorSet::seed_of(""), 14695981039346656037ull);
}

TEST(Sensors, SceneKeysAreChecked) {
  EXPECT_EQ(error_of("sensors:\n  - {name: a, type: imu, lnk: x}\n").rfind("s.yaml:2:", 0), 0u)
      << error_of("sensors:\n  - {name: a, type: imu, lnk: x}\n");
  EXPECT_NE(error_of("sensors:\n  - {name: a, type: imu, lnk: x}\n").find("lnk"),
            std::string::npos);
  const std::string gps = error_of("sensors:\n  - {name: c, type: gps, link: x}\n");
  EXPECT_NE(gps.find("unknown sensor type 'gps'"), std::string::npos) << gps;
  EXPECT_NE(error_of("sensors:\n  - {name: f, type: force_torque, link: x}\n").find("joint"),
            std::string::npos);
  EXPECT_NE(error_of("sensors:\n  - {name: i, type: imu}\n").find("needs link"), std::string::npos);
  EXPECT_NE(error_of("sensors:\n  - {name: i, type: imu, link: a, rate: -1}\n").find("rate"),
            std::string::npos);
  EXPECT_NE(error_of("sensors:\n  - {name: i, type: imu, link: a}\n"
                     "  - {name: i, type: imu, link: b}\n")
                .find("named twice"),
            std::string::npos);
  EXPECT_NE(
      error_of("sensors:\n  - {name: i, type: imu, link: a, noise: {stdev: 1}}\n").find("stdev"),
      std::string::npos);
  const Scene s = parse_scene(
      "sensors:\n  - name: i\n    type: imu\n    link: a\n    rate: 200\n    topic: /imu/data\n"
      "    pose: {position: [0, 0, 0.1], orientation: [0, 0, 0, 1]}\n"
      "    noise: {mean: 0.1, stddev: 0.2, bias: 0.3}\n",
      kScenes, "s.yaml");
  ASSERT_EQ(s.sensors.size(), 1u);
  EXPECT_EQ(s.sensors[0].topic, "/imu/data");
  EXPECT_EQ(s.sensors[0].rate, 200);
  EXPECT_EQ(s.sensors[0].noise.bias, 0.3);
  EXPECT_EQ(s.sensors[0].pose.p, Vec3(0, 0, 0.1));
  // A link the robot lacks: the sensor's name and line.
  const Scene bad = resting_panda("sensors:\n  - {name: nowhere, type: imu, link: no_link}\n");
  auto sim = make_simulator(bad);
  try {
    SensorSet set(sim->model(), bad.sensors);
    FAIL();
  } catch (const SensorError& e) {
    EXPECT_NE(std::string(e.what()).find("sensor 'nowhere' (fixed_panda.yaml:"), std::string::npos)
        << e.what();
  }
}

TEST(Sensors, UrdfGazeboTagsAsInTheTutorials) {
  const std::string urdf = R"(<robot name="r">
  <link name="base"/><link name="tool"/>
  <joint name="wrist_ft" type="fixed"><parent link="base"/><child link="tool"/></joint>
  <gazebo reference="base">
    <gravity>true</gravity>
    <sensor name="imu_sensor" type="imu">
      <always_on>true</always_on>
      <update_rate>100</update_rate>
      <visualize>true</visualize>
      <topic>__default_topic__</topic>
      <plugin filename="libgazebo_ros_imu_sensor.so" name="imu_plugin">
        <topicName>imu</topicName>
        <bodyName>base</bodyName>
        <updateRateHZ>100.0</updateRateHZ>
        <gaussianNoise>0.01</gaussianNoise>
        <xyzOffset>0 0 0</xyzOffset>
        <rpyOffset>0 0 0</rpyOffset>
        <frameName>base</frameName>
      </plugin>
      <pose>0 0 0.1 0 0 0</pose>
    </sensor>
    <sensor name="sonar" type="sonar"/>
  </gazebo>
  <gazebo reference="tool">
    <sensor name="tool_contact" type="contact">
      <update_rate>50</update_rate>
      <contact><collision>tool_collision</collision></contact>
      <plugin name="bumper" filename="libgazebo_ros_bumper.so">
        <bumperTopicName>tool_bumper</bumperTopicName>
        <frameName>world</frameName>
      </plugin>
    </sensor>
  </gazebo>
  <gazebo>
    <plugin name="ft_sensor" filename="libgazebo_ros_ft_sensor.so">
      <updateRate>100.0</updateRate>
      <topicName>ft_sensor_topic</topicName>
      <jointName>wrist_ft</jointName>
    </plugin>
    <plugin name="p3d" filename="libgazebo_ros_p3d.so"/>
  </gazebo>
</robot>)";
  std::vector<std::string> warnings;
  const auto s = sensors_from_urdf(urdf, &warnings);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[0].type, SensorType::Imu);
  EXPECT_EQ(s[0].name, "imu_sensor");
  EXPECT_EQ(s[0].link, "base");
  EXPECT_EQ(s[0].topic, "imu");
  EXPECT_EQ(s[0].frame, "base");
  EXPECT_EQ(s[0].rate, 100);
  EXPECT_EQ(s[0].noise.stddev, 0.01);
  EXPECT_EQ(s[0].pose.p, Vec3(0, 0, 0.1));
  EXPECT_EQ(s[1].type, SensorType::Contact);
  EXPECT_EQ(s[1].link, "tool");
  EXPECT_EQ(s[1].topic, "tool_bumper");
  EXPECT_EQ(s[1].frame, "world");
  EXPECT_EQ(s[1].rate, 50);
  EXPECT_EQ(s[2].type, SensorType::ForceTorque);
  EXPECT_EQ(s[2].joint, "wrist_ft");
  EXPECT_EQ(s[2].topic, "ft_sensor_topic");
  EXPECT_EQ(s[2].rate, 100);
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_NE(warnings[0].find("'sonar' of type 'sonar'"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[1].find("libgazebo_ros_p3d.so"), std::string::npos) << warnings[1];
}

// Cameras and lasers in a scene (issue 38): their keys, checked as the others are.
TEST(Sensors, CameraAndRaySceneKeys) {
  const Scene s = parse_scene(
      "sensors:\n"
      "  - {name: cam, type: depth_camera, link: world, rate: 30, width: 320, height: 240,\n"
      "     horizontal_fov: 1.2, near: 0.1, far: 8, pose: {position: [1, 0, 1]}}\n"
      "  - {name: eye, type: camera, link: a}\n"
      "  - {name: scan, type: ray, link: a, samples: 360, min_angle: -1.5, max_angle: 1.5,\n"
      "     range_min: 0.2, range_max: 20, range_resolution: 0.005, topic: /scan}\n",
      kScenes, "s.yaml");
  ASSERT_EQ(s.sensors.size(), 3u);
  EXPECT_EQ(s.sensors[0].type, SensorType::DepthCamera);
  EXPECT_EQ(s.sensors[0].link, "world");
  EXPECT_EQ(s.sensors[0].camera.width, 320);
  EXPECT_EQ(s.sensors[0].camera.height, 240);
  EXPECT_EQ(s.sensors[0].camera.hfov, 1.2);
  EXPECT_EQ(s.sensors[0].camera.near, 0.1);
  EXPECT_EQ(s.sensors[0].camera.far, 8);
  EXPECT_EQ(s.sensors[0].rate, 30);
  EXPECT_EQ(s.sensors[1].type, SensorType::Camera);
  EXPECT_EQ(s.sensors[1].camera.width, 640);  // Gazebo's defaults
  EXPECT_EQ(s.sensors[2].type, SensorType::Ray);
  EXPECT_EQ(s.sensors[2].ray.samples, 360);
  EXPECT_EQ(s.sensors[2].ray.angle_min, -1.5);
  EXPECT_EQ(s.sensors[2].ray.angle_max, 1.5);
  EXPECT_EQ(s.sensors[2].ray.range_min, 0.2);
  EXPECT_EQ(s.sensors[2].ray.range_max, 20);
  EXPECT_EQ(s.sensors[2].ray.resolution, 0.005);
  EXPECT_EQ(s.sensors[2].topic, "/scan");
  auto expect = [](const std::string& yaml, const std::string& what) {
    const std::string e = error_of(yaml);
    EXPECT_EQ(e.rfind("s.yaml:", 0), 0u) << e;
    EXPECT_NE(e.find(what), std::string::npos) << e;
  };
  expect("sensors:\n  - {name: c, type: camera, link: a, width: 0}\n", "width");
  expect("sensors:\n  - {name: c, type: camera, link: a, width: 1.5}\n", "width");
  expect("sensors:\n  - {name: c, type: camera, link: a, horizontal_fov: 4}\n", "horizontal_fov");
  expect("sensors:\n  - {name: c, type: camera, link: a, near: 2, far: 1}\n",
         "far must be greater than near");
  expect("sensors:\n  - {name: c, type: camera, link: a, samples: 10}\n",
         "'samples' is a ray sensor's key");
  expect("sensors:\n  - {name: c, type: imu, link: a, width: 10}\n", "'width' is a camera's key");
  expect("sensors:\n  - {name: r, type: ray, link: a, samples: 0}\n", "samples");
  expect("sensors:\n  - {name: r, type: ray, link: a, range_min: 5, range_max: 1}\n",
         "range_max must be greater than range_min");
  expect("sensors:\n  - {name: r, type: ray, link: a, min_angle: 1, max_angle: 0}\n",
         "min_angle must not exceed max_angle");
  expect("sensors:\n  - {name: r, type: ray, link: a, range_resolution: -1}\n", "range_resolution");
  expect("sensors:\n  - {name: r, type: ray, link: a, sample: 3}\n", "sample");
  // A SensorSet computes the dynamics' sensors only: a camera beside an IMU is never sampled.
  const Scene cams = resting_panda(
      "sensors:\n  - {name: c, type: camera, link: no_such_link}\n"
      "  - {name: i, type: imu, link: panda_hand}\n");
  auto sim = make_simulator(cams);
  SensorSet set(sim->model(), cams.sensors);
  for (int k = 0; k < 3; ++k) {
    set.before_step(*sim);
    ASSERT_TRUE(sim->step());
    set.after_step(*sim);
    EXPECT_FALSE(set.reading(0).ready);
    EXPECT_TRUE(set.reading(1).ready);
  }
}

// The tags of Gazebo's camera, Kinect and laser tutorials (gazebo_ros_pkgs' plugins).
TEST(Sensors, UrdfCameraDepthAndLaserTags) {
  const std::string urdf = R"(<robot name="r">
  <link name="base"/><link name="camera_link"/><link name="hokuyo_link"/>
  <gazebo reference="camera_link">
    <sensor type="camera" name="camera1">
      <update_rate>30.0</update_rate>
      <camera name="head">
        <horizontal_fov>1.3962634</horizontal_fov>
        <image><width>800</width><height>800</height><format>R8G8B8</format></image>
        <clip><near>0.02</near><far>300</far></clip>
        <noise><type>gaussian</type><mean>0.0</mean><stddev>0.007</stddev></noise>
      </camera>
      <plugin name="camera_controller" filename="libgazebo_ros_camera.so">
        <alwaysOn>true</alwaysOn>
        <updateRate>0.0</updateRate>
        <cameraName>rrbot/camera1</cameraName>
        <imageTopicName>image_raw</imageTopicName>
        <cameraInfoTopicName>camera_info</cameraInfoTopicName>
        <frameName>camera_link_optical</frameName>
        <hackBaseline>0.07</hackBaseline>
      </plugin>
    </sensor>
    <sensor type="depth" name="kinect">
      <update_rate>20</update_rate>
      <camera><horizontal_fov>1.047198</horizontal_fov>
        <image><width>640</width><height>480</height><format>R8G8B8</format></image>
        <clip><near>0.05</near><far>3</far></clip></camera>
      <plugin name="camera_plugin" filename="libgazebo_ros_openni_kinect.so">
        <cameraName>kinect_ir</cameraName>
        <imageTopicName>/kinect/color/image_raw</imageTopicName>
        <cameraInfoTopicName>/kinect/color/camera_info</cameraInfoTopicName>
        <depthImageTopicName>/kinect/depth/image_raw</depthImageTopicName>
        <depthImageCameraInfoTopicName>/kinect/depth/camera_info</depthImageCameraInfoTopicName>
        <pointCloudTopicName>/kinect/depth/points</pointCloudTopicName>
        <frameName>kinect_optical</frameName>
        <pointCloudCutoff>0.5</pointCloudCutoff>
      </plugin>
    </sensor>
  </gazebo>
  <gazebo reference="hokuyo_link">
    <sensor type="gpu_ray" name="head_hokuyo_sensor">
      <pose>0 0 0 0 0 0</pose>
      <update_rate>40</update_rate>
      <ray>
        <scan><horizontal><samples>720</samples><resolution>1</resolution>
          <min_angle>-1.570796</min_angle><max_angle>1.570796</max_angle></horizontal></scan>
        <range><min>0.10</min><max>30.0</max><resolution>0.01</resolution></range>
        <noise><type>gaussian</type><mean>0.0</mean><stddev>0.01</stddev></noise>
      </ray>
      <plugin name="gazebo_ros_head_hokuyo_controller" filename="libgazebo_ros_gpu_laser.so">
        <topicName>/rrbot/laser/scan</topicName>
        <frameName>hokuyo_link</frameName>
      </plugin>
    </sensor>
    <sensor type="ray" name="bad_laser">
      <ray><range><min>5</min><max>1</max></range></ray>
    </sensor>
  </gazebo>
</robot>)";
  std::vector<std::string> warnings;
  const auto s = sensors_from_urdf(urdf, &warnings);
  ASSERT_EQ(s.size(), 4u);
  EXPECT_EQ(s[0].type, SensorType::Camera);
  EXPECT_EQ(s[0].name, "camera1");
  EXPECT_EQ(s[0].link, "camera_link");
  EXPECT_EQ(s[0].rate, 30);  // updateRate 0 keeps <update_rate>
  EXPECT_EQ(s[0].camera.width, 800);
  EXPECT_EQ(s[0].camera.height, 800);
  EXPECT_NEAR(s[0].camera.hfov, 1.3962634, 1e-12);
  EXPECT_EQ(s[0].camera.near, 0.02);
  EXPECT_EQ(s[0].camera.far, 300);
  EXPECT_EQ(s[0].noise.stddev, 0.007);
  EXPECT_EQ(s[0].topic, "rrbot/camera1");
  EXPECT_EQ(s[0].image_topic, "image_raw");
  EXPECT_EQ(s[0].info_topic, "camera_info");
  EXPECT_EQ(s[0].frame, "camera_link_optical");
  EXPECT_EQ(s[1].type, SensorType::DepthCamera);
  EXPECT_EQ(s[1].rate, 20);
  EXPECT_EQ(s[1].camera.far, 3);
  EXPECT_EQ(s[1].topic, "kinect_ir");
  EXPECT_EQ(s[1].image_topic, "/kinect/color/image_raw");
  EXPECT_EQ(s[1].info_topic, "/kinect/color/camera_info");
  EXPECT_EQ(s[1].depth_topic, "/kinect/depth/image_raw");
  EXPECT_EQ(s[1].depth_info_topic, "/kinect/depth/camera_info");
  EXPECT_EQ(s[1].points_topic, "/kinect/depth/points");
  EXPECT_EQ(s[1].frame, "kinect_optical");
  EXPECT_EQ(s[2].type, SensorType::Ray);
  EXPECT_EQ(s[2].rate, 40);
  EXPECT_EQ(s[2].ray.samples, 720);
  EXPECT_NEAR(s[2].ray.angle_min, -1.570796, 1e-12);
  EXPECT_NEAR(s[2].ray.angle_max, 1.570796, 1e-12);
  EXPECT_EQ(s[2].ray.range_min, 0.1);
  EXPECT_EQ(s[2].ray.range_max, 30);
  EXPECT_EQ(s[2].ray.resolution, 0.01);
  EXPECT_EQ(s[2].noise.stddev, 0.01);
  EXPECT_EQ(s[2].topic, "/rrbot/laser/scan");
  EXPECT_EQ(s[2].frame, "hokuyo_link");
  EXPECT_EQ(s[3].ray.range_max, LaserSpec().range_max);  // the bad range: defaults, one warning
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("'bad_laser'"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("range max"), std::string::npos) << warnings[0];
}

// A robot after the first carries its own sensors (a robots: entry's sensors:): robot b, resting
// on the block, feels the block on its three links with its weight in all and its IMU reads +g;
// robot a, on the ground, feels the ground only, not b's contacts.
TEST(Sensors, RobotsAfterTheFirstCarryTheirOwnSensors) {
  const std::string sensors =
      " sensors: [{name: S_base, type: contact, link: base_link},"
      " {name: S_l1, type: contact, link: link1}, {name: S_l2, type: contact, link: link2},"
      " {name: S_imu, type: imu, link: base_link}],";
  auto robot = [&](const std::string& name, double x, double z) {
    std::string s = sensors;
    for (size_t p; (p = s.find("S_")) != std::string::npos;) s.replace(p, 1, name);
    return "  - {name: " + name + ", urdf: data/robots/double_pendulum_simple.urdf," + s +
           " base: free, locked_joints: {joint1: 1.5708, joint2: 0}, base_pose: {position: [" +
           std::to_string(x) + ", 0, " + std::to_string(z) + "]}}\n";
  };
  const std::string text =
      "gravity: [0, 0, -9.81]\nintegrator: contact_semi_implicit\ndt: 0.001\nground: true\n"
      "objects: [{name: block, shape: {box: [0.6, 0.6, 0.2]}, pose: {position: [2, 0, 0.1]}}]\n"
      "robots:\n" +
      robot("a", 0, 0.1) + robot("b", 2, 0.3);
  const Scene scene = parse_scene(text, kScenes, "two.yaml");
  ASSERT_EQ(scene.extra_robots.size(), 1u);
  ASSERT_EQ(scene.sensors.size(), 4u);  // robots[0]'s are the scene's (robot 0's)
  ASSERT_EQ(scene.extra_robots[0].sensors.size(), 4u);
  auto sim = make_simulator(scene);
  SensorSet sa(sim->robot_model(0), scene.sensors);
  SensorSet sb(sim->robot_model(1), scene.extra_robots[0].sensors, "", "b");
  const double g = 9.81;
  Vec3 fa = Vec3::Zero(), fb = Vec3::Zero();
  for (int k = 0; k < 1500; ++k) {
    sa.before_step(*sim);
    sb.before_step(*sim);
    const bool ok = sim->step();
    sa.after_step(*sim, ok);
    sb.after_step(*sim, ok);
    ASSERT_TRUE(ok) << sim->failure();
  }
  for (int i = 0; i < 3; ++i) {
    fa += sa.reading(i).total_force;
    fb += sb.reading(i).total_force;
    for (int t = 0; t < sa.reading(i).count; ++t) {
      EXPECT_EQ(sa.reading(i).touches[t].other, "ground");
    }
    for (int t = 0; t < sb.reading(i).count; ++t) {
      EXPECT_EQ(sb.reading(i).touches[t].other, "block");
      EXPECT_EQ(sb.reading(i).touches[t].self.compare(0, 2, "b/"), 0);
    }
  }
  const double weight = sim->robot_model(1).total_mass() * g;
  EXPECT_GT(sb.reading(0).count, 0);
  EXPECT_NEAR(fb.z(), weight, 0.05 * weight);
  EXPECT_NEAR(fa.z(), weight, 0.05 * weight);
  const SE3& base = sim->robot_state(1).base;
  const Vec3 up = base.R.transpose() * Vec3(0, 0, g);
  EXPECT_LT((sb.reading(3).linear_acceleration - up).norm(), 0.05 * g);
}

// One parse of a URDF serves the readers of its tags (sensors, transmissions): what each reads
// from the document is what it reads from the text.
TEST(Sensors, OneUrdfXmlForSensorsAndTransmissions) {
  const std::string urdf = R"(<robot name="r">
  <link name="base"/><link name="tool"/>
  <joint name="wrist" type="revolute"><parent link="base"/><child link="tool"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="5" velocity="1"/></joint>
  <transmission name="wrist_tr">
    <type>transmission_interface/SimpleTransmission</type>
    <joint name="wrist"><hardwareInterface>hardware_interface/EffortJointInterface</hardwareInterface></joint>
    <actuator name="wrist_motor"><mechanicalReduction>50</mechanicalReduction></actuator>
  </transmission>
  <gazebo reference="base">
    <sensor name="imu_sensor" type="imu"><update_rate>200</update_rate></sensor>
    <sensor name="sonar" type="sonar"/>
  </gazebo>
</robot>)";
  const UrdfXml doc(urdf);
  EXPECT_EQ(doc.error(), "");
  std::vector<std::string> w_text, w_doc;
  const auto s_text = sensors_from_urdf(urdf, &w_text);
  const auto s_doc = sensors_from_urdf(doc, &w_doc);
  ASSERT_EQ(s_doc.size(), 1u);
  ASSERT_EQ(s_text.size(), 1u);
  EXPECT_EQ(s_doc[0].name, "imu_sensor");
  EXPECT_EQ(s_doc[0].rate, s_text[0].rate);
  EXPECT_EQ(s_doc[0].where, s_text[0].where);
  EXPECT_EQ(w_doc, w_text);  // the sonar
  EXPECT_EQ(w_doc.size(), 1u);
  const auto t_doc = parse_transmissions(doc);
  const auto t_text = parse_transmissions(urdf);
  ASSERT_EQ(t_doc.size(), 1u);
  ASSERT_EQ(t_text.size(), 1u);
  EXPECT_EQ(t_doc[0].joint, "wrist");
  EXPECT_EQ(t_doc[0].reduction, 50);
  EXPECT_EQ(t_doc[0].interfaces, t_text[0].interfaces);
  EXPECT_EQ(t_doc[0].line, t_text[0].line);

  // XML that does not parse: the same warning, no transmissions.
  const std::string broken = "<robot name=\"r\"><link name=\"a\">";
  const UrdfXml bad(broken);
  EXPECT_NE(bad.error(), "");
  std::vector<std::string> b_text, b_doc;
  EXPECT_TRUE(sensors_from_urdf(bad, &b_doc).empty());
  EXPECT_TRUE(sensors_from_urdf(broken, &b_text).empty());
  EXPECT_EQ(b_doc, b_text);
  ASSERT_EQ(b_doc.size(), 1u);
  EXPECT_NE(b_doc[0].find("the XML does not parse"), std::string::npos) << b_doc[0];
  EXPECT_TRUE(parse_transmissions(bad).empty());
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
