// Constrained dynamics (Reuss 2002, eqs. 27-32), joint limits and ground contact.
//
// Bilateral constraints Psi(q) w = 0 (eq. 27) with w the generalized velocity of dynamics.h:
//   - point_world: a point of a link held at a world point,
//   - point_point: a point of one link held on a point of another (closes a loop),
//   - axis_parallel: an axis of a link kept parallel to a world axis,
//   - joint_coupling: a joint's coordinate held at multiplier times another's plus offset
//     (q_j = m q_l + o: a URDF <mimic> joint, Model::mimics), one row whose Jacobian is +1 on
//     the joint's rate and -m on the leader's (Psi_dot = 0).
// A point constraint has one row per constrained world direction (x, y, z by default; a planar
// loop names the two in-plane directions), an axis constraint two rows (the axis' components
// along two world directions normal to the target axis).
//
// Sign convention. The library writes the equations of motion as D wdot + H = tau (H = bias(),
// the paper's eq. (30) has +H on the right: H_paper = -H). With constraint forces:
//   D wdot + H = tau + Psi^T lambda,                                   (30)
//   Psi wdot + Psi_dot w = -2 alpha Psi w - beta^2 phi(q)              (28) + Baumgarte
// Eliminating wdot = a_free + D^-1 Psi^T lambda with a_free = D^-1 (tau - H) (one ABA call):
//   (Psi D^-1 Psi^T) lambda = -Psi a_free - Psi_dot w - 2 alpha Psi w - beta^2 phi   (32)
// which is the paper's (32), -Psi D^-1 (tau + H_paper) - Psi_dot w, plus the Baumgarte terms.
// lambda is the constraint force along the rows: for a point row along the world direction d,
// the force lambda d acts on link a at its point (and -lambda d on link b); for an axis row,
// a torque. D^-1 comes from minv() (eqs. 55-63, never forming D). Psi D^-1 Psi^T is factorized
// by LDLT; when a pivot falls below singular_tol times the largest (redundant or singular
// constraints), the minimum-norm least-squares multiplier is taken from an eigen-decomposition
// instead (the pseudo-inverse), and the step is counted in ConstraintReport::singular_solves.
//
// Drift: Baumgarte stabilization with alpha = 2 zeta omega, beta = omega (zeta = 1: critically
// damped error dynamics phi'' + 2 omega phi' + omega^2 phi = 0), and after each step a projection
// onto the constraint manifold in the metric of D (positions by Gauss-Newton steps
// dq = -D^-1 Psi^T (Psi D^-1 Psi^T)^+ phi, the base moved by f exp(dq_0), then velocities
// w -= D^-1 Psi^T (Psi D^-1 Psi^T)^+ Psi w, the smallest change of kinetic energy).
//
// Unilateral constraints (joint limits lambda >= 0, contact lambda_n >= 0 with Coulomb friction
// |lambda_t| <= mu lambda_n) are solved at the velocity level by time stepping (Moreau /
// Stewart-Trinkle): over a step h the free velocity w* = w + h a_free receives impulses p,
// w+ = w* + D^-1 J^T p. The rows (bilateral, limits, contact normal and friction) are built into
// one ConstraintRows (constraint.h) by its builders, over one point Jacobian; the impulses come
// from solver.h (projected Gauss-Seidel, or the active-set method: ConstraintOptions::solver).
// Beside the robot the step may carry free bodies (scene objects, each a single-body free model:
// v = [v_robot; v_obj1; ...], D^-1 block-diagonal: minv for the robot, the constant 6x6 inverse
// inertia in the body frame for each object) and contacts from outside (the collision layer's
// Contact list). The position update is the integrate layer's (contact_semi_implicit,
// integrate.h): velocity_step changes velocities only, finish_velocity_step reports and projects
// after the positions have moved. Forces are p / h. A scene with only bilateral constraints uses
// its integrator with the multipliers of (32) inside every stage.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "se3_sim/constraint/constraint.h"
#include "se3_sim/dynamics/dynamics.h"
#include "se3_sim/geometry/geometry.h"
#include "se3_sim/solver/solver.h"

namespace se3 {

enum class ConstraintType { PointWorld, PointPoint, AxisParallel, JointCoupling };

/// One bilateral constraint, by URDF link name (the model's links; "world" or "" is the world).
struct BilateralConstraint {
  ConstraintType type = ConstraintType::PointWorld;
  std::string name;                 ///< for reports and markers ("" = generated)
  std::string link_a;               ///< the constrained link
  Vec3 point_a = Vec3::Zero();      ///< point on link_a, link_a frame
  std::string link_b;               ///< point_point: the other link
  Vec3 point_b = Vec3::Zero();      ///< point_point: on link_b (its frame); point_world: world
  Vec3 axis_a = Vec3::UnitZ();      ///< axis_parallel: axis of link_a, link_a frame
  Vec3 axis_world = Vec3::UnitZ();  ///< axis_parallel: the world axis it stays parallel to
  /// Point constraints: the world directions held (rows). Empty = x, y and z.
  std::vector<Vec3> directions;
  /// point_world: take point_b from the initial state (the link point's world position there).
  bool world_point_from_initial = false;
  /// joint_coupling: q[joint] = multiplier q[leader] + offset (joints of the model that move;
  /// link_a is not used).
  std::string joint, leader;
  double multiplier = 1, offset = 0;
};

/// The joint_coupling constraints of the model's <mimic> joints (Model::mimics), named
/// "mimic:JOINT", in the model's order (leaders first).
std::vector<BilateralConstraint> mimic_constraints(const Model& model);

/// A sphere (radius >= 0; 0 = a point) on a link that may touch the ground plane.
struct ContactPoint {
  std::string name;  ///< for reports and markers ("" = the link name and an index)
  std::string link;
  Vec3 position = Vec3::Zero();  ///< centre in the link frame
  double radius = 0;
};

struct ConstraintOptions {
  // ---- bilateral, acceleration level (DAE, eq. 32)
  double baumgarte_omega = 20.0;  ///< 1/s; 0 disables Baumgarte
  double baumgarte_zeta = 1.0;
  bool project = true;            ///< position and velocity projection after every step
  double projection_tol = 1e-12;  ///< m or rad: Gauss-Newton stops below this
  int projection_iterations = 4;
  double singular_tol = 1e-10;  ///< relative pivot below which Psi D^-1 Psi^T counts as singular
  // ---- velocity level (limits, contact)
  int pgs_iterations = 200;
  double pgs_tol = 1e-10;  ///< stop when no impulse changes by more (N s)
  double erp = 0.2;        ///< fraction of a penetration (beyond slop) removed per step
  double slop = 1e-4;      ///< m or rad of penetration left alone (resting contact)
  double margin = 0.01;    ///< m or rad: rows of gaps below this (plus |rate| h) enter the solve
  double bilateral_erp = 0.2;         ///< velocity-level bilateral rows: b = -bilateral_erp phi / h
  double restitution = 0;             ///< of the ground and the contact spheres (the larger counts)
  double restitution_velocity = 0.2;  ///< m/s (rad/s): slower impacts do not bounce
  /// Of the joint limits: an impact faster than restitution_velocity leaves at e times its speed
  /// (the velocity-level rows, and the located impacts of another integrator).
  double limit_restitution = 0;
  double max_correction_velocity = 0.5;  ///< m/s: a contact's push-out speed at most (RowParams)
  ContactSolver solver = ContactSolver::PGS;  ///< pgs or active_set (solver.h)
};

/// What a scene asks for. Link names are resolved against the model by ConstraintSystem.
struct ConstraintSpec {
  std::vector<BilateralConstraint> bilateral;
  bool joint_limits = false;  ///< the URDF position limits as unilateral constraints
  bool ground = false;        ///< the plane normal . x = offset, solid below
  Vec3 ground_normal = Vec3::UnitZ();
  double ground_offset = 0;
  double mu = 0.8;  ///< Coulomb friction coefficient
  /// Contact spheres; with contacts_from_collisions also every collision sphere (centre,
  /// radius), box (8 corners), cylinder (8 points on each rim), capsule (its two end spheres)
  /// of `geometry`; meshes are skipped.
  std::vector<ContactPoint> contacts;
  bool contacts_from_collisions = false;
  std::shared_ptr<const GeometryModel> geometry;  ///< the model's, for contacts_from_collisions
  ConstraintOptions options;

  bool empty() const { return bilateral.empty() && !joint_limits && !ground; }
  /// Whether joint_limits was written in the scene (else the scene's default applies).
  bool joint_limits_given = false;
};

/// One constraint force for display and messages (world frame).
struct ConstraintForce {
  enum Kind { Bilateral = 0, Limit = 1, Contact = 2 };
  Kind kind = Bilateral;
  /// The constraint's name, "limit:<joint>", "contact:<name>" (scene contacts) or
  /// "contact:<link>:<k>" (unnamed and collision-geometry points).
  std::string name;
  int body = 0;                ///< body the force acts on (limits: the joint's body)
  Vec3 point = Vec3::Zero();   ///< application point (world)
  Vec3 force = Vec3::Zero();   ///< N, on `body` (a point_point pair's other body gets -force)
  Vec3 torque = Vec3::Zero();  ///< N m, world (axis_parallel)
  double joint_force = 0;      ///< limits: N m or N along the joint axis
  double gap = 0;              ///< limits and contact: distance to the limit or plane (< 0: in)
  bool active = false;         ///< carries a non-zero force this step
};

/// Diagnostics of the last step.
struct ConstraintReport {
  int bilateral_rows = 0;
  int rows = 0;  ///< rows of the last solve (bilateral + active unilateral)
  int active_contacts = 0;
  int active_limits = 0;
  int rank = 0;                       ///< numerical rank of the last bilateral solve
  std::uint64_t singular_solves = 0;  ///< solves that needed the pseudo-inverse (cumulative)
  std::uint64_t solves = 0;           ///< all multiplier solves (cumulative)
  int pgs_iterations = 0;             ///< last solver run (PGS sweeps or active-set updates)
  std::uint64_t velocity_steps = 0;   ///< steps taken at the velocity level (cumulative)
  double pgs_change = 0;              ///< last PGS sweep's largest impulse change
  double bilateral_error = 0;         ///< max |phi| of the bilateral rows after the step
  double penetration = 0;             ///< deepest contact penetration (m, >= 0)
  double limit_violation = 0;         ///< largest excursion beyond a joint limit (>= 0)
  int delassus_columns = 0;     ///< W's columns the last solve formed (rows: the full product)
  std::uint64_t fallbacks = 0;  ///< active-set solves that fell back to PGS (cumulative)
};

/// What a velocity step works on beside the robot: the free bodies' states and free
/// accelerations (as set_free_bodies), and contacts from outside (collision layer) with the
/// objects they index. Any pointer may be null.
struct ConstraintStepInput {
  std::vector<State>* bodies = nullptr;
  const std::vector<VecX>* body_a_free = nullptr;
  /// The other robots' states and free accelerations (set_free_bodies' robots), in their order.
  std::vector<State>* robots = nullptr;
  const std::vector<VecX>* robot_a_free = nullptr;
  const std::vector<Contact>* contacts = nullptr;
  const std::vector<CollisionObject>* objects = nullptr;
};

/// The constraints of one model with their workspace (sized once; a step allocates nothing
/// once the first step has run). Throws ModelError for unknown links or bad numbers.
class ConstraintSystem final : public AccelerationHook {
 public:
  ConstraintSystem(const Model& model, const ConstraintSpec& spec);

  const Model& model() const { return model_; }
  const ConstraintSpec& spec() const { return spec_; }
  int bilateral_rows() const { return nb_; }
  bool has_unilateral() const { return spec_.joint_limits || spec_.ground; }

  /// Fixes the world points of point_world constraints with world_point_from_initial.
  void anchor(const State& x);

  /// Psi (nb x nv) and phi (nb) of the bilateral rows at (base, q).
  void bilateral(const SE3& base, const VecX& q, MatX& Psi, VecX& phi);
  /// Psi_dot w (nb) at (base, q, v).
  void bilateral_bias(const SE3& base, const VecX& q, const VecX& v, VecX& gamma);

  /// The constrained acceleration of eq. (32) with Baumgarte terms, for total generalized
  /// force tau (the stepper's hook: every stage of every integrator). Fills lambda().
  const VecX& acceleration(const SE3& base, const VecX& q, const VecX& v, const VecX& tau) override;
  /// Multipliers of the last acceleration() or step() (bilateral rows first; N, N m).
  const VecX& lambda() const { return lambda_; }

  /// Projects x onto Psi = 0 and Psi w = 0 (D metric). Returns the final max |phi|.
  double project(State& x);

  // A time step under the constraints is integrate.h's constrained_step, in two ways:
  /// The end of a step with only bilateral constraints, after an integrator has taken it with
  /// this system as its acceleration hook: projection (or, without it, the error), the report,
  /// and the forces of the last stage's multipliers at the end-of-step configuration.
  void finish_bilateral_step(State& x);
  /// Free bodies stepped with the robot at the velocity level (scene objects): each a single
  /// free body (Model n = 0, floating; not owned, must outlive the system). Frame numbering of
  /// contacts from outside: frames 0..n the robot's bodies, n + 1 + j free body j.
  /// max_external_contacts: room for contacts from outside (StepInput::contacts; the deepest
  /// first when there are more).
  /// robots: other robots beside this system's (articulated models, not owned), touching the
  /// rest only through contacts from outside: their columns follow the free bodies' and their
  /// frames too (frame n + 1 + B + o_k + i for body i of robot k, o_k the bodies of the robots
  /// before it); D^-1 stays block-diagonal, each robot's block its own minv. robot_limits[k]:
  /// robot k's joint limits are rows of the velocity step too (as this system's own are), so a
  /// robot that a contact pushes stops at its limits (missing entries: no limits).
  void set_free_bodies(const std::vector<const Model*>& bodies, int max_external_contacts = 0,
                       const std::vector<const Model*>& robots = {},
                       const std::vector<bool>& robot_limits = {});
  /// Whether a row of the last velocity step (or reach test) touched robot k of
  /// set_free_bodies' robots (false when none did, or after a step without a velocity solve).
  bool robot_touched(int k) const { return art_[k].touched; }
  using StepInput = ConstraintStepInput;
  /// Whether a velocity step of h from x would have any unilateral row (a limit or contact
  /// within reach), from the free acceleration a_free and the given extra input.
  bool unilateral_within_reach(const State& x, const VecX& a_free, double h,
                               const StepInput& in = {});
  /// With limits or contact: the velocities of one velocity-level time step of h (see the
  /// header comment) from the free acceleration a_free (ABA with the passive forces, no hook):
  /// x.v (and the free bodies' v) become w+. Positions are the integrator's (integrate.h's
  /// contact step); then finish_velocity_step. Returns false for a non-finite solve.
  bool velocity_step(State& x, const VecX& a_free, double h, const StepInput& in = {});
  /// After the positions have moved with w+: the projection of the bilateral rows, and the
  /// report's errors (penetration of the internal contact spheres, limit excursion).
  void finish_velocity_step(State& x);

  /// Largest constraint error at x: bilateral |phi| (m or rad), penetration (m) and limit
  /// excursion (rad or m), whichever is largest.
  double error(const State& x);

  /// The robot's body poses (world) at (base, q): the forward kinematics the next velocity
  /// step's rows reuse when it starts at the same configuration.
  const std::vector<SE3>& body_poses(const SE3& base, const VecX& q) {
    kinematics(base, q, nullptr);
    return data_.oMb;
  }
  /// Forces of the last step, one per constraint / limit / contact point (world frame).
  const std::vector<ConstraintForce>& forces() const { return forces_; }
  /// A contact from outside (the collision layer) of the last velocity step, with the impulse
  /// it carried: on object b, and its opposite on a (collision object indices; normal from a to
  /// b, world, at the start-of-step configuration).
  struct WarmExternal {
    int a = -1, b = -1;
    Vec3 point = Vec3::Zero(), impulse = Vec3::Zero();
    Vec3 normal = Vec3::UnitZ();
    double depth = 0;
  };
  /// The last velocity step's outside contacts: the first external_count() of external().
  const std::vector<WarmExternal>& external() const { return warm_ext_; }
  int external_count() const { return warm_ext_count_; }
  const ConstraintReport& report() const { return report_; }

 private:
  struct PointRef {
    int body = 0;           ///< -1 = world
    Vec3 r = Vec3::Zero();  ///< body frame (world frame for the world)
  };
  struct Bil {
    ConstraintType type = ConstraintType::PointWorld;
    std::string name;
    PointRef a, b;
    Vec3 axis_a = Vec3::UnitZ(), axis_w = Vec3::UnitZ();
    std::vector<Vec3> dirs;  ///< row directions (point), or the two normals of axis_w (axis)
    int row0 = 0;
    /// joint_coupling: a.body the joint, b.body its leader, q_a = mult q_b + off (one row)
    double mult = 1, off = 0;
  };
  /// Another robot (set_free_bodies' robots): its kinematics and D^-1 block from its own Data.
  struct ArtSystem {
    explicit ArtSystem(const Model& m) : model(&m), data(m) {}
    const Model* model;
    Data data;
    SystemKinematics kin;
    int col0 = 0;
    bool touched = false;
    bool limits = false;                         ///< its joint limits are rows
    std::vector<double> warm_lower, warm_upper;  ///< last step's limit impulses, by joint
  };
  struct FreeBody {
    const Model* model = nullptr;
    Mat6 Minv = Mat6::Zero();  ///< inverse spatial inertia (body frame, constant)
    std::vector<SE3> pose;     ///< its one body pose, for the Jacobian
    SystemKinematics kin;
  };

  void bind();
  /// Forward kinematics, world axes and (with v) the body twists and bias accelerations.
  void kinematics(const SE3& base, const VecX& q, const VecX* v);
  /// Whether data_'s forward kinematics (oMb, kin_'s world axes) is at (base, q).
  bool kinematics_at(const SE3& base, const VecX& q) const;
  /// Before an algorithm runs on data_ at (base, q): a pass at another configuration leaves
  /// data_'s kinematics stale for kinematics()'s reuse.
  void data_to(const SE3& base, const VecX& q);
  /// phi_, Psi_ and (with_bias, after kinematics with v) gamma_ = Psi_dot w.
  void fill_bilateral(bool with_bias);
  Vec3 point_world(const PointRef& p) const;
  /// A joint_coupling's error q_a - mult q_b - off at q (an angle's wrapped into (-pi, pi]).
  double coupling_error(const Bil& b, const VecX& q) const;
  /// Psi_dot w of a body point (world frame), from Vb_ and Ab_.
  Vec3 point_accel_bias(const PointRef& p) const;
  /// Solves Wb_ out = rhs (solver.h's solve_equality) and counts it in the report.
  void solve_multipliers(const VecX& rhs, VecX& out);
  void assemble_bilateral_forces(const VecX& lam, double scale);
  /// The rows of a velocity step at the kinematics of x (vfree_ and the bodies' set).
  void build_rows(const State& x, double h, const StepInput& in);
  /// The internal contacts (contact spheres against the ground) at the current kinematics.
  void ground_contacts();
  /// Row r (an outside contact's normal) and its friction rows from last step's contacts.
  void warm_start_external(int r, const Contact& ct);
  /// row_mask_ of the first `rows` rows (bit s: the row touches system s); true when a row
  /// touches the robot.
  bool row_masks(int rows);
  /// The free bodies' rows of Y_ = D^-1 J^T (by row_mask_).
  void free_body_inverse_mass_jacobian(int rows);
  /// Y_ = D^-1 J^T and W_ = J D^-1 J^T of the first `rows` rows (the full product).
  void delassus(const State& x, int rows);
  /// lazy_w_ for this step: the columns of Y_ and W_ left to the solver.
  void lazy_delassus(const State& x, int rows);

  const Model& model_;
  ConstraintSpec spec_;
  ConstraintOptions opt_;
  RowParams params_;
  SolverOptions solver_opt_;
  std::vector<Bil> bil_;
  std::vector<PointRef> contacts_;  ///< sphere centres
  std::vector<double> contact_radius_;
  std::vector<std::string> contact_names_;
  std::vector<int> limit_force_index_;  ///< joints with a limit, in forces_ order
  int nb_ = 0;
  int max_rows_ = 0;
  int nv_total_ = 0;
  double alpha_ = 0, beta2_ = 0;

  Data data_;
  // The configuration data_'s forward kinematics is at, while fk_current_: kinematics() at the
  // same one (the collision layer's poses, then the step's rows) makes no second pass.
  bool fk_current_ = false;
  SE3 fk_base_;
  VecX fk_q_;
  SystemKinematics kin_;  ///< the robot's, over data_.oMb
  std::vector<Vec6> Vb_;  ///< body twists (body frame)
  std::vector<Vec6> Ab_;  ///< velocity-product accelerations (body frame, wdot = 0)
  std::vector<FreeBody> free_;
  std::vector<ArtSystem> art_;  ///< the other robots
  /// The robot of a joint-limit row at or after art_limit_rows_ (the one whose columns it has).
  ArtSystem& art_system_of_limit_row(int r);
  std::vector<State>* art_states_ = nullptr;  ///< their states in this velocity step
  int art_limit_rows_ = 0;  ///< the first of their joint-limit rows (after every contact row)
  std::vector<const SystemKinematics*> systems_;  ///< robot, then the free bodies, then art_
  std::vector<FrameRef> frames_;                  ///< collision frame -> (system, body)

  // internal contacts: sphere k against the ground, as collision-layer contacts
  std::vector<Contact> ground_contacts_;
  std::vector<CollisionObject> ground_objects_;  ///< spheres 0..nc-1, then the ground
  std::vector<int> ground_contact_sphere_;       ///< per ground contact: its sphere
  std::vector<Contact> one_contact_;             ///< one contact at a time for its rows

  // bilateral (nb rows)
  ConstraintRows::RowMat Psi_;
  MatX Yb_, Wb_;
  VecX phi_, gamma_, rhs_, lambda_, mult_, a_, dq_, vfree_;
  SolverWorkspace ws_;
  // velocity level (up to max_rows_)
  ConstraintRows rows_;
  int internal_rows_end_ = 0;  ///< rows before it: bilateral, limits, internal contacts
  MatX Y_, W_;
  VecX c_, p_;
  std::vector<std::uint64_t> row_mask_;  ///< per row: bit s set when it touches system s
  DelassusWorkspace delassus_ws_;        ///< robot_delassus's
  DelassusColumns lazy_w_;               ///< W_'s columns on demand (the active set's)
  bool factored_delassus_ = false;       ///< lazy_w_'s robot block by its factor (nv <= 64)
  std::vector<Vec3> warm_contact_;       ///< last impulses (n, t1, t2) per contact sphere
  /// Contacts from outside (the collision layer) have no identity across steps: the last
  /// step's are kept with their world impulse, and a new contact of the same object pair takes
  /// the impulse of the nearest one within 1 cm. Sized, not reserved (a copy keeps the size,
  /// not the capacity): the first warm_ext_count_ are in use; never allocates in a step.
  std::vector<WarmExternal> warm_ext_, warm_ext_next_;
  int warm_ext_count_ = 0;
  std::vector<double> warm_lower_, warm_upper_, contact_gap_;
  VecX warm_bil_;
  std::vector<ConstraintForce> forces_;
  ConstraintReport report_;
};

/// "point_world", "point_point", "axis_parallel" or "joint_coupling".
std::string constraint_type_name(ConstraintType t);

}  // namespace se3
