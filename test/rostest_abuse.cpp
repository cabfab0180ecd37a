// rostest node: abuse of simulator_node (test/abuse.test, issue 17). Bad commands of every kind,
// a 10 kHz flood of torque commands, concurrent service calls from four threads, and a step
// request of 2^32 - 1 steps: the node stays up, keeps publishing finite states, counts every
// rejection and every drop (accepted + rejected + dropped = sent), answers the huge request's
// interruption, and its resident memory stays flat.
#include <gtest/gtest.h>
#include <ros/network.h>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>
#include <std_msgs/Float64.h>
#include <std_srvs/Trigger.h>
#include <xmlrpcpp/XmlRpcClient.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <fstream>
#include <limits>
#include <mutex>
#include <random>
#include <thread>

#include "se3_sim/ApplyWrench.h"
#include "se3_sim/JointTorques.h"
#include "se3_sim/SetState.h"
#include "se3_sim/SimStats.h"
#include "se3_sim/Step.h"

namespace {

struct Listener {
  std::mutex mu;
  std::vector<double> js_wall;  // arrival times of joint_states
  bool nan_seen = false;
  se3_sim::SimStats stats;
  void on_js(const sensor_msgs::JointState::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mu);
    js_wall.push_back(ros::WallTime::now().toSec());
    for (const auto* v : {&m->position, &m->velocity, &m->effort}) {
      for (double x : *v) nan_seen = nan_seen || !std::isfinite(x);
    }
  }
  void on_stats(const se3_sim::SimStats::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mu);
    stats = *m;
  }
};
Listener* g = nullptr;
ros::Publisher* g_torque = nullptr;
std::uint64_t g_sent = 0;  // torque commands published after the first one

void wait(double s) {
  ros::WallDuration(s).sleep();
}

se3_sim::SimStats stats() {
  wait(0.3);  // sim_stats at 100 Hz, and what was sent has arrived
  std::lock_guard<std::mutex> l(g->mu);
  return g->stats;
}

std::uint64_t counted(const se3_sim::SimStats& s) {
  return s.accepted_commands + s.rejected_commands + s.dropped_commands;
}

void send(const se3_sim::JointTorques& m) {
  g_torque->publish(m);
  ++g_sent;
}

// The simulator's process id, from its XML-RPC API (getPid).
int simulator_pid() {
  XmlRpc::XmlRpcValue args, result, payload;
  args[0] = ros::this_node::getName();
  args[1] = std::string("/simulator");
  if (!ros::master::execute("lookupNode", args, result, payload, true)) return -1;
  const std::string uri = payload;
  std::string host;
  uint32_t port = 0;
  if (!ros::network::splitURI(uri, host, port)) return -1;
  XmlRpc::XmlRpcClient client(host.c_str(), port, "/");
  XmlRpc::XmlRpcValue a, r;
  a[0] = ros::this_node::getName();
  if (!client.execute("getPid", a, r) || r.getType() != XmlRpc::XmlRpcValue::TypeArray) return -1;
  return static_cast<int>(r[2]);
}

long rss_kb(int pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
}

se3_sim::JointTorques torques(std::vector<std::string> names, std::vector<double> efforts) {
  se3_sim::JointTorques m;
  m.name = std::move(names);
  m.effort = std::move(efforts);
  return m;
}

void flood(double seconds, double rate) {
  const auto t0 = std::chrono::steady_clock::now();
  const auto period = std::chrono::duration<double>(1.0 / rate);
  auto next = t0;
  const se3_sim::JointTorques m = torques({"panda_joint7"}, {0.01});
  while (std::chrono::steady_clock::now() - t0 < std::chrono::duration<double>(seconds)) {
    send(m);
    next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
    std::this_thread::sleep_until(next);
  }
}

}  // namespace

TEST(Abuse, TheNodeSurvivesCountsEverythingAndStaysFlat) {
  ros::NodeHandle nh;
  ros::Publisher wrist = nh.advertise<std_msgs::Float64>("wrist_effort_controller/command", 100);
  const int pid = simulator_pid();
  ASSERT_GT(pid, 0) << "cannot find the simulator's process";
  for (int k = 0; k < 100 && (g_torque->getNumSubscribers() == 0 || wrist.getNumSubscribers() == 0);
       ++k) {
    wait(0.05);
  }
  // The first message from this publisher is the baseline of its sequence numbers.
  g_torque->publish(torques({"panda_joint7"}, {0.0}));
  wait(0.5);
  flood(0.5, 10000.0);  // warm-up: queues and allocator pools reach their size
  const se3_sim::SimStats s0 = stats();
  const long rss0 = rss_kb(pid);
  ASSERT_GT(rss0, 0);
  const std::uint64_t sent0 = g_sent;
  const std::uint64_t counted0 = counted(s0);
  const double t_start = ros::WallTime::now().toSec();

  // 1. Bad commands of every kind, 20 of each.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<se3_sim::JointTorques> bad = {
      torques({"panda_joint1", "panda_joint2"}, {1.0}),   // lengths differ
      torques({"no_such_joint"}, {1.0}),                  // unknown joint
      torques({"panda_joint3", "panda_joint3"}, {1, 2}),  // named twice
      torques({"panda_joint4"}, {nan}),
      torques({"panda_joint5"}, {-inf}),
  };
  se3_sim::JointTorques w = torques({}, {});
  w.has_base_wrench = true;
  w.base_wrench.force.y = 1e300;  // finite, and it would end the simulation
  bad.push_back(w);
  w.base_wrench.force.y = 0;
  w.base_wrench.torque.x = nan;
  bad.push_back(w);
  for (int k = 0; k < 20; ++k) {
    for (const auto& b : bad) send(b);
    std_msgs::Float64 f;
    f.data = k % 2 ? nan : inf;
    wrist.publish(f);
  }
  const se3_sim::SimStats s1 = stats();
  // Sent in one burst, some may be lost at the publisher's queue of 100: those are counted as
  // dropped. None is taken.
  EXPECT_EQ(s1.rejected_commands - s0.rejected_commands + s1.dropped_commands - s0.dropped_commands,
            20u * (bad.size() + 1));
  EXPECT_EQ(s1.accepted_commands, s0.accepted_commands);

  // 2. A 10 kHz flood for 2 s: every message is taken, or counted as lost.
  flood(2.0, 10000.0);
  const se3_sim::SimStats s2 = stats();
  // Every torque command sent since the baseline is accepted, rejected or dropped; the 20
  // controller commands above are rejected too.
  EXPECT_EQ(counted(s2) - counted0, g_sent - sent0 + 20u);
  std::printf("flood: %llu sent, %llu accepted, %llu dropped\n",
              static_cast<unsigned long long>(g_sent - sent0),
              static_cast<unsigned long long>(s2.accepted_commands - s1.accepted_commands),
              static_cast<unsigned long long>(s2.dropped_commands - s1.dropped_commands));

  // ... and a burst as fast as the publisher goes (its queue of 100 overflows): lost ones are
  // counted as dropped.
  const se3_sim::JointTorques zero = torques({"panda_joint7"}, {0.0});
  for (int k = 0; k < 5000; ++k) send(zero);
  const se3_sim::SimStats s3 = stats();
  EXPECT_EQ(counted(s3) - counted0, g_sent - sent0 + 20u);
  std::printf("burst: 5000 sent, %llu accepted, %llu dropped\n",
              static_cast<unsigned long long>(s3.accepted_commands - s2.accepted_commands),
              static_cast<unsigned long long>(s3.dropped_commands - s2.dropped_commands));

  // 3. Concurrent service calls from four threads: every call is answered.
  std::atomic<int> answered{0}, unanswered{0};
  std::atomic<bool> stop{false};
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      std::mt19937 rng(t);
      // Persistent connections: the calls measure the node, not the master's lookups.
      ros::NodeHandle n;
      auto reset = n.serviceClient<std_srvs::Trigger>("simulator/reset", true);
      auto pause = n.serviceClient<std_srvs::Trigger>("simulator/pause", true);
      auto resume = n.serviceClient<std_srvs::Trigger>("simulator/resume", true);
      auto stepc = n.serviceClient<se3_sim::Step>("simulator/step", true);
      auto set = n.serviceClient<se3_sim::SetState>("simulator/set_state", true);
      auto apply = n.serviceClient<se3_sim::ApplyWrench>("simulator/apply_wrench", true);
      auto clear = n.serviceClient<std_srvs::Trigger>("simulator/clear_wrenches", true);
      while (!stop) {
        bool ok = true;
        const int which = static_cast<int>(rng() % 7);
        switch (which) {
          case 0: {
            std_srvs::Trigger s;
            ok = reset.call(s);
            break;
          }
          case 1: {
            std_srvs::Trigger s;
            ok = rng() % 2 ? pause.call(s) : resume.call(s);
            break;
          }
          case 2: {
            se3_sim::Step s;
            s.request.steps = rng() % 50;
            ok = stepc.call(s);
            break;
          }
          case 3: {
            se3_sim::SetState s;
            s.request.name = {rng() % 2 ? "panda_joint2" : "nope"};
            s.request.position = {0.1};
            ok = set.call(s);
            break;
          }
          case 4: {
            se3_sim::ApplyWrench s;
            s.request.link = rng() % 2 ? "panda_link5" : "nope";
            s.request.wrench.force.x = rng() % 3 ? 2.0 : 1e300;
            s.request.duration = 0.01;
            ok = apply.call(s);
            break;
          }
          case 5: {
            std_srvs::Trigger s;
            ok = clear.call(s);
            break;
          }
          default:
            send(torques({"panda_joint6"}, {0.0}));
        }
        if (!ok) std::fprintf(stderr, "unanswered: case %d\n", which);
        (ok ? answered : unanswered)++;
      }
    });
  }
  wait(2.0);
  stop = true;
  for (auto& th : threads) th.join();
  EXPECT_GT(answered, 40);
  EXPECT_EQ(unanswered, 0);

  // 4. A step request of 2^32 - 1 steps: the node keeps publishing while it runs, and a pause
  // ends it with the reason.
  std_srvs::Trigger t;
  ASSERT_TRUE(ros::service::call("simulator/reset", t));
  ASSERT_TRUE(ros::service::call("simulator/pause", t));
  wait(0.2);
  se3_sim::Step huge;
  huge.request.steps = 4294967295u;
  std::atomic<bool> huge_done{false};
  bool huge_called = false;
  std::thread stepper([&] {
    huge_called = ros::service::call("simulator/step", huge);
    huge_done = true;
  });
  wait(0.3);
  // Other services answer while it runs (the node takes turns between its 2 ms slices), each on
  // a fresh connection; std::mutex let the loop take the simulator back for up to 4 s.
  double slowest = 0;
  for (int k = 0; k < 10; ++k) {
    std_srvs::Trigger c;
    const auto c0 = std::chrono::steady_clock::now();
    EXPECT_TRUE(ros::service::call("simulator/clear_wrenches", c));
    slowest = std::max(
        slowest, std::chrono::duration<double>(std::chrono::steady_clock::now() - c0).count());
  }
  std::printf("slowest simulator/clear_wrenches during a step request: %.3f s\n", slowest);
  EXPECT_LT(slowest, 0.5) << "a service waited behind the step request's slices";
  const se3_sim::SimStats h0 = stats();
  std::size_t js0;
  {
    std::lock_guard<std::mutex> l(g->mu);
    js0 = g->js_wall.size();
  }
  wait(1.0);
  const se3_sim::SimStats h1 = stats();
  std::size_t js1;
  {
    std::lock_guard<std::mutex> l(g->mu);
    js1 = g->js_wall.size();
  }
  EXPECT_FALSE(huge_done) << "2^32 - 1 steps cannot be done already";
  EXPECT_GT(h1.sim_time, h0.sim_time + 0.05) << "the request does not step";
  EXPECT_GT(js1 - js0, 50u) << "joint_states stopped while the request runs (100 Hz)";
  ASSERT_TRUE(ros::service::call("simulator/pause", t));
  stepper.join();
  EXPECT_TRUE(huge_called);
  EXPECT_FALSE(huge.response.success);
  EXPECT_NE(huge.response.message.find("interrupted by simulator/pause"), std::string::npos)
      << huge.response.message;

  // The node is up and serving, published finite states all along with no long gap, and its
  // memory is flat.
  ASSERT_TRUE(ros::service::call("simulator/resume", t));
  wait(0.5);
  EXPECT_EQ(kill(pid, 0), 0) << "the simulator died";
  std::lock_guard<std::mutex> l(g->mu);
  EXPECT_FALSE(g->nan_seen);
  double gap = 0;
  std::size_t n = 0;
  for (std::size_t k = 1; k < g->js_wall.size(); ++k) {
    if (g->js_wall[k] < t_start) continue;
    gap = std::max(gap, g->js_wall[k] - g->js_wall[k - 1]);
    ++n;
  }
  const double span = ros::WallTime::now().toSec() - t_start;
  EXPECT_LT(gap, 0.5) << "joint_states stopped for " << gap << " s";
  EXPECT_GT(n, 0.5 * 100 * span) << "joint_states at " << n / span << " Hz (100 Hz asked)";
  const long rss1 = rss_kb(pid);
  std::printf("simulator RSS %ld kB -> %ld kB; joint_states %.0f Hz, longest gap %.3f s\n", rss0,
              rss1, n / span, gap);
  EXPECT_LT(rss1 - rss0, 4096) << "resident memory grew by " << rss1 - rss0 << " kB";
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "abuse_test");
  ros::NodeHandle nh;
  Listener listener;
  g = &listener;
  ros::Publisher torque = nh.advertise<se3_sim::JointTorques>("torque_command", 100);
  g_torque = &torque;
  ros::Subscriber a = nh.subscribe("joint_states", 100, &Listener::on_js, &listener);
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
