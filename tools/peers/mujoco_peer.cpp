// MuJoCo 2.2 peer (mujoco_peer.h): loading through MuJoCo's URDF import, coordinate maps.
#include "mujoco_peer.h"

#include <unistd.h>

#include <Eigen/Eigenvalues>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <regex>
#include <stdexcept>

#include "se3_sim/sim/sim.h"

namespace se3::peers {
namespace {

const char* kFreeJoint = "se3_sim_free";
const char* kDummyRoot = "se3_sim_world";
const char* kRenamedRoot = "se3_sim_root";

std::string compiler_element(bool balance) {
  return std::string(
             "\n<mujoco><compiler fusestatic=\"true\" inertiafromgeom=\"false\" boundmass=\"0\" "
             "boundinertia=\"0\" discardvisual=\"true\" balanceinertia=\"") +
         (balance ? "true" : "false") + "\"/></mujoco>\n";
}

// The value of attribute `name` in the start tag `tag` ("" when absent).
std::string attribute(const std::string& tag, const std::string& name) {
  const std::regex re("\\b" + name + R"(\s*=\s*["']([^"']*)["'])");
  std::smatch mt;
  return std::regex_search(tag, mt, re) ? mt[1].str() : std::string();
}

// The URDF with the named joint's type replaced by "fixed".
std::string fix_joint(const std::string& urdf, const std::string& joint) {
  static const std::regex start(R"(<joint\b[^>]*>)");
  static const std::regex type(R"(\btype\s*=\s*["'][^"']*["'])");
  for (auto it = std::sregex_iterator(urdf.begin(), urdf.end(), start);
       it != std::sregex_iterator(); ++it) {
    const std::string tag = it->str();
    if (attribute(tag, "name") != joint) continue;
    const std::string fixed = std::regex_replace(tag, type, "type=\"fixed\"");
    return urdf.substr(0, it->position()) + fixed + urdf.substr(it->position() + tag.size());
  }
  throw std::runtime_error("MuJoCo peer: locked joint '" + joint + "' not found in the URDF");
}

// Spatial inertia of MuJoCo body b in its body frame.
Inertia mujoco_inertia(const mjModel* m, int b) {
  const mjtNum* q = m->body_iquat + 4 * b;
  const Mat3 R = rotation_from_quaternion(q[1], q[2], q[3], q[0]);
  const Vec3 d(m->body_inertia[3 * b], m->body_inertia[3 * b + 1], m->body_inertia[3 * b + 2]);
  const Vec3 c(m->body_ipos[3 * b], m->body_ipos[3 * b + 1], m->body_ipos[3 * b + 2]);
  return Inertia::from_com(m->body_mass[b], c, R * d.asDiagonal() * R.transpose());
}

double inertia_rel(const Inertia& a, const Inertia& b) {
  const Mat6 A = a.matrix(), B = b.matrix();
  const double s = std::max(B.cwiseAbs().maxCoeff(), 1e-300);
  return (A - B).cwiseAbs().maxCoeff() / s;
}

// Writes inertia J (in MuJoCo body b's frame) into MuJoCo's principal-axes form.
void write_inertia(mjModel* m, int b, const Inertia& J) {
  const Vec3 c = J.com();
  const Mat3 Ic = J.I + J.m * hat(c) * hat(c);  // about the centre of mass
  Eigen::SelfAdjointEigenSolver<Mat3> es(Ic);
  Mat3 V = es.eigenvectors();
  if (V.determinant() < 0) V.col(2) = -V.col(2);
  const Eigen::Vector4d q = quaternion_from_rotation(V);  // x, y, z, w
  m->body_mass[b] = J.m;
  for (int k = 0; k < 3; ++k) {
    m->body_ipos[3 * b + k] = c[k];
    m->body_inertia[3 * b + k] = std::max(es.eigenvalues()[k], 0.0);
  }
  m->body_iquat[4 * b] = q[3];
  m->body_iquat[4 * b + 1] = q[0];
  m->body_iquat[4 * b + 2] = q[1];
  m->body_iquat[4 * b + 3] = q[2];
  // The compiler's shortcuts assumed the old inertial frame.
  m->body_sameframe[b] = 0;
  m->body_simple[b] = 0;
}

// MuJoCo's warnings ("Nan, Inf or huge value in QACC", its reset after one) go to stderr, not
// to the MUJOCO_LOG.TXT it would write into the working directory.
void warning_to_stderr(const char* msg) {
  std::fprintf(stderr, "MuJoCo: %s\n", msg);
}

}  // namespace

std::string strip_geometry(const std::string& urdf) {
  static const std::regex geom(R"(<(visual|collision)\b[\s\S]*?</\1\s*>)");
  static const std::regex empty_geom(R"(<(visual|collision)\b[^>]*/>)");
  return std::regex_replace(std::regex_replace(urdf, geom, ""), empty_geom, "");
}

MujocoRobot::MujocoRobot(const Model& ours, const std::string& urdf_text, const UrdfOptions& opt,
                         const MujocoOptions& mopt)
    : ours_(ours), dof_(ours.nv, -1), qpos_(ours.n + 1, -1), gravity_(ours.gravity) {
  if (!mju_user_warning) mju_user_warning = warning_to_stderr;
  std::string text = strip_geometry(urdf_text);
  for (const auto& kv : opt.locked) {
    if (kv.second != 0) {
      throw std::runtime_error("MuJoCo peer: locked joint '" + kv.first +
                               "' must be locked at 0 (MuJoCo's fixed joint has no offset)");
    }
    text = fix_joint(text, kv.first);
  }
  const std::size_t robot = text.find("<robot");
  const std::size_t robot_end = robot == std::string::npos ? robot : text.find('>', robot);
  const std::size_t close = text.rfind("</robot>");
  if (robot_end == std::string::npos || close == std::string::npos) {
    throw std::runtime_error("MuJoCo peer: no <robot> element");
  }
  // MuJoCo's body of link i (a free root named "world" would be MuJoCo's world body: renamed).
  std::vector<std::string> mj_name(ours.body_name.begin(), ours.body_name.end());
  if (ours.floating) {
    if (!mopt.body_frames && !ours.links.empty() && !ours.links[0].offset.isApprox(SE3(), 0)) {
      throw std::runtime_error("MuJoCo peer: the root link is not the base frame");
    }
    if (mj_name[0] == "world") {
      mj_name[0] = kRenamedRoot;
      static const std::regex world(R"(((?:<link\s+name|\blink)\s*=\s*)(["'])world\2)");
      text = std::regex_replace(text, world, std::string("$1\"") + kRenamedRoot + "\"");
    }
    const std::size_t end = text.rfind("</robot>");
    text.insert(end, std::string("<link name=\"") + kDummyRoot + "\"/><joint name=\"" + kFreeJoint +
                         "\" type=\"floating\"><parent link=\"" + kDummyRoot +
                         "\"/><child link=\"" + mj_name[0] + "\"/></joint>\n");
  }
  static std::atomic<int> counter{0};
  const std::string path =
      "/tmp/se3_sim_mujoco_" + std::to_string(getpid()) + "_" + std::to_string(counter++) + ".urdf";
  char err[1024] = "";
  for (int attempt = 0; attempt < 2 && !m_; ++attempt) {
    std::string t = text;
    t.insert(robot_end + 1, compiler_element(balanced_));
    std::ofstream(path) << t;
    m_ = mj_loadXML(path.c_str(), nullptr, err, sizeof err);
    if (!m_ && std::string(err).find("balanceinertia") != std::string::npos) balanced_ = true;
  }
  std::remove(path.c_str());
  if (!m_) throw std::runtime_error(std::string("MuJoCo could not load the URDF: ") + err);
  if (m_->nv != ours.nv) {
    const std::string msg =
        "MuJoCo has " + std::to_string(m_->nv) + " dofs, ours " + std::to_string(ours.nv);
    mj_deleteModel(m_);
    throw std::runtime_error(msg);
  }
  // Joints by name.
  for (int i = 1; i <= ours.n; ++i) {
    const int j = mj_name2id(m_, mjOBJ_JOINT, ours.joint_name[i].c_str());
    const int want = ours.joints[i].type == JointType::Revolute ? mjJNT_HINGE : mjJNT_SLIDE;
    if (j < 0 || m_->jnt_type[j] != want) {
      mj_deleteModel(m_);
      throw std::runtime_error("MuJoCo peer: joint '" + ours.joint_name[i] + "' missing or of " +
                               "another type in MuJoCo");
    }
    dof_[ours.idx_v(i)] = m_->jnt_dofadr[j];
    qpos_[i] = m_->jnt_qposadr[j];
  }
  if (ours.floating) {
    const int j = mj_name2id(m_, mjOBJ_JOINT, kFreeJoint);
    free_qpos_ = m_->jnt_qposadr[j];
    free_dof_ = m_->jnt_dofadr[j];
    for (int k = 0; k < 6; ++k) dof_[k] = free_dof_ + (k < 3 ? 3 + k : k - 3);
  }
  // Rigid-body dynamics only: no contact, no constraint (but the joint limits when asked);
  // passive forces only when kept.
  m_->opt.disableflags |= mjDSBL_CONTACT | mjDSBL_ACTUATION | mjDSBL_SENSOR;
  if (!mopt.limits) m_->opt.disableflags |= mjDSBL_CONSTRAINT;
  for (int i = 1; i <= ours.n; ++i) {
    const int j = mj_name2id(m_, mjOBJ_JOINT, ours.joint_name[i].c_str());
    const bool limited =
        mopt.limits && std::isfinite(ours.lower[i]) && std::isfinite(ours.upper[i]);
    m_->jnt_limited[j] = limited;
    if (limited) m_->jnt_range[2 * j] = ours.lower[i], m_->jnt_range[2 * j + 1] = ours.upper[i];
  }
  if (!mopt.keep_damping) m_->opt.disableflags |= mjDSBL_PASSIVE;
  for (int k = 0; k < m_->nv; ++k) {
    m_->dof_damping[k] = 0;
    m_->dof_frictionloss[k] = 0;
    m_->dof_armature[k] = 0;
  }
  for (int j = 0; j < m_->njnt; ++j) m_->jnt_stiffness[j] = 0;
  if (mopt.keep_damping) {
    for (int i = 1; i <= ours.n; ++i) m_->dof_damping[dof_[ours.idx_v(i)]] = ours.damping[i];
  }
  for (int k = 0; k < 3; ++k) m_->opt.gravity[k] = gravity_[k];

  // The bodies: MuJoCo body b carries the links fused into the link it is named after, as our
  // body of that link does; compare the inertias in MuJoCo's body frame (the link frame).
  const int moving = ours.floating ? ours.n + 1 : ours.n;
  if (m_->nbody - 1 != moving) {
    const std::string msg =
        "MuJoCo has " + std::to_string(m_->nbody - 1) + " bodies, ours " + std::to_string(moving);
    mj_deleteModel(m_);
    throw std::runtime_error(msg);
  }
  std::vector<Inertia> want(m_->nbody);
  std::vector<bool> seen(m_->nbody, false);
  for (int i = ours.floating ? 0 : 1; i <= ours.n; ++i) {
    const int b = mj_name2id(m_, mjOBJ_BODY, mj_name[i].c_str());
    const int l = mopt.body_frames ? 0 : ours.link_index(ours.body_name[i]);
    if (b <= 0 || l < 0 || seen[b]) {
      mj_deleteModel(m_);
      throw std::runtime_error("MuJoCo peer: body '" + ours.body_name[i] + "' not matched");
    }
    seen[b] = true;
    want[b] = mopt.body_frames ? ours.inertia[i]
                               : ours.inertia[i].transformed(ours.links[l].offset.inverse());
    inertia_difference_ =
        std::max(inertia_difference_, inertia_rel(mujoco_inertia(m_, b), want[b]));
  }
  if (balanced_ || inertia_difference_ > 1e-12) {
    for (int b = 1; b < m_->nbody; ++b) write_inertia(m_, b, want[b]);
    for (int k = 0; k < m_->nv; ++k) m_->dof_simplenum[k] = 0;
    for (int b = 0; b < m_->nbody; ++b) m_->body_subtreemass[b] = m_->body_mass[b];
    for (int b = m_->nbody - 1; b > 0; --b) {
      m_->body_subtreemass[m_->body_parentid[b]] += m_->body_subtreemass[b];
    }
  }
  d_ = mj_makeData(m_);
}

std::unique_ptr<MujocoRobot> mujoco_from_model(const Model& ours, MujocoOptions mopt) {
  mopt.body_frames = true;
  UrdfOptions opt;
  opt.floating = ours.floating;
  return std::make_unique<MujocoRobot>(ours, model_to_urdf(ours), opt, mopt);
}

MujocoRobot::~MujocoRobot() {
  if (d_) mj_deleteData(d_);
  if (m_) mj_deleteModel(m_);
}

std::string MujocoRobot::summary() const {
  char b[256];
  std::snprintf(b, sizeof b, "MuJoCo %s: %d bodies, %d dofs (ours %d, %d); inertias %.1e%s",
                mj_versionString(), bodies(), dofs(), ours_.floating ? ours_.n + 1 : ours_.n,
                ours_.nv, inertia_difference_,
                balanced_                     ? " (balanceinertia needed: ours written back)"
                : inertia_difference_ > 1e-12 ? " (ours written back)"
                                              : "");
  return b;
}

void MujocoRobot::set_state(const State& x) {
  mjtNum* qpos = d_->qpos;
  for (int i = 1; i <= ours_.n; ++i) qpos[qpos_[i]] = x.q[ours_.idx_q(i)];
  if (ours_.floating) {
    const Eigen::Vector4d q = quaternion_from_rotation(x.base.R);
    for (int k = 0; k < 3; ++k) qpos[free_qpos_ + k] = x.base.p[k];
    qpos[free_qpos_ + 3] = q[3];
    qpos[free_qpos_ + 4] = q[0];
    qpos[free_qpos_ + 5] = q[1];
    qpos[free_qpos_ + 6] = q[2];
  } else {
    const Vec3 g = x.base.R.transpose() * gravity_;
    for (int k = 0; k < 3; ++k) m_->opt.gravity[k] = g[k];
  }
  velocity_to_mj(x, x.v, d_->qvel);
}

void MujocoRobot::get_state(State& x) const {
  const mjtNum* qpos = d_->qpos;
  for (int i = 1; i <= ours_.n; ++i) x.q[ours_.idx_q(i)] = qpos[qpos_[i]];
  const int off = ours_.nv_base();
  for (int k = off; k < ours_.nv; ++k) x.v[k] = d_->qvel[dof_[k]];
  if (ours_.floating) {
    const mjtNum* q = qpos + free_qpos_;
    const double s = 1.0 / std::sqrt(q[3] * q[3] + q[4] * q[4] + q[5] * q[5] + q[6] * q[6]);
    x.base.R = rotation_from_quaternion(q[4] * s, q[5] * s, q[6] * s, q[3] * s);
    x.base.p = Vec3(q[0], q[1], q[2]);
    const mjtNum* w = d_->qvel + free_dof_;
    x.v.head<3>() = Vec3(w[3], w[4], w[5]);
    x.v.segment<3>(3) = x.base.R.transpose() * Vec3(w[0], w[1], w[2]);
  }
}

void MujocoRobot::velocity_to_mj(const State& x, const VecX& v, mjtNum* qvel) const {
  const int off = ours_.nv_base();
  for (int k = off; k < ours_.nv; ++k) qvel[dof_[k]] = v[k];
  if (ours_.floating) {
    const Vec3 lin = x.base.R * v.segment<3>(3);
    for (int k = 0; k < 3; ++k) {
      qvel[free_dof_ + k] = lin[k];
      qvel[free_dof_ + 3 + k] = v[k];
    }
  }
}

void MujocoRobot::accel_to_mj(const State& x, const VecX& a, mjtNum* qacc) const {
  const int off = ours_.nv_base();
  for (int k = off; k < ours_.nv; ++k) qacc[dof_[k]] = a[k];
  if (ours_.floating) {
    const Vec3 w = x.v.head<3>(), v = x.v.segment<3>(3);
    const Vec3 lin = x.base.R * (a.segment<3>(3) + w.cross(v));
    for (int k = 0; k < 3; ++k) {
      qacc[free_dof_ + k] = lin[k];
      qacc[free_dof_ + 3 + k] = a[k];
    }
  }
}

void MujocoRobot::accel_from_mj(const State& x, const mjtNum* qacc, VecX& a) const {
  a.resize(ours_.nv);
  const int off = ours_.nv_base();
  for (int k = off; k < ours_.nv; ++k) a[k] = qacc[dof_[k]];
  if (ours_.floating) {
    const mjtNum* f = qacc + free_dof_;
    const Vec3 w = x.v.head<3>(), v = x.v.segment<3>(3);
    a.head<3>() = Vec3(f[3], f[4], f[5]);
    a.segment<3>(3) = x.base.R.transpose() * Vec3(f[0], f[1], f[2]) - w.cross(v);
  }
}

void MujocoRobot::force_to_mj(const State& x, const VecX& tau, mjtNum* f) const {
  const int off = ours_.nv_base();
  for (int k = off; k < ours_.nv; ++k) f[dof_[k]] = tau[k];
  if (ours_.floating) {
    const Vec3 lin = x.base.R * tau.segment<3>(3);
    for (int k = 0; k < 3; ++k) {
      f[free_dof_ + k] = lin[k];
      f[free_dof_ + 3 + k] = tau[k];
    }
  }
}

void MujocoRobot::force_from_mj(const State& x, const mjtNum* f, VecX& tau) const {
  tau.resize(ours_.nv);
  const int off = ours_.nv_base();
  for (int k = off; k < ours_.nv; ++k) tau[k] = f[dof_[k]];
  if (ours_.floating) {
    const mjtNum* b = f + free_dof_;
    tau.head<3>() = Vec3(b[3], b[4], b[5]);
    tau.segment<3>(3) = x.base.R.transpose() * Vec3(b[0], b[1], b[2]);
  }
}

namespace {
using RowMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
}

MatX MujocoRobot::mass_from_mj(const State& x, const mjtNum* M) const {
  const int n = ours_.nv;
  const Eigen::Map<const RowMat> Mm(M, n, n);
  MatX T = MatX::Zero(n, n);  // MuJoCo velocity = T * ours
  const int off = ours_.nv_base();
  for (int k = off; k < n; ++k) T(dof_[k], k) = 1;
  if (ours_.floating) {
    T.block<3, 3>(free_dof_, 3) = x.base.R;
    T.block<3, 3>(free_dof_ + 3, 0).setIdentity();
  }
  return T.transpose() * Mm * T;
}

MatX MujocoRobot::minv_from_mj(const State& x, const mjtNum* Minv) const {
  const int n = ours_.nv;
  const Eigen::Map<const RowMat> Mi(Minv, n, n);
  MatX Ti = MatX::Zero(n, n);  // ours = Ti * MuJoCo velocity
  const int off = ours_.nv_base();
  for (int k = off; k < n; ++k) Ti(k, dof_[k]) = 1;
  if (ours_.floating) {
    Ti.block<3, 3>(3, free_dof_) = x.base.R.transpose();
    Ti.block<3, 3>(0, free_dof_ + 3).setIdentity();
  }
  return Ti * Mi * Ti.transpose();
}

}  // namespace se3::peers
