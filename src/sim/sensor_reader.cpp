// Sensor declarations (sensors.h): a scene's `sensors:` list and a URDF's Gazebo tags.
#include <tinyxml2.h>

#include <cmath>
#include <cstdlib>
#include <set>

#include "scene_reader.h"
#include "se3_sim/sensors.h"

namespace se3 {

using Field = SceneReader::Field;

// sensors: [{name, type, link | joint, pose: {position, orientation}, rate,
//            noise: {mean, stddev, bias}, topic, frame}, ...]
void read_scene_sensors(const SceneReader& r, const Field& v, std::vector<SensorSpec>& out) {
  std::set<std::string> names;
  for (const Field& item : r.items(v, 1000)) {
    SensorSpec s;
    s.where = r.file() + ":" + std::to_string(item.line);
    bool has_type = false;
    const Field* place = nullptr;
    std::vector<Field> fs = r.fields(
        item, {"name", "type", "link", "joint", "pose", "rate", "noise", "topic", "frame"});
    for (const Field& f : fs) {
      if (f.name == "type") {
        const std::string t = r.text(f);
        if (sensor_type_reserved(t)) {
          r.fail(f, "sensor type '" + t + "' is not supported yet (imu, force_torque, contact)");
        }
        if (t == "imu") {
          s.type = SensorType::Imu;
        } else if (t == "force_torque") {
          s.type = SensorType::ForceTorque;
        } else if (t == "contact") {
          s.type = SensorType::Contact;
        } else {
          r.fail(f, "unknown sensor type '" + t + "' (imu, force_torque, contact)");
        }
        has_type = true;
      }
    }
    if (!has_type) r.fail(item, "'" + item.key + "' needs type: imu | force_torque | contact");
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

std::string trimmed(const char* t) {
  std::string s = t ? t : "";
  const auto a = s.find_first_not_of(" \t\r\n"), b = s.find_last_not_of(" \t\r\n");
  return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
}

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
  if (const char* t = child_text(p, "frameName")) s.frame = trimmed(t);
  if (const char* t = child_text(p, "bodyName")) s.link = trimmed(t);
  if (const char* t = child_text(p, "jointName")) s.joint = trimmed(t);
  double rate = 0;
  if (child_number(p, "updateRate", &rate) || child_number(p, "updateRateHZ", &rate)) {
    if (rate >= 0) s.rate = rate;
  }
  double g = 0;
  if (child_number(p, "gaussianNoise", &g)) s.noise.stddev = std::abs(g);
}

bool known_plugin(const std::string& file) {
  return file == "libgazebo_ros_imu_sensor.so" || file == "libgazebo_ros_imu.so" ||
         file == "libgazebo_ros_ft_sensor.so" || file == "libgazebo_ros_bumper.so";
}

std::string plugin_name(const tinyxml2::XMLElement* p) {
  const char* f = p->Attribute("filename");
  return f ? f : "";
}

}  // namespace

std::vector<SensorSpec> sensors_from_urdf(const std::string& urdf_xml,
                                          std::vector<std::string>* warnings) {
  std::vector<SensorSpec> out;
  auto warn = [&](const std::string& w) {
    if (warnings) warnings->push_back(w);
  };
  tinyxml2::XMLDocument doc;
  if (doc.Parse(urdf_xml.c_str(), urdf_xml.size()) != tinyxml2::XML_SUCCESS) {
    warn("URDF sensors: the XML does not parse (" + std::string(doc.ErrorName()) + ")");
    return out;
  }
  const tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
  if (!robot) return out;
  for (const auto* g = robot->FirstChildElement("gazebo"); g; g = g->NextSiblingElement("gazebo")) {
    const char* ref = g->Attribute("reference");
    const int line = g->GetLineNum();
    // <sensor> elements on a link.
    for (const auto* se = g->FirstChildElement("sensor"); se;
         se = se->NextSiblingElement("sensor")) {
      const std::string type = se->Attribute("type") ? se->Attribute("type") : "";
      const std::string name = se->Attribute("name") ? se->Attribute("name") : "";
      if (type != "imu" && type != "contact") {
        warn("URDF line " + std::to_string(se->GetLineNum()) + ": sensor '" + name + "' of type '" +
             type + "' is not supported (imu, contact); ignored");
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
      s.link = ref;
      s.where = "URDF line " + std::to_string(se->GetLineNum());
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
