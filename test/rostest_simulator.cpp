// rostest node for simulator_node (test/simulator.test): rates of joint_states and TF, every
// link in TF, the scene's bus on sim_markers, torque commands by name and merged per joint
// (also from a second node), rejection of bad commands, commands that expire in simulated time,
// the reset/pause/resume/step services, set_state and apply_wrench with their refusals.
// Comparisons of motion are made between runs from the same reset state advanced by the step
// service, so they do not depend on wall-clock timing.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>
#include <std_srvs/Trigger.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <tf2_msgs/TFMessage.h>
#include <unistd.h>
#include <visualization_msgs/MarkerArray.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <set>

#include "se3_sim/ApplyWrench.h"
#include "se3_sim/ChainState.h"
#include "se3_sim/JointTorques.h"
#include "se3_sim/SetState.h"
#include "se3_sim/SimStats.h"
#include "se3_sim/Step.h"
#include "se3_sim/lie/lie.h"
#include "se3_sim/model/model.h"

namespace {

struct Listener {
  std::mutex mu;
  std::vector<double> js_times, tf_times;
  std::set<std::string> tf_frames;
  sensor_msgs::JointState last_js;
  se3_sim::ChainState last_cs;
  se3_sim::SimStats last_stats;
  int stats_count = 0;
  bool nan_seen = false;
  visualization_msgs::Marker last_bus;  // sim_markers, namespace base_visual
  int bus_count = 0;

  void on_js(const sensor_msgs::JointState::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mu);
    js_times.push_back(ros::WallTime::now().toSec());
    last_js = *m;
    for (double x : m->position) nan_seen = nan_seen || !std::isfinite(x);
    for (double x : m->velocity) nan_seen = nan_seen || !std::isfinite(x);
    for (double x : m->effort) nan_seen = nan_seen || !std::isfinite(x);
  }
  void on_tf(const tf2_msgs::TFMessage::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mu);
    tf_times.push_back(ros::WallTime::now().toSec());
    for (const auto& t : m->transforms) tf_frames.insert(t.child_frame_id);
  }
  void on_tf_static(const tf2_msgs::TFMessage::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mu);
    for (const auto& t : m->transforms) tf_frames.insert(t.child_frame_id);
  }
  void on_cs(const se3_sim::ChainState::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mu);
    last_cs = *m;
  }
  void on_markers(const visualization_msgs::MarkerArray::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mu);
    for (const auto& k : m->markers) {
      if (k.ns != "base_visual") continue;
      last_bus = k;
      ++bus_count;
    }
  }
  void on_stats(const se3_sim::SimStats::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mu);
    last_stats = *m;
    ++stats_count;
  }
};

Listener* g = nullptr;
double g_rate = 100.0;
ros::Publisher g_pub;  // torque_command

void wait(double s) {
  ros::WallDuration(s).sleep();
}

bool call_empty(const std::string& name) {
  std_srvs::Trigger e;
  return ros::service::call(name, e) && e.response.success;
}

se3_sim::Step::Response step(unsigned n) {
  se3_sim::Step s;
  s.request.steps = n;
  EXPECT_TRUE(ros::service::call("simulator/step", s));
  return s.response;
}

/// Joint positions by name from the latest chain_state published after now.
// The positions of a chain_state published after this call began: stamped (wall time here, no
// use_sim_time) at or after it. Three publish periods at least, and under load as long as
// delivery takes (up to 10 s): a fixed wait alone returned a message sent before a step.
std::map<std::string, double> fresh_positions() {
  const ros::Time since = ros::Time::now();
  wait(3.0 / g_rate);
  for (int k = 0; k < 1000; ++k) {
    {
      std::lock_guard<std::mutex> l(g->mu);
      if (g->last_cs.header.stamp >= since) break;
    }
    wait(0.01);
  }
  std::lock_guard<std::mutex> l(g->mu);
  std::map<std::string, double> out;
  for (size_t k = 0; k < g->last_cs.name.size(); ++k) {
    out[g->last_cs.name[k]] = g->last_cs.position[k];
  }
  return out;
}

se3_sim::SimStats fresh_stats() {
  wait(3.0 / g_rate);
  std::lock_guard<std::mutex> l(g->mu);
  return g->last_stats;
}

/// Reset, pause, optionally publish a command, step n, return the positions.
std::map<std::string, double> run_from_reset(ros::Publisher& pub, const se3_sim::JointTorques* cmd,
                                             unsigned n, double delay_before_step = 0.0) {
  EXPECT_TRUE(call_empty("simulator/pause"));
  EXPECT_TRUE(call_empty("simulator/reset"));
  if (cmd) {
    pub.publish(*cmd);
    wait(0.1);  // delivery
  }
  if (delay_before_step > 0) wait(delay_before_step);
  const auto r = step(n);
  EXPECT_TRUE(r.success) << r.message;
  return fresh_positions();
}

double rate_of(const std::vector<double>& t) {
  if (t.size() < 3) return 0;
  return (t.size() - 1) / (t.back() - t.front());
}

}  // namespace

// Every link is in TF: moving joints' links on /tf, fixed ones on /tf_static (latched).
TEST(Simulator, PublishesJointStatesAndEveryLinkInTfAtTheRate) {
  {
    std::lock_guard<std::mutex> l(g->mu);
    g->js_times.clear();
    g->tf_times.clear();
  }
  wait(2.0);
  std::string urdf;
  ASSERT_TRUE(ros::param::get("robot_description", urdf));
  ASSERT_FALSE(urdf.empty());
  const se3::Model m = se3::model_from_urdf_string(urdf, {});
  std::lock_guard<std::mutex> l(g->mu);
  EXPECT_NEAR(rate_of(g->js_times), g_rate, 0.1 * g_rate);
  EXPECT_NEAR(rate_of(g->tf_times), g_rate, 0.1 * g_rate);
  for (const auto& link : m.links) {
    if (link.name == "world") continue;
    EXPECT_TRUE(g->tf_frames.count(link.name)) << "no TF for link " << link.name;
  }
  // joint_states names every URDF joint that moves (locked ones included).
  std::set<std::string> names(g->last_js.name.begin(), g->last_js.name.end());
  for (int i = 1; i <= m.n; ++i) EXPECT_TRUE(names.count(m.joint_name[i])) << m.joint_name[i];
  EXPECT_EQ(g->last_js.position.size(), g->last_js.name.size());
  EXPECT_EQ(g->last_js.velocity.size(), g->last_js.name.size());
  EXPECT_EQ(g->last_js.effort.size(), g->last_js.name.size());
  EXPECT_FALSE(g->nan_seen);
}

// The scene's bus (base_visual: not in the URDF) is published on sim_markers as a box that moves
// and turns with the base: centre at base * (0, 0, -0.3), the base's orientation, 0.6 m sides.
TEST(Simulator, SceneBusIsABoxMarkerThatFollowsTheBase) {
  EXPECT_TRUE(call_empty("simulator/pause"));
  EXPECT_TRUE(call_empty("simulator/reset"));
  const auto r = step(500);  // the arm's initial rates turn the base
  EXPECT_TRUE(r.success) << r.message;
  wait(3.0 / g_rate);
  std::lock_guard<std::mutex> l(g->mu);
  ASSERT_GT(g->bus_count, 0) << "no base_visual marker on sim_markers";
  const visualization_msgs::Marker& b = g->last_bus;
  const geometry_msgs::Pose& base = g->last_cs.base_pose;
  EXPECT_EQ(b.type, visualization_msgs::Marker::CUBE);
  EXPECT_EQ(b.header.frame_id, g->last_cs.header.frame_id);
  EXPECT_DOUBLE_EQ(b.scale.x, 0.6);
  EXPECT_DOUBLE_EQ(b.scale.y, 0.6);
  EXPECT_DOUBLE_EQ(b.scale.z, 0.6);
  const se3::Mat3 R = se3::rotation_from_quaternion(base.orientation.x, base.orientation.y,
                                                    base.orientation.z, base.orientation.w);
  const se3::Mat3 Rb = se3::rotation_from_quaternion(b.pose.orientation.x, b.pose.orientation.y,
                                                     b.pose.orientation.z, b.pose.orientation.w);
  EXPECT_GT((R - se3::Mat3::Identity()).norm(), 1e-4);  // the base has turned
  EXPECT_LT((Rb - R).norm(), 1e-9);
  const se3::Vec3 c =
      se3::Vec3(base.position.x, base.position.y, base.position.z) + R * se3::Vec3(0, 0, -0.3);
  EXPECT_NEAR(b.pose.position.x, c.x(), 1e-9);
  EXPECT_NEAR(b.pose.position.y, c.y(), 1e-9);
  EXPECT_NEAR(b.pose.position.z, c.z(), 1e-9);
}

TEST(Simulator, TorqueByNameMovesThatJoint) {
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<se3_sim::JointTorques>("torque_command", 10);
  wait(0.5);
  const auto base = run_from_reset(pub, nullptr, 200);
  se3_sim::JointTorques cmd;
  // The wrist's last joint: on the free-floating arm its torque couples least into the others
  // (a torque on a middle joint legitimately whips the light wrist joints around).
  cmd.name = {"panda_joint7"};
  cmd.effort = {1.0};
  const auto moved = run_from_reset(pub, &cmd, 200);
  const double d7 = moved.at("panda_joint7") - base.at("panda_joint7");
  EXPECT_GT(d7, 0.05);  // pushed positively
  for (const auto& kv : base) {
    if (kv.first == "panda_joint7") continue;
    EXPECT_LT(std::abs(moved.at(kv.first) - kv.second), 0.2 * d7) << kv.first;
  }
  // The opposite torque turns it the other way.
  cmd.effort = {-1.0};
  const auto back = run_from_reset(pub, &cmd, 200);
  EXPECT_LT(back.at("panda_joint7") - base.at("panda_joint7"), -0.05);
  // Effort limits: 1000 N m is clamped to the URDF's 12 N m.
  cmd.effort = {1000.0};
  const auto clamped = run_from_reset(pub, &cmd, 200);
  cmd.effort = {12.0};
  const auto at_limit = run_from_reset(pub, &cmd, 200);
  EXPECT_NEAR(clamped.at("panda_joint7"), at_limit.at("panda_joint7"), 1e-12);
  EXPECT_TRUE(call_empty("simulator/reset"));
  EXPECT_TRUE(call_empty("simulator/resume"));
}

TEST(Simulator, BadCommandsAreRejectedCountedAndDoNotAct) {
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<se3_sim::JointTorques>("torque_command", 10);
  wait(0.5);
  const auto base = run_from_reset(pub, nullptr, 100);
  const std::uint64_t before = fresh_stats().rejected_commands;
  se3_sim::JointTorques unknown, nan, mismatch;
  unknown.name = {"panda_joint4", "no_such_joint"};
  unknown.effort = {20.0, 1.0};
  nan.name = {"panda_joint4"};
  nan.effort = {std::numeric_limits<double>::quiet_NaN()};
  mismatch.name = {"panda_joint4", "panda_joint2"};
  mismatch.effort = {20.0};
  for (const auto* c : {&unknown, &nan, &mismatch}) {
    const auto after = run_from_reset(pub, c, 100);
    EXPECT_EQ(after.at("panda_joint4"), base.at("panda_joint4")) << "a rejected command acted";
  }
  const se3_sim::SimStats st = fresh_stats();
  EXPECT_EQ(st.rejected_commands, before + 3);
  // Still alive and publishing finite states.
  const int n0 = g->stats_count;
  EXPECT_TRUE(call_empty("simulator/resume"));
  wait(0.3);
  EXPECT_GT(g->stats_count, n0);
  EXPECT_FALSE(g->nan_seen);
}

// A command acts for ~command_timeout of simulated time: a paused simulation keeps it however
// long the wall clock runs, and it stops acting once the simulation has stepped that long.
TEST(Simulator, CommandsExpireInSimulatedTimeAndAPausedSimulationKeepsThem) {
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<se3_sim::JointTorques>("torque_command", 10);
  wait(0.5);
  double timeout = 0.5;
  ros::param::get("simulator/command_timeout", timeout);
  const auto base = run_from_reset(pub, nullptr, 100);
  se3_sim::JointTorques cmd;
  cmd.name = {"panda_joint4"};
  cmd.effort = {20.0};
  const auto fresh = run_from_reset(pub, &cmd, 100);
  EXPECT_GT(fresh.at("panda_joint4") - base.at("panda_joint4"), 1e-3);
  // Longer than the timeout on the wall clock, paused: still acts, exactly as the fresh one.
  const auto kept = run_from_reset(pub, &cmd, 100, timeout + 0.3);
  EXPECT_EQ(kept.at("panda_joint4"), fresh.at("panda_joint4"));
  // Stepped past the timeout: the effort in joint_states is back to the damping alone.
  const auto r = step(static_cast<unsigned>(std::lround(timeout / 0.001)) + 5);
  EXPECT_TRUE(r.success) << r.message;
  wait(3.0 / g_rate);
  {
    std::lock_guard<std::mutex> l(g->mu);
    for (size_t k = 0; k < g->last_js.name.size(); ++k) {
      if (g->last_js.name[k] == "panda_joint4") {
        EXPECT_LT(std::abs(g->last_js.effort[k]), 0.1);
      }
    }
  }
  EXPECT_TRUE(call_empty("simulator/resume"));
}

namespace {

/// Effort of a joint in the latest joint_states.
double effort_of(const std::string& joint) {
  wait(3.0 / g_rate);
  std::lock_guard<std::mutex> l(g->mu);
  for (size_t k = 0; k < g->last_js.name.size(); ++k) {
    if (g->last_js.name[k] == joint) return g->last_js.effort[k];
  }
  ADD_FAILURE() << "no " << joint << " in joint_states";
  return 0;
}

/// A second node: rostopic publishing a torque command at 20 Hz until killed.
pid_t start_rostopic_pub(const std::string& yaml) {
  const pid_t pid = fork();
  if (pid == 0) {
    execlp("rostopic", "rostopic", "pub", "-r", "20", "torque_command", "se3_sim/JointTorques",
           yaml.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  return pid;
}

}  // namespace

// Two nodes commanding different joints both act: each message sets the joints it names and
// leaves the others as they were.
TEST(Simulator, TwoNodesOnDifferentJointsBothAct) {
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<se3_sim::JointTorques>("torque_command", 10);
  EXPECT_TRUE(call_empty("simulator/pause"));
  EXPECT_TRUE(call_empty("simulator/reset"));
  const pid_t other = start_rostopic_pub("{name: [panda_joint7], effort: [1.5]}");
  ASSERT_GT(other, 0);
  // Wait until the other node's command is in (its effort shows in joint_states).
  double e7 = 0;
  for (int k = 0; k < 60 && std::abs(e7 - 1.5) > 0.01; ++k) {
    wait(0.1);
    e7 = effort_of("panda_joint7");
  }
  EXPECT_NEAR(e7, 1.5, 0.01) << "the second node's command did not arrive";
  se3_sim::JointTorques cmd;
  cmd.name = {"panda_joint4"};
  cmd.effort = {-5.0};
  for (int k = 0; k < 5; ++k) {
    pub.publish(cmd);
    wait(0.05);
  }
  // Paused at the initial state: the commands less the damping at the initial rates (3e-3 N m s
  // times at most 0.3 rad/s).
  EXPECT_NEAR(effort_of("panda_joint4"), -5.0, 1e-3);
  EXPECT_NEAR(effort_of("panda_joint7"), 1.5, 1e-3);
  kill(other, SIGINT);
  waitpid(other, nullptr, 0);
  EXPECT_TRUE(call_empty("simulator/reset"));
  EXPECT_TRUE(call_empty("simulator/resume"));
}

// simulator/set_state (Gazebo's set_model_configuration / set_model_state) sets what it names
// and refuses, with the reason, what it cannot; apply_wrench pushes a link for a duration.
TEST(Simulator, SetStateAndApplyWrenchAnswerRefusalsAsRefusals) {
  EXPECT_TRUE(call_empty("simulator/pause"));
  EXPECT_TRUE(call_empty("simulator/reset"));
  se3_sim::SetState s;
  s.request.name = {"panda_joint4", "panda_joint2"};
  s.request.position = {-1.0, 0.25};
  s.request.set_base_pose = true;
  s.request.base_pose.position.x = 0.5;
  s.request.base_pose.position.z = 2.0;
  s.request.base_pose.orientation.w = 1.0;
  ASSERT_TRUE(ros::service::call("simulator/set_state", s));
  EXPECT_TRUE(s.response.success) << s.response.message;
  ASSERT_TRUE(step(1).success);
  {
    const auto p = fresh_positions();
    EXPECT_NEAR(p.at("panda_joint4"), -1.0, 1e-3);
    EXPECT_NEAR(p.at("panda_joint2"), 0.25, 1e-3);
    std::lock_guard<std::mutex> l(g->mu);
    EXPECT_NEAR(g->last_cs.base_pose.position.x, 0.5, 1e-3);
    EXPECT_NEAR(g->last_cs.base_pose.position.z, 2.0, 1e-3);
  }
  auto refused = [](se3_sim::SetState::Request req, const std::string& why) {
    se3_sim::SetState c;
    c.request = req;
    ASSERT_TRUE(ros::service::call("simulator/set_state", c));
    EXPECT_FALSE(c.response.success) << why;
    EXPECT_NE(c.response.message.find(why), std::string::npos) << c.response.message;
  };
  se3_sim::SetState::Request r;
  r.name = {"nope"};
  r.position = {0};
  refused(r, "unknown joint 'nope'");
  r.name = {"panda_finger_joint1"};
  refused(r, "locked");
  r.name = {"panda_joint4"};
  r.position = {5.0};
  refused(r, "outside its limits");
  r.position = {std::nan("")};
  refused(r, "non-finite");
  r.position = {-1.0, 2.0};
  refused(r, "lengths differ");
  r = se3_sim::SetState::Request();
  r.set_base_pose = true;
  r.base_pose.orientation.w = 2.0;
  refused(r, "not a unit quaternion");
  // apply_wrench: a force on the hand moves the arm; refusals say why.
  const auto before = run_from_reset(g_pub, nullptr, 100);
  se3_sim::ApplyWrench w;
  w.request.link = "panda_hand";
  w.request.wrench.force.z = 20.0;
  w.request.duration = 0.05;
  EXPECT_TRUE(call_empty("simulator/reset"));
  ASSERT_TRUE(ros::service::call("simulator/apply_wrench", w));
  EXPECT_TRUE(w.response.success) << w.response.message;
  ASSERT_TRUE(step(100).success);
  const auto pushed = fresh_positions();
  double moved = 0;
  for (const auto& kv : before) moved = std::max(moved, std::abs(pushed.at(kv.first) - kv.second));
  EXPECT_GT(moved, 1e-3);
  auto wrench_refused = [](se3_sim::ApplyWrench::Request req, const std::string& why) {
    se3_sim::ApplyWrench c;
    c.request = req;
    ASSERT_TRUE(ros::service::call("simulator/apply_wrench", c));
    EXPECT_FALSE(c.response.success) << why;
    EXPECT_NE(c.response.message.find(why), std::string::npos) << c.response.message;
  };
  se3_sim::ApplyWrench::Request wr = w.request;
  wr.link = "nope";
  wrench_refused(wr, "unknown link 'nope'");
  wr = w.request;
  wr.reference_frame = "panda_link3";
  wrench_refused(wr, "only the world frame");
  wr = w.request;
  wr.wrench.force.x = 1e300;
  wrench_refused(wr, "~max_wrench");
  wr = w.request;
  wr.wrench.torque.y = std::nan("");
  wrench_refused(wr, "non-finite");
  std_srvs::Trigger clear;
  ASSERT_TRUE(ros::service::call("simulator/clear_wrenches", clear));
  EXPECT_TRUE(clear.response.success);
  // Resume is refused only after a divergence; here it is taken.
  EXPECT_TRUE(call_empty("simulator/resume"));
}

TEST(Simulator, ResetPauseStepResume) {
  double dt = 0.001;
  ASSERT_TRUE(call_empty("simulator/reset"));
  ASSERT_TRUE(call_empty("simulator/resume"));
  wait(0.3);
  ASSERT_TRUE(call_empty("simulator/pause"));
  const se3_sim::SimStats s0 = fresh_stats();
  dt = s0.dt;
  EXPECT_TRUE(s0.paused);
  EXPECT_GT(s0.sim_time, 0.1);  // it ran while resumed
  const auto p0 = fresh_positions();
  wait(0.3);
  const se3_sim::SimStats s1 = fresh_stats();
  EXPECT_EQ(s1.sim_time, s0.sim_time) << "paused, yet time moved";
  EXPECT_EQ(fresh_positions(), p0);
  // Step N advances by exactly N dt.
  const auto r = step(25);
  EXPECT_TRUE(r.success) << r.message;
  EXPECT_NEAR(r.sim_time, s0.sim_time + 25 * dt, 1e-9);
  EXPECT_NE(fresh_positions(), p0);
  // Reset: time 0 and the scene's initial joint values.
  ASSERT_TRUE(call_empty("simulator/reset"));
  const se3_sim::SimStats s2 = fresh_stats();
  EXPECT_EQ(s2.sim_time, 0.0);
  const auto init = fresh_positions();
  EXPECT_NEAR(init.at("panda_joint4"), -2.356, 1e-12);
  // Step while running is refused.
  ASSERT_TRUE(call_empty("simulator/resume"));
  const auto refused = step(5);
  EXPECT_FALSE(refused.success);
  EXPECT_NE(refused.message.find("call simulator/pause first"), std::string::npos);
  wait(0.3);
  EXPECT_FALSE(fresh_stats().paused);
  EXPECT_GT(fresh_stats().sim_time, 0.1);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "simulator_test");
  ros::NodeHandle nh;
  Listener listener;
  g = &listener;
  ros::param::get("~rate", g_rate);
  ros::Subscriber a = nh.subscribe("joint_states", 100, &Listener::on_js, &listener);
  ros::Subscriber b = nh.subscribe("/tf", 100, &Listener::on_tf, &listener);
  ros::Subscriber b2 = nh.subscribe("/tf_static", 10, &Listener::on_tf_static, &listener);
  ros::Subscriber c = nh.subscribe("chain_state", 100, &Listener::on_cs, &listener);
  ros::Subscriber d = nh.subscribe("sim_stats", 100, &Listener::on_stats, &listener);
  ros::Subscriber e = nh.subscribe("sim_markers", 100, &Listener::on_markers, &listener);
  g_pub = nh.advertise<se3_sim::JointTorques>("torque_command", 10);
  ros::AsyncSpinner spinner(2);
  spinner.start();
  if (!ros::service::waitForService("simulator/step", ros::Duration(20.0))) {
    ADD_FAILURE() << "simulator services did not come up";
  }
  wait(1.0);
  const int rc = RUN_ALL_TESTS();
  spinner.stop();
  ros::shutdown();
  return rc;
}
