#!/usr/bin/python3
"""The install space (issue 19): `catkin_make install` must hold everything the launch files
need. This test runs the build's install step (cmake --install, what catkin_make install does
after building), checks that every se3_sim library and node of the devel space is installed,
then starts demo.launch from the install space alone, in an environment of install/setup.bash
with every devel and source path taken out, and checks that the simulator and the renderer
publish, and that their processes run the installed executables and libraries.

Started by test/install_space.test with the build folder, the devel and install prefixes and
the source folder as arguments (CMakeLists.txt).
"""
import glob
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import unittest
import xmlrpc.client

import rosgraph
import rospy
import rostest
from sensor_msgs.msg import Image, JointState

PKG = 'se3_sim'


def args():
    # CMakeLists.txt writes the four folders into the devel space (on CMAKE_PREFIX_PATH).
    for prefix in os.environ.get('CMAKE_PREFIX_PATH', '').split(':'):
        path = os.path.join(prefix, 'share', PKG, 'install_space_paths')
        if prefix and os.path.isfile(path):
            lines = [l for l in open(path).read().splitlines() if l]
            if len(lines) >= 4:
                return [os.path.realpath(x) for x in lines[:4]]
    raise SystemExit('install_space_check.py: no share/se3_sim/install_space_paths on '
                     'CMAKE_PREFIX_PATH (written by CMakeLists.txt into the devel space)')


BUILD, DEVEL, INSTALL, SOURCE = args()

# Sourced by bash -c: the install space's environment, minus the devel space and the sources.
ENV_SCRIPT = r'''
source "$INSTALL/setup.bash" || exit 1
keep() {  # $1 without the entries under $DEVEL, $SOURCE or the workspace's src folder
  local IFS=: out= p
  for p in $1; do
    p_real=$(realpath -m "$p" 2>/dev/null || echo "$p")
    case "$p_real/" in "$DEVEL"/*|"$SOURCE"/*|"$WS_SRC"/*) continue ;; esac
    out=${out:+$out:}$p
  done
  echo "$out"
}
for v in ROS_PACKAGE_PATH LD_LIBRARY_PATH CMAKE_PREFIX_PATH PYTHONPATH PKG_CONFIG_PATH PATH; do
  export $v="$(keep "${!v}")"
done
'''


class InstallSpace(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node('install_space_check')
        log = os.path.join(tempfile.gettempdir(), 'se3_sim_install_%d.log' % os.getpid())
        # A fresh install, so that nothing an earlier install left there hides a missing rule;
        # removed only when it is catkin_make's own install folder beside the build folder.
        if INSTALL == os.path.join(os.path.dirname(BUILD), 'install'):
            shutil.rmtree(INSTALL, ignore_errors=True)
        with open(log, 'w') as f:
            r = subprocess.run(['cmake', '--install', BUILD], stdout=f, stderr=subprocess.STDOUT,
                               timeout=600)
        if r.returncode != 0:
            raise AssertionError('cmake --install %s failed: %s' % (BUILD, open(log).read()[-3000:]))

    def env(self):
        env = {'HOME': os.environ.get('HOME', '/root'), 'PATH': '/usr/bin:/bin',
               'LANG': 'C.UTF-8', 'INSTALL': INSTALL, 'DEVEL': DEVEL, 'SOURCE': SOURCE,
               'WS_SRC': os.path.realpath(os.path.join(BUILD, '..', 'src')),
               'ROS_MASTER_URI': os.environ['ROS_MASTER_URI'], 'ROS_HOSTNAME': 'localhost'}
        return env

    def in_install_env(self, command, **kw):
        return subprocess.run(['bash', '-c', ENV_SCRIPT + command], env=self.env(),
                              capture_output=True, text=True, **kw)

    def test_every_library_and_node_is_installed(self):
        devel_libs = sorted(os.path.basename(p) for p in glob.glob(DEVEL + '/lib/libse3_sim_*.so'))
        self.assertTrue(devel_libs, 'no libse3_sim_*.so in %s/lib' % DEVEL)
        for lib in devel_libs:
            self.assertTrue(os.path.isfile(os.path.join(INSTALL, 'lib', lib)), lib)
        nodes = [os.path.basename(p) for p in glob.glob(DEVEL + '/lib/se3_sim/*_node')]
        self.assertEqual(sorted(nodes), ['renderer_node', 'simulator_node', 'teleop_node'])
        for exe in nodes + ['se3_dyn']:
            self.assertTrue(os.access(os.path.join(INSTALL, 'lib', PKG, exe), os.X_OK), exe)
        share = os.path.join(INSTALL, 'share', PKG)
        for d in ('launch', 'config/scenes', 'config/controllers', 'data/robots', 'msg', 'srv'):
            self.assertTrue(os.path.isdir(os.path.join(share, d)), d)
        for f in ('package.xml', 'LICENSE', 'launch/sim.launch', 'launch/demo.launch',
                  'launch/teleop.launch', 'config/scenes/generic.yaml'):
            self.assertTrue(os.path.isfile(os.path.join(share, f)), f)
        # Messages for Python and C++ users.
        self.assertTrue(glob.glob(INSTALL + '/lib/python3/dist-packages/se3_sim/msg/_JointTorques.py'))
        self.assertTrue(os.path.isfile(os.path.join(INSTALL, 'include', PKG, 'JointTorques.h')))
        # The environment sees the installed package only.
        r = self.in_install_env('rospack find se3_sim; rospack list | grep -c "^se3_sim "')
        self.assertEqual(r.stdout.split(), [share, '1'], r.stderr)
        r = self.in_install_env('rosrun se3_sim se3_dyn info "$(rospack find se3_sim)/data/robots/ur5_robot.urdf"')
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn('model: ur5', r.stdout)

    def test_demo_launch_from_the_install_space(self):
        log = tempfile.TemporaryFile()
        proc = subprocess.Popen(['bash', '-c', ENV_SCRIPT + 'exec roslaunch se3_sim demo.launch'],
                                env=self.env(), stdout=log, stderr=subprocess.STDOUT,
                                start_new_session=True)

        def text():
            log.seek(0)
            return log.read().decode(errors='replace')
        try:
            js = rospy.wait_for_message('joint_states', JointState, timeout=40)
            self.assertTrue(js.name and 'panda_joint1' in js.name, js)
            img = rospy.wait_for_message('renderer/image', Image, timeout=40)
            self.assertEqual((img.width, img.height), (1280, 1024))
            master = rosgraph.Master('/install_space_check')
            for node, exe in (('/simulator', 'simulator_node'), ('/renderer', 'renderer_node')):
                uri = master.lookupNode(node)
                self.assertTrue(uri, node)
                _, _, pid = xmlrpc.client.ServerProxy(uri).getPid('/install_space_check')
                self.assertEqual(os.path.realpath('/proc/%d/exe' % pid),
                                 os.path.join(INSTALL, 'lib', PKG, exe))
                with open('/proc/%d/maps' % pid) as f:
                    maps = f.read()
                self.assertIn(os.path.join(INSTALL, 'lib', 'libse3_sim_core.so'), maps)
                self.assertNotIn(DEVEL + '/', maps, '%s maps a devel-space file' % node)
        except Exception:
            print(text())
            raise
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGINT)
                try:
                    proc.wait(15)
                except subprocess.TimeoutExpired:
                    os.killpg(proc.pid, signal.SIGKILL)
                    proc.wait()


if __name__ == '__main__':
    rostest.rosrun(PKG, 'install_space_check', InstallSpace, sys.argv)
