// The naive baselines people actually use, for comparison with the Lie-group steppers:
// classical Runge-Kutta 4 on a coordinate vector that parameterizes the base orientation,
//   rk4_euler_angles: ZYX Euler angles (roll, pitch, yaw), R = Rz(yaw) Ry(pitch) Rx(roll), whose
//                     rate equations divide by cos(pitch) and blow up at pitch = +-90 deg
//                     (gimbal lock);
//   rk4_quaternion:   a unit quaternion with qdot = 1/2 q (0, w), renormalized after each step
//                     (the stages use the normalized rotation, the state drifts off norm 1
//                     within a step).
// The state vector is [orientation coordinates; base position (world); q; v] with
// pdot = R v_lin and the accelerations from ABA (one call per stage, four per step), all of it
// advanced by one classical RK4 tableau. The coordinates are taken from the base rotation at
// the start of every step and turned back into a rotation at its end (for Euler angles a
// rotation and its angles convert both ways exactly away from the singularity). For a fixed
// base there are no base coordinates and both are plain RK4 (= rkmk4).
#include <algorithm>
#include <cmath>
#include <string>

#include "se3_sim/integrate/integrate.h"
#include "steppers.h"

namespace se3 {
namespace {

enum class Chart { EulerZYX, Quaternion };

Mat3 rotation_zyx(double roll, double pitch, double yaw) {
  return (Eigen::AngleAxisd(yaw, Vec3::UnitZ()) * Eigen::AngleAxisd(pitch, Vec3::UnitY()) *
          Eigen::AngleAxisd(roll, Vec3::UnitX()))
      .toRotationMatrix();
}

Vec3 angles_zyx(const Mat3& R) {
  const double s = std::max(-1.0, std::min(1.0, -R(2, 0)));
  return Vec3(std::atan2(R(2, 1), R(2, 2)), std::asin(s), std::atan2(R(1, 0), R(0, 0)));
}

Mat3 rotation_wxyz(const Eigen::Vector4d& c) {
  const Eigen::Vector4d u = c.normalized();
  return Eigen::Quaterniond(u[0], u[1], u[2], u[3]).toRotationMatrix();
}

class CoordinateRk4Stepper final : public Stepper {
 public:
  CoordinateRk4Stepper(Chart chart, const Model& model, const StepperOptions& opt)
      : Stepper(model, opt),
        chart_(chart),
        nc_(model.floating ? (chart == Chart::EulerZYX ? 3 : 4) : 0),
        size_(nc_ + (model.floating ? 3 : 0) + model.nq + model.nv),
        y_(VecX::Zero(size_)),
        yt_(VecX::Zero(size_)),
        q_(VecX::Zero(model.nq)),
        v_(VecX::Zero(model.nv)) {
    for (auto& k : k_) k = VecX::Zero(size_);
  }

  std::string name() const override {
    return chart_ == Chart::EulerZYX ? "rk4_euler_angles" : "rk4_quaternion";
  }
  int order() const override { return 4; }

  StepInfo step(State& x, const VecX& tau, double h) override {
    const int n = model_.nq, nv = model_.nv;
    const int pp = nc_, pq = nc_ + (model_.floating ? 3 : 0), pv = pq + n;
    if (model_.floating) {
      if (chart_ == Chart::EulerZYX) {
        y_.head<3>() = angles_zyx(x.base.R);
      } else {
        const Eigen::Quaterniond qu(x.base.R);
        y_.head<4>() << qu.w(), qu.x(), qu.y(), qu.z();
      }
      y_.segment<3>(pp) = x.base.p;
    }
    y_.segment(pq, n) = x.q;
    y_.segment(pv, nv) = x.v;
    static const double c[4] = {0.0, 0.5, 0.5, 1.0};
    static const double b[4] = {1.0 / 6, 1.0 / 3, 1.0 / 3, 1.0 / 6};
    for (int s = 0; s < 4; ++s) {
      if (s == 0) {
        derivative(y_, tau, k_[0]);
      } else {
        yt_ = y_ + (c[s] * h) * k_[s - 1];
        derivative(yt_, tau, k_[s]);
      }
    }
    for (int s = 0; s < 4; ++s) y_.noalias() += (b[s] * h) * k_[s];
    StepInfo info;
    info.evaluations = 4;
    info.substeps = 1;
    if (!y_.allFinite()) {
      info.ok = false;
      info.reason = name() + ": non-finite state";
      return info;
    }
    if (model_.floating) {
      x.base.R = rotation_of(y_);
      x.base.p = y_.segment<3>(pp);
    }
    x.q = y_.segment(pq, n);
    x.v = y_.segment(pv, nv);
    return info;
  }

 private:
  Mat3 rotation_of(const VecX& y) const {
    if (chart_ == Chart::EulerZYX) return rotation_zyx(y[0], y[1], y[2]);
    return rotation_wxyz(y.head<4>());
  }

  void derivative(const VecX& y, const VecX& tau, VecX& dy) {
    const int n = model_.nq, nv = model_.nv;
    const int pp = nc_, pq = nc_ + (model_.floating ? 3 : 0), pv = pq + n;
    q_ = y.segment(pq, n);
    v_ = y.segment(pv, nv);
    SE3 base;
    if (model_.floating) {
      base.R = rotation_of(y);
      base.p = y.segment<3>(pp);
      const Vec3 w = v_.head<3>();
      if (chart_ == Chart::EulerZYX) {
        const double sr = std::sin(y[0]), cr = std::cos(y[0]);
        const double tp = std::tan(y[1]), cp = std::cos(y[1]);
        const double a = sr * w.y() + cr * w.z();
        dy[0] = w.x() + tp * a;
        dy[1] = cr * w.y() - sr * w.z();
        dy[2] = a / cp;
      } else {
        const double qw = y[0], qx = y[1], qy = y[2], qz = y[3];
        dy[0] = -0.5 * (qx * w.x() + qy * w.y() + qz * w.z());
        dy[1] = 0.5 * (qw * w.x() + qy * w.z() - qz * w.y());
        dy[2] = 0.5 * (qw * w.y() + qz * w.x() - qx * w.z());
        dy[3] = 0.5 * (qw * w.z() + qx * w.y() - qy * w.x());
      }
      dy.segment<3>(pp) = base.R * v_.segment<3>(3);
    } else {
      base = SE3();
    }
    dy.segment(pq, n) = v_.tail(n);
    dy.segment(pv, nv) = acceleration(model_.floating ? base : SE3(), q_, v_, tau);
  }

  Chart chart_;
  int nc_, size_;
  VecX y_, yt_, q_, v_;
  VecX k_[4];
};

}  // namespace

namespace detail {

std::unique_ptr<Stepper> make_rk4_euler_angles_stepper(const Model& model,
                                                       const StepperOptions& opt) {
  return std::make_unique<CoordinateRk4Stepper>(Chart::EulerZYX, model, opt);
}

std::unique_ptr<Stepper> make_rk4_quaternion_stepper(const Model& model,
                                                     const StepperOptions& opt) {
  return std::make_unique<CoordinateRk4Stepper>(Chart::Quaternion, model, opt);
}

}  // namespace detail
}  // namespace se3
