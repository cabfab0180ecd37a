// The shipped two_arms scene (config/scenes/two_arms.yaml) passing the box: the UR5 pushes it
// along the table onto the Panda's half, the Panda pushes it back onto the UR5's half, each arm
// sent the joint-space waypoints of examples/two_arms/pass_box.yaml (which pass_box.py sends)
// through its trajectory controller. The waypoints are the inverse kinematics of a Cartesian
// plan (the tool positions in the same file; DISABLED_PrintWaypoints solves it).
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "se3_sim/collision/collision.h"
#include "se3_sim/dynamics/dynamics.h"
#include "se3_sim/sim/controllers.h"
#include "se3_sim/sim/sim.h"
#include "se3_sim/solver/constraints.h"
#include "source_paths.h"

using namespace se3;

namespace {

const std::string kScene = se3_sim_test::source_dir() + "/config/scenes/two_arms.yaml";

// One waypoint: joint positions (the arm's joints' order) at a time from the start of its
// trajectory, and where its tool frame is meant to be (world frame).
struct Waypoint {
  double t;
  std::vector<double> q;
  Vec3 tool;
};

// One arm of pass_box.yaml, in the order the arms are sent.
struct Arm {
  std::string name;  // the robot's name in the scene
  std::string tool;  // the link that pushes
  std::vector<std::string> joints;
  double wait;  // simulated s from sending this arm's trajectory to the next one's
  std::vector<Waypoint> points;
  int robot = -1;  // index in the simulator
};

std::vector<Arm> load_arms(const Simulator& sim) {
  const YAML::Node y =
      YAML::LoadFile(se3_sim_test::source_dir() + "/examples/two_arms/pass_box.yaml");
  std::vector<Arm> arms;
  for (const YAML::Node& a : y["arms"]) {
    Arm arm{a["name"].as<std::string>(),
            a["tool_link"].as<std::string>(),
            a["joints"].as<std::vector<std::string>>(),
            a["wait"].as<double>(),
            {}};
    for (const YAML::Node& p : a["points"]) {
      const auto tool = p["tool"].as<std::vector<double>>();
      arm.points.push_back(
          {p["t"].as<double>(), p["q"].as<std::vector<double>>(), Vec3(tool[0], tool[1], tool[2])});
    }
    arm.robot = sim.robot_index(arm.name);
    arms.push_back(arm);
  }
  return arms;
}

// The tool frame of arm a in the world at the arm's state with its controller's joints at q.
SE3 tool_pose(const Simulator& sim, const Arm& a, const std::vector<double>& q) {
  const Model& m = sim.robot_model(a.robot);
  State s = sim.robot_state(a.robot);
  for (size_t j = 0; j < a.joints.size(); ++j) {
    s.q[m.joints[m.joint_index(a.joints[j])].idx_q] = q[j];
  }
  Data d(m);
  forward_kinematics(m, d, s.base, s.q);
  const LinkFrame& l = m.links[m.link_index(a.tool)];
  return d.oMb[l.body] * l.offset;
}

// Joint positions near q0 that put arm a's tool at p with rotation R (damped least squares on a
// finite-difference Jacobian of [rotation error; position error]).
std::vector<double> solve_ik(const Simulator& sim, const Arm& a, std::vector<double> q,
                             const Vec3& p, const Mat3& R) {
  const int n = static_cast<int>(q.size());
  auto err = [&](const std::vector<double>& x) {
    const SE3 T = tool_pose(sim, a, x);
    Eigen::Matrix<double, 6, 1> e;
    e.head<3>() = log_so3(R * T.R.transpose());
    e.tail<3>() = p - T.p;
    return e;
  };
  for (int it = 0; it < 200; ++it) {
    const Eigen::Matrix<double, 6, 1> e = err(q);
    if (e.norm() < 1e-10) break;
    Eigen::MatrixXd J(6, n);
    for (int j = 0; j < n; ++j) {
      std::vector<double> x = q;
      x[j] += 1e-7;
      J.col(j) = -(err(x) - e) / 1e-7;
    }
    const Eigen::MatrixXd A = J * J.transpose() + 1e-6 * Eigen::MatrixXd::Identity(6, 6);
    const Eigen::VectorXd dq = J.transpose() * A.ldlt().solve(e);
    for (int j = 0; j < n; ++j) q[j] += dq[j];
  }
  return q;
}

}  // namespace

// Prints the IK of the tool positions of pass_box.yaml, each solved from the previous point's
// joints (the first from the scene's start), the tool's rotation the start's (run with
// --gtest_also_run_disabled_tests).
TEST(TwoArms, DISABLED_PrintWaypoints) {
  auto sim = make_simulator(load_scene(kScene));
  for (const Arm& a : load_arms(*sim)) {
    const Model& m = sim->robot_model(a.robot);
    std::vector<double> q;
    for (const auto& j : a.joints) {
      q.push_back(sim->robot_state(a.robot).q[m.joints[m.joint_index(j)].idx_q]);
    }
    const SE3 T0 = tool_pose(*sim, a, q);
    std::printf("%s: %s at %.4f %.4f %.4f, z axis %.3f %.3f %.3f\n", a.name.c_str(), a.tool.c_str(),
                T0.p.x(), T0.p.y(), T0.p.z(), T0.R(0, 2), T0.R(1, 2), T0.R(2, 2));
    for (const Waypoint& w : a.points) {
      q = solve_ik(*sim, a, q, w.tool, T0.R);
      const SE3 T = tool_pose(*sim, a, q);
      std::printf("  - {t: %g, q: [", w.t);
      for (size_t j = 0; j < q.size(); ++j) std::printf("%s%.4f", j ? ", " : "", q[j]);
      std::printf("], tool: [%g, %g, %g]}  # error %.1e m\n", w.tool.x(), w.tool.y(), w.tool.z(),
                  (T.p - w.tool).norm());
    }
  }
}

namespace {

// The simulated time at which the first arm's trajectory is sent (pass_box.py sends it as soon
// as the controller subscribes; here after 0.2 s of the box settling on the table).
const double kFirstSend = 0.2;

// What one run of the scene saw: the box's centre when each arm's trajectory was sent and at
// the end, its extremes, which arms touched it, and each trajectory's end status.
struct PassRun {
  std::vector<Vec3> box_at_send;
  Vec3 start, end;
  double z_min = 1e9, z_max = -1e9;
  double upright_min = 1;  // the box's z axis against the world's, its smallest
  std::vector<bool> touched;
  std::vector<TrajectoryStatus> status;
  bool finite = true;
  double time = 0;
};

TrajectoryCommand command_of(const Arm& a) {
  TrajectoryCommand cmd;
  cmd.joint_names = a.joints;
  for (const Waypoint& p : a.points) {
    TrajectoryCommand::Point pt;
    pt.time_from_start = p.t;
    pt.positions = p.q;
    cmd.points.push_back(pt);
  }
  return cmd;
}

// Runs two_arms as pass_box.py drives it: the first arm's trajectory at kFirstSend, each next
// one `wait` after the one before, the run ending `wait` after the last; with `send` false the
// same time passes without any trajectory.
PassRun run_pass(bool send) {
  auto sim = make_simulator(load_scene(kScene));
  const std::vector<Arm> arms = load_arms(*sim);
  int box = -1;
  for (size_t i = 0; i < sim->object_specs().size(); ++i) {
    if (sim->object_specs()[i].name == "box") box = static_cast<int>(i);
  }
  EXPECT_GE(box, 0);
  PassRun r;
  r.touched.assign(arms.size(), false);
  r.start = sim->objects()[box].pose.p;
  std::vector<double> send_at;
  double t = kFirstSend;
  for (const Arm& a : arms) {
    EXPECT_GE(a.robot, 0) << a.name;
    send_at.push_back(t);
    t += a.wait;
  }
  const double t_end = t;
  size_t next = 0;
  while (sim->time() < t_end - 1e-9) {
    if (next < arms.size() && sim->time() >= send_at[next] - 1e-9) {
      r.box_at_send.push_back(sim->objects()[box].pose.p);
      if (send) {
        const Arm& a = arms[next];
        EXPECT_EQ(sim->robot_controllers(a.robot)->set_trajectory(0, command_of(a), sim->time()),
                  "")
            << a.name;
      }
      ++next;
    }
    if (!sim->step()) {
      ADD_FAILURE() << sim->failure();
      r.finite = false;
      break;
    }
    const SE3& pose = sim->objects()[box].pose;
    r.z_min = std::min(r.z_min, pose.p.z());
    r.z_max = std::max(r.z_max, pose.p.z());
    r.upright_min = std::min(r.upright_min, pose.R(2, 2));
    r.finite = r.finite && pose.p.allFinite();
    for (const Arm& a : arms) r.finite = r.finite && sim->robot_state(a.robot).finite();
    // A contact impulse between the box and a robot's link: robot 0's shapes are group 0,
    // robot k >= 1's group k + 1 (scene_collision.h).
    const auto& objs = *sim->contact_objects();
    const ConstraintSystem& cs = *sim->constraints();
    for (int c = 0; c < cs.external_count(); ++c) {
      const auto& w = cs.external()[c];
      if (!(w.impulse.norm() > 0)) continue;
      for (const auto& [x, y] : {std::pair(w.a, w.b), std::pair(w.b, w.a)}) {
        if (objs[x].name != "box") continue;
        for (size_t k = 0; k < arms.size(); ++k) {
          const int group = arms[k].robot == 0 ? 0 : arms[k].robot + 1;
          if (objs[y].group == group) r.touched[k] = true;
        }
      }
    }
  }
  r.end = sim->objects()[box].pose.p;
  r.time = sim->time();
  for (const Arm& a : arms) {
    r.status.push_back(sim->robot_controllers(a.robot)->trajectory_state(0).status);
  }
  return r;
}

void print(const PassRun& r) {
  std::printf("box start %.4f %.4f %.4f", r.start.x(), r.start.y(), r.start.z());
  for (size_t k = 1; k < r.box_at_send.size(); ++k) {
    const Vec3& p = r.box_at_send[k];
    std::printf(", before arm %zu %.4f %.4f %.4f", k, p.x(), p.y(), p.z());
  }
  std::printf(", end %.4f %.4f %.4f, z in [%.4f, %.4f], upright >= %.4f, touched", r.end.x(),
              r.end.y(), r.end.z(), r.z_min, r.z_max, r.upright_min);
  for (bool b : r.touched) std::printf(" %d", b ? 1 : 0);
  std::printf(", t %.3f\n", r.time);
}

}  // namespace

// The waypoints are the plan's IK: each puts its tool within 0.5 mm of the planned position
// (their joint values are rounded to 1e-4 rad), pointing down.
TEST(TwoArms, WaypointsPutTheToolsWhereThePlanSays) {
  auto sim = make_simulator(load_scene(kScene));
  const std::vector<Arm> arms = load_arms(*sim);
  ASSERT_EQ(arms.size(), 2u);
  EXPECT_EQ(arms[0].name, "ur5");
  EXPECT_EQ(arms[1].name, "panda");
  for (const Arm& a : arms) {
    ASSERT_GE(a.robot, 0) << a.name;
    for (const Waypoint& w : a.points) {
      ASSERT_EQ(w.q.size(), a.joints.size());
      const SE3 T = tool_pose(*sim, a, w.q);
      EXPECT_LT((T.p - w.tool).norm(), 5e-4) << a.tool << " at t " << w.t;
      EXPECT_LT(T.R(2, 2), -0.999) << a.tool << " at t " << w.t << " does not point down";
    }
  }
}

// The pass: the box (6 cm, resting on the table top at z 0.20 with its centre at z 0.23, x 0)
// ends the UR5's push on the Panda's half of the table (x > 0) and the Panda's on the UR5's:
// its centre beyond x = +-0.05, i.e. the whole box past the table's middle by 2 cm, which only a
// push does. On the table all along: its centre within 5 mm of z 0.23 (never lifted, tipped or
// dropped), upright, inside the top's outline (edges at x +-0.2, y +-0.4). Both arms pushed it
// (contact impulses between the box and each robot's links), both trajectories ran to their
// ends within their tolerances, and everything stayed finite.
TEST(TwoArms, UR5AndPandaPassTheBox) {
  const PassRun r = run_pass(true);
  print(r);
  ASSERT_TRUE(r.finite);
  ASSERT_EQ(r.box_at_send.size(), 2u);
  EXPECT_NEAR(r.start.x(), 0.0, 1e-3);
  const Vec3 after_ur5 = r.box_at_send[1];
  EXPECT_GT(after_ur5.x(), 0.05) << "the UR5 did not push the box onto the Panda's half";
  EXPECT_LT(r.end.x(), -0.05) << "the Panda did not push the box back onto the UR5's half";
  EXPECT_TRUE(r.touched[0]) << "the UR5 never touched the box";
  EXPECT_TRUE(r.touched[1]) << "the Panda never touched the box";
  EXPECT_GT(r.z_min, 0.225) << "the box left the table top";
  EXPECT_LT(r.z_max, 0.235) << "the box was lifted";
  EXPECT_GT(r.upright_min, 0.99) << "the box tipped";
  for (const Vec3& p : {after_ur5, r.end}) {
    EXPECT_LT(std::abs(p.x()), 0.17);  // the table's half length 0.2 - the box's half width
    EXPECT_LT(std::abs(p.y()), 0.37);
  }
  for (TrajectoryStatus s : r.status) {
    EXPECT_EQ(s, TrajectoryStatus::Succeeded) << status_name(s);
  }
}

// Without the trajectories the arms hold their start poses clear of the box and the box stays
// where it is, untouched: what the pass's checks tell apart.
TEST(TwoArms, WithoutTrajectoriesTheBoxStays) {
  const PassRun r = run_pass(false);
  print(r);
  ASSERT_TRUE(r.finite);
  EXPECT_LT((r.end - r.start).norm(), 1e-3);
  EXPECT_FALSE(r.touched[0]);
  EXPECT_FALSE(r.touched[1]);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
