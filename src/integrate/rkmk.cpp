// Runge-Kutta-Munthe-Kaas steppers for any explicit Butcher tableau (integrate.h).
//
// Stage i of a step from (f, q, v):
//   xi_i = h sum_j a_ij Kxi_j,  q_i = q + h sum_j a_ij qdot_j,  v_i = v + h sum_j a_ij a_j
//   f_i  = f exp(xi_i),         a_i = ABA(f_i, q_i, v_i),       Kxi_i = dexp_inv(-xi_i) V0_i
// and the step ends at f exp(h sum_i b_i Kxi_i) with q and v combined by b. The joint part is
// the plain Runge-Kutta method. dexp_inv(-xi) is the body-frame form: f^-1 fdot = dexp(-xi) xidot.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "lie/simd.h"
#include "se3_sim/integrate.h"

namespace se3 {

ButcherTableau tableau_rk4() {
  ButcherTableau t;
  t.name = "rkmk4";
  t.order = 4;
  t.a = {{}, {0.5}, {0.0, 0.5}, {0.0, 0.0, 1.0}};
  t.b = {1.0 / 6, 1.0 / 3, 1.0 / 3, 1.0 / 6};
  return t;
}

ButcherTableau tableau_dormand_prince45() {
  ButcherTableau t;
  t.name = "rkmk45";
  t.order = 5;
  t.a = {{},
         {1.0 / 5},
         {3.0 / 40, 9.0 / 40},
         {44.0 / 45, -56.0 / 15, 32.0 / 9},
         {19372.0 / 6561, -25360.0 / 2187, 64448.0 / 6561, -212.0 / 729},
         {9017.0 / 3168, -355.0 / 33, 46732.0 / 5247, 49.0 / 176, -5103.0 / 18656},
         {35.0 / 384, 0.0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84}};
  t.b = {35.0 / 384, 0.0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84, 0.0};
  const double bh[7] = {5179.0 / 57600,    0.0,          7571.0 / 16695, 393.0 / 640,
                        -92097.0 / 339200, 187.0 / 2100, 1.0 / 40};
  for (int i = 0; i < 7; ++i) t.b_err.push_back(t.b[i] - bh[i]);
  t.fsal = true;
  return t;
}

namespace {

// y += c x over n entries, two at a time in an SSE2 register (vectors here have a few to a few
// hundred entries: no setup beyond the loop).
inline void axpy(int n, double c, const double* __restrict x, double* __restrict y) {
  int k = 0;
  for (; k + 2 <= n; k += 2) detail::store2(y + k, detail::load2(y + k) + c * detail::load2(x + k));
  if (k < n) y[k] += c * x[k];
}

// y = x over n entries (a plain loop: std::copy calls memmove, costly for a dozen doubles).
inline void copy(int n, const double* __restrict x, double* __restrict y) {
  for (int k = 0; k < n; ++k) y[k] = x[k];
}

class RkmkStepper final : public Stepper {
 public:
  RkmkStepper(const ButcherTableau& tab, const Model& model, const StepperOptions& opt)
      : Stepper(model, opt), tab_(tab), s_(static_cast<int>(tab.b.size())) {
    if (s_ < 1 || static_cast<int>(tab_.a.size()) != s_) {
      throw std::invalid_argument("tableau '" + tab_.name + "': a and b sizes differ");
    }
    for (int i = 0; i < s_; ++i) {
      if (static_cast<int>(tab_.a[i].size()) > i) {
        throw std::invalid_argument("tableau '" + tab_.name + "' is not explicit");
      }
    }
    if (!tab_.b_err.empty() && static_cast<int>(tab_.b_err.size()) != s_) {
      throw std::invalid_argument("tableau '" + tab_.name + "': b_err has the wrong size");
    }
    if (tab_.fsal) {
      const auto& last = tab_.a[s_ - 1];
      for (int j = 0; j < s_ - 1; ++j) {
        const double aj = j < static_cast<int>(last.size()) ? last[j] : 0.0;
        if (aj != tab_.b[j] || tab_.b[s_ - 1] != 0) {
          throw std::invalid_argument("tableau '" + tab_.name + "' is not first-same-as-last");
        }
      }
    }
    if (s_ > kMaxStages) {
      throw std::invalid_argument("tableau '" + tab_.name + "': more than " +
                                  std::to_string(kMaxStages) + " stages");
    }
    if (adaptive() && !(opt_.tol > 0)) throw std::invalid_argument("tol must be positive");
    kxi_.assign(s_, Vec6::Zero());
    kv_.assign(s_, VecX::Zero(model.nv));
    vs_.assign(s_, VecX::Zero(model.nv));
    qi_ = VecX::Zero(model.n);
    start_ = State(model);
    trial_ = State(model);
    cache_end_ = State(model);
    cache_tau_ = VecX::Zero(model.nv);
    err_q_ = VecX::Zero(model.n);
    err_v_ = VecX::Zero(model.nv);
  }

  std::string name() const override { return tab_.name; }
  int order() const override { return tab_.order; }
  bool adaptive() const override { return !tab_.b_err.empty(); }
  void restart() override {
    h_suggest_ = 0;
    cache_valid_ = false;
  }

  StepInfo step(State& x, const VecX& tau_cmd, double h) override {
    if (adaptive()) return adaptive_step(x, tau_cmd, h);
    StepInfo info;
    first_stage_known_ = false;
    stages(x, tau_cmd, h, info);
    combine(x, h, x);  // in place: the stages hold all they need of x
    info.substeps = 1;
    return info;
  }

 private:
  // The stages of a step of size h from x: kv_, vs_ and kxi_ (stage 0 skipped when
  // first_stage_known_). The stage sums are plain loops over the few non-zero a_ij (Eigen's
  // expressions on vectors of a dozen entries cost more in setup than in arithmetic).
  void stages(const State& x, const VecX& tau, double h, StepInfo& info) {
    const bool fl = model_.floating;
    const int n = model_.n, nv = model_.nv, off = nv - n;
    for (int i = 0; i < s_; ++i) {
      if (i == 0 && first_stage_known_) continue;
      const auto& ai = tab_.a[i];
      double c[kMaxStages];
      const double* kv[kMaxStages];
      const double* qd[kMaxStages];
      int terms = 0;
      Vec6 xi = Vec6::Zero();
      for (int j = 0; j < static_cast<int>(ai.size()); ++j) {
        if (ai[j] == 0) continue;
        c[terms] = h * ai[j];
        kv[terms] = kv_[j].data();
        qd[terms] = vs_[j].data() + off;
        if (fl) xi.noalias() += c[terms] * kxi_[j];
        ++terms;
      }
      double* vi = vs_[i].data();
      const double* xv = x.v.data();
      if (terms == 0) {  // the stage point is x itself
        copy(nv, xv, vi);
        stage_acceleration(i, x.base, x.q, vs_[i], tau);
        if (fl) kxi_[i] = vs_[i].head<6>();
        ++info.evaluations;
        continue;
      }
      double* qi = qi_.data();
      const double* xq = x.q.data();
      copy(nv, xv, vi);
      copy(n, xq, qi);
      for (int t = 0; t < terms; ++t) {
        axpy(nv, c[t], kv[t], vi);
        axpy(n, c[t], qd[t], qi);
      }
      if (fl) {
        stage_acceleration(i, stage_pose(x.base, xi), qi_, vs_[i], tau);
        kxi_[i] = dexp_inv_se3_times(-xi, vs_[i].head<6>());
      } else {
        stage_acceleration(i, x.base, qi_, vs_[i], tau);
      }
      ++info.evaluations;
    }
  }

  // kv_[i] = the acceleration at a stage point (ABA's output vector is swapped in, not copied).
  void stage_acceleration(int i, const SE3& base, const VecX& q, const VecX& v, const VecX& tau) {
    const VecX& a = acceleration(base, q, v, tau);
    if (&a == &data_.ddq) {
      kv_[i].swap(data_.ddq);
    } else {
      copy(model_.nv, a.data(), kv_[i].data());
    }
  }

  // The base pose at a stage, x.base exp(xi). Without a constraint hook only ABA sees it, and
  // ABA depends on the base pose only through its rotation (the direction of gravity in the base
  // frame, dynamics.h): then the position is left as it is, and with zero gravity the pose too.
  SE3 stage_pose(const SE3& base, const Vec6& xi) const {
    if (acceleration_hook()) return base * exp_se3(xi);
    if (model_.gravity.isZero(0.0)) return base;
    return SE3(base.R * exp_so3(xi.head<3>()), base.p);
  }

  // y = x advanced by h with the weights b of the stages; y may be x itself. Returns the base's
  // increment xi (y.base = x.base exp(xi)).
  Vec6 combine(const State& x, double h, State& y) {
    const bool fl = model_.floating;
    const int n = model_.n, nv = model_.nv, off = nv - n;
    double c[kMaxStages];
    const double* kv[kMaxStages];
    const double* qd[kMaxStages];
    int terms = 0;
    Vec6 xi = Vec6::Zero();
    for (int i = 0; i < s_; ++i) {
      if (tab_.b[i] == 0) continue;
      c[terms] = h * tab_.b[i];
      kv[terms] = kv_[i].data();
      qd[terms] = vs_[i].data() + off;
      if (fl) xi.noalias() += c[terms] * kxi_[i];
      ++terms;
    }
    if (&y != &x) {
      copy(nv, x.v.data(), y.v.data());
      copy(n, x.q.data(), y.q.data());
    }
    for (int t = 0; t < terms; ++t) {
      axpy(nv, c[t], kv[t], y.v.data());
      axpy(n, c[t], qd[t], y.q.data());
    }
    if (fl) {
      y.base = x.base * exp_se3(xi);
      y.base.R = orthonormalize(y.base.R);
    } else if (&y != &x) {
      y.base = x.base;
    }
    return xi;
  }

  // One attempt of size h from x into y (y must not alias x: the error estimate reads both).
  // Returns the scaled RMS error norm (adaptive tableaus; 0 otherwise).
  double attempt(const State& x, const VecX& tau, double h, State& y, StepInfo& info) {
    const bool fl = model_.floating;
    const int n = model_.n;
    stages(x, tau, h, info);
    const Vec6 xi = combine(x, h, y);
    if (tab_.b_err.empty()) return 0;
    // Error estimate of the embedded pair, scaled per component by tol (1 + |y|).
    Vec6 exi = Vec6::Zero();
    err_q_.setZero();
    err_v_.setZero();
    for (int i = 0; i < s_; ++i) {
      const double c = h * tab_.b_err[i];
      if (c == 0) continue;
      if (fl) exi.noalias() += c * kxi_[i];
      err_q_.noalias() += c * vs_[i].tail(n);
      err_v_.noalias() += c * kv_[i];
    }
    double sum = 0;
    int count = 0;
    const double tol = opt_.tol;
    if (fl) {
      for (int k = 0; k < 6; ++k) {
        const double e = exi[k] / (tol * (1 + std::abs(xi[k])));
        sum += e * e;
      }
      count += 6;
    }
    for (int k = 0; k < n; ++k) {
      const double e = err_q_[k] / (tol * (1 + std::max(std::abs(x.q[k]), std::abs(y.q[k]))));
      sum += e * e;
    }
    for (int k = 0; k < model_.nv; ++k) {
      const double e = err_v_[k] / (tol * (1 + std::max(std::abs(x.v[k]), std::abs(y.v[k]))));
      sum += e * e;
    }
    count += n + model_.nv;
    return std::sqrt(sum / std::max(count, 1));
  }

  static bool same(const State& a, const State& b) {
    return a.base.R == b.base.R && a.base.p == b.base.p && a.q == b.q && a.v == b.v;
  }

  // After an accepted FSAL step the last stage is the next step's first: at the end point
  // xi = 0, so Kxi = V0 and the acceleration is the one just computed.
  void shift_fsal(const State& y) {
    std::swap(kv_[0], kv_[s_ - 1]);
    std::swap(vs_[0], vs_[s_ - 1]);
    if (model_.floating) kxi_[0] = y.v.head<6>();
    first_stage_known_ = true;
  }

  StepInfo adaptive_step(State& x, const VecX& tau, double H) {
    StepInfo info;
    start_.base = x.base;
    start_.q = x.q;
    start_.v = x.v;
    first_stage_known_ = tab_.fsal && cache_valid_ && same(x, cache_end_) && tau == cache_tau_;
    cache_valid_ = false;
    const double exponent = -1.0 / tab_.order;
    double remaining = H;
    double h = (h_suggest_ > 0) ? h_suggest_ : H;
    while (remaining > 0) {
      if (info.substeps + info.rejected >= opt_.max_substeps) {
        info.ok = false;
        info.reason = "adaptive step: more than " + std::to_string(opt_.max_substeps) +
                      " internal steps for one step";
        break;
      }
      bool truncated = false;
      double ht = h;
      if (ht >= remaining * (1 - 1e-9)) {
        truncated = ht > remaining;
        ht = remaining;
      }
      const double err = attempt(x, tau, ht, trial_, info);
      if (std::isfinite(err) && err <= 1.0 && trial_.finite()) {
        x.base = trial_.base;
        x.q = trial_.q;
        x.v = trial_.v;
        remaining -= ht;
        if (remaining < 1e-14 * H) remaining = 0;
        ++info.substeps;
        const double fac =
            err > 0 ? std::min(5.0, std::max(0.2, 0.9 * std::pow(err, exponent))) : 5.0;
        // A step shortened only to land on H says nothing against the longer suggestion.
        h = truncated ? std::max(h, ht * fac) : ht * fac;
        if (tab_.fsal) {
          shift_fsal(x);
        } else {
          first_stage_known_ = false;
        }
      } else {
        ++info.rejected;
        const double fac = std::isfinite(err) ? std::max(0.2, 0.9 * std::pow(err, exponent)) : 0.2;
        h = ht * std::min(fac, 0.9);
        first_stage_known_ = true;  // stage 1 sits at x, which has not moved
        if (h < opt_.h_min) {
          info.ok = false;
          info.reason = "adaptive step size fell below h_min = " + std::to_string(opt_.h_min) +
                        " (error " + std::to_string(err) + ")";
          break;
        }
      }
    }
    if (!info.ok) {
      x.base = start_.base;
      x.q = start_.q;
      x.v = start_.v;
      h_suggest_ = 0;
      first_stage_known_ = false;
      return info;
    }
    h_suggest_ = h;
    if (tab_.fsal && first_stage_known_) {
      cache_end_.base = x.base;
      cache_end_.q = x.q;
      cache_end_.v = x.v;
      cache_tau_ = tau;
      cache_valid_ = true;
    }
    return info;
  }

  static constexpr int kMaxStages = 16;
  ButcherTableau tab_;
  int s_;
  std::vector<Vec6> kxi_;
  std::vector<VecX> kv_, vs_;
  VecX qi_, err_q_, err_v_;
  State start_, trial_, cache_end_;
  VecX cache_tau_;
  bool first_stage_known_ = false;
  bool cache_valid_ = false;
  double h_suggest_ = 0;
};

}  // namespace

std::unique_ptr<Stepper> make_rkmk_stepper(const ButcherTableau& tableau, const Model& model,
                                           const StepperOptions& opt) {
  return std::make_unique<RkmkStepper>(tableau, model, opt);
}

}  // namespace se3
