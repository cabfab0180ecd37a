#!/usr/bin/python3
"""rostest for lockstep (test/lockstep.test): the rospy controller of docs/guide.md (extracted
from the page, so the page's code is the code that runs) reaches its targets; every accepted
command (torque_command or a controller's) is answered by exactly one joint_states, /tf,
chain_state and /clock, one control period on; the same commands after a reset give
bit-identical states; a rejected command advances nothing.

Waits use the wall clock: with use_sim_time, simulated time stands still until we command."""
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
import unittest

import rospy
import rostest
from rosgraph_msgs.msg import Clock
from se3_sim.msg import ChainState, JointTorques, SimStats
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from std_srvs.srv import Trigger
from tf2_msgs.msg import TFMessage

HERE = os.path.dirname(os.path.abspath(__file__))
PERIOD = 0.01  # control_period in lockstep.test


def doc_example():
    text = open(os.path.join(HERE, "..", "docs", "guide.md")).read()
    m = re.search(r"<!-- lockstep-example -->\s*```python\n(.*?)```", text, re.S)
    assert m, "docs/guide.md has no lockstep example"
    return m.group(1)


def wall_wait(seconds):
    threading.Event().wait(seconds)


class LockstepTest(unittest.TestCase):
    def setUp(self):
        self.lock = threading.Lock()
        self.states, self.chain, self.tf, self.clock = [], [], [], []
        self.stats = None
        fast = dict(queue_size=100, tcp_nodelay=True)
        self.subs = [rospy.Subscriber("joint_states", JointState, self.on(self.states), **fast),
                     rospy.Subscriber("chain_state", ChainState, self.on(self.chain), **fast),
                     rospy.Subscriber("/tf", TFMessage, self.on(self.tf), **fast),
                     rospy.Subscriber("/clock", Clock, self.on(self.clock), **fast),
                     rospy.Subscriber("sim_stats", SimStats, self.on_stats, queue_size=1)]
        self.torque = rospy.Publisher("torque_command", JointTorques, queue_size=100)
        self.wrist = rospy.Publisher("wrist_effort_controller/command", Float64, queue_size=100)
        rospy.wait_for_service("simulator/reset", 30)
        self.reset = rospy.ServiceProxy("simulator/reset", Trigger)
        end = time.time() + 20
        while time.time() < end and (self.torque.get_num_connections() == 0
                                     or self.wrist.get_num_connections() == 0
                                     or any(s.get_num_connections() == 0 for s in self.subs)):
            wall_wait(0.05)

    def on(self, store):
        def cb(msg):
            with self.lock:
                store.append(msg)
        return cb

    def on_stats(self, msg):
        with self.lock:
            self.stats = msg

    def counts(self):
        with self.lock:
            return len(self.states), len(self.chain), len(self.tf), len(self.clock)

    def clear(self):
        with self.lock:
            for s in (self.states, self.chain, self.tf, self.clock):
                del s[:]

    def wait_states(self, n, timeout=5.0):
        end = time.time() + timeout
        while time.time() < end and self.counts()[0] < n:
            wall_wait(0.002)
        return self.counts()[0] >= n

    def test_doc_example_reaches_its_targets(self):
        with tempfile.NamedTemporaryFile("w", suffix=".py", delete=False) as f:
            f.write(doc_example())
        try:
            out = subprocess.run([sys.executable, f.name, "400", "__name:=lockstep_pd"],
                                 capture_output=True, text=True, timeout=60)
        finally:
            os.unlink(f.name)
        self.assertEqual(out.returncode, 0, out.stdout + out.stderr)
        errors = [float(x) for x in re.findall(r"error (-?[\d.]+) rad after 400 periods", out.stdout)]
        self.assertEqual(len(errors), 2, out.stdout)
        for e in errors:
            self.assertLess(abs(e), 0.02, out.stdout)

    def run_commands(self, n):
        """Reset, then n commands (torque_command and the wrist controller in turn), each sent
        after the state the one before it brought. Returns the states."""
        self.reset()
        wall_wait(0.3)
        self.clear()
        for k in range(n):
            if k % 2 == 0:
                self.torque.publish(JointTorques(name=["panda_joint4", "panda_joint2"],
                                                 effort=[2.0 * ((k // 2) % 3 - 1), 0.5]))
            else:
                self.wrist.publish(Float64(data=0.3 * (k % 5 - 2)))
            self.assertTrue(self.wait_states(k + 1), "no state for command %d" % k)
        # The other topics' last messages may still be on their way (a loaded machine), then
        # anything more than one per command would arrive now.
        end = time.time() + 5.0
        while time.time() < end and min(self.counts()) < n:
            wall_wait(0.01)
        wall_wait(0.5)
        with self.lock:
            return list(self.states)

    def test_one_state_per_command_and_bit_identical_after_reset(self):
        n = 40
        first = self.run_commands(n)
        self.assertEqual(self.counts(), (n, n, n, n))
        with self.lock:
            for k in range(n):
                t = (k + 1) * PERIOD  # simulated time after k + 1 control periods
                self.assertAlmostEqual(self.clock[k].clock.to_sec(), t, delta=1e-6)
                self.assertEqual(self.states[k].header.stamp, self.clock[k].clock)
                self.assertEqual(self.chain[k].header.stamp, self.clock[k].clock)
        second = self.run_commands(n)
        self.assertEqual(self.counts(), (n, n, n, n))
        moved = 0.0
        for a, b in zip(first, second):
            self.assertEqual(a.position, b.position)  # bit-identical doubles
            self.assertEqual(a.velocity, b.velocity)
            self.assertEqual(a.effort, b.effort)
            moved = max(moved, max(abs(x - y) for x, y in zip(a.position, first[0].position)))
        self.assertGreater(moved, 1e-3)  # the commands did something

    def test_rejected_command_advances_nothing(self):
        self.reset()
        end = time.time() + 5
        while time.time() < end and self.stats is None:
            wall_wait(0.05)
        wall_wait(0.3)
        self.clear()
        with self.lock:
            before = self.stats.rejected_commands
        self.torque.publish(JointTorques(name=["no_such_joint"], effort=[1.0]))
        self.wrist.publish(Float64(data=float("nan")))
        wall_wait(1.0)
        self.assertEqual(self.counts(), (0, 0, 0, 0))
        with self.lock:
            self.assertEqual(self.stats.rejected_commands, before + 2)


if __name__ == "__main__":
    rospy.init_node("lockstep_check")
    rostest.rosrun("se3_sim", "lockstep_check", LockstepTest, sys.argv)
