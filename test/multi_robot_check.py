#!/usr/bin/python3
"""rostest of two robots in one world (test/multi_robot.test, docs/ros.md "Several robots").

Two Pandas without gravity: "left" (the node's own robot: joint_states, torque_command, bare
link names on TF) and "right" (namespace right: right/joint_states, right/torque_command, frames
right/LINK, right/robot_description). Checks: each one's torque command moves only that robot
(the other's joint_states stay exactly at their initial values); both robots' frames are on TF
where their scene puts them, with no frame name shared; the world services list both as models
and give each one's joints."""
import threading
import time
import unittest

import rospy
import rostest
from sensor_msgs.msg import JointState
from se3_sim.msg import Result
from se3_sim.msg import JointTorques
from se3_sim.srv import GetEntities, GetEntityState, ResetSimulation, ResetSimulationRequest
from tf2_msgs.msg import TFMessage


class MultiRobotTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.lock = threading.Lock()
        cls.js = {"left": None, "right": None}
        cls.children = {}  # child frame -> parent frame, from /tf and /tf_static
        cls.transforms = {}  # child frame -> its last transform
        rospy.Subscriber("joint_states", JointState, cls.on_js, "left", queue_size=10)
        rospy.Subscriber("right/joint_states", JointState, cls.on_js, "right", queue_size=10)
        rospy.Subscriber("/tf", TFMessage, cls.on_tf, queue_size=100)
        rospy.Subscriber("/tf_static", TFMessage, cls.on_tf, queue_size=100)
        cls.cmd = {"left": rospy.Publisher("torque_command", JointTorques, queue_size=10),
                   "right": rospy.Publisher("right/torque_command", JointTorques, queue_size=10)}
        for name in ("get_entities", "get_entity_state", "reset_simulation"):
            rospy.wait_for_service("simulator/" + name, timeout=60)
        cls.entities = rospy.ServiceProxy("simulator/get_entities", GetEntities)
        cls.get = rospy.ServiceProxy("simulator/get_entity_state", GetEntityState)
        cls.reset = rospy.ServiceProxy("simulator/reset_simulation", ResetSimulation)

    @classmethod
    def on_js(cls, msg, who):
        with cls.lock:
            cls.js[who] = msg

    @classmethod
    def on_tf(cls, msg):
        with cls.lock:
            for t in msg.transforms:
                cls.children[t.child_frame_id] = t.header.frame_id
                cls.transforms[t.child_frame_id] = t.transform

    def wait_for(self, pred, timeout):
        end = time.time() + timeout
        while time.time() < end and not rospy.is_shutdown():
            with self.lock:
                if pred():
                    return True
            time.sleep(0.02)
        return False

    def positions(self, who):
        with self.lock:
            m = self.js[who]
            return dict(zip(m.name, m.position))

    def fresh(self, who, after):
        """The first joint_states of who stamped after the wall time `after`."""
        self.assertTrue(self.wait_for(
            lambda: self.js[who] is not None and self.js[who].header.stamp.to_sec() > after, 5.0))
        return self.positions(who)

    def drive(self, who, joint, effort):
        # rospy drops what a publisher sends before the node has connected to it; on a loaded
        # machine that connection can come after the first joint_states.
        self.assertTrue(self.wait_for(lambda: self.cmd[who].get_num_connections() > 0, 20.0), who)
        m = JointTorques()
        m.header.stamp = rospy.Time.now()
        m.name = [joint]
        m.effort = [effort]
        for _ in range(10):  # within the node's command timeout of 0.5 s
            self.cmd[who].publish(m)
            time.sleep(0.03)

    def test_1_each_command_moves_only_its_robot(self):
        self.assertTrue(self.wait_for(lambda: all(self.js.values()), 20.0))
        for who, other in (("right", "left"), ("left", "right")):
            r = self.reset(scope=ResetSimulationRequest.SCOPE_DEFAULT)
            self.assertEqual(r.result.result, Result.RESULT_OK, r.result.error_message)
            start = time.time()
            q0 = {w: self.fresh(w, start) for w in ("left", "right")}
            self.assertEqual(q0["left"], q0["right"])  # same initial positions, same joint names
            self.drive(who, "panda_joint1", 20.0)
            time.sleep(0.3)
            now = time.time()
            moved, still = self.fresh(who, now), self.fresh(other, now)
            self.assertGreater(abs(moved["panda_joint1"] - q0[who]["panda_joint1"]), 1e-3, who)
            self.assertEqual(still, q0[other], "%s moved when %s was commanded" % (other, who))

    def test_2_frames_do_not_collide(self):
        # The node's robot under its bare link names, the other one under right/.
        self.assertTrue(self.wait_for(
            lambda: "panda_link7" in self.children and "right/panda_link7" in self.children, 10.0))
        with self.lock:
            children = dict(self.children)
        self.assertEqual(children["panda_link0"], "world")
        self.assertEqual(children["right/panda_link0"], "world")
        self.assertEqual(children["right/panda_link1"], "right/panda_link0")
        self.assertEqual(children["right/panda_link8"], "right/panda_link7")  # /tf_static
        left = [c for c in children if c.startswith("panda_")]
        right = [c for c in children if c.startswith("right/")]
        self.assertEqual(sorted("right/" + c for c in left), sorted(right))
        with self.lock:
            l0 = self.transforms["panda_link0"]
            r0 = self.transforms["right/panda_link0"]
        self.assertAlmostEqual(l0.translation.y, -0.5, places=9)
        self.assertAlmostEqual(r0.translation.y, 0.5, places=9)
        self.assertTrue(rospy.has_param("right/robot_description"))
        self.assertIn("panda_link0", rospy.get_param("right/robot_description"))

    def test_3_world_services_list_both_robots(self):
        names = [e for e in self.entities().entities]
        self.assertIn("left", names)
        self.assertIn("right", names)
        g = self.get(entity="right", reference_frame="")
        self.assertEqual(g.result.result, Result.RESULT_OK, g.result.error_message)
        self.assertAlmostEqual(g.state.pose.position.y, 0.5, places=9)


if __name__ == "__main__":
    rospy.init_node("multi_robot_check")
    rostest.rosrun("se3_sim", "multi_robot", MultiRobotTest)
