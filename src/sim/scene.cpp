// Scenes (sim.h): YAML text -> Scene -> Model and initial State.
#include <sys/stat.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>

#include "contact_scene.h"
#include "scene_reader.h"
#include "se3_sim/sim.h"
#include "yaml_lite.h"

namespace se3 {
namespace {

using yaml_lite::Node;

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

// The nearest directory at or above dir that holds package.xml ("" if none).
std::string package_root(std::string dir) {
  for (int depth = 0; depth < 32; ++depth) {
    if (file_exists(dir + "/package.xml")) return dir;
    if (dir == "/" || dir.empty()) break;
    const std::string up = dir_of(dir);
    if (up == dir) break;
    dir = up;
  }
  return "";
}

using Reader = SceneReader;

}  // namespace

Scene parse_scene(const std::string& text, const std::string& base_dir,
                  const std::string& file_for_messages) {
  Node root;
  try {
    root = yaml_lite::parse(text);
  } catch (const yaml_lite::Error& e) {
    throw SceneError(file_for_messages + ": " + e.what());
  }
  const Reader r(file_for_messages);
  std::vector<std::string> keys = {"name",
                                   "robot",
                                   "base",
                                   "base_pose",
                                   "base_twist",
                                   "base_inertia",
                                   "base_visual",
                                   "initial_positions",
                                   "initial_velocities",
                                   "locked_joints",
                                   "gravity",
                                   "integrator",
                                   "dt",
                                   "tol",
                                   "real_time_factor",
                                   "publish_rate",
                                   "friction_eps",
                                   "chain",
                                   "controllers"};
  for (const auto& k : constraint_scene_keys()) keys.push_back(k);  // constraints.h
  r.only_keys(root, "the scene", keys);
  Scene s;
  s.file = file_for_messages;
  bool has_robot = false;
  for (const auto& kv : root.map) {
    const std::string& k = kv.first;
    const Node& v = kv.second;
    if (k == "name") {
      s.name = r.text(v, k);
    } else if (k == "robot") {
      s.robot = r.text(v, k);
      has_robot = true;
    } else if (k == "base") {
      const std::string b = r.text(v, k);
      if (b != "free" && b != "fixed") r.fail(v, "'base' is free or fixed, got '" + b + "'");
      s.floating = b == "free";
      s.base_given = true;
    } else if (k == "base_pose") {
      if (!v.is_map()) r.fail(v, "'base_pose' needs {position: [..], orientation: [..]}");
      r.only_keys(v, "base_pose", {"position", "orientation"});
      for (const auto& p : v.map) {
        if (p.first == "position") {
          s.base_pose.p = r.vec3(p.second, "base_pose.position");
        } else {
          const auto qv = r.numbers(p.second, "base_pose.orientation", 4, 4);
          const double norm =
              std::sqrt(qv[0] * qv[0] + qv[1] * qv[1] + qv[2] * qv[2] + qv[3] * qv[3]);
          if (std::abs(norm - 1) > 1e-3) {
            r.fail(p.second, "base_pose.orientation (x, y, z, w) is not a unit quaternion");
          }
          s.base_pose.R = rotation_from_quaternion(qv[0], qv[1], qv[2], qv[3]);
        }
      }
    } else if (k == "base_twist") {
      const auto t = r.numbers(v, k, 6, 6);
      for (int i = 0; i < 6; ++i) s.base_twist[i] = t[i];
    } else if (k == "base_visual") {
      if (!v.is_map()) r.fail(v, "'base_visual' needs {box: [x,y,z], origin: [..], color: [..]}");
      r.only_keys(v, "base_visual", {"box", "origin", "color"});
      s.has_base_visual = true;
      bool has_box = false;
      for (const auto& p : v.map) {
        if (p.first == "box") {
          s.base_visual_box = r.vec3(p.second, "base_visual.box");
          if (!(s.base_visual_box.minCoeff() > 0)) {
            r.fail(p.second, "base_visual.box needs three positive extents");
          }
          has_box = true;
        } else if (p.first == "origin") {
          s.base_visual_origin = r.vec3(p.second, "base_visual.origin");
        } else {
          s.base_visual_color = r.vec3(p.second, "base_visual.color");
          if (!(s.base_visual_color.minCoeff() >= 0 && s.base_visual_color.maxCoeff() <= 1)) {
            r.fail(p.second, "base_visual.color needs three values in [0, 1]");
          }
        }
      }
      if (!has_box) r.fail(v, "'base_visual' needs box: [x, y, z]");
    } else if (k == "base_inertia") {
      if (!v.is_map()) r.fail(v, "'base_inertia' needs {mass: m, com: [..], inertia: [..]}");
      r.only_keys(v, "base_inertia", {"mass", "com", "inertia"});
      s.has_base_inertia = true;
      for (const auto& p : v.map) {
        if (p.first == "mass") {
          s.base_mass = r.number(p.second, "base_inertia.mass");
          if (!(s.base_mass > 0)) r.fail(p.second, "base_inertia.mass must be positive");
        } else if (p.first == "com") {
          s.base_com = r.vec3(p.second, "base_inertia.com");
        } else {
          const auto I = r.numbers(p.second, "base_inertia.inertia", 3, 6);
          if (I.size() != 3 && I.size() != 6) {
            r.fail(p.second, "base_inertia.inertia needs [ixx, iyy, izz] or six values");
          }
          Mat3 M = Mat3::Zero();
          M(0, 0) = I[0];
          M(1, 1) = I[1];
          M(2, 2) = I[2];
          if (I.size() == 6) {
            M(0, 1) = M(1, 0) = I[3];
            M(0, 2) = M(2, 0) = I[4];
            M(1, 2) = M(2, 1) = I[5];
          }
          const Eigen::SelfAdjointEigenSolver<Mat3> es(M);
          const Vec3 ev = es.eigenvalues();
          if (!(ev.minCoeff() > 0) || ev[0] + ev[1] < ev[2] * (1 - 1e-9)) {
            r.fail(p.second, "base_inertia.inertia is not a physical inertia");
          }
          s.base_inertia = M;
        }
      }
      if (!(s.base_mass > 0)) r.fail(v, "base_inertia needs a mass");
    } else if (k == "initial_positions") {
      s.initial_positions = r.joint_map(v, k);
    } else if (k == "initial_velocities") {
      s.initial_velocities = r.joint_map(v, k);
    } else if (k == "locked_joints") {
      s.locked_joints = r.joint_map(v, k);
    } else if (k == "gravity") {
      s.gravity = r.vec3(v, k);
    } else if (k == "integrator") {
      s.integrator = r.text(v, k);
      const auto names = stepper_names();
      bool known = false;
      for (const auto& n : names) known = known || n == s.integrator;
      if (!known) r.fail(v, "unknown integrator '" + s.integrator + "'");
    } else if (k == "dt") {
      s.dt = r.number(v, k);
      if (!(s.dt > 0)) r.fail(v, "'dt' must be positive");
    } else if (k == "tol") {
      s.tol = r.number(v, k);
      if (!(s.tol > 0)) r.fail(v, "'tol' must be positive");
    } else if (k == "real_time_factor") {
      s.real_time_factor = r.number(v, k);
      if (s.real_time_factor < 0)
        r.fail(v, "'real_time_factor' must be >= 0 (0: as fast as possible)");
    } else if (k == "publish_rate") {
      s.publish_rate = r.number(v, k);
      if (!(s.publish_rate > 0)) r.fail(v, "'publish_rate' must be positive");
    } else if (k == "friction_eps") {
      s.friction_eps = r.number(v, k);
      if (!(s.friction_eps > 0)) r.fail(v, "'friction_eps' must be positive");
    } else if (k == "controllers") {
      // ros_control's YAML shape (controllers.h), read with yaml-cpp from the same text.
      try {
        s.controllers = parse_controllers(YAML::Load(text)["controllers"], {}, file_for_messages);
      } catch (const YAML::Exception& e) {
        throw SceneError(file_for_messages + ": controllers: " + e.what());
      } catch (const ControllerError& e) {
        throw SceneError(e.what());
      }
    } else if (std::find(constraint_scene_keys().begin(), constraint_scene_keys().end(), k) !=
               constraint_scene_keys().end()) {
      parse_constraint_key(k, v, file_for_messages, s.constraints);
    } else if (k == "chain") {
      if (!v.is_map()) r.fail(v, "'chain' needs {length: L, masses: [..]}");
      r.only_keys(v, "chain", {"length", "masses"});
      for (const auto& p : v.map) {
        if (p.first == "length") {
          s.chain_length = r.number(p.second, "chain.length");
          if (!(s.chain_length > 0)) r.fail(p.second, "chain.length must be positive");
        } else {
          s.chain_masses = r.numbers(p.second, "chain.masses", 1, 1000);
          for (double m : s.chain_masses) {
            if (!(m > 0)) r.fail(p.second, "chain.masses must be positive");
          }
        }
      }
    }
  }
  if (s.name.empty()) s.name = s.robot;
  if (!has_robot) {
    // No robot: it comes from outside (scene_model's urdf_xml, e.g. robot_description).
  } else if (s.robot.compare(0, 6, "chain:") == 0) {
    char* end = nullptr;
    const long n = std::strtol(s.robot.c_str() + 6, &end, 10);
    if (*end != '\0' || n < 1 || n > 100000) {
      throw SceneError(file_for_messages + ": robot chain:N needs 1 <= N <= 100000");
    }
    s.robot_path = s.robot;
  } else if (!s.robot.empty() && s.robot[0] == '/') {
    s.robot_path = s.robot;
  } else {
    std::vector<std::string> tried = {base_dir + "/" + s.robot};
    const std::string root_dir = package_root(base_dir);
    if (!root_dir.empty()) tried.push_back(root_dir + "/" + s.robot);
    for (const auto& t : tried) {
      if (file_exists(t)) {
        s.robot_path = t;
        break;
      }
    }
    if (s.robot_path.empty()) {
      std::string list;
      for (const auto& t : tried) list += (list.empty() ? "" : ", ") + t;
      throw SceneError(file_for_messages + ": robot '" + s.robot + "' not found (tried " + list +
                       ")");
    }
  }
  if (!s.robot_path.empty() && s.robot_path[0] == '/' && !file_exists(s.robot_path)) {
    throw SceneError(file_for_messages + ": robot file '" + s.robot_path + "' not found");
  }
  return s;
}

Scene load_scene(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw SceneError("cannot read scene file '" + path + "'");
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_scene(ss.str(), dir_of(path), path);
}

Model scene_model(const Scene& scene, const std::string& urdf_xml) {
  Model m;
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
    m = urdf_xml.empty() ? model_from_urdf_file(scene.robot_path, opt)
                         : model_from_urdf_string(urdf_xml, opt);
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
  const int off = model.floating ? 6 : 0;
  auto index = [&](const std::string& joint, const char* key) {
    const int i = model.joint_index(joint);
    if (i < 1) {
      throw SceneError(scene.file + ": " + key + " names joint '" + joint +
                       "', which the model does not move");
    }
    return i;
  };
  for (const auto& kv : scene.initial_positions) {
    x.q[index(kv.first, "initial_positions") - 1] = kv.second;
  }
  for (const auto& kv : scene.initial_velocities) {
    x.v[off + index(kv.first, "initial_velocities") - 1] = kv.second;
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
    x.q[i - 1] = lo + (hi - lo) * 0.5 * (unit(rng) + 1.0);
  }
  for (int k = 0; k < model.nv; ++k) x.v[k] = unit(rng);
  return x;
}

std::string model_to_urdf(const Model& model) {
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
    for (size_t g = 0; g < model.visuals.size(); ++g) {
      if (model.visual_body[g] != i) continue;
      const Geometry& geo = model.visuals[g];
      o << "    <visual>";
      origin(geo.origin);
      o << "<geometry>";
      switch (geo.type) {
        case GeometryType::Box:
          o << "<box size=\"" << geo.size.x() << ' ' << geo.size.y() << ' ' << geo.size.z()
            << "\"/>";
          break;
        case GeometryType::Cylinder:
          o << "<cylinder radius=\"" << geo.size.x() << "\" length=\"" << geo.size.y() << "\"/>";
          break;
        case GeometryType::Sphere:
          o << "<sphere radius=\"" << geo.size.x() << "\"/>";
          break;
        case GeometryType::Mesh:
          o << "<mesh filename=\"" << geo.mesh << "\"/>";
          break;
      }
      o << "</geometry></visual>\n";
    }
    o << "  </link>\n";
  }
  for (int i = 1; i <= model.n; ++i) {
    const bool rev = model.joint_type[i] == JointType::Revolute;
    const bool limited = std::isfinite(model.lower[i]) && std::isfinite(model.upper[i]);
    const char* type = !rev ? "prismatic" : (limited ? "revolute" : "continuous");
    o << "  <joint name=\"" << model.joint_name[i] << "\" type=\"" << type << "\">";
    o << "<parent link=\"" << model.body_name[model.parent[i]] << "\"/><child link=\""
      << model.body_name[i] << "\"/>";
    origin(model.X_tree[i]);
    o << "<axis xyz=\"0 0 1\"/>";
    if (limited || !rev) {
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

}  // namespace se3
