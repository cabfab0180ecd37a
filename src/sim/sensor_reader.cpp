// Sensor declarations (sensors.h): a scene's `sensors:` list and a URDF's Gazebo tags.
#include <tinyxml2.h>

#include <cmath>
#include <cstdlib>
#include <set>

#include "../model/xml_text.h"
#include "scene_reader.h"
#include "se3_sim/model/urdf_xml.h"
#include "se3_sim/sim/sensors.h"

namespace se3 {

using Field = SceneReader::Field;

// sensors: [{name, type, link | joint, pose: {position, orientation}, rate,
//            noise: {mean, stddev, bias}, topic, frame,
//            camera, depth_camera: width, height, horizontal_fov, near, far;
//            ray: samples, min_angle, max_angle, range_min, range_max, range_resolution}, ...]
void read_scene_sensors(const SceneReader& r, const Field& v, std::vector<SensorSpec>& out) {
  static const char* kTypes = "imu, force_torque, contact, camera, depth_camera, ray";
  static const std::set<std::string> kCameraKeys = {"width", "height", "horizontal_fov", "near",
                                                    "far"};
  static const std::set<std::string> kRayKeys = {"samples",   "min_angle", "max_angle",
                                                 "range_min", "range_max", "range_resolution"};
  std::set<std::string> names;
  for (const Field& item : r.items(v, 1000)) {
    SensorSpec s;
    s.where = r.file() + ":" + std::to_string(item.line);
    bool has_type = false;
    const Field* place = nullptr;
    std::vector<Field> fs = r.fields(
        item, {"name",      "type",           "link",      "joint",     "pose",
               "rate",      "noise",          "topic",     "frame",     "width",
               "height",    "horizontal_fov", "near",      "far",       "samples",
               "min_angle", "max_angle",      "range_min", "range_max", "range_resolution"});
    for (const Field& f : fs) {
      if (f.name == "type") {
        const std::string t = r.text(f);
        if (t == "imu") {
          s.type = SensorType::Imu;
        } else if (t == "force_torque") {
          s.type = SensorType::ForceTorque;
        } else if (t == "contact") {
          s.type = SensorType::Contact;
        } else if (t == "camera") {
          s.type = SensorType::Camera;
        } else if (t == "depth_camera") {
          s.type = SensorType::DepthCamera;
        } else if (t == "ray") {
          s.type = SensorType::Ray;
        } else {
          r.fail(f, "unknown sensor type '" + t + "' (" + kTypes + ")");
        }
        has_type = true;
      }
    }
    if (!has_type) r.fail(item, "'" + item.key + "' needs type: " + kTypes);
    const bool camera = s.type == SensorType::Camera || s.type == SensorType::DepthCamera;
    const bool ray = s.type == SensorType::Ray;
    const Field* far_field = nullptr;
    const Field* range_max_field = nullptr;
    const Field* angle_field = nullptr;
    for (const Field& f : fs) {
      if (kCameraKeys.count(f.name) && !camera) {
        r.fail(f, "'" + f.name + "' is a camera's key (type camera or depth_camera)");
      }
      if (kRayKeys.count(f.name) && !ray) r.fail(f, "'" + f.name + "' is a ray sensor's key");
      if (f.name == "width") {
        s.camera.width = int(r.integer(f, 1, 8192));
      } else if (f.name == "height") {
        s.camera.height = int(r.integer(f, 1, 8192));
      } else if (f.name == "horizontal_fov") {
        s.camera.hfov = r.in_range(f, 1e-3, 3.14);
      } else if (f.name == "near") {
        s.camera.near = r.in_range(f, 1e-4, 1e4);
      } else if (f.name == "far") {
        s.camera.far = r.in_range(f, 1e-4, 1e6);
        far_field = &f;
      } else if (f.name == "samples") {
        s.ray.samples = int(r.integer(f, 1, 100000));
      } else if (f.name == "min_angle") {
        s.ray.angle_min = r.in_range(f, -2 * M_PI, 2 * M_PI);
        angle_field = &f;
      } else if (f.name == "max_angle") {
        s.ray.angle_max = r.in_range(f, -2 * M_PI, 2 * M_PI);
        angle_field = &f;
      } else if (f.name == "range_min") {
        s.ray.range_min = r.in_range(f, 0, 1e6);
      } else if (f.name == "range_max") {
        s.ray.range_max = r.in_range(f, 1e-4, 1e6);
        range_max_field = &f;
      } else if (f.name == "range_resolution") {
        s.ray.resolution = r.in_range(f, 0, 1e3);
      }
    }
    if (camera && !(s.camera.far > s.camera.near)) {
      r.fail(far_field ? *far_field : item, "far must be greater than near");
    }
    if (ray && !(s.ray.range_max > s.ray.range_min)) {
      r.fail(range_max_field ? *range_max_field : item, "range_max must be greater than range_min");
    }
    if (ray && s.ray.angle_min > s.ray.angle_max) {
      r.fail(angle_field ? *angle_field : item, "min_angle must not exceed max_angle");
    }
    for (const Field& f : fs) {
      if (f.name == "name") {
        s.name = r.text(f);
        if (!names.insert(s.name).second) r.fail(f, "sensor '" + s.name + "' named twice");
      } else if (f.name == "link") {
        if (s.type == SensorType::ForceTorque) {
          r.fail(f, "a force_torque sensor is on a joint: 'joint', not 'link'");
        }
        s.link = r.text(f);
        place = &f;
      } else if (f.name == "joint") {
        if (s.type != SensorType::ForceTorque) {
          r.fail(f, "only a force_torque sensor is on a joint; this one needs 'link'");
        }
        s.joint = r.text(f);
        place = &f;
      } else if (f.name == "pose") {
        for (const Field& p : r.fields(f, {"position", "orientation"})) {
          if (p.name == "position") {
            s.pose.p = r.vec3(p);
          } else {
            const auto q = r.numbers(p, 4, 4);
            const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
            if (std::abs(n - 1) > 1e-3)
              r.fail(p, "orientation (x, y, z, w) is not a unit quaternion");
            s.pose.R = rotation_from_quaternion(q[0] / n, q[1] / n, q[2] / n, q[3] / n);
          }
        }
      } else if (f.name == "rate") {
        s.rate = r.in_range(f, 0, 1e6);
      } else if (f.name == "noise") {
        for (const Field& p : r.fields(f, {"mean", "stddev", "bias"})) {
          if (p.name == "mean") s.noise.mean = r.number(p);
          if (p.name == "stddev") s.noise.stddev = r.non_negative(p);
          if (p.name == "bias") s.noise.bias = r.non_negative(p);
        }
      } else if (f.name == "topic") {
        s.topic = r.text(f);
      } else if (f.name == "frame") {
        s.frame = r.text(f);
      }
    }
    if (s.name.empty()) r.fail(item, "'" + item.key + "' needs a name");
    if (!place) {
      r.fail(item, "sensor '" + s.name + "' needs " +
                       (s.type == SensorType::ForceTorque ? "joint" : "link"));
    }
    out.push_back(std::move(s));
  }
}

namespace {

const char* child_text(const tinyxml2::XMLElement* e, const char* name) {
  const tinyxml2::XMLElement* c = e ? e->FirstChildElement(name) : nullptr;
  return c && c->GetText() ? c->GetText() : nullptr;
}

bool child_number(const tinyxml2::XMLElement* e, const char* name, double* out) {
  const char* t = child_text(e, name);
  if (!t) return false;
  char* end = nullptr;
  const double v = std::strtod(t, &end);
  if (end == t || !std::isfinite(v)) return false;
  *out = v;
  return true;
}

using xml_text::trimmed;

// SDF's <noise><type>gaussian</type><mean/><stddev/><bias_mean/></noise>, or the older IMU
// <noise><rate>...</rate><accel>...</accel></noise> (accel's numbers taken).
void read_noise(const tinyxml2::XMLElement* noise, SensorNoise& n) {
  if (!noise) return;
  const tinyxml2::XMLElement* src = noise;
  if (!child_text(noise, "mean") && !child_text(noise, "stddev")) {
    if (noise->FirstChildElement("accel")) src = noise->FirstChildElement("accel");
  }
  child_number(src, "mean", &n.mean);
  double sd = 0;
  if (child_number(src, "stddev", &sd)) n.stddev = std::abs(sd);
  double b = 0;
  if (child_number(src, "bias_stddev", &b)) n.bias = std::abs(b);
  double bm = 0;
  if (child_number(src, "bias_mean", &bm)) n.mean += bm;
}

// The gazebo_ros plugin's parameters: topicName, frameName, bodyName, jointName, updateRate
// (or updateRateHZ), gaussianNoise, bumperTopicName.
void read_plugin(const tinyxml2::XMLElement* p, SensorSpec& s) {
  if (const char* t = child_text(p, "topicName")) s.topic = trimmed(t);
  if (const char* t = child_text(p, "bumperTopicName")) s.topic = trimmed(t);
  // Cameras (libgazebo_ros_camera.so, libgazebo_ros_openni_kinect.so): cameraName is the
  // namespace of the image topics.
  if (const char* t = child_text(p, "cameraName")) s.topic = trimmed(t);
  if (const char* t = child_text(p, "imageTopicName")) s.image_topic = trimmed(t);
  if (const char* t = child_text(p, "cameraInfoTopicName")) s.info_topic = trimmed(t);
  if (const char* t = child_text(p, "depthImageTopicName")) s.depth_topic = trimmed(t);
  if (const char* t = child_text(p, "depthImageCameraInfoTopicName"))
    s.depth_info_topic = trimmed(t);
  if (const char* t = child_text(p, "pointCloudTopicName")) s.points_topic = trimmed(t);
  if (const char* t = child_text(p, "frameName")) s.frame = trimmed(t);
  if (const char* t = child_text(p, "bodyName")) s.link = trimmed(t);
  if (const char* t = child_text(p, "jointName")) s.joint = trimmed(t);
  double rate = 0;
  if (child_number(p, "updateRate", &rate) || child_number(p, "updateRateHZ", &rate)) {
    // A camera's or laser's updateRate 0 (gazebo_ros: "as the sensor") keeps <update_rate>.
    if (rate > 0 || (rate == 0 && !sensor_is_rendered(s.type))) s.rate = rate;
  }
  double g = 0;
  if (child_number(p, "gaussianNoise", &g)) s.noise.stddev = std::abs(g);
}

// <camera><horizontal_fov/><image><width/><height/></image><clip><near/><far/></clip>
// <noise/></camera>. Values out of range: one warning each, the default kept.
template <class Warn>
void read_camera(const tinyxml2::XMLElement* c, SensorSpec& s, Warn&& warn) {
  if (!c) return;
  const std::string at = s.where + ": sensor '" + s.name + "': ";
  double v = 0;
  if (child_number(c, "horizontal_fov", &v)) {
    if (v > 1e-3 && v < 3.14) {
      s.camera.hfov = v;
    } else {
      warn(at + "horizontal_fov " + std::to_string(v) + " is not in (0, pi); default kept");
    }
  }
  if (const auto* im = c->FirstChildElement("image")) {
    if (child_number(im, "width", &v)) {
      if (v >= 1 && v <= 8192) {
        s.camera.width = int(v);
      } else {
        warn(at + "image width " + std::to_string(v) + " is not in [1, 8192]; default kept");
      }
    }
    if (child_number(im, "height", &v)) {
      if (v >= 1 && v <= 8192) {
        s.camera.height = int(v);
      } else {
        warn(at + "image height " + std::to_string(v) + " is not in [1, 8192]; default kept");
      }
    }
  }
  if (const auto* clip = c->FirstChildElement("clip")) {
    double n = s.camera.near, f = s.camera.far;
    child_number(clip, "near", &n);
    child_number(clip, "far", &f);
    if (n > 0 && f > n) {
      s.camera.near = n;
      s.camera.far = f;
    } else {
      warn(at + "clip near " + std::to_string(n) + ", far " + std::to_string(f) +
           " need 0 < near < far; defaults kept");
    }
  }
  read_noise(c->FirstChildElement("noise"), s.noise);
}

// <ray><scan><horizontal><samples/><resolution/><min_angle/><max_angle/></horizontal></scan>
// <range><min/><max/><resolution/></range><noise/></ray>. Gazebo's horizontal resolution
// multiplies the samples (samples * resolution rays, usually 1).
template <class Warn>
void read_ray(const tinyxml2::XMLElement* r, SensorSpec& s, Warn&& warn) {
  if (!r) return;
  const std::string at = s.where + ": sensor '" + s.name + "': ";
  LaserSpec l = s.ray;
  double v = 0;
  const tinyxml2::XMLElement* scan = r->FirstChildElement("scan");
  if (const auto* h = scan ? scan->FirstChildElement("horizontal") : nullptr) {
    double res = 1;
    child_number(h, "resolution", &res);
    if (child_number(h, "samples", &v)) l.samples = int(std::lround(v * (res > 0 ? res : 1)));
    child_number(h, "min_angle", &l.angle_min);
    child_number(h, "max_angle", &l.angle_max);
  }
  if (const auto* range = r->FirstChildElement("range")) {
    child_number(range, "min", &l.range_min);
    child_number(range, "max", &l.range_max);
    child_number(range, "resolution", &l.resolution);
  }
  std::string err;
  if (check_laser_spec(l, &err)) {
    s.ray = l;
  } else {
    warn(at + err + "; the defaults are kept");
  }
  read_noise(r->FirstChildElement("noise"), s.noise);
}

bool known_plugin(const std::string& file) {
  return file == "libgazebo_ros_imu_sensor.so" || file == "libgazebo_ros_imu.so" ||
         file == "libgazebo_ros_ft_sensor.so" || file == "libgazebo_ros_bumper.so" ||
         file == "libgazebo_ros_camera.so" || file == "libgazebo_ros_openni_kinect.so" ||
         file == "libgazebo_ros_depth_camera.so" || file == "libgazebo_ros_laser.so" ||
         file == "libgazebo_ros_gpu_laser.so";
}

std::string plugin_name(const tinyxml2::XMLElement* p) {
  const char* f = p->Attribute("filename");
  return f ? f : "";
}

}  // namespace

std::vector<SensorSpec> sensors_from_urdf(const std::string& urdf_xml,
                                          std::vector<std::string>* warnings) {
  return sensors_from_urdf(UrdfXml(urdf_xml), warnings);
}

std::vector<SensorSpec> sensors_from_urdf(const UrdfXml& urdf, std::vector<std::string>* warnings) {
  std::vector<SensorSpec> out;
  auto warn = [&](const std::string& w) {
    if (warnings) warnings->push_back(w);
  };
  if (!urdf.error().empty()) {
    warn("URDF sensors: the XML does not parse (" + urdf.error() + ")");
    return out;
  }
  const tinyxml2::XMLElement* robot = urdf.robot();
  if (!robot) return out;
  for (const auto* g = robot->FirstChildElement("gazebo"); g; g = g->NextSiblingElement("gazebo")) {
    const char* ref = g->Attribute("reference");
    const int line = g->GetLineNum();
    // <sensor> elements on a link.
    for (const auto* se = g->FirstChildElement("sensor"); se;
         se = se->NextSiblingElement("sensor")) {
      const std::string type = se->Attribute("type") ? se->Attribute("type") : "";
      const std::string name = se->Attribute("name") ? se->Attribute("name") : "";
      const bool camera = type == "camera" || type == "depth";
      const bool ray = type == "ray" || type == "gpu_ray";
      if (type != "imu" && type != "contact" && !camera && !ray) {
        warn("URDF line " + std::to_string(se->GetLineNum()) + ": sensor '" + name + "' of type '" +
             type + "' is not supported (imu, contact, camera, depth, ray, gpu_ray); ignored");
        continue;
      }
      if (!ref) {
        warn("URDF line " + std::to_string(se->GetLineNum()) + ": sensor '" + name +
             "' is not in a <gazebo reference=\"LINK\">; ignored");
        continue;
      }
      SensorSpec s;
      s.name = name.empty() ? std::string(ref) + "_" + type : name;
      s.type = type == "imu" ? SensorType::Imu : SensorType::Contact;
      if (camera) s.type = type == "depth" ? SensorType::DepthCamera : SensorType::Camera;
      if (ray) s.type = SensorType::Ray;
      s.link = ref;
      s.where = "URDF line " + std::to_string(se->GetLineNum());
      if (camera) read_camera(se->FirstChildElement("camera"), s, warn);
      if (ray) read_ray(se->FirstChildElement("ray"), s, warn);
      double rate = 0;
      if (child_number(se, "update_rate", &rate) && rate >= 0) s.rate = rate;
      if (const char* pose = child_text(se, "pose")) {
        double v[6] = {0, 0, 0, 0, 0, 0};
        char* p = const_cast<char*>(pose);
        for (double& x : v) x = std::strtod(p, &p);
        s.pose.p = Vec3(v[0], v[1], v[2]);
        s.pose.R =
            exp_so3(Vec3(0, 0, v[5])) * exp_so3(Vec3(0, v[4], 0)) * exp_so3(Vec3(v[3], 0, 0));
      }
      read_noise(se->FirstChildElement("noise"), s.noise);
      if (const auto* imu = se->FirstChildElement("imu"))
        read_noise(imu->FirstChildElement("noise"), s.noise);
      for (const auto* p = se->FirstChildElement("plugin"); p;
           p = p->NextSiblingElement("plugin")) {
        const std::string file = plugin_name(p);
        if (!known_plugin(file)) {
          warn("URDF line " + std::to_string(p->GetLineNum()) + ": plugin '" + file +
               "' of sensor '" + s.name + "' is not supported; its parameters are ignored");
          continue;
        }
        read_plugin(p, s);
        s.link = ref;  // a sensor's body is its reference link
      }
      if (s.topic.empty()) s.topic = s.name;
      out.push_back(std::move(s));
    }
    // Model plugins directly under <gazebo>: the IMU (libgazebo_ros_imu.so, bodyName) and the
    // force-torque sensor (libgazebo_ros_ft_sensor.so, jointName).
    for (const auto* p = g->FirstChildElement("plugin"); p; p = p->NextSiblingElement("plugin")) {
      const std::string file = plugin_name(p);
      const std::string pname = p->Attribute("name") ? p->Attribute("name") : "";
      if (file != "libgazebo_ros_imu.so" && file != "libgazebo_ros_ft_sensor.so") {
        if (file.rfind("libgazebo_ros_", 0) == 0 && file.find("control") == std::string::npos) {
          warn("URDF line " + std::to_string(p->GetLineNum()) + ": plugin '" + file +
               "' is not supported; ignored");
        }
        continue;
      }
      SensorSpec s;
      s.type = file == "libgazebo_ros_imu.so" ? SensorType::Imu : SensorType::ForceTorque;
      s.where = "URDF line " + std::to_string(p->GetLineNum());
      read_plugin(p, s);
      if (s.type == SensorType::Imu && s.link.empty() && ref) s.link = ref;
      if (s.type == SensorType::Imu ? s.link.empty() : s.joint.empty()) {
        warn(s.where + ": plugin '" + file + "' names no " +
             (s.type == SensorType::Imu ? "bodyName" : "jointName") + "; ignored");
        continue;
      }
      s.name = !pname.empty() ? pname : (s.type == SensorType::Imu ? s.link : s.joint);
      if (s.topic.empty()) s.topic = s.name;
      (void)line;
      out.push_back(std::move(s));
    }
  }
  return out;
}

}  // namespace se3
