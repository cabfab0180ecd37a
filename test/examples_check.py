#!/usr/bin/python3
"""rostest for the shipped example package (test/examples.test): examples/two_link's launch file,
written like a Gazebo tutorial's (the controller YAML loaded by <rosparam command="load"> under
the robot's namespace), brings the arm up with its controllers in /two_link: a JointTrajectory on
/two_link/arm_controller/command takes joint1 to its goal, and a Float64MultiArray on
/two_link/wrist_velocity_controller/command turns joint2 at the commanded rate."""
import threading
import unittest

import rospy
import rostest
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint


def wall_wait(seconds):
    threading.Event().wait(seconds)


class TwoLinkExample(unittest.TestCase):
    def setUp(self):
        self.lock = threading.Lock()
        self.q = {}
        self.v = {}
        rospy.Subscriber("/joint_states", JointState, self.on_js)
        self.traj = rospy.Publisher("/two_link/arm_controller/command", JointTrajectory,
                                    queue_size=1)
        self.vel = rospy.Publisher("/two_link/wrist_velocity_controller/command",
                                   Float64MultiArray, queue_size=1)

    def on_js(self, msg):
        with self.lock:
            self.q = dict(zip(msg.name, msg.position))
            self.v = dict(zip(msg.name, msg.velocity))

    def wait_for(self, what, seconds):
        for _ in range(int(seconds / 0.05)):
            with self.lock:
                if what():
                    return True
            wall_wait(0.05)
        return False

    def test_controllers_in_the_robot_namespace(self):
        self.assertTrue(self.wait_for(lambda: self.traj.get_num_connections() > 0 and
                                      self.vel.get_num_connections() > 0 and self.q, 30),
                        "no subscriber on /two_link/*/command or no joint_states")
        t = JointTrajectory()
        t.joint_names = ["joint1"]
        p = JointTrajectoryPoint()
        p.positions = [0.8]
        p.time_from_start = rospy.Duration(1.0)
        t.points.append(p)
        self.traj.publish(t)
        self.assertTrue(self.wait_for(lambda: abs(self.q["joint1"] - 0.8) < 0.02, 30),
                        "joint1 not at 0.8: %s" % self.q.get("joint1"))
        self.vel.publish(Float64MultiArray(data=[0.5]))
        self.assertTrue(self.wait_for(lambda: abs(self.v["joint2"] - 0.5) < 0.05, 30),
                        "joint2 not turning at 0.5 rad/s: %s" % self.v.get("joint2"))


if __name__ == '__main__':
    rospy.init_node('examples_check')
    rostest.rosrun('se3_sim', 'examples_check', TwoLinkExample)
