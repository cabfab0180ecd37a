// Rigid-body dynamics of the free-floating (or fixed-base) tree, section 6 of Reuss 2002.
//
// State: base pose f0 (body 0 in the world; fixed-base models use it as the mount pose),
// joint positions q (size nq) and generalized velocity v (size nv): for a free base
// v = [V0; qdot] with V0 = [w; v] the base twist in its own frame (eq. 12), else v = qdot.
// Accelerations are time derivatives of these components (dV0/dt in the base frame).
//
// Every function works on a preallocated Data and allocates nothing.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "se3_sim/model/model.h"

namespace se3 {

using VecX = Eigen::VectorXd;
using MatX = Eigen::MatrixXd;
using Mat36 = Eigen::Matrix<double, 3, 6>;

/// The workspace of the algorithms: one per thread, sized for a model by the constructor with
/// O(n) memory. The mass-matrix workspaces (M and Minv, nv x nv, and their helpers) are sized on
/// the first crba or minv call, or ahead of it by reserve_crba() / reserve_minv(): a time step that
/// calls crba or minv reserves in its constructor, so that no step allocates.
///
/// Every field says which calls fill it and in which frame ("body": the body's own frame;
/// "world": the world frame). A field holds what the last call that fills it left; the others
/// leave it alone. Per-body arrays have n + 1 entries ([0] the base); per-coordinate arrays are
/// indexed by the joint's idx_q (size nq) or idx_v (size nv; a free base's six entries of the
/// per-dof arrays are unused).
struct Data {
  explicit Data(const Model& model);

  // ---- per body
  /// Body i in its parent's frame, X_tree[i] exp(S_i q_i): every algorithm (all start with the
  /// joint transforms); [0] is not written.
  std::vector<SE3> Xup;
  /// Body i in the world: forward_kinematics, minv's recursion, crba's world-frame evaluation
  /// (crba_local false), and the energy, momentum and centre-of-mass functions.
  std::vector<SE3> oMb;
  /// Body twists (body frame), eq. (33): forward_kinematics with v, body_twists, rnea, aba,
  /// kinetic_energy, spatial_momentum ([0] the base's twist, zero for a fixed base).
  std::vector<Vec6> V;
  /// Body accelerations (body frame) with gravity folded in as the fictitious base acceleration
  /// [0; -R0^T g] (section 4.3), eq. (35): rnea, aba. Add R_i^T g (world to body) for the true one.
  std::vector<Vec6> A;
  /// Velocity-product accelerations gamma_i = V_i x (S_i qd_i) (body frame), eq. (34): aba.
  std::vector<Vec6> c;
  /// rnea: the wrench body i's joint transmits, eq. (36) summed over its subtree (body frame),
  /// [0] the base's (minus f_ext_base); aba: the articulated bias forces pA, eqs. (39)-(41) (body
  /// frame).
  std::vector<Vec6> F;
  /// aba: articulated-body inertias, eq. (38) (body frame; the upper triangle only); minv's
  /// recursion: articulated inertias in the world frame (the upper triangle only).
  std::vector<Mat6> IA;
  /// crba: composite inertias of the subtrees, eq. (50) (body frame when crba_local, else world).
  std::vector<Inertia> Ic;

  // ---- per coordinate
  /// sin and cos of every joint coordinate (nq; read for revolute joints only): every algorithm.
  std::vector<double> sin_q, cos_q;
  /// U = IA S of every joint dof (nv): aba (body frame), minv's recursion (world frame).
  std::vector<Vec6> U;
  /// 1 / (S^T IA S) (nv): aba, minv (the factor route's 1 / Diag_k, the same pivots). u = tau - S^T
  /// pA (nv): aba.
  std::vector<double> Dinv, u;
  /// The joint axes S_i in the world frame (nv): minv's recursion.
  std::vector<Vec6> S;

  // ---- outputs (nv; the free base's six coordinates first)
  VecX tau;   ///< rnea
  VecX ddq;   ///< aba
  VecX nle;   ///< bias: H
  MatX M;     ///< crba: the mass matrix (nv x nv, both triangles); empty before the first call
  MatX Minv;  ///< minv: D^-1 (nv x nv, both triangles); empty before the first call
  /// mass_matrix_ltdl: D = L^T Diag L, L's strict lower triangle and Diag on the diagonal (the
  /// upper triangle holds D's); sized with M
  MatX LD;

  // ---- algorithm workspaces (contents unspecified between calls)
  /// crba (world frame): the joint axes in the world, one row per twist component, so that a row
  /// of D is six axpys (6 x nv; sized with M).
  Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor> Jrow;
  /// minv (eqs. 58-63): world-frame bias wrenches of all columns (subtrees are disjoint column
  /// ranges, so one 6 x nv block holds them all) and the acceleration blocks of the forward pass;
  /// crba (local frames): the wrenches Ic S of a subtree's columns. Sized with M or Minv.
  using Mat6X = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor>;
  Mat6X Fm;
  std::vector<Mat6X> Pm;
  /// The block of Pm body i's forward pass writes (a body reuses its parent's when it is the
  /// parent's last child).
  std::vector<int> P_slot;
  /// First body of the run of consecutive-index ancestors ending at j (crba's row segments).
  std::vector<int> run_start;
  /// crba in local frames (a wrench transform per ancestor-descendant pair) rather than in the
  /// world frame (forward kinematics, world inertias, six multiply-adds per pair): chosen when
  /// the pairs are few, i.e. for shallow trees (set from the model; may be overridden).
  bool crba_local = true;
  /// minv factorizes crba's D (D = L^T Diag L along the tree, then D^-1 row by row) rather than
  /// running the recursion of eqs. (55)-(63): chosen for small, shallow trees, where the
  /// recursion's column loops are short (set from the model; may be overridden before the first
  /// minv call). The factor route fills M (and what crba fills) and leaves oMb, IA, U, S alone.
  bool minv_by_factor = false;
  /// The parent of every dof along the tree (-1: none); a free base's six dofs form a chain.
  std::vector<int> v_parent;

  /// Sizes M and crba's workspaces (done by crba's first call otherwise).
  void reserve_crba(const Model& model);
  /// Sizes Minv and minv's workspaces (done by minv's first call otherwise).
  void reserve_minv(const Model& model);
  bool crba_reserved() const { return crba_reserved_; }
  bool minv_reserved() const { return minv_reserved_; }

 private:
  bool crba_reserved_ = false;
  bool minv_reserved_ = false;
};

/// Positions of every body: Xup and oMb (the product of exponentials, section 5).
void forward_kinematics(const Model& model, Data& data, const SE3& base, const VecX& q);
/// Positions and twists: Xup, oMb and V (eq. 33).
void forward_kinematics(const Model& model, Data& data, const SE3& base, const VecX& q,
                        const VecX& v);
/// Body twists V (eq. 33) at generalized velocity v for the joint transforms already in
/// data.Xup (left by any algorithm's call at the configuration wanted).
void body_twists(const Model& model, Data& data, const VecX& v);

/// Recursive Newton-Euler, eqs. (33)-(37) (with V_j, not Vdot_j, inside ad* in (36)).
/// Returns tau (nv): for a free base the first six entries are the base wrench [N; F] (base
/// frame) needed for the motion, zero for a free motion. f_ext_base: wrench applied on the base.
const VecX& rnea(const Model& model, Data& data, const SE3& base, const VecX& q, const VecX& v,
                 const VecX& a, const Vec6* f_ext_base = nullptr);

/// Articulated-body algorithm, eqs. (38)-(43). Returns ddq (nv), with dV0/dt first for a free
/// base. f_ext_base: wrench applied on the base (base frame, about its origin). The result
/// depends on the base pose only through its rotation (gravity's direction in the base frame).
const VecX& aba(const Model& model, Data& data, const SE3& base, const VecX& q, const VecX& v,
                const VecX& tau, const Vec6* f_ext_base = nullptr);

/// Mass matrix D (eq. 50) by the composite-rigid-body algorithm; both triangles filled.
const MatX& crba(const Model& model, Data& data, const SE3& base, const VecX& q);

/// crba's D factorized along the tree, D = L^T Diag L (Featherstone's LTDL): L unit lower
/// triangular with L(k, i) != 0 only for i an ancestor dof of k (Data::v_parent), so the
/// factorization has no fill-in and costs sum over dofs of depth^2. Returns Data::LD; sets
/// Data::Dinv to 1 / Diag. O(n d^2) against O(n^2) for D^-1, and the solves below use it.
const MatX& mass_matrix_ltdl(const Model& model, Data& data, const SE3& base, const VecX& q);
/// x <- L^-T x (nv entries) with L from the last mass_matrix_ltdl on data.
void ltdl_solve_lt(const Data& data, double* x);
/// x <- L^-1 x (nv entries): D^-1 b = L^-1 Diag^-1 L^-T b.
void ltdl_solve_l(const Data& data, double* x);

/// D^-1, both triangles: by the recursive factorization of eqs. (55)-(63), O(n) per column, or
/// for small shallow trees by factorizing crba's D (Data::minv_by_factor says which).
const MatX& minv(const Model& model, Data& data, const SE3& base, const VecX& q);

/// H(q, v, g) with D vdot + H = tau (note: the paper's eq. (30) writes +H on the right).
const VecX& bias(const Model& model, Data& data, const SE3& base, const VecX& q, const VecX& v);

/// The base rows of D, [D_00 D_0q] (6 x nv, base frame): the map from v to the momentum of the
/// whole tree about the base frame, P_0 = D_0 v; D_00 is the tree's composite inertia (eq. 50 at
/// the root). O(n) by composite inertias in the base frame (src/dynamics/momentum.cpp). Zero
/// for a fixed base. Allocates only when D0 has another size.
using Mat6N = Eigen::Matrix<double, 6, Eigen::Dynamic>;
void base_momentum_map(const Model& model, Data& data, const VecX& q, Mat6N& D0);

/// Kinetic energy 1/2 v^T D v, computed recursively (needs no mass matrix).
double kinetic_energy(const Model& model, Data& data, const SE3& base, const VecX& q,
                      const VecX& v);
/// Potential energy -sum m_i g . c_i (world frame, zero at the world origin).
double potential_energy(const Model& model, Data& data, const SE3& base, const VecX& q);
/// Total spatial momentum [angular about the world origin; linear], world frame.
Vec6 spatial_momentum(const Model& model, Data& data, const SE3& base, const VecX& q,
                      const VecX& v);
/// Centre of mass of the whole system, world frame.
Vec3 center_of_mass(const Model& model, Data& data, const SE3& base, const VecX& q);

/// The simulated state (see the top of this file): q has nq entries, v has nv.
struct State {
  SE3 base;
  VecX q;
  VecX v;

  State() = default;
  /// Zero state of the right sizes, the base at its rest pose (Model::X_tree[0], the identity
  /// unless a URDF floating joint places it).
  explicit State(const Model& model);
  /// Every number finite and the base rotation orthonormal to 1e-6.
  bool finite() const;
};

/// An acceleration function that replaces the plain ABA inside a time step (integrate.h's
/// Stepper::acceleration; constraints.h: the multipliers of eq. (32) at every stage). tau is the
/// total generalized force (command plus passive forces).
class AccelerationHook {
 public:
  virtual ~AccelerationHook() = default;
  virtual const VecX& acceleration(const SE3& base, const VecX& q, const VecX& v,
                                   const VecX& tau) = 0;
};

}  // namespace se3
