// Time steppers on the Lie-group state of a free-floating (or fixed-base) tree.
//
// The state is the base pose f0 in SE(3), the joint positions q and the generalized velocity
// v = [V0; qdot] (V0 the base twist in the base frame; no V0 for a fixed base), as in
// dynamics.h. The base pose is integrated on SE(3) itself, f <- f exp(h xi), never through
// coordinates, so no orientation is singular.
//
// Runge-Kutta-Munthe-Kaas (RKMK): near f_n the base is written f(t) = f_n exp(xi(t)) with
// xi(0) = 0; since f^-1 fdot = hat(dexp(-xi) xidot) (lie.h), the local coordinate obeys
// xidot = dexp_inv(-xi) V0, an ODE on the vector space se(3) that any explicit Runge-Kutta
// tableau integrates together with q and v. The step ends with f_{n+1} = f_n exp(xi_{n+1}).
//
// Forces during a step: gravity (Model::gravity), the commanded generalized force tau_cmd
// (size nv: for a free base a wrench [N; F] on the base, in its frame, first; then the joint
// efforts, already clamped by the caller) and the passive joint forces of the model, evaluated
// at every stage: damping -d qdot and regularized Coulomb friction -f tanh(qdot / eps).
//
// A stepper owns its workspace (one dynamics Data and the stage vectors), sized once for its
// model: step() allocates nothing. The model must outlive the stepper.
#pragma once

#include <Eigen/Cholesky>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "se3_sim/dynamics/dynamics.h"

namespace se3 {

struct StepperOptions {
  /// Error tolerance of adaptive steppers (absolute and relative, per component).
  double tol = 1e-6;
  /// Smallest internal step of adaptive steppers; below it the step fails.
  double h_min = 1e-10;
  /// Most internal steps (accepted + rejected) an adaptive stepper takes to cover one step().
  int max_substeps = 100000;
  /// Regularization speed of Coulomb friction: f tanh(qdot / eps) (rad/s or m/s).
  double friction_eps = 1e-2;
  /// Apply the model's joint damping and friction.
  bool passive_forces = true;
};

/// The model's passive joint forces, the one law every stepper and the simulator apply: on each
/// joint dof k, damping -d_k qdot_k and regularized Coulomb friction -f_k tanh(qdot_k / eps);
/// nothing on the base.
class PassiveForces {
 public:
  /// Gathers the damped and rubbing joints of the model once (nothing when !enabled).
  PassiveForces(const Model& model, double friction_eps, bool enabled = true);
  /// Whether any joint has damping or friction.
  bool any() const { return any_; }
  /// Whether any joint has Coulomb friction.
  bool has_friction() const { return !rubbing_.empty(); }
  /// out = base - d w - f tanh(w / eps) over the nv entries (base == nullptr: zero); out may be
  /// base itself.
  void apply(const double* base, const double* w, double* out) const;
  /// base - d_k w - f_k tanh(w / eps), the same for one coordinate k of v.
  double at(int k, double base, double w) const;
  /// out = -f tanh(w / eps) (friction alone, nv entries).
  void friction(const double* w, double* out) const;
  /// d per coordinate of v (nv; zero on the base and the undamped joints).
  const VecX& damping() const { return damping_; }
  /// The coordinates k of v with Coulomb friction f.
  struct Rubbing {
    int k;
    double f;
  };
  const std::vector<Rubbing>& rubbing() const { return rubbing_; }
  double inv_eps() const { return inv_eps_; }

 private:
  int nv_;
  bool any_ = false;
  VecX damping_;
  VecX friction_;  // f per coordinate of v
  double inv_eps_;
  std::vector<Rubbing> rubbing_;
};

struct StepInfo {
  bool ok = true;
  int evaluations = 0;  ///< dynamics (ABA) calls
  int substeps = 0;     ///< accepted internal steps (1 for fixed-step methods)
  int rejected = 0;     ///< rejected internal steps (adaptive only)
  /// Whether the step (or part of it) was taken by the velocity-level contact scheme
  /// (contact_semi_implicit) rather than by the stepper's own method: constrained_step sets it
  /// when a limit or contact was within reach. Reports count steps by the scheme that took them.
  bool velocity_level = false;
  /// Impacts located inside the step and applied as impulses (joint limits struck under an
  /// integrator other than the contact scheme: constrained_step).
  int events = 0;
  std::string reason;  ///< why the step failed (ok == false); the state is then unchanged
};

/// The free base of the velocity-level step (contact_semi_implicit, semi_implicit_euler and the
/// contact scheme's steps of any stepper), written so that the world momentum of a free-floating
/// tree changes by the external impulses only (gravity, the applied base wrench, ground and
/// objects), to rounding, whatever its joint torques, limits and self-contacts do; a single free
/// body's flight is the world-frame semi-implicit Euler step (exact in zero gravity). With D_0 =
/// [D_00 D_0q] the base rows of D (base_momentum_map) and V0 = [w; u] (docs/design.md, "The
/// velocity-level step"):
///   (V1) a_0 = [0; R^T g] + D_00^-1 (F_0 - D_0q a_q)   the free velocity's base part,
///   (V2) f+ = f E, E = (exp(h w), h u)                 the pose with the new rates,
///   (V3) D_0(q+) v+ = Ad*_E^T D_0(q) v                 the base twist re-expressed.
/// For a fixed base it is the plain semi-implicit Euler step. Sized once; allocates nothing.
class FreeBaseStep {
 public:
  explicit FreeBaseStep(const Model& model);
  /// a (ABA's, nv) with its base part replaced by (V1); tau is the generalized force whose first
  /// six entries are the applied base wrench F_0. When a holds constraint forces (an
  /// acceleration hook), a_unconstrained is ABA's acceleration without them: their base wrench
  /// then counts as external. Returns a copy held here.
  const VecX& free_acceleration(Data& data, const State& x, const VecX& tau, const VecX& a,
                                const VecX* a_unconstrained = nullptr);
  /// With x.v the step's final rates at the step's first configuration: the positions (V2,
  /// q <- q + h qdot) and the base twist re-expressed (V3). data is a workspace.
  void advance(Data& data, State& x, double h);

 private:
  bool map_at(const VecX& q) const;
  /// D0_ and its base block's Cholesky factor at q (kept while q does not change).
  void map(Data& data, const VecX& q);
  const Model& model_;
  Mat6N D0_;
  Eigen::LLT<Mat6> llt_;
  VecX q_at_;
  bool valid_ = false;
  VecX a_;
  VecX d_;
};

/// (V2): f <- f E with E = (exp(h w), h u) for the twist V = [w; u] (the rotation in the body
/// frame, the translation along the body-frame velocity taken in the step's first frame);
/// returns E. The velocity-level step's pose update of a robot's base and of a scene object.
SE3 advance_free_pose(SE3& f, const Vec6& V, double h);
/// A momentum (wrench-like, [angular; linear]) about the frame of the step's start expressed about
/// the new frame f E: Ad*_E^T P.
Vec6 reexpress_momentum(const SE3& E, const Vec6& P);

/// Joint limits under an integrator other than the contact scheme (constrained_step, scenes
/// whose only unilateral constraints are the robot's joint limits): the integrator's own steps
/// between impacts; an impact is located inside the step (regula falsi on the step length, until
/// the deepest limit's gap is within [-gap_tol, 0]) and applied there as an impulse through the
/// full D^-1, J v+ = -e J v- on the limits struck (e = restitution above restitution_velocity,
/// else 0; impulses >= 0), then the step goes on from that instant. A joint resting on its limit
/// (within rest_gap, not separating, and its free acceleration not leaving it) takes the contact
/// scheme's step instead; one that the free acceleration leaves (after a plastic impact) keeps
/// the integrator.
struct LimitEventOptions {
  double gap_tol = 1e-12;             ///< rad or m: an impact is located to this gap
  double time_tol = 1e-14;            ///< s: or to this bracket of the step length
  int max_iterations = 60;            ///< regula falsi iterations per impact
  int max_events = 8;                 ///< impacts per step; beyond, the contact scheme's step
  double rest_gap = 1e-6;             ///< rad or m: a limit this close counts as touching
  double rest_speed = 1e-6;           ///< rad/s or m/s: a touching limit slower than this rests
  double restitution = 0;             ///< of the limits
  double restitution_velocity = 0.2;  ///< slower impacts do not bounce
};

/// The workspace of the limit events (sized once for a model: a step allocates nothing).
struct LimitEventWorkspace {
  explicit LimitEventWorkspace(const Model& model);
  State x0, x1;           ///< the sub-step's start and trial states
  std::vector<int> rows;  ///< struck limits: +(i) lower, -(i) upper
  MatX W;                 ///< J D^-1 J^T of the struck limits
  VecX rhs, lambda;
};

class Stepper {
 public:
  Stepper(const Model& model, const StepperOptions& opt);
  virtual ~Stepper() = default;
  Stepper(const Stepper&) = delete;
  Stepper& operator=(const Stepper&) = delete;

  /// Registry name, e.g. "rkmk4".
  virtual std::string name() const = 0;
  /// Order of accuracy (global error O(h^order)).
  virtual int order() const = 0;
  virtual bool adaptive() const { return false; }
  /// Whether this is the semi-implicit Euler scheme (contact_semi_implicit, semi_implicit_euler)
  /// whose velocity update and position update the contact step takes apart.
  virtual bool contact_scheme() const { return false; }
  /// Advances x by exactly h under tau_cmd (size nv). An adaptive stepper covers h with as many
  /// internal steps as its tolerance needs and remembers the internal step size across calls.
  /// On failure (ok == false) x is left as it was.
  virtual StepInfo step(State& x, const VecX& tau_cmd, double h) = 0;
  /// Forgets what is carried between calls (adaptive step size, cached last evaluation).
  virtual void restart() {}

  /// The generalized acceleration at x under tau_cmd plus the passive forces (one ABA call).
  const VecX& acceleration(const SE3& base, const VecX& q, const VecX& v, const VecX& tau_cmd);
  /// The passive joint forces at joint rates v (size nv, zero on the base part), into out.
  void passive_forces(const VecX& v, VecX& out) const;
  /// The passive-force law of this stepper's model and options.
  const PassiveForces& passive() const { return passive_; }

  const Model& model() const { return model_; }
  const StepperOptions& options() const { return opt_; }
  Data& data() { return data_; }
  /// Constraint hook (not owned; nullptr = unconstrained ABA, the default). Set around a step
  /// by constrained_step (below).
  void set_acceleration_hook(AccelerationHook* hook) { hook_ = hook; }
  AccelerationHook* acceleration_hook() const { return hook_; }
  /// The free base's velocity-level step (FreeBaseStep) for this model, with its workspace.
  FreeBaseStep& free_base() { return free_base_; }
  /// The workspace of located joint-limit impacts (constrained_step), made on first use.
  LimitEventWorkspace& limit_events();

 protected:
  /// The semi-implicit Euler step of the velocity-level scheme: v += h a with the free base's
  /// part by FreeBaseStep (V1), then the positions and the base twist (V2, V3).
  StepInfo velocity_level_step(State& x, const VecX& tau_cmd, double h);

  const Model& model_;
  StepperOptions opt_;
  Data data_;
  VecX tau_;  ///< total generalized force of the current evaluation
  AccelerationHook* hook_ = nullptr;
  PassiveForces passive_;  ///< nothing when opt_.passive_forces is off
  FreeBaseStep free_base_;
  std::unique_ptr<LimitEventWorkspace> limit_events_;
};

/// The stepper registry: the one list of integrators (the CLI, its help text, scenes and the
/// simulator node take their names from it). Built in: euler, semi_implicit_euler (alias
/// symplectic_euler, its former name), rkmk4, rkmk45 (Dormand-Prince 5(4), adaptive),
/// variational, rk4_euler_angles, rk4_quaternion.
///
/// Creates a stepper by name (or alias) for model. Throws std::invalid_argument naming the known
/// ones.
using StepperFactory = std::function<std::unique_ptr<Stepper>(const Model&, const StepperOptions&)>;
std::unique_ptr<Stepper> make_stepper(const std::string& name, const Model& model,
                                      const StepperOptions& opt = {});
/// Adds (or replaces) a stepper in the registry.
void register_stepper(const std::string& name, const std::string& description,
                      StepperFactory factory);
/// Makes alias another name of the registered stepper `name` (whose Stepper::name() stays its
/// own). Throws std::invalid_argument when name is not registered.
void register_stepper_alias(const std::string& alias, const std::string& name);
/// Every name make_stepper accepts, aliases included, sorted.
std::vector<std::string> stepper_names();
/// The registered stepper a name stands for: the name itself, the stepper behind an alias, or ""
/// when unknown.
std::string stepper_canonical_name(const std::string& name);
/// One-line description of a registered name ("" when unknown; an alias says whose it is).
std::string stepper_description(const std::string& name);
/// The registry as help text: one line per stepper, "  NAME  DESCRIPTION", its aliases on it.
std::string stepper_help();

/// An explicit Runge-Kutta tableau (row i of a holds a_ij for j < i). With b_err non-empty the
/// method is an embedded pair: b_err = b - b_hat estimates the local error of the lower order.
struct ButcherTableau {
  std::string name;
  int order = 1;
  std::vector<std::vector<double>> a;
  std::vector<double> b;
  std::vector<double> b_err;
  /// First-same-as-last: the last stage is evaluated at the step's end point.
  bool fsal = false;
  /// A fixed-step tableau whose stage i reads only stage i - 1 (classical RK4) runs in one pass
  /// that feeds each slope into the weighted sum and the next stage point (fewer instructions
  /// per step: docs/performance.md); false runs it through the general path, as every other
  /// tableau. The two give the same step to rounding (gtest_integrate).
  bool fast_path = true;
};
ButcherTableau tableau_rk4();
ButcherTableau tableau_dormand_prince45();

/// The RKMK stepper for any explicit tableau (fixed step, or adaptive with b_err).
std::unique_ptr<Stepper> make_rkmk_stepper(const ButcherTableau& tableau, const Model& model,
                                           const StepperOptions& opt);

class ConstraintSystem;  // constraints.h (constraint layer)
struct Contact;          // collision.h
struct CollisionObject;  // collision.h

/// The registered name of the contact scheme (semi-implicit Euler with velocity-level impulses).
inline constexpr const char* kContactStepper = "contact_semi_implicit";
/// Whether a stepper name is the contact scheme, or semi_implicit_euler (the same scheme
/// without constraints, kept as a contact scene's integrator for older scenes).
bool is_contact_scheme(const std::string& name);

/// A free body of a contact step (a scene object: Model n = 0, floating, its frame at its centre
/// of mass): FreeBaseStep's (V1) for a tree of one body without applied wrench, a = [0; R^T g]
/// (its free velocity taken in the frame of the step's start, where without torque the
/// momentum does not change).
void free_body_acceleration(const Model& body, const State& x, VecX& a);
/// After the impulses: FreeBaseStep's (V2) and (V3) for one body, the pose by
/// advance_free_pose and the twist re-expressed in the new frame, V <- J^-1 Ad*_E^T J V, so that
/// in flight the world momentum stays exactly what it was.
void advance_free_body(const Model& body, State& x, double h);

/// The contact scheme's free acceleration at x (ABA with the passive forces and without the
/// hook, the free base's part by FreeBaseStep): what a velocity-level step of another robot
/// starts from (ContactBodies::robot_a_free). Valid until the stepper's next call.
const VecX& contact_free_acceleration(Stepper& stepper, const State& x, const VecX& tau_cmd);
/// After a velocity-level step set x.v: the positions and the base twist (FreeBaseStep::advance
/// on the stepper's workspace of the last contact_free_acceleration at x).
void advance_velocity_level(Stepper& stepper, State& x, double h);

/// The free bodies of a contact step beside the robot (scene objects) and contacts from
/// outside; any pointer may be null (no bodies, no outside contacts).
struct ContactBodies {
  const std::vector<const Model*>* models = nullptr;  ///< single free bodies (n = 0)
  std::vector<State>* states = nullptr;
  const std::vector<VecX>* a_free = nullptr;  ///< free_body_acceleration of each, this step
  const std::vector<Contact>* contacts = nullptr;
  const std::vector<CollisionObject>* objects = nullptr;
  /// Other robots in the contact (ConstraintSystem::set_free_bodies' robots): their states, whose
  /// v a velocity-level step sets (their positions are the caller's), and free accelerations.
  std::vector<State>* robot_states = nullptr;
  const std::vector<VecX>* robot_a_free = nullptr;
};

/// One step of h under the constraints (constraints.h). With only bilateral constraints (and no
/// bodies) the stepper integrates with the multipliers of eq. (32) in every stage (the system
/// is its acceleration hook for the step) and the system then projects the state and records
/// the forces. With joint limits, contact or free bodies the step is the contact scheme: the
/// free velocity from ABA (with the passive forces), the impulses (ConstraintSystem::
/// velocity_step), the positions with the new velocities and the base twist (FreeBaseStep),
/// then ConstraintSystem::finish_velocity_step. A stepper other than the contact scheme
/// (is_contact_scheme) keeps its own steps while no limit or contact is within reach: the
/// steps that have one are the contact scheme's (first order), documented in docs/contact.md.
/// On failure the result says why.
StepInfo constrained_step(ConstraintSystem& constraints, Stepper& stepper, State& x,
                          const VecX& tau_cmd, double h, const ContactBodies& bodies = {});

}  // namespace se3
