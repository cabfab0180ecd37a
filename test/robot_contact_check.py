#!/usr/bin/python3
"""rostest of contact sensors on robots after the first (test/robot_contact.test).

Robot b (namespace b) of test/data/pendulums_contact.yaml rests on the ground: its scene sensor
publishes b/bumper (se3_sim/ContactsState) with contacts of b's base link on the ground. A
pendulum spawned over the block through simulator/spawn_entity, its URDF carrying a Gazebo
bumper (libgazebo_ros_bumper.so, bumperTopicName bumper), is accepted in this scene with
collision, comes to rest on the block (not through it) and reports the block on c/bumper."""
import os
import sys
import threading
import time
import unittest

import rospkg
import rospy
import rostest
from geometry_msgs.msg import Pose, PoseStamped
from se3_sim.msg import ContactsState, Resource, Result
from se3_sim.srv import GetEntityState, SpawnEntity

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import wait_util  # noqa: E402

BUMPER = """
  <gazebo reference="base_link">
    <sensor name="c_bumper" type="contact">
      <update_rate>50</update_rate>
      <plugin name="bumper" filename="libgazebo_ros_bumper.so">
        <bumperTopicName>bumper</bumperTopicName>
      </plugin>
    </sensor>
  </gazebo>
</robot>"""


class RobotContactTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.lock = threading.Lock()
        cls.last = {}
        for ns in ("b", "c"):
            rospy.Subscriber(ns + "/bumper", ContactsState, cls.on_contacts, ns, queue_size=10)
        for name in ("spawn_entity", "get_entity_state"):
            rospy.wait_for_service("simulator/" + name, timeout=60)
        cls.spawn = rospy.ServiceProxy("simulator/spawn_entity", SpawnEntity)
        cls.get = rospy.ServiceProxy("simulator/get_entity_state", GetEntityState)

    @classmethod
    def on_contacts(cls, msg, ns):
        with cls.lock:
            cls.last[ns] = msg

    def wait_for(self, pred, timeout):
        return wait_util.wait_for(self.lock, pred, timeout)

    def touching(self, ns, other):
        m = self.last.get(ns)
        return m is not None and any(s.collision2_name == other for s in m.states)

    def test_1_scene_robot_reports_the_ground(self):
        self.assertTrue(self.wait_for(lambda: self.touching("b", "ground"), 20.0),
                        "b/bumper: %s" % self.last.get("b"))
        with self.lock:
            m = self.last["b"]
        for s in m.states:
            self.assertTrue(s.collision1_name.startswith("b/"), s.collision1_name)
            self.assertEqual(s.collision2_name, "ground")
        self.assertEqual(m.header.frame_id, "world")

    def test_2_spawned_robot_lands_on_the_block_and_reports_it(self):
        path = os.path.join(rospkg.RosPack().get_path("se3_sim"),
                            "data/robots/double_pendulum_simple.urdf")
        with open(path) as f:
            urdf = f.read().replace("</robot>", BUMPER)
        pose = Pose()
        pose.position.x, pose.position.z = 2.0, 0.35
        pose.orientation.w = 1.0
        r = self.spawn(name="c", entity_resource=Resource(uri="", resource_string=urdf),
                       initial_pose=PoseStamped(pose=pose))
        self.assertEqual(r.result.result, Result.RESULT_OK, r.result.error_message)
        self.assertTrue(self.wait_for(lambda: self.touching("c", "block"), 20.0),
                        "c/bumper: %s" % self.last.get("c"))
        time.sleep(1.0)
        g = self.get(entity="c", reference_frame="")
        self.assertEqual(g.result.result, Result.RESULT_OK, g.result.error_message)
        self.assertGreater(g.state.pose.position.z, 0.2)  # on the block's top, not through it


if __name__ == "__main__":
    rospy.init_node("robot_contact_check")
    rostest.rosrun("se3_sim", "robot_contact", RobotContactTest)
