// Scene keys for constraints and contact (contact_scene.h). Syntax:
//   constraints:                 # bilateral, by name
//     loop: {type: point_point, link_a: coupler, point_a: [0.45, 0, 0],
//            link_b: rocker, point_b: [0.3, 0, 0], directions: [x, z]}
//     pin: {type: point_world, link_a: base, point_a: [0, 0, 0], point_b: [0, 0, 1]}
//     pin0: {type: point_world, link_a: base, point_b: initial}   # where the point starts
//     up: {type: axis_parallel, link_a: base, axis_a: [0, 0, 1], axis_world: [0, 0, 1]}
//   joint_limits: false          # URDF position limits as unilateral constraints (default on)
//   ground: {normal: [0, 0, 1], offset: 0, mu: 0.8, restitution: 0, from_collisions: false}
//   contacts:                    # spheres on links (radius 0: a point), by name
//     FL: {link: FL_FOOT, position: [0, 0, 0], radius: 0.016}
//   constraint_options: {baumgarte_omega: 20, baumgarte_zeta: 1, project: true,
//                        pgs_iterations: 200, erp: 0.2, slop: 1e-4, margin: 0.01,
//                        restitution_velocity: 0.2, max_correction_velocity: 0.5,
//                        solver: pgs}     # or active_set
// directions name world axes (x, y, z) or give vectors [dx, dy, dz].
#include "contact_scene.h"

#include <algorithm>
#include <cmath>

#include "se3_sim/sim/sim.h"

namespace se3 {
namespace {

using Field = SceneReader::Field;

Vec3 direction(const SceneReader& r, const Field& f) {
  if (f.node.IsScalar()) {
    const std::string& v = f.node.Scalar();
    if (v == "x") return Vec3::UnitX();
    if (v == "y") return Vec3::UnitY();
    if (v == "z") return Vec3::UnitZ();
    r.fail(f, "'" + f.key + "' entries are x, y, z or [dx, dy, dz]");
  }
  const Vec3 d = r.vec3(f);
  if (!(d.norm() > 1e-12)) r.fail(f, "'" + f.key + "' has a zero vector");
  return d;
}

void parse_bilateral(const SceneReader& r, const Field& v, ConstraintSpec& spec) {
  const std::string& where = v.key;
  BilateralConstraint c;
  c.name = v.name;
  bool has_type = false, has_a = false;
  const Field* point_b = nullptr;
  const std::vector<Field> fields = r.fields(
      v, {"type", "link_a", "point_a", "link_b", "point_b", "axis_a", "axis_world", "directions"});
  for (const Field& x : fields) {
    const std::string& k = x.name;
    if (k == "type") {
      const std::string t = r.text(x);
      has_type = true;
      if (t == "point_world") {
        c.type = ConstraintType::PointWorld;
      } else if (t == "point_point") {
        c.type = ConstraintType::PointPoint;
      } else if (t == "axis_parallel") {
        c.type = ConstraintType::AxisParallel;
      } else {
        r.fail(x, "'" + x.key + "' is point_world, point_point or axis_parallel, got '" + t + "'");
      }
    } else if (k == "link_a") {
      c.link_a = r.text(x);
      has_a = true;
    } else if (k == "point_a") {
      c.point_a = r.vec3(x);
    } else if (k == "link_b") {
      c.link_b = r.text(x);
    } else if (k == "point_b") {
      point_b = &x;
    } else if (k == "axis_a") {
      c.axis_a = direction(r, x);
    } else if (k == "axis_world") {
      c.axis_world = direction(r, x);
    } else if (k == "directions") {
      if (!x.node.IsSequence() || x.node.size() == 0 || x.node.size() > 3) {
        r.fail(x, "'" + x.key + "' needs a list of 1 to 3 directions");
      }
      for (const Field& d : r.items(x, 3)) c.directions.push_back(direction(r, d));
    }
  }
  if (!has_type) r.fail(v, "'" + where + "' needs a type");
  if (!has_a) r.fail(v, "'" + where + "' needs link_a");
  if (point_b) {
    if (c.type == ConstraintType::PointWorld && point_b->node.IsScalar() &&
        point_b->node.Scalar() == "initial") {
      c.world_point_from_initial = true;
    } else {
      c.point_b = r.vec3(*point_b);
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

void parse_constraint_key(const SceneReader& r, const Field& v, ConstraintSpec& spec) {
  const std::string& key = v.name;
  if (key == "constraints") {
    for (const Field& c : r.fields(v, {}, true)) parse_bilateral(r, c, spec);
  } else if (key == "joint_limits") {
    spec.joint_limits = r.boolean(v);
    spec.joint_limits_given = true;
  } else if (key == "ground") {
    if (v.node.IsScalar()) {
      spec.ground = r.boolean(v);
      return;
    }
    const std::vector<Field> fields =
        r.fields(v, {"normal", "offset", "mu", "restitution", "from_collisions"});
    spec.ground = true;
    for (const Field& f : fields) {
      if (f.name == "normal") {
        spec.ground_normal = direction(r, f);
      } else if (f.name == "offset") {
        spec.ground_offset = r.number(f);
      } else if (f.name == "mu") {
        spec.mu = r.non_negative(f);
      } else if (f.name == "restitution") {
        spec.options.restitution = r.in_range(f, 0, 1);
      } else {
        spec.contacts_from_collisions = r.boolean(f);
      }
    }
  } else if (key == "contacts") {
    for (const Field& item : r.fields(v, {}, true)) {
      ContactPoint c;
      c.name = item.name;
      for (const Field& p : r.fields(item, {"link", "position", "radius"})) {
        if (p.name == "link") {
          c.link = r.text(p);
        } else if (p.name == "position") {
          c.position = r.vec3(p);
        } else {
          c.radius = r.non_negative(p);
        }
      }
      if (c.link.empty()) r.fail(item, "'" + item.key + "' needs a link");
      spec.contacts.push_back(c);
    }
  } else if (key == "constraint_options") {
    ConstraintOptions& o = spec.options;
    for (const Field& x :
         r.fields(v, {"baumgarte_omega", "baumgarte_zeta", "project", "projection_tol",
                      "projection_iterations", "singular_tol", "pgs_iterations", "pgs_tol", "erp",
                      "slop", "margin", "bilateral_erp", "restitution_velocity",
                      "limit_restitution", "max_correction_velocity", "solver"})) {
      const std::string& k = x.name;
      if (k == "solver") {
        const std::string name = r.text(x);
        if (name == "pgs") {
          o.solver = ContactSolver::PGS;
        } else if (name == "active_set") {
          o.solver = ContactSolver::ActiveSet;
        } else {
          r.fail(x, "'" + x.key + "' is pgs or active_set, got '" + name + "'");
        }
      } else if (k == "project") {
        o.project = r.boolean(x);
      } else if (k == "projection_iterations") {
        o.projection_iterations = static_cast<int>(r.integer(x, 0, 1000000));
      } else if (k == "pgs_iterations") {
        o.pgs_iterations = std::max(1, static_cast<int>(r.integer(x, 0, 1000000)));
      } else if (k == "max_correction_velocity") {
        o.max_correction_velocity = r.positive(x);
      } else if (k == "erp") {
        o.erp = r.in_range(x, 0, 1);
      } else if (k == "bilateral_erp") {
        o.bilateral_erp = r.in_range(x, 0, 1);
      } else if (k == "limit_restitution") {
        o.limit_restitution = r.in_range(x, 0, 1);
      } else {
        const double val = r.non_negative(x);
        if (k == "baumgarte_omega") o.baumgarte_omega = val;
        if (k == "baumgarte_zeta") o.baumgarte_zeta = val;
        if (k == "projection_tol") o.projection_tol = val;
        if (k == "singular_tol") o.singular_tol = val;
        if (k == "pgs_tol") o.pgs_tol = val;
        if (k == "slop") o.slop = val;
        if (k == "margin") o.margin = val;
        if (k == "restitution_velocity") o.restitution_velocity = val;
      }
    }
  }
}

}  // namespace se3
