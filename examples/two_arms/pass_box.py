#!/usr/bin/python3
"""Passes the box between the two arms of config/scenes/two_arms.yaml (docs/multi_robot.md,
"Passing the box"): the UR5 pushes it along the table onto the Panda's half, then the Panda
pushes it back onto the UR5's half. Each arm gets one trajectory_msgs/JointTrajectory on its
trajectory controller's topic (arm/command, panda/arm/command); the Panda's is sent once the
UR5's has run (the file's `wait`; simulated time when /use_sim_time is set).

  roslaunch se3_sim sim.launch scene:=two_arms
  rosrun se3_sim pass_box.py

The waypoints are pass_box.yaml's, which test/gtest_two_arms.cpp runs in the library
(TwoArms.UR5AndPandaPassTheBox): joint positions from the models' inverse kinematics of a
Cartesian plan (each tool pointing down as the scene starts it): down behind the box, along the
table through the box's place, up and back."""
import os
import sys

import rospy
import yaml
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

# The waypoints: pass_box.yaml beside this script, or the file in the private parameter ~file.
DEFAULT_FILE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "pass_box.yaml")


def trajectory(arm):
    t = JointTrajectory()
    t.joint_names = arm["joints"]
    for point in arm["points"]:
        p = JointTrajectoryPoint()
        p.positions = point["q"]
        p.time_from_start = rospy.Duration(point["t"])
        t.points.append(p)
    return t  # header.stamp zero: start now


def send(arm, timeout):
    """Sends one arm's trajectory once its controller subscribes, then waits arm["wait"]."""
    pub = rospy.Publisher(arm["topic"], JointTrajectory, queue_size=1, latch=True)
    deadline = rospy.Time.now() + rospy.Duration(timeout)
    while pub.get_num_connections() == 0 and not rospy.is_shutdown():
        if rospy.Time.now() > deadline:
            rospy.logerr("pass_box: nobody subscribes to %s (is the two_arms scene running?)",
                         pub.resolved_name)
            return False
        rospy.sleep(0.1)
    pub.publish(trajectory(arm))
    rospy.loginfo("pass_box: sent %s %d waypoints on %s", arm["name"], len(arm["points"]),
                  pub.resolved_name)
    rospy.sleep(arm["wait"])  # let it run, and the box settle
    return not rospy.is_shutdown()


def main():
    rospy.init_node("pass_box")
    path = rospy.get_param("~file", DEFAULT_FILE)
    with open(path) as f:
        arms = yaml.safe_load(f)["arms"]
    for arm in arms:
        if not send(arm, 30.0):
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
