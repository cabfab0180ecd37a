#!/usr/bin/python3
"""rostest for a scene without a robot in the nodes (test/objects_only.test).

The simulator runs box_stack (three boxes, no robot): every box is a frame on /tf (parent the
world), robot_description holds the empty robot's URDF, and the renderer draws the top box where
/tf puts it: its projected centre differs from the sky colour of its row (read at the image's
right edge). The image is read as raw bytes (rospy.AnyMsg)."""
import sys
import threading
import time
import unittest

import rospy
import rostest
from tf2_msgs.msg import TFMessage

from image_check_util import H, W, Camera, parse_image, px

CAMERA = Camera((2.0, -2.0, 0.3), (0.0, 0.0, 0.3), 900.0)  # as in objects_only.test
BOXES = ("bottom", "middle", "top")


class ObjectsOnlyTest(unittest.TestCase):
    def setUp(self):
        self.lock = threading.Lock()
        self.image = None
        self.boxes = {}
        rospy.Subscriber("renderer/image", rospy.AnyMsg, self.on_image, queue_size=1)
        rospy.Subscriber("/tf", TFMessage, self.on_tf, queue_size=10)

    def on_image(self, msg):
        with self.lock:
            self.image = bytes(msg._buff)

    def on_tf(self, msg):
        with self.lock:
            for t in msg.transforms:
                if t.child_frame_id in BOXES and t.header.frame_id == "world":
                    p = t.transform.translation
                    self.boxes[t.child_frame_id] = (p.x, p.y, p.z)

    def test_boxes_published_and_drawn(self):
        end = time.time() + 40.0
        drawn = False
        while time.time() < end and not drawn:
            time.sleep(0.5)
            with self.lock:
                if self.image is None or "top" not in self.boxes:
                    continue
                buff, top = self.image, self.boxes["top"]
            width, height, encoding, step, data = parse_image(buff)
            self.assertEqual((width, height, encoding), (W, H, "rgb8"))
            u, v = CAMERA.project(top)
            self.assertTrue(20 < u < W - 60 and 40 < v < H / 2 - 20, (u, v))
            sky = px(data, W - 5, v)
            got = px(data, u, v)
            drawn = sum(abs(a - b) for a, b in zip(got, sky)) > 30
        with self.lock:
            self.assertEqual(sorted(self.boxes), sorted(BOXES), "boxes on /tf")
            # At rest on each other (the stack does not move).
            self.assertAlmostEqual(self.boxes["top"][2], 0.5, delta=0.01)
        self.assertTrue(rospy.get_param("robot_description", ""), "robot_description is empty")
        self.assertTrue(drawn, "the top box is not drawn where /tf puts it")


if __name__ == "__main__":
    rospy.init_node("objects_only_check")
    rostest.rosrun("se3_sim", "objects_only_check", ObjectsOnlyTest, sys.argv)
