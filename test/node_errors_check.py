#!/usr/bin/python3
"""simulator_node on a scene whose controller name is not a ROS name (issue 35): the node used to
abort on roscpp's InvalidNameException (exit -6). It must end with exit code 1 and one line that
names the scene file, the line and the controller.

Started by test/node_errors.test (rostest).
"""
import os
import subprocess
import tempfile
import unittest

import rostest

PKG = 'se3_sim'
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # the package


class NodeErrors(unittest.TestCase):
    def run_node(self, scene_text):
        with tempfile.NamedTemporaryFile('w', suffix='.yaml', delete=False) as f:
            f.write(scene_text)
            path = f.name
        try:
            p = subprocess.run(
                ['rosrun', PKG, 'simulator_node', '__name:=refused_simulator', '_scene:=' + path],
                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=60, text=True)
        finally:
            os.unlink(path)
        return p.returncode, p.stdout, path

    def test_controller_name_that_is_not_a_ros_name(self):
        rc, out, path = self.run_node(
            'robot: %s/data/robots/panda.urdf\n'
            'controllers:\n'
            '  "my arm": {type: effort_controllers/JointGroupPositionController,'
            ' joints: [panda_joint1], pid: {p: 100, d: 10}}\n' % ROOT)
        self.assertEqual(rc, 1, out)
        lines = [l for l in out.splitlines() if 'not a ROS name' in l]
        self.assertEqual(len(lines), 1, out)
        self.assertIn(os.path.basename(path) + ':3:', lines[0])
        self.assertIn("'my arm'", lines[0])


if __name__ == '__main__':
    rostest.rosrun(PKG, 'node_errors', NodeErrors)
