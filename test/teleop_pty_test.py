#!/usr/bin/python3
"""Runs the real teleop_node on a pseudo-terminal, types keys and xterm SGR mouse reports into
it and checks what it publishes on torque_command (right joint, sign, clamping, mouse drag,
wheel, click, dead-man, zero on quit) and renderer/camera_command, and that the terminal is
left as it was found (termios attributes, mouse reporting switched off) after a quit, after
SIGINT/SIGTERM and after a crash signal. Also checks the clean exit without a terminal.

Started by test/teleop.test (rostest), which loads robot_description with the Panda URDF.
"""
import fcntl
import os
import re
import resource
import select
import signal
import struct
import subprocess
import sys
import tempfile
import termios
import threading
import time
import unittest

import roslib.packages
import rospy
import rostest
from geometry_msgs.msg import Twist
from se3_sim.msg import JointTorques

PKG = 'se3_sim'
MOUSE_ON = (b'\x1b[?1000h', b'\x1b[?1002h', b'\x1b[?1006h')
MOUSE_OFF = (b'\x1b[?1000l', b'\x1b[?1002l', b'\x1b[?1006l')
PANDA_ARM = ['panda_joint%d' % i for i in range(1, 8)]
TIMEOUT = 3.0  # the node's ~timeout (dead-man) in these tests
STEP = 0.1     # the node's ~step: a tenth of each joint's effort limit per key press
LIMIT = dict(('panda_joint%d' % i, 87.0 if i <= 4 else 12.0) for i in range(1, 8))
COLS, ROWS = 80, 24  # the pseudo-terminal's size


def sgr(code, x, y, release=False):
    """An xterm SGR mouse report."""
    return b'\x1b[<%d;%d;%d%s' % (code, x, y, b'm' if release else b'M')


def node_executable():
    # test/teleop.test passes the node's path as the first argument (see there).
    if len(sys.argv) > 1 and os.path.basename(sys.argv[1]) == 'teleop_node':
        return sys.argv[1]
    found = roslib.packages.find_node(PKG, 'teleop_node')
    if not found:
        raise RuntimeError('teleop_node executable not found (is the package built?)')
    return found[0]


def no_core_dump():
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


class PtyNode:
    """teleop_node with a fresh pseudo-terminal as its stdin and stdout."""

    def __init__(self, extra_args=()):
        self.master, self.slave = os.openpty()
        fcntl.ioctl(self.slave, termios.TIOCSWINSZ, struct.pack('HHHH', ROWS, COLS, 0, 0))
        self.original = termios.tcgetattr(self.slave)
        self.output = bytearray()
        self.lock = threading.Lock()
        self.stop = False
        self.stderr = tempfile.TemporaryFile()
        args = [node_executable(), '__name:=teleop', '_timeout:=%g' % TIMEOUT,
                '_step:=%g' % STEP, '_rate:=20'] + list(extra_args)
        self.proc = subprocess.Popen(args, stdin=self.slave, stdout=self.slave,
                                     stderr=self.stderr, start_new_session=True,
                                     preexec_fn=no_core_dump)
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self):
        # The terminal must be drained, as a real one is, or the node's writes would stall.
        while not self.stop:
            ready, _, _ = select.select([self.master], [], [], 0.1)
            if not ready:
                continue
            try:
                data = os.read(self.master, 65536)
            except OSError:
                return
            if not data:
                return
            with self.lock:
                self.output += data

    def text(self):
        with self.lock:
            return bytes(self.output)

    def type(self, data):
        os.write(self.master, data)

    def wait_output(self, needle, timeout=10.0):
        deadline = time.time() + timeout
        while time.time() < deadline:
            if needle in self.text():
                return True
            if self.proc.poll() is not None:
                time.sleep(0.2)
                return needle in self.text()
            time.sleep(0.02)
        return False

    def attrs(self):
        return termios.tcgetattr(self.slave)

    def is_raw(self):
        lflag = self.attrs()[3]
        return not (lflag & termios.ECHO) and not (lflag & termios.ICANON)

    def wait_exit(self, timeout=10.0):
        try:
            return self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            return None

    def errors(self):
        self.stderr.seek(0)
        return self.stderr.read().decode(errors='replace')

    def close(self):
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        time.sleep(0.2)  # let the reader take the last bytes
        self.stop = True
        self.reader.join(2.0)
        os.close(self.master)
        os.close(self.slave)
        self.stderr.close()


class Recorder:
    """Keeps the messages of one topic with their arrival time."""

    def __init__(self, topic, msg_type):
        self.lock = threading.Lock()
        self.msgs = []
        self.sub = rospy.Subscriber(topic, msg_type, self._cb, queue_size=1000)

    def _cb(self, msg):
        with self.lock:
            self.msgs.append((time.time(), msg))

    def since(self, t):
        with self.lock:
            return [(tm, m) for tm, m in self.msgs if tm >= t]

    def wait_for(self, predicate, timeout=3.0, since=None):
        """First message arriving after `since` (default now) that satisfies predicate."""
        start = time.time() if since is None else since
        deadline = time.time() + timeout
        while time.time() < deadline:
            for tm, m in self.since(start):
                if predicate(m):
                    return tm, m
            time.sleep(0.01)
        return None, None

    def last(self):
        with self.lock:
            return self.msgs[-1][1] if self.msgs else None


def near(a, b):
    return abs(a - b) < 1e-9


class TeleopOnPty(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node('teleop_pty_test')
        cls.torques = Recorder('torque_command', JointTorques)
        cls.camera = Recorder('renderer/camera_command', Twist)

    def start(self):
        node = PtyNode()
        self.addCleanup(node.close)
        for seq in MOUSE_ON:
            self.assertTrue(node.wait_output(seq), 'mouse mode %r not switched on; stderr: %s'
                            % (seq, node.errors()))
        _, msg = self.torques.wait_for(lambda m: True, timeout=15.0)
        self.assertIsNotNone(msg, 'no torque_command; stderr: ' + node.errors())
        self.assertTrue(node.is_raw(), 'terminal not in raw mode while teleop runs')
        return node, msg

    def expect(self, expected, timeout=3.0):
        """Waits for a torque_command whose efforts equal `expected` {joint: effort}, every
        other joint zero; returns its arrival time."""
        def ok(m):
            got = dict(zip(m.name, m.effort))
            return all(near(got.get(j, 0.0), expected.get(j, 0.0)) for j in got) and \
                all(j in got for j in expected)
        tm, msg = self.wait_for_or_fail(ok, expected, timeout)
        return tm

    def wait_for_or_fail(self, ok, expected, timeout):
        tm, msg = self.torques.wait_for(ok, timeout)
        if msg is None:
            last = self.torques.last()
            self.fail('expected efforts %s, last message %s' % (
                expected, dict(zip(last.name, last.effort)) if last else None))
        return tm, msg

    def check_restored(self, node):
        self.assertEqual(node.attrs(), node.original, 'termios attributes not restored')
        # The reader thread may not have drained the last bytes the node wrote yet.
        deadline = time.time() + 3.0
        while time.time() < deadline and not all(off in node.text() for off in MOUSE_OFF):
            time.sleep(0.05)
        out = node.text()
        for on, off in zip(MOUSE_ON, MOUSE_OFF):
            self.assertIn(off, out, 'mouse mode not switched off: %r' % off)
            self.assertGreater(out.rfind(off), out.rfind(on))

    def check_panel_fits(self, node):
        """The last panel drawn fits the COLS x ROWS terminal: at most ROWS lines, none reaching
        the last column (where it would wrap)."""
        deadline = time.time() + 3.0
        while time.time() < deadline:
            out = node.text()
            start = out.rfind(b'\x1b[H')
            end = out.find(b'\x1b[J', start)
            if start >= 0 and end > start:
                break
            time.sleep(0.05)
        self.assertTrue(start >= 0 and end > start, 'no complete panel drawn')
        text = re.sub(rb'\x1b\[[0-9;?]*[A-Za-z]', b'', out[start:end]).decode(errors='replace')
        text = text.replace('\r', '')  # the terminal's output processing adds CR to LF
        lines = text.split('\n')
        self.assertLessEqual(len(lines), ROWS, text)
        for line in lines:
            self.assertLess(len(line), COLS, 'panel line too wide: %r' % line)
        self.assertIn('panda_joint7', text)

    def test_keys_mouse_dead_man_and_quit(self):
        node, first = self.start()
        names = list(first.name)
        self.assertEqual(names[:7], PANDA_ARM)
        self.assertFalse(first.has_base_wrench)
        self.assertTrue(all(e == 0.0 for e in first.effort))
        j1, j2, j3, j5 = 'panda_joint1', 'panda_joint2', 'panda_joint3', 'panda_joint5'

        # Keys: '2' selects the second joint; + raises, - lowers by ~step times its limit.
        node.type(b'2+++')
        self.expect({j2: 3 * STEP * LIMIT[j2]})
        node.type(b'-----')
        self.expect({j2: -2 * STEP * LIMIT[j2]})
        # The step scales with the limit (12 N m: 1.2 per press); clamped to the limits.
        node.type(b'5+')
        self.expect({j2: -2 * STEP * LIMIT[j2], j5: 1.2})
        node.type(b'+' * 10)
        self.expect({j2: -2 * STEP * LIMIT[j2], j5: 12.0})
        node.type(b'3]]]' + b'-' * 8)  # step x8, then far below -87
        self.expect({j2: -2 * STEP * LIMIT[j2], j5: 12.0, j3: -87.0})
        self.check_panel_fits(node)
        node.type(b' ')  # space zeroes all
        self.expect({})
        # Arrow keys split across writes: Down from joint 3 selects joint 4, Up goes back.
        node.type(b'\x1b[')
        node.type(b'B\x1bO')
        node.type(b'A[[[+')  # step back to ~step, + on joint 3
        self.expect({j3: STEP * LIMIT[j3]})
        node.type(b'\x7f')  # Backspace zeroes the selected joint
        self.expect({})

        # Mouse: left drag of +20 columns = half of joint 1's 87 N m; back left of the press
        # point gives a negative torque. Garbage between reports is ignored.
        node.type(b'1' + sgr(0, 10, 5) + sgr(32, 20, 5) + b'\x1b[99;99~' + sgr(32, 30, 5))
        self.expect({j1: 43.5})
        node.type(sgr(32, 2, 6) + sgr(0, 2, 6, release=True))
        self.expect({j1: -17.4})
        # Wheel down x4 from joint 1 selects joint 5 (12 N m): a 10-column drag gives 3 N m.
        node.type(sgr(65, 2, 6) * 4 + sgr(0, 50, 6) + sgr(32, 60, 6) + sgr(0, 60, 6, True))
        self.expect({j1: -17.4, j5: 3.0})
        # A click (press and release, no motion) zeroes the selected joint.
        node.type(sgr(0, 7, 7) + sgr(0, 7, 7, release=True))
        t_last_input = time.time()
        self.expect({j1: -17.4})

        # Dead-man: no input for ~timeout s and every torque falls to zero.
        t_zero, _ = self.wait_for_or_fail(lambda m: not any(m.effort), {}, TIMEOUT + 3.0)
        idle = t_zero - t_last_input
        self.assertGreater(idle, TIMEOUT - 0.5, 'torques zeroed too early (%.2f s)' % idle)
        self.assertLess(idle, TIMEOUT + 1.5, 'dead-man too late (%.2f s)' % idle)

        # Camera keys: one Twist per press.
        t = time.time()
        node.type(b'az')
        _, yaw = self.camera.wait_for(lambda m: m.angular.z > 0, since=t)
        _, zoom = self.camera.wait_for(lambda m: m.linear.x > 0, since=t)
        self.assertIsNotNone(yaw, 'no camera yaw command for "a"')
        self.assertIsNotNone(zoom, 'no camera zoom command for "z"')
        self.assertAlmostEqual(yaw.angular.z, 0.1)
        self.assertAlmostEqual(zoom.linear.x, 0.1)
        self.assertEqual(len(self.camera.since(t)), 2)

        # Quit: a last all-zero command, exit code 0, terminal as before.
        node.type(b'1++')
        self.expect({j1: 2 * STEP * LIMIT[j1]})
        node.type(b'q')
        self.assertEqual(node.wait_exit(), 0, node.errors())
        time.sleep(0.3)
        self.assertFalse(any(self.torques.last().effort), 'last command after quit not zero')
        self.check_restored(node)

    def test_signals_restore_the_terminal(self):
        for sig in (signal.SIGTERM, signal.SIGINT):
            node, _ = self.start()
            node.type(b'+')
            self.expect({PANDA_ARM[0]: STEP * LIMIT[PANDA_ARM[0]]})
            node.proc.send_signal(sig)
            self.assertEqual(node.wait_exit(), 0, node.errors())
            self.check_restored(node)

    def test_ctrl_c_byte_quits(self):
        node, _ = self.start()
        node.type(b'\x03')
        self.assertEqual(node.wait_exit(), 0, node.errors())
        self.check_restored(node)

    def test_crash_signal_restores_the_terminal(self):
        node, _ = self.start()
        node.proc.send_signal(signal.SIGSEGV)
        self.assertEqual(node.wait_exit(), -signal.SIGSEGV)
        self.check_restored(node)

    def test_waits_for_robot_description(self):
        # As with sim.launch and a scene: robot_description is empty until the simulator has
        # loaded the robot.
        urdf = rospy.get_param('robot_description')
        self.addCleanup(rospy.set_param, 'robot_description', urdf)
        rospy.set_param('robot_description', '')
        t = time.time()
        node = PtyNode()
        self.addCleanup(node.close)
        time.sleep(2.0)
        self.assertIsNone(node.proc.poll(), 'gave up waiting: ' + node.errors())
        self.assertEqual(self.torques.since(t), [])
        rospy.set_param('robot_description', urdf)
        _, msg = self.torques.wait_for(lambda m: True, timeout=15.0)
        self.assertIsNotNone(msg, 'no torque_command; stderr: ' + node.errors())
        self.assertEqual(list(msg.name)[:7], PANDA_ARM)
        node.type(b'q')
        self.assertEqual(node.wait_exit(), 0, node.errors())
        self.check_restored(node)

    def test_without_a_terminal_it_exits_cleanly(self):
        res = subprocess.run([node_executable()], stdin=subprocess.DEVNULL,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=20)
        self.assertEqual(res.returncode, 0)
        self.assertIn(b'not a terminal', res.stderr)
        self.assertEqual(res.stderr.count(b'\n'), 1)  # one line


if __name__ == '__main__':
    rostest.rosrun(PKG, 'teleop_pty', TeleopOnPty)
