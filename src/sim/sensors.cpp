// SensorSet (sensors.h): IMU, force-torque and contact readings from a step's motion.
#include "se3_sim/sim/sensors.h"

#include <urdf_model/model.h>

#include <algorithm>
#include <cmath>

#include "se3_sim/collision/collision.h"
#include "se3_sim/model/model.h"
#include "se3_sim/sim/sim.h"
#include "se3_sim/solver/constraints.h"

namespace se3 {
namespace {

std::string sensor_where(const SensorSpec& s) {
  return "sensor '" + s.name + "'" + (s.where.empty() ? "" : " (" + s.where + ")");
}

// The world pose of body b from the joint transforms of the last rnea (Data::Xup).
SE3 body_pose(const Model& m, const Data& d, const SE3& base, int b) {
  SE3 T;
  for (int j = b; j > 0; j = m.parent[j]) T = d.Xup[j] * T;
  return base * T;
}

}  // namespace

std::uint64_t SensorSet::seed_of(const std::string& name) {
  std::uint64_t h = 14695981039346656037ull;
  for (const char c : name) {
    h ^= static_cast<unsigned char>(c);
    h *= 1099511628211ull;
  }
  return h;
}

SensorSet::SensorSet(const Model& model, const std::vector<SensorSpec>& specs,
                     const std::string& urdf_xml, const std::string& robot)
    : model_(&model),
      robot_(robot),
      prefix_(robot.empty() ? "" : robot + "/"),
      specs_(specs),
      data_(model),
      x0_(model),
      a_(VecX::Zero(model.nv)) {
  std::shared_ptr<const urdf::ModelInterface> urdf;
  const int nl = static_cast<int>(model.links.size());
  for (const SensorSpec& s : specs_) {
    Resolved r;
    int li = -1;
    if (sensor_is_rendered(s.type)) {  // drawn elsewhere (the ros layer): never sampled here
      sensors_.push_back(std::move(r));
      continue;
    }
    if (s.type == SensorType::ForceTorque) {
      for (int l = 0; l < nl; ++l) {
        if (!model.links[l].joint.empty() && model.links[l].joint == s.joint) li = l;
      }
      if (li < 0) {
        throw SensorError(sensor_where(s) + ": joint '" + s.joint + "' is not in the robot");
      }
    } else {
      li = model.link_index(s.link);
      if (li < 0) {
        throw SensorError(sensor_where(s) + ": link '" + s.link + "' is not in the robot");
      }
    }
    const LinkFrame& lf = model.links[li];
    r.body = lf.body;
    r.collision_link = prefix_ + lf.name;
    r.in_body = lf.offset * s.pose;
    r.period = 1;  // from the rate and the simulator's dt, in before_step
    if (s.type == SensorType::ForceTorque) {
      // The URDF subtree below the joint: links whose parent chain reaches li.
      std::vector<char> in(nl, 0);
      for (int l = 0; l < nl; ++l) {
        for (int k = l; k >= 0; k = model.links[k].parent) {
          if (k == li) {
            in[l] = 1;
            break;
          }
        }
        if (in[l]) r.links.push_back(l);
      }
      r.in_subtree_body.assign(model.n + 1, 0);
      r.whole_body = r.body > 0 && model.body_name[r.body] == lf.name;
      if (r.whole_body) {
        for (int k = r.body; k <= model.subtree_end[r.body]; ++k) r.in_subtree_body[k] = 1;
      } else {
        for (int k = 1; k <= model.n; ++k) {
          if (model.parent[k] != r.body) continue;
          const int lk = model.link_index(model.body_name[k]);
          if (lk < 0 || !in[lk]) continue;
          r.children.push_back(k);
          for (int j = k; j <= model.subtree_end[k]; ++j) r.in_subtree_body[j] = 1;
        }
        // The links of the subtree merged into the body: their inertias from the URDF.
        if (!urdf) {
          if (urdf_xml.empty()) {
            throw SensorError(sensor_where(s) + ": joint '" + s.joint +
                              "' is fixed and the URDF text is not at hand");
          }
          // Through the guarded parse (model.h), never urdfdom's own: it formats the text it
          // quotes printf-style.
          try {
            urdf = parse_urdf_document(urdf_xml).urdf;
          } catch (const ModelError& e) {
            throw SensorError(sensor_where(s) + ": " + e.what());
          }
        }
        for (int l : r.links) {
          if (model.links[l].body != r.body) continue;
          auto link = urdf->getLink(model.links[l].name);
          if (!link) link = urdf->getLink("/" + model.links[l].name);
          if (!link || !link->inertial) continue;
          const auto& in_ = *link->inertial;
          const auto& o = in_.origin;
          double qx, qy, qz, qw;
          o.rotation.getQuaternion(qx, qy, qz, qw);
          const Mat3 R = rotation_from_quaternion(qx, qy, qz, qw);
          Mat3 Ic;
          Ic << in_.ixx, in_.ixy, in_.ixz, in_.ixy, in_.iyy, in_.iyz, in_.ixz, in_.iyz, in_.izz;
          const Inertia il = Inertia::from_com(
              in_.mass, Vec3(o.position.x, o.position.y, o.position.z), R * Ic * R.transpose());
          il.add_transformed(model.links[l].offset, r.part);
        }
      }
    }
    sensors_.push_back(std::move(r));
  }
  readings_.resize(specs_.size());
  for (size_t i = 0; i < specs_.size(); ++i) {
    if (specs_[i].type == SensorType::Contact) readings_[i].touches.resize(64);
  }
  reset();
}

void SensorSet::reset() {
  for (size_t i = 0; i < sensors_.size(); ++i) {
    sensors_[i].rng.seed(seed_of(specs_[i].name));
    readings_[i].ready = false;
    readings_[i].count = 0;
  }
  draw_biases();
  pending_ = false;
}

void SensorSet::draw_biases() {
  for (size_t i = 0; i < sensors_.size(); ++i) {
    const double b = specs_[i].noise.bias;
    Resolved& s = sensors_[i];
    s.bias.setZero();
    if (b == 0) continue;
    std::normal_distribution<double> n(0.0, b);
    for (int k = 0; k < 6; ++k) s.bias[k] = n(s.rng);
  }
}

double SensorSet::noise(Resolved& s, const SensorNoise& n) {
  if (n.stddev == 0) return n.mean;
  std::normal_distribution<double> d(n.mean, n.stddev);
  return d(s.rng);
}

int SensorSet::robot_index(const Simulator& sim) const {
  return robot_.empty() ? 0 : sim.robot_index(robot_);
}

int SensorSet::link_of(const CollisionObject& obj) const {
  const std::string& name = obj.link;
  if (name.size() <= prefix_.size() || name.compare(0, prefix_.size(), prefix_) != 0) return -1;
  for (size_t l = 0; l < model_->links.size(); ++l) {
    const std::string& own = model_->links[l].name;
    if (name.size() == prefix_.size() + own.size() &&
        name.compare(prefix_.size(), own.size(), own) == 0) {
      return static_cast<int>(l);
    }
  }
  return -1;
}

void SensorSet::before_step(const Simulator& sim) {
  pending_ = false;
  const int robot = robot_index(sim);
  if (robot < 0) return;
  const std::uint64_t k = sim.steps();
  bool due = false;
  if (sim.dt() != dt_) {  // the periods follow the step size
    dt_ = sim.dt();
    for (size_t i = 0; i < sensors_.size(); ++i) {
      const double rate = specs_[i].rate;
      sensors_[i].period =
          rate > 0 ? static_cast<int>(std::max(1.0, std::round(1.0 / (rate * dt_)))) : 1;
    }
  }
  for (size_t i = 0; i < sensors_.size(); ++i) {
    due = due || (!sensor_is_rendered(specs_[i].type) && k % sensors_[i].period == 0);
  }
  if (!due) return;
  const State& x = sim.robot_state(robot);
  x0_.base = x.base;
  x0_.q = x.q;
  x0_.v = x.v;
  t0_ = sim.time();
  step0_ = k;
  const ConstraintSystem* cs = sim.constraints();
  velocity_steps0_ = cs ? cs->report().velocity_steps : 0;
  pending_ = true;
}

void SensorSet::after_step(const Simulator& sim, bool ok) {
  if (!pending_) return;
  pending_ = false;
  if (!ok || sim.steps() != step0_ + 1) return;
  const int robot = robot_index(sim);
  if (robot < 0) return;
  const Model& m = *model_;
  a_ = (sim.robot_state(robot).v - x0_.v) / sim.dt();
  rnea(m, data_, x0_.base, x0_.q, x0_.v, a_);
  const ConstraintSystem* cs = sim.constraints();
  contact_step_ = cs && cs->report().velocity_steps != velocity_steps0_;
  for (size_t i = 0; i < sensors_.size(); ++i) {
    if (sensor_is_rendered(specs_[i].type)) continue;
    if (step0_ % sensors_[i].period == 0) sample(sim, static_cast<int>(i));
  }
}

void SensorSet::sample(const Simulator& sim, int i) {
  const Model& m = *model_;
  Resolved& s = sensors_[i];
  const SensorSpec& spec = specs_[i];
  SensorReading& out = readings_[i];
  out.stamp = t0_;
  const int b = s.body;
  if (spec.type == SensorType::Imu) {
    const SE3 oMs = body_pose(m, data_, x0_.base, b) * s.in_body;
    out.orientation = Eigen::Quaterniond(oMs.R);
    const Vec3 w = data_.V[b].head<3>(), v = data_.V[b].tail<3>();
    const Vec3 alpha = data_.A[b].head<3>();
    const Vec3& r = s.in_body.p;
    // The point's acceleration (body axes), gravity folded in: the specific force.
    const Vec3 acc = data_.A[b].tail<3>() + w.cross(v) + alpha.cross(r) + w.cross(w.cross(r));
    out.angular_velocity = s.in_body.R.transpose() * w;
    out.linear_acceleration = s.in_body.R.transpose() * acc;
    if (spec.noise.any()) {
      for (int k = 0; k < 3; ++k) {
        out.angular_velocity[k] += s.bias[k] + noise(s, spec.noise);
        out.linear_acceleration[k] += s.bias[3 + k] + noise(s, spec.noise);
      }
    }
  } else if (spec.type == SensorType::ForceTorque) {
    // The wrench the parent side applies on the subtree (body frame, about its origin): the
    // subtree's rate of momentum change with gravity folded in, less the outside forces on it.
    Vec6 W;
    if (s.whole_body) {
      W = data_.F[b];
    } else {
      const Vec6& V = data_.V[b];
      W = s.part * data_.A[b] + cross_force(V, s.part * V);
      for (int k : s.children) W += act_force(data_.Xup[k], data_.F[k]);
    }
    W -= external_wrench(sim, s);
    // Child on parent (SDF's child_to_parent), in the sensor frame.
    const Vec6 Ws = act_inv_force(s.in_body, -W);
    out.torque = Ws.head<3>();
    out.force = Ws.tail<3>();
    if (spec.noise.any()) {
      for (int k = 0; k < 3; ++k) {
        out.torque[k] += s.bias[k] + noise(s, spec.noise);
        out.force[k] += s.bias[3 + k] + noise(s, spec.noise);
      }
    }
  } else {
    fill_contacts(sim, i);
  }
  out.ready = true;
}

// The outside forces of the step on the force-torque sensor's subtree (body frame of s.body,
// about its origin): the contact spheres' forces on bodies wholly in the subtree, and the
// collision layer's contacts on the subtree's links (impulse / dt).
Vec6 SensorSet::external_wrench(const Simulator& sim, const Resolved& s) const {
  Vec6 W = Vec6::Zero();
  const ConstraintSystem* cs = sim.constraints();
  if (!cs || !contact_step_) return W;
  SE3 oMb;
  bool posed = false;  // the body's pose only when a force acts
  auto add = [&](const Vec3& p, const Vec3& f) {
    if (!posed) oMb = body_pose(*model_, data_, x0_.base, s.body);
    posed = true;
    const Vec3 fb = oMb.R.transpose() * f;
    W.head<3>() += oMb.act_inv(p).cross(fb);
    W.tail<3>() += fb;
  };
  for (const ConstraintForce& f : cs->forces()) {
    if (!robot_.empty()) break;  // the constraint system's own contact spheres are robot 0's
    if (f.kind != ConstraintForce::Contact || f.body < 0 || f.body > model_->n) continue;
    if (s.in_subtree_body[f.body] || (s.whole_body && f.body == s.body)) add(f.point, f.force);
  }
  const std::vector<CollisionObject>* objects = sim.contact_objects();
  if (!objects) return W;
  const double inv_dt = 1.0 / sim.dt();
  const auto& ext = cs->external();
  for (int k = 0; k < cs->external_count(); ++k) {
    const auto& c = ext[k];
    for (int side = 0; side < 2; ++side) {
      const int o = side ? c.b : c.a;
      if (o < 0 || o >= static_cast<int>(objects->size())) continue;
      const CollisionObject& obj = (*objects)[o];
      // Robot 0's shapes are on frames 0..n by their bare link names; a robot 1..'s carry its
      // prefix (their frames come after the objects').
      int body = obj.frame, link = -1;
      if (!robot_.empty()) {
        link = link_of(obj);
        if (link < 0) continue;
        body = model_->links[link].body;
      }
      if (body < 0 || body > model_->n) continue;
      bool in = s.in_subtree_body[body] != 0;
      if (!in && body == s.body) {
        in = s.whole_body;
        for (int l : s.links) {
          in = in || (robot_.empty() ? model_->links[l].name == obj.link : l == link);
        }
      }
      if (in) add(c.point, (side ? inv_dt : -inv_dt) * c.impulse);
    }
  }
  return W;
}

void SensorSet::fill_contacts(const Simulator& sim, int i) {
  SensorReading& out = readings_[i];
  out.count = 0;
  out.total_force.setZero();
  const ConstraintSystem* cs = sim.constraints();
  const std::vector<CollisionObject>* objects = sim.contact_objects();
  if (!cs || !objects || !contact_step_) return;
  const double inv_dt = 1.0 / sim.dt();
  const auto& ext = cs->external();
  for (int k = 0; k < cs->external_count(); ++k) {
    const auto& c = ext[k];
    for (int side = 0; side < 2; ++side) {
      const int o = side ? c.b : c.a, other = side ? c.a : c.b;
      if (o < 0 || o >= static_cast<int>(objects->size())) continue;
      const CollisionObject& obj = (*objects)[o];
      if (obj.link != sensors_[i].collision_link) continue;
      if (robot_.empty() && obj.frame != sensors_[i].body) continue;
      const Vec3 f = (side ? inv_dt : -inv_dt) * c.impulse;
      if (c.depth < 0 && f.squaredNorm() == 0) continue;  // within the margin, not touching
      if (out.count == static_cast<int>(out.touches.size())) continue;
      SensorReading::Touch& t = out.touches[out.count++];
      t.self = obj.name;
      t.other = other >= 0 && other < static_cast<int>(objects->size()) ? (*objects)[other].name
                                                                        : std::string();
      t.position = c.point;
      t.normal = side ? c.normal : Vec3(-c.normal);
      t.depth = c.depth;
      t.force = f;
      out.total_force += f;
    }
  }
}

}  // namespace se3
