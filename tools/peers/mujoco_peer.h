// MuJoCo 2.2 as a peer: the same robot loaded through MuJoCo's own URDF import, with the state,
// forces, accelerations and mass matrices converted between its coordinates and ours.
//
// The MuJoCo model is made from the URDF text our model came from, with
//   - visual and collision elements stripped (the dynamics never need them, and data/robots
//     ships no meshes), and `<mujoco><compiler fusestatic="true" inertiafromgeom="false"
//     boundmass="0" boundinertia="0" balanceinertia="false"/></mujoco>` inserted: links fixed
//     to their parent are fused into it, as ours are, and no inertia comes from geometry;
//   - a free base as a URDF `floating` joint from a massless dummy root to the root link;
//   - locked joints (UrdfOptions::locked, at 0 only) turned into fixed joints;
//   - contacts and every constraint (limits, friction loss) disabled, and (unless kept for a
//     damped scene) joint damping, friction loss, stiffness and armature set to zero.
// MuJoCo refuses an inertia that breaks the triangle inequality (anymal_c, hyq, romeo_small
// have one); it is then compiled with balanceinertia="true". Its principal-axes decomposition of
// a full URDF inertia is itself only accurate to ~1e-7 on some links (panda). In both cases
// (compiled inertias more than 1e-12 from ours) every body's mass, centre of mass and inertia
// are written back from our model, so both engines integrate the same bodies;
// inertia_difference() reports how far MuJoCo's compiled inertias were from ours before that.
//
// Coordinates. Joints: MuJoCo's dof and qpos of the joint of the same name (same angle and
// sign). Free base: MuJoCo's qpos is (p, quaternion w x y z) of the root link, its qvel is
// (linear velocity of the root origin in the world frame, angular velocity in the root frame);
// ours is V = [w; v] in the base frame. With R the base rotation, MuJoCo's velocity is T v,
// T = [[0, R], [1, 0]] on the base block (identity on joints), so forces map by T^T, the mass
// matrix as D = T^T M T and its inverse as T^-1 M^-1 T^-T; MuJoCo's linear acceleration is
// R (dv/dt + w x v).
#pragma once

#include <mujoco/mujoco.h>

#include <memory>
#include <string>
#include <vector>

#include "se3_sim/dynamics/dynamics.h"

namespace se3::peers {

struct MujocoOptions {
  /// Keep the URDF's joint damping (MuJoCo's Euler integrates it implicitly; its implicit
  /// integrator linearizes it). Friction loss is a constraint in MuJoCo and stays off.
  bool keep_damping = false;
  /// The URDF text is model_to_urdf(ours): its links are our bodies, so MuJoCo's body frames
  /// are ours (no link offsets). Scenes use this: base inertias and locked joints are in it.
  bool body_frames = false;
  /// Keep our model's finite joint limits as MuJoCo's limit constraints (jnt_range, default
  /// solref and solimp); contact stays off.
  bool limits = false;
};

/// A robot in MuJoCo, paired with our model of the same URDF. Not copyable.
class MujocoRobot {
 public:
  /// ours: our model of urdf_text built with opt. Throws std::runtime_error with MuJoCo's
  /// message when MuJoCo cannot load it or its dofs do not match ours.
  MujocoRobot(const Model& ours, const std::string& urdf_text, const UrdfOptions& opt,
              const MujocoOptions& mopt = {});
  ~MujocoRobot();
  MujocoRobot(const MujocoRobot&) = delete;
  MujocoRobot& operator=(const MujocoRobot&) = delete;

  mjModel* m() const { return m_; }
  mjData* d() const { return d_; }
  /// Bodies MuJoCo simulates (its nbody without the world body) and its dofs.
  int bodies() const { return m_->nbody - 1; }
  int dofs() const { return m_->nv; }
  /// Largest relative difference (max norm of the 6x6 spatial inertias) between MuJoCo's
  /// compiled bodies and ours, before any write-back.
  double inertia_difference() const { return inertia_difference_; }
  /// MuJoCo needed balanceinertia to compile (and our inertias were written back).
  bool balanced() const { return balanced_; }
  /// One line: bodies, dofs, inertia check.
  std::string summary() const;

  /// MuJoCo's qpos and qvel from our state (and, for a fixed base, gravity turned into the
  /// base frame, since MuJoCo's root sits at the world origin).
  void set_state(const State& x);
  /// Our state from MuJoCo's qpos and qvel (q and v sized already; fixed base: base kept).
  void get_state(State& x) const;
  /// qvel <- T v (no qpos change).
  void velocity_to_mj(const State& x, const VecX& v, mjtNum* qvel) const;
  /// MuJoCo's qacc for our acceleration a at state x.
  void accel_to_mj(const State& x, const VecX& a, mjtNum* qacc) const;
  /// Our acceleration from MuJoCo's qacc at state x.
  void accel_from_mj(const State& x, const mjtNum* qacc, VecX& a) const;
  /// MuJoCo's generalized force for ours (base wrench [N; F] in the base frame first).
  void force_to_mj(const State& x, const VecX& tau, mjtNum* f) const;
  /// Our generalized force from MuJoCo's.
  void force_from_mj(const State& x, const mjtNum* f, VecX& tau) const;
  /// Our mass matrix from MuJoCo's dense one (nv x nv, row-major): T^T M T.
  MatX mass_from_mj(const State& x, const mjtNum* M) const;
  /// Our inverse mass matrix from MuJoCo's dense one (row-major): T^-1 M^-1 T^-T.
  MatX minv_from_mj(const State& x, const mjtNum* Minv) const;

  /// MuJoCo dof index of our coordinate k (base: the free joint's dofs in MuJoCo's order).
  int dof(int k) const { return dof_[k]; }

 private:
  const Model& ours_;
  mjModel* m_ = nullptr;
  mjData* d_ = nullptr;
  std::vector<int> dof_;   ///< our coordinate k -> MuJoCo dof (joints); base handled apart
  std::vector<int> qpos_;  ///< our joint i (1..n) -> MuJoCo qpos index ([0] unused)
  int free_qpos_ = -1, free_dof_ = -1;
  Vec3 gravity_;
  double inertia_difference_ = 0;
  bool balanced_ = false;
};

/// MuJoCo's model of our model itself (model_to_urdf(ours), body_frames): for scenes and
/// generated models, whatever their URDF, locked joints or added base inertia.
std::unique_ptr<MujocoRobot> mujoco_from_model(const Model& ours, MujocoOptions mopt = {});

/// The URDF text without <visual> and <collision> elements.
std::string strip_geometry(const std::string& urdf);

}  // namespace se3::peers
