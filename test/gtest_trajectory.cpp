// ros_controllers' JointTrajectoryController inside the simulator (controllers.h, trajectory.h):
// the splines against their polynomials, a 5-waypoint trajectory on the UR5 under gravity,
// replacement mid-trajectory, holding when idle and after a reset; gazebo_ros_control's
// position and velocity interfaces (a PID from pid_gains); transmissions' hardware interfaces
// (transmissions.h); the list of supported types.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Dense>
#include <cmath>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "error_of.h"
#include "se3_sim/sim/controllers.h"
#include "se3_sim/sim/sim.h"
#include "se3_sim/sim/trajectory.h"
#include "se3_sim/sim/transmissions.h"
#include "source_paths.h"

using namespace se3;

namespace {

const std::string kSource = se3_sim_test::source_dir();
const std::vector<std::string> kJoints = {"shoulder_pan_joint", "shoulder_lift_joint",
                                          "elbow_joint",        "wrist_1_joint",
                                          "wrist_2_joint",      "wrist_3_joint"};

// The fixed UR5 under gravity (config/scenes/fixed_arm.yaml: rkmk4, dt 1 ms).
std::unique_ptr<Simulator> ur5() {
  return make_simulator(load_scene(kSource + "/config/scenes/fixed_arm.yaml"));
}

// Tracking gains: stiff on the three big joints, light on the wrists (their effective inertia
// is small: dt d / M stays well below the step's bound of 2).
const double kP[6] = {4000, 4000, 4000, 300, 300, 300};
const double kD[6] = {200, 200, 100, 4, 4, 2};
const double kI[6] = {20000, 20000, 20000, 100, 100, 100};
// The integral term's clamp (N m): above the gravity torques, so that the integral removes them.
const double kIClamp[6] = {100, 100, 100, 10, 10, 10};

std::string effort_trajectory_yaml(const std::string& extra = "") {
  std::string y = "arm:\n  type: effort_controllers/JointTrajectoryController\n  joints: [";
  for (size_t j = 0; j < kJoints.size(); ++j) y += (j ? ", " : "") + kJoints[j];
  y += "]\n  gains:\n";
  for (size_t j = 0; j < kJoints.size(); ++j) {
    y += "    " + kJoints[j] + ": {p: " + std::to_string(kP[j]) + ", i: " + std::to_string(kI[j]) +
         ", d: " + std::to_string(kD[j]) + ", i_clamp: " + std::to_string(kIClamp[j]) + "}\n";
  }
  return y + extra;
}

enum class Given { Positions, Velocities, Accelerations };

// Five waypoints 0.6 s apart around fixed_arm's start, with velocities and accelerations from
// a smooth curve through them when asked.
TrajectoryCommand five_waypoints(const State& x0, Given given, double start = NAN) {
  TrajectoryCommand cmd;
  cmd.joint_names = kJoints;
  cmd.start = start;
  for (int p = 1; p <= 5; ++p) {
    TrajectoryCommand::Point pt;
    pt.time_from_start = 0.6 * p;
    const double s = 0.6 * p;
    for (int j = 0; j < 6; ++j) {
      const double amp = 0.25 + 0.05 * j, w = 1.0 + 0.1 * j;
      pt.positions.push_back(x0.q[j] + amp * std::sin(w * s));
      if (given != Given::Positions) pt.velocities.push_back(amp * w * std::cos(w * s));
      if (given == Given::Accelerations) pt.accelerations.push_back(-amp * w * w * std::sin(w * s));
    }
    if (p == 5) {  // the last point at rest
      if (given != Given::Positions) std::fill(pt.velocities.begin(), pt.velocities.end(), 0.0);
      if (given == Given::Accelerations) {
        std::fill(pt.accelerations.begin(), pt.accelerations.end(), 0.0);
      }
    }
    cmd.points.push_back(pt);
  }
  return cmd;
}

// The interpolating polynomial of the boundary conditions, solved as a linear system (not by
// the closed forms of trajectory.cpp): coefficients c0..c5.
Eigen::Matrix<double, 6, 1> polynomial(int order, double q0, double v0, double a0, double q1,
                                       double v1, double a1, double T) {
  const int n = order + 1;  // 2, 4 or 6 coefficients
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd b(n);
  std::vector<double> rhs0 = {q0, v0, a0}, rhs1 = {q1, v1, a1};
  const int derivs = n / 2;
  for (int d = 0; d < derivs; ++d) {
    for (int k = d; k < n; ++k) {
      double f = 1;
      for (int m = 0; m < d; ++m) f *= k - m;
      A(d, k) = k == d ? f : 0.0;                 // at s = 0
      A(derivs + d, k) = f * std::pow(T, k - d);  // at s = T
    }
    b[d] = rhs0[d];
    b[derivs + d] = rhs1[d];
  }
  const Eigen::VectorXd c = A.fullPivLu().solve(b);
  Eigen::Matrix<double, 6, 1> out = Eigen::Matrix<double, 6, 1>::Zero();
  out.head(n) = c;
  return out;
}

double eval(const Eigen::Matrix<double, 6, 1>& c, double s) {
  double q = 0;
  for (int k = 5; k >= 0; --k) q = q * s + c[k];
  return q;
}

std::string controller_error(const std::function<void()>& f) {
  return se3_test::error_of<ControllerError>(f);
}

}  // namespace

// ------------------------------------------------------------------ splines

// Every segment of the three kinds of 5-point trajectories (the bridge from the held start
// included) equals the polynomial of its boundary conditions at 50 sample times, to 1e-12; the
// knots are the waypoints.
TEST(Trajectory, SplinesEqualTheirPolynomials) {
  auto sim = ur5();
  sim->set_controllers(parse_controllers_text(effort_trajectory_yaml()));
  ControllerSet& set = *sim->controllers();
  const State x0 = sim->state();
  for (Given given : {Given::Positions, Given::Velocities, Given::Accelerations}) {
    SCOPED_TRACE(static_cast<int>(given));
    set.reset(x0);
    const TrajectoryCommand cmd = five_waypoints(x0, given, 0.0);
    ASSERT_EQ(set.set_trajectory(0, cmd, 0.0), "");
    double worst = 0;
    for (int j = 0; j < 6; ++j) {
      double tp = 0, qp = x0.q[j], vp = 0, ap = 0;
      for (size_t p = 0; p < cmd.points.size(); ++p) {
        const auto& pt = cmd.points[p];
        const double t1 = pt.time_from_start, T = t1 - tp;
        const double q1 = pt.positions[j];
        const double v1 = given != Given::Positions ? pt.velocities[j] : 0.0;
        const double a1 = given == Given::Accelerations ? pt.accelerations[j] : 0.0;
        // ros_controllers' orders; the bridge from the held start is at least cubic.
        const int order = given == Given::Accelerations          ? 5
                          : given == Given::Velocities || p == 0 ? 3
                                                                 : 1;
        const auto c = polynomial(order, qp, order == 1 ? 0 : vp, ap, q1, v1, a1, T);
        for (int k = 0; k < 50; ++k) {
          const double s = T * k / 50.0;
          double q, v, a;
          set.sample(0, j, tp + s, q, v, a);
          worst = std::max(worst, std::abs(q - eval(c, s)));
        }
        double q, v, a;
        set.sample(0, j, t1, q, v, a);
        EXPECT_NEAR(q, q1, 1e-12) << kJoints[j] << " at point " << p;
        tp = t1, qp = q1, vp = v1, ap = a1;
      }
      // Past the end: the last point, held.
      double q, v, a;
      set.sample(0, j, 10.0, q, v, a);
      EXPECT_NEAR(q, cmd.points.back().positions[j], 1e-12);
      EXPECT_EQ(v, 0.0);
    }
    EXPECT_LT(worst, 1e-12);
    std::printf("  largest difference from the polynomials: %.2e rad\n", worst);
  }
}

TEST(Trajectory, SplineClosedFormsMeetTheirEnds) {
  double q, v, a;
  const Spline s = quintic_spline(0.3, -1.0, 2.0, 1.1, 0.5, -3.0, 0.7);
  sample_spline(s, 0.7, q, v, a);
  EXPECT_NEAR(q, 1.1, 1e-13);
  EXPECT_NEAR(v, 0.5, 1e-12);
  EXPECT_NEAR(a, -3.0, 1e-11);
  const Spline c = cubic_spline(0.3, -1.0, 1.1, 0.5, 0.7);
  sample_spline(c, 0.0, q, v, a);
  EXPECT_NEAR(v, -1.0, 1e-13);
  sample_spline(c, 0.7 - 1e-15, q, v, a);
  EXPECT_NEAR(q, 1.1, 1e-13);
  EXPECT_NEAR(v, 0.5, 1e-12);
}

// ------------------------------------------------------------------ the UR5 following them

// The UR5 under gravity follows a 5-waypoint trajectory of each kind with the effort flavour:
// at each waypoint's time every joint is within the gains' tracking error, bounded by what the
// PID must push against (gravity and the trajectory's inertial torque, at most the joint's
// effort limit) over p, and the end is reached to 1 mrad.
TEST(Trajectory, Ur5FollowsFiveWaypointsUnderGravity) {
  for (Given given : {Given::Positions, Given::Velocities, Given::Accelerations}) {
    SCOPED_TRACE(static_cast<int>(given));
    auto sim = ur5();
    sim->set_controllers(parse_controllers_text(effort_trajectory_yaml()));
    const State x0 = sim->state();
    const TrajectoryCommand cmd = five_waypoints(x0, given);
    ASSERT_EQ(sim->controllers()->set_trajectory(0, cmd, sim->time()), "");
    const Model& m = sim->model();
    double worst_ratio = 0;
    for (size_t p = 0; p < cmd.points.size(); ++p) {
      const int steps = static_cast<int>(std::lround(0.6 / sim->dt()));
      ASSERT_EQ(sim->step_n(steps), steps) << sim->failure();
      for (int j = 0; j < 6; ++j) {
        const double err = std::abs(sim->state().q[j] - cmd.points[p].positions[j]);
        const double bound = m.effort[j + 1] / kP[j];
        worst_ratio = std::max(worst_ratio, err / bound);
        EXPECT_LT(err, bound) << kJoints[j] << " at waypoint " << p;
      }
    }
    ASSERT_EQ(sim->step_n(1000), 1000);
    for (int j = 0; j < 6; ++j) {
      EXPECT_NEAR(sim->state().q[j], cmd.points.back().positions[j], 1e-3) << kJoints[j];
    }
    EXPECT_EQ(sim->controllers()->trajectory_state(0).status, TrajectoryStatus::Succeeded);
    std::printf("  largest waypoint error / (effort limit / p): %.3f\n", worst_ratio);
  }
}

// A new trajectory mid-way replaces the rest of the current one from its start time: the
// desired position and velocity are continuous there (sampled an instant before and after), for
// a start now and a start in the future; the robot keeps following.
TEST(Trajectory, ReplacementMidTrajectoryIsContinuous) {
  for (double delay : {0.0, 0.25}) {
    SCOPED_TRACE(delay);
    auto sim = ur5();
    sim->set_controllers(parse_controllers_text(effort_trajectory_yaml()));
    ControllerSet& set = *sim->controllers();
    const State x0 = sim->state();
    ASSERT_EQ(set.set_trajectory(0, five_waypoints(x0, Given::Velocities), sim->time()), "");
    ASSERT_EQ(sim->step_n(1234), 1234);
    const double now = sim->time(), ts = now + delay;
    // Before: the old trajectory around the switch.
    std::vector<double> q_old(6), v_old(6);
    for (int j = 0; j < 6; ++j) {
      double a;
      set.sample(0, j, ts, q_old[j], v_old[j], a);
    }
    State target = x0;
    target.q.array() -= 0.2;
    TrajectoryCommand next = five_waypoints(target, Given::Positions, ts);
    ASSERT_EQ(set.set_trajectory(0, next, now), "");
    const double eps = 1e-9;
    for (int j = 0; j < 6; ++j) {
      double qb, vb, ab, qa, va, aa, q, v, a;
      set.sample(0, j, ts - eps, qb, vb, ab);
      set.sample(0, j, ts + eps, qa, va, aa);
      set.sample(0, j, ts, q, v, a);
      EXPECT_NEAR(q, q_old[j], 1e-12) << kJoints[j];
      EXPECT_NEAR(v, v_old[j], 1e-12) << kJoints[j];
      EXPECT_NEAR(qa, qb, 1e-8) << kJoints[j];
      EXPECT_NEAR(va, vb, 1e-6) << kJoints[j];
    }
    ASSERT_EQ(sim->step_n(4000), 4000) << sim->failure();
    for (int j = 0; j < 6; ++j) {
      EXPECT_NEAR(sim->state().q[j], next.points.back().positions[j], 2e-3) << kJoints[j];
    }
  }
}

// Without a trajectory the controller holds where it started, and again after a reset, with the
// desired state reset there.
TEST(Trajectory, HoldsWhenIdleAndAfterReset) {
  auto sim = ur5();
  sim->set_controllers(parse_controllers_text(effort_trajectory_yaml()));
  const State x0 = sim->state();
  ASSERT_EQ(sim->step_n(1500), 1500);
  for (int j = 0; j < 6; ++j) EXPECT_NEAR(sim->state().q[j], x0.q[j], 2e-3) << kJoints[j];
  EXPECT_EQ(sim->controllers()->trajectory_state(0).status, TrajectoryStatus::Idle);
  ASSERT_EQ(
      sim->controllers()->set_trajectory(0, five_waypoints(x0, Given::Positions), sim->time()), "");
  ASSERT_EQ(sim->step_n(1000), 1000);
  sim->reset();
  const TrajectoryState& st = sim->controllers()->trajectory_state(0);
  EXPECT_EQ(st.status, TrajectoryStatus::Idle);
  for (int j = 0; j < 6; ++j) EXPECT_EQ(st.desired_q[j], x0.q[j]);
  ASSERT_EQ(sim->step_n(1500), 1500);
  for (int j = 0; j < 6; ++j) EXPECT_NEAR(sim->state().q[j], x0.q[j], 2e-3) << kJoints[j];
}

TEST(Trajectory, RefusesWhatItCannotFollow) {
  auto sim = ur5();
  sim->set_controllers(parse_controllers_text(effort_trajectory_yaml()));
  ControllerSet& set = *sim->controllers();
  const State x0 = sim->state();
  TrajectoryCommand cmd = five_waypoints(x0, Given::Positions);
  cmd.joint_names[2] = "nope";
  EXPECT_NE(set.set_trajectory(0, cmd, 0).find("'nope' is not one of its joints"),
            std::string::npos);
  cmd = five_waypoints(x0, Given::Positions);
  cmd.points[3].time_from_start = cmd.points[2].time_from_start;
  EXPECT_NE(set.set_trajectory(0, cmd, 0).find("point 3"), std::string::npos);
  cmd = five_waypoints(x0, Given::Positions, 0.0);
  EXPECT_NE(set.set_trajectory(0, cmd, 100.0).find("before the current time"), std::string::npos);
  cmd = five_waypoints(x0, Given::Positions);
  cmd.points[1].positions[0] = NAN;
  EXPECT_NE(set.set_trajectory(0, cmd, 0).find("non-finite"), std::string::npos);
  // Partial goals only when allowed; the other joints keep their trajectory (here: holding).
  cmd = five_waypoints(x0, Given::Positions);
  cmd.joint_names.resize(2);
  for (auto& p : cmd.points) p.positions.resize(2);
  EXPECT_NE(set.set_trajectory(0, cmd, 0).find("allow_partial_joints_goal"), std::string::npos);
  sim->set_controllers(
      parse_controllers_text(effort_trajectory_yaml("  allow_partial_joints_goal: true\n")));
  ASSERT_EQ(sim->controllers()->set_trajectory(0, cmd, 0), "");
  double q, v, a;
  sim->controllers()->sample(0, 4, 1.0, q, v, a);
  EXPECT_EQ(q, x0.q[4]);
  sim->controllers()->sample(0, 1, 3.0, q, v, a);
  EXPECT_EQ(q, cmd.points.back().positions[1]);
}

// A joint leaving its `trajectory` tolerance stops the controller (path tolerance violated);
// YAML keys as ros_controllers names them.
TEST(Trajectory, ConstraintsAndKeys) {
  const auto specs = parse_controllers_text(effort_trajectory_yaml(R"(  constraints:
    goal_time: 0.5
    stopped_velocity_tolerance: 0.02
    elbow_joint: {trajectory: 0.001, goal: 0.01}
  state_publish_rate: 25
  stop_trajectory_duration: 0.2
)"));
  ASSERT_EQ(specs.size(), 1u);
  EXPECT_EQ(specs[0].kind, ControllerKind::Trajectory);
  EXPECT_EQ(specs[0].constraints.goal_time, 0.5);
  EXPECT_EQ(specs[0].constraints.stopped_velocity_tolerance, 0.02);
  EXPECT_EQ(specs[0].constraints.trajectory[2], 0.001);
  EXPECT_EQ(specs[0].constraints.goal[2], 0.01);
  EXPECT_EQ(specs[0].state_publish_rate, 25);
  EXPECT_EQ(specs[0].stop_trajectory_duration, 0.2);
  auto sim = ur5();
  sim->set_controllers(specs);
  TrajectoryCommand fast = five_waypoints(sim->state(), Given::Positions);
  for (auto& p : fast.points) p.time_from_start *= 0.2;  // too fast to track within 1 mrad
  ASSERT_EQ(sim->controllers()->set_trajectory(0, fast, 0), "");
  ASSERT_EQ(sim->step_n(600), 600);
  const TrajectoryState& st = sim->controllers()->trajectory_state(0);
  EXPECT_EQ(st.status, TrajectoryStatus::PathToleranceViolated);
  EXPECT_EQ(st.status_joint, 2);
  // A key ros_controllers does not know, and gains missing for the effort flavour.
  EXPECT_NE(controller_error([] {
              parse_controllers_text(effort_trajectory_yaml("  constraint: {}\n"), {}, "c.yaml");
            }).find("unknown key 'constraint'"),
            std::string::npos);
  EXPECT_NE(controller_error([] {
              parse_controllers_text(
                  "arm: {type: effort_controllers/JointTrajectoryController, joints: [a]}", {},
                  "c.yaml");
            }).find("no gains for joint 'a'"),
            std::string::npos);
}

// ------------------------------------------------------------------ position / velocity interfaces

// velocity_controllers/JointVelocityController through the velocity interface's PID
// (pid_gains) reaches its commanded velocity; JointGroupVelocityController too (to 1% of the
// command: the arm's own motion pushes on each joint through the coupling inertia), while a
// position-interface group holds the shoulder and elbow up.
TEST(Interfaces, VelocityControllerReachesItsVelocity) {
  auto sim = ur5();
  auto specs = parse_controllers_text(R"(
pan: {type: velocity_controllers/JointVelocityController, joint: shoulder_pan_joint}
wrists: {type: velocity_controllers/JointGroupVelocityController,
         joints: [wrist_1_joint, wrist_2_joint, wrist_3_joint]}
hold: {type: position_controllers/JointGroupPositionController,
       joints: [shoulder_lift_joint, elbow_joint]}
)");
  set_interface_gains(specs, parse_interface_gains(YAML::Load(R"(
shoulder_pan_joint: {p: 300, i: 300, i_clamp: 50}
shoulder_lift_joint: {p: 4000, i: 20000, d: 200, i_clamp: 100}
elbow_joint: {p: 4000, i: 20000, d: 100, i_clamp: 100}
wrist_1_joint: {p: 50, i: 50, i_clamp: 10}
wrist_2_joint: {p: 50, i: 50, i_clamp: 10}
wrist_3_joint: {p: 20, i: 20, i_clamp: 5}
)")));
  sim->set_controllers(specs);
  const double v = 0.5, w[3] = {-0.2, 0.3, 0.4};
  ASSERT_EQ(sim->controllers()->set_command(0, &v, 1), "");
  ASSERT_EQ(sim->controllers()->set_command(1, w, 3), "");
  ASSERT_EQ(sim->step_n(1500), 1500) << sim->failure();
  const Model& m = sim->model();
  EXPECT_NEAR(sim->state().v[m.idx_v(m.joint_index("shoulder_pan_joint"))], v, 0.01 * v);
  for (int k = 0; k < 3; ++k) {
    const int i = m.joint_index("wrist_" + std::to_string(k + 1) + "_joint");
    EXPECT_NEAR(sim->state().v[m.idx_v(i)], w[k], 0.01 * std::abs(w[k])) << k;
  }
}

// position_controllers/JointGroupPositionController (gains from pid_gains) and
// position_controllers/JointTrajectoryController (its own gains as the interface's) follow.
TEST(Interfaces, PositionInterfaceControllersFollow) {
  std::string pid_gains;
  for (int j = 0; j < 6; ++j) {
    pid_gains += kJoints[j] + ": {p: " + std::to_string(kP[j]) + ", i: " + std::to_string(kI[j]) +
                 ", d: " + std::to_string(kD[j]) + ", i_clamp: " + std::to_string(kIClamp[j]) +
                 "}\n";
  }
  {
    auto sim = ur5();
    auto specs = parse_controllers_text(
        "arm: {type: position_controllers/JointGroupPositionController, joints: [" + kJoints[0] +
        ", " + kJoints[1] + ", " + kJoints[2] + ", " + kJoints[3] + ", " + kJoints[4] + ", " +
        kJoints[5] + "]}");
    set_interface_gains(specs, parse_interface_gains(YAML::Load(pid_gains)));
    sim->set_controllers(specs);
    std::vector<double> target(6);
    for (int j = 0; j < 6; ++j) target[j] = sim->state().q[j] + 0.1 * (j % 2 ? 1 : -1);
    ASSERT_EQ(sim->controllers()->set_command(0, target.data(), 6), "");
    ASSERT_EQ(sim->step_n(3000), 3000) << sim->failure();
    for (int j = 0; j < 6; ++j) EXPECT_NEAR(sim->state().q[j], target[j], 2e-3) << kJoints[j];
  }
  {
    auto sim = ur5();
    std::string yaml = effort_trajectory_yaml();
    yaml.replace(yaml.find("effort_controllers"), 18, "position_controllers");
    sim->set_controllers(parse_controllers_text(yaml));
    const TrajectoryCommand cmd = five_waypoints(sim->state(), Given::Velocities);
    ASSERT_EQ(sim->controllers()->set_trajectory(0, cmd, 0), "");
    ASSERT_EQ(sim->step_n(4000), 4000) << sim->failure();
    for (int j = 0; j < 6; ++j) {
      EXPECT_NEAR(sim->state().q[j], cmd.points.back().positions[j], 2e-3) << kJoints[j];
    }
  }
}

// Without pid_gains and gains of its own, a position-interface controller is refused, naming
// the parameter that gives them.
TEST(Interfaces, WithoutGainsIsAnErrorNamingPidGains) {
  auto sim = ur5();
  const auto specs = parse_controllers_text(
      "pan: {type: position_controllers/JointPositionController, joint: shoulder_pan_joint}");
  const std::string e = controller_error([&] { sim->set_controllers(specs); });
  EXPECT_NE(e.find("/gazebo_ros_control/pid_gains/shoulder_pan_joint"), std::string::npos) << e;
  EXPECT_NE(e.find("PositionJointInterface"), std::string::npos) << e;
}

// ------------------------------------------------------------------ transmissions

namespace {

std::string two_joint_urdf(const std::string& transmissions) {
  return R"(<?xml version="1.0"?>
<robot name="two">
  <link name="base"/>
  <link name="l1"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l2"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j1" type="continuous"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/></joint>
  <joint name="j2" type="continuous"><parent link="l1"/><child link="l2"/><axis xyz="0 1 0"/></joint>
)" + transmissions +
         "</robot>\n";
}

}  // namespace

// Both formats, names with and without the hardware_interface/ prefix, the reduction.
TEST(Transmissions, BothFormatsAndPrefixes) {
  const auto t = parse_transmissions(two_joint_urdf(R"(
  <transmission name="t1">
    <type>transmission_interface/SimpleTransmission</type>
    <joint name="j1"/>
    <actuator name="m1">
      <hardwareInterface>VelocityJointInterface</hardwareInterface>
      <mechanicalReduction>50</mechanicalReduction>
    </actuator>
  </transmission>
  <transmission name="t2">
    <type>transmission_interface/SimpleTransmission</type>
    <joint name="j2">
      <hardwareInterface>hardware_interface/EffortJointInterface</hardwareInterface>
      <hardwareInterface>hardware_interface/PositionJointInterface</hardwareInterface>
    </joint>
    <actuator name="m2"><mechanicalReduction>2.5</mechanicalReduction></actuator>
  </transmission>
)"));
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0].joint, "j1");
  EXPECT_EQ(t[0].transmission, "t1");
  EXPECT_EQ(t[0].interfaces, std::vector<std::string>{"VelocityJointInterface"});
  EXPECT_EQ(t[0].reduction, 50);
  EXPECT_EQ(t[1].interfaces,
            (std::vector<std::string>{"EffortJointInterface", "PositionJointInterface"}));
  EXPECT_EQ(t[1].reduction, 2.5);
  EXPECT_TRUE(parse_transmissions(two_joint_urdf("")).empty());
}

// A transmission declaring a velocity interface refuses an effort controller with the message a
// Gazebo user knows, naming the joint, the controller and both interfaces; a matching one and a
// URDF without transmissions accept it.
TEST(Transmissions, VelocityInterfaceRefusesAnEffortController) {
  const std::string velocity = R"(
  <transmission name="j1_trans">
    <type>transmission_interface/SimpleTransmission</type>
    <joint name="j1"><hardwareInterface>hardware_interface/VelocityJointInterface</hardwareInterface></joint>
    <actuator name="m1"><mechanicalReduction>1</mechanicalReduction></actuator>
  </transmission>
)";
  const auto effort = parse_controllers_text(
      "arm: {type: effort_controllers/JointTrajectoryController, joints: [j1, j2],"
      " gains: {j1: {p: 10}, j2: {p: 10}}}");
  const std::string e = controller_error(
      [&] { check_interfaces(effort, parse_transmissions(two_joint_urdf(velocity))); });
  EXPECT_NE(e.find("no matching hardware interface"), std::string::npos) << e;
  EXPECT_NE(e.find("'j1'"), std::string::npos) << e;
  EXPECT_NE(e.find("'arm' (effort_controllers/JointTrajectoryController)"), std::string::npos) << e;
  EXPECT_NE(e.find("needs EffortJointInterface"), std::string::npos) << e;
  EXPECT_NE(e.find("declares VelocityJointInterface"), std::string::npos) << e;
  std::printf("  %s\n", e.c_str());
  // The velocity flavour matches; no transmissions: anything goes.
  auto vel = parse_controllers_text(
      "arm: {type: velocity_controllers/JointTrajectoryController, joints: [j1],"
      " gains: {j1: {p: 10}}}");
  EXPECT_EQ(controller_error(
                [&] { check_interfaces(vel, parse_transmissions(two_joint_urdf(velocity))); }),
            "");
  EXPECT_EQ(
      controller_error([&] { check_interfaces(effort, parse_transmissions(two_joint_urdf(""))); }),
      "");
}

// The shipped config/controllers/ur5.yaml: its trajectory controller takes its interface's gains
// from the file's gazebo_ros_control/pid_gains, matches the UR5's transmissions (position
// interface), and an effort controller on the same joints does not.
TEST(Transmissions, ShippedUr5ConfigMatchesTheUr5) {
  std::ifstream in(kSource + "/config/controllers/ur5.yaml");
  std::stringstream text;
  text << in.rdbuf();
  const YAML::Node root = YAML::Load(text.str());
  auto specs = parse_controllers(root, {"arm_controller"}, "ur5.yaml");
  set_interface_gains(specs, parse_interface_gains(root["gazebo_ros_control"]["pid_gains"]));
  std::ifstream urdf_in(kSource + "/data/robots/ur5_robot.urdf");
  std::stringstream urdf;
  urdf << urdf_in.rdbuf();
  const auto transmissions = parse_transmissions(urdf.str());
  EXPECT_EQ(transmissions.size(), 6u);
  EXPECT_EQ(controller_error([&] { check_interfaces(specs, transmissions); }), "");
  auto sim = ur5();
  EXPECT_EQ(controller_error([&] { sim->set_controllers(specs); }), "");
  const auto effort = parse_controllers_text(effort_trajectory_yaml());
  EXPECT_NE(controller_error([&] {
              check_interfaces(effort, transmissions);
            }).find("declares PositionJointInterface"),
            std::string::npos);
}

// ------------------------------------------------------------------ types

TEST(Controllers, UnsupportedTypeListsTheSupportedOnes) {
  const std::string e = controller_error([] {
    parse_controllers_text(
        "x: {type: effort_controllers/JointGroupVelocityController, joints: [a]}", {}, "c.yaml");
  });
  EXPECT_NE(e.find("'effort_controllers/JointGroupVelocityController' is not supported"),
            std::string::npos)
      << e;
  for (const char* t : {"effort_controllers/JointTrajectoryController",
                        "velocity_controllers/JointTrajectoryController",
                        "position_controllers/JointTrajectoryController",
                        "velocity_controllers/JointVelocityController",
                        "velocity_controllers/JointGroupVelocityController",
                        "position_controllers/JointPositionController",
                        "position_controllers/JointGroupPositionController",
                        "effort_controllers/JointGroupPositionController"}) {
    EXPECT_NE(e.find(t), std::string::npos) << t << " missing from: " << e;
  }
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
