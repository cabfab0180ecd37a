#!/usr/bin/python3
"""rostest node for renderer_node: poses panda through /tf_static, reads renderer/image.

Checks the size (1280x1024) and encoding (rgb8), that pixels where a link must be differ from the
frame drawn before the robot had a pose, that pixels away from the robot do not, and that the
horizon lies on the row the camera geometry gives. The image is read as raw bytes (rospy.AnyMsg),
so no Python sensor_msgs package is needed.
"""
import math
import sys
import time
import unittest
import xml.etree.ElementTree as ET

import rospy
import rostest
from geometry_msgs.msg import TransformStamped
from tf2_msgs.msg import TFMessage

from image_check_util import H, W, Camera, parse_image, px

EYE = (2.0, -2.0, 0.8)
TARGET = (0.0, 0.0, 0.5)
FOCAL = 1000.0
CAMERA = Camera(EYE, TARGET, FOCAL)  # the camera of renderer.test, built independently
project = CAMERA.project


def quaternion_rpy(r, p, y):
    cr, sr = math.cos(r / 2), math.sin(r / 2)
    cp, sp = math.cos(p / 2), math.sin(p / 2)
    cy, sy = math.cos(y / 2), math.sin(y / 2)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy)


class RendererImageTest(unittest.TestCase):
    def setUp(self):
        self.last = None
        self.sub = rospy.Subscriber("renderer/image", rospy.AnyMsg, self.on_image, queue_size=1)
        self.tf_pub = rospy.Publisher("/tf_static", TFMessage, queue_size=1, latch=True)

    def on_image(self, msg):
        self.count = getattr(self, "count", 0) + 1
        self.last = (time.time(), bytes(msg._buff))

    def wait_image(self, after, timeout=30.0):
        end = time.time() + timeout
        while time.time() < end and not rospy.is_shutdown():
            if self.last is not None and self.last[0] > after:
                return parse_image(self.last[1])
            time.sleep(0.05)
        self.fail("no image on renderer/image")

    def publish_panda_tf(self):
        xml = rospy.get_param("robot_description")
        root = ET.fromstring(xml)
        msgs = []
        now = rospy.Time.now()

        def add(parent, child, xyz, rpy):
            t = TransformStamped()
            t.header.stamp = now
            t.header.frame_id = parent
            t.child_frame_id = child
            t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = xyz
            q = quaternion_rpy(*rpy)
            (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
             t.transform.rotation.w) = q
            msgs.append(t)

        add("world", "panda_link0", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        for j in root.findall("joint"):  # every joint at q = 0
            o = j.find("origin")
            xyz = [float(v) for v in (o.get("xyz", "0 0 0") if o is not None else "0 0 0").split()]
            rpy = [float(v) for v in (o.get("rpy", "0 0 0") if o is not None else "0 0 0").split()]
            add(j.find("parent").get("link"), j.find("child").get("link"), xyz, rpy)
        self.tf_pub.publish(TFMessage(transforms=msgs))

    @staticmethod
    def px(data, u, v):
        return px(data, u, v)

    def test_image(self):
        width, height, encoding, step, before = self.wait_image(0.0)
        self.assertEqual((width, height), (W, H))
        self.assertEqual(encoding, "rgb8")
        self.assertEqual(step, 3 * W)
        self.assertEqual(len(before), 3 * W * H)

        self.publish_panda_tf()
        time.sleep(1.5)
        _, _, _, _, after = self.wait_image(time.time())

        # The base pillar (link0 to joint1, 0.333 m) and the upper arm at q = 0.
        for p in [(0.0, 0.0, 0.15), (0.0, 0.0, 0.25), (0.0, 0.0, 0.5)]:
            u, v = project(p)
            self.assertTrue(0 <= u < W and 0 <= v < H)
            self.assertNotEqual(self.px(after, u, v), self.px(before, u, v),
                                "no link drawn at %s (pixel %.0f, %.0f)" % (p, u, v))
        # Far from the robot nothing changes.
        for u, v in [(5, 5), (W - 5, H - 5), (5, H - 5), (W - 5, 300)]:
            self.assertEqual(self.px(after, u, v), self.px(before, u, v))

        # The horizon: bright sky just above the computed row, darker ground just below, at
        # columns away from the robot.
        vh = CAMERA.horizon_row()
        self.assertTrue(10 < vh < H - 10)
        for u in (5, 100, W - 100, W - 5):
            sky = self.px(after, u, math.floor(vh) - 3)
            ground = self.px(after, u, math.ceil(vh) + 3)
            self.assertGreater(sum(sky), sum(ground) + 40, "column %d row %.1f" % (u, vh))
            above = self.px(after, u, math.floor(vh) - 12)
            self.assertLess(abs(sum(above) - sum(sky)), 40)

        # The image rate follows ~rate (20 Hz here); loose, the test machine is shared.
        start, t0 = self.count, time.time()
        time.sleep(3.0)
        hz = (self.count - start) / (time.time() - t0)
        self.assertGreater(hz, 0.5 * 20, "renderer/image at %.1f Hz" % hz)
        self.assertLess(hz, 1.5 * 20, "renderer/image at %.1f Hz" % hz)


if __name__ == "__main__":
    rospy.init_node("renderer_image_check")
    rostest.rosrun("se3_sim", "renderer_image_check", RendererImageTest, sys.argv)
