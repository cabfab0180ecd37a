// The world interface of the Simulator (world.h, sim.h): models, spawn and delete between steps,
// model and link states.
#include "se3_sim/sim/world.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "object_parts.h"
#include "robot_collision.h"
#include "scene_objects_reader.h"
#include "se3_sim/constraint/constraint.h"
#include "se3_sim/sim/scene_collision.h"
#include "se3_sim/sim/sim.h"

namespace se3 {

namespace {

// A scene collision with old's frames and warnings, a ground index and a count of robot frames;
// its model is set by the caller.
std::unique_ptr<SceneCollision> collision_like(const SceneCollision& old, int ground,
                                               int robot_frames) {
  return std::make_unique<SceneCollision>(SceneCollision{CollisionModel({}, {}),
                                                         old.robot_bodies,
                                                         old.free_objects,
                                                         old.object_frame,
                                                         {},
                                                         {},
                                                         ground,
                                                         old.warnings,
                                                         robot_frames});
}

// A position farther than this from the origin is refused (m): beyond it double precision
// leaves contact and integration no digits to work with.
constexpr double kMaxPosition = 1e6;

std::string fig(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", x);
  return buf;
}

void check_pose(const SE3& pose, const std::string& what) {
  if (!pose.p.allFinite() || !pose.R.allFinite()) {
    throw WorldError(WorldError::Kind::InvalidPose, what + ".pose is not finite");
  }
  if (!is_rotation(pose.R)) {
    throw WorldError(WorldError::Kind::InvalidPose,
                     what + ".pose.orientation is not a rotation (unit quaternion)");
  }
  if (pose.p.norm() > kMaxPosition) {
    throw WorldError(WorldError::Kind::InvalidPose,
                     what + ".pose.position is " + fig(pose.p.norm()) +
                         " m from the origin (at most " + fig(kMaxPosition) + ")");
  }
}

void check_rates(const VecX& v, double max_rate, const std::string& what) {
  if (!v.allFinite()) throw WorldError(WorldError::Kind::Invalid, what + " is not finite");
  if (v.size() > 0 && v.cwiseAbs().maxCoeff() > max_rate) {
    throw WorldError(WorldError::Kind::Invalid,
                     what + " has a rate of " + fig(v.cwiseAbs().maxCoeff()) + " above the limit " +
                         fig(max_rate) + " (GuardOptions::max_rate)");
  }
}

// World axes [R w; R v] of a body-frame twist [w; v] of a frame with rotation R.
Vec6 to_world(const Mat3& R, const Vec6& t) {
  Vec6 out;
  out.head<3>() = R * t.head<3>();
  out.tail<3>() = R * t.tail<3>();
  return out;
}

Vec6 to_body(const Mat3& R, const Vec6& t) {
  Vec6 out;
  out.head<3>() = R.transpose() * t.head<3>();
  out.tail<3>() = R.transpose() * t.tail<3>();
  return out;
}

}  // namespace

SceneObject parse_scene_object(const std::string& yaml, const std::string& base_dir,
                               const std::string& source, const std::string& name) {
  const SceneReader r(source);
  SceneReader::Field doc = r.document(yaml);
  doc.key = "object";
  SceneObject o = read_scene_object(r, doc, base_dir, name);
  if (!name.empty()) o.name = o.material.name = name;
  return o;
}

struct WorldEdit {
  std::uint64_t generation = 0;
  std::string spawned, deleted;  ///< the model the edit adds or removes ("" if none)
  std::vector<SceneObject> specs;
  std::vector<Simulator::ObjectBody> bodies;
  std::vector<const Model*> body_models;
  std::vector<int> body_from;  ///< per new body: the old body index it continues, or -1
  std::unique_ptr<CollisionModel> collision;
  std::unique_ptr<SceneCollision> scene_collision;
  std::unique_ptr<ConstraintSystem> constraints, constraints_start;
  // A robot edit (the objects untouched): the spawned robot, built (extra set), or the deleted
  // robot (deleted its name). In a scene with collision, scene_collision and constraints are the
  // world with it or without it.
  bool robot = false;
  std::unique_ptr<Simulator::ExtraRobot> extra;
};

WorldEditInfo edit_info(const WorldEditPtr& edit) {
  WorldEditInfo i;
  if (!edit) return i;
  i.spawned = edit->spawned;
  i.deleted = edit->deleted;
  i.robot = edit->robot;
  i.robot_model = edit->extra ? edit->extra->model.get() : nullptr;
  return i;
}

void WorldEditDeleter::operator()(WorldEdit* edit) const {
  delete edit;
}

void Simulator::set_robot_name(const std::string& name, const std::string& ns) {
  if (!name.empty() && object_index(name) >= 0) {
    throw WorldError(WorldError::Kind::Invalid, "name '" + name + "' is an object's");
  }
  for (char c : name) {
    if (std::isspace(static_cast<unsigned char>(c)) || c == '/' || c == '#') {
      throw WorldError(WorldError::Kind::Invalid, "name '" + name + "' is not a frame name");
    }
  }
  robot_name_ = name;
  robot_ns_ = ns;
}

std::vector<WorldModel> Simulator::world_models() const {
  std::vector<WorldModel> out;
  if (!robot_name_.empty()) out.push_back({robot_name_, "robot", robot_ns_, !model_->floating});
  for (const auto& r : extra_) out.push_back({r->name, "robot", r->ns, !r->model->floating});
  for (const SceneObject& o : object_specs_) out.push_back({o.name, "object", "", o.is_static});
  return out;
}

int Simulator::object_index(const std::string& name) const {
  for (size_t j = 0; j < object_specs_.size(); ++j) {
    if (object_specs_[j].name == name) return static_cast<int>(j);
  }
  return -1;
}

int Simulator::body_of(int object) const {
  for (size_t b = 0; b < bodies_.size(); ++b) {
    if (bodies_[b].index == object) return static_cast<int>(b);
  }
  return -1;
}

void Simulator::check_new_name(const std::string& name) const {
  using K = WorldError::Kind;
  if (name.empty()) throw WorldError(K::NameInvalid, "name is empty");
  for (char c : name) {
    if (std::isspace(static_cast<unsigned char>(c)) || c == '/' || c == '#' || c == ':') {
      throw WorldError(K::NameInvalid,
                       "name '" + name + "' is not a frame name (no spaces, '/', '#' or ':')");
    }
  }
  if (robot_index(name) >= 0 || object_index(name) >= 0) {
    throw WorldError(K::NameInUse, "name '" + name + "' is already a model's");
  }
  if (!robot_name_.empty() && model_->link_index(name) >= 0) {
    throw WorldError(K::NameInUse, "name '" + name + "' is a link of the robot (a TF frame)");
  }
  if (name == "ground" || name == "world") {
    throw WorldError(K::NameInvalid, "name '" + name + "' is reserved");
  }
}

WorldEditPtr Simulator::prepare_spawn(const SceneObject& o) const {
  check_new_name(o.name);
  const std::string what = "object '" + o.name + "'";
  check_pose(o.pose, what);
  if (!o.is_static) {
    if (!(o.mass > 0) || !std::isfinite(o.mass) || !(o.inertia.m > 0)) {
      throw WorldError(WorldError::Kind::Invalid, what + ".mass must be positive and finite");
    }
    check_rates(o.twist, config_.guard.max_rate, what + ".twist");
  } else if (!o.twist.isZero()) {
    throw WorldError(WorldError::Kind::Invalid,
                     what + ".twist needs a mass (a static object does not move)");
  }
  std::vector<SceneObject> specs = object_specs_;
  specs.push_back(o);
  WorldEditPtr e = prepare_objects(std::move(specs));
  e->spawned = o.name;
  return e;
}

WorldEditPtr Simulator::prepare_delete(const std::string& name) const {
  if (const int k = robot_index(name); k == 0) {
    throw WorldError(WorldError::Kind::Invalid,
                     "name '" + name + "' is the simulator's first robot, which cannot be deleted");
  } else if (k > 0) {
    WorldEditPtr e(new WorldEdit);
    e->generation = world_generation_;
    e->robot = true;
    e->deleted = name;
    if (coupled_robots()) without_robot_collision(k, *e);
    return e;
  }
  const int j = object_index(name);
  if (j < 0) throw WorldError(WorldError::Kind::NotFound, "name '" + name + "': no such model");
  std::vector<SceneObject> specs = object_specs_;
  specs.erase(specs.begin() + j);
  WorldEditPtr e = prepare_objects(std::move(specs));
  e->deleted = name;
  return e;
}

WorldEditPtr Simulator::prepare_objects(std::vector<SceneObject> specs) const {
  WorldEditPtr e(new WorldEdit);
  e->generation = world_generation_;
  const int first_frame = model_->n + 1;
  std::vector<CollisionObject> colliders;
  std::vector<int> scene_object, body, object_frame;
  // The robots' collision objects stay as they are; those of robots 1.. (frames after the free
  // objects') move with the free objects' count.
  const int robots_from = first_frame + static_cast<int>(bodies_.size());
  std::vector<size_t> robot_objects;
  if (scene_collision_) {
    const std::vector<CollisionObject>& old = scene_collision_->model.objects();
    for (size_t k = 0; k < old.size(); ++k) {
      if (scene_collision_->scene_object[k] >= 0 || int(k) == scene_collision_->ground) continue;
      if (old[k].frame >= robots_from) robot_objects.push_back(colliders.size());
      colliders.push_back(old[k]);
      scene_object.push_back(-1);
      body.push_back(scene_collision_->body[k]);
    }
  }
  for (size_t j = 0; j < specs.size(); ++j) {
    const SceneObject& o = specs[j];
    const int frame = first_frame + static_cast<int>(e->bodies.size());
    colliders.push_back(object_collider(o, frame));
    scene_object.push_back(static_cast<int>(j));
    body.push_back(-1);
    object_frame.push_back(o.is_static ? CollisionObject::kWorld : frame);
    if (o.is_static) continue;
    ObjectBody b;
    b.index = static_cast<int>(j);
    b.model = std::make_unique<Model>();
    b.model->floating = true;
    b.model->name = o.name;
    b.model->start_with_base(o.name, o.inertia);
    b.model->gravity = model_->gravity;
    b.model->finalize();
    try {
      b.model->validate();
    } catch (const ModelError&) {
      throw WorldError(WorldError::Kind::Invalid,
                       "object '" + o.name +
                           "'.inertia: a free object needs a mass and a positive-definite "
                           "inertia (check the shape's size and the mass)");
    }
    b.initial = State(*b.model);
    b.initial.base = o.pose;
    b.initial.v = o.twist;
    b.size = smallest_extent(o.shape);
    const int old = object_index(o.name);
    e->body_from.push_back(old >= 0 ? body_of(old) : -1);
    e->body_models.push_back(b.model.get());
    e->bodies.push_back(std::move(b));
  }
  // The ground: the scene collision's as it is, or the constraint spec's plane.
  int ground = -1;
  if (scene_collision_ && scene_collision_->ground >= 0) {
    ground = static_cast<int>(colliders.size());
    colliders.push_back(scene_collision_->model.objects()[scene_collision_->ground]);
    scene_object.push_back(-1);
    body.push_back(-1);
  } else if (!scene_collision_ && spec_.ground) {
    CollisionObject g;
    g.name = "ground";
    g.halfspace = true;
    g.group = 1;
    g.mu = spec_.mu;
    g.restitution = spec_.options.restitution;
    const Vec3 n = spec_.ground_normal.normalized();
    Vec3 t1, t2;
    tangent_basis(n, t1, t2);
    g.placement.R.col(0) = t1;
    g.placement.R.col(1) = t2;
    g.placement.R.col(2) = n;
    g.placement.p = spec_.ground_offset * n;
    ground = static_cast<int>(colliders.size());
    colliders.push_back(g);
  }
  const int nb = static_cast<int>(e->bodies.size());
  const int shift = nb - static_cast<int>(bodies_.size());
  for (const size_t k : robot_objects) colliders[k].frame += shift;
  try {
    if (scene_collision_) {
      CollisionOptions opt = scene_collision_->model.options();
      for (FramePair& p : opt.adjacent) {
        if (p.a >= robots_from) p.a += shift;
        if (p.b >= robots_from) p.b += shift;
      }
      e->scene_collision = std::make_unique<SceneCollision>(
          SceneCollision{CollisionModel(std::move(colliders), std::move(opt)), first_frame, nb,
                         std::move(object_frame), std::move(scene_object), std::move(body), ground,
                         scene_collision_->warnings, scene_collision_->robot_frames});
    } else if (nb > 0) {
      CollisionOptions copt;
      copt.margin = spec_.options.margin;
      e->collision = std::make_unique<CollisionModel>(std::move(colliders), copt);
    }
  } catch (const std::invalid_argument& err) {
    throw WorldError(WorldError::Kind::Invalid, std::string("shape: ") + err.what());
  }
  // The constraint system for the new set of free bodies (rebuild_constraints without the
  // projection: the initial state was projected when the constraints were set).
  if (scene_collision_) {
    std::vector<const Model*> robots;
    std::vector<bool> limits;
    if (coupled_robots()) {
      robots = extra_robot_models();
      for (const auto& r : extra_) {
        limits.push_back(r->constraints_start && r->constraints_start->spec().joint_limits);
      }
    }
    e->constraints = coupled_constraints(e->body_models, robots, limits);
    e->constraints_start = std::make_unique<ConstraintSystem>(*e->constraints);
  } else if (!(spec_.empty() && nb == 0)) {
    e->constraints = std::make_unique<ConstraintSystem>(*model_, spec_);
    if (nb > 0 || scene_collision_) {
      e->constraints->set_free_bodies(e->body_models, (scene_collision_ ? 64 : 0) + 16 * nb);
    }
    e->constraints->anchor(initial_);
    e->constraints_start = std::make_unique<ConstraintSystem>(*e->constraints);
  }
  e->specs = std::move(specs);
  return e;
}

std::string Simulator::commit(WorldEditPtr e) {
  if (!e) throw WorldError(WorldError::Kind::Invalid, "no edit");
  if (e->generation != world_generation_) {
    throw WorldError(WorldError::Kind::Stale,
                     "the world changed since the edit was prepared; prepare it again");
  }
  if (e->robot) return commit_robot(*e);
  const size_t nb = e->bodies.size();
  std::vector<State> states(nb), last_good(nb);
  for (size_t j = 0; j < nb; ++j) {
    const int from = e->body_from[j];
    states[j] = from >= 0 ? body_states_[from] : e->bodies[j].initial;
    last_good[j] = from >= 0 ? body_last_good_[from] : e->bodies[j].initial;
  }
  std::vector<ObjectState> objects(e->specs.size());
  for (size_t j = 0; j < e->specs.size(); ++j) {
    const SceneObject& o = e->specs[j];
    const int old = object_index(o.name);
    if (old >= 0 && object_specs_[old].is_static == o.is_static) {
      objects[j] = objects_[old];
    } else {
      objects[j].name = o.name;
      objects[j].is_static = o.is_static;
      objects[j].pose = o.pose;
      objects[j].twist = o.is_static ? Vec6::Zero() : o.twist;
    }
    if (o.is_static) objects[j].pose = o.pose;
  }
  // Nothing below throws: the swap is whole.
  object_specs_ = std::move(e->specs);
  objects_ = std::move(objects);
  bodies_ = std::move(e->bodies);
  body_models_ = std::move(e->body_models);
  body_states_ = std::move(states);
  body_last_good_ = std::move(last_good);
  body_a_.assign(nb, VecX::Zero(6));
  if (scene_collision_) {
    scene_collision_ = std::move(e->scene_collision);
  } else {
    collision_ = std::move(e->collision);
  }
  constraints_ = std::move(e->constraints);
  constraints_start_ = std::move(e->constraints_start);
  const int robot_frames = scene_collision_ ? scene_collision_->robot_frames : 0;
  frame_poses_.assign(model_->n + 1 + nb + robot_frames, SE3());
  free_poses_.assign(nb, SE3());
  collision_data_.contacts.reserve((scene_collision_ ? 256 : 0) + 64 * (nb + extra_.size()));
  contacts_fresh_ = false;
  ++world_generation_;
  if (!e->spawned.empty()) ++spawned_;
  if (!e->deleted.empty()) ++deleted_;
  return interpenetration_report();
}

std::string Simulator::spawn_object(const SceneObject& object) {
  return commit(prepare_spawn(object));
}

void Simulator::delete_model(const std::string& name) {
  commit(prepare_delete(name));
}

ModelState Simulator::model_state(const std::string& name) {
  ModelState s;
  if (const int k = robot_index(name); k >= 0) {
    const Model& m = robot_model(k);
    const State& x = robot_state(k);
    const int nb = m.nv_base();
    s.pose = x.base;
    if (nb == 6) s.twist = to_world(x.base.R, x.v.head<6>());
    s.q = x.q;
    s.v = x.v.tail(m.nv - nb);
    return s;
  }
  const int j = object_index(name);
  if (j < 0) throw WorldError(WorldError::Kind::NotFound, "name '" + name + "': no such model");
  s.pose = objects_[j].pose;
  s.twist = to_world(s.pose.R, objects_[j].twist);
  return s;
}

std::string Simulator::set_model_state(const std::string& name, const ModelState& s) {
  const std::string what = "model '" + name + "' state";
  check_pose(s.pose, what);
  if (!s.twist.allFinite())
    throw WorldError(WorldError::Kind::Invalid, what + ".twist is not finite");
  check_rates(s.twist, config_.guard.max_rate, what + ".twist");
  if (const int k = robot_index(name); k >= 0) {
    const Model& m = robot_model(k);
    const int nb = m.nv_base();
    if (s.q.size() != m.n) {
      throw WorldError(WorldError::Kind::Invalid,
                       what + ".joint positions: " + std::to_string(s.q.size()) +
                           " given, the robot has " + std::to_string(m.n));
    }
    if (s.v.size() != m.nv - nb) {
      throw WorldError(WorldError::Kind::Invalid,
                       what + ".joint velocities: " + std::to_string(s.v.size()) +
                           " given, the robot has " + std::to_string(m.nv - nb));
    }
    if (!s.q.allFinite())
      throw WorldError(WorldError::Kind::Invalid, what + ".joint positions are not finite");
    check_rates(s.v, config_.guard.max_rate, what + ".joint velocities");
    if (nb == 0 && !s.twist.isZero()) {
      throw WorldError(WorldError::Kind::Invalid,
                       what + ".twist must be zero: the robot's base is fixed");
    }
    State x = robot_state(k);
    x.base = s.pose;
    x.q = s.q;
    if (nb == 6) x.v.head<6>() = to_body(s.pose.R, s.twist);
    x.v.tail(m.nv - nb) = s.v;
    set_robot_state(k, x);
    contacts_fresh_ = false;
    return interpenetration_report();
  }
  const int j = object_index(name);
  if (j < 0) throw WorldError(WorldError::Kind::NotFound, "name '" + name + "': no such model");
  if (s.q.size() != 0 || s.v.size() != 0) {
    throw WorldError(WorldError::Kind::Invalid, what + ": an object has no joints");
  }
  if (object_specs_[j].is_static) {
    if (!s.twist.isZero()) {
      throw WorldError(WorldError::Kind::Invalid,
                       what + ".twist must be zero: the object is static");
    }
    std::vector<SceneObject> specs = object_specs_;
    specs[j].pose = s.pose;
    return commit(prepare_objects(std::move(specs)));
  }
  const int b = body_of(j);
  State& x = body_states_[b];
  x.base = s.pose;
  x.v = to_body(s.pose.R, s.twist);
  body_last_good_[b] = x;
  objects_[j].pose = x.base;
  objects_[j].twist = x.v;
  contacts_fresh_ = false;
  return interpenetration_report();
}

std::vector<std::string> Simulator::link_names() const {
  std::vector<std::string> out;
  if (!robot_name_.empty()) {
    for (const LinkFrame& L : model_->links) out.push_back(L.name);
  }
  for (const SceneObject& o : object_specs_) out.push_back(o.name);
  for (const auto& r : extra_) {
    for (const LinkFrame& L : r->model->links) out.push_back(r->name + "::" + L.name);
  }
  return out;
}

LinkState Simulator::link_state(const std::string& link, const std::string& reference) {
  // Resolves MODEL::LINK or LINK into a world pose and world-axes twist.
  auto world = [&](const std::string& full, const char* field) {
    std::string model, name = full;
    const auto sep = full.find("::");
    if (sep != std::string::npos) {
      model = full.substr(0, sep);
      name = full.substr(sep + 2);
    }
    // Link k of a robot (its model, workspace and state).
    auto robot_link = [](const Model& m, Data& d, const State& x, int k) {
      forward_kinematics(m, d, x.base, x.q, x.v);
      const LinkFrame& L = m.links[k];
      const SE3& B = d.oMb[L.body];
      const Vec6& V = d.V[L.body];
      LinkState s;
      s.pose = B * L.offset;
      s.twist.head<3>() = B.R * V.head<3>();
      s.twist.tail<3>() = B.R * (V.tail<3>() + V.head<3>().cross(L.offset.p));
      return s;
    };
    if (!robot_name_.empty() && (model.empty() || model == robot_name_)) {
      const int k = model_->link_index(name);
      if (k >= 0) return robot_link(*model_, diag_, state_, k);
    }
    if (const int r = model.empty() ? -1 : robot_index(model); r >= 1) {
      ExtraRobot& R = extra(r);
      const int k = R.model->link_index(name);
      if (k >= 0) return robot_link(*R.model, R.diag, R.state, k);
    }
    const int j = object_index(name);
    if (j >= 0 && (model.empty() || model == name)) {
      LinkState s;
      s.pose = objects_[j].pose;
      s.twist = to_world(s.pose.R, objects_[j].twist);
      return s;
    }
    throw WorldError(WorldError::Kind::NotFound,
                     std::string(field) + " '" + full + "': no such link");
  };
  const LinkState a = world(link, "link");
  if (reference.empty() || reference == "world") return a;
  const LinkState r = world(reference, "reference");
  LinkState s;
  s.pose = r.pose.inverse() * a.pose;
  const Mat3 Rt = r.pose.R.transpose();
  s.twist.head<3>() = Rt * (a.twist.head<3>() - r.twist.head<3>());
  s.twist.tail<3>() =
      Rt * (a.twist.tail<3>() - r.twist.tail<3>() - r.twist.head<3>().cross(a.pose.p - r.pose.p));
  return s;
}

std::string Simulator::set_link_state(const std::string& link, const LinkState& s) {
  std::string model, name = link;
  const auto sep = link.find("::");
  if (sep != std::string::npos) {
    model = link.substr(0, sep);
    name = link.substr(sep + 2);
  }
  const int j = object_index(name);
  if (j >= 0 && (model.empty() || model == name)) {
    ModelState m;
    m.pose = s.pose;
    m.twist = s.twist;
    return set_model_state(name, m);
  }
  // A robot's root link (robot 0 by its name or without a model name, robots 1.. by theirs):
  // its pose and twist are the robot's base state.
  const int first = !robot_name_.empty() && (model.empty() || model == robot_name_) ? 0 : -1;
  for (const int r : {first, model.empty() ? -1 : robot_index(model)}) {
    if (r < 0) continue;
    const Model& m = robot_model(r);
    const int k = m.link_index(name);
    if (k < 0) continue;
    const LinkFrame& L = m.links[k];
    if (L.body != 0 || !L.offset.R.isIdentity(0) || !L.offset.p.isZero(0)) {
      throw WorldError(WorldError::Kind::Invalid,
                       "link '" + link +
                           "' is not the robot's root link: its pose follows from the joints "
                           "(set the model state instead)");
    }
    ModelState ms = model_state(robot_name(r));
    ms.pose = s.pose;
    ms.twist = s.twist;
    return set_model_state(robot_name(r), ms);
  }
  throw WorldError(WorldError::Kind::NotFound, "link '" + link + "': no such link");
}

std::string Simulator::interpenetration_report() {
  if (!collider()) return "";
  collide_objects();
  const Contact* deepest = nullptr;
  for (const Contact& c : collision_data_.contacts) {
    if (c.depth > 0 && (!deepest || c.depth > deepest->depth)) deepest = &c;
  }
  if (!deepest) return "";
  const std::vector<CollisionObject>& objects = collider()->objects();
  return "'" + objects[deepest->a].name + "' and '" + objects[deepest->b].name +
         "' interpenetrate by " + fig(deepest->depth) + " m";
}

void Simulator::reset_world() {
  const double t = time_;
  const std::uint64_t n = steps_;
  reset();
  time_ = last_checked_time_ = t;
  steps_ = last_checked_steps_ = n;
}

namespace {

// A ROS namespace as the robot's topics take it: letters, digits, '_' and '/', no name part
// starting with a digit.
bool namespace_ok(const std::string& ns) {
  bool start = true;
  for (char c : ns) {
    const bool alpha = std::isalpha(static_cast<unsigned char>(c)) || c == '_';
    const bool digit = std::isdigit(static_cast<unsigned char>(c));
    if (c == '/') {
      start = true;
    } else if (alpha || (digit && !start)) {
      start = false;
    } else {
      return false;
    }
  }
  return true;
}

}  // namespace

WorldEditPtr Simulator::prepare_spawn_robot(const RobotSpawn& sp) const {
  using K = WorldError::Kind;
  if (sp.urdf.empty()) throw WorldError(K::Resource, "urdf is empty");
  Model m;
  UrdfDocument doc;
  try {
    doc = parse_urdf_document(sp.urdf);
    UrdfOptions opt;
    opt.floating = sp.base == RobotSpawn::Base::Free ||
                   (sp.base == RobotSpawn::Base::FromUrdf && doc.gazebo.is_static != 1);
    m = model_from_urdf(doc, opt);
    // A URDF bolted to a link named world (as Gazebo fixes a robot): a fixed base.
    if (sp.base == RobotSpawn::Base::FromUrdf && opt.floating && !m.links.empty() &&
        m.links[0].name == "world") {
      opt.floating = false;
      m = model_from_urdf(doc, opt);
    }
    m.gravity = model_->gravity;
    m.validate();
  } catch (const std::exception& e) {
    throw WorldError(K::Resource, std::string("urdf: ") + e.what());
  }
  const std::string name = sp.name.empty() ? m.name : sp.name;
  check_new_name(name);
  if (!namespace_ok(sp.ns)) {
    throw WorldError(K::NameInvalid, "namespace '" + sp.ns +
                                         "' is not a ROS namespace (letters, digits, '_' and '/')");
  }
  // The namespace the robot's topics take (a robot 1.. without one: its name), '/' around it
  // left out; robot 0 without a namespace is the node's own.
  auto bare = [](const std::string& n) {
    const auto a = n.find_first_not_of('/');
    return a == std::string::npos ? std::string() : n.substr(a, n.find_last_not_of('/') + 1 - a);
  };
  const std::string ns = bare(sp.ns.empty() ? name : sp.ns);
  for (int k = 0; k < robot_count(); ++k) {
    const std::string other = bare(robot_namespace(k));
    if ((k == 0 && !other.empty() && other == ns) ||
        (k > 0 && (other.empty() ? robot_name(k) : other) == ns)) {
      throw WorldError(K::NameInUse,
                       "namespace '" + ns + "' is robot '" + robot_name(k) + "''s already");
    }
  }
  const std::string what = "robot '" + name + "'";
  check_pose(sp.pose, what);
  // A scene collision that left its robots 1.. out (set_scene_collision without them) has no
  // frames for another.
  if (scene_collision_ && !extra_.empty() && !coupled_robots()) {
    throw WorldError(K::Invalid,
                     "robots cannot be spawned into a scene collision that holds no robot after "
                     "the first (docs/multi_robot.md)");
  }
  State x(m);
  x.base = sp.pose;
  for (int i = 1; i <= m.n; ++i) {
    x.q[m.idx_q(i)] = std::min(m.upper[i], std::max(m.lower[i], 0.0));
  }
  WorldEditPtr e(new WorldEdit);
  e->generation = world_generation_;
  e->robot = true;
  e->spawned = name;
  try {
    e->extra = make_extra_robot(name, bare(sp.ns), std::make_unique<Model>(std::move(m)), x, {},
                                sp.joint_limits);
  } catch (const std::exception& err) {
    throw WorldError(K::Invalid, what + ": " + err.what());
  }
  if (scene_collision_) {
    // Its shapes, meshes loaded and their hulls built, here and not in the step.
    const Model& model = *e->extra->model;
    const GeometryModel g = geometry_from_urdf(model, doc, sp.geometry);
    with_robot_collision(sp, g, doc.gazebo, *e);
  }
  return e;
}

void Simulator::with_robot_collision(const RobotSpawn& sp, const GeometryModel& g,
                                     const GazeboTags& gz, WorldEdit& e) const {
  using K = WorldError::Kind;
  const Model& m = *e.extra->model;
  const SceneCollision& old = *scene_collision_;
  RobotCollisionSpec rc;
  rc.name = e.spawned;
  rc.first = old.robot_bodies + old.free_objects + old.robot_frames;
  // A group no other robot has (deletes leave gaps: groups need only differ).
  int group = 1;
  for (const CollisionObject& o : old.model.objects()) group = std::max(group, o.group);
  for (const int gr : old.model.options().self_colliding_groups) group = std::max(group, gr);
  rc.group = group + 1;
  rc.self_collision = sp.self_collision;
  rc.mu = spec_.mu;
  rc.dt = config_.dt;
  if (!sp.srdf.empty()) {
    try {
      rc.disabled_links = srdf_disabled_pairs(sp.srdf);
    } catch (const std::invalid_argument& err) {
      throw WorldError(K::Resource, std::string("srdf: ") + err.what());
    }
    for (const auto& p : rc.disabled_links) {
      for (const std::string* l : {&p.first, &p.second}) {
        if (m.link_index(*l) < 0) {
          throw WorldError(K::Invalid,
                           "srdf names link '" + *l + "', which robot '" + e.spawned + "' lacks");
        }
      }
    }
  }
  // The old objects, the robot's after them, the ground last (as scene_collision orders them).
  std::vector<CollisionObject> objects;
  std::vector<int> scene_object, body;
  for (size_t i = 0; i < old.model.objects().size(); ++i) {
    if (static_cast<int>(i) == old.ground) continue;
    objects.push_back(old.model.objects()[i]);
    scene_object.push_back(old.scene_object[i]);
    body.push_back(old.body[i]);
  }
  CollisionOptions opt = old.model.options();
  try {
    append_robot_collision(m, g, gz, rc, objects, opt);
  } catch (const std::invalid_argument& err) {
    throw WorldError(K::Resource, err.what());
  }
  scene_object.resize(objects.size(), -1);
  body.resize(objects.size(), -1);
  int ground = -1;
  if (old.ground >= 0) {
    ground = static_cast<int>(objects.size());
    objects.push_back(old.model.objects()[old.ground]);
    scene_object.push_back(-1);
    body.push_back(-1);
  }
  auto sc = collision_like(old, ground, old.robot_frames + m.n + 1);
  sc->warnings.insert(sc->warnings.end(), g.warnings.begin(), g.warnings.end());
  try {
    sc->model = CollisionModel(std::move(objects), std::move(opt));
  } catch (const std::invalid_argument& err) {
    throw WorldError(K::Resource, "robot '" + e.spawned + "': " + err.what());
  }
  sc->scene_object = std::move(scene_object);
  sc->body = std::move(body);
  e.scene_collision = std::move(sc);
  std::vector<const Model*> robots = extra_robot_models();
  std::vector<bool> limits;
  // constraints_start, not constraints: a reset beside this preparation replaces the latter.
  for (const auto& r : extra_) {
    limits.push_back(r->constraints_start && r->constraints_start->spec().joint_limits);
  }
  robots.push_back(&m);
  limits.push_back(sp.joint_limits);
  e.constraints = coupled_constraints(body_models_, robots, limits);
  e.constraints_start = std::make_unique<ConstraintSystem>(*e.constraints);
}

void Simulator::without_robot_collision(int k, WorldEdit& e) const {
  const SceneCollision& old = *scene_collision_;
  int first = old.robot_bodies + old.free_objects;
  for (int j = 1; j < k; ++j) first += extra(j).model->n + 1;
  const int count = extra(k).model->n + 1;
  const int end = first + count;
  auto moved = [&](int f) { return f >= end ? f - count : f; };
  auto gone = [&](int f) { return f >= first && f < end; };
  std::vector<CollisionObject> objects;
  std::vector<int> scene_object, body, groups;
  int ground = -1;
  for (size_t i = 0; i < old.model.objects().size(); ++i) {
    CollisionObject o = old.model.objects()[i];
    if (gone(o.frame)) {
      groups.push_back(o.group);
      continue;
    }
    o.frame = moved(o.frame);
    if (static_cast<int>(i) == old.ground) ground = static_cast<int>(objects.size());
    objects.push_back(std::move(o));
    scene_object.push_back(old.scene_object[i]);
    body.push_back(old.body[i]);
  }
  CollisionOptions opt = old.model.options();
  std::vector<FramePair> adjacent;
  for (const FramePair& p : opt.adjacent) {
    if (!gone(p.a) && !gone(p.b)) adjacent.push_back({moved(p.a), moved(p.b)});
  }
  opt.adjacent = std::move(adjacent);
  auto in = [](const std::vector<int>& v, int x) {
    return std::find(v.begin(), v.end(), x) != v.end();
  };
  std::vector<int> self;
  for (const int gr : opt.self_colliding_groups) {
    if (!in(groups, gr)) self.push_back(gr);
  }
  opt.self_colliding_groups = std::move(self);
  const std::string prefix = extra(k).name + "/";
  std::vector<std::pair<std::string, std::string>> pairs;
  for (const auto& p : opt.disabled_links) {
    if (p.first.compare(0, prefix.size(), prefix) != 0) pairs.push_back(p);
  }
  opt.disabled_links = std::move(pairs);
  auto sc = collision_like(old, ground, old.robot_frames - count);
  try {
    sc->model = CollisionModel(std::move(objects), std::move(opt));
  } catch (const std::invalid_argument& err) {
    throw WorldError(WorldError::Kind::Invalid, err.what());
  }
  sc->scene_object = std::move(scene_object);
  sc->body = std::move(body);
  e.scene_collision = std::move(sc);
  std::vector<const Model*> robots;
  std::vector<bool> limits;
  for (size_t j = 0; j < extra_.size(); ++j) {
    if (static_cast<int>(j) + 1 == k) continue;
    robots.push_back(extra_[j]->model.get());
    limits.push_back(extra_[j]->constraints_start &&
                     extra_[j]->constraints_start->spec().joint_limits);
  }
  e.constraints = coupled_constraints(body_models_, robots, limits);
  e.constraints_start = std::make_unique<ConstraintSystem>(*e.constraints);
}

std::unique_ptr<ConstraintSystem> Simulator::coupled_constraints(
    const std::vector<const Model*>& bodies, const std::vector<const Model*>& robots,
    const std::vector<bool>& limits) const {
  // As rebuild_constraints builds it (the initial state was projected when it ran).
  ConstraintSpec spec = spec_;
  if (config_.mimic_joints && !model_->mimics.empty()) {
    const std::vector<BilateralConstraint> mimics = mimic_constraints(*model_);
    spec.bilateral.insert(spec.bilateral.end(), mimics.begin(), mimics.end());
  }
  auto c = std::make_unique<ConstraintSystem>(*model_, spec);
  c->set_free_bodies(bodies, 64 + static_cast<int>(16 * (bodies.size() + robots.size())), robots,
                     limits);
  c->anchor(initial_);
  return c;
}

void Simulator::swap_robot_collision(WorldEdit& e) {
  if (!e.scene_collision) return;
  scene_collision_ = std::move(e.scene_collision);
  constraints_ = std::move(e.constraints);
  constraints_start_ = std::move(e.constraints_start);
  frame_poses_.assign(model_->n + 1 + bodies_.size() + scene_collision_->robot_frames, SE3());
  collision_data_.contacts.reserve(256 + 64 * (bodies_.size() + extra_.size()));
}

std::string Simulator::spawn_robot(const RobotSpawn& spawn) {
  WorldEditPtr e = prepare_spawn_robot(spawn);
  const std::string name = e->spawned;
  commit(std::move(e));
  return name;
}

std::string Simulator::commit_robot(WorldEdit& e) {
  if (!e.spawned.empty()) {
    if (!e.extra) throw WorldError(WorldError::Kind::Invalid, "the edit was committed");
    insert_robot(std::move(e.extra));
    swap_robot_collision(e);
    ++spawned_;
  } else {
    const int k = robot_index(e.deleted);
    if (k < 1) {
      throw WorldError(WorldError::Kind::NotFound, "name '" + e.deleted + "': no such robot");
    }
    remove_robot(k);
    swap_robot_collision(e);
    ++deleted_;
  }
  ++world_generation_;
  contacts_fresh_ = false;
  return interpenetration_report();
}

}  // namespace se3
