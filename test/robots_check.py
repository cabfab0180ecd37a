#!/usr/bin/python3
"""Bring your own robot (issue 19): `roslaunch se3_sim sim.launch robot:=FILE.urdf` with every
URDF of data/robots and test/data's quirky robots, one launch after another on this rostest's
master, under the generic defaults (no scene). Each must run and publish finite joint_states
with the URDF's moving joints and a TF tree that reaches every link from `world`; a fixed base
stays where it is, a free one (floating:=true, or a floating joint from the world in the URDF)
moves under gravity (on the generic scene's ground). For test/data/quirky.urdf each quirk's warning appears once in the log.

Started by test/robots.test (rostest).
"""
import math
import os
import select
import signal
import subprocess
import sys
import tempfile
import threading
import time
import unittest
import xml.etree.ElementTree as ET

import rosgraph
import rospy
import rostest
from se3_sim.msg import JointTorques
from sensor_msgs.msg import JointState
from tf2_msgs.msg import TFMessage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tf_tree_util import TfTree  # noqa: E402

PKG = 'se3_sim'
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # the package
MOVING = ('revolute', 'continuous', 'prismatic')


def urdf_links_and_joints(path):
    """Link names (leading '/' stripped, as TF frames cannot have it) with the root first, and
    the moving joints."""
    root = ET.parse(path).getroot()
    links = [l.get('name').lstrip('/') for l in root.findall('link')]
    children = {j.find('child').get('link').lstrip('/') for j in root.findall('joint')}
    links.sort(key=lambda l: l in children)  # the root (no parent joint) first
    joints = [j.get('name') for j in root.findall('joint') if j.get('type') in MOVING]
    return links, joints


class Recorder:
    """joint_states and TF from the current launch (cleared between launches)."""

    def __init__(self):
        self.lock = threading.Lock()
        self.clear()
        rospy.Subscriber('joint_states', JointState, self._js, queue_size=100)
        rospy.Subscriber('/tf', TFMessage, self._tf, queue_size=1000)
        rospy.Subscriber('/tf_static', TFMessage, self._tf, queue_size=100)

    def clear(self):
        with getattr(self, 'lock', threading.Lock()):
            self.states = []
            self.tree = TfTree()

    def _js(self, msg):
        with self.lock:
            self.states.append(msg)

    def _tf(self, msg):
        with self.lock:
            self.tree.add(msg)

    def snapshot(self):
        with self.lock:
            tree = TfTree()
            tree.edges = dict(self.tree.edges)
            return list(self.states), tree


class Launch:
    def __init__(self, args, launch_file='sim.launch', stdin=subprocess.DEVNULL):
        self.log = tempfile.TemporaryFile()
        env = dict(os.environ, PYTHONUNBUFFERED='1')
        self.proc = subprocess.Popen(['roslaunch', PKG, launch_file] + args, stdin=stdin,
                                     stdout=self.log, stderr=subprocess.STDOUT, env=env,
                                     start_new_session=True)

    def text(self):
        self.log.seek(0)
        return self.log.read().decode(errors='replace')

    def stop(self):
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGINT)
            try:
                self.proc.wait(15)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()


def finite(values):
    return all(math.isfinite(x) for x in values)


class BringYourOwnRobot(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node('robots_check')
        cls.rec = Recorder()

    def run_robot(self, urdf, args=(), free=False, joints=None, warnings=()):
        """Launches sim.launch robot:=urdf (args...), checks what it publishes, stops it; returns
        the launch's log."""
        links, urdf_joints = urdf_links_and_joints(urdf)
        joints = urdf_joints if joints is None else joints
        self.rec.clear()
        launch = Launch(['robot:=' + urdf] + list(args))
        try:
            deadline = time.time() + 30
            while time.time() < deadline and launch.proc.poll() is None:
                states, tree = self.rec.snapshot()
                if len(states) >= 3 and all(tree.pose(l) is not None for l in links):
                    break
                time.sleep(0.1)
            states, tree = self.rec.snapshot()
            log = launch.text()
            name = os.path.basename(urdf) + ' ' + ' '.join(args)
            self.assertIsNone(launch.proc.poll(), '%s: the launch ended:\n%s' % (name, log))
            self.assertGreaterEqual(len(states), 3, '%s: no joint_states:\n%s' % (name, log))
            for m in states[-3:]:
                self.assertEqual(sorted(m.name), sorted(joints), name)
                for field in (m.position, m.velocity, m.effort):
                    self.assertEqual(len(field), len(joints), name)
                    self.assertTrue(finite(field), '%s: %s' % (name, m))
            missing = [l for l in links if tree.pose(l) is None]
            self.assertEqual(missing, [], '%s: links without TF from world' % name)
            base = links[0]
            z0 = tree.pose(base)[0][2]
            time.sleep(0.4)
            _, tree = self.rec.snapshot()
            for l in links:
                p, q = tree.pose(l)
                self.assertTrue(finite(p) and finite(q), '%s: TF of %s: %s %s' % (name, l, p, q))
            dz = tree.pose(base)[0][2] - z0
            if free:
                # Under gravity on the generic scene's ground: it settles or topples where its
                # links have collision shapes, falls through where they have none (romeo's
                # collision meshes are not shipped; quirky.urdf's base has no shape).
                self.assertNotEqual(dz, 0.0, '%s: a free base moves under gravity' % name)
            else:
                self.assertEqual(dz, 0.0, '%s: a fixed base stays' % name)
            log = launch.text()
            for w in warnings:
                self.assertEqual(log.count(w), 1, '%s: warning %r once in:\n%s' % (name, w, log))
            return log
        finally:
            launch.stop()

    def test_every_robot_of_data_robots(self):
        robots = os.path.join(ROOT, 'data', 'robots')
        legged = ('anymal_c.urdf', 'hyq_no_sensors.urdf', 'romeo_small.urdf', 'solo12.urdf')
        for f in sorted(os.listdir(robots)):
            if not f.endswith('.urdf'):
                continue
            path = os.path.join(robots, f)
            # The generic default: a fixed base. Legged robots also with a free one.
            self.run_robot(path)
            if f in legged:
                self.run_robot(path, ['floating:=true'], free=True)

    def test_quirky_robot(self):
        path = os.path.join(ROOT, 'test', 'data', 'quirky.urdf')
        quirks = ['/shoulder', 'elbow', 'wrist']  # sensor_joint moves nothing: locked
        self.run_robot(path, joints=quirks, warnings=QUIRK_WARNINGS)  # fixed: the default
        self.run_robot(path, ['floating:=true'], free=True, joints=quirks)


    def launch_fails(self, args, needles):
        """sim.launch args... must end with a FATAL line holding every needle."""
        launch = Launch(args)
        try:
            launch.proc.wait(30)
        except subprocess.TimeoutExpired:
            pass
        finally:
            launch.stop()
        log = launch.text()
        fatal = [l for l in log.splitlines() if 'FATAL' in l]
        self.assertTrue(fatal, 'no FATAL line for %s:\n%s' % (args, log))
        for n in needles:
            self.assertIn(n, fatal[0])

    def wait_for_robot(self, joint, timeout=30):
        deadline = time.time() + timeout
        while time.time() < deadline:
            states, _ = self.rec.snapshot()
            if states and joint in states[-1].name:
                return states[-1]
            time.sleep(0.1)
        self.fail('no joint_states with %s' % joint)

    def test_robot_description_scenes_and_errors(self):
        kuka = os.path.join(ROOT, 'data', 'robots', 'kuka_iiwa.urdf')
        ur5 = os.path.join(ROOT, 'data', 'robots', 'ur5_robot.urdf')
        # An already loaded robot_description (e.g. xacro's output), asked for.
        with open(kuka) as f:
            rospy.set_param('robot_description', f.read())
        self.rec.clear()
        launch = Launch(['use_robot_description:=true'])
        try:
            self.wait_for_robot('lbr_iiwa_joint_1')
        finally:
            launch.stop()
        # A scene named without robot:= brings its own robot; the stale description goes.
        self.rec.clear()
        launch = Launch(['scene:=fixed_panda'])
        try:
            self.wait_for_robot('panda_joint1')
        finally:
            launch.stop()
        self.assertNotIn('lbr_iiwa', rospy.get_param('robot_description'))
        # The generic scene with no robot anywhere: one clear line.
        rospy.set_param('robot_description', '')
        self.launch_fails(['scene:=generic'], ['no robot', 'robot:='])
        # A scene's joint that the robot lacks: the scene and the joint named.
        self.launch_fails(['robot:=' + ur5, 'scene:=fixed_panda'],
                          ['fixed_panda.yaml', 'panda_finger_joint1'])
        self.launch_fails(['robot:=' + ur5, 'scene:=no_such_scene'], ["'no_such_scene'"])
        self.launch_fails(['robot:=' + ur5, 'initial_positions:={elbow: 1}'], ["'elbow'"])

    def test_initial_positions_and_overrides(self):
        ur5 = os.path.join(ROOT, 'data', 'robots', 'ur5_robot.urdf')
        self.rec.clear()
        launch = Launch(['robot:=' + ur5, 'initial_positions:={elbow_joint: 1.25}',
                         'gravity:=0 0 0', 'real_time_factor:=0.5'])
        try:
            m = self.wait_for_robot('elbow_joint')
            time.sleep(0.5)
            states, _ = self.rec.snapshot()
            q = dict(zip(states[-1].name, states[-1].position))
            # Zero gravity and no torque: the arm stays where it starts.
            self.assertAlmostEqual(q['elbow_joint'], 1.25, places=9)
            self.assertAlmostEqual(q['shoulder_lift_joint'], 0.0, places=9)
        finally:
            launch.stop()

    def test_demo_takes_the_arguments_of_sim(self):
        def args(name):
            root = ET.parse(os.path.join(ROOT, 'launch', name)).getroot()
            return {a.get('name'): a.get('default') for a in root.findall('arg')}
        sim, demo = args('sim.launch'), args('demo.launch')
        self.assertEqual({k: demo[k] for k in sim if k in demo}, sim)
        self.assertEqual(sorted(set(demo) - set(sim)), ['renderer', 'teleop'])

    def test_quitting_teleop_leaves_the_simulation_running(self):
        ur5 = os.path.join(ROOT, 'data', 'robots', 'ur5_robot.urdf')
        master_fd, slave_fd = os.openpty()
        stop = threading.Event()

        def drain():  # a terminal is read, or teleop's panel would fill it
            while not stop.is_set():
                r, _, _ = select.select([master_fd], [], [], 0.1)
                if r:
                    try:
                        os.read(master_fd, 65536)
                    except OSError:
                        return
        reader = threading.Thread(target=drain, daemon=True)
        reader.start()
        launch = Launch(['robot:=' + ur5, 'renderer:=false', 'teleop:=true'], 'demo.launch',
                        stdin=slave_fd)
        ros_master = rosgraph.Master('/robots_check')

        def teleop_up():
            try:
                ros_master.lookupNode('/teleop')
                return True
            except rosgraph.masterapi.Error:
                return False
        self.rec.clear()
        try:
            self.wait_for_robot('elbow_joint')
            deadline = time.time() + 30
            while time.time() < deadline and not teleop_up():
                time.sleep(0.1)
            self.assertTrue(teleop_up(), launch.text())
            rospy.wait_for_message('torque_command', JointTorques, timeout=30)  # in raw mode
            os.write(master_fd, b'q')
            deadline = time.time() + 15
            while time.time() < deadline and teleop_up():
                time.sleep(0.1)
            self.assertFalse(teleop_up(), 'teleop did not quit')
            self.rec.clear()
            time.sleep(1.0)
            states, _ = self.rec.snapshot()
            self.assertGreater(len(states), 50, 'the simulation stopped with teleop')
            self.assertIsNone(launch.proc.poll(), launch.text())
        finally:
            launch.stop()
            stop.set()
            reader.join(2)
            os.close(master_fd)
            os.close(slave_fd)


# One line of each quirk's warning (src/model/urdf_quirks.cpp, the README's quirks table).
QUIRK_WARNINGS = []

if __name__ == '__main__':
    rostest.rosrun(PKG, 'robots_check', BringYourOwnRobot, sys.argv)
