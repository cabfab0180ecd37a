#!/usr/bin/python3
"""rostest of two robots in one world (test/multi_robot.test, docs/ros.md "Several robots").

Two Pandas without gravity: "left" (the node's own robot: joint_states, torque_command, bare
link names on TF) and "right" (namespace right: right/joint_states, right/torque_command, frames
right/LINK, right/robot_description). Checks: each one's torque command moves only that robot
(the other's joint_states stay exactly at their initial values); both robots' frames are on TF
where their scene puts them, with no frame name shared; the world services list both as models
and give each one's joints; right/chain_state carries what right/joint_states does, as
chain_state does for left; right's trajectory controller publishes right/wrist/state;
simulator/apply_wrench takes right's links as right/LINK (its TF frames) and moves only right."""
import os
import sys
import threading
import time
import unittest

import rospy
import rostest
from sensor_msgs.msg import JointState
from se3_sim.msg import Result
from se3_sim.msg import ChainState, JointTorques, JointTrajectoryControllerState
from se3_sim.srv import ApplyWrench, ApplyWrenchRequest
from se3_sim.srv import GetEntities, GetEntityState, ResetSimulation, ResetSimulationRequest
from std_srvs.srv import Trigger
from tf2_msgs.msg import TFMessage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import wait_util  # noqa: E402


class MultiRobotTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.lock = threading.Lock()
        cls.js = {"left": None, "right": None}
        cls.children = {}  # child frame -> parent frame, from /tf and /tf_static
        cls.transforms = {}  # child frame -> its last transform
        rospy.Subscriber("joint_states", JointState, cls.on_js, "left", queue_size=10)
        rospy.Subscriber("right/joint_states", JointState, cls.on_js, "right", queue_size=10)
        cls.chain = {"left": [], "right": []}  # every chain_state
        cls.js_seen = {"left": [], "right": []}  # every joint_states
        cls.ctl_state = None
        rospy.Subscriber("chain_state", ChainState, cls.on_chain, "left", queue_size=10)
        rospy.Subscriber("right/chain_state", ChainState, cls.on_chain, "right", queue_size=10)
        rospy.Subscriber("right/wrist/state", JointTrajectoryControllerState, cls.on_ctl,
                         queue_size=10)
        rospy.Subscriber("/tf", TFMessage, cls.on_tf, queue_size=100)
        rospy.Subscriber("/tf_static", TFMessage, cls.on_tf, queue_size=100)
        cls.cmd = {"left": rospy.Publisher("torque_command", JointTorques, queue_size=10),
                   "right": rospy.Publisher("right/torque_command", JointTorques, queue_size=10)}
        for name in ("get_entities", "get_entity_state", "reset_simulation", "apply_wrench",
                     "clear_wrenches"):
            rospy.wait_for_service("simulator/" + name, timeout=60)
        cls.apply = rospy.ServiceProxy("simulator/apply_wrench", ApplyWrench)
        cls.clear = rospy.ServiceProxy("simulator/clear_wrenches", Trigger)
        cls.entities = rospy.ServiceProxy("simulator/get_entities", GetEntities)
        cls.get = rospy.ServiceProxy("simulator/get_entity_state", GetEntityState)
        cls.reset = rospy.ServiceProxy("simulator/reset_simulation", ResetSimulation)

    @classmethod
    def on_js(cls, msg, who):
        with cls.lock:
            cls.js[who] = msg
            cls.js_seen[who].append(msg)

    @classmethod
    def on_chain(cls, msg, who):
        with cls.lock:
            cls.chain[who].append(msg)

    def chain_pairs(self, who):
        """(chain_state, joint_states) pairs of one publication (the same stamp)."""
        with self.lock:
            js = {m.header.stamp: m for m in self.js_seen[who]}
            return [(c, js[c.header.stamp]) for c in self.chain[who] if c.header.stamp in js]

    @classmethod
    def on_ctl(cls, msg):
        with cls.lock:
            cls.ctl_state = msg

    @classmethod
    def on_tf(cls, msg):
        with cls.lock:
            for t in msg.transforms:
                cls.children[t.child_frame_id] = t.header.frame_id
                cls.transforms[t.child_frame_id] = t.transform

    def wait_for(self, pred, timeout):
        return wait_util.wait_for(self.lock, pred, timeout)

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

    def test_4_chain_state_of_every_robot(self):
        # Each chain_state follows the joint_states of the same stamp (published just before it).
        end = time.time() + 20.0
        while time.time() < end and min(len(self.chain_pairs(w)) for w in self.chain) < 3:
            time.sleep(0.05)
        pairs = {w: self.chain_pairs(w) for w in ("left", "right")}
        for who in pairs:
            self.assertGreaterEqual(len(pairs[who]), 3, who)
        for who, y in (("left", -0.5), ("right", 0.5)):
            for cs, js in pairs[who]:
                self.assertEqual(list(cs.name), list(js.name), who)
                self.assertEqual(list(cs.position), list(js.position), who)
                self.assertEqual(list(cs.velocity), list(js.velocity), who)
                self.assertEqual(list(cs.effort), list(js.effort), who)
                self.assertEqual(cs.header.frame_id, "world", who)
                self.assertAlmostEqual(cs.base_pose.position.y, y, places=9)
                self.assertGreaterEqual(cs.kinetic_energy, 0.0)
                self.assertEqual(cs.potential_energy, 0.0)  # no gravity
        left, right = pairs["left"][-1][0], pairs["right"][-1][0]
        self.assertEqual(list(left.name), list(right.name))

    def test_5_trajectory_controller_state_of_robot_two(self):
        self.assertTrue(self.wait_for(lambda: self.ctl_state is not None, 20.0))
        with self.lock:
            m = self.ctl_state
        self.assertEqual(list(m.joint_names), ["panda_joint7"])
        self.assertEqual(len(m.actual.positions), 1)
        self.assertEqual(len(m.desired.positions), 1)
        q = self.fresh("right", 0.0)
        self.assertAlmostEqual(m.actual.positions[0], q["panda_joint7"], places=3)

    def test_6_apply_wrench_on_robot_two(self):
        r = self.reset(scope=ResetSimulationRequest.SCOPE_DEFAULT)
        self.assertEqual(r.result.result, Result.RESULT_OK, r.result.error_message)
        bad = self.apply(ApplyWrenchRequest(link="right/no_such_link", duration=0.1))
        self.assertFalse(bad.success)
        self.assertIn("unknown link 'right/no_such_link'", bad.message)
        self.assertNotIn("\n", bad.message)
        start = time.time()
        q0 = {w: self.fresh(w, start) for w in ("left", "right")}
        req = ApplyWrenchRequest(link="right/panda_link4", duration=0.3)
        req.wrench.force.x = 30.0
        res = self.apply(req)
        self.assertTrue(res.success, res.message)
        time.sleep(0.6)
        now = time.time()
        moved, still = self.fresh("right", now), self.fresh("left", now)
        self.assertGreater(max(abs(moved[j] - q0["right"][j]) for j in moved), 1e-3)
        self.assertEqual(still, q0["left"], "left moved under right's wrench")
        # Until cleared: clear_wrenches takes it off.
        req.duration = -1.0
        self.assertTrue(self.apply(req).success)
        c = self.clear()
        self.assertTrue(c.success)
        self.assertIn("cleared 1 wrench", c.message)


if __name__ == "__main__":
    rospy.init_node("multi_robot_check")
    rostest.rosrun("se3_sim", "multi_robot", MultiRobotTest)
