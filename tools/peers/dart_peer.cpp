// DART 6 peer (dart_peer.h).
#include "dart_peer.h"

#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <dart/dynamics/BodyNode.hpp>
#include <dart/dynamics/DegreeOfFreedom.hpp>
#include <dart/dynamics/FreeJoint.hpp>
#include <dart/dynamics/Inertia.hpp>
#include <dart/dynamics/Joint.hpp>
#include <dart/dynamics/Skeleton.hpp>
#include <dart/simulation/World.hpp>
#include <dart/utils/urdf/DartLoader.hpp>
#include <fstream>
#include <regex>
#include <stdexcept>

#include "se3_sim/sim/sim.h"

namespace se3::peers {

struct DartRobot::Impl {
  dart::dynamics::SkeletonPtr skel;
  dart::simulation::WorldPtr world;
  std::vector<int> map;  ///< our coordinate k -> DART dof
  Eigen::VectorXd pos, vel;
  Vec3 gravity;
};

DartRobot::DartRobot(const Model& ours, bool keep_damping)
    : ours_(ours), impl_(std::make_unique<Impl>()) {
  static const std::regex geom(R"(<(visual|collision)\b[\s\S]*?</\1\s*>)");
  static std::atomic<int> counter{0};
  const std::string path =
      "/tmp/se3_sim_dart_" + std::to_string(getpid()) + "_" + std::to_string(counter++) + ".urdf";
  std::ofstream(path) << std::regex_replace(model_to_urdf(ours), geom, "");
  using dart::utils::DartLoader;
  DartLoader::Options dopt(
      nullptr,
      ours.floating ? DartLoader::RootJointType::FLOATING : DartLoader::RootJointType::FIXED,
      dart::dynamics::Inertia(0.0, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Zero()));
  DartLoader loader(dopt);
  Impl& I = *impl_;
  I.skel = loader.parseSkeleton(dart::common::Uri::createFromPath(path));
  std::remove(path.c_str());
  if (!I.skel || static_cast<int>(I.skel->getNumDofs()) != ours.nv) {
    throw std::runtime_error("DART peer: could not load the model with " + std::to_string(ours.nv) +
                             " dofs");
  }
  for (std::size_t k = 0; k < I.skel->getNumDofs(); ++k) {
    I.skel->getDof(k)->setDampingCoefficient(0);
    I.skel->getDof(k)->setSpringStiffness(0);
    I.skel->getDof(k)->setCoulombFriction(0);
  }
  for (std::size_t k = 0; k < I.skel->getNumJoints(); ++k) {
    I.skel->getJoint(k)->setActuatorType(dart::dynamics::Joint::FORCE);
    I.skel->getJoint(k)->setLimitEnforcement(false);
  }
  I.map.resize(ours.nv);
  for (int k = 0; k < ours.nv_base(); ++k) I.map[k] = k;
  for (int i = 1; i <= ours.n; ++i) {
    const dart::dynamics::Joint* j = I.skel->getJoint(ours.joint_name[i]);
    if (!j || j->getNumDofs() != 1) {
      throw std::runtime_error("DART peer: joint '" + ours.joint_name[i] + "' not found");
    }
    I.map[ours.idx_v(i)] = static_cast<int>(j->getIndexInSkeleton(0));
    if (keep_damping) I.skel->getDof(I.map[ours.idx_v(i)])->setDampingCoefficient(ours.damping[i]);
  }
  I.gravity = ours.gravity;
  I.world = std::make_shared<dart::simulation::World>();
  I.world->addSkeleton(I.skel);
  I.world->setGravity(I.gravity);
  I.pos = Eigen::VectorXd::Zero(ours.nv);
  I.vel = Eigen::VectorXd::Zero(ours.nv);
}

DartRobot::~DartRobot() = default;

void DartRobot::set_state(const State& x) {
  Impl& I = *impl_;
  if (ours_.floating) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = x.base.R;
    T.translation() = x.base.p;
    I.pos.head<6>() = dart::dynamics::FreeJoint::convertToPositions(T);
  } else {
    I.world->setGravity(x.base.R.transpose() * I.gravity);
  }
  for (int i = 1; i <= ours_.n; ++i) I.pos[I.map[ours_.idx_v(i)]] = x.q[ours_.idx_q(i)];
  for (int k = 0; k < ours_.nv; ++k) I.vel[I.map[k]] = x.v[k];
  I.skel->setPositions(I.pos);
  I.skel->setVelocities(I.vel);
}

void DartRobot::get_state(State& x) const {
  const Impl& I = *impl_;
  const Eigen::VectorXd p = I.skel->getPositions(), v = I.skel->getVelocities();
  if (ours_.floating) {
    const Eigen::Isometry3d T = dart::dynamics::FreeJoint::convertToTransform(p.head<6>());
    x.base.R = T.linear();
    x.base.p = T.translation();
  }
  for (int i = 1; i <= ours_.n; ++i) x.q[ours_.idx_q(i)] = p[I.map[ours_.idx_v(i)]];
  for (int k = 0; k < ours_.nv; ++k) x.v[k] = v[I.map[k]];
}

bool DartRobot::step(double h) {
  impl_->world->setTimeStep(h);
  impl_->world->step();
  const Eigen::VectorXd& p = impl_->skel->getPositions();
  const Eigen::VectorXd& v = impl_->skel->getVelocities();
  return p.allFinite() && v.allFinite() && v.cwiseAbs().maxCoeff() < 1e6;
}

MatX DartRobot::mass_matrix() const {
  const Eigen::MatrixXd& M = impl_->skel->getMassMatrix();
  MatX out(ours_.nv, ours_.nv);
  for (int r = 0; r < ours_.nv; ++r) {
    for (int c = 0; c < ours_.nv; ++c) out(r, c) = M(impl_->map[r], impl_->map[c]);
  }
  return out;
}

MatX DartRobot::inverse_mass_matrix() const {
  const Eigen::MatrixXd& M = impl_->skel->getInvMassMatrix();
  MatX out(ours_.nv, ours_.nv);
  for (int r = 0; r < ours_.nv; ++r) {
    for (int c = 0; c < ours_.nv; ++c) out(r, c) = M(impl_->map[r], impl_->map[c]);
  }
  return out;
}

DartMinvCheck dart_minv_check(const Model& ours, const std::string& urdf_text, const State& x) {
  static const std::regex geom(R"(<(visual|collision)\b[\s\S]*?</\1\s*>)");
  const std::string path = "/tmp/se3_sim_dart_minv_" + std::to_string(getpid()) + ".urdf";
  std::ofstream(path) << std::regex_replace(urdf_text, geom, "");
  using dart::utils::DartLoader;
  DartLoader::Options dopt(
      nullptr,
      ours.floating ? DartLoader::RootJointType::FLOATING : DartLoader::RootJointType::FIXED,
      dart::dynamics::Inertia(0.0, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Zero()));
  DartLoader loader(dopt);
  const auto skel = loader.parseSkeleton(dart::common::Uri::createFromPath(path));
  std::remove(path.c_str());
  if (!skel || static_cast<int>(skel->getNumDofs()) != ours.nv) {
    throw std::runtime_error("DART peer: could not load the URDF with " + std::to_string(ours.nv) +
                             " dofs");
  }
  for (std::size_t k = 0; k < skel->getNumJoints(); ++k) {
    skel->getJoint(k)->setActuatorType(dart::dynamics::Joint::FORCE);
  }
  std::vector<int> map(ours.nv);
  for (int k = 0; k < ours.nv_base(); ++k) map[k] = k;
  for (int i = 1; i <= ours.n; ++i) {
    map[ours.idx_v(i)] =
        static_cast<int>(skel->getJoint(ours.joint_name[i])->getIndexInSkeleton(0));
  }
  Eigen::VectorXd pos = Eigen::VectorXd::Zero(ours.nv);
  if (ours.floating) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = x.base.R;
    T.translation() = x.base.p;
    pos.head<6>() = dart::dynamics::FreeJoint::convertToPositions(T);
  }
  for (int i = 1; i <= ours.n; ++i) pos[map[ours.idx_v(i)]] = x.q[ours.idx_q(i)];
  skel->setPositions(pos);
  const Eigen::MatrixXd M = skel->getMassMatrix(), Mi = skel->getInvMassMatrix();
  const Eigen::MatrixXd Minv = M.inverse();
  DartMinvCheck c;
  c.self = (Mi - Minv).cwiseAbs().maxCoeff() / Minv.cwiseAbs().maxCoeff();
  Data d(ours);
  MatX D = crba(ours, d, x.base, x.q), Mo(ours.nv, ours.nv);
  for (int r = 0; r < ours.nv; ++r) {
    for (int k = 0; k < ours.nv; ++k) Mo(r, k) = M(map[r], map[k]);
  }
  c.mass = (Mo - D).cwiseAbs().maxCoeff() / D.cwiseAbs().maxCoeff();
  const MatX Dinv = D.inverse();
  c.ours = (minv(ours, d, x.base, x.q) - Dinv).cwiseAbs().maxCoeff() / Dinv.cwiseAbs().maxCoeff();
  for (std::size_t b = 0; b < skel->getNumBodyNodes(); ++b) {
    const auto* body = skel->getBodyNode(b);
    if (body->getParentJoint()->getNumDofs() != 0 || !body->getParentBodyNode()) continue;
    bool moving_above = false;
    for (auto* p = body->getParentBodyNode(); p && !moving_above; p = p->getParentBodyNode()) {
      moving_above = p->getParentJoint()->getNumDofs() != 0;
    }
    bool moving_below = false;
    for (std::size_t k = 0; k < skel->getNumDofs() && !moving_below; ++k) {
      const auto* child = skel->getDof(k)->getChildBodyNode();
      for (auto* p = child; p; p = p->getParentBodyNode()) {
        if (p == body) {
          moving_below = true;
          break;
        }
      }
    }
    if (moving_above && moving_below) ++c.welded;
  }
  return c;
}

}  // namespace se3::peers
