// Runge-Kutta-Munthe-Kaas steppers for any explicit Butcher tableau (integrate.h).
//
// Stage i of a step from (f, q, v):
//   xi_i = h sum_j a_ij Kxi_j,  q_i = q + h sum_j a_ij qdot_j,  v_i = v + h sum_j a_ij a_j
//   f_i  = f exp(xi_i),         a_i = ABA(f_i, q_i, v_i),       Kxi_i = dexp_inv(-xi_i) V0_i
// and the step ends at f exp(h sum_i b_i Kxi_i) with q and v combined by b. The joint part is
// the plain Runge-Kutta method (every joint has nq = nv = 1: q advances with the joint rates, the
// entries of v after the base's). dexp_inv(-xi) is the body-frame form: f^-1 fdot = dexp(-xi)
// xidot, taken from its series for methods of order <= 4 (see series_dexp_).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "lie/simd.h"
#include "se3_sim/integrate/integrate.h"
#include "se3_sim/lie/format.h"

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

using detail::copy;

class RkmkStepper final : public Stepper {
  static constexpr int kMaxStages = 16;
  struct Term {  // a tableau entry: stage j, coefficient a
    int j;
    double a;
  };

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
    if (adaptive() && !(opt_.tol > 0)) throw std::invalid_argument("tol must be positive");
    rows_.resize(s_);
    for (int i = 0; i < s_; ++i) {
      for (int j = 0; j < static_cast<int>(tab_.a[i].size()); ++j) {
        if (tab_.a[i][j] != 0) rows_[i].push_back({j, tab_.a[i][j]});
      }
      if (tab_.b[i] != 0) weights_.push_back({i, tab_.b[i]});
    }
    if (weights_.empty()) throw std::invalid_argument("tableau '" + tab_.name + "': b is zero");
    if (s_ > kMaxStages) {
      throw std::invalid_argument("tableau '" + tab_.name + "': more than " +
                                  std::to_string(kMaxStages) + " stages");
    }
    series_dexp_ = tab_.order <= 4;
    chain_ = tab_.fast_path && !adaptive();
    chain_c_.assign(s_, 0.0);
    for (int i = 1; i < s_; ++i) {
      const auto& ai = tab_.a[i];
      for (int j = 0; j + 1 < static_cast<int>(ai.size()); ++j) chain_ = chain_ && ai[j] == 0;
      if (static_cast<int>(ai.size()) == i) chain_c_[i] = ai[i - 1];
    }
    vbuf_[0] = vbuf_[1] = sum_v_ = VecX::Zero(model.nv);
    sum_q_ = VecX::Zero(model.nq);
    kxi_.assign(s_, Vec6::Zero());
    kv_.assign(s_, VecX::Zero(model.nv));
    vs_.assign(s_, VecX::Zero(model.nv));
    qi_ = VecX::Zero(model.nq);
    start_ = State(model);
    trial_ = State(model);
    cache_end_ = State(model);
    cache_tau_ = VecX::Zero(model.nv);
    err_q_ = VecX::Zero(model.nq);
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
    if (chain_) return step_chain(x, tau_cmd, h);
    StepInfo info;
    first_stage_known_ = false;
    stages(x, tau_cmd, h, info);
    combine(x, h, x);  // in place: the stages hold all they need of x
    info.substeps = 1;
    return info;
  }

 private:
  // A fixed step of a tableau whose stage i reads only stage i - 1 (classical RK4): each stage's
  // slope goes into the b-weighted sum and into the next stage point in one pass and is then
  // dropped, so no stage is stored and no combination pass is left at the end.
  StepInfo step_chain(State& x, const VecX& tau, double h) {
    const bool fl = model_.floating;
    const int n = model_.nq, nv = model_.nv, off = model_.nv_base();
    const double *xv = x.v.data(), *xq = x.q.data();
    double *sv = sum_v_.data(), *sq = sum_q_.data();
    const VecX *vi = &x.v, *qi = &x.q;  // the stage point's rates and positions
    Vec6 xi = Vec6::Zero(), sum_xi = Vec6::Zero();
    SE3 fi;  // the stage's base pose (free base)
    for (int i = 0;; ++i) {
      // The base's slope reads only the stage point, so it is formed before the stage's ABA call
      // (measured faster: docs/performance.md).
      Vec6 kxi = Vec6::Zero();
      if (fl) {
        kxi = i == 0 ? vi->head<6>()
                     : (series_dexp_ ? dexp_inv_se3_times_series(-xi, vi->head<6>())
                                     : dexp_inv_se3_times(-xi, vi->head<6>()));
      }
      if (i > 0 && fl) fi = stage_pose(x.base, xi);
      const double* a = acceleration(i > 0 && fl ? fi : x.base, *qi, *vi, tau).data();
      const double* w = vi->data() + off;  // the stage's joint rates, qdot
      const double b = h * tab_.b[i];
      if (i + 1 == s_) {  // x += sum + b slope (q first: with one stage, w is x's own rates)
        add_sum(n, b, w, sq, i > 0, x.q.data());
        add_sum(nv, b, a, sv, i > 0, x.v.data());
        if (fl) {
          x.base = x.base * exp_se3(sum_xi + b * kxi);
          x.base.R = reorthonormalize(x.base.R);
        }
        break;
      }
      const double c = h * chain_c_[i + 1];
      VecX& vn = vbuf_[i & 1];  // not *vi: that is x.v or the other buffer
      feed(n, w, b, sq, i > 0, c, xq, qi_.data());
      feed(nv, a, b, sv, i > 0, c, xv, vn.data());
      if (fl) {
        sum_xi += b * kxi;
        xi = c * kxi;
      }
      vi = &vn;
      qi = &qi_;
    }
    StepInfo info;
    info.evaluations = s_;
    info.substeps = 1;
    return info;
  }

  // sum = (add ? sum : 0) + b z and next = x + c z, in one pass over z.
  static void feed(int n, const double* z, double b, double* sum, bool add, double c,
                   const double* x, double* next) {
    if (add) {
      for (int k = 0; k < n; ++k) {
        const double zk = z[k];
        sum[k] += b * zk;
        next[k] = x[k] + c * zk;
      }
    } else {
      for (int k = 0; k < n; ++k) {
        const double zk = z[k];
        sum[k] = b * zk;
        next[k] = x[k] + c * zk;
      }
    }
  }

  // y += (add ? sum : 0) + b z.
  static void add_sum(int n, double b, const double* z, const double* sum, bool add, double* y) {
    if (!add) return detail::axpy(n, b, z, y);
    for (int k = 0; k < n; ++k) y[k] += sum[k] + b * z[k];
  }

  // The stages of a step of size h from x: kv_, vs_ and kxi_ (stage 0 skipped when
  // first_stage_known_).
  void stages(const State& x, const VecX& tau, double h, StepInfo& info) {
    const bool fl = model_.floating;
    for (int i = 0; i < s_; ++i) {
      if (i == 0 && first_stage_known_) continue;
      ++info.evaluations;
      if (rows_[i].empty()) {  // the stage point is x itself
        copy(model_.nv, x.v.data(), vs_[i].data());
        stage_acceleration(i, x.base, x.q, vs_[i], tau);
        if (fl) kxi_[i] = vs_[i].head<6>();
        continue;
      }
      const Vec6 xi = advance(x, rows_[i], h, vs_[i].data(), qi_.data());
      if (!fl) {
        stage_acceleration(i, x.base, qi_, vs_[i], tau);
        continue;
      }
      stage_acceleration(i, stage_pose(x.base, xi), qi_, vs_[i], tau);
      kxi_[i] = series_dexp_ ? dexp_inv_se3_times_series(-xi, vs_[i].head<6>())
                             : dexp_inv_se3_times(-xi, vs_[i].head<6>());
    }
  }

  // v = x.v + h sum_t a_t kv_[j_t] and q = x.q + h sum_t a_t qdot_[j_t] over the terms (one pass
  // over each vector); returns the base's xi = h sum_t a_t kxi_[j_t]. v and q may be x's own.
  Vec6 advance(const State& x, const std::vector<Term>& terms, double h, double* v, double* q) {
    const int n = model_.nq, nv = model_.nv, off = model_.nv_base();
    const int T = static_cast<int>(terms.size());
    double c[kMaxStages];
    const double* a[kMaxStages];
    const double* qd[kMaxStages];
    Vec6 xi = Vec6::Zero();
    for (int t = 0; t < T; ++t) {
      c[t] = h * terms[t].a;
      a[t] = kv_[terms[t].j].data();
      qd[t] = vs_[terms[t].j].data() + off;
      if (model_.floating) xi += c[t] * kxi_[terms[t].j];
    }
    detail::add_terms(nv, x.v.data(), T, c, a, v);
    detail::add_terms(n, x.q.data(), T, c, qd, q);
    return xi;
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
  // frame: dynamics.h's contract, tested by gtest_dynamics): then the position is left as it is,
  // and with zero gravity the pose too.
  SE3 stage_pose(const SE3& base, const Vec6& xi) const {
    if (acceleration_hook()) return base * exp_se3(xi);
    if (model_.gravity.isZero(0.0)) return base;
    return SE3(base.R * exp_so3(xi.head<3>()), base.p);
  }

  // y = x advanced by h with the weights b of the stages; y may be x itself (the stages keep
  // their own copy of the rates). Returns the base's increment xi (y.base = x.base exp(xi)).
  Vec6 combine(const State& x, double h, State& y) {
    const Vec6 xi = advance(x, weights_, h, y.v.data(), y.q.data());
    if (!model_.floating) {
      if (&y != &x) y.base = x.base;
      return xi;
    }
    y.base = x.base * exp_se3(xi);
    y.base.R = reorthonormalize(y.base.R);
    return xi;
  }

  // One attempt of size h from x into y (y must not alias x: the error estimate reads both).
  // Returns the scaled RMS error norm (adaptive tableaus; 0 otherwise).
  double attempt(const State& x, const VecX& tau, double h, State& y, StepInfo& info) {
    const bool fl = model_.floating;
    const int n = model_.nq;
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
          info.reason = "adaptive step size fell below h_min = " + num(opt_.h_min) + " (error " +
                        num(err) + ")";
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

  ButcherTableau tab_;
  int s_;
  // The non-zero entries of the tableau: a_ij of stage i (rows_[i]), and b_i (weights_, j = i).
  std::vector<std::vector<Term>> rows_;
  std::vector<Term> weights_;
  // dexp_inv by its series through ad^2 (lie.h) for methods of order <= 4, the closed form above.
  // Munthe-Kaas (1999): an RKMK method of order p keeps its order with the series cut after
  // ad^(p-1); the cut changes the increment's slope by O(|xi|^(p-1)), which the integral over a
  // step of size h (xi = O(h)) turns into O(h^(p+1)), the method's local error. The ad^3 term is
  // zero, so through ad^2 is through ad^3: order 4.
  bool series_dexp_ = false;
  // step_chain: whether the tableau qualifies, its a_{i,i-1}, and its workspace.
  bool chain_ = false;
  std::vector<double> chain_c_;
  VecX vbuf_[2], sum_v_, sum_q_;
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
