#!/usr/bin/python3
"""rostest of two robots in lockstep (test/multi_robot_lockstep.test): every command to the
first robot is answered by exactly one joint_states, chain_state, right/joint_states and
right/chain_state, all four with the same stamp (simulated time one control period on), and
right/chain_state carries right/joint_states' joints; a command to the second robot steps
nothing (docs/ros.md "Several robots").

Waits use the wall clock: with use_sim_time, simulated time stands still until we command."""
import threading
import time
import unittest

import rospy
import rostest
from se3_sim.msg import ChainState, JointTorques
from sensor_msgs.msg import JointState

PERIOD = 0.01  # control_period in multi_robot_lockstep.test
TOPICS = (("joint_states", JointState), ("chain_state", ChainState),
          ("right/joint_states", JointState), ("right/chain_state", ChainState))


def wall_wait(seconds):
    threading.Event().wait(seconds)


class MultiRobotLockstepTest(unittest.TestCase):
    def setUp(self):
        self.lock = threading.Lock()
        self.got = {t: [] for t, _ in TOPICS}
        fast = dict(queue_size=100, tcp_nodelay=True)
        self.subs = [rospy.Subscriber(t, c, self.on, t, **fast) for t, c in TOPICS]
        self.cmd = {"left": rospy.Publisher("torque_command", JointTorques, queue_size=100),
                    "right": rospy.Publisher("right/torque_command", JointTorques,
                                             queue_size=100)}
        end = time.time() + 30
        while time.time() < end and (any(p.get_num_connections() == 0 for p in self.cmd.values())
                                     or any(s.get_num_connections() == 0 for s in self.subs)):
            wall_wait(0.05)
        wall_wait(0.3)

    def on(self, msg, topic):
        with self.lock:
            self.got[topic].append(msg)

    def counts(self):
        with self.lock:
            return tuple(len(self.got[t]) for t, _ in TOPICS)

    def test_one_state_of_each_robot_per_command(self):
        n = 30
        start = self.counts()
        for k in range(n):
            self.cmd["left"].publish(JointTorques(name=["panda_joint1"], effort=[1.0]))
            end = time.time() + 5.0
            while time.time() < end and min(c - s for c, s in zip(self.counts(), start)) < k + 1:
                wall_wait(0.002)
        wall_wait(0.5)  # anything more than one per command would arrive now
        self.assertEqual(tuple(c - s for c, s in zip(self.counts(), start)), (n,) * 4)
        with self.lock:
            got = {t: self.got[t][-n:] for t, _ in TOPICS}
        t0 = got["joint_states"][0].header.stamp.to_sec()
        for k in range(n):
            stamps = [got[t][k].header.stamp for t, _ in TOPICS]
            self.assertEqual(len(set(stamps)), 1, "publication %d: %s" % (k, stamps))
            self.assertAlmostEqual(stamps[0].to_sec() - t0, k * PERIOD, delta=1e-6)
            cs, js = got["right/chain_state"][k], got["right/joint_states"][k]
            self.assertEqual(list(cs.name), list(js.name))
            self.assertEqual(list(cs.position), list(js.position))
            self.assertEqual(list(cs.velocity), list(js.velocity))
        # The second robot's commands do not step a lockstep simulation.
        before = self.counts()
        for _ in range(5):
            self.cmd["right"].publish(JointTorques(name=["panda_joint1"], effort=[1.0]))
            wall_wait(0.05)
        wall_wait(0.5)
        self.assertEqual(self.counts(), before)


if __name__ == "__main__":
    rospy.init_node("multi_robot_lockstep_check")
    rostest.rosrun("se3_sim", "multi_robot_lockstep", MultiRobotLockstepTest)
