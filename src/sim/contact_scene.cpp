// Scene keys for constraints and contact (contact_scene.h). Syntax:
//   constraints:                 # bilateral, by name
//     loop: {type: point_point, link_a: coupler, point_a: [0.45, 0, 0],
//            link_b: rocker, point_b: [0.3, 0, 0], directions: [x, z]}
//     pin: {type: point_world, link_a: base, point_a: [0, 0, 0], point_b: [0, 0, 1]}
//     pin0: {type: point_world, link_a: base, point_b: initial}   # where the point starts
//     up: {type: axis_parallel, link_a: base, axis_a: [0, 0, 1], axis_world: [0, 0, 1]}
//   joint_limits: true           # URDF position limits as unilateral constraints
//   ground: {normal: [0, 0, 1], offset: 0, mu: 0.8, from_collisions: false}
//   contacts:                    # spheres on links (radius 0: a point), by name
//     FL: {link: FL_FOOT, position: [0, 0, 0], radius: 0.016}
//   constraint_options: {baumgarte_omega: 20, baumgarte_zeta: 1, project: true,
//                        pgs_iterations: 200, erp: 0.2, slop: 1e-4, margin: 0.01}
// directions name world axes (x, y, z) or give vectors [dx, dy, dz].
#include "contact_scene.h"

#include <cmath>
#include <cstdlib>

#include "scene_reader.h"
#include "se3_sim/sim.h"

namespace se3 {
namespace {

using yaml_lite::Node;

using Rd = SceneReader;

Vec3 direction(const Rd& r, const Node& n, const std::string& key) {
  if (n.is_scalar()) {
    if (n.value == "x") return Vec3::UnitX();
    if (n.value == "y") return Vec3::UnitY();
    if (n.value == "z") return Vec3::UnitZ();
    r.fail(n, "'" + key + "' entries are x, y, z or [dx, dy, dz]");
  }
  const Vec3 d = r.vec3(n, key);
  if (!(d.norm() > 1e-12)) r.fail(n, "'" + key + "' has a zero vector");
  return d;
}

void parse_bilateral(const Rd& r, const std::string& name, const Node& v, ConstraintSpec& spec) {
  const std::string where = "constraints." + name;
  r.map(v, where);
  r.only_keys(
      v, where,
      {"type", "link_a", "point_a", "link_b", "point_b", "axis_a", "axis_world", "directions"});
  BilateralConstraint c;
  c.name = name;
  bool has_type = false, has_a = false;
  const Node* point_b = nullptr;
  for (const auto& kv : v.map) {
    const std::string& k = kv.first;
    const Node& x = kv.second;
    const std::string key = where + "." + k;
    if (k == "type") {
      const std::string t = r.text(x, key);
      has_type = true;
      if (t == "point_world") {
        c.type = ConstraintType::PointWorld;
      } else if (t == "point_point") {
        c.type = ConstraintType::PointPoint;
      } else if (t == "axis_parallel") {
        c.type = ConstraintType::AxisParallel;
      } else {
        r.fail(x, "'" + key + "' is point_world, point_point or axis_parallel, got '" + t + "'");
      }
    } else if (k == "link_a") {
      c.link_a = r.text(x, key);
      has_a = true;
    } else if (k == "point_a") {
      c.point_a = r.vec3(x, key);
    } else if (k == "link_b") {
      c.link_b = r.text(x, key);
    } else if (k == "point_b") {
      point_b = &x;
    } else if (k == "axis_a") {
      c.axis_a = direction(r, x, key);
    } else if (k == "axis_world") {
      c.axis_world = direction(r, x, key);
    } else if (k == "directions") {
      if (!x.is_list() || x.list.empty() || x.list.size() > 3) {
        r.fail(x, "'" + key + "' needs a list of 1 to 3 directions");
      }
      for (const Node& d : x.list) c.directions.push_back(direction(r, d, key));
    }
  }
  if (!has_type) r.fail(v, "'" + where + "' needs a type");
  if (!has_a) r.fail(v, "'" + where + "' needs link_a");
  if (point_b) {
    if (c.type == ConstraintType::PointWorld && point_b->is_scalar() &&
        point_b->value == "initial") {
      c.world_point_from_initial = true;
    } else {
      c.point_b = r.vec3(*point_b, where + ".point_b");
    }
  } else if (c.type == ConstraintType::PointWorld) {
    c.world_point_from_initial = true;
  }
  if (c.type == ConstraintType::PointPoint && c.link_b.empty()) {
    r.fail(v, "'" + where + "' (point_point) needs link_b");
  }
  spec.bilateral.push_back(c);
}

}  // namespace

const std::vector<std::string>& constraint_scene_keys() {
  static const std::vector<std::string> keys = {"constraints", "joint_limits", "ground", "contacts",
                                                "constraint_options"};
  return keys;
}

void parse_constraint_key(const std::string& key, const Node& v, const std::string& file,
                          ConstraintSpec& spec) {
  const Rd r(file);
  if (key == "constraints") {
    if (v.is_scalar() && v.value.empty()) return;
    r.map(v, key);
    for (const auto& kv : v.map) parse_bilateral(r, kv.first, kv.second, spec);
  } else if (key == "joint_limits") {
    spec.joint_limits = r.boolean(v, key);
  } else if (key == "ground") {
    if (v.is_scalar()) {
      spec.ground = r.boolean(v, key);
      return;
    }
    r.map(v, key);
    r.only_keys(v, key, {"normal", "offset", "mu", "from_collisions"});
    spec.ground = true;
    for (const auto& kv : v.map) {
      const std::string k = key + "." + kv.first;
      if (kv.first == "normal") {
        spec.ground_normal = direction(r, kv.second, k);
      } else if (kv.first == "offset") {
        spec.ground_offset = r.number(kv.second, k);
      } else if (kv.first == "mu") {
        spec.mu = r.number(kv.second, k);
        if (spec.mu < 0) r.fail(kv.second, "'" + k + "' must be >= 0");
      } else {
        spec.contacts_from_collisions = r.boolean(kv.second, k);
      }
    }
  } else if (key == "contacts") {
    if (v.is_scalar() && v.value.empty()) return;
    r.map(v, key);
    for (const auto& kv : v.map) {
      const std::string where = key + "." + kv.first;
      r.map(kv.second, where);
      r.only_keys(kv.second, where, {"link", "position", "radius"});
      ContactPoint c;
      c.name = kv.first;
      for (const auto& p : kv.second.map) {
        const std::string k = where + "." + p.first;
        if (p.first == "link") {
          c.link = r.text(p.second, k);
        } else if (p.first == "position") {
          c.position = r.vec3(p.second, k);
        } else {
          c.radius = r.number(p.second, k);
          if (c.radius < 0) r.fail(p.second, "'" + k + "' must be >= 0");
        }
      }
      if (c.link.empty()) r.fail(kv.second, "'" + where + "' needs a link");
      spec.contacts.push_back(c);
    }
  } else if (key == "constraint_options") {
    r.map(v, key);
    r.only_keys(
        v, key,
        {"baumgarte_omega", "baumgarte_zeta", "project", "projection_tol", "projection_iterations",
         "singular_tol", "pgs_iterations", "pgs_tol", "erp", "slop", "margin", "bilateral_erp"});
    ConstraintOptions& o = spec.options;
    for (const auto& kv : v.map) {
      const std::string& k = kv.first;
      const Node& x = kv.second;
      const std::string kk = key + "." + k;
      if (k == "project") {
        o.project = r.boolean(x, kk);
        continue;
      }
      const double val = r.number(x, kk);
      if (val < 0) r.fail(x, "'" + kk + "' must be >= 0");
      if (k == "baumgarte_omega") o.baumgarte_omega = val;
      if (k == "baumgarte_zeta") o.baumgarte_zeta = val;
      if (k == "projection_tol") o.projection_tol = val;
      if (k == "projection_iterations") o.projection_iterations = static_cast<int>(val);
      if (k == "singular_tol") o.singular_tol = val;
      if (k == "pgs_iterations") o.pgs_iterations = std::max(1, static_cast<int>(val));
      if (k == "pgs_tol") o.pgs_tol = val;
      if (k == "erp") {
        if (val > 1) r.fail(x, "'" + kk + "' must be in [0, 1]");
        o.erp = val;
      }
      if (k == "slop") o.slop = val;
      if (k == "margin") o.margin = val;
      if (k == "bilateral_erp") {
        if (val > 1) r.fail(x, "'" + kk + "' must be in [0, 1]");
        o.bilateral_erp = val;
      }
    }
  }
}

}  // namespace se3
