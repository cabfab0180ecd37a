// rostest node for controllers inside simulator_node (test/controllers.test): a position
// controller reaches its targets and holds them, an effort controller's command shows in
// joint_states.effort, bad controller commands are rejected, counted and change nothing.
// Motion is compared after simulator/step from a paused simulator, so wall-clock timing does
// not matter.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>
#include <std_msgs/Float64.h>
#include <std_msgs/Float64MultiArray.h>
#include <std_srvs/Trigger.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <mutex>

#include "se3_sim/SimStats.h"
#include "se3_sim/Step.h"

namespace {

struct Listener {
  std::mutex mu;
  sensor_msgs::JointState js;
  se3_sim::SimStats stats;
  void on_js(const sensor_msgs::JointState::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mu);
    js = *m;
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

bool step(unsigned n) {
  se3_sim::Step s;
  s.request.steps = n;
  return ros::service::call("simulator/step", s) && s.response.success;
}

struct Joint {
  double q = 0, v = 0, e = 0;
};

std::map<std::string, Joint> fresh_joints() {
  wait(0.05);  // joint_states at 100 Hz
  std::lock_guard<std::mutex> l(g->mu);
  std::map<std::string, Joint> out;
  for (size_t k = 0; k < g->js.name.size(); ++k) {
    out[g->js.name[k]] = {g->js.position[k], g->js.velocity[k], g->js.effort[k]};
  }
  return out;
}

std::uint64_t rejected() {
  wait(0.05);
  std::lock_guard<std::mutex> l(g->mu);
  return g->stats.rejected_commands;
}

const std::vector<double> kTargets = {0.5, -0.3, 0.2, -1.8, 0.4, 1.2};

std_msgs::Float64MultiArray array(const std::vector<double>& v) {
  std_msgs::Float64MultiArray m;
  m.data = v;
  return m;
}

}  // namespace

TEST(Controllers, PositionControllerReachesItsTargetsAndHoldsThem) {
  ros::NodeHandle nh;
  ros::Publisher pub =
      nh.advertise<std_msgs::Float64MultiArray>("shoulder_position_controller/command", 10, true);
  ASSERT_TRUE(trigger("simulator/pause"));
  ASSERT_TRUE(trigger("simulator/reset"));
  pub.publish(array(kTargets));
  wait(0.3);  // delivery (latched)
  ASSERT_TRUE(step(4000));
  auto j = fresh_joints();
  for (int k = 0; k < 6; ++k) {
    const std::string name = "panda_joint" + std::to_string(k + 1);
    EXPECT_NEAR(j[name].q, kTargets[k], 1e-3) << name;
  }
  ASSERT_TRUE(step(1000));
  j = fresh_joints();
  for (int k = 0; k < 6; ++k) {
    const std::string name = "panda_joint" + std::to_string(k + 1);
    EXPECT_NEAR(j[name].q, kTargets[k], 1e-3) << name << " did not hold";
    EXPECT_LT(std::abs(j[name].v), 1e-2) << name;
  }
  // Under gravity the shoulder works: its effort in joint_states is the controller's.
  EXPECT_GT(std::abs(j["panda_joint2"].e), 1.0);
  // The arm started at rest (T(0) = 0): the relative energy figures are measured against
  // M |g| L and the largest kinetic energy, not T(0) (they read 1e12 and more).
  wait(0.1);
  std::lock_guard<std::mutex> l(g->mu);
  std::printf("energy_drift_rel %g, energy_balance_rel %g\n", g->stats.energy_drift_rel,
              g->stats.energy_balance_rel);
  EXPECT_LT(g->stats.energy_drift_rel, 10.0);
  EXPECT_LT(g->stats.energy_balance_rel, 1.0);
}

TEST(Controllers, EffortControllerCommandShowsInJointStatesEffort) {
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<std_msgs::Float64>("wrist_effort_controller/command", 10, true);
  ASSERT_TRUE(trigger("simulator/pause"));
  ASSERT_TRUE(trigger("simulator/reset"));
  std_msgs::Float64 e;
  e.data = 3.0;
  pub.publish(e);
  wait(0.3);
  ASSERT_TRUE(step(1));
  auto j = fresh_joints();
  EXPECT_NEAR(j["panda_joint7"].e, 3.0 - 0.003 * j["panda_joint7"].v, 1e-9);
  // Beyond the URDF limit (12 N m) it is clamped.
  e.data = 50.0;
  pub.publish(e);
  wait(0.3);
  ASSERT_TRUE(step(1));
  j = fresh_joints();
  EXPECT_NEAR(j["panda_joint7"].e, 12.0 - 0.003 * j["panda_joint7"].v, 1e-9);
  e.data = 0.0;
  pub.publish(e);
  wait(0.2);
}

TEST(Controllers, BadCommandsAreRejectedCountedAndChangeNothing) {
  ros::NodeHandle nh;
  ros::Publisher group =
      nh.advertise<std_msgs::Float64MultiArray>("shoulder_position_controller/command", 10);
  ros::Publisher single = nh.advertise<std_msgs::Float64>("wrist_effort_controller/command", 10);
  wait(0.5);
  ASSERT_TRUE(trigger("simulator/pause"));
  ASSERT_TRUE(trigger("simulator/reset"));
  group.publish(array(kTargets));
  wait(0.2);
  const std::uint64_t before = rejected();
  const double nan = std::nan("");
  group.publish(array({0.1, 0.2, 0.3}));                  // wrong length
  group.publish(array({}));                               // empty
  group.publish(array({0.5, nan, 0.2, -1.8, 0.4, 1.2}));  // NaN
  group.publish(array({0.5, -0.3, 0.2, -1.8, 0.4, std::numeric_limits<double>::infinity()}));
  std_msgs::Float64 e;
  e.data = nan;
  single.publish(e);
  wait(0.5);
  EXPECT_EQ(rejected(), before + 5);
  // The targets are still the good ones.
  ASSERT_TRUE(step(4000));
  const auto j = fresh_joints();
  for (int k = 0; k < 6; ++k) {
    const std::string name = "panda_joint" + std::to_string(k + 1);
    EXPECT_NEAR(j.at(name).q, kTargets[k], 1e-3) << name;
  }
  EXPECT_TRUE(std::isfinite(j.at("panda_joint7").e));
  EXPECT_TRUE(trigger("simulator/resume"));
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "controllers_test");
  ros::NodeHandle nh;
  Listener listener;
  g = &listener;
  ros::Subscriber a = nh.subscribe("joint_states", 10, &Listener::on_js, &listener);
  ros::Subscriber b = nh.subscribe("sim_stats", 10, &Listener::on_stats, &listener);
  ros::AsyncSpinner spinner(2);
  spinner.start();
  if (!ros::service::waitForService("simulator/step", ros::Duration(20.0))) {
    ADD_FAILURE() << "simulator services did not come up";
  }
  wait(0.5);
  const int rc = RUN_ALL_TESTS();
  spinner.stop();
  ros::shutdown();
  return rc;
}
