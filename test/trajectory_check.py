#!/usr/bin/python3
"""rostest for the trajectory controller (test/trajectory.test): a JointTrajectory of three
points on arm_controller/command takes the UR5 to its last point (joint_states within 0.01 rad),
arm_controller/state publishes the controller's joints with desired, actual and error, and the
desired position ends at the last point; a trajectory naming an unknown joint is refused (counted
in sim_stats.rejected_commands)."""
import threading
import unittest

import rospy
import rostest
from se3_sim.msg import JointTrajectoryControllerState, SimStats
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
          "wrist_2_joint", "wrist_3_joint"]
START = [0.0, -1.2, 1.0, -1.0, -1.57, 0.0]
GOAL = [0.6, -0.9, 0.6, -1.4, -1.2, 0.5]


def wall_wait(seconds):
    threading.Event().wait(seconds)


class Trajectory(unittest.TestCase):
    def setUp(self):
        self.lock = threading.Lock()
        self.q = {}
        self.states = []
        self.stats = None
        rospy.Subscriber("joint_states", JointState, self.on_js)
        rospy.Subscriber("arm_controller/state", JointTrajectoryControllerState, self.on_state)
        rospy.Subscriber("sim_stats", SimStats, self.on_stats)
        self.pub = rospy.Publisher("arm_controller/command", JointTrajectory, queue_size=1)

    def on_js(self, msg):
        with self.lock:
            self.q = dict(zip(msg.name, msg.position))

    def on_state(self, msg):
        with self.lock:
            self.states.append(msg)

    def on_stats(self, msg):
        with self.lock:
            self.stats = msg

    def wait_for(self, what, seconds):
        for _ in range(int(seconds / 0.05)):
            with self.lock:
                if what():
                    return True
            wall_wait(0.05)
        return False

    def test_arrives_and_publishes_state(self):
        self.assertTrue(self.wait_for(lambda: self.pub.get_num_connections() > 0 and self.q
                                      and self.states and self.stats, 30),
                        "no subscriber on arm_controller/command or no joint_states / state")
        traj = JointTrajectory()
        traj.joint_names = JOINTS
        for k, t in enumerate((1.0, 2.0, 3.0)):
            p = JointTrajectoryPoint()
            p.positions = [s + (g - s) * (k + 1) / 3.0 for s, g in zip(START, GOAL)]
            p.time_from_start = rospy.Duration(t)
            traj.points.append(p)
        self.pub.publish(traj)  # header.stamp zero: now

        def arrived():
            return all(abs(self.q[j] - g) < 0.01 for j, g in zip(JOINTS, GOAL))
        self.assertTrue(self.wait_for(arrived, 30),
                        "not at the goal: %s" % {j: self.q.get(j) for j in JOINTS})
        wall_wait(0.5)
        with self.lock:
            last = self.states[-1]
            n = len(self.states)
        self.assertGreater(n, 10)
        self.assertEqual(list(last.joint_names), JOINTS)
        for k, g in enumerate(GOAL):
            self.assertAlmostEqual(last.desired.positions[k], g, places=9)
            self.assertAlmostEqual(last.actual.positions[k], g, delta=0.01)
            self.assertAlmostEqual(last.error.positions[k],
                                   last.desired.positions[k] - last.actual.positions[k],
                                   places=9)
        # A refused trajectory: counted, and the arm stays.
        with self.lock:
            before = self.stats.rejected_commands
        bad = JointTrajectory()
        bad.joint_names = ["no_such_joint"]
        p = JointTrajectoryPoint()
        p.positions = [0.0]
        p.time_from_start = rospy.Duration(1.0)
        bad.points.append(p)
        self.pub.publish(bad)
        self.assertTrue(self.wait_for(lambda: self.stats.rejected_commands > before, 10),
                        "the bad trajectory was not counted as rejected")
        wall_wait(0.5)
        with self.lock:
            self.assertTrue(arrived())


if __name__ == "__main__":
    rospy.init_node("trajectory_check")
    rostest.rosrun("se3_sim", "trajectory", Trajectory)
