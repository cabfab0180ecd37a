// `variational`: a Lie-group variational integrator for the free-floating (or fixed-base) tree.
//
// The configuration is (f, q) in SE(3) x R^n, the Lagrangian L = 1/2 w^T D(q) w - U(f, q) with
// w = [V0; qdot] (V0 = f^-1 fdot, the body-frame base twist). One step joins (f_k, q_k) to
// (f_k+1, q_k+1) by the exponential arc f(t) = f_k exp(t xi / h), whose body twist is the
// constant xi / h, and by the straight line in q; with w = [xi; q_k+1 - q_k] / h the discrete
// Lagrangian is the trapezoidal rule along that arc,
//   L_d = h/2 (T(q_k, w) + T(q_k+1, w)) - h/2 (U(f_k, q_k) + U(f_k+1, q_k+1)).
// It depends only on the two end points, so the discrete Euler-Lagrange (here: discrete
// Euler-Poincare on SE(3)) equations define a symplectic map; L_d is invariant under
// f -> g f when U is (zero gravity), so the world-frame spatial momentum is conserved exactly
// by the discrete Noether theorem (up to the solver tolerance); L_d is symmetric in its end
// points, so the method is time-reversible and of order 2. Energy is not conserved exactly
// but its error stays bounded (oscillates at O(h^2)) over very long runs, the property the
// charts show.
//
// With the left-trivialized momentum p = D(q) v (base block: the body-frame momentum mu), the
// discrete Legendre transforms of L_d give, with pbar = 1/2 (D(q_k) + D(q_k+1)) w:
//   dexp_inv(xi)^T pbar_b = mu_k + h/2 (Q_b(k) + tau_b)
//   pbar_q = p_q,k + h/2 (dT/dq(q_k, w) + Q_q(k) + tau_q + passive(w))     (implicit in w)
//   f_k+1 = f_k exp(xi), q_k+1 = q_k + h w_q,
//   mu_k+1 = dexp_inv(-xi)^T pbar_b + h/2 (Q_b(k+1) + tau_b)
//   p_q,k+1 = pbar_q + h/2 (dT/dq(q_k+1, w) + Q_q(k+1) + tau_q + passive(w)),
//   v_k+1 = D(q_k+1)^-1 p_k+1,
// where Q = -dU is the generalized gravity force (minus RNEA at rest), dT/dq the gradient of
// the kinetic energy at fixed w, and the commanded and passive forces enter as a discrete
// Lagrange-d'Alembert forcing, half at each end. The implicit equation is solved by a
// fixed-point iteration on w (w <- A(w)^-1 rhs(w)), each iteration one mass matrix (CRBA) with
// a Cholesky solve and one O(n) pass for dT/dq; where that contracts slowly or diverges (large
// steps, fast spin of light links) Newton's method takes over, with a difference Jacobian of
// nv further map applications per iteration. Linear joint damping is taken into the matrix
// (implicitly), so strong damping does not limit the step. Every map application and the
// end-point update counts as one dynamics evaluation in StepInfo. If neither iteration
// converges the step fails and the state is left unchanged.
//
// dT/dq_j: moving q_j rotates every twist of the subtree of j rigidly, dV_j/dq_j = ad_{V_j} S_j,
// so dT/dq_j = P_j . ad_{V_j} S_j with P_j the momentum of the subtree of j in frame j.
#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "se3_sim/integrate/integrate.h"
#include "steppers.h"

namespace se3 {

namespace {

class VariationalStepper final : public Stepper {
 public:
  VariationalStepper(const Model& model, const StepperOptions& opt)
      : Stepper(model, opt),
        end_data_(model),
        nv_(model.nv),
        D0_(MatX::Zero(nv_, nv_)),
        D1_(MatX::Zero(nv_, nv_)),
        A_(MatX::Zero(nv_, nv_)),
        llt_(nv_),
        p0_(VecX::Zero(nv_)),
        p1_(VecX::Zero(nv_)),
        Q0_(VecX::Zero(nv_)),
        Q1_(VecX::Zero(nv_)),
        w_(VecX::Zero(nv_)),
        w_new_(VecX::Zero(nv_)),
        rhs_(VecX::Zero(nv_)),
        dT_(VecX::Zero(nv_)),
        pas_(VecX::Zero(nv_)),
        zero_(VecX::Zero(nv_)),
        q1_(VecX::Zero(model.nq)),
        g_(VecX::Zero(nv_)),
        wt_(VecX::Zero(nv_)),
        J_(MatX::Zero(nv_, nv_)),
        lu_(nv_),
        P_(model.n + 1, Vec6::Zero()),
        cache_end_(model),
        cache_tau_(VecX::Zero(nv_)),
        dv_(VecX::Zero(nv_)) {
    data_.reserve_crba(model);  // crba runs inside every step
    end_data_.reserve_crba(model);
    has_gravity_ = model.gravity.squaredNorm() > 0;
  }

  std::string name() const override { return "variational"; }
  int order() const override { return 2; }
  void restart() override { cache_valid_ = false; }

  StepInfo step(State& x, const VecX& tau, double h) override {
    StepInfo info;
    const Model& m = model_;
    const int n = m.nq;
    const bool fl = m.floating;
    // ---- start point: D(q_k), p_k, Q(k) (reused from the previous step's end when possible)
    const bool continued = cache_valid_ && same(x, cache_end_) && tau == cache_tau_;
    if (continued) {
      D0_ = D1_;
      Q0_ = Q1_;
      p0_ = p1_;
    } else {
      D0_ = crba(m, data_, x.base, x.q);
      p0_.noalias() = D0_ * x.v;
      gravity_force(x.base, x.q, data_, Q0_);
      ++info.evaluations;
    }
    cache_valid_ = false;
    forward_kinematics(m, data_, x.base, x.q);  // data_.Xup at q_k for dT/dq(q_k, w)
    const double h2 = 0.5 * h;
    // Predictor: w ~ v(t + h/2), extrapolated from the last step's change of v when there is one.
    w_ = x.v;
    if (continued && last_h_ > 0) w_ += (0.5 * h / last_h_) * dv_;
    // Fixed-point iteration w <- map(w); where it converges slowly or not at all (large steps,
    // fast motion of light links), Newton's method on map(w) - w with a difference Jacobian.
    double last_change = std::numeric_limits<double>::infinity();
    bool converged = false;
    for (int it = 0; it < 10 && !converged; ++it) {
      if (!fixed_point_map(x, tau, h, w_, w_new_, info)) return info;
      const double change = (w_new_ - w_).cwiseAbs().maxCoeff();
      const double scale = 1.0 + w_new_.cwiseAbs().maxCoeff();
      w_.swap(w_new_);
      // Converged, or stalled at rounding level (no further decrease).
      if (change <= 1e-14 * scale || (change <= 1e-10 * scale && change >= 0.5 * last_change)) {
        converged = true;
      } else if (!std::isfinite(change) || (it >= 2 && change > 0.3 * last_change)) {
        break;  // slow or diverging: Newton
      }
      last_change = change;
    }
    if (!converged) {
      if (!w_.allFinite()) w_ = x.v;
      last_change = std::numeric_limits<double>::infinity();
      for (int it = 0; it < 30 && !converged; ++it) {
        if (!fixed_point_map(x, tau, h, w_, g_, info)) return info;
        g_ -= w_;  // residual map(w) - w
        const double res = g_.cwiseAbs().maxCoeff();
        const double scale = 1.0 + w_.cwiseAbs().maxCoeff();
        if (!std::isfinite(res)) break;
        // Converged, or stalled at the rounding level of the (ill-conditioned) mass matrix.
        if (res <= 1e-14 * scale || (res <= 1e-10 * scale && res >= 0.5 * last_change) ||
            (it >= 5 && res <= 1e-9 * scale)) {
          converged = true;
          break;
        }
        last_change = res;
        for (int j = 0; j < nv_; ++j) {
          const double eps = 1e-7 * (1.0 + std::abs(w_[j]));
          wt_ = w_;
          wt_[j] += eps;
          if (!fixed_point_map(x, tau, h, wt_, w_new_, info)) return info;
          J_.col(j) = (w_new_ - wt_ - g_) / eps;
        }
        lu_.compute(J_);
        wt_ = lu_.solve(g_);  // into a vector of its own: no temporary
        w_ -= wt_;
      }
    }
    if (!converged) {
      info.ok = false;
      info.reason = "variational step: the implicit equation did not converge (step too large)";
      return info;
    }
    // ---- end point
    const Vec6 xi = fl ? Vec6(h * w_.head<6>()) : Vec6::Zero();
    q1_ = x.q + h * w_.tail(n);
    SE3 base1 = x.base;
    if (fl) {
      base1 = x.base * exp_se3(xi);
      base1.R = orthonormalize(base1.R);
    }
    // pbar with the converged w, at the D(q_k+1) of the final q_k+1.
    D1_ = crba(m, end_data_, base1, q1_);
    p1_.noalias() = 0.5 * (D0_ + D1_) * w_;
    gravity_force(base1, q1_, end_data_, Q1_);
    forward_kinematics(m, end_data_, base1, q1_);
    kinetic_gradient(end_data_, w_, dT_);
    ++info.evaluations;
    if (fl) {
      const Vec6 pb = p1_.head<6>();
      p1_.head<6>().noalias() = dexp_inv_se3(-xi).transpose() * pb;
    }
    passive_.apply(nullptr, w_.data(), pas_.data());
    p1_ += h2 * (Q1_ + tau + pas_);
    p1_.tail(n) += h2 * dT_.tail(n);
    llt_.compute(D1_);
    if (llt_.info() != Eigen::Success) {
      info.ok = false;
      info.reason = "variational step: mass matrix not positive definite";
      return info;
    }
    w_new_ = llt_.solve(p1_);
    if (!w_new_.allFinite() || !base1.R.allFinite() || !q1_.allFinite()) {
      info.ok = false;
      info.reason = "variational step: non-finite state";
      return info;
    }
    dv_ = w_new_ - x.v;
    last_h_ = h;
    x.base = base1;
    x.q = q1_;
    x.v = w_new_;
    info.substeps = 1;
    cache_end_.base = x.base;
    cache_end_.q = x.q;
    cache_end_.v = x.v;
    cache_tau_ = tau;
    cache_valid_ = true;
    return info;
  }

 private:
  // One application of the fixed-point map of the implicit equation: out = A(w)^-1 rhs(w).
  bool fixed_point_map(const State& x, const VecX& tau, double h, const VecX& w, VecX& out,
                       StepInfo& info) {
    ++info.evaluations;
    const double h2 = 0.5 * h;
    q1_ = x.q + h * w.tail(model_.nq);
    D1_ = crba(model_, end_data_, x.base, q1_);
    A_ = 0.5 * (D0_ + D1_);
    // Linear damping taken implicitly into the matrix; friction explicitly.
    A_.diagonal() += h2 * passive_.damping();
    kinetic_gradient(data_, w, dT_);
    rhs_ = p0_ + h2 * (Q0_ + tau + dT_);
    if (passive_.has_friction()) {
      passive_.friction(w.data(), pas_.data());
      rhs_ += h2 * pas_;
    }
    if (model_.floating) {
      const Vec6 xi = h * w.head<6>();
      const Vec6 mu = rhs_.head<6>();
      rhs_.head<6>().noalias() = dexp_se3(xi).transpose() * mu;
    }
    llt_.compute(A_);
    if (llt_.info() != Eigen::Success) {
      info.ok = false;
      info.reason = "variational step: mass matrix not positive definite";
      return false;
    }
    out = llt_.solve(rhs_);
    return true;
  }

  static bool same(const State& a, const State& b) {
    return a.base.R == b.base.R && a.base.p == b.base.p && a.q == b.q && a.v == b.v;
  }

  // Q = -dU: the generalized gravity force (minus the RNEA torques holding the system at rest).
  void gravity_force(const SE3& base, const VecX& q, Data& d, VecX& out) {
    if (!has_gravity_) {
      out.setZero();
      return;
    }
    out = -rnea(model_, d, base, q, zero_, zero_);
  }

  // dT/dq at the configuration whose joint transforms are in d.Xup, at generalized velocity w
  // (zero on the base part); the body twists go to d.V.
  void kinetic_gradient(Data& d, const VecX& w, VecX& out) {
    const Model& m = model_;
    out.setZero();
    body_twists(m, d, w);
    for (int i = 0; i <= m.n; ++i) P_[i] = m.inertia[i] * d.V[i];
    for (int i = m.n; i >= 1; --i) {
      const Vec6 S = Vec6::Unit(m.joints[i].axis());  // a one-dof joint: S = e_k
      out[m.idx_v(i)] = P_[i].dot(cross_motion(d.V[i], S));
      P_[m.parent[i]] += act_force(d.Xup[i], P_[i]);
    }
  }

  Data end_data_;
  int nv_;
  MatX D0_, D1_, A_;
  Eigen::LLT<MatX> llt_;
  VecX p0_, p1_, Q0_, Q1_, w_, w_new_, rhs_, dT_, pas_, zero_, q1_, g_, wt_;
  MatX J_;
  Eigen::PartialPivLU<MatX> lu_;
  std::vector<Vec6> P_;  // subtree momenta (kinetic_gradient)
  State cache_end_;
  VecX cache_tau_;
  VecX dv_;
  double last_h_ = 0;
  bool cache_valid_ = false;
  bool has_gravity_ = false;
};

}  // namespace

std::unique_ptr<Stepper> detail::make_variational_stepper(const Model& model,
                                                          const StepperOptions& opt) {
  return std::make_unique<VariationalStepper>(model, opt);
}

}  // namespace se3
