#!/usr/bin/python3
"""rostest of the world services and topics (test/world.test, docs/ros.md "World services").

The scene (test/data/world_scene.yaml): a fixed chain, a static table and a box on it, with
sim time. Checks: the features; the entity list with categories; spawning an object from YAML
text (it shows on model_states within 0.5 s and falls), with its refusals (name in use, bad
name, malformed YAML, non-finite pose, a malformed URDF) changing nothing; renaming; entity and link states
round-trip; stepping a paused simulation by N steps; reset of the world (time runs on) and of
the simulation (time 0, spawned objects gone); delete; sim_stats counts; the spawn tool."""
import math
import os
import subprocess
import sys
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import Pose, PoseStamped
from rosgraph_msgs.msg import Clock
from se3_sim.msg import (EntityCategory, EntityFilters, EntityState, LinkStates, ModelStates,
                         Resource, Result, SimStats, SimulationState, SimulatorFeatures)
from se3_sim.srv import (DeleteEntity, GetEntities, GetEntitiesStates, GetEntityState,
                         GetSimulationState, GetSimulatorFeatures, ResetSimulation,
                         ResetSimulationRequest, SetEntityState, SetSimulationState, SpawnEntity,
                         SpawnEntityResponse,
                         StepSimulation)

HERE = os.path.dirname(os.path.abspath(__file__))
BALL = "name: ball\nshape: {sphere: 0.05}\nmass: 0.5\n"


def srv(name, kind):
    rospy.wait_for_service("simulator/" + name, timeout=60)
    return rospy.ServiceProxy("simulator/" + name, kind)


def pose(x, y, z, qx=0.0, qy=0.0, qz=0.0, qw=1.0):
    p = Pose()
    p.position.x, p.position.y, p.position.z = x, y, z
    p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w = qx, qy, qz, qw
    return p


class WorldTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.lock = threading.RLock()
        cls.models = None
        cls.models_at = {}  # name -> wall time first seen on model_states
        cls.links = None
        cls.clock = None
        cls.clock_min = float("inf")  # the smallest /clock since it was last set to inf
        cls.stats = None
        rospy.Subscriber("model_states", ModelStates, cls.on_models, queue_size=10)
        rospy.Subscriber("link_states", LinkStates, cls.on_links, queue_size=10)
        rospy.Subscriber("/clock", Clock, cls.on_clock, queue_size=10)
        rospy.Subscriber("sim_stats", SimStats, cls.on_stats, queue_size=10)
        cls.spawn = srv("spawn_entity", SpawnEntity)
        cls.delete = srv("delete_entity", DeleteEntity)
        cls.entities = srv("get_entities", GetEntities)
        cls.get = srv("get_entity_state", GetEntityState)
        cls.set = srv("set_entity_state", SetEntityState)
        cls.states = srv("get_entities_states", GetEntitiesStates)
        cls.step = srv("step_simulation", StepSimulation)
        cls.reset = srv("reset_simulation", ResetSimulation)
        cls.features = srv("get_simulator_features", GetSimulatorFeatures)
        cls.set_sim = srv("set_simulation_state", SetSimulationState)
        cls.get_sim = srv("get_simulation_state", GetSimulationState)

    @classmethod
    def on_models(cls, msg):
        with cls.lock:
            cls.models = msg
            for n in msg.name:
                cls.models_at.setdefault(n, time.time())

    @classmethod
    def on_links(cls, msg):
        with cls.lock:
            cls.links = msg

    @classmethod
    def on_clock(cls, msg):
        with cls.lock:
            cls.clock = msg.clock.to_sec()
            cls.clock_min = min(cls.clock_min, cls.clock)

    @classmethod
    def on_stats(cls, msg):
        with cls.lock:
            cls.stats = msg

    def wait_for(self, what, timeout=10.0):
        end = time.time() + timeout
        while time.time() < end:
            with self.lock:
                v = what()
            if v:
                return v
            time.sleep(0.02)
        return None

    def model_z(self, name):
        with self.lock:
            if self.models is None or name not in self.models.name:
                return None
            return self.models.pose[self.models.name.index(name)].position.z

    def names(self):
        r = self.entities(filters=EntityFilters())
        self.assertEqual(r.result.result, Result.RESULT_OK)
        return list(r.entities)

    def play(self, playing):
        s = SimulationState()
        s.state = SimulationState.STATE_PLAYING if playing else SimulationState.STATE_PAUSED
        self.set_sim(s)

    def test_1_features_and_entities(self):
        f = self.features().features
        for want in (SimulatorFeatures.SPAWNING, SimulatorFeatures.DELETING,
                     SimulatorFeatures.ENTITY_STATE_GETTING,
                     SimulatorFeatures.ENTITY_STATE_SETTING,
                     SimulatorFeatures.SIMULATION_RESET_STATE,
                     SimulatorFeatures.STEP_SIMULATION_MULTIPLE):
            self.assertIn(want, f.features)
        r = self.entities(filters=EntityFilters())
        self.assertEqual(r.result.result, Result.RESULT_OK)
        self.assertEqual(r.entities[1:], ["table", "box"])
        self.assertEqual(list(r.categories), [EntityCategory.CATEGORY_ROBOT,
                                              EntityCategory.CATEGORY_STATIC,
                                              EntityCategory.CATEGORY_OBJECT])
        r = self.entities(filters=EntityFilters(filter="^b.x$"))
        self.assertEqual(r.entities, ["box"])
        r = self.entities(filters=EntityFilters(filter="("))
        self.assertEqual(r.result.result, Result.RESULT_OPERATION_FAILED)
        self.assertIn("filters.filter", r.result.error_message)

    def test_2_spawn_falls_and_refusals(self):
        self.play(True)
        before = self.names()
        t0 = time.time()
        r = self.spawn(name="", allow_renaming=False,
                       entity_resource=Resource(uri="", resource_string=BALL),
                       entity_namespace="", initial_pose=PoseStamped(pose=pose(-2, 0, 2)))
        self.assertEqual(r.result.result, Result.RESULT_OK, r.result.error_message)
        self.assertEqual(r.entity_name, "ball")
        self.assertTrue(self.wait_for(lambda: "ball" in self.models_at, 5.0), "not on model_states")
        with self.lock:
            self.assertLess(self.models_at["ball"] - t0, 0.5 + 0.1)  # 0.1: the call's own time
        z0 = self.model_z("ball")
        self.assertTrue(self.wait_for(lambda: (self.model_z("ball") or 9) < z0 - 0.05, 10.0),
                        "the ball does not fall")
        self.assertTrue(self.wait_for(lambda: self.links is not None and
                                      "ball::ball" in self.links.name, 5.0))

        def refused(code, why, **kw):
            req = dict(name="", allow_renaming=False,
                       entity_resource=Resource(uri="", resource_string=BALL),
                       entity_namespace="", initial_pose=PoseStamped())
            req.update(kw)
            r = self.spawn(**req)
            self.assertEqual(r.result.result, code, r.result.error_message)
            self.assertIn(why, r.result.error_message)

        refused(SpawnEntityResponse.NAME_NOT_UNIQUE, "'ball' is already a model's")
        refused(SpawnEntityResponse.NAME_INVALID, "not a frame name", name="a/b")
        refused(SpawnEntityResponse.RESOURCE_PARSE_ERROR, "shape.sphere",
                entity_resource=Resource(uri="", resource_string="name: x\nshape: {sphere: -1}\n"))
        refused(SpawnEntityResponse.INVALID_POSE, "initial_pose",
                initial_pose=PoseStamped(pose=pose(float("nan"), 0, 1)), name="nan_ball")
        refused(SpawnEntityResponse.RESOURCE_PARSE_ERROR, "entity_resource",
                entity_resource=Resource(uri="", resource_string="<robot name='r'/>"))
        refused(SpawnEntityResponse.NO_RESOURCE, "entity_resource",
                entity_resource=Resource(uri="", resource_string=""))
        refused(SpawnEntityResponse.NO_RESOURCE, "/nonexistent.yaml",
                entity_resource=Resource(uri="/nonexistent.yaml", resource_string=""))
        self.assertEqual(self.names(), before + ["ball"])
        r = self.spawn(name="ball", allow_renaming=True,
                       entity_resource=Resource(uri="", resource_string=BALL),
                       entity_namespace="", initial_pose=PoseStamped(pose=pose(-3, 0, 2)))
        self.assertEqual(r.result.result, Result.RESULT_OK, r.result.error_message)
        self.assertEqual(r.entity_name, "ball_1")
        d = self.delete(entity="ball_1")
        self.assertEqual(d.result.result, Result.RESULT_OK, d.result.error_message)
        self.assertNotIn("ball_1", self.names())
        self.assertTrue(self.wait_for(lambda: self.models is not None and
                                      "ball_1" not in self.models.name, 5.0))
        d = self.delete(entity="nothing")
        self.assertEqual(d.result.result, Result.RESULT_NOT_FOUND)
        robot = self.names()[0]
        d = self.delete(entity=robot)
        self.assertEqual(d.result.result, Result.RESULT_OPERATION_FAILED)
        self.assertIn("cannot be deleted", d.result.error_message)
        self.assertTrue(self.wait_for(lambda: self.stats is not None and
                                      self.stats.spawned == 2 and self.stats.deleted == 1, 5.0))

    def test_3_states_round_trip_and_step(self):
        self.play(False)
        self.assertEqual(self.get_sim().state.state, SimulationState.STATE_PAUSED)
        s = EntityState()
        s.pose = pose(3.1, 0.05, 0.5, 0.0, 0.0, math.sin(0.35), math.cos(0.35))
        s.twist.linear.x, s.twist.linear.y, s.twist.linear.z = 0.1, -0.2, 0.3
        s.twist.angular.x, s.twist.angular.y, s.twist.angular.z = 0.4, 0.5, -0.6
        r = self.set(entity="box", state=s)
        self.assertEqual(r.result.result, Result.RESULT_OK, r.result.error_message)
        g = self.get(entity="box", reference_frame="")
        self.assertEqual(g.result.result, Result.RESULT_OK)
        p, q = g.state.pose.position, g.state.pose.orientation
        self.assertLess(abs(p.x - 3.1) + abs(p.y - 0.05) + abs(p.z - 0.5), 1e-12)
        self.assertLess(abs(q.z - math.sin(0.35)) + abs(q.w - math.cos(0.35)) + abs(q.x), 1e-12)
        t = g.state.twist
        self.assertLess(abs(t.linear.x - 0.1) + abs(t.linear.y + 0.2) + abs(t.angular.z + 0.6),
                        1e-12)
        link = self.get(entity="box::box", reference_frame="")
        self.assertLess(abs(link.state.pose.position.z - 0.5), 1e-12)
        # An interpenetrating state is accepted and reported.
        r = self.set(entity="box", state=EntityState(pose=pose(3.0, 0.0, 0.12)))
        self.assertEqual(r.result.result, Result.RESULT_OK)
        self.assertIn("interpenetrate", r.result.error_message)
        # Refusals.
        r = self.set(entity="nothing", state=s)
        self.assertEqual(r.result.result, Result.RESULT_NOT_FOUND)
        r = self.set(entity="box", state=EntityState(pose=pose(0, 0, 0, 0, 0, 0, 2)))
        self.assertEqual(r.result.result, Result.RESULT_OPERATION_FAILED)
        self.assertIn("state.pose", r.result.error_message)
        r = self.set(entity="table", state=EntityState(pose=pose(3, 0, 0.05), twist=s.twist))
        self.assertEqual(r.result.result, Result.RESULT_OPERATION_FAILED)
        self.assertIn("static", r.result.error_message)
        g = self.get(entity="nothing::link", reference_frame="")
        self.assertEqual(g.result.result, Result.RESULT_NOT_FOUND)
        # Step N while paused: the clock moves by N steps exactly; playing, stepping is refused.
        self.assertTrue(self.wait_for(lambda: self.clock is not None, 5.0))
        time.sleep(0.3)
        with self.lock:
            c0 = self.clock
        r = self.step(steps=100)
        self.assertEqual(r.result.result, Result.RESULT_OK, r.result.error_message)
        self.assertTrue(self.wait_for(lambda: abs(self.clock - (c0 + 0.1)) < 1e-6, 5.0),
                        (c0, self.clock))
        self.play(True)
        r = self.step(steps=1)
        self.assertEqual(r.result.result, Result.RESULT_INCORRECT_STATE)
        st = self.states(filters=EntityFilters())
        self.assertEqual(list(st.entities), self.names())

    def test_4_reset_world_then_simulation(self):
        self.play(True)
        self.assertTrue(self.wait_for(lambda: (self.clock or 0) > 0.5, 20.0))
        with self.lock:
            c0 = self.clock
        r = self.reset(scope=ResetSimulationRequest.SCOPE_STATE)
        self.assertEqual(r.result.result, Result.RESULT_OK, r.result.error_message)
        g = self.get(entity="box", reference_frame="")
        self.assertAlmostEqual(g.state.pose.position.z, 0.15, delta=0.01)
        self.assertIn("ball", self.names())  # spawned entities stay
        time.sleep(0.5)
        with self.lock:
            self.assertGreater(self.clock, c0)  # time ran on
        with self.lock:
            WorldTest.clock_min = float("inf")
        r = self.reset(scope=0)  # SCOPE_DEFAULT: everything
        self.assertEqual(r.result.result, Result.RESULT_OK, r.result.error_message)
        self.assertNotIn("ball", self.names())
        # Time went back to 0 (and runs on from there).
        self.assertTrue(self.wait_for(lambda: self.clock_min < 0.05, 5.0), self.clock_min)

    def test_5_spawn_tool(self):
        self.play(True)
        out = subprocess.run(["rosrun", "se3_sim", "spawn", "-file",
                              os.path.join(HERE, "data", "world_ball.yaml"), "-model", "cli_ball",
                              "-x", "-1", "-y", "2", "-z", "3", "-Y", "0.5"],
                             capture_output=True, text=True, timeout=60)
        self.assertEqual(out.returncode, 0, out.stdout + out.stderr)
        self.assertIn("cli_ball", self.names())
        g = self.get(entity="cli_ball", reference_frame="")
        self.assertAlmostEqual(g.state.pose.position.x, -1, delta=0.01)
        out = subprocess.run(["rosrun", "se3_sim", "spawn", "-file",
                              os.path.join(HERE, "data", "world_ball.yaml"), "-model", "cli_ball"],
                             capture_output=True, text=True, timeout=60)
        self.assertEqual(out.returncode, 1)
        self.assertIn("already a model's", out.stderr)


if __name__ == "__main__":
    rospy.init_node("world_check")
    rostest.rosrun("se3_sim", "world_check", WorldTest, sys.argv)
