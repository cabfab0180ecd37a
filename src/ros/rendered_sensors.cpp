// Cameras, depth cameras and laser scans of the simulator node, on a thread of their own.
#include "se3_sim/ros/rendered_sensors.h"

#include <image_transport/image_transport.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <random>
#include <thread>

#include "se3_sim/collision/laser.h"
#include "se3_sim/render/camera_sensor.h"
#include "se3_sim/ros/convert.h"
#include "se3_sim/sim/laser_world.h"

namespace se3_ros {

namespace {

// A topic inside the camera's namespace unless written absolute.
std::string join_topic(const std::string& ns, const std::string& name) {
  if (!name.empty() && name[0] == '/') return name;
  if (ns.empty()) return name;
  return ns + "/" + name;
}

// A scene object as cameras draw it, on frame `body`.
se3::render::DrawItem object_item(const se3::SceneObject& o, int body) {
  const Eigen::Vector3f rgb =
      o.material.has_color ? o.material.rgba.head<3>() : Eigen::Vector3f(0.7f, 0.7f, 0.7f);
  return se3::render::shape_item(o.shape, rgb, body, o.name);
}

std::string sensor_where(const se3::SensorSpec& s) {
  return "sensor '" + s.name + "'" + (s.where.empty() ? "" : " (" + s.where + ")");
}

}  // namespace

struct RenderedSensors::Impl {
  struct Sensor {
    se3::SensorSpec spec;
    int body = se3::GeometryObject::kWorld;  ///< kWorld: fixed in the world
    se3::SE3 in_body;                        ///< sensor frame (optical for cameras) in the body
    std::string frame;
    int period = 1;
    std::mt19937_64 rng;
    std::unique_ptr<se3::render::CameraSensor> camera;
    std::unique_ptr<se3::LaserScanner> laser;
    image_transport::Publisher image_pub, depth_pub;
    ros::Publisher info_pub, depth_info_pub, points_pub, scan_pub;
    sensor_msgs::Image image, depth;
    sensor_msgs::CameraInfo info;
    sensor_msgs::PointCloud2 points;
    sensor_msgs::LaserScan scan;
  };
  struct Frame {
    std::vector<se3::SE3> poses;  ///< bodies 0..n, then object j at n + 1 + j
    std::vector<char> due;
    double time = 0;
    bool full = false;
    /// The world's objects changed (spawned, deleted): what cameras draw and lasers scan is
    /// rebuilt from `objects` before this frame.
    bool world_changed = false;
    std::vector<se3::SceneObject> objects;
  };

  std::vector<Sensor> sensors;
  std::unique_ptr<se3::CollisionModel> collision;  ///< for lasers
  std::vector<se3::render::DrawItem> robot_items;  ///< the robot's visuals (cameras)
  se3::GeometryModel geometry;                     ///< the robot's collisions (lasers)
  se3::ConstraintSpec ground;                      ///< the scene's ground (lasers)
  bool any_camera = false, any_laser = false;
  std::uint64_t generation = ~std::uint64_t(0);  ///< Simulator::world_generation shown
  std::vector<geometry_msgs::TransformStamped> tfs;
  bool use_sim_time = false;
  bool wait = false;
  int nbodies = 0;
  double dt = 0;

  std::mutex mu;
  std::condition_variable cv;
  Frame pending, work;
  std::vector<se3::SE3> links;  ///< link_poses' output (its body_poses() are what is used)
  bool busy = false, quit = false;
  long dropped = 0;
  std::thread thread;

  void loop();
  /// Cameras' items and the lasers' collision model for these objects (allocates).
  void set_objects(const std::vector<se3::SceneObject>& objects);
  void publish(Frame& f);
  void publish_camera(Sensor& s, const Frame& f, const ros::Time& stamp);
  void publish_scan(Sensor& s, const Frame& f, const ros::Time& stamp);
};

RenderedSensors::RenderedSensors(ros::NodeHandle& nh, const se3::Scene& scene,
                                 const se3::Model& model, const se3::GeometryModel& geometry,
                                 const std::vector<se3::SensorSpec>& specs,
                                 const std::string& world_frame, bool use_sim_time, bool wait)
    : impl_(new Impl) {
  Impl& I = *impl_;
  I.use_sim_time = use_sim_time;
  I.wait = wait;
  I.nbodies = model.n + 1;
  const int nobj = int(scene.objects.size());
  const bool ground = scene.constraints.ground;

  // What cameras draw: the robot's visuals, then each object as an item on its own pose; what
  // lasers scan: the collision layer's shapes (set_objects, again when the objects change).
  for (const se3::SensorSpec& s : specs) {
    I.any_camera = I.any_camera || s.type != se3::SensorType::Ray;
    I.any_laser = I.any_laser || s.type == se3::SensorType::Ray;
  }
  if (I.any_camera) I.robot_items = se3::render::make_draw_items(model, geometry);
  if (I.any_laser) {
    I.geometry.collisions = geometry.collisions;
    I.ground = scene.constraints;
    I.collision = std::make_unique<se3::CollisionModel>(
        se3::laser_world(I.geometry, I.nbodies, scene.objects, I.ground), se3::CollisionOptions());
  }

  image_transport::ImageTransport it(nh);
  for (const se3::SensorSpec& s : specs) {
    Impl::Sensor x;
    x.spec = s;
    x.rng.seed(se3::SensorSet::seed_of(s.name));
    const bool world = s.link == "world" || s.link == world_frame;
    std::string link = world_frame;
    se3::SE3 offset;
    if (!world) {
      const int li = model.link_index(s.link);
      if (li < 0) {
        throw se3::SensorError(sensor_where(s) + ": link '" + s.link + "' is not in the robot");
      }
      x.body = model.links[li].body;
      offset = model.links[li].offset;
      link = se3::frame_name(s.link);
    }
    const bool camera = s.type != se3::SensorType::Ray;
    const se3::SE3 optical(camera ? se3::render::optical_in_body() : se3::Mat3::Identity(),
                           se3::Vec3::Zero());
    const se3::SE3 in_link = s.pose * optical;
    x.in_body = offset * in_link;
    // The frame: given, else the link itself when the sensor sits at its origin (lasers), else
    // one of the sensor's own on /tf_static (cameras: <name>_optical_frame).
    x.frame = s.frame;
    if (x.frame.empty()) {
      x.frame =
          camera ? s.name + "_optical_frame" : (s.pose.isApprox(se3::SE3(), 1e-12) ? link : s.name);
      if (x.frame != link) {
        geometry_msgs::TransformStamped t;
        t.header.frame_id = link;
        t.child_frame_id = x.frame;
        t.transform = to_transform(in_link);
        I.tfs.push_back(t);
      }
    }
    const std::string ns = s.topic.empty() ? s.name : s.topic;
    if (camera) {
      se3::render::CameraSensorSpec cs;
      cs.width = s.camera.width;
      cs.height = s.camera.height;
      cs.hfov = s.camera.hfov;
      cs.near = s.camera.near;
      cs.far = s.camera.far;
      cs.depth = s.type == se3::SensorType::DepthCamera;
      cs.ground = ground && scene.constraints.ground_normal.isApprox(se3::Vec3::UnitZ()) &&
                  scene.constraints.ground_offset == 0;
      std::string err;
      if (!se3::render::check_camera_spec(cs, &err)) {
        throw se3::SensorError(sensor_where(s) + ": " + err);
      }
      x.camera = std::make_unique<se3::render::CameraSensor>(cs);
      const se3::render::CameraIntrinsics& k = x.camera->intrinsics();
      x.info.width = k.width;
      x.info.height = k.height;
      x.info.distortion_model = "plumb_bob";
      x.info.D.assign(5, 0.0);
      std::copy(k.K.begin(), k.K.end(), x.info.K.begin());
      x.info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
      std::copy(k.P.begin(), k.P.end(), x.info.P.begin());
      x.info.header.frame_id = x.frame;
      x.image.header.frame_id = x.frame;
      x.image.width = k.width;
      x.image.height = k.height;
      x.image.encoding = "rgb8";
      x.image.step = 3 * k.width;
      x.image.data.resize(std::size_t(3) * k.width * k.height);
      x.image_pub = it.advertise(join_topic(ns, s.image_topic), 2);
      x.info_pub = nh.advertise<sensor_msgs::CameraInfo>(join_topic(ns, s.info_topic), 2);
      if (cs.depth) {
        x.depth.header.frame_id = x.frame;
        x.depth.width = k.width;
        x.depth.height = k.height;
        x.depth.encoding = "32FC1";
        x.depth.step = 4 * k.width;
        x.depth.data.resize(std::size_t(4) * k.width * k.height);
        x.points.header.frame_id = x.frame;
        x.points.width = k.width;
        x.points.height = k.height;
        const char* names[4] = {"x", "y", "z", "rgb"};
        for (int f = 0; f < 4; ++f) {
          sensor_msgs::PointField pf;
          pf.name = names[f];
          pf.offset = 4 * f;
          pf.datatype = sensor_msgs::PointField::FLOAT32;
          pf.count = 1;
          x.points.fields.push_back(pf);
        }
        x.points.point_step = 16;
        x.points.row_step = 16 * k.width;
        x.points.is_dense = false;
        x.points.data.resize(std::size_t(16) * k.width * k.height);
        x.depth_pub = it.advertise(join_topic(ns, s.depth_topic), 2);
        x.depth_info_pub =
            nh.advertise<sensor_msgs::CameraInfo>(join_topic(ns, s.depth_info_topic), 2);
        x.points_pub = nh.advertise<sensor_msgs::PointCloud2>(join_topic(ns, s.points_topic), 2);
      }
      ROS_INFO("simulator: sensor %s, %s %dx%d (hfov %g rad) on %s in frame %s at %g Hz",
               s.name.c_str(), cs.depth ? "depth_camera" : "camera", k.width, k.height, cs.hfov,
               x.image_pub.getTopic().c_str(), x.frame.c_str(), s.rate);
    } else {
      std::string err;
      if (!se3::check_laser_spec(s.ray, &err)) {
        throw se3::SensorError(sensor_where(s) + ": " + err);
      }
      x.laser = std::make_unique<se3::LaserScanner>(*I.collision, s.ray);
      x.scan.header.frame_id = x.frame;
      x.scan.angle_min = float(s.ray.angle_min);
      x.scan.angle_max = float(s.ray.angle_max);
      x.scan.angle_increment = float(s.ray.increment());
      x.scan.time_increment = 0;
      x.scan.scan_time = s.rate > 0 ? float(1.0 / s.rate) : 0.0f;
      x.scan.range_min = float(s.ray.range_min);
      x.scan.range_max = float(s.ray.range_max);
      x.scan.ranges.resize(s.ray.samples);
      x.scan_pub = nh.advertise<sensor_msgs::LaserScan>(ns, 2);
      ROS_INFO(
          "simulator: sensor %s, ray (sensor_msgs/LaserScan, %d samples) on %s in frame %s "
          "at %g Hz",
          s.name.c_str(), s.ray.samples, x.scan_pub.getTopic().c_str(), x.frame.c_str(), s.rate);
    }
    I.sensors.push_back(std::move(x));
  }
  if (I.any_camera) {
    std::vector<se3::render::DrawItem> items = I.robot_items;
    for (int j = 0; j < nobj; ++j) items.push_back(object_item(scene.objects[j], I.nbodies + j));
    for (Impl::Sensor& x : I.sensors) {
      if (x.camera) x.camera->set_items(items);
    }
  }
  for (Impl::Frame* f : {&I.pending, &I.work}) {
    f->poses.assign(I.nbodies + nobj, se3::SE3());
    f->due.assign(I.sensors.size(), 0);
  }
  I.thread = std::thread([this] { impl_->loop(); });
}

RenderedSensors::~RenderedSensors() {
  {
    std::lock_guard<std::mutex> lock(impl_->mu);
    impl_->quit = true;
  }
  impl_->cv.notify_all();
  if (impl_->thread.joinable()) impl_->thread.join();
}

const std::vector<geometry_msgs::TransformStamped>& RenderedSensors::static_transforms() const {
  return impl_->tfs;
}

long RenderedSensors::dropped() const {
  std::lock_guard<std::mutex> lock(impl_->mu);
  return impl_->dropped;
}

void RenderedSensors::after_step(se3::Simulator& sim) {
  Impl& I = *impl_;
  if (sim.dt() != I.dt) {
    I.dt = sim.dt();
    for (Impl::Sensor& s : I.sensors) {
      const double rate = s.spec.rate;
      s.period = rate > 0 ? int(std::max(1.0, std::round(1.0 / (rate * I.dt)))) : 1;
    }
  }
  const std::uint64_t k = sim.steps();
  bool any = false;
  for (const Impl::Sensor& s : I.sensors) any = any || k % std::uint64_t(s.period) == 0;
  if (!any) return;
  std::unique_lock<std::mutex> lock(I.mu);
  if (I.wait) I.cv.wait(lock, [&] { return !I.pending.full; });
  sim.link_poses(I.links);  // computes body_poses() too
  const std::vector<se3::SE3>& oMb = sim.body_poses();
  Impl::Frame& f = I.pending;
  const std::vector<se3::ObjectState>& objs = sim.objects();
  if (sim.world_generation() != I.generation) {
    // Objects spawned or deleted: the thread rebuilds what it draws before this frame (a frame
    // replaced before it was taken passes the change on). Allocates, on a change only.
    I.generation = sim.world_generation();
    f.objects = sim.object_specs();
    f.world_changed = true;
  }
  if (f.poses.size() != I.nbodies + objs.size()) f.poses.resize(I.nbodies + objs.size());
  for (int b = 0; b < I.nbodies && b < int(oMb.size()); ++b) f.poses[b] = oMb[b];
  for (std::size_t j = 0; j < objs.size() && I.nbodies + j < f.poses.size(); ++j) {
    f.poses[I.nbodies + j] = objs[j].pose;
  }
  // A frame not yet taken is replaced whole: its sensors show this state only if due now (a
  // stamp stays on its sensor's rate), the others lose that frame.
  for (std::size_t i = 0; i < I.sensors.size(); ++i) {
    const bool due = k % std::uint64_t(I.sensors[i].period) == 0;
    if (f.full && f.due[i]) ++I.dropped;
    f.due[i] = char(due);
  }
  f.time = sim.time();
  f.full = true;
  lock.unlock();
  I.cv.notify_all();
}

void RenderedSensors::flush() {
  Impl& I = *impl_;
  std::unique_lock<std::mutex> lock(I.mu);
  I.cv.wait(lock, [&] { return !I.pending.full && !I.busy; });
}

void RenderedSensors::Impl::loop() {
  std::unique_lock<std::mutex> lock(mu);
  while (true) {
    cv.wait(lock, [&] { return quit || pending.full; });
    if (quit) return;
    std::swap(pending, work);
    pending.full = false;
    busy = true;
    lock.unlock();
    cv.notify_all();
    publish(work);
    lock.lock();
    busy = false;
    cv.notify_all();
  }
}

void RenderedSensors::reset() {
  Impl& I = *impl_;
  std::unique_lock<std::mutex> lock(I.mu);
  // A frame of the state before the reset is not published after it; the one being drawn is
  // finished first, then every sensor's noise restarts from its seed.
  if (I.pending.full) {
    I.pending.full = false;
    for (char& d : I.pending.due) d = 0;
  }
  I.cv.wait(lock, [&] { return !I.busy; });
  for (Impl::Sensor& s : I.sensors) s.rng.seed(se3::SensorSet::seed_of(s.spec.name));
  lock.unlock();
  I.cv.notify_all();  // a flush() waiting for the dropped frame
}

void RenderedSensors::Impl::set_objects(const std::vector<se3::SceneObject>& objects) {
  if (any_camera) {
    std::vector<se3::render::DrawItem> items = robot_items;
    for (std::size_t j = 0; j < objects.size(); ++j) {
      items.push_back(object_item(objects[j], nbodies + int(j)));
    }
    for (Sensor& s : sensors) {
      if (s.camera) s.camera->set_items(items);
    }
  }
  if (any_laser) {
    auto model = std::make_unique<se3::CollisionModel>(
        se3::laser_world(geometry, nbodies, objects, ground), se3::CollisionOptions());
    for (Sensor& s : sensors) {
      if (s.laser) s.laser = std::make_unique<se3::LaserScanner>(*model, s.spec.ray);
    }
    collision = std::move(model);
  }
}

void RenderedSensors::Impl::publish(Frame& f) {
  if (f.world_changed) {
    set_objects(f.objects);
    f.world_changed = false;
  }
  const ros::Time stamp = use_sim_time ? ros::Time(f.time) : ros::Time::now();
  for (std::size_t i = 0; i < sensors.size(); ++i) {
    if (!f.due[i]) continue;
    Sensor& s = sensors[i];
    if (s.camera) {
      publish_camera(s, f, stamp);
    } else {
      publish_scan(s, f, stamp);
    }
  }
}

void RenderedSensors::Impl::publish_camera(Sensor& s, const Frame& f, const ros::Time& stamp) {
  const se3::SE3 body = s.body == se3::GeometryObject::kWorld ? se3::SE3() : f.poses[s.body];
  const se3::SE3 oMc = body * s.in_body;
  if (!oMc.R.allFinite() || !oMc.p.allFinite()) return;  // never a frame from a broken pose
  // A depth camera draws colour only for someone: the image's or the cloud's subscribers
  // (the depth is the same bits either way).
  if (s.depth_pub) {
    s.camera->set_color(s.image_pub.getNumSubscribers() > 0 ||
                        s.points_pub.getNumSubscribers() > 0);
  }
  // The frame straight into the messages' buffers (no copy of it), but for a noisy image, which
  // is made from the camera's own.
  const se3::SensorNoise& n = s.spec.noise;
  se3::render::CameraOutputs out;
  if (!n.any()) out.rgb = s.image.data.data();
  if (s.depth_pub) {
    out.depth = reinterpret_cast<float*>(s.depth.data.data());
    out.cloud = reinterpret_cast<float*>(s.points.data.data());
  }
  s.camera->render(oMc, f.poses, {}, out);
  const std::vector<uint8_t>& rgb = s.camera->rgb();
  if (!s.camera->color()) {
    // Nobody reads the colour image: only its CameraInfo goes out.
  } else if (n.any()) {
    // Gaussian noise on the intensities (as Gazebo's camera noise: stddev in [0, 1] units).
    std::normal_distribution<double> g(n.mean, n.stddev);
    for (std::size_t k = 0; k < rgb.size(); ++k) {
      const double v = rgb[k] + 255.0 * (n.stddev > 0 ? g(s.rng) : n.mean);
      s.image.data[k] = uint8_t(std::clamp(std::lround(v), 0L, 255L));
    }
  }
  s.image.header.stamp = stamp;
  s.info.header.stamp = stamp;
  if (s.camera->color()) s.image_pub.publish(s.image);
  s.info_pub.publish(s.info);
  if (!s.depth_pub) return;
  if (n.any()) {
    // Depth noise in metres along the ray: the depth and the point move together.
    std::normal_distribution<double> g(n.mean, n.stddev);
    float* d = reinterpret_cast<float*>(s.depth.data.data());
    float* p = reinterpret_cast<float*>(s.points.data.data());
    for (std::size_t k = 0; k < s.depth.data.size() / 4; ++k) {
      if (!std::isfinite(d[k])) continue;
      const double scale = 1.0 + (n.stddev > 0 ? g(s.rng) : n.mean) / d[k];
      d[k] = float(d[k] * scale);
      for (int c = 0; c < 3; ++c) p[4 * k + c] = float(p[4 * k + c] * scale);
    }
  }
  s.depth.header.stamp = stamp;
  s.points.header.stamp = stamp;
  s.depth_pub.publish(s.depth);
  s.depth_info_pub.publish(s.info);
  s.points_pub.publish(s.points);
}

void RenderedSensors::Impl::publish_scan(Sensor& s, const Frame& f, const ros::Time& stamp) {
  const se3::SE3 body = s.body == se3::GeometryObject::kWorld ? se3::SE3() : f.poses[s.body];
  const se3::SE3 oMs = body * s.in_body;
  if (!oMs.R.allFinite() || !oMs.p.allFinite()) return;
  s.laser->scan(oMs, f.poses);
  const std::vector<float>& r = s.laser->ranges();
  const se3::SensorNoise& n = s.spec.noise;
  std::normal_distribution<double> g(n.mean, n.stddev > 0 ? n.stddev : 1.0);
  for (std::size_t k = 0; k < r.size(); ++k) {
    float v = r[k];
    if (n.any() && std::isfinite(v)) v = float(v + (n.stddev > 0 ? g(s.rng) : n.mean));
    s.scan.ranges[k] = v;
  }
  s.scan.header.stamp = stamp;
  s.scan_pub.publish(s.scan);
}

}  // namespace se3_ros
