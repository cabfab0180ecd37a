#!/usr/bin/python3
"""rostest of robots spawned and deleted at run time (test/spawn_robot.test, docs/ros.md "World
services", docs/multi_robot.md).

A fixed UR5 runs (publish_rate 50 Hz). Checks: a malformed URDF, a name in use and a non-finite
pose are refused naming the field, changing nothing; the Panda spawned from the parameter
panda_description (entity_resource.uri param:NAME) has its TF frames panda/LINK (under the world
frame, none on /tf_static) and panda/joint_states within 0.5 s of the reply (and
panda/chain_state with the same joints; simulator/apply_wrench takes its links as panda/LINK),
while the UR5's
joint_states have no gap longer than two periods; the world services and topics see it
(get_entities: a robot with its namespace; get and set its state; model_states, link_states,
sim_stats); deleting it stops its frames and joint_states and unadvertises its topics; the spawn
tool (rosrun se3_sim spawn -urdf -param ...) spawns it again, and a reset of the spawned entities
deletes it; allow_renaming gives a robot a suffix."""
import math
import subprocess
import os
import sys
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import Pose, PoseStamped
from sensor_msgs.msg import JointState
from se3_sim.msg import (ChainState, EntityCategory, LinkStates, ModelStates, Resource, Result,
                         SimStats)
from se3_sim.srv import (ApplyWrench, ApplyWrenchRequest, DeleteEntity, GetEntities, GetEntityState, ResetSimulation,
                         ResetSimulationRequest, SetEntityState, SpawnEntity, SpawnEntityResponse)
from tf2_msgs.msg import TFMessage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import wait_util  # noqa: E402

PERIOD = 1.0 / 50  # the node's publish_rate


def pose(x, y, z):
    p = Pose()
    p.position.x, p.position.y, p.position.z = x, y, z
    p.orientation.w = 1.0
    return p


class SpawnRobotTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.lock = threading.Lock()
        cls.ur5_stamps = []  # header stamps of the UR5's joint_states
        cls.js_at = {}  # namespace -> wall time of its last joint_states
        cls.js_first = {}  # namespace -> wall time of its first joint_states
        cls.tf_at = {}  # child frame -> wall time of its last /tf transform
        cls.tf_parent = {}
        cls.static_children = set()
        cls.models = cls.links = cls.stats = cls.chain = cls.js = None
        rospy.Subscriber("joint_states", JointState, cls.on_ur5, queue_size=100)
        for ns in ("panda", "arm2"):
            rospy.Subscriber(ns + "/joint_states", JointState, cls.on_js, ns, queue_size=10)
        rospy.Subscriber("panda/joint_states", JointState, cls.on_attr, "js", queue_size=10)
        rospy.Subscriber("panda/chain_state", ChainState, cls.on_attr, "chain", queue_size=10)
        rospy.Subscriber("/tf", TFMessage, cls.on_tf, queue_size=200)
        rospy.Subscriber("/tf_static", TFMessage, cls.on_static, queue_size=10)
        rospy.Subscriber("model_states", ModelStates, cls.on_attr, "models", queue_size=10)
        rospy.Subscriber("link_states", LinkStates, cls.on_attr, "links", queue_size=10)
        rospy.Subscriber("sim_stats", SimStats, cls.on_attr, "stats", queue_size=10)

        def srv(name, kind):
            rospy.wait_for_service("simulator/" + name, timeout=60)
            return rospy.ServiceProxy("simulator/" + name, kind)
        cls.spawn = srv("spawn_entity", SpawnEntity)
        cls.delete = srv("delete_entity", DeleteEntity)
        cls.entities = srv("get_entities", GetEntities)
        cls.get = srv("get_entity_state", GetEntityState)
        cls.set = srv("set_entity_state", SetEntityState)
        cls.apply = srv("apply_wrench", ApplyWrench)

    @classmethod
    def on_ur5(cls, msg):
        with cls.lock:
            cls.ur5_stamps.append(msg.header.stamp.to_sec())

    @classmethod
    def on_js(cls, msg, ns):
        with cls.lock:
            cls.js_at[ns] = time.time()
            cls.js_first.setdefault(ns, time.time())

    @classmethod
    def on_tf(cls, msg):
        now = time.time()
        with cls.lock:
            for t in msg.transforms:
                cls.tf_at[t.child_frame_id] = now
                cls.tf_parent[t.child_frame_id] = t.header.frame_id

    @classmethod
    def on_static(cls, msg):
        with cls.lock:
            for t in msg.transforms:
                cls.static_children.add(t.child_frame_id)

    @classmethod
    def on_attr(cls, msg, attr):
        with cls.lock:
            setattr(cls, attr, msg)

    def wait_for(self, pred, timeout):
        return wait_util.wait_for(self.lock, pred, timeout, poll=0.005)

    def names(self):
        r = self.entities()
        self.assertEqual(r.result.result, Result.RESULT_OK, r.result.error_message)
        return dict(zip(r.entities, zip(r.categories, r.namespaces)))

    def request(self, **kw):
        req = dict(name="panda", allow_renaming=False,
                   entity_resource=Resource(uri="param:/panda_description", resource_string=""),
                   entity_namespace="", initial_pose=PoseStamped(pose=pose(1.0, 0.0, 0.5)))
        req.update(kw)
        return self.spawn(**req)

    def test_1_refusals_change_nothing(self):
        self.assertTrue(self.wait_for(lambda: len(self.ur5_stamps) > 5, 10.0))
        before = self.names()
        self.assertEqual(len(before), 1, before)
        ur5 = list(before)[0]

        def refused(code, field, **kw):
            r = self.request(**kw)
            self.assertEqual(r.result.result, code, r.result.error_message)
            self.assertTrue(r.result.error_message.startswith(field), r.result.error_message)
        refused(SpawnEntityResponse.RESOURCE_PARSE_ERROR, "entity_resource",
                entity_resource=Resource(uri="", resource_string="<robot name='r'><link name='a'>"))
        refused(SpawnEntityResponse.RESOURCE_PARSE_ERROR, "entity_resource",
                entity_resource=Resource(uri="", resource_string="<robot name='r'/>"))
        refused(SpawnEntityResponse.NAME_NOT_UNIQUE, "name", name=ur5)
        refused(SpawnEntityResponse.INVALID_POSE, "initial_pose",
                initial_pose=PoseStamped(pose=pose(float("nan"), 0, 0.5)))
        refused(SpawnEntityResponse.NAMESPACE_INVALID, "entity_namespace",
                entity_namespace="bad ns")
        refused(SpawnEntityResponse.NO_RESOURCE, "entity_resource",
                entity_resource=Resource(uri="param:/no_such_parameter", resource_string=""))
        self.assertEqual(self.names(), before)
        n = len(self.ur5_stamps)
        self.assertTrue(self.wait_for(lambda: len(self.ur5_stamps) > n + 5, 5.0))  # runs on

    def largest_gap(self, start, end):
        with self.lock:
            stamps = [s for s in self.ur5_stamps if start <= s <= end]
        self.assertGreater(len(stamps), 5)
        return max(b - a for a, b in zip(stamps, stamps[1:]))

    def test_2_spawn_from_parameter(self):
        # The node's own jitter on this machine over a quiet second, for comparison.
        q0 = time.time()
        time.sleep(1.0)
        quiet = self.largest_gap(q0, time.time())
        t0 = time.time()
        r = self.request()
        t1 = time.time()
        self.assertEqual(r.result.result, Result.RESULT_OK, r.result.error_message)
        self.assertEqual(r.entity_name, "panda")
        self.assertTrue(self.wait_for(lambda: "panda" in self.js_first and
                                      self.tf_parent.get("panda/panda_link0") == "world" and
                                      "panda/panda_hand" in self.tf_at, 5.0))
        with self.lock:
            js_latency = self.js_first["panda"] - t1
            tf_latency = self.tf_at["panda/panda_link0"] - t1
        rospy.loginfo("spawn_entity took %.3f s; panda/joint_states %.3f s and its TF %.3f s "
                      "after the reply", t1 - t0, js_latency, tf_latency)
        self.assertLess(js_latency, 0.5)
        self.assertLess(tf_latency, 0.5)
        # The UR5's stream over the spawn: no gap longer than two periods (or than the largest
        # of a quiet second when the machine's load makes those longer: the spawn adds none).
        time.sleep(0.3)
        gap = self.largest_gap(t0 - 0.1, t1 + 0.3)
        rospy.loginfo("UR5 joint_states: largest gap %.4f s over the spawn, %.4f s over a quiet "
                      "second (period %.3f s)", gap, quiet, PERIOD)
        self.assertLessEqual(gap, max(2 * PERIOD, quiet) + 0.002)
        # Every frame of it on /tf (none latched on /tf_static), its description set.
        with self.lock:
            self.assertFalse([c for c in self.static_children if c.startswith("panda/")])
        self.assertIn("<robot", rospy.get_param("/panda/robot_description"))
        # Its chain_state, and wrenches on its links by their frame names.
        self.assertTrue(self.wait_for(lambda: self.chain is not None and self.js is not None,
                                      5.0))
        with self.lock:
            self.assertEqual(list(self.chain.name), list(self.js.name))
            self.assertEqual(self.chain.header.frame_id, "world")
        w = self.apply(ApplyWrenchRequest(link="panda/panda_hand", duration=0.01))
        self.assertTrue(w.success, w.message)
        # The world services and topics see it.
        names = self.names()
        self.assertEqual(names["panda"], (EntityCategory.CATEGORY_ROBOT, "panda"))
        r = self.request()
        self.assertEqual(r.result.result, SpawnEntityResponse.NAME_NOT_UNIQUE)
        self.assertTrue(r.result.error_message.startswith("name"), r.result.error_message)
        g = self.get(entity="panda", reference_frame="")
        self.assertEqual(g.result.result, Result.RESULT_OK, g.result.error_message)
        self.assertLess(g.state.pose.position.z, 0.5)  # a free base: it falls
        s = self.set(entity="panda", state=g.state)
        self.assertEqual(s.result.result, Result.RESULT_OK, s.result.error_message)
        g.state.pose.position.x = 3.0
        g.state.pose.position.z = 2.0
        s = self.set(entity="panda", state=g.state)
        self.assertEqual(s.result.result, Result.RESULT_OK, s.result.error_message)
        g2 = self.get(entity="panda::panda_link0", reference_frame="")
        self.assertEqual(g2.result.result, Result.RESULT_OK, g2.result.error_message)
        self.assertAlmostEqual(g2.state.pose.position.x, 3.0, delta=1e-6)
        self.assertTrue(self.wait_for(lambda: self.models is not None and
                                      "panda" in self.models.name and self.links is not None and
                                      "panda::panda_hand" in self.links.name, 5.0))
        # A name in use with allow_renaming: a suffix, and the namespace follows the name.
        r = self.request(allow_renaming=True)
        self.assertEqual(r.result.result, Result.RESULT_OK, r.result.error_message)
        self.assertEqual(r.entity_name, "panda_1")
        self.assertEqual(self.names()["panda_1"], (EntityCategory.CATEGORY_ROBOT, "panda_1"))
        r = self.request(allow_renaming=True)
        self.assertEqual(r.result.result, Result.RESULT_OK, r.result.error_message)
        self.assertEqual(r.entity_name, "panda_2")
        for name in ("panda_1", "panda_2"):
            d = self.delete(entity=name)
            self.assertEqual(d.result.result, Result.RESULT_OK, d.result.error_message)
        self.assertTrue(self.wait_for(lambda: self.stats is not None and
                                      self.stats.spawned == 3 and self.stats.deleted == 2, 5.0))

    def test_3_delete_stops_frames_and_topics(self):
        self.assertIn("panda", self.names())
        d = self.delete(entity="panda")
        self.assertEqual(d.result.result, Result.RESULT_OK, d.result.error_message)
        t1 = time.time()
        self.assertNotIn("panda", self.names())
        time.sleep(0.5)
        with self.lock:
            late_tf = [c for c, t in self.tf_at.items() if c.startswith("panda/") and t > t1 + 0.1]
            late_js = self.js_at["panda"] > t1 + 0.1
        self.assertEqual(late_tf, [])
        self.assertFalse(late_js)
        topics = [t for t, _ in rospy.get_published_topics()]
        self.assertNotIn("/panda/joint_states", topics)
        self.assertNotIn("/panda/chain_state", topics)
        w = self.apply(ApplyWrenchRequest(link="panda/panda_hand", duration=0.01))
        self.assertFalse(w.success)
        self.assertFalse(rospy.has_param("/panda/robot_description"))
        self.assertTrue(self.wait_for(lambda: self.models is not None and
                                      "panda" not in self.models.name, 5.0))
        self.assertTrue(self.wait_for(lambda: self.stats is not None and
                                      self.stats.deleted == 3, 5.0))
        d = self.delete(entity="panda")
        self.assertEqual(d.result.result, Result.RESULT_NOT_FOUND)
        # From a file (a package:// URI) too.
        r = self.request(name="panda_file", entity_resource=Resource(
            uri="package://se3_sim/data/robots/panda.urdf", resource_string=""))
        self.assertEqual(r.result.result, Result.RESULT_OK, r.result.error_message)
        self.assertTrue(self.wait_for(lambda: "panda_file/panda_link0" in self.tf_at, 5.0))
        d = self.delete(entity="panda_file")
        self.assertEqual(d.result.result, Result.RESULT_OK, d.result.error_message)

    def test_4_spawn_tool(self):
        out = subprocess.run(["rosrun", "se3_sim", "spawn", "-urdf", "-param", "panda_description",
                              "-model", "panda2", "-robot_namespace", "arm2",
                              "-x", "-1", "-y", "0.5", "-z", "0.8", "-Y", "1.57"],
                             capture_output=True, text=True, timeout=60)
        self.assertEqual(out.returncode, 0, out.stdout + out.stderr)
        names = self.names()
        self.assertEqual(names["panda2"], (EntityCategory.CATEGORY_ROBOT, "arm2"))
        self.assertTrue(self.wait_for(lambda: "arm2" in self.js_first and
                                      "arm2/panda_link0" in self.tf_at, 5.0))
        g = self.get(entity="panda2", reference_frame="")
        self.assertAlmostEqual(g.state.pose.position.x, -1, delta=0.01)
        yaw = 2 * math.atan2(g.state.pose.orientation.z, g.state.pose.orientation.w)
        self.assertAlmostEqual(yaw, 1.57, delta=1e-6)
        # A reset of the spawned entities deletes it, topics and all.
        reset = rospy.ServiceProxy("simulator/reset_simulation", ResetSimulation)
        r = reset(scope=ResetSimulationRequest.SCOPE_SPAWNED)
        self.assertEqual(r.result.result, Result.RESULT_OK, r.result.error_message)
        self.assertNotIn("panda2", self.names())
        topics = [t for t, _ in rospy.get_published_topics()]
        self.assertNotIn("/arm2/joint_states", topics)
        self.assertFalse(rospy.has_param("/arm2/robot_description"))


if __name__ == "__main__":
    rospy.init_node("spawn_robot_check")
    rostest.rosrun("se3_sim", "spawn_robot_check", SpawnRobotTest, sys.argv)
