// Controllers inside the simulator (controllers.h) and the Simulator's command API: control
// toolbox's PID, ros_control's YAML shapes and their errors, position / velocity / effort
// controllers on the Panda under gravity, per-joint merging and simulated-time expiry of
// commands, link wrenches as J^T w (checked by virtual power), and bit-identical runs after a
// reset.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>

#include "se3_sim/sim/controllers.h"
#include "se3_sim/sim/gain_check.h"
#include "se3_sim/sim/sim.h"
#include "source_paths.h"
#include "test_util.h"

using namespace se3;

namespace {

const std::string kSource = se3_sim_test::source_dir();
const std::string kScenes = kSource + "/config/scenes/";

std::string controller_error(const std::string& yaml, const std::vector<std::string>& names = {}) {
  try {
    parse_controllers_text(yaml, names, "c.yaml");
  } catch (const ControllerError& e) {
    return e.what();
  }
  return "";
}

// The fixed-base Panda of config/scenes/fixed_panda.yaml (gravity, fingers locked).
std::unique_ptr<Simulator> panda() {
  return make_simulator(load_scene(kScenes + "fixed_panda.yaml"));
}

const char* kPandaControllers = R"(
arm:
  type: effort_controllers/JointGroupPositionController
  joints: [panda_joint1, panda_joint2, panda_joint3, panda_joint4, panda_joint5, panda_joint6]
  pid: {p: 600, i: 3000, d: 30, i_clamp: 87}
  panda_joint5: {pid: {p: 250, d: 10}}
  panda_joint6: {pid: {p: 150, d: 10}}
wrist:
  type: effort_controllers/JointEffortController
  joint: panda_joint7
)";

}  // namespace

// ------------------------------------------------------------------ PID

TEST(Pid, TermsAsControlToolbox) {
  PidGains g;
  g.p = 2;
  g.d = 0.5;
  Pid pid(g);
  // First call: the derivative from a last error of 0 (control_toolbox's derivative kick).
  EXPECT_DOUBLE_EQ(pid.compute(1.0, 0.1), 2 * 1.0 + 0.5 * (1.0 - 0.0) / 0.1);
  EXPECT_DOUBLE_EQ(pid.compute(0.5, 0.1), 2 * 0.5 + 0.5 * (0.5 - 1.0) / 0.1);
  // A given derivative is used as is; no time step or a non-finite error gives 0.
  EXPECT_DOUBLE_EQ(pid.compute(0.5, 3.0, 0.1), 2 * 0.5 + 0.5 * 3.0);
  EXPECT_EQ(pid.compute(1.0, 0.0), 0.0);
  EXPECT_EQ(pid.compute(std::nan(""), 0.1), 0.0);
  EXPECT_EQ(pid.compute(1.0, std::numeric_limits<double>::infinity(), 0.1), 0.0);
}

TEST(Pid, IntegralClampWithAndWithoutAntiwindup) {
  PidGains g;
  g.i = 10;
  // No i_clamp: the clamp is [0, 0] and the integral term stays 0 (control_toolbox's default).
  Pid none(g);
  for (int k = 0; k < 10; ++k) EXPECT_EQ(none.compute(1.0, 0.0, 0.1), 0.0);
  // Without antiwindup the term is clamped but the integral keeps growing.
  g.i_clamp_min = -2;
  g.i_clamp_max = 3;
  Pid clamped(g);
  double u = 0;
  for (int k = 0; k < 10; ++k) u = clamped.compute(1.0, 0.0, 0.1);
  EXPECT_DOUBLE_EQ(u, 3.0);
  EXPECT_NEAR(clamped.integral(), 1.0, 1e-12);  // 10 x 0.1, beyond 3 / 10
  // ... so it takes as long to unwind: one step of -1 still gives the clamp.
  EXPECT_DOUBLE_EQ(clamped.compute(-1.0, 0.0, 0.1), 3.0);
  // With antiwindup the integral itself stops at i_clamp / i.
  g.antiwindup = true;
  Pid anti(g);
  for (int k = 0; k < 10; ++k) u = anti.compute(1.0, 0.0, 0.1);
  EXPECT_DOUBLE_EQ(u, 3.0);
  EXPECT_NEAR(anti.integral(), 0.3, 1e-12);
  EXPECT_NEAR(anti.compute(-1.0, 0.0, 0.1), 10 * 0.2, 1e-12);
  anti.reset();
  EXPECT_EQ(anti.integral(), 0.0);
}

// ------------------------------------------------------------------ YAML

TEST(ControllerYaml, RosControlShapes) {
  const auto specs = parse_controllers_text(R"(
joint_state_controller: {type: joint_state_controller/JointStateController, publish_rate: 50}
group:
  type: effort_controllers/JointGroupPositionController
  joints: [a, b, c]
  pid: {p: 10, d: 1}
  b: {pid: {p: 20, i: 2, i_clamp: 5}}
  gains: {c: {p: 30, i_clamp_min: -1, i_clamp_max: 4, antiwindup: true}}
single: {type: effort_controllers/JointPositionController, joint: a, pid: {p: 7, d: 0.5}}
velocity: {type: effort_controllers/JointVelocityController, joint: b, pid: {p: 3}}
effort: {type: effort_controllers/JointGroupEffortController, joints: [a, b]}
)",
                                            {}, "c.yaml");
  ASSERT_EQ(specs.size(), 5u);
  EXPECT_EQ(specs[0].kind, ControllerKind::JointState);
  const ControllerSpec& g = specs[1];
  EXPECT_EQ(g.name, "group");
  EXPECT_EQ(g.kind, ControllerKind::GroupPosition);
  ASSERT_EQ(g.joints, (std::vector<std::string>{"a", "b", "c"}));
  ASSERT_EQ(g.gains.size(), 3u);
  EXPECT_EQ(g.gains[0].p, 10);
  EXPECT_EQ(g.gains[0].d, 1);
  // A joint's own gains start from the common ones.
  EXPECT_EQ(g.gains[1].p, 20);
  EXPECT_EQ(g.gains[1].d, 1);
  EXPECT_EQ(g.gains[1].i, 2);
  EXPECT_EQ(g.gains[1].i_clamp_max, 5);
  EXPECT_EQ(g.gains[1].i_clamp_min, -5);
  EXPECT_EQ(g.gains[2].p, 30);
  EXPECT_EQ(g.gains[2].i_clamp_min, -1);
  EXPECT_EQ(g.gains[2].i_clamp_max, 4);
  EXPECT_TRUE(g.gains[2].antiwindup);
  EXPECT_EQ(specs[2].kind, ControllerKind::Position);
  EXPECT_EQ(specs[2].joints, std::vector<std::string>{"a"});
  EXPECT_EQ(specs[2].gains[0].d, 0.5);
  EXPECT_EQ(specs[3].kind, ControllerKind::Velocity);
  EXPECT_EQ(specs[4].kind, ControllerKind::GroupEffort);
  EXPECT_TRUE(specs[4].gains.empty());
  // Only the named ones, in the order named.
  const auto two = parse_controllers_text(kPandaControllers, {"wrist", "arm"});
  ASSERT_EQ(two.size(), 2u);
  EXPECT_EQ(two[0].name, "wrist");
  EXPECT_EQ(two[1].name, "arm");
}

TEST(ControllerYaml, ErrorsNameTheControllerTheKeyAndTheLine) {
  EXPECT_NE(controller_error("x: {type: diff_drive_controller/DiffDriveController, joint: a}")
                .find("c.yaml:1: controller 'x': type 'diff_drive_controller/"
                      "DiffDriveController' is not supported"),
            std::string::npos);
  EXPECT_NE(controller_error("x: {joints: [a]}").find("controller 'x': needs a 'type'"),
            std::string::npos);
  EXPECT_NE(controller_error("x: {type: effort_controllers/JointGroupEffortController}")
                .find("needs 'joints"),
            std::string::npos);
  EXPECT_NE(controller_error("x: {type: effort_controllers/JointEffortController, joints: [a]}")
                .find("needs 'joint: NAME'"),
            std::string::npos);
  EXPECT_NE(controller_error("x:\n  type: effort_controllers/JointPositionController\n"
                             "  joint: a\n  pid: {i: 3}\n")
                .find("c.yaml:4: controller 'x': 'pid' needs a p gain"),
            std::string::npos);
  EXPECT_NE(controller_error("x: {type: effort_controllers/JointPositionController, joint: a}")
                .find("no gains for joint 'a'"),
            std::string::npos);
  EXPECT_NE(controller_error("x: {type: effort_controllers/JointPositionController, joint: a, "
                             "pid: {p: 1, q: 2}}")
                .find("unknown key 'q'"),
            std::string::npos);
  EXPECT_NE(controller_error("x: {type: effort_controllers/JointPositionController, joint: a, "
                             "pid: {p: .nan}}")
                .find("finite number"),
            std::string::npos);
  EXPECT_NE(controller_error("x: {type: effort_controllers/JointGroupEffortController, "
                             "joints: [a, a]}")
                .find("joint 'a' is listed twice"),
            std::string::npos);
  EXPECT_NE(controller_error("x: {type: effort_controllers/JointGroupEffortController, "
                             "joints: [a], pid: {p: 1}}")
                .find("takes no gains"),
            std::string::npos);
  EXPECT_NE(controller_error(kPandaControllers, {"arm", "nope"})
                .find("no controller 'nope' in the configuration"),
            std::string::npos);
  EXPECT_NE(controller_error("[1, 2]").find("need a map"), std::string::npos);
  EXPECT_NE(controller_error("x: {type: [").find("c.yaml"), std::string::npos);
}

TEST(ControllerSet, BindsJointsAndRefusesBadCommands) {
  auto sim = panda();
  const Model& m = sim->model();
  auto specs = parse_controllers_text(kPandaControllers);
  ControllerSet set(m, specs);
  ASSERT_EQ(set.size(), 2);
  const int arm = set.find("arm"), wrist = set.find("wrist");
  ASSERT_GE(arm, 0);
  ASSERT_GE(wrist, 0);
  EXPECT_EQ(set.find("nope"), -1);
  EXPECT_EQ(set.command_size(arm), 6);
  EXPECT_EQ(set.command_size(wrist), 1);
  EXPECT_TRUE(set.controls(m.joint_index("panda_joint7")));
  const double six[6] = {0.1, 0.2, 0.3, -1.0, 0.5, 0.6};
  EXPECT_EQ(set.set_command(arm, six, 6), "");
  EXPECT_EQ(set.command(arm)[3], -1.0);
  EXPECT_NE(set.set_command(arm, six, 5).find("takes 6 values, got 5"), std::string::npos);
  const double bad[6] = {0, 0, std::nan(""), 0, 0, 0};
  EXPECT_NE(set.set_command(arm, bad, 6).find("non-finite value for 'panda_joint3'"),
            std::string::npos);
  EXPECT_EQ(set.command(arm)[2], 0.3);  // the refused command changed nothing
  // Unknown, locked or twice-claimed joints are refused when binding.
  auto unknown = specs;
  unknown[1].joints = {"no_such_joint"};
  EXPECT_THROW(ControllerSet(m, unknown), ControllerError);
  auto locked = specs;
  locked[1].joints = {"panda_finger_joint1"};
  EXPECT_THROW(ControllerSet(m, locked), ControllerError);
  auto twice = specs;
  twice[1].joints = {"panda_joint2"};
  try {
    ControllerSet s(m, twice);
    ADD_FAILURE() << "a joint claimed twice was accepted";
  } catch (const ControllerError& e) {
    EXPECT_NE(std::string(e.what()).find("already driven by controller 'arm'"), std::string::npos);
  }
}

// Binding errors name the file and line of the controller's joint (they had neither).
TEST(ControllerSet, BindingErrorsNameTheFileAndLine) {
  auto sim = panda();
  const auto specs = parse_controllers_text(
      "arm:\n"
      "  type: effort_controllers/JointGroupEffortController\n"
      "  joints:\n"
      "    - panda_joint1\n"
      "    - no_such_joint\n",
      {}, "ctl.yaml");
  try {
    ControllerSet set(sim->model(), specs);
    ADD_FAILURE() << "an unknown joint was bound";
  } catch (const ControllerError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("ctl.yaml:5: controller 'arm': joint 'no_such_joint'", 0),
              0u)
        << e.what();
  }
}

// ------------------------------------------------------------------ in the Simulator

TEST(Controllers, PositionControllerReachesAndHoldsItsTargetsUnderGravity) {
  auto sim = panda();
  const Model& m = sim->model();
  sim->set_controllers(parse_controllers_text(kPandaControllers, {"arm"}));
  ControllerSet& c = *sim->controllers();
  // After set_controllers (ros_control's starting()) it holds the initial pose.
  const VecX q0 = sim->state().q;
  ASSERT_EQ(sim->step_n(500), 500) << sim->failure();
  for (int i = 1; i <= 6; ++i) EXPECT_NEAR(sim->state().q[i - 1], q0[i - 1], 0.05) << i;
  const double target[6] = {0.5, -0.3, 0.2, -1.8, 0.4, 1.2};
  ASSERT_EQ(c.set_command(0, target, 6), "");
  ASSERT_EQ(sim->step_n(5000), 5000) << sim->failure();
  // Reached (the integral removes gravity's offset) ...
  for (int k = 0; k < 6; ++k) {
    const int i = m.joint_index("panda_joint" + std::to_string(k + 1));
    EXPECT_NEAR(sim->state().q[i - 1], target[k], 1e-3) << "joint " << k + 1;
  }
  // ... and held.
  double worst = 0, fastest = 0;
  for (int s = 0; s < 1000; ++s) {
    ASSERT_TRUE(sim->step());
    for (int k = 0; k < 6; ++k) {
      const int i = m.joint_index("panda_joint" + std::to_string(k + 1));
      worst = std::max(worst, std::abs(sim->state().q[i - 1] - target[k]));
      fastest = std::max(fastest, std::abs(sim->state().v[m.idx_v(i)]));
    }
  }
  EXPECT_LT(worst, 1e-3);
  EXPECT_LT(fastest, 1e-2);
  // Without the controller the arm falls away from there.
  sim->set_controllers({});
  ASSERT_EQ(sim->step_n(300), 300);
  EXPECT_GT(std::abs(sim->state().q[m.joint_index("panda_joint2") - 1] - target[1]), 0.05);
}

TEST(Controllers, EffortControllerCommandIsTheAppliedEffortClampedToTheUrdfLimit) {
  auto sim = panda();
  const Model& m = sim->model();
  sim->set_controllers(parse_controllers_text(kPandaControllers, {"wrist"}));
  const int j7 = m.joint_index("panda_joint7");
  const double e = 3.5;
  ASSERT_EQ(sim->controllers()->set_command(0, &e, 1), "");
  ASSERT_TRUE(sim->step());
  EXPECT_EQ(sim->actuation()[m.idx_v(j7)], 3.5);
  VecX eff;
  sim->applied_joint_efforts(eff);
  EXPECT_NEAR(eff[j7 - 1], 3.5 - m.damping[j7] * sim->state().v[m.idx_v(j7)], 1e-12);
  const double big = 1000;  // URDF limit 12 N m
  ASSERT_EQ(sim->controllers()->set_command(0, &big, 1), "");
  ASSERT_TRUE(sim->step());
  EXPECT_EQ(sim->actuation()[m.idx_v(j7)], 12.0);
  // A torque command on the same joint adds to it; the sum is clamped.
  const double minus = -20;
  ASSERT_EQ(sim->controllers()->set_command(0, &minus, 1), "");
  sim->set_joint_effort(j7, 5.0);
  ASSERT_TRUE(sim->step());
  EXPECT_EQ(sim->actuation()[m.idx_v(j7)], -12.0);  // -20 + 5, clamped
  sim->clear_command();
  const double nine = -9;
  ASSERT_EQ(sim->controllers()->set_command(0, &nine, 1), "");
  sim->set_joint_effort(j7, 5.0);
  ASSERT_TRUE(sim->step());
  EXPECT_EQ(sim->actuation()[m.idx_v(j7)], -4.0);
  // After a reset the effort command is 0 again.
  sim->reset();
  ASSERT_TRUE(sim->step());
  EXPECT_EQ(sim->actuation()[m.idx_v(j7)], 0.0);
}

TEST(Controllers, VelocityControllerReachesItsVelocity) {
  // One link turning about a fixed vertical axis, no gravity: nothing else acts on the joint.
  Model m = make_chain(1, false);
  m.gravity.setZero();
  SimConfig cfg;
  cfg.integrator = "symplectic_euler";
  Simulator sim(m, State(m), cfg);
  sim.set_controllers(
      parse_controllers_text("v: {type: effort_controllers/JointVelocityController, joint: j1,"
                             " pid: {p: 20, i: 400, i_clamp: 50}}"));
  const double w = 1.5;
  ASSERT_EQ(sim.controllers()->set_command(0, &w, 1), "");
  ASSERT_EQ(sim.step_n(3000), 3000) << sim.failure();
  EXPECT_NEAR(sim.state().v[0], 1.5, 1e-3);
  // j1 has no limits: a position controller takes the shortest way round.
  sim.set_controllers(parse_controllers_text(
      "p: {type: effort_controllers/JointPositionController, joint: j1, pid: {p: 20, d: 8}}"));
  State x = sim.state();
  x.q[0] = 3.0;
  x.v.setZero();
  sim.set_state(x);
  sim.controllers()->reset(x);
  const double target = -3.0;  // 0.28 rad away through pi, 6 rad the long way
  ASSERT_EQ(sim.controllers()->set_command(0, &target, 1), "");
  ASSERT_EQ(sim.step_n(4000), 4000) << sim.failure();
  EXPECT_NEAR(sim.state().q[0], 2 * M_PI - 3.0, 1e-2);
}

TEST(Commands, MergePerJointAndExpireAfterTheTimeoutInSimulatedTime) {
  auto sim = panda();
  const Model& m = sim->model();
  const int j2 = m.joint_index("panda_joint2"), j4 = m.joint_index("panda_joint4");
  sim->set_command_timeout(0.0105);  // 11 steps of 1 ms
  sim->set_joint_effort(j2, 5.0);
  sim->set_joint_effort(j4, -3.0);
  sim->set_joint_effort(j2, 6.0);  // replaces j2's, leaves j4's
  EXPECT_EQ(sim->command()[m.idx_v(j2)], 6.0);
  EXPECT_EQ(sim->command()[m.idx_v(j4)], -3.0);
  // No step, no expiry, however long the wall clock waits.
  EXPECT_EQ(sim->command()[m.idx_v(j4)], -3.0);
  ASSERT_EQ(sim->step_n(5), 5);
  sim->set_joint_effort(j4, -2.0);  // renewed at step 5: acts until step 16
  ASSERT_EQ(sim->step_n(6), 6);     // steps 6..11: j2's acted on steps 1..11
  EXPECT_EQ(sim->actuation()[m.idx_v(j2)], 6.0);
  ASSERT_TRUE(sim->step());  // step 12
  EXPECT_EQ(sim->actuation()[m.idx_v(j2)], 0.0);
  EXPECT_EQ(sim->actuation()[m.idx_v(j4)], -2.0);
  ASSERT_EQ(sim->step_n(4), 4);  // steps 13..16
  EXPECT_EQ(sim->actuation()[m.idx_v(j4)], -2.0);
  ASSERT_TRUE(sim->step());
  EXPECT_EQ(sim->actuation()[m.idx_v(j4)], 0.0);
  // Without a timeout a command stays.
  sim->set_command_timeout(0);
  sim->set_joint_effort(j2, 1.0);
  ASSERT_EQ(sim->step_n(100), 100);
  EXPECT_EQ(sim->actuation()[m.idx_v(j2)], 1.0);
  EXPECT_THROW(sim->set_joint_effort(j2, std::nan("")), std::invalid_argument);
  EXPECT_THROW(sim->set_base_wrench(Vec6::Constant(std::nan(""))), std::invalid_argument);
}

// J^T w by virtual power: for every generalized velocity v, tau . v equals the power of the
// wrench on the moving point, F . p_dot + N . omega, found here by central differences of the
// point's world pose along the motion exp(+-eps v), on a free base and on a fixed one.
TEST(LinkWrench, IsTheJacobianTransposeOfThePoint) {
  for (bool floating : {true, false}) {
    SCOPED_TRACE(floating ? "free base" : "fixed base");
    UrdfOptions opt;
    opt.floating = floating;
    opt.locked = {{"panda_finger_joint1", 0.02}};  // the other finger stays prismatic
    const Model m = model_from_urdf_file(se3_test::robot_path("panda.urdf"), opt);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1, 1);
    State x(m);
    for (int k = 0; k < m.n; ++k) x.q[k] = u(rng);
    x.base = SE3(exp_so3(Vec3(0.3, -0.2, 0.5)), Vec3(0.1, 0.2, 0.3));
    Data d(m);
    for (const char* name : {"panda_link6", "panda_rightfinger", "panda_link0"}) {
      SCOPED_TRACE(name);
      const int link = m.link_index(name);
      ASSERT_GE(link, 0);
      const Vec3 point(0.05, -0.02, 0.1);
      Vec6 w;
      w << 0.3, -0.7, 0.2, 2.0, 1.0, -1.5;
      forward_kinematics(m, d, x.base, x.q);
      VecX tau = VecX::Zero(m.nv);
      add_link_wrench_force(m, d, link, point, w, tau);
      const LinkFrame& L = m.links[link];
      for (int trial = 0; trial < 3; ++trial) {
        VecX v(m.nv);
        for (int k = 0; k < m.nv; ++k) v[k] = u(rng);
        const double eps = 1e-5;
        SE3 T[2];
        for (int s = 0; s < 2; ++s) {
          const double e = s == 0 ? -eps : eps;
          SE3 base = x.base;
          if (floating) base = x.base * exp_se3(e * v.head<6>());
          VecX q = x.q;
          const int off = m.nv_base();
          for (int k = 0; k < m.n; ++k) q[k] += e * v[off + k];
          forward_kinematics(m, d, base, q);
          T[s] = d.oMb[L.body] * L.offset;
        }
        const Vec3 pdot = (T[1].act(point) - T[0].act(point)) / (2 * eps);
        const Vec3 omega = log_so3(T[1].R * T[0].R.transpose()) / (2 * eps);
        const double power = w.tail<3>().dot(pdot) + w.head<3>().dot(omega);
        EXPECT_NEAR(tau.dot(v), power, 1e-7 * (1 + std::abs(power)));
      }
    }
  }
}

// The simulator applies a link wrench for its duration (whole steps), adds several up, clears
// them on reset, and refuses bad ones.
TEST(LinkWrench, ActsForItsDurationInTheSimulator) {
  const Scene scene = load_scene(kScenes + "satellite_arm.yaml");
  auto a = make_simulator(scene), b = make_simulator(scene);
  const Model& m = a->model();
  const int base_link = m.link_index("panda_link0");
  Vec6 w;
  w << 0.5, 0, 0, 0, 10, 0;
  // On the base link at its origin, world axes = base axes at the identity pose: the same as a
  // base wrench command. 0.0105 s = 11 steps.
  ASSERT_TRUE(scene.base_pose.R.isIdentity());
  a->apply_link_wrench(base_link, Vec3::Zero(), w, 0.0105);
  b->set_base_wrench(w);
  for (int k = 0; k < 11; ++k) {
    ASSERT_TRUE(a->step());
    ASSERT_TRUE(b->step());
  }
  EXPECT_EQ(a->link_wrench_count(), 0);  // used up
  EXPECT_LT((a->state().v - b->state().v).norm(), 1e-3 * b->state().v.norm());
  EXPECT_GT(b->state().v.segment<3>(3).norm(), 1e-3);
  // Two halves add up to the whole.
  auto c = make_simulator(scene), d = make_simulator(scene);
  c->apply_link_wrench(base_link, Vec3::Zero(), w, -1);
  d->apply_link_wrench(base_link, Vec3::Zero(), 0.5 * w, -1);
  d->apply_link_wrench(base_link, Vec3::Zero(), 0.5 * w, -1);
  ASSERT_EQ(c->step_n(20), 20);
  ASSERT_EQ(d->step_n(20), 20);
  EXPECT_LT((c->state().v - d->state().v).norm(), 1e-12);
  d->clear_link_wrenches(base_link);
  EXPECT_EQ(d->link_wrench_count(), 0);
  c->reset();
  EXPECT_EQ(c->link_wrench_count(), 0);
  EXPECT_THROW(c->apply_link_wrench(-1, Vec3::Zero(), w, 1), std::invalid_argument);
  EXPECT_THROW(c->apply_link_wrench(static_cast<int>(m.links.size()), Vec3::Zero(), w, 1),
               std::invalid_argument);
  EXPECT_THROW(c->apply_link_wrench(0, Vec3::Zero(), Vec6::Constant(std::nan("")), 1),
               std::invalid_argument);
  for (int k = 0; k < Simulator::kMaxLinkWrenches; ++k) c->apply_link_wrench(0, Vec3::Zero(), w, 1);
  EXPECT_THROW(c->apply_link_wrench(0, Vec3::Zero(), w, 1), std::invalid_argument);
}

// The same commands after a reset give bit-identical states: controllers restart from the
// initial state, commands and wrenches are cleared, and the contact solver's warm starts begin
// again (the quadruped started standing on the ground: controllers and contact from step 1).
TEST(Reset, SameCommandsGiveBitIdenticalStates) {
  std::ifstream in(kScenes + "quadruped_ground.yaml");
  std::stringstream text;
  text << in.rdbuf();
  std::string standing = text.str();
  const std::string drop = "position: [0.0, 0.0, 0.40]";
  ASSERT_NE(standing.find(drop), std::string::npos);
  standing.replace(standing.find(drop), drop.size(), "position: [0.0, 0.0, 0.235]");
  // Few solver iterations, so that where the warm start begins shows in the result.
  const std::string iterations = "pgs_iterations: 200";
  ASSERT_NE(standing.find(iterations), std::string::npos);
  standing.replace(standing.find(iterations), iterations.size(), "pgs_iterations: 4");
  for (const char* file : {"fixed_panda.yaml", "standing quadruped"}) {
    SCOPED_TRACE(file);
    auto sim = file[0] == 'f' ? make_simulator(load_scene(kScenes + file))
                              : make_simulator(parse_scene(standing, kScenes, "standing.yaml"));
    const Model& m = sim->model();
    if (!sim->controllers()) {
      sim->set_controllers(parse_controllers_text(kPandaControllers, {"arm", "wrist"}));
    }
    auto run = [&](std::vector<State>& out) {
      sim->reset();
      const std::vector<double> hold = sim->controllers()->command(0);  // the initial pose
      for (int k = 0; k < 300; ++k) {
        if (k % 50 == 0) {
          sim->set_joint_effort(1 + (k / 50) % m.n, 0.1 * (k % 3) - 0.1);
          std::vector<double> c = hold;
          for (size_t j = 0; j < c.size(); ++j) c[j] += 0.05 * std::sin(k + j);
          ASSERT_EQ(sim->controllers()->set_command(0, c.data(), c.size()), "");
        }
        if (k == 120) sim->apply_link_wrench(1, Vec3(0.01, 0, 0), Vec6::Constant(0.2), 0.05);
        ASSERT_TRUE(sim->step()) << sim->failure();
        out.push_back(sim->state());
      }
    };
    std::vector<State> first, second;
    run(first);
    run(second);
    ASSERT_EQ(first.size(), second.size());
    for (size_t k = 0; k < first.size(); ++k) {
      ASSERT_EQ(first[k].q, second[k].q) << "step " << k;
      ASSERT_EQ(first[k].v, second[k].v) << "step " << k;
      ASSERT_TRUE(first[k].base.R == second[k].base.R && first[k].base.p == second[k].base.p);
    }
  }
}

// A scene's controllers: key runs them headless (se3_dyn simulate --scene): the quadruped
// stands on its feet under position controllers.
TEST(SceneControllers, QuadrupedStandsUnderPositionControllers) {
  const Scene scene = load_scene(kScenes + "quadruped_ground.yaml");
  EXPECT_TRUE(scene.locked_joints.empty());
  ASSERT_EQ(scene.controllers.size(), 1u);
  EXPECT_EQ(scene.controllers[0].kind, ControllerKind::GroupPosition);
  EXPECT_EQ(scene.controllers[0].joints.size(), 12u);
  auto sim = make_simulator(scene);
  ASSERT_NE(sim->controllers(), nullptr);
  const Model& m = sim->model();
  EXPECT_EQ(m.n, 12);
  const VecX q0 = sim->state().q;
  ASSERT_EQ(sim->step_n(3000), 3000) << sim->failure();
  const State& x = sim->state();
  // Upright, off the ground on its legs, joints near the standing posture, at rest.
  EXPECT_GT(x.base.R(2, 2), 0.98);
  EXPECT_GT(x.base.p.z(), 0.15);
  for (int k = 0; k < m.n; ++k) EXPECT_NEAR(x.q[k], q0[k], 0.02) << m.joint_name[k + 1];
  EXPECT_LT(x.v.norm(), 0.01);
  // Headless, as se3_dyn simulate --scene runs it.
  SimulateOptions o;
  o.scene = kScenes + "quadruped_ground.yaml";
  o.duration = 1.0;
  const SimulateResult r = simulate_headless(o);
  EXPECT_FALSE(r.diverged) << r.status;
  // A scene naming an unknown joint, or a bad controller, is refused with the file.
  const std::string text =
      "robot: chain:2\ncontrollers:\n  c: {type: effort_controllers/JointEffortController, "
      "joint: nope}\n";
  const Scene bad = parse_scene(text, kScenes, "bad.yaml");
  EXPECT_THROW(make_simulator(bad), ControllerError);
  try {
    parse_scene("robot: chain:2\ncontrollers:\n  c: {type: nope}\n", kScenes, "bad.yaml");
    ADD_FAILURE() << "accepted";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.yaml:3: controller 'c': type 'nope'"),
              std::string::npos)
        << e.what();
  }
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}

// gain_check.h: a velocity controller's p (pure damping, target 0) on one free joint flips the
// joint's velocity every step past dt p / M = 2 and not below it, as the bound says; the check
// warns past it only. On panda_push the Gazebo-style d = 40 on every joint is past the bound on
// the wrist (and nowhere else), the scene's own gains are within it, as are every shipped
// scene's.
TEST(GainCheck, TheBoundIsWhereAVelocityControllerStartsToFlip) {
  for (const double factor : {1.8, 2.2}) {
    SCOPED_TRACE(factor);
    const std::string base =
        "robot: chain:1\nbase: fixed\ngravity: [0, 0, 0]\ndt: 0.001\n"
        "initial_velocities: {j1: 1.0}\n";
    auto probe = make_simulator(parse_scene(base, kScenes, "g.yaml"));
    Data data(probe->model());
    const double m = minv(probe->model(), data, probe->state().base, probe->state().q)(0, 0);
    const double p = factor / (0.001 * m);
    const Scene sc = parse_scene(base +
                                     "controllers: {c: {type: "
                                     "effort_controllers/JointVelocityController, joint: j1, "
                                     "pid: {p: " +
                                     std::to_string(p) + "}}}\n",
                                 kScenes, "g.yaml");
    auto sim = make_simulator(sc);
    const auto warnings =
        gain_stability_warnings(sim->model(), sim->state(), sc.controllers, 0.001);
    ASSERT_EQ(warnings.size(), factor > 2 ? 1u : 0u);
    if (factor > 2) {
      EXPECT_NE(warnings[0].find("controller 'c': joint 'j1' p = "), std::string::npos)
          << warnings[0];
    }
    double v_last = sim->state().v(0);
    int flips = 0;
    for (int k = 0; k < 20; ++k) {
      ASSERT_TRUE(sim->step()) << sim->failure();
      flips += sim->state().v(0) * v_last < 0;
      v_last = sim->state().v(0);
    }
    EXPECT_EQ(flips, 20);  // 1 - dt p / M is negative either way
    if (factor > 2) {
      EXPECT_GT(std::abs(v_last), 10.0);  // 1.2^20 = 38
    } else {
      EXPECT_LT(std::abs(v_last), 0.05);  // 0.8^20 = 0.012
    }
  }
}

TEST(GainCheck, NoShippedSceneIsPastTheBound) {
  int with_controllers = 0;
  for (const char* name : {"fixed_arm", "fixed_panda", "panda_push", "quadruped_ground",
                           "solo12_meshes", "satellite_arm", "ur5_self_collision"}) {
    SCOPED_TRACE(name);
    const Scene sc = load_scene(kScenes + name + ".yaml");
    auto sim = make_simulator(sc);
    with_controllers += !sc.controllers.empty();
    for (const std::string& w :
         gain_stability_warnings(sim->model(), sim->state(), sc.controllers, sim->dt())) {
      ADD_FAILURE() << w;
    }
  }
  EXPECT_GE(with_controllers, 3);
  // The shipped ros_control YAML for the Panda, on fixed_panda.
  std::ifstream in(kSource + "/config/controllers/panda.yaml");
  std::stringstream text;
  text << in.rdbuf();
  const std::vector<ControllerSpec> specs = parse_controllers_text(text.str());
  ASSERT_GE(specs.size(), 3u);
  auto sim = make_simulator(load_scene(kScenes + "fixed_panda.yaml"));
  for (const ControllerSpec& s : specs) {
    for (const std::string& w :
         gain_stability_warnings(sim->model(), sim->state(), {s}, sim->dt())) {
      ADD_FAILURE() << w;
    }
  }
}

TEST(GainCheck, PandaPushGazeboGainsArePastTheBoundOnTheWristOnly) {
  Scene sc = load_scene(kScenes + "panda_push.yaml");
  auto sim = make_simulator(sc);
  EXPECT_TRUE(
      gain_stability_warnings(sim->model(), sim->state(), sc.controllers, sim->dt()).empty());
  ASSERT_EQ(sc.controllers.size(), 1u);
  for (PidGains& g : sc.controllers[0].gains) g = PidGains{400, 0, 40};
  const auto w = gain_stability_warnings(sim->model(), sim->state(), sc.controllers, sim->dt());
  std::string all;
  for (const std::string& line : w) all += line + "\n";
  std::printf("%s", all.c_str());
  EXPECT_NE(all.find("joint 'panda_joint7' gains p = 400, d = 40"), std::string::npos) << all;
  EXPECT_NE(all.find("lower d below"), std::string::npos) << all;
  for (const char* big : {"panda_joint2", "panda_joint3", "panda_joint4"}) {
    EXPECT_EQ(all.find(big), std::string::npos) << big;
  }
}
