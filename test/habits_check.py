#!/usr/bin/python3
"""The first hour of a Gazebo user (issue 37), as a new user tries it: sim.launch robot:=FILE
(and demo.launch) with robots the project never saw, one launch after another on this rostest's
master.

Started by test/habits.test (rostest).
"""
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
import unittest

import rosgraph
import rospy
import rostest
from sensor_msgs.msg import JointState
from tf2_msgs.msg import TFMessage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tf_tree_util import TfTree  # noqa: E402

PKG = 'se3_sim'
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # the package
DATA = os.path.join(ROOT, 'test', 'data')
HANGING = os.path.join(DATA, 'hanging_arm.urdf')


class Launch:
    """roslaunch (or another command) in its own session, its output in a file."""

    def __init__(self, args, launch_file='sim.launch', cwd=None, command=None):
        self.log = tempfile.TemporaryFile()
        # roscpp's INFO lines go to stdout, which a file would hold back until the node ends.
        env = dict(os.environ, PYTHONUNBUFFERED='1', ROSCONSOLE_STDOUT_LINE_BUFFERED='1')
        if cwd:
            env['PWD'] = cwd
        cmd = (command or ['roslaunch']) + [PKG, launch_file] + args
        self.proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=self.log,
                                     stderr=subprocess.STDOUT, env=env, cwd=cwd,
                                     start_new_session=True)

    def text(self):
        self.log.seek(0)
        return self.log.read().decode(errors='replace')

    def wait_for(self, what, seconds=40):
        """Until what() is true or the launch ended; returns what()."""
        deadline = time.time() + seconds
        while time.time() < deadline and self.proc.poll() is None and not what():
            time.sleep(0.1)
        return what()

    def stop(self):
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGINT)
            try:
                self.proc.wait(20)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()


class Recorder:
    def __init__(self):
        self.lock = threading.Lock()
        self.clear()
        rospy.Subscriber('joint_states', JointState, self._js, queue_size=100)
        rospy.Subscriber('/tf', TFMessage, self._tf, queue_size=1000)
        rospy.Subscriber('/tf_static', TFMessage, self._tf, queue_size=100)

    def clear(self):
        with getattr(self, 'lock', threading.Lock()):
            self.names = None
            self.tree = TfTree()

    def _js(self, msg):
        with self.lock:
            self.names = list(msg.name)

    def _tf(self, msg):
        with self.lock:
            self.tree.add(msg)

    def pose(self, frame):
        with self.lock:
            return self.tree.pose(frame)


def subscribed(topic):
    """Whether some node subscribes to topic (the simulator's controller commands)."""
    _, subs, _ = rosgraph.Master('/habits_check').getSystemState()
    return any(t == topic and nodes for t, nodes in subs)


class FirstHour(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node('habits_check')
        cls.rec = Recorder()

    def setUp(self):
        self.rec.clear()

    def launch(self, *args, **kw):
        launch = Launch(*args, **kw)
        self.addCleanup(launch.stop)
        return launch

    def test_a_fixed_arm_stands_on_the_ground(self):
        # Its arm hangs 0.6 m below the base: the base goes up so that the tip touches z = 0.
        launch = self.launch(['robot:=' + HANGING])
        self.assertTrue(launch.wait_for(lambda: self.rec.pose('base')), launch.text())
        self.assertAlmostEqual(self.rec.pose('base')[0][2], 0.6, places=6)

    def test_b_relative_mesh_names_beside_the_urdf(self):
        # Launched from test/data with a relative path: the mesh (a 0.1 m box) is found, so the
        # box stands on the ground with its origin 0.05 m up.
        launch = self.launch(['robot:=relative_mesh.urdf'], cwd=DATA)
        self.assertTrue(launch.wait_for(lambda: self.rec.pose('box')), launch.text())
        self.assertAlmostEqual(self.rec.pose('box')[0][2], 0.05, places=5)
        self.assertEqual(os.path.realpath(rospy.get_param('/robot_description_dir')),
                         os.path.realpath(DATA))
        self.assertNotIn('not loaded', launch.text())

    def test_c_stale_robot_description_is_not_used(self):
        with open(HANGING) as f:
            rospy.set_param('/robot_description', f.read())
        launch = self.launch([])
        self.assertTrue(launch.wait_for(lambda: self.rec.names), launch.text())
        self.assertNotIn('j', self.rec.names, 'the stale robot_description was simulated')
        launch.stop()
        self.rec.clear()
        # Asked for, it is used.
        with open(HANGING) as f:
            rospy.set_param('/robot_description', f.read())
        launch = self.launch(['use_robot_description:=true'])
        self.assertTrue(launch.wait_for(lambda: self.rec.names), launch.text())
        self.assertEqual(self.rec.names, ['j'])

    def test_d_e_namespaced_yaml_and_one_bad_controller(self):
        # rrbot's layout: the YAML declares its namespace; one controller type is not supported.
        yaml = tempfile.NamedTemporaryFile('w', suffix='.yaml', delete=False)
        self.addCleanup(os.unlink, yaml.name)
        yaml.write('rrbot:\n'
                   '  j_position_controller:\n'
                   '    type: effort_controllers/JointPositionController\n'
                   '    joint: j\n'
                   '    pid: {p: 100.0, i: 0.01, d: 10.0}\n'
                   '  base_drive_controller:\n'
                   '    type: diff_drive_controller/DiffDriveController\n')
        yaml.close()
        launch = self.launch(['robot:=' + HANGING, 'controller_config:=' + yaml.name,
                              'controllers:=j_position_controller base_drive_controller'])
        self.assertTrue(
            launch.wait_for(lambda: subscribed('/rrbot/j_position_controller/command')),
            launch.text())
        time.sleep(0.5)
        self.assertIsNone(launch.proc.poll(), launch.text())
        lines = [l for l in launch.text().splitlines()
                 if 'base_drive_controller' in l and 'simulator:' in l]
        self.assertEqual(len(lines), 1, launch.text())
        self.assertIn('not supported', lines[0])

    def test_d_missing_controller_says_where_it_looked(self):
        launch = self.launch(['robot:=' + HANGING, 'controllers:=nowhere_controller'])
        self.assertTrue(launch.wait_for(lambda: 'controller not started' in launch.text()),
                        launch.text())
        line = [l for l in launch.text().splitlines()
                if 'nowhere_controller' in l and 'simulator:' in l][0]
        self.assertIn('/nowhere_controller/type', line)
        self.assertIn('every namespace', line)

    def test_f_fatal_is_a_failure_and_one_line(self):
        launch = Launch(['robot:=/no/such/robot.urdf'], command=['rosrun', PKG, 'launch'])
        self.addCleanup(launch.stop)
        launch.proc.wait(60)
        text = launch.text()
        self.assertNotEqual(launch.proc.returncode, 0, text)
        self.assertNotIn('Traceback', text)
        self.assertEqual(text.count('/no/such/robot.urdf: No such file or directory'), 1, text)
        # A simulator that ends FATAL: plain roslaunch returns 0, rosrun se3_sim launch its code.
        for command, failed in ((['roslaunch'], False), (['rosrun', PKG, 'launch'], True)):
            launch = Launch(['robot:=' + HANGING, 'dt:=-1'], command=command)
            self.addCleanup(launch.stop)
            launch.proc.wait(60)
            self.assertIn('FATAL', launch.text())
            self.assertEqual(launch.proc.returncode != 0, failed, launch.text())

    def test_g_use_sim_time_is_not_left_true(self):
        launch = self.launch(['robot:=' + HANGING, 'use_sim_time:=true'])
        self.assertTrue(launch.wait_for(lambda: self.rec.names), launch.text())
        self.assertTrue(rospy.get_param('/use_sim_time'))
        launch.stop()
        self.assertFalse(rospy.get_param('/use_sim_time', False), launch.text())

    def test_f_g_missing_mesh_package_is_one_line(self):
        launch = self.launch(['robot:=' + os.path.join(DATA, 'missing_package.urdf')],
                             launch_file='demo.launch')
        self.assertTrue(launch.wait_for(lambda: 'renderer: model' in launch.text(), 90),
                        launch.text())
        text = launch.text()
        lines = [l for l in text.splitlines() if 'no_such_mesh_package' in l and 'renderer:' in l]
        self.assertEqual(len(lines), 1, text)
        # rospack's own line, once (it prints one for every lookup that fails).
        rospack = [l for l in text.splitlines() if l.startswith('[rospack] Error')]
        self.assertLessEqual(len(rospack), 1, text)
        self.assertIn('ROS_PACKAGE_PATH', lines[0])
        self.assertIn('3 links', lines[0])
        self.assertNotIn('in the files', text)
        self.assertIn('no mesh file loaded', text)


if __name__ == '__main__':
    rostest.rosrun(PKG, 'habits', FirstHour)
