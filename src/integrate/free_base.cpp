// The free base in the velocity-level step (integrate.h's FreeBaseStep): the tree's momentum in
// the world changes by the external impulses only, whatever the joints do. docs/design.md,
// "The velocity-level step", derives the three equations:
//   (V1) a_0 = [0; R^T g] + D_00^-1 (F_0 - D_0q a_q)          the free velocity's base part
//   (V2) f+ = f E,  E = (exp(h w), h u)                        the pose, V0 = [w; u]
//   (V3) D_0(q+) v+ = Ad*_E^T D_0(q) v                         the base twist re-expressed
#include <cmath>

#include "se3_sim/integrate/integrate.h"

namespace se3 {

SE3 advance_free_pose(SE3& f, const Vec6& V, double h) {
  const SE3 E(exp_so3(h * V.head<3>()), h * V.tail<3>());
  f.p += h * (f.R * V.tail<3>());  // = f.R E.p, world-frame velocity first
  f.R = reorthonormalize(f.R * E.R);
  return E;
}

Vec6 reexpress_momentum(const SE3& E, const Vec6& P) {
  return act_inv_force(E, P);
}

FreeBaseStep::FreeBaseStep(const Model& model)
    : model_(model),
      D0_(Mat6N::Zero(6, model.nv)),
      q_at_(VecX::Zero(model.nq)),
      a_(VecX::Zero(model.nv)),
      d_(VecX::Zero(model.nv)) {}

bool FreeBaseStep::map_at(const VecX& q) const {
  if (!valid_) return false;
  for (int k = 0; k < model_.nq; ++k) {
    if (q[k] != q_at_[k]) return false;  // NaN: never equal, recomputed
  }
  return true;
}

void FreeBaseStep::map(Data& data, const VecX& q) {
  if (map_at(q)) return;
  base_momentum_map(model_, data, q, D0_);
  llt_.compute(D0_.leftCols<6>());
  for (int k = 0; k < model_.nq; ++k) q_at_[k] = q[k];
  valid_ = true;
}

const VecX& FreeBaseStep::free_acceleration(Data& data, const State& x, const VecX& tau,
                                            const VecX& a, const VecX* a_unconstrained) {
  for (int k = 0; k < model_.nv; ++k) a_[k] = a[k];
  if (!model_.floating) return a_;
  map(data, x.q);
  // (V1): D_0 (v + h a) = D_0 v + h (F_0 + D_00 [0; R^T g]), the frozen base frame's momentum
  // changed by the applied base wrench F_0 and gravity alone; with constraint forces in a (an
  // acceleration hook), also by theirs: D_0 (a - a_unconstrained) = (Psi^T lambda)_0.
  Vec6 r = tau.head<6>();
  if (a_unconstrained) {
    for (int k = 0; k < model_.nv; ++k) d_[k] = a[k] - (*a_unconstrained)[k];
    r.noalias() += D0_ * d_;
  }
  const int nq = model_.nq;
  if (nq > 0) r.noalias() -= D0_.rightCols(nq) * a_.tail(nq);
  Vec6 a0 = llt_.solve(r);
  a0.tail<3>() += x.base.R.transpose() * model_.gravity;
  a_.head<6>() = a0;
  return a_;
}

void FreeBaseStep::advance(Data& data, State& x, double h) {
  const int nq = model_.nq, nb = model_.nv_base();
  if (!model_.floating) {
    for (int k = 0; k < nq; ++k) x.q[k] += h * x.v[nb + k];
    return;
  }
  map(data, x.q);
  const Vec6 P = D0_ * x.v;  // momentum about the step's first base frame
  const SE3 E = advance_free_pose(x.base, x.v.head<6>(), h);
  for (int k = 0; k < nq; ++k) x.q[k] += h * x.v[6 + k];
  // (V3): the same momentum about the new base frame, and the base twist that carries it with
  // the joints' new rates at the new configuration.
  map(data, x.q);
  Vec6 r = reexpress_momentum(E, P);
  if (nq > 0) r.noalias() -= D0_.rightCols(nq) * x.v.tail(nq);
  x.v.head<6>() = llt_.solve(r);
}

}  // namespace se3
