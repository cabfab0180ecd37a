#include "lie/simd.h"
#include "se3_sim/dynamics/dynamics.h"
#include "tree_depth.h"

namespace se3 {

namespace {
// crba runs in local frames when the ancestor-descendant pairs are at most this many per body.
constexpr int kCrbaLocalPairsPerBody = 8;
// minv factorizes CRBA's D when its row recurrence costs at most this many multiply-adds per dof
// on average; the recursion's 6x6 base block costs more on a free base (docs/performance.md:
// the crossovers measured on chains, fixed ~23 and free ~35).
constexpr int kMinvFactorWorkPerDof = 22;
constexpr int kMinvFactorWorkPerDofFree = 32;
}  // namespace

Data::Data(const Model& model) {
  const size_t nb = static_cast<size_t>(model.n) + 1;
  const size_t nq = static_cast<size_t>(model.nq), nv = static_cast<size_t>(model.nv);
  Xup.assign(nb, SE3());
  oMb.assign(nb, SE3());
  V.assign(nb, Vec6::Zero());
  A.assign(nb, Vec6::Zero());
  c.assign(nb, Vec6::Zero());
  F.assign(nb, Vec6::Zero());
  IA.assign(nb, Mat6::Zero());
  Ic.assign(nb, Inertia());
  sin_q.assign(nq, 0.0);
  cos_q.assign(nq, 1.0);
  U.assign(nv, Vec6::Zero());
  Dinv.assign(nv, 0.0);
  u.assign(nv, 0.0);
  S.assign(nv, Vec6::Zero());
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
  // The parent dof of every dof: a free base's six form a chain, a body's joint hangs on its
  // parent body's joint (or on the base's last dof, or on nothing for a fixed base).
  const int v1 = model.nv_base() - 1;
  v_parent.assign(nv, -1);
  for (int k = 1; k < model.nv_base(); ++k) v_parent[k] = k - 1;
  for (int i = 1; i <= model.n; ++i) {
    const int p = model.parent[i];
    v_parent[v1 + i] = p > 0 ? v1 + p : v1;
  }
  // D^-1 by factorizing D: its cost, sum over dofs k of depth_k k (the row recurrence), against
  // the recursion's subtree column loops and per-body world inertias.
  std::vector<int> depth(nv);
  detail::dof_depths(
      model.nv, [this](int k) { return v_parent[k]; }, depth.data());
  long factor_work = 0;
  for (int k = 0; k < model.nv; ++k) factor_work += static_cast<long>(depth[k]) * k;
  minv_by_factor =
      factor_work <= (model.floating ? kMinvFactorWorkPerDofFree : kMinvFactorWorkPerDof) *
                         static_cast<long>(model.nv);
  tau = VecX::Zero(model.nv);
  ddq = VecX::Zero(model.nv);
  nle = VecX::Zero(model.nv);
  // D^-1's forward pass keeps one 6 x nv acceleration block per open branch: a body reuses its
  // parent's block when it is the parent's last child (all earlier siblings are done by then).
  int slots = 1;
  for (int i = 1; i <= model.n; ++i) {
    const auto& sib = model.children[model.parent[i]];
    P_slot[i] = (sib.back() == i) ? P_slot[model.parent[i]] : slots++;
  }
  Pm.resize(slots);
}

void Data::reserve_crba(const Model& model) {
  if (crba_reserved_) return;
  M = MatX::Zero(model.nv, model.nv);
  LD = MatX::Zero(model.nv, model.nv);
  Jrow = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor>::Zero(6, model.nv);
  if (Fm.cols() != model.nv) Fm = Mat6X::Zero(6, model.nv);
  crba_reserved_ = true;
}

void Data::reserve_minv(const Model& model) {
  if (minv_reserved_) return;
  if (minv_by_factor) reserve_crba(model);
  Minv = MatX::Zero(model.nv, model.nv);
  if (Fm.cols() != model.nv) Fm = Mat6X::Zero(6, model.nv);
  for (Mat6X& P : Pm) P = Mat6X::Zero(6, model.nv);
  minv_reserved_ = true;
}

State::State(const Model& model)
    : base(model.X_tree.empty() ? SE3() : model.X_tree[0]),
      q(VecX::Zero(model.nq)),
      v(VecX::Zero(model.nv)) {}

bool State::finite() const {
  return detail::all_finite(static_cast<int>(q.size()), q.data()) &&
         detail::all_finite(static_cast<int>(v.size()), v.data()) &&
         detail::all_finite(3, base.p.data()) && is_rotation(base.R);
}

}  // namespace se3
