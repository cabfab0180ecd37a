// The collision model of a scene (scene_collision.h).
#include "se3_sim/sim/scene_collision.h"

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "object_parts.h"
#include "robot_collision.h"
#include "se3_sim/model/limits.h"

namespace se3 {
namespace {

std::string scene_name(const Scene& s) {
  return s.file.empty() ? std::string("the scene") : s.file;
}

std::string read_text(const std::string& path, const Scene& scene) {
  std::string text, why;
  if (!read_file(path, text, &why, limits::kMaxUrdfBytes)) {
    throw SceneError(scene_name(scene) + ": cannot read srdf '" + path + "': " + why);
  }
  return text;
}

// The package folder of a robot or scene file (limits.h, package_root): se3_sim's own robots'
// meshes are in its data/meshes.
std::string package_root_of_file(const std::string& file) {
  const auto slash = file.find_last_of('/');
  if (slash == std::string::npos) return "";
  return package_root(slash == 0 ? "/" : file.substr(0, slash));
}

// The links' <gazebo> surface tags of a robot (their warnings were given with the model's).
GazeboTags robot_gazebo_tags(const Scene& robot, const Model& model, const std::string& urdf_xml) {
  const std::string xml = scene_urdf_text(robot, urdf_xml);
  if (xml.empty()) return {};
  std::vector<std::string> links, joints;
  for (const LinkFrame& lf : model.links) {
    links.push_back(lf.name);
    if (!lf.joint.empty()) joints.push_back(lf.joint);
  }
  return read_gazebo_tags(xml, links, joints);
}

// A collision shape of `link` with that link's Gazebo surface: its own mu, self_collide, and its
// contact stiffness and damping as the pair's correction. dt: the scene's step.
void gazebo_surface(const GazeboTags& gz, const std::string& link, double dt, CollisionObject& o) {
  const GazeboLink* gl = gz.link(link);
  if (!gl) return;
  if (!std::isnan(gl->mu())) {
    o.mu = gl->mu();
    o.mu_own = true;
  }
  o.self_collide = gl->self_collide == 1;
  // Contact stiffness and damping as ODE turns them into its error reduction at the step h:
  // ERP = h kp / (h kp + kd) (Gazebo's defaults kp 1e12, kd 1 where one is not given).
  if (!std::isnan(gl->kp) || !std::isnan(gl->kd)) {
    const double kp = std::isnan(gl->kp) ? 1e12 : gl->kp;
    const double kd = std::isnan(gl->kd) ? 1.0 : gl->kd;
    const double hk = dt * kp;
    if (hk + kd > 0) o.erp = std::clamp(hk / (hk + kd), 0.0, 1.0);
  }
  if (gl->min_depth >= 0) o.slop = gl->min_depth;
  if (gl->max_vel > 0) o.max_correction_velocity = gl->max_vel;
}

}  // namespace

void append_robot_collision(const Model& m, const GeometryModel& g, const GazeboTags& gz,
                            const RobotCollisionSpec& spec, std::vector<CollisionObject>& objects,
                            CollisionOptions& options) {
  const std::string& name = spec.name;
  for (const GeometryObject& go : g.collisions) {
    if (go.body < 0 || go.body > m.n) continue;
    if (go.shape.type == ShapeType::Mesh &&
        (!go.shape.mesh || go.shape.mesh->triangle_count() == 0)) {
      throw std::invalid_argument("robot '" + name + "': " +
                                  (go.warning.empty() ? "link '" + go.link + "': collision mesh '" +
                                                            go.shape.resource + "' has no triangles"
                                                      : go.warning) +
                                  "; contact needs it");
    }
    CollisionObject o;
    o.name = name + "/" + go.name;
    o.link = name + "/" + go.link;
    o.frame = spec.first + go.body;
    o.placement = go.placement;
    o.shape = go.shape;
    o.group = spec.group;
    o.mu = spec.mu;
    gazebo_surface(gz, go.link, spec.dt, o);
    objects.push_back(o);
  }
  const int first = spec.first;
  for (int i = 1; i <= m.n; ++i) options.adjacent.push_back({first + m.parent[i], first + i});
  if (!m.floating) options.adjacent.push_back({first, CollisionObject::kWorld});
  if (spec.self_collision) options.self_colliding_groups.push_back(spec.group);
  for (const auto& p : spec.disabled_links) {
    options.disabled_links.push_back({name + "/" + p.first, name + "/" + p.second});
  }
}

GeometryModel scene_robot_geometry(const Scene& scene, const Model& model,
                                   const std::string& urdf_xml) {
  GeometryOptions gopt;
  const std::string root =
      package_root_of_file(scene.robot_path.empty() ? scene.file : scene.robot_path);
  if (!root.empty()) gopt.paths.package_path = {root + "/data/meshes"};
  return scene_geometry(scene, model, urdf_xml, gopt);
}

SceneCollision scene_collision(const Scene& scene, const Model* model,
                               const GeometryModel* geometry, const std::string& urdf_xml,
                               const std::vector<const Model*>& robots) {
  std::vector<CollisionObject> objs;
  std::vector<int> scene_object, body;
  CollisionOptions opt;
  opt.margin = scene.contact_margin;
  opt.max_contacts_per_pair = scene.max_contacts_per_pair;
  opt.ground_contacts_per_body = scene.ground_per_body;
  opt.self_collision = scene.self_collision;
  std::vector<std::string> warnings;
  const double robot_mu = scene.constraints.mu;
  int robot_bodies = 0;
  if (model) {
    robot_bodies = model->n + 1;
    GeometryModel loaded;
    if (!geometry) {
      loaded = scene_robot_geometry(scene, *model, urdf_xml);
      geometry = &loaded;
    }
    warnings = geometry->warnings;
    const GazeboTags gz = robot_gazebo_tags(scene, *model, urdf_xml);
    auto surface = [&](CollisionObject& o) { gazebo_surface(gz, o.link, scene.dt, o); };
    for (const GeometryObject& g : geometry->collisions) {
      if (g.body < 0 || g.body > model->n) continue;  // world geometry of a URDF: not the robot's
      if (g.shape.type == ShapeType::Mesh &&
          (!g.shape.mesh || g.shape.mesh->triangle_count() == 0)) {
        // robot_on_ground (a robot from outside): the geometry's warning was given; the rest of
        // the robot still stands on the ground.
        if (scene.robot_on_ground) continue;
        // The geometry's warning names the link, the resource and why (not found, not a
        // regular file, unreadable, empty, no triangles).
        throw SceneError(scene_name(scene) + ": " +
                         (g.warning.empty() ? "link '" + g.link + "': collision mesh '" +
                                                  g.shape.resource + "' has no triangles"
                                            : g.warning) +
                         "; contact needs it (fix the path, or give the link a primitive "
                         "<collision>)");
      }
      CollisionObject o;
      o.name = g.name;
      o.link = g.link;
      o.frame = g.body;
      o.placement = g.placement;
      o.shape = g.shape;
      o.group = 0;
      o.mu = robot_mu;
      surface(o);
      objs.push_back(o);
      scene_object.push_back(-1);
      body.push_back(g.body);
    }
    for (std::size_t k = 0; k < scene.constraints.contacts.size(); ++k) {
      const ContactPoint& c = scene.constraints.contacts[k];
      const int li = model->link_index(c.link);
      if (li < 0) {
        throw SceneError(scene_name(scene) + ": contacts names link '" + c.link +
                         "', which the robot lacks");
      }
      const LinkFrame& lf = model->links[li];
      CollisionObject o;
      o.name = c.name.empty() ? c.link + "_contact" + std::to_string(k) : c.name;
      o.link = lf.name;
      o.frame = lf.body;
      o.placement = lf.offset * SE3(Mat3::Identity(), c.position);
      o.shape = make_sphere(c.radius > 0 ? c.radius : 1e-6);  // radius 0: a point
      o.group = 0;
      o.mu = robot_mu;
      objs.push_back(o);
      scene_object.push_back(-1);
      body.push_back(lf.body);
    }
    for (int i = 1; i <= model->n; ++i) opt.adjacent.push_back({model->parent[i], i});
    // A fixed base never touches the world's static geometry: both are immovable.
    if (!model->floating) opt.adjacent.push_back({0, CollisionObject::kWorld});
    if (!scene.srdf.empty()) {
      try {
        opt.disabled_links = srdf_disabled_pairs(read_text(scene.srdf, scene));
      } catch (const std::invalid_argument& e) {
        throw SceneError(scene_name(scene) + ": srdf '" + scene.srdf + "': " + e.what());
      }
      for (const auto& p : opt.disabled_links) {
        for (const std::string* l : {&p.first, &p.second}) {
          if (model->link_index(*l) < 0) {
            throw SceneError(scene_name(scene) + ": srdf '" + scene.srdf + "' names link '" + *l +
                             "', which the robot lacks");
          }
        }
      }
    }
  }
  SceneCollision sc{CollisionModel({}, {}), robot_bodies, 0, {}, {}, {}, -1, warnings};
  int next = robot_bodies;
  for (std::size_t j = 0; j < scene.objects.size(); ++j) {
    const SceneObject& so = scene.objects[j];
    const CollisionObject o = object_collider(so, so.is_static ? CollisionObject::kWorld : next++);
    sc.object_frame.push_back(o.frame);
    objs.push_back(o);
    scene_object.push_back(int(j));
    body.push_back(-1);
  }
  sc.free_objects = next - robot_bodies;
  if (robots.size() > scene.extra_robots.size()) {
    throw SceneError(scene_name(scene) + ": more robots than the scene's robots: list");
  }
  for (std::size_t k = 0; k < robots.size(); ++k) {
    const Model& m = *robots[k];
    const Scene& e = scene.extra_robots[k];
    RobotCollisionSpec rc;
    rc.name = !e.robot_name.empty() ? e.robot_name : m.name.empty() ? "robot" : m.name;
    rc.first = next;
    rc.group = 2 + static_cast<int>(k);
    rc.self_collision = e.self_collision;
    rc.mu = robot_mu;
    rc.dt = scene.dt;
    next += m.n + 1;
    GeometryOptions gopt;
    const std::string root = package_root(e.robot_path);
    if (!root.empty()) gopt.paths.package_path = {root + "/data/meshes"};
    const GeometryModel g = scene_geometry(e, m, "", gopt);
    warnings.insert(warnings.end(), g.warnings.begin(), g.warnings.end());
    if (!e.srdf.empty()) {
      try {
        rc.disabled_links = srdf_disabled_pairs(read_text(e.srdf, scene));
      } catch (const std::invalid_argument& err) {
        throw SceneError(scene_name(scene) + ": srdf '" + e.srdf + "': " + err.what());
      }
      for (const auto& p : rc.disabled_links) {
        for (const std::string* l : {&p.first, &p.second}) {
          if (m.link_index(*l) < 0) {
            throw SceneError(scene_name(scene) + ": srdf '" + e.srdf + "' names link '" + *l +
                             "', which robot '" + rc.name + "' lacks");
          }
        }
      }
    }
    try {
      append_robot_collision(m, g, robot_gazebo_tags(e, m, ""), rc, objs, opt);
    } catch (const std::invalid_argument& err) {
      throw SceneError(scene_name(scene) + ": " + err.what());
    }
    scene_object.resize(objs.size(), -1);
    body.resize(objs.size(), -1);
  }
  sc.robot_frames = next - robot_bodies - sc.free_objects;
  if (scene.constraints.ground) {
    CollisionObject g;
    g.name = "ground";
    g.halfspace = true;
    g.group = 1;
    g.mu = scene.constraints.mu;
    const Vec3 n = scene.constraints.ground_normal.normalized();
    // Any rotation taking z to n.
    g.placement.R = Eigen::Quaterniond::FromTwoVectors(Vec3::UnitZ(), n).toRotationMatrix();
    g.placement.p = scene.constraints.ground_offset * n;
    sc.ground = int(objs.size());
    objs.push_back(g);
    scene_object.push_back(-1);
    body.push_back(-1);
  }
  try {
    sc.model = CollisionModel(std::move(objs), std::move(opt));
  } catch (const std::invalid_argument& e) {
    throw SceneError(scene_name(scene) + ": " + e.what());
  }
  sc.scene_object = std::move(scene_object);
  sc.body = std::move(body);
  return sc;
}

void scene_frame_poses(const std::vector<SE3>& body_poses,
                       const std::vector<SE3>& free_object_poses, std::vector<SE3>& frames) {
  frames.resize(body_poses.size() + free_object_poses.size());
  std::copy(body_poses.begin(), body_poses.end(), frames.begin());
  std::copy(free_object_poses.begin(), free_object_poses.end(),
            frames.begin() + long(body_poses.size()));
}

std::vector<GeometryObject> scene_object_geometry(const std::vector<SceneObject>& objects,
                                                  const std::vector<SE3>& poses) {
  std::vector<GeometryObject> out;
  for (std::size_t j = 0; j < objects.size(); ++j) {
    GeometryObject g;
    g.name = objects[j].name;
    g.link = objects[j].name;
    g.body = GeometryObject::kWorld;
    g.placement = j < poses.size() ? poses[j] : objects[j].pose;
    g.shape = objects[j].shape;
    g.material = objects[j].material;
    out.push_back(std::move(g));
  }
  return out;
}

}  // namespace se3
