#!/usr/bin/python3
"""rostest for the sensors (test/sensors.test, test/sensors_urdf.test): each sensor given as
TOPIC:KIND:FRAME:RATE (KIND imu, wrench, contact, image, info or scan) publishes on TOPIC in FRAME, stamped with
simulated time (never ahead of /clock) at RATE Hz of simulated time, with finite values."""
import math
import sys
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import WrenchStamped
from rosgraph_msgs.msg import Clock
from se3_sim.msg import ContactsState
from sensor_msgs.msg import CameraInfo, Image, Imu, LaserScan

KINDS = {"imu": Imu, "wrench": WrenchStamped, "contact": ContactsState, "image": Image,
         "info": CameraInfo, "scan": LaserScan}


def numbers(msg, kind):
    if kind == "imu":
        o, w, a = msg.orientation, msg.angular_velocity, msg.linear_acceleration
        return [o.x, o.y, o.z, o.w, w.x, w.y, w.z, a.x, a.y, a.z]
    if kind in ("image", "info"):
        return [msg.width, msg.height] + (list(msg.K) if kind == "info" else [])
    if kind == "scan":  # +-Inf: nothing within range (REP 117)
        return [r for r in msg.ranges if not math.isinf(r)] + [msg.angle_min, msg.angle_max]
    if kind == "wrench":
        f, t = msg.wrench.force, msg.wrench.torque
        return [f.x, f.y, f.z, t.x, t.y, t.z]
    out = []
    for s in msg.states:
        out += list(s.depths) + [s.total_wrench.force.x, s.total_wrench.force.y,
                                 s.total_wrench.force.z]
    return out


class SensorsTest(unittest.TestCase):
    def test_topics_frames_and_stamps(self):
        specs = [a.split(":") for a in sys.argv[1:]
                 if a.count(":") == 3 and not a.startswith(("-", "_"))]
        self.assertTrue(specs)
        lock = threading.Lock()
        got = {s[0]: [] for s in specs}
        clock = [0.0]

        def on_clock(msg):
            with lock:
                clock[0] = msg.clock.to_sec()

        def on(topic):
            def cb(msg):
                with lock:
                    got[topic].append((msg, clock[0]))
            return cb

        subs = [rospy.Subscriber("/clock", Clock, on_clock, queue_size=1000)]
        for topic, kind, _, _ in specs:
            subs.append(rospy.Subscriber(topic, KINDS[kind], on(topic), queue_size=1000))
        end = time.time() + 60
        while time.time() < end:
            with lock:
                if all(len(v) >= 50 for v in got.values()):
                    break
            time.sleep(0.1)
        for topic, kind, frame, rate in specs:
            with lock:
                msgs = list(got[topic])
            self.assertGreaterEqual(len(msgs), 50, topic)
            period = 1.0 / float(rate)
            stamps = [m.header.stamp.to_sec() for m, _ in msgs]
            for (m, seen_clock), s in zip(msgs, stamps):
                self.assertEqual(m.header.frame_id, frame, topic)
                # Never ahead of simulated time (the /clock of its step may arrive just after it).
                self.assertLessEqual(s, seen_clock + 0.05, topic)
                self.assertAlmostEqual(s / period, round(s / period), places=5, msg=topic)
                self.assertTrue(all(math.isfinite(x) for x in numbers(m, kind)), topic)
            gaps = [b - a for a, b in zip(stamps, stamps[1:])]
            self.assertTrue(all(abs(g - period) < 1e-6 for g in gaps), (topic, gaps[:10]))
            if kind == "imu":
                o = msgs[-1][0].orientation
                self.assertAlmostEqual(o.x ** 2 + o.y ** 2 + o.z ** 2 + o.w ** 2, 1.0, places=9)


if __name__ == "__main__":
    rospy.init_node("sensors_check")
    rostest.rosrun("se3_sim", "sensors_check", SensorsTest, sys.argv)
