#!/usr/bin/python3
"""rostest node for renderer_node: poses panda through /tf_static, reads renderer/image.

Checks the size (1280x1024) and encoding (rgb8), that pixels where a link must be differ from the
frame drawn before the robot had a pose, that pixels away from the robot do not, and that the
horizon lies on the row the camera geometry gives; camera_info; the RViz markers naming the
Panda's meshes; save_frame writing a new file each time; scene mesh objects from sim_markers
(a readable one in its colour, an unreadable one as the grey stand-in); and a second renderer (namespace
follow) whose camera follows panda_link0, rendering only while someone subscribes. Images and
markers are read as raw bytes (rospy.AnyMsg).
"""
import math
import sys
import time
import unittest
import xml.etree.ElementTree as ET

import os

import rospy
import rostest
from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import CameraInfo
from std_srvs.srv import Trigger
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

    def publish_panda_tf(self, base=(0.0, 0.0, 0.0)):
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

        add("world", "panda_link0", base, (0.0, 0.0, 0.0))
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


    def test_camera_info(self):
        msgs = []
        sub = rospy.Subscriber("renderer/camera_info", CameraInfo, msgs.append, queue_size=1)
        end = time.time() + 30
        while not msgs and time.time() < end:
            time.sleep(0.1)
        sub.unregister()
        self.assertTrue(msgs, "no renderer/camera_info")
        k = msgs[-1].K
        self.assertEqual((msgs[-1].width, msgs[-1].height), (W, H))
        self.assertAlmostEqual(k[0], FOCAL)
        self.assertAlmostEqual(k[2], W / 2 - 0.5)
        self.assertAlmostEqual(k[5], H / 2 - 0.5)

    def test_markers_name_the_meshes(self):
        got = []
        sub = rospy.Subscriber("renderer/markers", rospy.AnyMsg,
                               lambda m: got.append(bytes(m._buff)), queue_size=1)
        end = time.time() + 30
        while not got and time.time() < end:
            time.sleep(0.1)
        sub.unregister()
        self.assertTrue(got, "no renderer/markers")
        name = b"package://example-robot-data/robots/panda_description/meshes/visual/link3.dae"
        self.assertIn(name, got[-1])

    def test_save_frame_writes_a_new_file_each_time(self):
        rospy.wait_for_service("renderer/save_frame", 30)
        save = rospy.ServiceProxy("renderer/save_frame", Trigger)
        a, b = save(), save()
        self.assertTrue(a.success, a.message)
        self.assertTrue(b.success, b.message)
        self.assertNotEqual(a.message, b.message)
        for r in (a, b):
            self.assertTrue(os.path.isfile(r.message), r.message)
            with open(r.message, "rb") as f:
                self.assertEqual(f.read(4), b"\x89PNG")

    def test_sim_mesh_objects_are_drawn(self):
        """A scene's mesh object as the simulator publishes it on sim_markers (MESH_RESOURCE,
        file:// of its path) is drawn with its triangles in its colour; one whose file cannot be
        read is drawn as the grey stand-in cube."""
        from visualization_msgs.msg import Marker, MarkerArray
        path = "/tmp/se3_sim_renderer_check_box_%d.stl" % os.getpid()
        h = 0.1  # a 0.2 m cube
        with open(path, "w") as f:
            f.write("solid box\n")
            for axis in range(3):
                for side in (-1, 1):
                    u, w = (axis + 1) % 3, (axis + 2) % 3
                    quad = []
                    for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                        c = [0.0, 0.0, 0.0]
                        c[axis], c[u], c[w] = side * h, a * h, b * h
                        quad.append(c)
                    if side < 0:
                        quad[1], quad[3] = quad[3], quad[1]
                    for tri in ((0, 1, 2), (0, 2, 3)):
                        f.write("facet normal 0 0 0\nouter loop\n")
                        for k in tri:
                            f.write("vertex %g %g %g\n" % tuple(quad[k]))
                        f.write("endloop\nendfacet\n")
            f.write("endsolid box\n")
        pub = rospy.Publisher("sim_markers", MarkerArray, queue_size=1, latch=True)
        before = self.wait_image(time.time())[4]
        places = {"file://" + path: (0.5, 0.9, 0.3),
                  "file:///nonexistent/se3_sim_missing.stl": (0.9, 0.4, 0.15)}
        arr = MarkerArray()
        for i, (res, pos) in enumerate(sorted(places.items())):
            m = Marker()
            m.header.frame_id = "world"
            m.ns = "objects"
            m.id = i
            m.type = Marker.MESH_RESOURCE
            m.action = Marker.ADD
            m.mesh_resource = res
            m.pose.position.x, m.pose.position.y, m.pose.position.z = pos
            m.pose.orientation.w = 1.0
            m.scale.x = m.scale.y = m.scale.z = 1.0
            m.color.r, m.color.g, m.color.b, m.color.a = 0.9, 0.1, 0.1, 1.0
            arr.markers.append(m)
        pub.publish(arr)
        time.sleep(2.0)
        after = self.wait_image(time.time())[4]
        pub.unregister()
        os.remove(path)
        u, v = project(places["file://" + path])
        self.assertTrue(0 <= u < W and 0 <= v < H)
        r, g, b = self.px(after, u, v)
        self.assertNotEqual((r, g, b), self.px(before, u, v), "the mesh object is not drawn")
        self.assertGreater(r, g + 40, "not the object's colour: %s" % ((r, g, b),))
        self.assertGreater(r, b + 40, "not the object's colour: %s" % ((r, g, b),))
        # A point 0.3 m above it (about 90 px, the cube's half height about 30 px) is untouched.
        u2, v2 = project((0.5, 0.9, 0.3 + 0.3))
        self.assertEqual(self.px(after, u2, v2), self.px(before, u2, v2))
        # The stand-in: grey (equal channels), where the unreadable mesh's object stands.
        u, v = project(places["file:///nonexistent/se3_sim_missing.stl"])
        r, g, b = self.px(after, u, v)
        self.assertNotEqual((r, g, b), self.px(before, u, v), "no stand-in drawn")
        self.assertLess(max(abs(r - g), abs(g - b)), 3, "the stand-in is not grey: %s" % ((r, g, b),))

    def test_percent_conversions_in_a_colour_do_not_end_the_node(self):
        """A robot_description with "%n" in a material's rgba (it crashed renderer_node):
        the renderer of ns percent loads it and keeps publishing images."""
        images = []
        sub = rospy.Subscriber("percent/renderer/image", rospy.AnyMsg,
                               lambda m: images.append(time.time()), queue_size=1)
        end = time.time() + 30.0
        while time.time() < end and len(images) < 3:
            time.sleep(0.1)
        sub.unregister()
        self.assertGreaterEqual(len(images), 3, "percent/renderer/image stopped or never came")

    def test_zz_follow_frame(self):
        """Last (name order): it moves panda_link0."""
        self.publish_panda_tf()
        # Nobody subscribes the follow renderer's image: it draws nothing (no camera TF).
        frames = []

        def on_tf(msg):
            frames.extend(t.child_frame_id for t in msg.transforms)

        tf_sub = rospy.Subscriber("/tf", TFMessage, on_tf, queue_size=50)
        time.sleep(2.0)
        self.assertNotIn("follow_camera", frames)
        images = []
        img_sub = rospy.Subscriber("follow/renderer/image", rospy.AnyMsg,
                                   lambda m: images.append((time.time(), bytes(m._buff))),
                                   queue_size=1)

        def image_after(t0, timeout=30.0):
            end = time.time() + timeout
            while time.time() < end:
                fresh = [i for i in images if i[0] > t0]
                if fresh:
                    return parse_image(fresh[-1][1])[4]
                time.sleep(0.05)
            self.fail("no follow/renderer/image")

        time.sleep(1.5)
        before = image_after(time.time())
        self.assertIn("follow_camera", frames)
        main_before = self.wait_image(time.time())[4]
        probe = [project(p) for p in [(0.0, 0.0, 0.15), (0.0, 0.0, 0.5)]]
        # The robot falls 1 m and slides: the follow camera keeps it in place, the other not.
        self.publish_panda_tf((0.6, 0.4, -1.0))
        time.sleep(1.5)
        after = image_after(time.time() + 0.3)
        main_after = self.wait_image(time.time())[4]
        for u, v in probe:
            diff = sum(abs(a - b) for a, b in zip(self.px(after, u, v), self.px(before, u, v)))
            self.assertLessEqual(diff, 6, "follow camera lost the robot at pixel %.0f, %.0f" % (u, v))
            self.assertNotEqual(self.px(main_after, u, v), self.px(main_before, u, v))
        img_sub.unregister()
        tf_sub.unregister()


if __name__ == "__main__":
    rospy.init_node("renderer_image_check")
    rostest.rosrun("se3_sim", "renderer_image_check", RendererImageTest, sys.argv)
