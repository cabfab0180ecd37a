// Rigid-body dynamics of the free-floating (or fixed-base) tree, section 6 of Reuss 2002.
//
// State: base pose f0 (body 0 in the world; fixed-base models use it as the mount pose),
// joint positions q (size n) and generalized velocity v (size nv): for a free base
// v = [V0; qdot] with V0 = [w; v] the base twist in its own frame (eq. 12), else v = qdot.
// Accelerations are time derivatives of these components (dV0/dt in the base frame).
//
// Every function works on a preallocated Data and allocates nothing.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "se3_sim/model.h"

namespace se3 {

using VecX = Eigen::VectorXd;
using MatX = Eigen::MatrixXd;
using Mat36 = Eigen::Matrix<double, 3, 6>;

/// The workspace: one per thread, sized once for a model.
struct Data {
  explicit Data(const Model& model);

  std::vector<SE3> Xup;              ///< body i in its parent's frame: X_tree[i] * exp(S_i q_i)
  std::vector<double> sin_q, cos_q;  ///< sin and cos of every joint position (revolute joints)
  std::vector<SE3> oMb;              ///< body i in the world
  std::vector<Vec6> V;               ///< body twists (body frame), eq. (33)
  std::vector<Vec6> A;  ///< body accelerations (body frame, gravity folded in), eq. (35)
  std::vector<Vec6> c;  ///< velocity-product accelerations gamma, eq. (34)
  std::vector<Vec6> F;  ///< body wrenches / bias forces, eq. (36)
  /// rnea: twist and acceleration of body i interleaved component by component,
  /// (V_0, A_0, V_1, A_1, ..., V_5, A_5) in VA[2i], VA[2i+1], so both travel through one transform.
  std::vector<Vec6> VA;
  std::vector<Mat6> IA;  ///< articulated-body inertias, eq. (38)
  std::vector<Vec6> U;   ///< IA S
  std::vector<double> Dinv, u;
  std::vector<Inertia> Ic;  ///< composite inertias (CRBA)

  VecX tau;             ///< rnea output (nv)
  VecX ddq;             ///< aba output (nv)
  VecX nle;             ///< bias H (nv)
  MatX M;               ///< crba output (nv x nv, both triangles)
  MatX Minv;            ///< minv output (nv x nv, both triangles)
  std::vector<Vec6> S;  ///< joint axes in the world frame (crba, minv)
  /// crba: world-frame joint axes, one row per twist component, so a row of D is six axpys.
  Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor> Jrow;
  /// minv (eqs. 58-63): world-frame bias wrenches of all columns (subtrees are disjoint column
  /// ranges, so one 6 x nv block holds them all) and the acceleration blocks of the forward pass.
  using Mat6X = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor>;
  Mat6X Fm;
  std::vector<Mat6X> Pm;
  std::vector<int> P_slot;
  /// First body of the run of consecutive-index ancestors ending at j (crba's row segments).
  std::vector<int> run_start;
  /// crba in local frames (a wrench transform per ancestor-descendant pair) rather than in the
  /// world frame (forward kinematics, world inertias, six multiply-adds per pair): chosen when
  /// the pairs are few, i.e. for shallow trees (set from the model; may be overridden).
  bool crba_local = true;
};

/// Positions of every body: Xup and oMb (the product of exponentials, section 5).
void forward_kinematics(const Model& model, Data& data, const SE3& base, const VecX& q);

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

/// D^-1 by the recursive factorization of eqs. (55)-(63), O(n) per column; both triangles.
const MatX& minv(const Model& model, Data& data, const SE3& base, const VecX& q);

/// H(q, v, g) with D vdot + H = tau (note: the paper's eq. (30) writes +H on the right).
const VecX& bias(const Model& model, Data& data, const SE3& base, const VecX& q, const VecX& v);

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

/// The simulated state (see the top of this file): q has n entries, v has nv.
struct State {
  SE3 base;
  VecX q;
  VecX v;

  State() = default;
  /// Zero state of the right sizes (base at the identity).
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
