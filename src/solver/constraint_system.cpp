// Constrained dynamics: bilateral constraints with multipliers from eq. (32), their projection,
// and the velocity level of time stepping with joint limits, Coulomb contact and free bodies
// (constraints.h), on the rows of constraint.h and the solvers of solver.h.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "se3_sim/solver/constraints.h"

namespace se3 {

std::string constraint_type_name(ConstraintType t) {
  switch (t) {
    case ConstraintType::PointWorld:
      return "point_world";
    case ConstraintType::PointPoint:
      return "point_point";
    case ConstraintType::AxisParallel:
      return "axis_parallel";
    case ConstraintType::JointCoupling:
      return "joint_coupling";
  }
  return "unknown";
}

std::vector<BilateralConstraint> mimic_constraints(const Model& model) {
  std::vector<BilateralConstraint> out;
  for (const JointMimic& mm : model.mimics) {
    BilateralConstraint c;
    c.type = ConstraintType::JointCoupling;
    c.joint = model.joint_name[mm.joint];
    c.leader = model.joint_name[mm.leader];
    c.name = "mimic:" + c.joint;
    c.multiplier = mm.multiplier;
    c.offset = mm.offset;
    out.push_back(c);
  }
  return out;
}

namespace {

bool is_world(const std::string& link) {
  return link.empty() || link == "world";
}

Vec3 unit(const Vec3& v, const std::string& what) {
  const double len = v.norm();
  if (!(len > 1e-12) || !std::isfinite(len)) throw ModelError(what + " needs a non-zero vector");
  return v / len;
}

}  // namespace

ConstraintSystem::ConstraintSystem(const Model& model, const ConstraintSpec& spec)
    : model_(model), spec_(spec), opt_(spec.options), data_(model) {
  const int nv = model.nv;
  auto resolve = [&](const std::string& link, const Vec3& point, const std::string& who) {
    PointRef p;
    if (is_world(link)) {
      p.body = -1;
      p.r = point;
      return p;
    }
    const int k = model.link_index(link);
    if (k < 0) throw ModelError(who + ": the model has no link '" + link + "'");
    p.body = model.links[k].body;
    p.r = model.links[k].offset.act(point);
    return p;
  };
  if (!(opt_.baumgarte_omega >= 0) || !(opt_.baumgarte_zeta >= 0) || !(opt_.erp >= 0) ||
      !(opt_.erp <= 1) || !(opt_.slop >= 0) || !(opt_.max_correction_velocity > 0) ||
      !(opt_.margin >= 0) || opt_.pgs_iterations < 1 || !(opt_.singular_tol > 0) ||
      !(spec.mu >= 0) || !std::isfinite(spec.mu)) {
    throw ModelError("constraint options out of range");
  }
  if (spec_.joint_limits) {  // limits on a model without any: no rows, no velocity-level step
    bool any = false;
    for (int i = 1; i <= model.n; ++i) {
      any = any || std::isfinite(model.lower[i]) || std::isfinite(model.upper[i]);
    }
    spec_.joint_limits = any;
  }
  alpha_ = 2.0 * opt_.baumgarte_zeta * opt_.baumgarte_omega;
  beta2_ = opt_.baumgarte_omega * opt_.baumgarte_omega;
  int row = 0;
  for (size_t k = 0; k < spec.bilateral.size(); ++k) {
    const BilateralConstraint& c = spec.bilateral[k];
    Bil b;
    b.type = c.type;
    b.name = c.name.empty() ? constraint_type_name(c.type) + std::to_string(k) : c.name;
    b.row0 = row;
    if (c.type == ConstraintType::JointCoupling) {
      b.a.body = model.joint_index(c.joint);
      b.b.body = model.joint_index(c.leader);
      if (b.a.body < 1)
        throw ModelError(b.name + ": the model has no moving joint '" + c.joint + "'");
      if (b.b.body < 1) {
        throw ModelError(b.name + ": the model has no moving joint '" + c.leader + "' to follow");
      }
      if (b.a.body == b.b.body) throw ModelError(b.name + ": a joint cannot follow itself");
      if (!std::isfinite(c.multiplier) || !std::isfinite(c.offset)) {
        throw ModelError(b.name + ": multiplier and offset must be finite");
      }
      b.mult = c.multiplier;
      b.off = c.offset;
      ++row;
      bil_.push_back(b);
      continue;
    }
    if (is_world(c.link_a)) throw ModelError(b.name + ": link_a must be a link of the model");
    b.a = resolve(c.link_a, c.point_a, b.name);
    if (c.type == ConstraintType::AxisParallel) {
      const int k_link = model.link_index(c.link_a);
      b.axis_a = model.links[k_link].offset.R * unit(c.axis_a, b.name + " axis_a");
      b.axis_w = unit(c.axis_world, b.name + " axis_world");
      Vec3 t1, t2;
      tangent_basis(b.axis_w, t1, t2);
      b.dirs = {t1, t2};
    } else {
      if (c.type == ConstraintType::PointPoint) {
        if (is_world(c.link_b)) throw ModelError(b.name + ": point_point needs link_b");
        b.b = resolve(c.link_b, c.point_b, b.name);
        if (b.b.body == b.a.body) throw ModelError(b.name + ": both points on one body");
      } else {
        b.b.body = -1;
        b.b.r = c.point_b;
      }
      if (c.directions.empty()) {
        b.dirs = {Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitZ()};
      } else {
        for (const Vec3& d : c.directions) b.dirs.push_back(unit(d, b.name + " direction"));
      }
    }
    if (b.a.body == 0 && !model.floating) {
      throw ModelError(b.name + ": link '" + c.link_a + "' is fixed to the world");
    }
    row += static_cast<int>(b.dirs.size());
    bil_.push_back(b);
  }
  nb_ = row;

  if (spec.ground) {
    spec_.ground_normal = unit(spec.ground_normal, "ground normal");
    int idx = 0;
    for (const ContactPoint& c : spec.contacts) {
      if (!(c.radius >= 0)) throw ModelError("contact on '" + c.link + "': radius must be >= 0");
      contacts_.push_back(resolve(c.link, c.position, "contact"));
      if (contacts_.back().body < 0) throw ModelError("contact needs a link of the model");
      contact_radius_.push_back(c.radius);
      contact_names_.push_back("contact:" +
                               (c.name.empty() ? c.link + ":" + std::to_string(idx) : c.name));
      ++idx;
    }
    if (spec.contacts_from_collisions) {
      if (!spec.geometry) {
        throw ModelError("contacts from collisions need the model's collision geometry");
      }
      for (const GeometryObject& geo : spec.geometry->collisions) {
        const int body = geo.body;
        if (body < 0 || body > model.n) continue;
        const std::string base_name =
            "contact:" + (geo.link.empty() ? model.body_name[body] : geo.link) + ":";
        auto add = [&](const Vec3& local, double radius) {
          PointRef p;
          p.body = body;
          p.r = geo.placement.act(local);
          contacts_.push_back(p);
          contact_radius_.push_back(radius);
          contact_names_.push_back(base_name + std::to_string(idx++));
        };
        const Shape& sh = geo.shape;
        switch (sh.type) {
          case ShapeType::Sphere:
            add(Vec3::Zero(), sh.radius);
            break;
          case ShapeType::Box:
            for (int c = 0; c < 8; ++c) {
              add(0.5 * Vec3((c & 1) ? sh.box.x() : -sh.box.x(), (c & 2) ? sh.box.y() : -sh.box.y(),
                             (c & 4) ? sh.box.z() : -sh.box.z()),
                  0.0);
            }
            break;
          case ShapeType::Cylinder:
            for (int e = -1; e <= 1; e += 2) {
              for (int k = 0; k < 8; ++k) {
                const double t = k * M_PI / 4;
                add(Vec3(sh.radius * std::cos(t), sh.radius * std::sin(t), 0.5 * e * sh.length),
                    0.0);
              }
            }
            break;
          case ShapeType::Capsule:
            add(Vec3(0, 0, -0.5 * sh.length), sh.radius);
            add(Vec3(0, 0, 0.5 * sh.length), sh.radius);
            break;
          case ShapeType::Mesh:
            break;
        }
      }
    }
  }
  const int nc = static_cast<int>(contacts_.size());
  params_.erp = opt_.erp;
  params_.slop = opt_.slop;
  params_.bilateral_erp = opt_.bilateral_erp;
  params_.margin = opt_.margin;
  params_.restitution_velocity = opt_.restitution_velocity;
  params_.limit_restitution = opt_.limit_restitution;
  params_.max_correction_velocity = opt_.max_correction_velocity;
  solver_opt_.iterations = opt_.pgs_iterations;
  solver_opt_.tol = opt_.pgs_tol;
  solver_opt_.singular_tol = opt_.singular_tol;

  data_.reserve_minv(model);  // minv runs inside time steps
  fk_q_ = VecX::Zero(model.nq);
  kin_.reset(model, data_.oMb, 0);
  Vb_.assign(model.n + 1, Vec6::Zero());
  Ab_.assign(model.n + 1, Vec6::Zero());
  Psi_ = ConstraintRows::RowMat::Zero(nb_, nv);
  Yb_ = MatX::Zero(nv, nb_);
  Wb_ = MatX::Zero(nb_, nb_);
  phi_ = VecX::Zero(nb_);
  gamma_ = VecX::Zero(nb_);
  rhs_ = VecX::Zero(nb_);
  lambda_ = VecX::Zero(nb_);
  mult_ = VecX::Zero(nb_);
  a_ = VecX::Zero(nv);
  dq_ = VecX::Zero(nv);
  warm_contact_.assign(nc, Vec3::Zero());
  warm_lower_.assign(model.n + 1, 0.0);
  warm_upper_.assign(model.n + 1, 0.0);
  warm_bil_ = VecX::Zero(nb_);
  contact_gap_.assign(nc, std::numeric_limits<double>::infinity());
  // The contact spheres and the ground as collision objects on the robot's frames.
  for (int k = 0; k < nc; ++k) {
    CollisionObject o;
    o.name = contact_names_[k];
    o.frame = contacts_[k].body;
    o.shape.type = ShapeType::Sphere;
    o.shape.radius = contact_radius_[k];
    o.mu = spec.mu;
    o.restitution = opt_.restitution;
    ground_objects_.push_back(o);
  }
  CollisionObject ground;
  ground.name = "ground";
  ground.frame = CollisionObject::kWorld;
  ground.halfspace = true;
  ground.mu = spec.mu;
  ground.restitution = opt_.restitution;
  ground_objects_.push_back(ground);
  ground_contacts_.reserve(nc);
  ground_contact_sphere_.reserve(nc);
  set_free_bodies({});
  for (const Bil& b : bil_) {
    ConstraintForce f;
    f.kind = ConstraintForce::Bilateral;
    f.name = b.name;
    f.body = b.a.body;
    forces_.push_back(f);
  }
  if (spec_.joint_limits) {
    for (int i = 1; i <= model.n; ++i) {
      if (!std::isfinite(model.lower[i]) && !std::isfinite(model.upper[i])) continue;
      ConstraintForce f;
      f.kind = ConstraintForce::Limit;
      f.name = "limit:" + model.joint_name[i];
      f.body = i;
      forces_.push_back(f);
      limit_force_index_.push_back(i);
    }
  }
  for (int k = 0; k < nc; ++k) {
    ConstraintForce f;
    f.kind = ConstraintForce::Contact;
    f.name = contact_names_[k];
    f.body = contacts_[k].body;
    forces_.push_back(f);
  }
  report_.bilateral_rows = nb_;
}

void ConstraintSystem::anchor(const State& x) {
  kinematics(x.base, x.q, nullptr);
  for (size_t k = 0; k < bil_.size(); ++k) {
    if (bil_[k].type == ConstraintType::PointWorld && spec_.bilateral[k].world_point_from_initial) {
      bil_[k].b.r = point_world(bil_[k].a);
    }
  }
}

void ConstraintSystem::set_free_bodies(const std::vector<const Model*>& bodies,
                                       int max_external_contacts,
                                       const std::vector<const Model*>& robots,
                                       const std::vector<bool>& robot_limits) {
  free_.clear();
  free_.reserve(bodies.size());
  for (const Model* m : bodies) {
    if (!m || m->n != 0 || !m->floating) {
      throw ModelError("a free body is a single free-floating body (n = 0)");
    }
    FreeBody f;
    f.model = m;
    f.Minv = m->inertia[0].matrix().inverse();
    if (!f.Minv.allFinite()) {
      const std::string& name = m->name.empty() ? m->body_name[0] : m->name;
      throw ModelError("free object '" + name +
                       "' has a singular inertia (mass or size too small)");
    }
    f.pose.assign(1, SE3());
    free_.push_back(std::move(f));
  }
  nv_total_ = model_.nv + 6 * static_cast<int>(free_.size());
  art_.clear();
  art_.reserve(robots.size());
  int art_bodies = 0, art_limit_rows = 0;
  for (size_t k = 0; k < robots.size(); ++k) {
    const Model* m = robots[k];
    if (!m) throw ModelError("a robot beside the system is null");
    art_.emplace_back(*m);
    ArtSystem& a = art_.back();
    a.col0 = nv_total_;
    a.limits = k < robot_limits.size() && robot_limits[k];
    a.warm_lower.assign(m->n + 1, 0.0);
    a.warm_upper.assign(m->n + 1, 0.0);
    a.data.reserve_minv(*m);
    if (a.limits) art_limit_rows += 2 * m->n;
    nv_total_ += m->nv;
    art_bodies += m->n + 1;
  }
  systems_.clear();
  systems_.push_back(&kin_);
  frames_.assign(model_.n + 1 + free_.size() + art_bodies, FrameRef{});
  for (int i = 0; i <= model_.n; ++i) frames_[i] = FrameRef{0, i};
  for (size_t j = 0; j < free_.size(); ++j) {
    free_[j].kin.reset(*free_[j].model, free_[j].pose, model_.nv + 6 * static_cast<int>(j));
    systems_.push_back(&free_[j].kin);
    frames_[model_.n + 1 + j] = FrameRef{static_cast<int>(j) + 1, 0};
  }
  for (size_t k = 0, f = model_.n + 1 + free_.size(); k < art_.size(); ++k) {
    ArtSystem& a = art_[k];
    a.kin.reset(*a.model, a.data.oMb, a.col0);
    systems_.push_back(&a.kin);
    const int s = static_cast<int>(1 + free_.size() + k);
    for (int i = 0; i <= a.model->n; ++i) frames_[f++] = FrameRef{s, i};
  }
  const int nc = static_cast<int>(contacts_.size());
  // Rows: bilateral, limits, the internal contacts, and room for contacts from outside.
  max_rows_ = nb_ + (spec_.joint_limits ? 2 * model_.n : 0) + 3 * nc +
              3 * std::max(0, max_external_contacts) + art_limit_rows;
  rows_.reserve(nv_total_, max_rows_);
  ws_.reserve(max_rows_, nb_);
  Y_ = MatX::Zero(nv_total_, max_rows_);
  W_ = MatX::Zero(max_rows_, max_rows_);
  c_ = VecX::Zero(max_rows_);
  p_ = VecX::Zero(max_rows_);
  vfree_ = VecX::Zero(nv_total_);
  row_mask_.assign(max_rows_, 0);
  delassus_ws_.reserve(model_.nv, max_rows_);
  const int nsys = 1 + static_cast<int>(free_.size());
  lazy_w_.reserve(max_rows_, nsys);
  lazy_w_.width[0] = model_.nv;
  // A row's dofs in one 64-bit mask (DelassusColumns::zmask).
  factored_delassus_ = model_.nv > 0 && model_.nv <= 64;
  if (factored_delassus_) {
    lazy_w_.reserve_factored(max_rows_, model_.nv);
    data_.reserve_crba(model_);
  }
  for (int j = 1; j < nsys; ++j) {
    lazy_w_.first[j] = model_.nv + 6 * (j - 1);
    lazy_w_.width[j] = 6;
  }
  one_contact_.assign(1, Contact{});
  warm_ext_.assign(std::max(0, max_external_contacts), WarmExternal{});
  warm_ext_next_.assign(warm_ext_.size(), WarmExternal{});
  warm_ext_count_ = 0;
}

ConstraintSystem::ArtSystem& ConstraintSystem::art_system_of_limit_row(int r) {
  for (ArtSystem& a : art_) {
    if (!rows_.J.row(r).segment(a.col0, a.model->nv).isZero(0)) return a;
  }
  return art_.back();  // not reached: such a row has its joint's column
}

void ConstraintSystem::bind() {
  // The kinematics views point into this object (a copy re-points them here).
  kin_.model = &model_;
  kin_.oMb = &data_.oMb;
  systems_[0] = &kin_;
  for (size_t j = 0; j < free_.size(); ++j) {
    free_[j].kin.oMb = &free_[j].pose;
    systems_[j + 1] = &free_[j].kin;
  }
  for (size_t k = 0; k < art_.size(); ++k) {
    art_[k].kin.model = art_[k].model;
    art_[k].kin.oMb = &art_[k].data.oMb;
    systems_[1 + free_.size() + k] = &art_[k].kin;
  }
}

bool ConstraintSystem::kinematics_at(const SE3& base, const VecX& q) const {
  return fk_current_ && base.p == fk_base_.p && base.R == fk_base_.R && q == fk_q_;
}

void ConstraintSystem::data_to(const SE3& base, const VecX& q) {
  if (!kinematics_at(base, q)) fk_current_ = false;
}

void ConstraintSystem::kinematics(const SE3& base, const VecX& q, const VecX* v) {
  bind();
  const Model& m = model_;
  if (!kinematics_at(base, q)) {
    forward_kinematics(model_, data_, base, q);
    kin_.update_world_axes();
    fk_base_ = base;
    fk_q_ = q;
    fk_current_ = true;
  }
  if (!v) return;
  body_twists(m, data_, *v);
  Vb_.swap(data_.V);  // kept here: the next aba call on data_ overwrites data_.V
  const std::vector<Vec6>& Vb = Vb_;
  Ab_[0].setZero();
  for (int i = 1; i <= m.n; ++i) {
    const int p = m.parent[i];
    Ab_[i] = act_inv_motion(data_.Xup[i], Ab_[p]);
    // S qdot x (body twist) ... the joint's velocity-product term: V_i x (S_i qdot_i).
    const Vec6 Sq = Vec6::Unit(m.joints[i].axis()) * (*v)[m.idx_v(i)];
    Ab_[i] += cross_motion(Vb[i], Sq);
  }
}

Vec3 ConstraintSystem::point_world(const PointRef& p) const {
  return p.body < 0 ? p.r : data_.oMb[p.body].act(p.r);
}

Vec3 ConstraintSystem::point_accel_bias(const PointRef& p) const {
  if (p.body < 0) return Vec3::Zero();
  const Vec6& V = Vb_[p.body];
  const Vec6& A = Ab_[p.body];
  const Vec3 w = V.head<3>();
  const Vec3 a =
      A.tail<3>() + w.cross(V.tail<3>()) + A.head<3>().cross(p.r) + w.cross(w.cross(p.r));
  return data_.oMb[p.body].R * a;
}

double ConstraintSystem::coupling_error(const Bil& b, const VecX& q) const {
  const double e = q[model_.idx_q(b.a.body)] - b.mult * q[model_.idx_q(b.b.body)] - b.off;
  return model_.continuous(b.a.body) ? wrap_angle(e) : e;
}

void ConstraintSystem::fill_bilateral(bool with_bias) {
  Psi_.setZero();
  for (const Bil& b : bil_) {
    if (b.type == ConstraintType::JointCoupling) {
      // q_a - m q_b - o: linear in q, so Psi_dot w = 0 (fk_q_ is the q of kinematics()).
      phi_[b.row0] = coupling_error(b, fk_q_);
      Psi_(b.row0, model_.idx_v(b.a.body)) += 1.0;
      Psi_(b.row0, model_.idx_v(b.b.body)) -= b.mult;
      if (with_bias) gamma_[b.row0] = 0;
    } else if (b.type == ConstraintType::AxisParallel) {
      const Mat3& R = data_.oMb[b.a.body].R;
      const Vec3 u = R * b.axis_a;
      Vec3 wdot = Vec3::Zero(), w = Vec3::Zero();
      if (with_bias) {
        w = R * Vb_[b.a.body].head<3>();
        wdot = R * Ab_[b.a.body].head<3>();
      }
      for (int k = 0; k < 2; ++k) {
        const Vec3& e = b.dirs[k];
        const int r = b.row0 + k;
        phi_[r] = e.dot(u);
        angular_jacobian(kin_, b.a.body, u.cross(e), 1.0, Psi_.row(r).data());
        if (with_bias) gamma_[r] = e.dot(wdot.cross(u) + w.cross(w.cross(u)));
      }
    } else {
      const Vec3 pa = point_world(b.a), pb = point_world(b.b);
      const Vec3 d_ab = pa - pb;
      Vec3 acc = Vec3::Zero();
      if (with_bias) acc = point_accel_bias(b.a) - point_accel_bias(b.b);
      for (size_t k = 0; k < b.dirs.size(); ++k) {
        const Vec3& d = b.dirs[k];
        const int r = b.row0 + static_cast<int>(k);
        phi_[r] = d.dot(d_ab);
        point_jacobian(kin_, b.a.body, pa, d, 1.0, Psi_.row(r).data());
        point_jacobian(kin_, b.b.body, pb, d, -1.0, Psi_.row(r).data());
        if (with_bias) gamma_[r] = d.dot(acc);
      }
    }
  }
}

void ConstraintSystem::bilateral(const SE3& base, const VecX& q, MatX& Psi, VecX& phi) {
  kinematics(base, q, nullptr);
  fill_bilateral(false);
  Psi = Psi_;
  phi = phi_;
}

void ConstraintSystem::bilateral_bias(const SE3& base, const VecX& q, const VecX& v, VecX& gamma) {
  kinematics(base, q, &v);
  fill_bilateral(true);
  gamma = gamma_;
}

void ConstraintSystem::solve_multipliers(const VecX& rhs, VecX& out) {
  ++report_.solves;
  if (rhs.size() == 0) return;
  const SolverStats st = solve_equality(Wb_, rhs, out, ws_, opt_.singular_tol);
  report_.rank = st.rank;
  if (st.singular) ++report_.singular_solves;
}

const VecX& ConstraintSystem::acceleration(const SE3& base, const VecX& q, const VecX& v,
                                           const VecX& tau) {
  data_to(base, q);
  a_ = aba(model_, data_, base, q, v, tau);  // a_free = D^-1 (tau - H)
  if (nb_ == 0) return a_;
  kinematics(base, q, &v);
  fill_bilateral(true);
  const MatX& Minv = minv(model_, data_, base, q);
  Yb_.noalias() = Minv * Psi_.transpose();  // D^-1 Psi^T
  Wb_.noalias() = Psi_ * Yb_;               // Psi D^-1 Psi^T
  // Written as GEMV updates: a negated or scaled product expression would be evaluated into a
  // heap temporary first (Eigen, found by counting calloc).
  rhs_ = -gamma_;
  rhs_.noalias() -= Psi_ * a_;
  if (alpha_ > 0) rhs_.noalias() -= (alpha_ * Psi_) * v;
  if (beta2_ > 0) rhs_ -= beta2_ * phi_;
  solve_multipliers(rhs_, lambda_);
  a_.noalias() += Yb_ * lambda_;
  return a_;
}

double ConstraintSystem::project(State& x) {
  if (nb_ == 0) return 0;
  double err = 0;
  for (int it = 0;; ++it) {
    kinematics(x.base, x.q, nullptr);
    fill_bilateral(false);
    err = phi_.cwiseAbs().maxCoeff();
    if (err <= opt_.projection_tol || it >= opt_.projection_iterations) break;
    data_to(x.base, x.q);
    const MatX& Minv = minv(model_, data_, x.base, x.q);
    Yb_.noalias() = Minv * Psi_.transpose();
    Wb_.noalias() = Psi_ * Yb_;
    rhs_ = -phi_;
    solve_multipliers(rhs_, mult_);
    dq_.noalias() = Yb_ * mult_;
    if (model_.floating) {
      x.base = x.base * exp_se3(dq_.head<6>());
      x.base.R = orthonormalize(x.base.R);
    }
    x.q.noalias() += dq_.tail(model_.n);
  }
  // Velocities: w -= D^-1 Psi^T (Psi D^-1 Psi^T)^+ Psi w (Psi_ is at the final positions).
  data_to(x.base, x.q);
  const MatX& Minv = minv(model_, data_, x.base, x.q);
  Yb_.noalias() = Minv * Psi_.transpose();
  Wb_.noalias() = Psi_ * Yb_;
  rhs_.setZero();
  rhs_.noalias() -= Psi_ * x.v;
  solve_multipliers(rhs_, mult_);
  x.v.noalias() += Yb_ * mult_;
  report_.bilateral_error = err;
  return err;
}

double ConstraintSystem::error(const State& x) {
  kinematics(x.base, x.q, nullptr);
  double e = 0;
  if (nb_ > 0) {
    fill_bilateral(false);
    e = phi_.cwiseAbs().maxCoeff();
  }
  if (spec_.joint_limits) {
    for (int i = 1; i <= model_.n; ++i) {
      const double qi = x.q[model_.idx_q(i)];
      if (std::isfinite(model_.lower[i])) e = std::max(e, model_.lower[i] - qi);
      if (std::isfinite(model_.upper[i])) e = std::max(e, qi - model_.upper[i]);
    }
  }
  if (spec_.ground) {
    const Vec3& n = spec_.ground_normal;
    for (size_t k = 0; k < contacts_.size(); ++k) {
      const double g = n.dot(point_world(contacts_[k])) - contact_radius_[k] - spec_.ground_offset;
      e = std::max(e, -g);
    }
  }
  return e;
}

void ConstraintSystem::finish_bilateral_step(State& x) {
  if (opt_.project) {
    project(x);
  } else {
    kinematics(x.base, x.q, nullptr);
    fill_bilateral(false);
    report_.bilateral_error = nb_ > 0 ? phi_.cwiseAbs().maxCoeff() : 0.0;
  }
  report_.rows = nb_;
  // Forces of the last stage's multipliers, placed at the end-of-step configuration.
  kinematics(x.base, x.q, nullptr);
  assemble_bilateral_forces(lambda_, 1.0);
}

void ConstraintSystem::assemble_bilateral_forces(const VecX& lam, double scale) {
  for (size_t k = 0; k < bil_.size(); ++k) {
    const Bil& b = bil_[k];
    ConstraintForce& f = forces_[k];
    if (b.type == ConstraintType::JointCoupling) {
      // The generalized force on the joint (N m or N along its axis); its leader gets -mult times.
      f.point = data_.oMb[b.a.body].p;
      f.force.setZero();
      f.torque.setZero();
      f.joint_force = scale * lam[b.row0];
      f.active = f.joint_force != 0;
      continue;
    }
    f.point = point_world(b.a);
    f.force.setZero();
    f.torque.setZero();
    for (size_t j = 0; j < b.dirs.size(); ++j) {
      const double l = scale * lam[b.row0 + static_cast<int>(j)];
      if (b.type == ConstraintType::AxisParallel) {
        f.torque += l * (data_.oMb[b.a.body].R * b.axis_a).cross(b.dirs[j]);
      } else {
        f.force += l * b.dirs[j];
      }
    }
    f.active = f.force.squaredNorm() + f.torque.squaredNorm() > 0;
  }
}

void ConstraintSystem::ground_contacts() {
  ground_contacts_.clear();
  ground_contact_sphere_.clear();
  const Vec3& nrm = spec_.ground_normal;
  for (size_t k = 0; k < contacts_.size(); ++k) {
    const PointRef& c = contacts_[k];
    if (c.body == 0 && !model_.floating) continue;
    const Vec3 lowest = point_world(c) - contact_radius_[k] * nrm;
    const double g = nrm.dot(lowest) - spec_.ground_offset;
    contact_gap_[k] = g;
    Contact ct;
    ct.a = static_cast<int>(contacts_.size());  // the ground
    ct.b = static_cast<int>(k);
    ct.point = lowest;
    ct.normal = nrm;
    ct.depth = -g;
    ground_contacts_.push_back(ct);
    ground_contact_sphere_.push_back(static_cast<int>(k));
  }
}

void ConstraintSystem::build_rows(const State& x, double h, const StepInput& in) {
  // Joint-limit rows need no kinematics (their Jacobian is +-1 on the joint's column): a robot
  // with limits alone steps without a forward-kinematics pass (minv makes one when a row is in).
  const bool need_kinematics = nb_ > 0 || spec_.ground || !free_.empty() || !art_.empty() ||
                               (in.contacts && !in.contacts->empty());
  if (need_kinematics) {
    kinematics(x.base, x.q, nullptr);
  } else {
    bind();
  }
  for (size_t j = 0; j < free_.size(); ++j) {
    free_[j].pose[0] = (*in.bodies)[j].base;
    free_[j].kin.update_world_axes();
  }
  if (!art_.empty() && !in.robots) {
    throw std::invalid_argument("velocity_step: the other robots' states are missing");
  }
  art_states_ = in.robots;
  for (size_t k = 0; k < art_.size(); ++k) {
    ArtSystem& a = art_[k];
    const State& s = (*in.robots)[k];
    forward_kinematics(*a.model, a.data, s.base, s.q);
    a.kin.update_world_axes();
    a.touched = false;
  }
  rows_.clear();
  // Bilateral rows, at the velocity level.
  for (size_t k = 0; k < bil_.size(); ++k) {
    const Bil& b = bil_[k];
    const int id = static_cast<int>(k);
    if (b.type == ConstraintType::JointCoupling) {
      const int r = rows_.add(RowType::Equality, id);
      rows_.J(r, model_.idx_v(b.a.body)) += 1.0;
      rows_.J(r, model_.idx_v(b.b.body)) -= b.mult;
      rows_.b[r] = -params_.bilateral_erp * coupling_error(b, x.q) / h;
    } else if (b.type == ConstraintType::AxisParallel) {
      add_axis_rows(rows_, kin_, b.a.body, data_.oMb[b.a.body].R * b.axis_a, b.dirs[0], b.dirs[1],
                    h, params_, id);
    } else {
      add_point_rows(rows_, kin_, b.a.body, point_world(b.a), &kin_, b.b.body, point_world(b.b),
                     b.dirs, h, params_, id);
    }
  }
  if (spec_.joint_limits) {
    add_joint_limit_rows(rows_, kin_, x.q, vfree_, h, params_);
  }
  // The contact spheres against the ground: a contact within reach (gap + approach h < margin).
  if (spec_.ground) {
    ground_contacts();
    for (const Contact& ct : ground_contacts_) {
      one_contact_[0] = ct;
      const int n = rows_.count;
      add_contact_rows(rows_, one_contact_, ground_objects_, frames_, systems_, vfree_, h, params_);
      rows_.id[n] = rows_.id[n + 1] = rows_.id[n + 2] = ct.b;  // the sphere
      const double vn = rows_.J.row(n).dot(vfree_);
      if (-ct.depth + h * std::min(0.0, vn) >= opt_.margin) rows_.count = n;  // out of reach
    }
  }
  internal_rows_end_ = rows_.count;
  if (in.contacts && in.objects && !in.contacts->empty()) {
    int art_limit_room = 0;  // kept for the other robots' limits, which come after
    for (const ArtSystem& a : art_) art_limit_room += a.limits ? 2 * a.model->n : 0;
    const int room = (rows_.capacity() - rows_.count - art_limit_room) / 3;
    if (static_cast<int>(in.contacts->size()) <= room) {
      add_contact_rows(rows_, *in.contacts, *in.objects, frames_, systems_, vfree_, h, params_);
    } else {  // the deepest first, as many as fit
      for (int k = 0; k < room; ++k) {
        one_contact_[0] = (*in.contacts)[k];
        const int n = rows_.count;
        add_contact_rows(rows_, one_contact_, *in.objects, frames_, systems_, vfree_, h, params_);
        for (int r = n; r < rows_.count; ++r) rows_.id[r] = k;  // the contact's index
      }
    }
  }
  // The other robots' joint limits (id: the joint; the robot from the row's columns).
  art_limit_rows_ = rows_.count;
  for (size_t k = 0; k < art_.size(); ++k) {
    if (art_[k].limits) {
      add_joint_limit_rows(rows_, art_[k].kin, (*in.robots)[k].q, vfree_, h, params_);
    }
  }
}

bool ConstraintSystem::unilateral_within_reach(const State& x, const VecX& a_free, double h,
                                               const StepInput& in) {
  vfree_.head(model_.nv) = x.v;
  vfree_.head(model_.nv).noalias() += h * a_free;
  for (size_t j = 0; j < free_.size() && in.bodies; ++j) {
    vfree_.segment<6>(model_.nv + 6 * j) = (*in.bodies)[j].v + h * (*in.body_a_free)[j];
  }
  for (size_t k = 0; k < art_.size() && in.robots; ++k) {
    const int nv = art_[k].model->nv;
    vfree_.segment(art_[k].col0, nv) = (*in.robots)[k].v + h * (*in.robot_a_free)[k];
  }
  build_rows(x, h, in);
  for (int r = 0; r < rows_.count; ++r) {
    if (rows_.type[r] != RowType::Equality) return true;
  }
  return false;
}

// A friction impulse within this (relative) of its disc's edge: the contact slid.
constexpr double kSlidEdge = 1e-6;

void ConstraintSystem::warm_start_external(int r, const Contact& ct) {
  // The nearest of last step's contacts of the same pair, within a radius: contacts that move
  // less than that per step keep their impulse (resting and slowly sliding ones).
  constexpr double kWarmRadius = 0.01;  // m
  double best = kWarmRadius * kWarmRadius;
  const WarmExternal* from = nullptr;
  for (int k = 0; k < warm_ext_count_; ++k) {
    const WarmExternal& w = warm_ext_[k];
    if (w.a != ct.a || w.b != ct.b) continue;
    const double d2 = (w.point - ct.point).squaredNorm();
    if (d2 < best) best = d2, from = &w;
  }
  if (!from) return;
  // The normal impulse: the active set's first guess is then "sticking" for a contact that
  // carried load (a stack's upper contacts, whose free residual is zero since both boxes fall
  // alike, would start separated and cost an update each). A contact whose friction was on its
  // disc's edge slid: its friction impulse too, in the new tangent basis and on the new disc's
  // edge, so that the active set's first guess classifies it from its residuals (sliding on, in
  // which direction, or sticking) instead of starting it sticking.
  const double dn = from->impulse.dot(ct.normal), pn = std::max(0.0, dn);
  p_[r] = pn;
  const double lim = rows_.mu[r] * pn, edge = lim * (1 - kSlidEdge);
  if (!(lim > 0) || from->impulse.squaredNorm() - dn * dn < edge * edge) return;
  Vec3 t1, t2;
  tangent_basis(ct.normal, t1, t2);  // the basis add_contact_rows uses
  const double f1 = from->impulse.dot(t1), f2 = from->impulse.dot(t2);
  const double s = lim / std::sqrt(f1 * f1 + f2 * f2);
  p_[rows_.friction[r]] = s * f1;
  p_[rows_.friction2[r]] = s * f2;
}

bool ConstraintSystem::row_masks(int rows) {
  const int nvr = model_.nv;
  const int nsys = 1 + static_cast<int>(free_.size());
  auto J = rows_.J.topRows(rows);
  bool robot_rows = false;
  for (int r = 0; r < rows; ++r) {
    std::uint64_t mask = 0;
    if (nvr > 0 && !J.row(r).head(nvr).isZero(0)) mask |= 1;
    for (int j = 1; j < nsys; ++j) {
      if (!J.row(r).segment<6>(nvr + 6 * (j - 1)).isZero(0)) mask |= std::uint64_t(1) << j;
    }
    for (size_t k = 0; k < art_.size(); ++k) {
      ArtSystem& a = art_[k];
      if (!J.row(r).segment(a.col0, a.model->nv).isZero(0)) {
        mask |= std::uint64_t(1) << (nsys + k);
        a.touched = true;
      }
    }
    row_mask_[r] = mask;
    robot_rows = robot_rows || (mask & 1);
  }
  return robot_rows;
}

void ConstraintSystem::free_body_inverse_mass_jacobian(int rows) {
  const int nvr = model_.nv;
  auto J = rows_.J.topRows(rows);
  const int nsys = 1 + static_cast<int>(free_.size());
  for (size_t k = 0; k < art_.size(); ++k) {
    ArtSystem& a = art_[k];
    const int nv = a.model->nv;
    if (!a.touched) {
      for (int r = 0; r < rows; ++r) Y_.col(r).segment(a.col0, nv).setZero();
      continue;
    }
    const State& s = (*art_states_)[k];
    const MatX& Minv = minv(*a.model, a.data, s.base, s.q);
    for (int r = 0; r < rows; ++r) {
      if (row_mask_[r] >> (nsys + k) & 1) {
        Y_.col(r).segment(a.col0, nv).noalias() = Minv * J.row(r).segment(a.col0, nv).transpose();
      } else {
        Y_.col(r).segment(a.col0, nv).setZero();
      }
    }
  }
  for (size_t j = 1; j <= free_.size(); ++j) {
    const int c0 = nvr + 6 * static_cast<int>(j - 1);
    const Mat6& Mi = free_[j - 1].Minv;
    for (int r = 0; r < rows; ++r) {
      if (row_mask_[r] >> j & 1) {
        Y_.col(r).segment<6>(c0).noalias() = Mi * J.row(r).segment<6>(c0).transpose();
      } else {
        Y_.col(r).segment<6>(c0).setZero();
      }
    }
  }
}

void ConstraintSystem::lazy_delassus(const State& x, int rows) {
  // The robot's block through its mass matrix's factor (O(n d^2), and each column of W sums
  // over the dofs the rows share) rather than a dense D^-1 (O(n^2), dense columns).
  const bool robot_rows = row_masks(rows);
  lazy_w_.factor = nullptr;
  lazy_w_.dinv[0] = nullptr;
  data_to(x.base, x.q);
  if (robot_rows && factored_delassus_) {
    mass_matrix_ltdl(model_, data_, x.base, x.q);
    lazy_w_.factor = &data_;
  } else if (robot_rows) {
    lazy_w_.dinv[0] = minv(model_, data_, x.base, x.q).data();
  }
  for (size_t j = 0; j < free_.size(); ++j) lazy_w_.dinv[j + 1] = free_[j].Minv.data();
  lazy_w_.J = &rows_.J;
  lazy_w_.Y = &Y_;
  lazy_w_.W = &W_;
  lazy_w_.mask = row_mask_.data();
  lazy_w_.touched = rows_.touched.data();
  delassus_begin(lazy_w_, rows);
}

void ConstraintSystem::delassus(const State& x, int rows) {
  const Model& m = model_;
  const int nvr = m.nv;
  auto J = rows_.J.topRows(rows);
  auto Y = Y_.leftCols(rows);
  data_to(x.base, x.q);
  const int nsys = 1 + static_cast<int>(free_.size());
  if (nsys + static_cast<int>(art_.size()) > 64) {  // dense (a mask per row holds 64 systems)
    const MatX& Minv = minv(m, data_, x.base, x.q);
    robot_delassus(rows_.J, rows, nvr, Minv, Y_, W_, delassus_ws_);
    for (size_t j = 0; j < free_.size(); ++j) {
      const int c0 = nvr + 6 * static_cast<int>(j);
      Y.middleRows(c0, 6).noalias() = free_[j].Minv * J.middleCols(c0, 6).transpose();
    }
    for (size_t k = 0; k < art_.size(); ++k) {
      ArtSystem& a = art_[k];
      const State& s = (*art_states_)[k];
      a.touched = !J.middleCols(a.col0, a.model->nv).isZero(0);
      Y.middleRows(a.col0, a.model->nv).noalias() =
          minv(*a.model, a.data, s.base, s.q) * J.middleCols(a.col0, a.model->nv).transpose();
    }
    auto W = W_.topLeftCorner(rows, rows);
    W.triangularView<Eigen::Lower>() += J.rightCols(J.cols() - nvr) * Y.bottomRows(Y.rows() - nvr);
  } else {
    // Block-sparse: a contact row touches at most two systems (the robot, free bodies), and
    // D^-1 is block-diagonal by system, so W(r, s) sums only over the systems both rows
    // touch (box_stack: a quarter of the dense product's multiply-adds).
    const bool robot_rows = row_masks(rows);
    if (robot_rows) {
      const MatX& Minv = minv(m, data_, x.base, x.q);
      robot_delassus(rows_.J, rows, nvr, Minv, Y_, W_, delassus_ws_);
    } else {
      Y.topRows(nvr).setZero();
    }
    free_body_inverse_mass_jacobian(rows);
    // W's robot block is robot_delassus's; the free bodies' blocks are added by their masks.
    for (int r = 0; r < rows; ++r) {
      const std::uint64_t mr = row_mask_[r] & ~std::uint64_t(1);
      if (!mr && robot_rows) continue;
      for (int q = 0; q <= r; ++q) {
        std::uint64_t both = mr & row_mask_[q];
        double w = 0;
        while (both) {
          const int j = __builtin_ctzll(both);
          both &= both - 1;
          if (j < nsys) {
            const int c0 = nvr + 6 * (j - 1);
            w += J.row(r).segment<6>(c0).dot(Y.col(q).segment<6>(c0));
          } else {
            const ArtSystem& a = art_[j - nsys];
            w += J.row(r).segment(a.col0, a.model->nv).dot(Y.col(q).segment(a.col0, a.model->nv));
          }
        }
        W_(r, q) = robot_rows ? W_(r, q) + w : w;
      }
    }
  }
  // W is symmetric: the lower triangle computed, the upper copied.
  for (int j = 1; j < rows; ++j) {
    for (int i = 0; i < j; ++i) W_(i, j) = W_(j, i);
  }
}

bool ConstraintSystem::velocity_step(State& x, const VecX& a_free, double h, const StepInput& in) {
  const Model& m = model_;
  const int nvr = m.nv;
  if (!free_.empty() && !(in.bodies && in.body_a_free)) {
    throw std::invalid_argument("velocity_step: the free bodies' states are missing");
  }
  vfree_.head(nvr) = x.v;
  vfree_.head(nvr).noalias() += h * a_free;
  for (size_t j = 0; j < free_.size(); ++j) {
    vfree_.segment<6>(nvr + 6 * j) = (*in.bodies)[j].v + h * (*in.body_a_free)[j];
  }
  for (size_t k = 0; k < art_.size() && in.robots; ++k) {
    const int nv = art_[k].model->nv;
    vfree_.segment(art_[k].col0, nv) = (*in.robots)[k].v + h * (*in.robot_a_free)[k];
  }
  build_rows(x, h, in);
  const int rows = rows_.count;

  // Warm starts by producer.
  int n_limits = 0, n_contacts = 0;
  // All first: a normal row sets its friction rows, which come after it.
  for (int r = 0; r < rows; ++r) p_[r] = 0;
  for (int r = 0; r < rows; ++r) {
    const int id = rows_.id[r];
    switch (rows_.type[r]) {
      case RowType::Equality:  // below
        break;
      case RowType::JointLimit:
        if (r < art_limit_rows_) {
          p_[r] = rows_.J(r, m.idx_v(id)) > 0 ? warm_lower_[id] : warm_upper_[id];
        } else {
          const ArtSystem& a = art_system_of_limit_row(r);
          p_[r] = rows_.J(r, a.col0 + a.model->idx_v(id)) > 0 ? a.warm_lower[id] : a.warm_upper[id];
        }
        ++n_limits;
        break;
      case RowType::ContactNormal:
        if (r < internal_rows_end_) {
          p_[r] = warm_contact_[id][0];
          p_[rows_.friction[r]] = warm_contact_[id][1];
          p_[rows_.friction2[r]] = warm_contact_[id][2];
        } else {
          warm_start_external(r, (*in.contacts)[id]);
        }
        ++n_contacts;
        break;
      case RowType::ContactFriction:
        break;
    }
  }
  // Bilateral rows come in each constraint's order: row r of the velocity rows is row r of Psi.
  for (int r = 0; r < rows && r < nb_; ++r) p_[r] = warm_bil_[r];

  // ---- Delassus matrix W = J D^-1 J^T (D^-1 block-diagonal by system) and the solve
  int it = 0;
  double change = 0;
  if (rows > 0) {
    auto c = c_.head(rows);
    c.noalias() = rows_.J.topRows(rows) * vfree_;
    c -= rows_.b.head(rows);
    SolverStats st;
    // The active set reads only the columns of W of the rows that carry impulse: when at most
    // half the rows start active, W's columns are formed as it asks for them.
    const bool lazy = opt_.solver == ContactSolver::ActiveSet && free_.size() < 64 &&
                      art_.empty() && lazy_columns_pay(c_, rows_, p_);
    if (lazy) {
      lazy_delassus(x, rows);
      st = solve_active_set(lazy_w_, c_, rows_, p_, ws_, solver_opt_);
      // v+ = v* + D^-1 J^T p over the rows with impulse (the robot's part through its factor,
      // the free bodies' through the columns of Y the solver formed).
      delassus_impulse_velocity(lazy_w_, p_, vfree_);
    } else {
      delassus(x, rows);
      st = opt_.solver == ContactSolver::ActiveSet
               ? solve_active_set(W_, c_, rows_, p_, ws_, solver_opt_)
               : solve_pgs(W_, c_, rows_, p_, solver_opt_);
      st.columns = rows;
      vfree_.noalias() += Y_.leftCols(rows) * p_.head(rows);
    }
    it = st.iterations;
    change = st.change;
    report_.delassus_columns = st.columns;
    if (st.fallback) ++report_.fallbacks;
  }
  x.v = vfree_.head(nvr);
  for (size_t j = 0; j < free_.size(); ++j) (*in.bodies)[j].v = vfree_.segment<6>(nvr + 6 * j);
  for (size_t k = 0; k < art_.size(); ++k) {
    (*in.robots)[k].v = vfree_.segment(art_[k].col0, art_[k].model->nv);
  }
  ++report_.solves;
  ++report_.velocity_steps;

  // ---- warm starts and forces (world frame, at the start-of-step configuration)
  for (ConstraintForce& f : forces_) {
    f.active = false;
    if (f.kind != ConstraintForce::Bilateral) {
      f.force.setZero();
      f.joint_force = 0;
    }
  }
  const int n_bil_forces = static_cast<int>(bil_.size());
  const int n_limit_forces = static_cast<int>(limit_force_index_.size());
  if (nb_ > 0) {
    warm_bil_ = p_.head(nb_);
    assemble_bilateral_forces(p_, 1.0 / h);
  }
  for (int k = 0; k < n_limit_forces; ++k) {
    const int i = limit_force_index_[k];
    ConstraintForce& f = forces_[n_bil_forces + k];
    f.point = data_.oMb[i].p;
    const double ql = x.q[m.idx_q(i)];
    f.gap = std::min(ql - m.lower[i], m.upper[i] - ql);
  }
  const Vec3& nrm = spec_.ground_normal;
  for (size_t k = 0; k < contacts_.size(); ++k) {
    ConstraintForce& f = forces_[n_bil_forces + n_limit_forces + k];
    f.point = point_world(contacts_[k]) - contact_radius_[k] * nrm;
    f.gap = contact_gap_[k];
  }
  int next = 0;
  for (int r = internal_rows_end_; r < rows; ++r) {
    if (rows_.type[r] != RowType::ContactNormal) continue;
    if (next == static_cast<int>(warm_ext_next_.size())) break;
    const Contact& ct = (*in.contacts)[rows_.id[r]];
    Vec3 t1, t2;
    tangent_basis(ct.normal, t1, t2);  // the basis add_contact_rows used
    WarmExternal& w = warm_ext_next_[next++];
    w.a = ct.a;
    w.b = ct.b;
    w.point = ct.point;
    w.normal = ct.normal;
    w.depth = ct.depth;
    w.impulse = p_[r] * ct.normal + p_[rows_.friction[r]] * t1 + p_[rows_.friction2[r]] * t2;
  }
  warm_ext_.swap(warm_ext_next_);
  warm_ext_count_ = next;
  for (int i = 1; i <= m.n; ++i) warm_lower_[i] = warm_upper_[i] = 0;
  for (ArtSystem& a : art_) {
    std::fill(a.warm_lower.begin(), a.warm_lower.end(), 0.0);
    std::fill(a.warm_upper.begin(), a.warm_upper.end(), 0.0);
  }
  for (int r = art_limit_rows_; r < rows; ++r) {
    ArtSystem& a = art_system_of_limit_row(r);
    const int id = rows_.id[r];
    (rows_.J(r, a.col0 + a.model->idx_v(id)) > 0 ? a.warm_lower : a.warm_upper)[id] = p_[r];
  }
  for (Vec3& w : warm_contact_) w.setZero();
  for (int r = nb_; r < internal_rows_end_; ++r) {
    const int id = rows_.id[r];
    if (rows_.type[r] == RowType::JointLimit) {
      const bool lower = rows_.J(r, m.idx_v(id)) > 0;
      (lower ? warm_lower_ : warm_upper_)[id] = p_[r];
      for (int k = 0; k < n_limit_forces; ++k) {
        if (limit_force_index_[k] != id) continue;
        ConstraintForce& f = forces_[n_bil_forces + k];
        f.joint_force += (lower ? 1.0 : -1.0) * p_[r] / h;
        f.active = f.active || p_[r] > 0;
      }
    } else if (rows_.type[r] == RowType::ContactNormal) {
      const int f1 = rows_.friction[r], f2 = rows_.friction2[r];
      warm_contact_[id] = Vec3(p_[r], p_[f1], p_[f2]);
      Vec3 t1, t2;
      tangent_basis(nrm, t1, t2);
      ConstraintForce& f = forces_[n_bil_forces + n_limit_forces + id];
      f.force = (p_[r] * nrm + p_[f1] * t1 + p_[f2] * t2) / h;
      f.active = p_[r] > 0;
    }
  }
  report_.rows = rows;
  report_.active_contacts = n_contacts;
  report_.active_limits = n_limits;
  report_.pgs_iterations = it;
  report_.pgs_change = change;
  bool finite = x.v.allFinite();
  for (size_t j = 0; j < free_.size(); ++j) finite = finite && (*in.bodies)[j].v.allFinite();
  for (size_t k = 0; k < art_.size(); ++k) finite = finite && (*in.robots)[k].v.allFinite();
  return finite;
}

void ConstraintSystem::finish_velocity_step(State& x) {
  const Model& m = model_;
  if (opt_.project && nb_ > 0) project(x);
  // Errors at the end of the step (kinematics only for what needs positions).
  if (nb_ > 0 || (spec_.ground && !contacts_.empty())) kinematics(x.base, x.q, nullptr);
  report_.penetration = 0;
  const Vec3& nrm = spec_.ground_normal;
  for (size_t k = 0; spec_.ground && k < contacts_.size(); ++k) {
    const double g = nrm.dot(point_world(contacts_[k])) - contact_radius_[k] - spec_.ground_offset;
    report_.penetration = std::max(report_.penetration, -g);
  }
  report_.limit_violation = 0;
  if (spec_.joint_limits) {
    for (int i = 1; i <= m.n; ++i) {
      const double qi = x.q[m.idx_q(i)];
      if (std::isfinite(m.lower[i])) {
        report_.limit_violation = std::max(report_.limit_violation, m.lower[i] - qi);
      }
      if (std::isfinite(m.upper[i])) {
        report_.limit_violation = std::max(report_.limit_violation, qi - m.upper[i]);
      }
    }
  }
  if (nb_ > 0) {
    fill_bilateral(false);
    report_.bilateral_error = phi_.cwiseAbs().maxCoeff();
  }
}

}  // namespace se3
