#!/usr/bin/python3
"""rostest: the simulator publishes the four-bar's loop-closure force on constraint_forces."""
import math
import time
import unittest

import rospy
import rostest
from se3_sim.msg import ConstraintForces


class ConstraintForcesTest(unittest.TestCase):
    def test_loop_force_published(self):
        msgs = []
        sub = rospy.Subscriber('constraint_forces', ConstraintForces, msgs.append)
        deadline = time.time() + 30.0
        while len(msgs) < 20 and time.time() < deadline:
            time.sleep(0.05)
        sub.unregister()
        self.assertGreaterEqual(len(msgs), 20, 'too few constraint_forces messages')
        active = 0
        for m in msgs:
            n = len(m.name)
            self.assertGreater(n, 0)
            for arr in (m.kind, m.link, m.point, m.force, m.torque, m.joint_force, m.gap,
                        m.active):
                self.assertEqual(len(arr), n)
            self.assertIn('loop', m.name)
            k = m.name.index('loop')
            self.assertEqual(m.kind[k], 0)  # bilateral
            self.assertIn(m.link[k], ('coupler', 'rocker'))
            f = m.force[k]
            p = m.point[k]
            for x in (f.x, f.y, f.z, p.x, p.y, p.z):
                self.assertTrue(math.isfinite(x))
            # Under gravity the loop carries load: a force of newtons, in the linkage's x-z plane.
            mag = math.sqrt(f.x * f.x + f.y * f.y + f.z * f.z)
            if m.active[k] and mag > 0.01:
                active += 1
                self.assertLess(abs(f.y), 1e-6 * max(1.0, mag))
                self.assertLess(mag, 1e4)
        self.assertGreater(active, len(msgs) // 2, 'the loop force is rarely active')


if __name__ == '__main__':
    rospy.init_node('constraint_forces_check')
    rostest.rosrun('se3_sim', 'constraint_forces_check', ConstraintForcesTest)
