#!/usr/bin/python3
"""rostest for the cameras and lasers (test/cameras.test): args CAMERA WIDTH HEIGHT RATE SCAN
SAMPLES RATE. The camera's rgb8 image, CameraInfo, 32FC1 depth (metres, NaN where nothing is
hit), organized cloud (x y z rgb) and the LaserScan: sizes, frames, sim-time stamps at the rate,
K matching the image (fx = fy = (w / 2) / tan(hfov / 2), principal point at the image's
centre), the optical frame on /tf_static, and the cloud's points equal to the depth through K."""
import math
import struct
import sys
import threading
import time
import unittest

import rospy
import rostest
from sensor_msgs.msg import CameraInfo, Image, LaserScan, PointCloud2
from tf2_msgs.msg import TFMessage


class CamerasTest(unittest.TestCase):
    def test_camera_and_scan(self):
        args = [a for a in sys.argv[1:] if not a.startswith(("-", "_"))]
        cam, width, height, rate = args[0], int(args[1]), int(args[2]), float(args[3])
        scan, samples, scan_rate = args[4], int(args[5]), float(args[6])
        topics = {
            "image": ("/%s/image_raw" % cam, Image),
            "info": ("/%s/camera_info" % cam, CameraInfo),
            "depth": ("/%s/depth/image_raw" % cam, Image),
            "depth_info": ("/%s/depth/camera_info" % cam, CameraInfo),
            "points": ("/%s/depth/points" % cam, PointCloud2),
            "scan": ("/" + scan, LaserScan),
        }
        lock = threading.Lock()
        got = {k: [] for k in topics}
        statics = []

        def on(key):
            def cb(msg):
                with lock:
                    got[key].append(msg)
            return cb

        subs = [rospy.Subscriber(t, c, on(k), queue_size=50) for k, (t, c) in topics.items()]
        subs.append(rospy.Subscriber("/tf_static", TFMessage,
                                     lambda m: statics.extend(m.transforms), queue_size=10))
        end = time.time() + 90
        while time.time() < end:
            with lock:
                if all(len(v) >= 5 for v in got.values()):
                    break
            time.sleep(0.1)
        with lock:
            for k, v in got.items():
                self.assertGreaterEqual(len(v), 5, topics[k][0])
        frame = cam + "_optical_frame"
        img = got["image"][-1]
        self.assertEqual((img.width, img.height, img.encoding), (width, height, "rgb8"))
        self.assertEqual(len(img.data), width * height * 3)
        self.assertEqual(img.header.frame_id, frame)
        for key in ("info", "depth_info"):
            info = got[key][-1]
            self.assertEqual((info.width, info.height), (width, height))
            self.assertEqual(info.header.frame_id, frame)
            fx, cx, fy, cy = info.K[0], info.K[2], info.K[4], info.K[5]
            self.assertAlmostEqual(fx, 0.5 * width / math.tan(0.5 * 1.047), places=6)
            self.assertEqual(fx, fy)
            self.assertAlmostEqual(cx, 0.5 * (width - 1))
            self.assertAlmostEqual(cy, 0.5 * (height - 1))
            self.assertEqual(list(info.P[:3]), [fx, 0.0, cx])
        depth = got["depth"][-1]
        self.assertEqual((depth.width, depth.height, depth.encoding), (width, height, "32FC1"))
        self.assertEqual(depth.step, 4 * width)
        d = struct.unpack("<%df" % (width * height), bytes(depth.data))
        finite = [z for z in d if math.isfinite(z)]
        self.assertGreater(len(finite), width * height // 4)  # the table, the robot, the ground
        self.assertTrue(all(0.05 <= z <= 6.0 for z in finite))
        pts = got["points"][-1]
        self.assertEqual((pts.width, pts.height, pts.point_step), (width, height, 16))
        self.assertEqual([f.name for f in pts.fields], ["x", "y", "z", "rgb"])
        self.assertEqual(pts.header.frame_id, frame)
        # The cloud's point of a pixel is its depth through K (the same frame's messages).
        stamp = pts.header.stamp
        same = [m for m in got["depth"] if m.header.stamp == stamp]
        self.assertTrue(same)
        d = struct.unpack("<%df" % (width * height), bytes(same[0].data))
        info = got["info"][-1]
        checked = 0
        for j in range(0, height, 37):
            for i in range(0, width, 41):
                x, y, z = struct.unpack_from("<3f", bytes(pts.data), 16 * (j * width + i))
                if not math.isfinite(d[j * width + i]):
                    self.assertTrue(math.isnan(z))
                    continue
                checked += 1
                self.assertAlmostEqual(z, d[j * width + i], places=5)
                self.assertAlmostEqual(x, (i - info.K[2]) / info.K[0] * z, places=4)
                self.assertAlmostEqual(y, (j - info.K[5]) / info.K[4] * z, places=4)
        self.assertGreater(checked, 20)
        # Stamps: simulated time at the rate.
        for key, r in (("image", rate), ("depth", rate), ("scan", scan_rate)):
            for m in got[key]:
                s = m.header.stamp.to_sec() * r
                self.assertAlmostEqual(s, round(s), places=4, msg=key)
        sc = got["scan"][-1]
        self.assertEqual(len(sc.ranges), samples)
        self.assertEqual(sc.header.frame_id, scan)
        self.assertTrue(all(math.isinf(r) or sc.range_min <= r <= sc.range_max for r in sc.ranges))
        self.assertTrue(any(math.isfinite(r) for r in sc.ranges))
        # The optical frame on /tf_static, below the world.
        end = time.time() + 10
        while time.time() < end and not any(t.child_frame_id == frame for t in statics):
            time.sleep(0.1)
        opt = [t for t in statics if t.child_frame_id == frame]
        self.assertEqual(len(opt), 1)
        self.assertEqual(opt[0].header.frame_id, "world")


if __name__ == "__main__":
    rospy.init_node("cameras_check")
    rostest.rosrun("se3_sim", "cameras_check", CamerasTest, sys.argv)
