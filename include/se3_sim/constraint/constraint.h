// The constraint layer: the rows of one time step in one structure, as MuJoCo's efc_* arrays.
//
// A step's unknowns are the impulses p (one per row) that change the stacked generalized velocity
// of every system of the scene (the robot, then each free scene object: v = [v_robot; v_obj1;
// ...]): v+ = v* + D^-1 J^T p, with v* the free velocity after the step's forces and D^-1
// block-diagonal (one block per system). Every row r carries
//   - its type (RowType): an equality (bilateral: J_r v+ = b_r), a joint limit or a contact normal
//     (unilateral: J_r v+ >= b_r, p_r >= 0, complementary), or a contact friction row;
//   - its Jacobian row J_r (rows x nv_total, columns by system),
//   - its reference b_r: the velocity the row asks for, which carries the position correction
//     (a gap g > 0 may close within the step, b = -g / h; a penetration beyond `slop` is pushed
//     out at the rate erp (depth - slop) / h; a bilateral error phi is removed at -erp phi / h)
//     and restitution (a normal approaching at v_n < -restitution_velocity asks for -e v_n);
//     a contact's push-out is at most max_correction_velocity (no energy from deep penetration);
//   - the friction coefficient (normal rows) and the id of what produced it.
// Friction is the elliptic (isotropic, circular) Coulomb cone: two tangent rows per contact whose
// impulses (p_t1, p_t2) must stay in the disc of radius mu p_n. A contact's friction rows are
// found through its normal row's `friction` and `friction2` indices (and a friction row's normal
// through `normal`), never by position: the solvers (solver.h) read the types and indices only.
//
// The builders below fill rows over one point Jacobian (point_jacobian): the velocity of a body
// point along a world direction, from the world axes of the system's velocity coordinates.
#pragma once

#include <cstdint>
#include <vector>

#include "se3_sim/collision/collision.h"
#include "se3_sim/dynamics/dynamics.h"

namespace se3 {

enum class RowType : std::uint8_t {
  Equality = 0,         ///< bilateral: J v+ = b, p free
  JointLimit = 1,       ///< J v+ >= b, p >= 0, complementary
  ContactNormal = 2,    ///< J v+ >= b, p >= 0, complementary
  ContactFriction = 3,  ///< tangent: (p_t1, p_t2) in the disc mu p_n, opposing slip
};

/// Position-correction and restitution parameters of the references b.
struct RowParams {
  double erp = 0.2;            ///< fraction of a penetration (beyond slop) removed per step
  double slop = 1e-4;          ///< m or rad of penetration left alone (resting contact)
  double bilateral_erp = 0.2;  ///< bilateral rows: b = -bilateral_erp phi / h
  double margin = 0.01;        ///< m or rad: limits closer than this (plus |rate| h) get a row
  double restitution_velocity = 0.2;  ///< m/s: slower impacts do not bounce (resting contact)
  double limit_restitution = 0;       ///< of the joint limits: J v+ >= -e J v on an impact
  /// m/s: the largest separation velocity a contact's position correction asks for (a deep
  /// penetration is pushed out at this speed over several steps, not launched)
  double max_correction_velocity = 0.5;
};

/// One system's kinematics for Jacobian rows: body poses and the world axis of every velocity
/// coordinate (a free base's six first: Ad(f0) e_k), its first column in the stacked v.
struct SystemKinematics {
  const Model* model = nullptr;
  const std::vector<SE3>* oMb = nullptr;  ///< body poses (a Data's oMb after forward_kinematics)
  std::vector<Vec6> Sw;                   ///< nv world axes (update_world_axes)
  int col0 = 0;                           ///< first column of this system in J

  /// Sizes Sw for model (once).
  void reset(const Model& m, const std::vector<SE3>& poses, int first_column);
  /// The world axes from the poses (after forward kinematics).
  void update_world_axes();
};

/// The rows of one step (capacity fixed by reserve(); clear() and the builders allocate
/// nothing). J is row-major: a builder writes one contiguous row.
struct ConstraintRows {
  using RowMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  static constexpr int kNone = -1;

  int nv = 0;     ///< columns: the stacked velocity of every system
  int count = 0;  ///< rows in use
  RowMat J;       ///< capacity x nv
  VecX b;         ///< reference velocity of each row
  std::vector<RowType> type;
  std::vector<int> id;         ///< producer: bilateral constraint, joint, or contact index
  std::vector<int> friction;   ///< normal rows: its first friction row (kNone: none)
  std::vector<int> friction2;  ///< normal rows: its second friction row (kNone: none)
  std::vector<int> normal;     ///< friction rows: their normal row; others kNone
  std::vector<double> mu;      ///< normal rows: Coulomb coefficient; others 0
  std::vector<double> gap;     ///< limit and normal rows: distance (< 0: penetrating)
  /// Contact rows: bit a set for each of J's first 64 columns the builder wrote (a superset of
  /// the non-zero ones, closed under a tree's ancestors); 0 for other rows (not known).
  std::vector<std::uint64_t> touched;

  void reserve(int columns, int capacity);
  int capacity() const { return static_cast<int>(b.size()); }
  void clear() { count = 0; }
  /// Appends a zero row of the given type; returns its index (throws std::length_error when
  /// full: the capacity is the caller's bound).
  int add(RowType t, int producer);
  double* row(int r) { return J.row(r).data(); }
};

/// What robot_delassus keeps between calls (sized by reserve; a call allocates nothing).
struct DelassusWorkspace {
  std::vector<std::uint64_t> mask;  ///< per row: bit a set when J(r, a) != 0
  MatX Jc, Mc, Yc;  ///< one group's J(rows, S), D^-1(:, S), Y(S, :) over its columns S

  void reserve(int nv, int capacity);
};

/// The robot's block of the Delassus matrix of the first `rows` rows of J, whose first nv
/// columns are the robot's and Minv = D^-1 its inverse mass matrix (nv x nv, symmetric):
/// Y.topRows(nv) = D^-1 J^T and the lower triangle of W = J D^-1 J^T (the upper untouched).
/// A contact row moves only its link's ancestor joints and a free base: each row's non-zero
/// columns are found from J and the sums run over those alone (dense for nv > 64, few rows, or
/// when the groups of rows would cost more than they save), equal to the dense products up to
/// rounding. ws.reserve(nv, rows' capacity).
void robot_delassus(const ConstraintRows::RowMat& J, int rows, int nv, const MatX& Minv, MatX& Y,
                    MatX& W, DelassusWorkspace& ws);

/// The Delassus matrix W = J D^-1 J^T of a step's rows with its columns formed on demand: column
/// j, Y(:, j) = D^-1 J(j, :)^T and W(:, j) = J Y(:, j) over every row, the first time
/// delassus_column asks for it (W_jj with it: a row that needs its pivot gets its column too).
/// Row r touches the systems of mask[r] (bit s: J's columns first[s] .. first[s] + width[s] - 1,
/// D^-1's block dinv[s], column-major and symmetric: D^-1 is block-diagonal by system), so a
/// column sums over its own row's systems alone, and D^-1 J(j, :)^T over the row's non-zero
/// entries (a contact row moves its link's ancestor joints and a free base). The pointers are
/// the caller's (set before each step: a copied owner re-points them); reserve sizes the rest
/// once.
struct DelassusColumns {
  const ConstraintRows::RowMat* J = nullptr;  ///< the rows' Jacobian (row-major)
  MatX* Y = nullptr;                          ///< D^-1 J^T: column j valid once done[j]
  MatX* W = nullptr;                          ///< column j valid once done[j]
  const std::uint64_t* mask = nullptr;        ///< per row: the systems it touches
  /// Optional (ConstraintRows::touched): per row, its columns known to hold its non-zeros (0:
  /// not known, J's row is scanned).
  const std::uint64_t* touched = nullptr;
  std::vector<int> first, width;    ///< per system: its columns of J
  std::vector<const double*> dinv;  ///< per system: its block of D^-1
  std::vector<std::uint8_t> done;   ///< per row: its columns of Y and W formed
  int rows = 0;
  int formed = 0;  ///< columns formed since delassus_begin

  /// System 0 (the robot, J's first width[0] columns) by its mass matrix's factor D = L^T Diag L
  /// (mass_matrix_ltdl on *factor) instead of a dense block dinv[0]: D^-1 = L^-1 Diag^-1 L^-T,
  /// so with Z = J L^-T (formed for every row by delassus_begin, O(depth^2) a row)
  /// W(r, j) = sum_a Z(r, a) Z(j, a) / Diag_a over the dofs a both rows' Z rows touch, each dof's
  /// column of Z summed over the rows [lo_a, hi_a) that touch it. Y's robot rows are then not
  /// formed: delassus_impulse_velocity applies D^-1 J^T p through the factor. Needs width[0] <= 64.
  const Data* factor = nullptr;
  MatX Z;                            ///< capacity x width[0]: J L^-T (column-major, by dof)
  std::vector<std::uint64_t> zmask;  ///< per row: the dofs its row of Z touches
  std::vector<int> lo, hi;           ///< per dof: the rows of Z's column that may be non-zero
  VecX g;                            ///< width[0]: delassus_impulse_velocity's workspace
  std::vector<double*> ptr;          ///< width[0]: columns of Z one pass reads or writes
  std::vector<double> coef;          ///< width[0]: their coefficients

  void reserve(int capacity, int systems);
  /// Sizes the factored mode's workspaces for a robot of nv dofs.
  void reserve_factored(int capacity, int nv);
};

/// A new step of `rows` rows: no column formed.
void delassus_begin(DelassusColumns& d, int rows);
/// W(:, j) over the step's rows (formed the first time, with Y(:, j)).
const double* delassus_column(DelassusColumns& d, int j);
/// Every column not formed yet (then W's first rows x rows block is the whole, symmetric to
/// rounding).
void delassus_complete(DelassusColumns& d);
/// v += D^-1 J^T p over the rows with p_r != 0 (their columns formed first; v has J's columns).
void delassus_impulse_velocity(DelassusColumns& d, const VecX& p, VecX& v);

/// row[col0 + k] += s d . (v_k + w_k x p) over the coordinates k that move `body` (its path to the
/// root, a free base's six): the velocity of the world point p fixed on `body` along the world
/// direction d. The one point Jacobian every builder uses. body < 0 (the world) adds nothing.
void point_jacobian(const SystemKinematics& sys, int body, const Vec3& p, const Vec3& d, double s,
                    double* row);
/// point_jacobian along three directions into three rows at once (a contact's normal and
/// tangents: one walk up the tree), the same sums; sets the rows' `touched` bits.
void point_jacobian3(const SystemKinematics& sys, int body, const Vec3& p, const Vec3* const d[3],
                     double s, ConstraintRows& rows, const int r[3]);
/// row[col0 + k] += s c . w_k: the body's world angular velocity along c.
void angular_jacobian(const SystemKinematics& sys, int body, const Vec3& c, double s, double* row);

/// The reference velocity of a unilateral row of gap g (< 0: penetration) over a step of h.
double gap_reference(double g, double h, const RowParams& p);

/// Two unit vectors completing the unit n to a right-handed orthonormal basis (t1, t2, n).
void tangent_basis(const Vec3& n, Vec3& t1, Vec3& t2);

// ---- builders (each appends rows; `id` is stored on them)
/// A point of (sys_a, body_a) held on a point of (sys_b, body_b) (sys_b == nullptr or body_b < 0:
/// a world point) along the world directions dirs: one equality row each, b = -erp phi / h.
/// pa, pb are world points.
void add_point_rows(ConstraintRows& rows, const SystemKinematics& sa, int body_a, const Vec3& pa,
                    const SystemKinematics* sb, int body_b, const Vec3& pb,
                    const std::vector<Vec3>& dirs, double h, const RowParams& p, int id);
/// The world axis u of a body kept parallel to axis_world: two equality rows (u's components
/// along the two normals e1, e2 of axis_world).
void add_axis_rows(ConstraintRows& rows, const SystemKinematics& s, int body, const Vec3& u,
                   const Vec3& e1, const Vec3& e2, double h, const RowParams& p, int id);
/// The position limits of every limited joint of sys within reach (margin + |v*| h): a row per
/// side, id the joint index. q the system's joint positions, vfree the stacked free velocity
/// (the system's part from its col0).
void add_joint_limit_rows(ConstraintRows& rows, const SystemKinematics& s, const VecX& q,
                          const VecX& vfree, double h, const RowParams& p);

/// Where a collision frame lives: system index (into the kinematics list) and body; system < 0
/// for the world.
struct FrameRef {
  int system = -1;
  int body = 0;
};
/// One normal row and two friction rows per contact (Contact normal from object a to b; the
/// row's velocity is that of b's point relative to a's along the normal, >= 0 separates), id the
/// contact index. frames[k] is collision frame k's system and body; objects the collision
/// objects (for their frames, mu: the larger of the two; restitution: the larger). vfree is the
/// stacked free velocity (for the restitution target). Contacts between two world-fixed frames
/// are skipped.
void add_contact_rows(ConstraintRows& rows, const std::vector<Contact>& contacts,
                      const std::vector<CollisionObject>& objects,
                      const std::vector<FrameRef>& frames,
                      const std::vector<const SystemKinematics*>& systems, const VecX& vfree,
                      double h, const RowParams& p);

}  // namespace se3
