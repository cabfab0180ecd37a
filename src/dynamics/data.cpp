#include "lie/simd.h"
#include "se3_sim/dynamics.h"

namespace se3 {

namespace {
// crba runs in local frames when the ancestor-descendant pairs are at most this many per body.
constexpr int kCrbaLocalPairsPerBody = 8;
}  // namespace

Data::Data(const Model& model) {
  const size_t nb = static_cast<size_t>(model.n) + 1;
  Xup.assign(nb, SE3());
  sin_q.assign(nb, 0.0);
  cos_q.assign(nb, 1.0);
  VA.assign(2 * nb, Vec6::Zero());
  oMb.assign(nb, SE3());
  V.assign(nb, Vec6::Zero());
  A.assign(nb, Vec6::Zero());
  c.assign(nb, Vec6::Zero());
  F.assign(nb, Vec6::Zero());
  IA.assign(nb, Mat6::Zero());
  U.assign(nb, Vec6::Zero());
  Dinv.assign(nb, 0.0);
  u.assign(nb, 0.0);
  Ic.assign(nb, Inertia());
  S.assign(nb, Vec6::Zero());
  P_slot.assign(nb, 0);
  run_start.assign(nb, 0);
  for (int j = 1; j <= model.n; ++j) {
    run_start[j] = (j > 1 && model.parent[j] == j - 1) ? run_start[j - 1] : j;
  }
  // Ancestor-descendant pairs: a wrench transform each in local frames, against about a
  // forward-kinematics step, a world inertia and an axis per body in the world frame.
  long pairs = 0;
  for (int i = 1; i <= model.n; ++i) pairs += model.subtree_end[i] - i;
  crba_local = pairs <= kCrbaLocalPairsPerBody * model.n;
  tau = VecX::Zero(model.nv);
  ddq = VecX::Zero(model.nv);
  nle = VecX::Zero(model.nv);
  M = MatX::Zero(model.nv, model.nv);
  Minv = MatX::Zero(model.nv, model.nv);
  Jrow = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor>::Zero(6, model.nv);
  Fm = Mat6X::Zero(6, model.nv);
  // D^-1's forward pass keeps one 6 x nv acceleration block per open branch: a body reuses its
  // parent's block when it is the parent's last child (all earlier siblings are done by then).
  int slots = 1;
  for (int i = 1; i <= model.n; ++i) {
    const auto& sib = model.children[model.parent[i]];
    P_slot[i] = (sib.back() == i) ? P_slot[model.parent[i]] : slots++;
  }
  Pm.assign(slots, Mat6X::Zero(6, model.nv));
}

State::State(const Model& model) : q(VecX::Zero(model.n)), v(VecX::Zero(model.nv)) {}

bool State::finite() const {
  return detail::all_finite(static_cast<int>(q.size()), q.data()) &&
         detail::all_finite(static_cast<int>(v.size()), v.data()) &&
         detail::all_finite(3, base.p.data()) && is_rotation(base.R);
}

}  // namespace se3
