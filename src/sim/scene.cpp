// Scenes (sim.h): YAML text -> Scene -> Model and initial State.
#include <sys/stat.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <unordered_map>

#include "contact_scene.h"
#include "scene_objects_reader.h"
#include "scene_reader.h"
#include "se3_sim/model/limits.h"
#include "se3_sim/sim/sim.h"

namespace se3 {
namespace {

bool file_exists(const std::string& p) {
  struct stat st;
  return ::stat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

std::string dir_of(const std::string& path) {
  const auto slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

using Field = SceneReader::Field;

void read_base_pose(const SceneReader& r, const Field& v, Scene& s) {
  s.base_pose_given = true;
  for (const Field& p : r.fields(v, {"position", "orientation"})) {
    if (p.name == "position") {
      s.base_pose.p = r.vec3(p);
    } else {
      const auto qv = r.numbers(p, 4, 4);
      const double norm = std::sqrt(qv[0] * qv[0] + qv[1] * qv[1] + qv[2] * qv[2] + qv[3] * qv[3]);
      if (std::abs(norm - 1) > 1e-3) {
        r.fail(p, "base_pose.orientation (x, y, z, w) is not a unit quaternion");
      }
      s.base_pose.R = rotation_from_quaternion(qv[0], qv[1], qv[2], qv[3]);
    }
  }
}

void read_base_visual(const SceneReader& r, const Field& v, Scene& s) {
  s.has_base_visual = true;
  bool has_box = false;
  for (const Field& p : r.fields(v, {"box", "origin", "color"})) {
    if (p.name == "box") {
      s.base_visual_box = r.vec3(p);
      if (!(s.base_visual_box.minCoeff() > 0)) {
        r.fail(p, "base_visual.box needs three positive extents");
      }
      has_box = true;
    } else if (p.name == "origin") {
      s.base_visual_origin = r.vec3(p);
    } else {
      s.base_visual_color = r.vec3(p);
      if (!(s.base_visual_color.minCoeff() >= 0 && s.base_visual_color.maxCoeff() <= 1)) {
        r.fail(p, "base_visual.color needs three values in [0, 1]");
      }
    }
  }
  if (!has_box) r.fail(v, "'base_visual' needs box: [x, y, z]");
}

void read_base_inertia(const SceneReader& r, const Field& v, Scene& s) {
  s.has_base_inertia = true;
  for (const Field& p : r.fields(v, {"mass", "com", "inertia"})) {
    if (p.name == "mass") {
      s.base_mass = r.positive(p);
    } else if (p.name == "com") {
      s.base_com = r.vec3(p);
    } else {
      s.base_inertia = read_inertia(r, p);  // scene_objects_reader.h
    }
  }
  if (!(s.base_mass > 0)) r.fail(v, "base_inertia needs a mass");
}

void read_chain(const SceneReader& r, const Field& v, Scene& s) {
  for (const Field& p : r.fields(v, {"length", "masses"})) {
    if (p.name == "length") {
      s.chain_length = r.positive(p);
    } else {
      s.chain_masses = r.numbers(p, 1, 1000);
      for (double m : s.chain_masses) {
        if (!(m > 0)) r.fail(p, "chain.masses must be positive");
      }
    }
  }
}

void read_integrator(const SceneReader& r, const Field& v, Scene& s) {
  s.integrator = r.text(v);
  const auto names = stepper_names();
  if (std::find(names.begin(), names.end(), s.integrator) == names.end()) {
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
    r.fail(v, "unknown integrator '" + s.integrator + "' (known: " + list + ")");
  }
}

// ros_control's YAML shape (controllers.h): parse_controllers names the file, line, controller
// and key itself.
void read_controllers(const SceneReader& r, const Field& v, Scene& s) {
  try {
    s.controllers = parse_controllers(v.node, {}, r.file());
  } catch (const ControllerError& e) {
    throw SceneError(e.what());
  }
}

void read_contact(const SceneReader& r, const Field& v, Scene& s) {
  for (const Field& f : r.fields(v, {"margin", "max_contacts_per_pair", "ground_per_body"})) {
    if (f.name == "margin") {
      s.contact_margin = r.non_negative(f);
    } else if (f.name == "ground_per_body") {
      s.ground_per_body = r.boolean(f);
    } else {
      s.max_contacts_per_pair = static_cast<int>(r.integer(f, 1, 64));
    }
  }
}

// The top-level keys and what reads each. A later key (objects, ...) is one more row.
using KeyReader = void (*)(const SceneReader&, const Field&, Scene&);
const std::vector<std::pair<const char*, KeyReader>>& scene_keys() {
  static const std::vector<std::pair<const char*, KeyReader>> keys = {
      {"name", [](const SceneReader& r, const Field& v, Scene& s) { s.name = r.text(v); }},
      {"robot", [](const SceneReader& r, const Field& v, Scene& s) { s.robot = r.text(v); }},
      {"base",
       [](const SceneReader& r, const Field& v, Scene& s) {
         const std::string b = r.text(v);
         if (b != "free" && b != "fixed") r.fail(v, "'base' is free or fixed, got '" + b + "'");
         s.floating = b == "free";
         s.base_given = true;
       }},
      {"base_pose", read_base_pose},
      {"base_twist",
       [](const SceneReader& r, const Field& v, Scene& s) {
         const auto t = r.numbers(v, 6, 6);
         for (int i = 0; i < 6; ++i) s.base_twist[i] = t[i];
       }},
      {"base_inertia", read_base_inertia},
      {"base_visual", read_base_visual},
      {"initial_positions", [](const SceneReader& r, const Field& v,
                               Scene& s) { s.initial_positions = r.joint_map(v); }},
      {"initial_velocities", [](const SceneReader& r, const Field& v,
                                Scene& s) { s.initial_velocities = r.joint_map(v); }},
      {"locked_joints",
       [](const SceneReader& r, const Field& v, Scene& s) { s.locked_joints = r.joint_map(v); }},
      {"gravity", [](const SceneReader& r, const Field& v, Scene& s) { s.gravity = r.vec3(v); }},
      {"integrator", read_integrator},
      {"dt",
       [](const SceneReader& r, const Field& v, Scene& s) {
         s.dt = r.positive(v);
         const std::string why = dt_problem(s.dt);
         if (!why.empty()) r.fail(v, "'dt' " + why);
       }},
      {"tol", [](const SceneReader& r, const Field& v, Scene& s) { s.tol = r.positive(v); }},
      {"real_time_factor",
       [](const SceneReader& r, const Field& v, Scene& s) {
         s.real_time_factor = r.number(v);
         if (s.real_time_factor < 0) {
           r.fail(v, "'real_time_factor' must be >= 0 (0: as fast as possible)");
         }
       }},
      {"publish_rate",
       [](const SceneReader& r, const Field& v, Scene& s) { s.publish_rate = r.positive(v); }},
      {"friction_eps",
       [](const SceneReader& r, const Field& v, Scene& s) { s.friction_eps = r.positive(v); }},
      {"chain", read_chain},
      {"controllers", read_controllers},
      {"self_collision",
       [](const SceneReader& r, const Field& v, Scene& s) { s.self_collision = r.boolean(v); }},
      {"contact", read_contact},
      {"robot_on_ground",
       [](const SceneReader& r, const Field& v, Scene& s) { s.robot_on_ground = r.boolean(v); }},
  };
  return keys;
}

std::string resolve_robot(const Scene& s, const std::string& base_dir) {
  if (s.robot.compare(0, 6, "chain:") == 0) {
    char* end = nullptr;
    errno = 0;
    const long n = std::strtol(s.robot.c_str() + 6, &end, 10);
    if (s.robot.size() == 6 || *end != '\0' || errno != 0 || n < 1 || n > limits::kMaxBodies) {
      throw SceneError(s.file +
                       ": robot chain:N needs 1 <= N <= " + std::to_string(limits::kMaxBodies));
    }
    return s.robot;
  }
  std::string ros_file, ros_error;
  if (scene_ros_reference(s.robot, base_dir, &ros_file, &ros_error)) {
    if (ros_file.empty()) throw SceneError(s.file + ": robot '" + s.robot + "': " + ros_error);
    return ros_file;
  }
  if (s.robot[0] == '/') {
    if (!file_exists(s.robot)) {
      throw SceneError(s.file + ": robot file '" + s.robot + "' not found");
    }
    return s.robot;
  }
  std::vector<std::string> tried = {base_dir + "/" + s.robot};
  const std::string root_dir = package_root(base_dir);
  if (!root_dir.empty()) tried.push_back(root_dir + "/" + s.robot);
  for (const auto& t : tried) {
    if (file_exists(t)) return t;
  }
  std::string list;
  for (const auto& t : tried) list += (list.empty() ? "" : ", ") + t;
  throw SceneError(s.file + ": robot '" + s.robot + "' not found (tried " + list + ")");
}

// The keys of one `robots:` entry; those shared with the top level are read by scene_keys().
const std::vector<std::string>& robot_entry_keys() {
  static const std::vector<std::string> keys = {"name",
                                                "urdf",
                                                "namespace",
                                                "base",
                                                "base_pose",
                                                "base_twist",
                                                "initial_positions",
                                                "initial_velocities",
                                                "locked_joints",
                                                "controllers",
                                                "srdf",
                                                "self_collision",
                                                "joint_limits",
                                                "sensors"};
  return keys;
}

// The top-level keys that describe the one robot: with `robots:` they belong in its entries.
bool is_robot_key(const std::string& key) {
  for (const std::string& k : robot_entry_keys()) {
    // The top level's sensors: stay robot 0's beside robots: (its entry may list them too).
    if (k == key && k != "name" && k != "urdf" && k != "namespace" && k != "sensors") return true;
  }
  return key == "robot";
}

// `robots: [{name, urdf, namespace, base, ...}, ...]`: each entry a Scene of its robot keys.
std::vector<Scene> read_robots(const SceneReader& r, const Field& v, const std::string& base_dir) {
  std::vector<Scene> out;
  for (const Field& item : r.items(v, static_cast<std::size_t>(limits::kMaxBodies))) {
    Scene e;
    e.file = r.file();
    bool has_urdf = false;
    for (const Field& f : r.fields(item, robot_entry_keys())) {
      if (f.name == "name") {
        e.robot_name = r.text(f);
        for (char c : e.robot_name) {
          if (std::isspace(static_cast<unsigned char>(c)) || c == '/' || c == '#' || c == ':') {
            r.fail(f, "'" + f.key + "' is not a frame name (no spaces, '/', '#' or ':')");
          }
        }
        for (const Scene& o : out) {
          if (o.robot_name == e.robot_name) {
            r.fail(f, "'" + f.key + "': robot name '" + e.robot_name + "' is used twice");
          }
        }
      } else if (f.name == "namespace") {
        e.robot_namespace = r.text(f);
        while (!e.robot_namespace.empty() && e.robot_namespace[0] == '/') {
          e.robot_namespace.erase(0, 1);
        }
        for (char c : e.robot_namespace) {
          if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '/')) {
            r.fail(f, "'" + f.key + "' is not a ROS name (letters, digits, '_' and '/')");
          }
        }
      } else if (f.name == "urdf") {
        e.robot = r.text(f);
        has_urdf = true;
      } else if (f.name == "srdf") {
        e.srdf = read_scene_srdf(r, f, base_dir);
      } else if (f.name == "sensors") {
        read_scene_sensors(r, f, e.sensors);
      } else if (f.name == "joint_limits") {
        e.constraints.joint_limits = r.boolean(f);
        e.constraints.joint_limits_given = true;
      } else {
        for (const auto& k : scene_keys()) {
          if (f.name == k.first) k.second(r, f, e);
        }
      }
    }
    if (!has_urdf) r.fail(item, "'" + item.key + "' needs urdf: (the robot's URDF file)");
    if (e.robot.compare(0, 6, "chain:") == 0) {
      r.fail(item, "'" + item.key + ".urdf' needs a URDF file (chain:N is the robot: key's)");
    }
    e.robot_path = resolve_robot(e, base_dir);
    if (!e.constraints.joint_limits_given) e.constraints.joint_limits = true;
    out.push_back(std::move(e));
  }
  if (out.empty()) r.fail(v, "'robots' needs at least one robot");
  for (size_t i = 0; i < out.size(); ++i) {
    for (size_t j = 0; j < i; ++j) {
      if (!out[i].robot_namespace.empty() && out[i].robot_namespace == out[j].robot_namespace) {
        r.fail(v, "'robots[" + std::to_string(i) + "].namespace' '" + out[i].robot_namespace +
                      "' is robots[" + std::to_string(j) + "]'s too");
      }
    }
  }
  return out;
}

}  // namespace

Scene parse_scene(const std::string& text, const std::string& base_dir,
                  const std::string& file_for_messages) {
  const SceneReader r(file_for_messages);
  const Field root = r.document(text);
  std::vector<std::string> known;
  for (const auto& k : scene_keys()) known.push_back(k.first);
  for (const auto& k : constraint_scene_keys()) known.push_back(k);  // constraints.h
  known.push_back("objects");                                        // these two need base_dir
  known.push_back("srdf");
  known.push_back("sensors");
  known.push_back("robots");
  Scene s;
  s.file = file_for_messages;
  std::vector<Scene> robots;
  int robots_line = 0, robot_key_line = 0;
  std::string robot_key;
  for (const Field& f : r.fields(root, known)) {
    if (f.name == "robots") {
      robots = read_robots(r, f, base_dir);
      robots_line = f.line;
      continue;
    }
    if (robot_key.empty() && (is_robot_key(f.name) || f.name == "controllers")) {
      robot_key = f.name;
      robot_key_line = f.line;
    }
    if (f.name == "objects") {
      read_scene_objects(r, f, base_dir, s.objects);
      continue;
    }
    if (f.name == "sensors") {
      read_scene_sensors(r, f, s.sensors);
      continue;
    }
    if (f.name == "srdf") {
      s.srdf = read_scene_srdf(r, f, base_dir);
      continue;
    }
    bool done = false;
    for (const auto& k : scene_keys()) {
      if (f.name == k.first) {
        k.second(r, f, s);
        done = true;
        break;
      }
    }
    if (!done) parse_constraint_key(r, f, s.constraints);
  }
  if (!s.robot.empty()) s.robot_path = resolve_robot(s, base_dir);
  if (!robots.empty()) {
    if (!robot_key.empty()) {
      r.fail(robot_key_line, "'" + robot_key + "' is a robot's key: with 'robots:' (line " +
                                 std::to_string(robots_line) + ") it goes in a robots: entry");
    }
    // The first robot is the scene's robot, as `robot:` and its keys would set it; its topics
    // and frames are the node's own (docs/ros.md "Several robots").
    Scene& e = robots[0];
    if (!e.robot_namespace.empty()) {
      r.fail(robots_line,
             "'robots[0].namespace': the first robot is the node's own robot (its "
             "topics are the node's, its frames its bare link names); give the "
             "others namespaces");
    }
    s.robot = e.robot;
    s.robot_path = e.robot_path;
    s.floating = e.floating;
    s.base_given = e.base_given;
    s.base_pose = e.base_pose;
    s.base_twist = e.base_twist;
    s.initial_positions = e.initial_positions;
    s.initial_velocities = e.initial_velocities;
    s.locked_joints = e.locked_joints;
    s.controllers = e.controllers;
    s.srdf = e.srdf;
    s.self_collision = e.self_collision;
    s.sensors.insert(s.sensors.end(), e.sensors.begin(), e.sensors.end());
    s.robot_name = e.robot_name;
    s.robot_namespace = e.robot_namespace;
    if (e.constraints.joint_limits_given) {
      s.constraints.joint_limits = e.constraints.joint_limits;
      s.constraints.joint_limits_given = true;
    }
    for (size_t i = 1; i < robots.size(); ++i) {
      robots[i].gravity = s.gravity;
      robots[i].integrator = s.integrator;
      robots[i].dt = s.dt;
      for (const SceneObject& o : s.objects) {
        if (o.name == robots[i].robot_name) {
          throw SceneError(s.file + ": robots[" + std::to_string(i) + "].name '" + o.name +
                           "' is an object's too");
        }
      }
      s.extra_robots.push_back(std::move(robots[i]));
    }
  }
  if (s.name.empty()) s.name = s.robot;
  return s;
}

Scene load_scene(const std::string& path) {
  std::string text, why;
  if (!read_file(path, text, &why, limits::kMaxSceneBytes)) {
    if (why.find(" bytes, more than the ") != std::string::npos) {
      throw SceneError(path + ": " + why + " a scene may have (docs/robustness.md)");
    }
    throw SceneError("cannot read scene file '" + path + "': " + why);
  }
  return parse_scene(text, dir_of(path), path);
}

Model scene_model(const Scene& scene, const std::string& urdf_xml, GazeboTags* gazebo) {
  Model m;
  if (urdf_xml.empty() && scene.robot_path.empty() && !scene.objects.empty()) {
    // Objects and no robot: an empty robot (a fixed base without mass or joints, nv = 0).
    m.floating = false;
    m.start_with_base("world");
    m.gravity = scene.gravity;
    m.finalize();
    return m;
  }
  if (urdf_xml.empty() && scene.robot_path.empty()) {
    throw SceneError((scene.file.empty() ? std::string("the scene") : scene.file) +
                     ": no robot: the scene has no 'robot:' and none was given (a URDF, e.g. "
                     "robot_description)");
  }
  if (urdf_xml.empty() && scene.robot_path.compare(0, 6, "chain:") == 0) {
    if (!scene.locked_joints.empty()) {
      throw SceneError(scene.file + ": locked_joints are not supported for chain:N robots");
    }
    m = make_chain(std::atoi(scene.robot_path.c_str() + 6), scene.floating, scene.chain_masses,
                   scene.chain_length);
  } else {
    if (urdf_xml.empty() && scene.robot_path.empty()) {
      throw SceneError(scene.file + ": the scene names no robot and none was given");
    }
    UrdfOptions opt;
    opt.floating = scene.floating;
    opt.locked = scene.locked_joints;
    try {
      const UrdfDocument doc =
          urdf_xml.empty() ? read_urdf_document(scene.robot_path) : parse_urdf_document(urdf_xml);
      // Gazebo's <static>true</static>: the model does not fall (the scene's base: wins).
      if (!scene.base_given && doc.gazebo.is_static == 1) opt.floating = false;
      m = model_from_urdf(doc, opt);
      if (gazebo) *gazebo = doc.gazebo;
    } catch (const ModelError& e) {
      // A locked joint the robot lacks is the scene's error: name the scene.
      const std::string what = e.what();
      if (!scene.file.empty() && what.compare(0, 13, "locked joint ") == 0) {
        throw SceneError(scene.file + ": locked_joints names joint " + what.substr(13));
      }
      throw;
    }
  }
  if (scene.has_base_inertia) {
    m.inertia[0] += Inertia::from_com(scene.base_mass, scene.base_com, scene.base_inertia);
  }
  m.gravity = scene.gravity;
  m.validate();
  return m;
}

State scene_state(const Scene& scene, const Model& model) {
  State x(model);
  x.base = scene.base_pose;
  std::unordered_map<std::string, int> joints;
  for (int i = 1; i <= model.n; ++i) joints.emplace(model.joint_name[i], i);
  auto index = [&](const std::string& joint, const char* key) {
    const auto it = joints.find(joint);
    if (it == joints.end()) {
      throw SceneError(scene.file + ": " + key + " names joint '" + joint +
                       "', which the robot does not move");
    }
    return it->second;
  };
  for (const auto& kv : scene.initial_positions) {
    x.q[model.idx_q(index(kv.first, "initial_positions"))] = kv.second;
  }
  // A continuous joint's angle as its configuration space has it: in (-pi, pi].
  wrap_continuous_joints(model, x.q);
  for (const auto& kv : scene.initial_velocities) {
    x.v[model.idx_v(index(kv.first, "initial_velocities"))] = kv.second;
  }
  if (model.floating) {
    x.v.head<6>() = scene.base_twist;
  } else if (!scene.base_twist.isZero()) {
    throw SceneError(scene.file + ": base_twist needs a free base");
  }
  return x;
}

State random_state(const Model& model, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  State x(model);
  for (int i = 1; i <= model.n; ++i) {
    double lo = model.lower[i], hi = model.upper[i];
    if (!std::isfinite(lo) || !std::isfinite(hi) || hi <= lo) {
      lo = -M_PI;
      hi = M_PI;
    }
    x.q[model.idx_q(i)] = lo + (hi - lo) * 0.5 * (unit(rng) + 1.0);
  }
  for (int k = 0; k < model.nv; ++k) x.v[k] = unit(rng);
  return x;
}

std::string model_to_urdf(const Model& model, const GeometryModel* geometry) {
  std::ostringstream o;
  o.precision(17);
  auto origin = [&](const SE3& f) {
    const Vec3 rpy = f.R.eulerAngles(2, 1, 0).reverse();  // URDF rpy: R = Rz(y) Ry(p) Rx(r)
    o << "<origin xyz=\"" << f.p.x() << ' ' << f.p.y() << ' ' << f.p.z() << "\" rpy=\"" << rpy.x()
      << ' ' << rpy.y() << ' ' << rpy.z() << "\"/>";
  };
  const std::string name = model.name.empty() ? std::string("robot") : model.name;
  o << "<?xml version=\"1.0\"?>\n<robot name=\"" << name << "\">\n";
  for (int i = 0; i <= model.n; ++i) {
    const Inertia& I = model.inertia[i];
    o << "  <link name=\"" << model.body_name[i] << "\">\n";
    if (I.m > 0) {
      const Vec3 c = I.com();
      const Mat3 Ic = I.I + I.m * hat(c) * hat(c);  // about the centre of mass
      o << "    <inertial>";
      origin(SE3(Mat3::Identity(), c));
      o << "<mass value=\"" << I.m << "\"/><inertia ixx=\"" << Ic(0, 0) << "\" ixy=\"" << Ic(0, 1)
        << "\" ixz=\"" << Ic(0, 2) << "\" iyy=\"" << Ic(1, 1) << "\" iyz=\"" << Ic(1, 2)
        << "\" izz=\"" << Ic(2, 2) << "\"/></inertial>\n";
    }
    for (const GeometryObject& geo : geometry ? geometry->visuals : std::vector<GeometryObject>()) {
      if (geo.body != i || geo.stand_in) continue;
      const Shape& sh = geo.shape;
      o << "    <visual>";
      origin(geo.placement);
      o << "<geometry>";
      switch (sh.type) {
        case ShapeType::Box:
          o << "<box size=\"" << sh.box.x() << ' ' << sh.box.y() << ' ' << sh.box.z() << "\"/>";
          break;
        case ShapeType::Cylinder:
        case ShapeType::Capsule:  // URDF has no capsule
          o << "<cylinder radius=\"" << sh.radius << "\" length=\"" << sh.length << "\"/>";
          break;
        case ShapeType::Sphere:
          o << "<sphere radius=\"" << sh.radius << "\"/>";
          break;
        case ShapeType::Mesh:
          o << "<mesh filename=\"" << sh.resource << "\" scale=\"" << sh.scale.x() << ' '
            << sh.scale.y() << ' ' << sh.scale.z() << "\"/>";
          break;
      }
      o << "</geometry></visual>\n";
    }
    o << "  </link>\n";
  }
  for (int i = 1; i <= model.n; ++i) {
    const bool limited = std::isfinite(model.lower[i]) && std::isfinite(model.upper[i]);
    const std::string type = model.joints[i].urdf_type(limited);
    o << "  <joint name=\"" << model.joint_name[i] << "\" type=\"" << type << "\">";
    o << "<parent link=\"" << model.body_name[model.parent[i]] << "\"/><child link=\""
      << model.body_name[i] << "\"/>";
    origin(model.X_tree[i]);
    o << "<axis xyz=\"0 0 1\"/>";  // every joint's axis is its body's z (model.h)
    if (type != "continuous") {    // URDF requires <limit> on the other moving joints
      const double e = std::isfinite(model.effort[i]) ? model.effort[i] : 1e9;
      const double vl = std::isfinite(model.velocity[i]) ? model.velocity[i] : 1e9;
      o << "<limit lower=\"" << (limited ? model.lower[i] : -1e9) << "\" upper=\""
        << (limited ? model.upper[i] : 1e9) << "\" effort=\"" << e << "\" velocity=\"" << vl
        << "\"/>";
    }
    if (model.damping[i] != 0 || model.friction[i] != 0) {
      o << "<dynamics damping=\"" << model.damping[i] << "\" friction=\"" << model.friction[i]
        << "\"/>";
    }
    o << "</joint>\n";
  }
  o << "</robot>\n";
  return o.str();
}

std::string scene_urdf_text(const Scene& scene, const std::string& urdf_xml) {
  if (!urdf_xml.empty()) return urdf_xml;
  if (scene.robot_path.empty() || scene.robot_path.compare(0, 6, "chain:") == 0) return "";
  std::ifstream in(scene.robot_path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::vector<SensorSpec> scene_sensors(const Scene& scene, const std::string& urdf_xml,
                                      std::vector<std::string>* warnings) {
  const std::string xml = scene_urdf_text(scene, urdf_xml);
  if (xml.empty()) return scene_sensors(scene, nullptr, warnings);
  const UrdfXml urdf(xml);
  return scene_sensors(scene, &urdf, warnings);
}

std::vector<SensorSpec> scene_sensors(const Scene& scene, const UrdfXml* urdf,
                                      std::vector<std::string>* warnings) {
  std::vector<SensorSpec> out = scene.sensors;
  if (!urdf) return out;
  for (SensorSpec& s : sensors_from_urdf(*urdf, warnings)) {
    bool taken = false;
    for (const SensorSpec& t : out) taken = taken || t.name == s.name;
    if (taken) {
      if (warnings) {
        warnings->push_back(s.where + ": sensor '" + s.name +
                            "' is also in the scene; the scene's is used");
      }
      continue;
    }
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace se3
