// Shared helpers of the library tests: the robot list, models to sweep, random states drawn
// with fixed seeds, and error measures.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "se3_sim/dynamics/dynamics.h"
#include "se3_sim/lie/lie.h"
#include "se3_sim/model/model.h"
#include "source_paths.h"

namespace se3_test {

using se3::Mat3;
using se3::MatX;
using se3::SE3;
using se3::Vec3;
using se3::Vec6;
using se3::VecX;

inline std::string robot_path(const std::string& file) {
  return se3_sim_test::source_dir() + "/data/robots/" + file;
}

/// One URDF of data/robots with its expected number of moving joints.
struct RobotFile {
  std::string file;
  int dof;
  bool floating_ok;  ///< false: a free base is rejected (massless root)
};

inline const std::vector<RobotFile>& robot_files() {
  static const std::vector<RobotFile> robots = {
      {"ur5_robot.urdf", 6, true},
      {"panda.urdf", 9, true},
      {"kuka_iiwa.urdf", 7, false},
      {"solo12.urdf", 12, true},
      {"anymal_c.urdf", 12, true},
      {"hyq_no_sensors.urdf", 12, true},
      {"romeo_small.urdf", 31, true},
      {"double_pendulum.urdf", 2, true},
      {"double_pendulum_simple.urdf", 2, true},
  };
  return robots;
}

/// A model to sweep, with a label for failure messages.
struct Case {
  std::string label;
  se3::Model model;
};

/// Every robot of data/robots fixed and floating (kuka floating is rejected, so left out) and
/// generated chains of 1, 2, 10 and 200 bodies, fixed and floating.
inline std::vector<Case> all_cases() {
  std::vector<Case> cases;
  for (const RobotFile& r : robot_files()) {
    for (bool floating : {false, true}) {
      if (floating && !r.floating_ok) continue;
      se3::UrdfOptions opt;
      opt.floating = floating;
      cases.push_back({r.file + (floating ? " floating" : " fixed"),
                       se3::model_from_urdf_file(robot_path(r.file), opt)});
    }
  }
  for (int n : {1, 2, 10, 200}) {
    for (bool floating : {false, true}) {
      cases.push_back({"chain" + std::to_string(n) + (floating ? " floating" : " fixed"),
                       se3::make_chain(n, floating)});
    }
  }
  return cases;
}

/// Uniform in [lo, hi].
inline double uniform(std::mt19937_64& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

inline VecX random_vec(std::mt19937_64& rng, int n, double scale) {
  VecX x(n);
  for (int i = 0; i < n; ++i) x[i] = uniform(rng, -scale, scale);
  return x;
}

inline Vec3 random_unit(std::mt19937_64& rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  Vec3 u;
  do {
    u = Vec3(g(rng), g(rng), g(rng));
  } while (u.norm() < 1e-3);
  return u.normalized();
}

/// A rotation with angle uniform in [0, pi] about a random axis.
inline Mat3 random_rotation(std::mt19937_64& rng) {
  return se3::exp_so3(uniform(rng, 0.0, M_PI) * random_unit(rng));
}

inline SE3 random_pose(std::mt19937_64& rng, double pos_scale = 1.0) {
  return SE3(random_rotation(rng), random_vec(rng, 3, pos_scale));
}

/// A random state: base pose, joint positions (revolute in [-pi, pi], prismatic within 0.05 m),
/// generalized velocity and a generalized force / acceleration, all of order 1.
struct RandomState {
  SE3 base;
  VecX q, v, u;
};

inline RandomState random_state(const se3::Model& m, std::mt19937_64& rng) {
  RandomState s;
  s.base = random_pose(rng);
  s.q.resize(m.n);
  for (int i = 1; i <= m.n; ++i) {
    s.q[i - 1] = m.joints[i].type == se3::JointType::Prismatic ? uniform(rng, -0.05, 0.05)
                                                               : uniform(rng, -M_PI, M_PI);
  }
  s.v = random_vec(rng, m.nv, 1.0);
  s.u = random_vec(rng, m.nv, 1.0);
  return s;
}

/// max |a - b| / max |b| (max-norm relative to the largest entry of the reference b).
template <class A, class B>
double rel_err(const A& a, const B& b) {
  const double scale = b.cwiseAbs().maxCoeff();
  const double diff = (a - b).cwiseAbs().maxCoeff();
  return scale > 0 ? diff / scale : diff;
}

template <class A>
double max_abs(const A& a) {
  return a.cwiseAbs().maxCoeff();
}

}  // namespace se3_test
