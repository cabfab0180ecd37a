#!/usr/bin/python3
"""rostest for the shipped two_arms scene passing the box (test/two_arms.test): while
examples/two_arms/pass_box.py drives the UR5 and then the Panda, the box on model_states goes
onto the Panda's half of the table (its centre past x = +0.05: the whole box past the middle by
2 cm) and then back onto the UR5's (past x = -0.05), its centre within 5 mm of z 0.23 (resting
on the table top at z 0.20) all along. The same run as gtest_two_arms
TwoArms.UR5AndPandaPassTheBox, through the ROS topics."""
import threading
import time
import unittest

import rospy
import rostest
from se3_sim.msg import ModelStates


class TwoArmsTest(unittest.TestCase):
    def setUp(self):
        self.lock = threading.Lock()
        self.xs = []  # the box's x, in order
        self.z = [1e9, -1e9]
        rospy.Subscriber("model_states", ModelStates, self.on_states, queue_size=10)

    def on_states(self, msg):
        if "box" not in msg.name:
            return
        p = msg.pose[msg.name.index("box")].position
        with self.lock:
            self.xs.append(p.x)
            self.z = [min(self.z[0], p.z), max(self.z[1], p.z)]

    def test_box_passed_there_and_back(self):
        end = time.time() + 150.0
        there = back = False
        while time.time() < end and not back:
            time.sleep(0.2)
            with self.lock:
                there = there or any(x > 0.05 for x in self.xs)
                back = there and self.xs[-1] < -0.05
        with self.lock:
            self.assertTrue(self.xs, "no box on model_states")
            self.assertTrue(there, "the box never reached the Panda's half: x max %.3f"
                            % max(self.xs))
            self.assertTrue(back, "the box did not come back to the UR5's half: x %.3f"
                            % self.xs[-1])
            self.assertGreater(self.z[0], 0.225, "the box left the table top")
            self.assertLess(self.z[1], 0.235, "the box was lifted")


if __name__ == "__main__":
    rospy.init_node("two_arms_check")
    rostest.rosrun("se3_sim", "two_arms", TwoArmsTest)
