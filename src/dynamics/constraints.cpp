// Constrained dynamics: bilateral constraints with multipliers from eq. (32), their projection,
// and velocity-level time stepping with joint limits and Coulomb contact (constraints.h).
#include "se3_sim/constraints.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "joint.h"

namespace se3 {

std::string constraint_type_name(ConstraintType t) {
  switch (t) {
    case ConstraintType::PointWorld:
      return "point_world";
    case ConstraintType::PointPoint:
      return "point_point";
    case ConstraintType::AxisParallel:
      return "axis_parallel";
  }
  return "unknown";
}

namespace {

bool is_world(const std::string& link) {
  return link.empty() || link == "world";
}

// Two unit vectors completing n (unit) to a right-handed orthonormal basis (t1, t2, n).
void tangents(const Vec3& n, Vec3& t1, Vec3& t2) {
  const Vec3 seed = std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  t1 = seed.cross(n).normalized();
  t2 = n.cross(t1);
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
      !(opt_.erp <= 1) || !(opt_.slop >= 0) || !(opt_.margin >= 0) || opt_.pgs_iterations < 1 ||
      !(opt_.singular_tol > 0) || !(spec.mu >= 0) || !std::isfinite(spec.mu)) {
    throw ModelError("constraint options out of range");
  }
  alpha_ = 2.0 * opt_.baumgarte_zeta * opt_.baumgarte_omega;
  beta2_ = opt_.baumgarte_omega * opt_.baumgarte_omega;
  int row = 0;
  for (size_t k = 0; k < spec.bilateral.size(); ++k) {
    const BilateralConstraint& c = spec.bilateral[k];
    Bil b;
    b.type = c.type;
    b.name = c.name.empty() ? constraint_type_name(c.type) + std::to_string(k) : c.name;
    if (is_world(c.link_a)) throw ModelError(b.name + ": link_a must be a link of the model");
    b.a = resolve(c.link_a, c.point_a, b.name);
    b.row0 = row;
    if (c.type == ConstraintType::AxisParallel) {
      const int k_link = model.link_index(c.link_a);
      b.axis_a = model.links[k_link].offset.R * unit(c.axis_a, b.name + " axis_a");
      b.axis_w = unit(c.axis_world, b.name + " axis_world");
      Vec3 t1, t2;
      tangents(b.axis_w, t1, t2);
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
  max_rows_ = nb_ + (spec.joint_limits ? 2 * model.n : 0) + 3 * nc;

  data_.reserve_minv(model);  // minv runs inside time steps
  Sw_.assign(nv, Vec6::Zero());
  Vb_.assign(model.n + 1, Vec6::Zero());
  Ab_.assign(model.n + 1, Vec6::Zero());
  Psi_ = MatX::Zero(nb_, nv);
  Yb_ = MatX::Zero(nv, nb_);
  Wb_ = MatX::Zero(nb_, nb_);
  phi_ = VecX::Zero(nb_);
  gamma_ = VecX::Zero(nb_);
  rhs_ = VecX::Zero(nb_);
  lambda_ = VecX::Zero(nb_);
  mult_ = VecX::Zero(nb_);
  ldlt_ = Eigen::LDLT<MatX>(nb_);
  eig_ = Eigen::SelfAdjointEigenSolver<MatX>(nb_);
  a_ = VecX::Zero(nv);
  dq_ = VecX::Zero(nv);
  vfree_ = VecX::Zero(nv);
  J_ = MatX::Zero(max_rows_, nv);
  Y_ = MatX::Zero(nv, max_rows_);
  W_ = MatX::Zero(max_rows_, max_rows_);
  b_ = VecX::Zero(max_rows_);
  c_ = VecX::Zero(max_rows_);
  p_ = VecX::Zero(max_rows_);
  row_kind_.assign(max_rows_, kBil);
  row_ref_.assign(max_rows_, 0);
  warm_contact_.assign(nc, Vec3::Zero());
  warm_lower_.assign(model.n + 1, 0.0);
  warm_upper_.assign(model.n + 1, 0.0);
  warm_bil_ = VecX::Zero(nb_);
  contact_gap_.assign(nc, std::numeric_limits<double>::infinity());

  for (const Bil& b : bil_) {
    ConstraintForce f;
    f.kind = ConstraintForce::Bilateral;
    f.name = b.name;
    f.body = b.a.body;
    forces_.push_back(f);
  }
  if (spec.joint_limits) {
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

void ConstraintSystem::kinematics(const SE3& base, const VecX& q, const VecX* v) {
  forward_kinematics(model_, data_, base, q);
  const Model& m = model_;
  if (m.floating) {
    for (int k = 0; k < 6; ++k) Sw_[k] = act_motion(data_.oMb[0], Vec6::Unit(k));
  }
  for (int i = 1; i <= m.n; ++i) {
    detail::with_joint(m.joints[i],
                       [&](auto J) { J.world_axis(data_.oMb[i], Sw_[m.idx_v(i)].data()); });
  }
  if (!v) return;
  body_twists(m, data_, *v);
  Vb_.swap(data_.V);  // kept here: the next aba call on data_ overwrites data_.V
  const std::vector<Vec6>& Vb = Vb_;
  Ab_[0].setZero();
  for (int i = 1; i <= m.n; ++i) {
    const int p = m.parent[i];
    Ab_[i] = act_inv_motion(data_.Xup[i], Ab_[p]);
    detail::with_joint(m.joints[i], [&](auto J) {
      J.add_bias_acceleration(Vb[i].data(), (*v)[m.idx_v(i)], Ab_[i].data());
    });
  }
}

Vec3 ConstraintSystem::point_world(const PointRef& p) const {
  return p.body < 0 ? p.r : data_.oMb[p.body].act(p.r);
}

void ConstraintSystem::add_point_row(const PointRef& p, const Vec3& d, double s, MatX& M,
                                     int row) const {
  if (p.body < 0) return;
  const Vec3 pw = data_.oMb[p.body].act(p.r);
  const Vec3 pxd = pw.cross(d);  // d . (v + w x p) = d . v + w . (p x d)
  auto add = [&](int col) {
    const Vec6& S = Sw_[col];
    M(row, col) += s * (d.dot(S.tail<3>()) + pxd.dot(S.head<3>()));
  };
  for (int j = p.body; j >= 1; j = model_.parent[j]) add(model_.idx_v(j));
  if (model_.floating) {
    for (int k = 0; k < 6; ++k) add(k);
  }
}

void ConstraintSystem::add_angular_row(int body, const Vec3& c, double s, MatX& M, int row) const {
  if (body < 0) return;
  for (int j = body; j >= 1; j = model_.parent[j]) {
    const int col = model_.idx_v(j);
    M(row, col) += s * c.dot(Sw_[col].head<3>());
  }
  if (model_.floating) {
    for (int k = 0; k < 6; ++k) M(row, k) += s * c.dot(Sw_[k].head<3>());
  }
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

void ConstraintSystem::fill_bilateral(bool with_bias) {
  Psi_.setZero();
  for (const Bil& b : bil_) {
    if (b.type == ConstraintType::AxisParallel) {
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
        add_angular_row(b.a.body, u.cross(e), 1.0, Psi_, r);
        if (with_bias) gamma_[r] = e.dot(wdot.cross(u) + w.cross(w.cross(u)));
      }
    } else {
      const Vec3 d_ab = point_world(b.a) - point_world(b.b);
      Vec3 acc = Vec3::Zero();
      if (with_bias) acc = point_accel_bias(b.a) - point_accel_bias(b.b);
      for (size_t k = 0; k < b.dirs.size(); ++k) {
        const Vec3& d = b.dirs[k];
        const int r = b.row0 + static_cast<int>(k);
        phi_[r] = d.dot(d_ab);
        add_point_row(b.a, d, 1.0, Psi_, r);
        add_point_row(b.b, d, -1.0, Psi_, r);
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
  const int m = static_cast<int>(rhs.size());
  if (m == 0) return;
  const double wmax = Wb_.diagonal().cwiseAbs().maxCoeff();
  if (!(wmax > 0) || !std::isfinite(wmax)) {
    out.setZero();
    report_.rank = 0;
    ++report_.singular_solves;
    return;
  }
  ldlt_.compute(Wb_);
  const auto D = ldlt_.vectorD();
  const double dmax = D.cwiseAbs().maxCoeff();
  if (ldlt_.info() == Eigen::Success && D.minCoeff() > opt_.singular_tol * dmax) {
    out = ldlt_.solve(rhs);
    report_.rank = m;
    return;
  }
  // Rank deficient: the minimum-norm least-squares multiplier (pseudo-inverse).
  ++report_.singular_solves;
  eig_.compute(Wb_);
  const auto& ev = eig_.eigenvalues();
  const auto& V = eig_.eigenvectors();
  const double thr = opt_.singular_tol * ev.cwiseAbs().maxCoeff();
  out.setZero();
  int rank = 0;
  for (int k = 0; k < m; ++k) {
    if (ev[k] > thr) {
      out.noalias() += V.col(k) * (V.col(k).dot(rhs) / ev[k]);
      ++rank;
    }
  }
  report_.rank = rank;
}

const VecX& ConstraintSystem::acceleration(const SE3& base, const VecX& q, const VecX& v,
                                           const VecX& tau) {
  a_ = aba(model_, data_, base, q, v, tau);  // a_free = D^-1 (tau - H)
  if (nb_ == 0) return a_;
  kinematics(base, q, &v);
  fill_bilateral(true);
  const MatX& Minv = minv(model_, data_, base, q);
  Yb_.noalias() = Minv * Psi_.transpose();  // D^-1 Psi^T
  Wb_.noalias() = Psi_ * Yb_;               // Psi D^-1 Psi^T
  rhs_.noalias() = -(Psi_ * a_);
  rhs_ -= gamma_;
  if (alpha_ > 0) rhs_.noalias() -= alpha_ * (Psi_ * v);
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
  const MatX& Minv = minv(model_, data_, x.base, x.q);
  Yb_.noalias() = Minv * Psi_.transpose();
  Wb_.noalias() = Psi_ * Yb_;
  rhs_.noalias() = -(Psi_ * x.v);
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
      const double qi = x.q[i - 1];
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

bool ConstraintSystem::velocity_step(State& x, const VecX& a_free, double h) {
  const Model& m = model_;
  vfree_ = x.v;
  vfree_.noalias() += h * a_free;

  // ---- rows
  kinematics(x.base, x.q, nullptr);
  J_.setZero();
  int rows = 0;
  if (nb_ > 0) {
    fill_bilateral(false);
    J_.topRows(nb_) = Psi_;
    for (int r = 0; r < nb_; ++r) {
      b_[r] = -opt_.bilateral_erp * phi_[r] / h;
      row_kind_[r] = kBil;
      row_ref_[r] = r;
      p_[r] = warm_bil_[r];
    }
    rows = nb_;
  }
  auto gap_target = [&](double g) {
    if (g >= 0) return -g / h;  // may close the gap within the step, no further
    if (g >= -opt_.slop) return 0.0;
    return -opt_.erp * (g + opt_.slop) / h;
  };
  int n_limits = 0;
  if (spec_.joint_limits) {
    for (int i = 1; i <= m.n; ++i) {
      const int col = m.idx_v(i);
      const double qi = x.q[i - 1];
      const double reach = opt_.margin + std::abs(vfree_[col]) * h;
      if (std::isfinite(m.lower[i]) && qi - m.lower[i] < reach) {
        J_(rows, col) = 1.0;
        b_[rows] = gap_target(qi - m.lower[i]);
        row_kind_[rows] = kLimLower;
        row_ref_[rows] = i;
        p_[rows] = warm_lower_[i];
        ++rows;
        ++n_limits;
      } else {
        warm_lower_[i] = 0;
      }
      if (std::isfinite(m.upper[i]) && m.upper[i] - qi < reach) {
        J_(rows, col) = -1.0;
        b_[rows] = gap_target(m.upper[i] - qi);
        row_kind_[rows] = kLimUpper;
        row_ref_[rows] = i;
        p_[rows] = warm_upper_[i];
        ++rows;
        ++n_limits;
      } else {
        warm_upper_[i] = 0;
      }
    }
  }
  int n_contacts = 0;
  const Vec3& nrm = spec_.ground_normal;
  Vec3 t1, t2;
  tangents(nrm, t1, t2);
  for (size_t k = 0; k < contacts_.size(); ++k) {
    const PointRef& c = contacts_[k];
    if (c.body == 0 && !m.floating) continue;
    PointRef cp = c;  // the body point at the sphere's lowest point
    cp.r = c.r - contact_radius_[k] * (data_.oMb[c.body].R.transpose() * nrm);
    const double g = nrm.dot(point_world(cp)) - spec_.ground_offset;
    contact_gap_[k] = g;
    add_point_row(cp, nrm, 1.0, J_, rows);
    const double vn = J_.row(rows).dot(vfree_);
    if (g + h * std::min(0.0, vn) >= opt_.margin) {
      J_.row(rows).setZero();
      warm_contact_[k].setZero();
      continue;
    }
    add_point_row(cp, t1, 1.0, J_, rows + 1);
    add_point_row(cp, t2, 1.0, J_, rows + 2);
    b_[rows] = gap_target(g);
    b_[rows + 1] = b_[rows + 2] = 0;
    row_kind_[rows] = kNormal;
    row_kind_[rows + 1] = kTangent1;
    row_kind_[rows + 2] = kTangent2;
    row_ref_[rows] = row_ref_[rows + 1] = row_ref_[rows + 2] = static_cast<int>(k);
    p_.segment<3>(rows) = warm_contact_[k];
    rows += 3;
    ++n_contacts;
  }

  // ---- Delassus matrix and projected Gauss-Seidel
  int it = 0;
  double change = 0;
  if (rows > 0) {
    const MatX& Minv = minv(m, data_, x.base, x.q);
    auto Jr = J_.topRows(rows);
    auto Yr = Y_.leftCols(rows);
    auto Wr = W_.topLeftCorner(rows, rows);
    Yr.noalias() = Minv * Jr.transpose();
    Wr.noalias() = Jr * Yr;
    auto cr = c_.head(rows);
    cr.noalias() = Jr * vfree_;
    cr -= b_.head(rows);
    const double mu = spec_.mu;
    for (it = 1; it <= opt_.pgs_iterations; ++it) {
      change = 0;
      for (int r = 0; r < rows; ++r) {
        const double wii = W_(r, r);
        const RowKind kind = static_cast<RowKind>(row_kind_[r]);
        if (kind == kTangent2) continue;  // handled with its kTangent1 partner
        if (!(wii > 1e-14)) continue;
        if (kind == kTangent1) {
          const double w22 = W_(r + 1, r + 1);
          const double r1 = c_[r] + W_.row(r).head(rows).dot(p_.head(rows));
          const double r2 = c_[r + 1] + W_.row(r + 1).head(rows).dot(p_.head(rows));
          double n1 = p_[r] - r1 / wii;
          double n2 = w22 > 1e-14 ? p_[r + 1] - r2 / w22 : 0.0;
          const double lim = mu * p_[r - 1];
          const double len = std::hypot(n1, n2);
          if (len > lim) {
            const double s = len > 0 ? lim / len : 0.0;
            n1 *= s;
            n2 *= s;
          }
          change = std::max(change, std::max(std::abs(n1 - p_[r]), std::abs(n2 - p_[r + 1])));
          p_[r] = n1;
          p_[r + 1] = n2;
          continue;
        }
        const double res = c_[r] + W_.row(r).head(rows).dot(p_.head(rows));
        double np = p_[r] - res / wii;
        if (kind != kBil) np = std::max(0.0, np);
        change = std::max(change, std::abs(np - p_[r]));
        p_[r] = np;
      }
      if (change <= opt_.pgs_tol) break;
    }
    it = std::min(it, opt_.pgs_iterations);
    x.v = vfree_;
    x.v.noalias() += Yr * p_.head(rows);
  } else {
    x.v = vfree_;
  }
  ++report_.solves;

  // ---- positions with the new velocities (symplectic Euler on SE(3))
  if (m.floating) {
    x.base = x.base * exp_se3(h * x.v.head<6>());
    x.base.R = orthonormalize(x.base.R);
  }
  x.q.noalias() += h * x.v.tail(m.n);

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
    const double ql = x.q[i - 1];
    f.gap = std::min(ql - m.lower[i], m.upper[i] - ql);
  }
  for (size_t k = 0; k < contacts_.size(); ++k) {
    ConstraintForce& f = forces_[n_bil_forces + n_limit_forces + k];
    f.point = point_world(contacts_[k]) - contact_radius_[k] * nrm;
    f.gap = contact_gap_[k];
  }
  for (int r = nb_; r < rows; ++r) {
    const int kind = row_kind_[r];
    const int ref = row_ref_[r];
    if (kind == kLimLower || kind == kLimUpper) {
      const double s = kind == kLimLower ? 1.0 : -1.0;
      (kind == kLimLower ? warm_lower_ : warm_upper_)[ref] = p_[r];
      for (int k = 0; k < n_limit_forces; ++k) {
        if (limit_force_index_[k] != ref) continue;
        ConstraintForce& f = forces_[n_bil_forces + k];
        f.joint_force += s * p_[r] / h;
        f.active = f.active || p_[r] > 0;
      }
    } else if (kind == kNormal) {
      warm_contact_[ref] = p_.segment<3>(r);
      ConstraintForce& f = forces_[n_bil_forces + n_limit_forces + ref];
      f.force = (p_[r] * nrm + p_[r + 1] * t1 + p_[r + 2] * t2) / h;
      f.active = p_[r] > 0;
    }
  }

  report_.rows = rows;
  report_.active_contacts = n_contacts;
  report_.active_limits = n_limits;
  report_.pgs_iterations = it;
  report_.pgs_change = change;

  if (opt_.project && nb_ > 0) project(x);
  // Errors at the end of the step.
  kinematics(x.base, x.q, nullptr);
  report_.penetration = 0;
  for (size_t k = 0; k < contacts_.size(); ++k) {
    const double g = nrm.dot(point_world(contacts_[k])) - contact_radius_[k] - spec_.ground_offset;
    report_.penetration = std::max(report_.penetration, -g);
  }
  report_.limit_violation = 0;
  if (spec_.joint_limits) {
    for (int i = 1; i <= m.n; ++i) {
      const double qi = x.q[i - 1];
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
  return x.finite();
}

}  // namespace se3
