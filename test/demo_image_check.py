#!/usr/bin/python3
"""rostest for simulator + renderer together (test/demo.test).

The camera is level (eye and target at the same height), so the horizon is the middle row and
each sky row has one colour. Every link with visual geometry that the simulator publishes on
TF (a tree: /tf and /tf_static, composed up to world) and whose origin projects into the sky
(above the horizon, inside the image) must be drawn there: its pixel (or one within 5 px) differs from that row's sky colour, read at the image's right edge. Frames
without geometry (panda_hand_tcp, a point between the finger tips) can lie over the sky. The image is read as raw bytes
(rospy.AnyMsg), so no Python sensor_msgs package is needed.
"""
import sys
import threading
import xml.etree.ElementTree as ET
import time
import unittest

import rospy
import rostest
from tf2_msgs.msg import TFMessage

from image_check_util import H, W, Camera, parse_image, px
from tf_tree_util import TfTree

CAMERA = Camera((3.0, -3.0, 1.2), (0.0, 0.0, 1.2), 900.0)  # as in demo.test


class DemoImageTest(unittest.TestCase):
    def setUp(self):
        self.drawn = None  # links with visual geometry, once the simulator has published them
        self.lock = threading.Lock()
        self.image = None
        self.tree = TfTree()
        rospy.Subscriber("renderer/image", rospy.AnyMsg, self.on_image, queue_size=1)
        rospy.Subscriber("/tf", TFMessage, self.on_tf, queue_size=10)
        rospy.Subscriber("/tf_static", TFMessage, self.on_tf, queue_size=10)

    def on_image(self, msg):
        with self.lock:
            self.image = (time.time(), bytes(msg._buff), self.tree.world_positions())

    def on_tf(self, msg):
        with self.lock:
            self.tree.add(msg)

    @staticmethod
    def px(data, u, v):
        return px(data, u, v)

    def test_links_drawn_where_the_simulator_puts_them(self):
        end = time.time() + 40.0
        checked = 0
        while time.time() < end and checked == 0:
            time.sleep(0.5)
            if self.drawn is None:
                # The simulator puts its scene's robot on robot_description ("" until then).
                xml = rospy.get_param("robot_description", "")
                if not xml:
                    continue
                self.drawn = {l.get("name") for l in ET.fromstring(xml).findall("link")
                              if l.find("visual") is not None}
            with self.lock:
                if self.image is None or len(self.image[2]) < 8:
                    continue
                stamp, buff, links = self.image
            width, height, encoding, step, data = parse_image(buff)
            self.assertEqual((width, height, encoding, step), (W, H, "rgb8", 3 * W))
            self.assertEqual(len(data), 3 * W * H)
            # The horizon lies on the middle row: sky above, darker ground below.
            sky_near = self.px(data, W - 5, H / 2 - 4)
            ground_near = self.px(data, W - 5, H / 2 + 4)
            self.assertGreater(sum(sky_near), sum(ground_near) + 40)
            for name, p in sorted(links.items()):
                if name not in self.drawn:
                    continue  # no geometry (or the renderer's own camera frame)
                uv = CAMERA.project(p)
                if uv is None:
                    continue
                u, v = uv
                if not (20 < u < W - 60 and 40 < v < H / 2 - 20):
                    continue  # not in the sky part of the image
                # The image and the TF this test holds may be a publish period apart while the
                # arm moves, so a link origin on the edge of its mesh is looked for within
                # kNear pixels (2.5 cm at this distance) rather than at one pixel.
                kNear = 5
                best = 0
                for du in range(-kNear, kNear + 1, kNear):
                    for dv in range(-kNear, kNear + 1, kNear):
                        sky = self.px(data, W - 5, v + dv)
                        got = self.px(data, u + du, v + dv)
                        best = max(best, sum(abs(a - b) for a, b in zip(got, sky)))
                self.assertGreater(best, 30,
                                   "link %s at pixel (%.0f, %.0f) looks like the sky" % (name, u, v))
                checked += 1
        self.assertGreater(checked, 2, "too few links projected into the sky")


if __name__ == "__main__":
    rospy.init_node("demo_image_check")
    rostest.rosrun("se3_sim", "demo_image_check", DemoImageTest, sys.argv)
