#!/usr/bin/python3
"""rostest (test/world_contact.test): a plate spawned above the double pendulum's fixed
base (1 m up) lands on the robot's collision shapes, not on the ground: the node's robot keeps
its collision shapes in the scene collision after its start-up (joint limits on), so spawned
objects touch the robot."""
import sys
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import Pose, PoseStamped
from se3_sim.msg import Resource, Result
from se3_sim.srv import GetEntityState, SpawnEntity

PLATE = "name: plate\nshape: {box: [0.3, 0.3, 0.02]}\nmass: 0.2\n"


class WorldContactTest(unittest.TestCase):
    def test_spawned_object_lands_on_the_robot(self):
        rospy.wait_for_service("simulator/spawn_entity", timeout=60)
        spawn = rospy.ServiceProxy("simulator/spawn_entity", SpawnEntity)
        get = rospy.ServiceProxy("simulator/get_entity_state", GetEntityState)
        p = Pose()
        p.position.z = 1.5
        p.orientation.w = 1.0
        r = spawn(name="", allow_renaming=False,
                  entity_resource=Resource(uri="", resource_string=PLATE),
                  entity_namespace="", initial_pose=PoseStamped(pose=p))
        self.assertEqual(r.result.result, Result.RESULT_OK, r.result.error_message)
        t0 = get(entity="plate", reference_frame="").state.header.stamp.to_sec()
        end = time.time() + 30
        z = None
        while time.time() < end:
            s = get(entity="plate", reference_frame="").state
            if s.header.stamp.to_sec() > t0 + 0.6:
                z = s.pose.position.z
                break
            time.sleep(0.05)
        self.assertIsNotNone(z, "the simulation did not run 0.6 s")
        # Free fall from 1.5 m would have reached the ground (z = 0.01) after 0.5 s.
        self.assertGreater(z, 0.7, "the plate fell through the robot")


if __name__ == "__main__":
    rospy.init_node("world_contact_check")
    rostest.rosrun("se3_sim", "world_contact_check", WorldContactTest, sys.argv)
