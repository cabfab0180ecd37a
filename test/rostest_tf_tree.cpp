// rostest node for TF and /clock (test/tf_tree.test): the simulator's /tf and /tf_static are
// the tree robot_state_publisher computes from joint_states (REP 105; each frame one parent),
// /clock comes after every physics step, and simulator/reset takes simulated time back to 0 in
// /clock, the stamps and sim_stats alike.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/JointState.h>
#include <std_srvs/Trigger.h>
#include <tf2_msgs/TFMessage.h>

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <mutex>
#include <set>

#include "se3_sim/SimStats.h"
#include "se3_sim/Step.h"

namespace {

using Edges = std::map<std::string, geometry_msgs::TransformStamped>;  // by child frame

struct Listener {
  std::mutex mu;
  Edges sim_tf, sim_static, rsp_tf, rsp_static;
  std::vector<double> clock;
  ros::Time js_stamp;
  se3_sim::SimStats stats;

  static void add(Edges& e, const tf2_msgs::TFMessage& m) {
    for (const auto& t : m.transforms) e[t.child_frame_id] = t;
  }
  void on_sim_tf(const tf2_msgs::TFMessage::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mu);
    add(sim_tf, *m);
  }
  void on_sim_static(const tf2_msgs::TFMessage::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mu);
    add(sim_static, *m);
  }
  void on_rsp_tf(const tf2_msgs::TFMessage::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mu);
    add(rsp_tf, *m);
  }
  void on_rsp_static(const tf2_msgs::TFMessage::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mu);
    add(rsp_static, *m);
  }
  void on_clock(const rosgraph_msgs::Clock::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mu);
    clock.push_back(m->clock.toSec());
  }
  void on_js(const sensor_msgs::JointState::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mu);
    js_stamp = m->header.stamp;
  }
  void on_stats(const se3_sim::SimStats::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mu);
    stats = *m;
  }
};
Listener* g = nullptr;

void wait(double s) {
  ros::WallDuration(s).sleep();
}

bool trigger(const std::string& name) {
  std_srvs::Trigger t;
  return ros::service::call(name, t) && t.response.success;
}

Eigen::Matrix3d rotation(const geometry_msgs::Quaternion& q) {
  return Eigen::Quaterniond(q.w, q.x, q.y, q.z).normalized().toRotationMatrix();
}

void expect_same(const Edges& rsp, const Edges& sim, const char* what) {
  for (const auto& kv : rsp) {
    SCOPED_TRACE(std::string(what) + " " + kv.first);
    const auto it = sim.find(kv.first);
    ASSERT_NE(it, sim.end()) << "the simulator does not publish " << kv.first;
    const auto &a = kv.second, &b = it->second;
    EXPECT_EQ(a.header.frame_id, b.header.frame_id);
    EXPECT_NEAR(a.transform.translation.x, b.transform.translation.x, 1e-9);
    EXPECT_NEAR(a.transform.translation.y, b.transform.translation.y, 1e-9);
    EXPECT_NEAR(a.transform.translation.z, b.transform.translation.z, 1e-9);
    EXPECT_LT((rotation(a.transform.rotation) - rotation(b.transform.rotation)).norm(), 1e-9);
  }
}

}  // namespace

// Paused after some motion, so every joint_states carries the same state: robot_state_publisher's
// transforms of it are the simulator's, edge by edge, on /tf and on /tf_static.
TEST(Tf, SameTransformsAsRobotStatePublisher) {
  ASSERT_TRUE(trigger("simulator/pause"));
  ASSERT_TRUE(trigger("simulator/reset"));
  se3_sim::Step s;
  s.request.steps = 700;  // the arm's initial rates move every joint
  ASSERT_TRUE(ros::service::call("simulator/step", s) && s.response.success);
  const ros::Time at(s.response.sim_time);
  ros::Time rsp_stamp;
  for (int k = 0; k < 50; ++k) {  // robot_state_publisher answers the new stamp once
    wait(0.1);
    std::lock_guard<std::mutex> l(g->mu);
    const auto it = g->rsp_tf.find("panda_link1");
    if (it != g->rsp_tf.end() && it->second.header.stamp == at) break;
  }
  // Both latched /tf_static messages arrive once, each in its own time on a loaded machine.
  for (int k = 0; k < 100; ++k) {
    {
      std::lock_guard<std::mutex> l(g->mu);
      bool all = !g->rsp_static.empty();
      for (const auto& kv : g->rsp_static) all = all && g->sim_static.count(kv.first);
      if (all) break;
    }
    wait(0.1);
  }
  std::lock_guard<std::mutex> l(g->mu);
  ASSERT_FALSE(g->rsp_tf.empty()) << "robot_state_publisher published nothing";
  ASSERT_FALSE(g->rsp_static.empty());
  for (const auto& kv : g->rsp_tf) EXPECT_EQ(kv.second.header.stamp, at) << kv.first;
  EXPECT_EQ(g->sim_tf.at("panda_link1").header.stamp, at);
  expect_same(g->rsp_tf, g->sim_tf, "/tf");
  expect_same(g->rsp_static, g->sim_static, "/tf_static");
  // The simulator has one more: world -> the root (robot_state_publisher knows no base pose).
  EXPECT_EQ(g->sim_tf.size(), g->rsp_tf.size() + 1);
  EXPECT_EQ(g->sim_tf.at("panda_link0").header.frame_id, "world");
}

// Together, the simulator and robot_state_publisher give every frame one parent, and every
// frame reaches world.
TEST(Tf, NoFrameHasTwoParents) {
  std::lock_guard<std::mutex> l(g->mu);
  std::map<std::string, std::set<std::string>> parents;
  for (const Edges* e : {&g->sim_tf, &g->sim_static, &g->rsp_tf, &g->rsp_static}) {
    for (const auto& kv : *e) parents[kv.first].insert(kv.second.header.frame_id);
  }
  EXPECT_GT(parents.size(), 10u);
  for (const auto& kv : parents) {
    EXPECT_EQ(kv.second.size(), 1u) << kv.first << " has " << kv.second.size() << " parents";
    std::string f = kv.first;
    for (int depth = 0; depth < 50 && f != "world"; ++depth) {
      f = parents.count(f) ? *parents[f].begin() : "";
    }
    EXPECT_EQ(f, "world") << kv.first << " does not reach world";
  }
}

// /clock after every physics step (1 kHz at dt = 1 ms in real time): consecutive values differ
// by exactly one step; and it agrees with sim_stats.
TEST(Clock, AfterEveryPhysicsStep) {
  ASSERT_TRUE(trigger("simulator/reset"));
  {
    std::lock_guard<std::mutex> l(g->mu);
    g->clock.clear();
  }
  ASSERT_TRUE(trigger("simulator/resume"));
  wait(1.5);
  ASSERT_TRUE(trigger("simulator/pause"));
  wait(0.2);
  std::lock_guard<std::mutex> l(g->mu);
  const std::vector<double> c = g->clock;
  ASSERT_GT(c.size(), 300u) << "the simulation hardly ran";
  const double dt = g->stats.dt;
  int off = 0;
  for (size_t k = 1; k < c.size(); ++k) off += std::abs(c[k] - c[k - 1] - dt) > 1e-9;
  EXPECT_EQ(off, 0) << "of " << c.size() << " /clock messages, " << off
                    << " did not follow a single step";
  EXPECT_NEAR(c.back(), g->stats.sim_time, 1e-9);
}

// simulator/reset: /clock, the stamps and sim_stats all start again from 0.
TEST(Clock, ResetTakesSimulatedTimeBackToZeroEverywhere) {
  ASSERT_TRUE(trigger("simulator/resume"));
  wait(0.5);
  ASSERT_TRUE(trigger("simulator/pause"));
  wait(0.2);
  {
    std::lock_guard<std::mutex> l(g->mu);
    ASSERT_GT(g->stats.sim_time, 0.2);
    g->clock.clear();
  }
  ASSERT_TRUE(trigger("simulator/reset"));
  wait(0.3);
  std::lock_guard<std::mutex> l(g->mu);
  ASSERT_FALSE(g->clock.empty()) << "no /clock after the reset";
  EXPECT_EQ(g->clock.back(), 0.0);
  EXPECT_EQ(g->stats.sim_time, 0.0);
  EXPECT_EQ(g->js_stamp.toSec(), 0.0);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "tf_tree_test");
  ros::NodeHandle nh;
  Listener listener;
  g = &listener;
  const auto hints = ros::TransportHints().tcpNoDelay();
  ros::Subscriber subs[] = {
      nh.subscribe("/tf", 100, &Listener::on_sim_tf, &listener, hints),
      nh.subscribe("/tf_static", 10, &Listener::on_sim_static, &listener, hints),
      nh.subscribe("/rsp/tf", 100, &Listener::on_rsp_tf, &listener, hints),
      nh.subscribe("/rsp/tf_static", 10, &Listener::on_rsp_static, &listener, hints),
      nh.subscribe("/clock", 100000, &Listener::on_clock, &listener, hints),
      nh.subscribe("joint_states", 10, &Listener::on_js, &listener, hints),
      nh.subscribe("sim_stats", 10, &Listener::on_stats, &listener, hints)};
  (void)subs;
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
