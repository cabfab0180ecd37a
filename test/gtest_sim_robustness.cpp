// The simulation's share of issue 35's findings: many free objects, controller names that are
// not ROS names, setup work that grew with the square of the bodies, free objects outside the
// divergence guard, continuous joints at huge angles, runs of no step, and trajectory files
// without the objects. Each reproducer failed before its fix (docs/robustness.md).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "../src/dynamics/tree_depth.h"
#include "error_of.h"
#include "se3_sim/constraint/constraint.h"
#include "se3_sim/model/limits.h"
#include "se3_sim/sim/controllers.h"
#include "se3_sim/sim/sim.h"
#include "source_paths.h"

using namespace se3;

namespace {

const std::string kSource = se3_sim_test::source_dir();
const std::string kSe3Dyn = se3_sim_test::se3_dyn_exe();

std::string temp_file(const std::string& name, const std::string& text) {
  const std::string path =
      ::testing::TempDir() + "se3_simrobust_" + std::to_string(getpid()) + "_" + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

using se3_test::error_of;

// Output and exit code of a shell command (stderr into the output).
std::string run(const std::string& cmd, int& rc) {
  std::string out;
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  const int status = pclose(p);
  rc = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return out;
}

// n boxes of 0.1 m resting on the ground, 0.3 m apart on a square grid.
std::string boxes_scene(int n) {
  std::ostringstream s;
  s << "gravity: [0, 0, -9.81]\nintegrator: contact_semi_implicit\ndt: 0.001\n"
       "ground: {normal: [0, 0, 1]}\nobjects:\n";
  const int side = static_cast<int>(std::ceil(std::sqrt(double(n))));
  for (int k = 0; k < n; ++k) {
    s << "  - {name: box" << k << ", shape: {box: [0.1, 0.1, 0.1]}, mass: 1, pose: {position: ["
      << 0.3 * (k % side) << ", " << 0.3 * (k / side) << ", 0.05]}}\n";
  }
  return s.str();
}

}  // namespace

// ---------------------------------------------------------------- many free objects

// 64 free objects made 65 systems, past the 64 of a row's system mask: SIGFPE. Each box rests
// alone, so every box of a large scene ends where the one box of a small scene does.
TEST(ManyObjects, AnyCountRestsLikeOneBox) {
  SimulateOptions one;
  one.scene = temp_file("boxes1.yaml", boxes_scene(1));
  one.duration = 0.002;  // two steps: the dense solve of 130 boxes takes 0.5 s a step
  const double z1 = simulate_headless(one).objects.at(0).pose.p.z();
  EXPECT_NEAR(z1, 0.05, 1e-3);
  for (const int n : {63, 64, 65, 130}) {
    const std::string path = temp_file("boxes" + std::to_string(n) + ".yaml", boxes_scene(n));
    EXPECT_EXIT(
        {
          SimulateOptions o;
          o.scene = path;
          o.duration = 0.002;
          const SimulateResult r = simulate_headless(o);
          int bad = 0;
          for (const auto& ob : r.objects) {
            if (!(std::abs(ob.pose.p.z() - z1) < 1e-6) || !(ob.twist.norm() < 1e-3)) ++bad;
          }
          std::fprintf(stderr, "objects %zu, diverged %d, off the single box %d\n",
                       r.objects.size(), int(r.diverged), bad);
          std::exit(r.objects.size() == size_t(n) && !r.diverged && bad == 0 ? 0 : 1);
        },
        ::testing::ExitedWithCode(0), "")
        << n << " boxes";
    std::remove(path.c_str());
  }
  std::remove(one.scene.c_str());
}

// A scene of objects alone has no robot dofs: its block of the Delassus matrix is zero (Eigen's
// triangular product of inner dimension 0 was SIGFPE).
// 64 rows: Eigen takes its blocked product (40 and fewer are formed coefficient by coefficient).
bool robot_block_of_no_dofs_is_zero() {
  const int rows = 64;
  ConstraintRows::RowMat J = ConstraintRows::RowMat::Ones(rows, 12);
  const MatX Minv(0, 0);
  MatX Y = MatX::Ones(12, rows);
  MatX W = MatX::Ones(rows, rows);
  DelassusWorkspace ws;
  ws.reserve(0, rows);
  robot_delassus(J, rows, 0, Minv, Y, W, ws);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c <= r; ++c) {
      if (W(r, c) != 0.0) return false;
    }
  }
  return true;
}

TEST(ManyObjects, RobotBlockOfNoDofsIsZero) {
  EXPECT_EXIT(std::exit(robot_block_of_no_dofs_is_zero() ? 0 : 1), ::testing::ExitedWithCode(0),
              "");
}

// ---------------------------------------------------------------- controller names

TEST(ControllerNames, ANameThatIsNotARosNameIsOneLineWithFileAndLine) {
  const std::string text =
      "robot: data/robots/panda.urdf\n"
      "controllers:\n"
      "  \"my arm\": {type: effort_controllers/JointGroupPositionController,"
      " joints: [panda_joint1], pid: {p: 100, d: 10}}\n";
  const std::string e =
      error_of<SceneError>([&] { parse_scene(text, kSource + "/config/scenes", "bad.yaml"); });
  EXPECT_NE(e.find("bad.yaml:3: "), std::string::npos) << e;
  EXPECT_NE(e.find("'my arm'"), std::string::npos) << e;
  EXPECT_NE(e.find("not a ROS name"), std::string::npos) << e;
  EXPECT_EQ(e.find('\n'), std::string::npos) << e;
  // A controller_config file and specs built in code are refused the same way.
  const Model m = make_chain(2, false);
  auto bind = [&](const char* name) {
    ControllerSpec s;
    s.name = name;
    s.type = "effort_controllers/JointGroupEffortController";
    s.joints = {"j1"};
    return error_of<ControllerError>([&] {
      const ControllerSet set(m, {s});
      (void)set;
    });
  };
  for (const char* name :
       {"my arm", "1arm", "~arm", "/arm", "arm/", "a//b", "arm-1", "", "\xc3\xa9"}) {
    const std::string why = bind(name);
    EXPECT_NE(why.find("not a ROS name"), std::string::npos) << name << ": " << why;
  }
  for (const char* name : {"arm", "Arm_1", "arm/position_controller", "a1/b_2/c"}) {
    EXPECT_EQ(bind(name), "") << name;
  }
  const std::string f = error_of<ControllerError>([] {
    parse_controllers_text(
        "ok: {type: effort_controllers/JointEffortController, joint: j1}\n"
        "'bad name': {type: effort_controllers/JointEffortController,"
        " joint: j1}\n",
        {}, "ctl.yaml");
  });
  EXPECT_NE(f.find("ctl.yaml:2: "), std::string::npos) << f;
}

// ---------------------------------------------------------------- linear setup

// Data's cost estimate walked every dof's ancestors: n^2 / 2 steps for a chain of n (26 s for
// 100,000 bodies before the first step). Each dof's depth now comes from its parent's: one
// look-up per dof, whatever the tree.
TEST(LinearSetup, DofDepthsLookUpEachParentOnce) {
  for (const int n : {1000, 100000}) {
    std::vector<int> chain(n), star(n), depth(n);
    for (int k = 0; k < n; ++k) chain[k] = k - 1, star[k] = k == 0 ? -1 : 0;
    long calls = 0;
    detail::dof_depths(
        n, [&](int k) { return ++calls, chain[k]; }, depth.data());
    EXPECT_EQ(calls, n) << "chain of " << n;
    EXPECT_EQ(depth[n - 1], n - 1);
    calls = 0;
    detail::dof_depths(
        n, [&](int k) { return ++calls, star[k]; }, depth.data());
    EXPECT_EQ(calls, n) << "star of " << n;
    EXPECT_EQ(depth[n - 1], 1);
  }
  // A free chain's dofs: the base's six, then a joint per body.
  const Model m = make_chain(5, true);
  const Data d(m);
  std::vector<int> depth(m.nv);
  detail::dof_depths(
      m.nv, [&](int k) { return d.v_parent[k]; }, depth.data());
  for (int k = 0; k < m.nv; ++k) EXPECT_EQ(depth[k], k);
}

// ---------------------------------------------------------------- the guard covers objects

TEST(ObjectGuard, AnObjectBeyondTheRateLimitDivergesNamingIt) {
  auto scene = [](const std::string& vz) {
    return "gravity: [0, 0, -9.81]\nobjects:\n"
           "  - {name: shot, shape: {sphere: 0.1}, mass: 1, pose: {position: [0, 0, 1]},"
           " twist: [0, 0, 0, 0, 0, " +
           vz + "]}\n";
  };
  for (const char* vz : {"1e300", "2e4", "-1e5"}) {
    SimulateOptions o;
    o.scene = temp_file("shot.yaml", scene(vz));
    o.duration = 0.01;
    const SimulateResult r = simulate_headless(o);
    EXPECT_TRUE(r.diverged) << vz;
    EXPECT_NE(r.status.find("object 'shot'"), std::string::npos) << r.status;
    EXPECT_LT(r.status.size(), 300u) << r.status;
    ASSERT_EQ(r.objects.size(), 1u);
    EXPECT_NEAR(r.objects[0].pose.p.z(), 1.0, 1e-12) << vz;  // rolled back: never moved
    std::remove(o.scene.c_str());
  }
  SimulateOptions fine;  // below the limit: a fast shot, not a divergence
  fine.scene = temp_file("fine.yaml", scene("9000"));
  fine.duration = 0.01;
  const SimulateResult r = simulate_headless(fine);
  EXPECT_FALSE(r.diverged) << r.status;
  EXPECT_NEAR(r.objects.at(0).pose.p.z(), 1 + 90, 0.01);
  std::remove(fine.scene.c_str());
}

// ---------------------------------------------------------------- continuous joints

TEST(ContinuousJoints, HugeAnglesAreWrappedWhereTheyEnter) {
  auto run_at = [](const std::string& q) {
    SimulateOptions o;
    o.scene = temp_file("chain3.yaml", "robot: chain:3\ninitial_positions: {j1: " + q +
                                           ", j2: 0.3}\ninitial_velocities: {j1: 1}\n");
    o.duration = 0.2;
    const SimulateResult r = simulate_headless(o);
    std::remove(o.scene.c_str());
    return r;
  };
  const SimulateResult r0 = run_at("0");
  const SimulateResult r15 = run_at("1e15");
  EXPECT_LT(r15.energy_drift_rel, 100 * r0.energy_drift_rel + 1e-9) << r15.energy_drift_rel;

  const Model m = make_chain(3, false);
  Scene s;
  s.initial_positions = {{"j1", 1e15}, {"j2", -7.0}, {"j3", M_PI}};
  const State x = scene_state(s, m);
  EXPECT_GT(x.q[0], -M_PI);
  EXPECT_LE(x.q[0], M_PI);
  EXPECT_DOUBLE_EQ(x.q[0], std::remainder(1e15, 2 * M_PI));
  EXPECT_NEAR(x.q[1], -7.0 + 2 * M_PI, 1e-15);
  EXPECT_EQ(x.q[2], M_PI);  // pi stays pi, the end of (-pi, pi]

  // The simulator's own entries: set_initial_state and set_state (the node's simulator/set_state).
  Simulator sim(m, State(m), SimConfig());
  State y(m);
  y.q << -1e15, 3 * M_PI, -M_PI;
  sim.set_state(y);
  for (int k = 0; k < 3; ++k) {
    EXPECT_GT(sim.state().q[k], -M_PI) << k;
    EXPECT_LE(sim.state().q[k], M_PI) << k;
  }
  EXPECT_EQ(sim.state().q[2], M_PI);
  sim.set_initial_state(y);
  sim.reset();
  EXPECT_LE(std::abs(sim.state().q[0]), M_PI);

  // Joints with limits and prismatic joints keep their coordinate.
  Model lim = make_chain(3, false);
  lim.lower[1] = -10, lim.upper[1] = 10;  // body 1: q[0]
  lim.joints[3] = JointModel(JointType::Prismatic);
  lim.finalize();
  State z(lim);
  z.q << 9.0, 9.0, 9.0;
  Simulator sl(lim, z, SimConfig());
  EXPECT_EQ(sl.state().q[0], 9.0);
  EXPECT_NEAR(sl.state().q[1], 9.0 - 2 * M_PI, 1e-14);
  EXPECT_EQ(sl.state().q[2], 9.0);
}

// ---------------------------------------------------------------- runs of no step

TEST(ZeroSteps, ARunThatWouldTakeNoStepIsAnError) {
  const std::string path =
      temp_file("slow.yaml", "robot: chain:2\ndt: 1000\ngravity: [0, 0, 0]\n");  // dt in ms?
  SimulateOptions o;
  o.scene = path;
  o.duration = 0.2;
  const std::string e = error_of<std::invalid_argument>([&] { simulate_headless(o); });
  EXPECT_NE(e.find("no step"), std::string::npos) << e;
  SimulateOptions zero;
  zero.model = "chain:2";
  zero.duration = 0;
  EXPECT_NE(error_of<std::invalid_argument>([&] { simulate_headless(zero); }).find("no step"),
            std::string::npos);
  o.duration = 600;  // at least half a step: one step
  EXPECT_EQ(simulate_headless(o).steps, 1u);
  int rc = 0;
  const std::string out = run(kSe3Dyn + " simulate --scene " + path + " --duration 0.2", rc);
  EXPECT_EQ(rc, 1) << out;
  EXPECT_NE(out.find("no step"), std::string::npos) << out;
  EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << out;
  std::remove(path.c_str());
}

// ---------------------------------------------------------------- trajectories with objects

TEST(TrajectoryCsv, EveryFreeObjectHasItsPoseAndTwist) {
  SimulateOptions o;
  o.scene = kSource + "/config/scenes/ball_on_table.yaml";
  o.duration = 0.3;
  o.out_csv = temp_file("traj.csv", "");
  const SimulateResult r = simulate_headless(o);
  std::ifstream in(o.out_csv);
  std::string header, line, last;
  std::getline(in, header);
  int rows = 0;
  while (std::getline(in, line)) last = line, ++rows;
  EXPECT_EQ(rows, 301);
  std::vector<std::string> names, values;
  for (std::stringstream ss(header); std::getline(ss, line, ',');) names.push_back(line);
  for (std::stringstream ss(last); std::getline(ss, line, ',');) values.push_back(line);
  ASSERT_EQ(names.size(), values.size()) << header;
  const char* cols[] = {"x", "y", "z", "qx", "qy", "qz", "qw", "wx", "wy", "wz", "vx", "vy", "vz"};
  std::vector<double> ball;
  for (const char* c : cols) {
    const auto it = std::find(names.begin(), names.end(), std::string("obj:ball:") + c);
    ASSERT_NE(it, names.end()) << c << " in " << header;
    ball.push_back(std::stod(values[it - names.begin()]));
  }
  EXPECT_EQ(header.find("obj:table:"), std::string::npos) << header;  // static: not a state
  const auto& b = r.objects.at(1);
  ASSERT_EQ(b.name, "ball");
  for (int k = 0; k < 3; ++k) EXPECT_EQ(ball[k], b.pose.p[k]) << k;
  const Eigen::Vector4d q = quaternion_from_rotation(b.pose.R);
  for (int k = 0; k < 4; ++k) EXPECT_EQ(ball[3 + k], q[k]) << k;
  for (int k = 0; k < 6; ++k) EXPECT_EQ(ball[7 + k], b.twist[k]) << k;
  EXPECT_LT(ball[2], 1.29 - 0.1);  // it fell
  std::remove(o.out_csv.c_str());
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ::testing::FLAGS_gtest_death_test_style = "threadsafe";
  return RUN_ALL_TESTS();
}

// One rule for a time step: the scene reader, the simulator, se3_dyn and the node's ~dt all
// refuse what dt_problem refuses (the simulator used to take any positive dt, 1e-12 included).
TEST(TimeStep, OneRuleForEveryWayADtComesIn) {
  for (double dt : {std::nan(""), HUGE_VAL, -1e-3, 0.0, 1e-10}) {
    EXPECT_FALSE(se3::dt_problem(dt).empty()) << dt;
    se3::SimConfig cfg;
    cfg.dt = dt;
    const se3::Model m = se3::make_chain(2, false);
    try {
      se3::Simulator sim(m, se3::State(m), cfg);
      ADD_FAILURE() << "dt " << dt << " was taken";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("dt "), std::string::npos) << e.what();
    }
  }
  for (double dt : {1e-9, 1e-3, 0.1}) EXPECT_EQ(se3::dt_problem(dt), "") << dt;
  EXPECT_EQ(se3::dt_problem(1e-10), "is below the smallest step, 1e-9 s (docs/robustness.md)");
}
