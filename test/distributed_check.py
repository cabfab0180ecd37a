#!/usr/bin/python3
"""rostest: the renderer and a controller on a "second host" (test/distributed.test).

A network namespace of this test's own, joined to this one by a veth pair (10.213.N.1 here,
10.213.N.2 there), stands in for a second machine. Here: a master and the simulator (the fixed
Panda with its arm under a position controller), ROS_IP=10.213.N.1. There: renderer_node and a
rospy controller publishing /arm_position_controller/command, ROS_IP=10.213.N.2. This test node
(here, on the same master) checks that renderer/image arrives from the renderer's address over
there, and that joint_states show the arm at the controller's targets. Without the right to
create a network namespace it says so and skips."""
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)

TARGETS = [0.4, -0.5, 0.3, -1.9, 0.2, 1.4, 0.6]  # panda_joint1..7

CONTROLLER = r'''
import sys, rospy
from std_msgs.msg import Float64MultiArray
rospy.init_node("remote_controller")
pub = rospy.Publisher("arm_position_controller/command", Float64MultiArray, queue_size=1)
targets = [float(x) for x in sys.argv[1].split(",")]
while not rospy.is_shutdown():
    pub.publish(Float64MultiArray(data=targets))
    rospy.sleep(0.2)
'''


def run(cmd):
    return subprocess.run(cmd, capture_output=True, text=True)


def free_port():
    s = socket.socket()
    s.bind(("", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def devel_node(name):
    for d in os.environ.get("CMAKE_PREFIX_PATH", "").split(":"):
        p = os.path.join(d, "lib", "se3_sim", name)
        if os.access(p, os.X_OK):
            return p
    raise RuntimeError("cannot find " + name)


class DistributedTest(unittest.TestCase):
    def setUp(self):
        self.procs = []
        self.ns = None
        self.tmp = tempfile.mkdtemp(prefix="se3_dist_")
        n = os.getpid() % 200 + 20
        self.ns = "se3sim%d" % os.getpid()
        self.veth = ("se3h%d" % (os.getpid() % 100000), "se3n%d" % (os.getpid() % 100000))
        self.here_ip, self.there_ip = "10.213.%d.1" % n, "10.213.%d.2" % n
        # ip is installed by scripts/deps.sh --test: without it this is a failure, not a skip
        self.assertTrue(shutil.which("ip"), "ip not found on PATH: install the Debian package "
                        "iproute2 (scripts/deps.sh --test)")
        if os.environ.get("SE3_SIM_NO_NETNS"):  # to see the skip path where netns do work
            self.reason = "SE3_SIM_NO_NETNS is set"
            self.ns = None
            return
        r = run(["ip", "netns", "add", self.ns])
        if r.returncode != 0:
            self.reason = (r.stderr or r.stdout).strip() or "ip netns add failed"
            self.ns = None
            return
        steps = [["ip", "link", "add", self.veth[0], "type", "veth", "peer", "name", self.veth[1]],
                 ["ip", "link", "set", self.veth[1], "netns", self.ns],
                 ["ip", "addr", "add", self.here_ip + "/24", "dev", self.veth[0]],
                 ["ip", "link", "set", self.veth[0], "up"],
                 ["ip", "netns", "exec", self.ns, "ip", "addr", "add", self.there_ip + "/24",
                  "dev", self.veth[1]],
                 ["ip", "netns", "exec", self.ns, "ip", "link", "set", self.veth[1], "up"],
                 ["ip", "netns", "exec", self.ns, "ip", "link", "set", "lo", "up"]]
        for s in steps:
            r = run(s)
            if r.returncode != 0:
                self.reason = "%s: %s" % (" ".join(s), r.stderr.strip())
                self.tearDown()
                self.ns = None
                return

    def tearDown(self):
        for p in reversed(self.procs):
            if p.poll() is None:
                p.send_signal(signal.SIGINT)
        for p in reversed(self.procs):
            try:
                p.wait(5)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        self.procs = []
        if self.ns:
            run(["ip", "link", "del", self.veth[0]])
            run(["ip", "netns", "del", self.ns])
            self.ns = None
        shutil.rmtree(self.tmp, ignore_errors=True)

    def start(self, cmd, env, name, netns=False):
        if netns:
            cmd = ["ip", "netns", "exec", self.ns, "env"] + \
                  ["%s=%s" % kv for kv in env.items() if kv[0].startswith("ROS")] + cmd
        log = open(os.path.join(self.tmp, name + ".log"), "w")
        p = subprocess.Popen(cmd, env=env, stdout=log, stderr=subprocess.STDOUT)
        self.procs.append(p)
        return p

    def log(self, name):
        try:
            return open(os.path.join(self.tmp, name + ".log")).read()[-3000:]
        except OSError:
            return ""

    def test_image_and_commands_cross_between_hosts(self):
        if self.ns is None:
            msg = "SKIPPED: cannot create a network namespace here (%s); " \
                  "the distributed test needs root (CAP_NET_ADMIN)" % self.reason
            print(msg)
            sys.stderr.write(msg + "\n")
            self.skipTest(msg)
        port = free_port()
        master = "http://%s:%d" % (self.here_ip, port)
        env = dict(os.environ)
        env.pop("ROS_HOSTNAME", None)  # it would take precedence over ROS_IP
        env["ROS_MASTER_URI"] = master
        here = dict(env, ROS_IP=self.here_ip)
        there = dict(env, ROS_IP=self.there_ip)
        self.start(["rosmaster", "--core", "-p", str(port)], here, "master")
        end = time.time() + 15
        while time.time() < end and subprocess.run(["rosparam", "list"], env=here,
                                                   capture_output=True).returncode != 0:
            time.sleep(0.2)
        r = subprocess.run(["rosparam", "load", os.path.join(ROOT, "config/controllers/panda.yaml")],
                           env=here, capture_output=True, text=True)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.start([devel_node("simulator_node"),
                    "_scene:=" + os.path.join(ROOT, "config/scenes/fixed_panda.yaml"),
                    "_controllers:=arm_position_controller", "_publish_rate:=50"],
                   here, "simulator")
        self.start([devel_node("renderer_node"), "_rate:=4", "_focal_px:=900.0"], there,
                   "renderer", netns=True)
        ctl = os.path.join(self.tmp, "controller.py")
        with open(ctl, "w") as f:
            f.write(CONTROLLER)
        self.start([sys.executable, ctl, ",".join(str(x) for x in TARGETS)], there, "controller",
                   netns=True)

        # This node: on the same master, here.
        os.environ.clear()
        os.environ.update(here)
        import rosgraph
        import rospy
        from image_check_util import parse_image
        from sensor_msgs.msg import JointState
        rospy.init_node("distributed_check", disable_signals=True)
        lock = threading.Lock()
        got = {}

        def on_image(msg):
            with lock:
                got["image"] = (bytes(msg._buff), msg._connection_header.get("callerid"))

        def on_js(msg):
            with lock:
                got["js"] = dict(zip(msg.name, msg.position))

        rospy.Subscriber("renderer/image", rospy.AnyMsg, on_image, queue_size=1)
        rospy.Subscriber("joint_states", JointState, on_js, queue_size=1)
        end = time.time() + 45
        reached = False
        while time.time() < end:
            time.sleep(0.2)
            with lock:
                js, image = got.get("js"), got.get("image")
            if js and image:
                err = max(abs(js["panda_joint%d" % (k + 1)] - t) for k, t in enumerate(TARGETS))
                if err < 0.01:
                    reached = True
                    break
        logs = "\n".join("--- %s\n%s" % (n, self.log(n))
                         for n in ("master", "simulator", "renderer", "controller"))
        self.assertIsNotNone(got.get("image"), "no image from the renderer over there\n" + logs)
        self.assertIsNotNone(got.get("js"), "no joint_states\n" + logs)
        self.assertTrue(reached, "the arm did not reach the remote controller's targets: %s\n%s"
                        % (got.get("js"), logs))
        width, height, encoding, step, data = parse_image(got["image"][0])
        self.assertEqual((width, height, encoding), (1280, 1024, "rgb8"))
        # The renderer and the controller announced themselves at the namespace's address.
        m = rosgraph.Master("/distributed_check")
        for node in ("/renderer", "/remote_controller"):
            self.assertIn(self.there_ip, m.lookupNode(node), node)
        self.assertIn(self.here_ip, m.lookupNode("/simulator"))
        rospy.signal_shutdown("done")


if __name__ == "__main__":
    import rostest
    rostest.rosrun("se3_sim", "distributed_check", DistributedTest, sys.argv)
