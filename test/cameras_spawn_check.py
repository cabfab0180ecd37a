#!/usr/bin/python3
"""rostest (test/cameras_spawn.test): a static crate spawned 0.3 m in front of panda_push's
table_camera fills the centre of its depth image (about 0.25 m deep instead of 1.45 m), one
spawned 0.12 m in front of table_scan shortens the scan's middle range to it; deleted, both
see the scene again."""
import math
import struct
import sys
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import Pose, PoseStamped
from se3_sim.msg import Resource, Result
from se3_sim.srv import DeleteEntity, SpawnEntity
from sensor_msgs.msg import Image, LaserScan

CRATE = "shape: {box: [0.1, 0.1, 0.1]}\n"


class CamerasSpawnTest(unittest.TestCase):
    def setUp(self):
        self.lock = threading.Lock()
        self.depth = None
        self.scan = None
        self.subs = [
            rospy.Subscriber("/table_camera/depth/image_raw", Image, self.on_depth, queue_size=1),
            rospy.Subscriber("/table_scan", LaserScan, self.on_scan, queue_size=1),
        ]
        rospy.wait_for_service("simulator/spawn_entity", timeout=60)
        self.spawn = rospy.ServiceProxy("simulator/spawn_entity", SpawnEntity)
        self.delete = rospy.ServiceProxy("simulator/delete_entity", DeleteEntity)

    def on_depth(self, msg):
        k = (msg.height // 2) * msg.width + msg.width // 2
        with self.lock:
            self.depth = (msg.header.stamp.to_sec(), struct.unpack_from("<f", msg.data, 4 * k)[0])

    def on_scan(self, msg):
        with self.lock:
            self.scan = (msg.header.stamp.to_sec(), msg.ranges[len(msg.ranges) // 2])

    def after(self, t0):
        """The centre depth and the middle range of the first messages stamped after t0."""
        end = time.time() + 30
        while time.time() < end:
            with self.lock:
                if self.depth and self.scan and self.depth[0] > t0 and self.scan[0] > t0:
                    return self.depth[1], self.scan[1]
            time.sleep(0.05)
        self.fail("no camera and scan frames after t = %g" % t0)

    def now(self):
        with self.lock:
            return max(self.depth[0] if self.depth else 0, self.scan[0] if self.scan else 0)

    def put(self, name, x, y, z):
        p = Pose()
        p.position.x, p.position.y, p.position.z = x, y, z
        p.orientation.w = 1.0
        r = self.spawn(name=name, allow_renaming=False,
                       entity_resource=Resource(uri="", resource_string=CRATE),
                       entity_namespace="", initial_pose=PoseStamped(pose=p))
        self.assertEqual(r.result.result, Result.RESULT_OK, r.result.error_message)

    def test_spawned_objects_are_seen(self):
        depth, rng = self.after(0.0)
        self.assertTrue(math.isfinite(depth) and depth > 1.0, depth)
        self.assertGreater(rng, 0.2)
        # table_camera at (1.4, 0.9, 0.7) looks along (-0.669, -0.595, -0.446); the crate's
        # centre 0.3 m along that axis, its surface there 0.21 to 0.25 m deep. table_scan at
        # (1.1, 0, 0.09) looks along -x; the crate's near face 0.12 m ahead.
        self.put("camera_crate", 1.4 - 0.3 * 0.669, 0.9 - 0.3 * 0.595, 0.7 - 0.3 * 0.446)
        self.put("scan_crate", 1.1 - 0.17, 0.0, 0.09)
        depth, rng = self.after(self.now())
        self.assertLess(depth, 0.3)
        self.assertAlmostEqual(rng, 0.12, delta=0.005)
        for name in ("camera_crate", "scan_crate"):
            r = self.delete(entity=name)
            self.assertEqual(r.result.result, Result.RESULT_OK, r.result.error_message)
        depth, rng = self.after(self.now())
        self.assertGreater(depth, 1.0)
        self.assertGreater(rng, 0.2)


if __name__ == "__main__":
    rospy.init_node("cameras_spawn_check")
    rostest.rosrun("se3_sim", "cameras_spawn_check", CamerasSpawnTest, sys.argv)
