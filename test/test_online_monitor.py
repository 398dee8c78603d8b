#!/usr/bin/env python3
"""Monitoring rostest (test/online_monitor.test): a generated urban drive whose LiDAR is knocked
(0.5 deg / 3 cm at STEP_S), converted to a bag and played at 1x through the nodes of kitti.launch.
The node has to publish the first extrinsic, notice the change (~status: suspect, then changed /
recalibrating; /diagnostics WARN or ERROR naming the monitor), keep the old extrinsic on tf
meanwhile, and put the new one on tf once recalibrated."""
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import unittest

import rospkg
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from sensor_msgs.msg import CameraInfo
from tescalib.msg import CalibrationStatus
from tf2_msgs.msg import TFMessage

_PKG = rospkg.RosPack().get_path('tescalib')
sys.path[:0] = [os.path.join(_PKG, 'scripts'), os.path.join(_PKG, 'test')]
import extrinsics as ex  # noqa: E402
from generated_drive import generated_drive  # noqa: E402

DEG = 57.29577951308232
SECONDS, STEP_S, SEED = 30, 8.0, 31


class OnlineMonitor(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_online_monitor')
        cls.lock = threading.Lock()
        cls.status, cls.tf, cls.diag = [], [], []
        cls.start = None  # the bag's first stamp: the drive's 0 s
        rospy.Subscriber('/kitti/camera_color_left/camera_info', CameraInfo, cls.on_info)
        rospy.Subscriber('/tescalib/status', CalibrationStatus, cls.on_status)
        rospy.Subscriber('/tf_static', TFMessage, cls.on_tf)
        rospy.Subscriber('/diagnostics', DiagnosticArray, cls.on_diag)
        cls.tmp = tempfile.mkdtemp(prefix='tescalib_monitor_')
        bag = os.path.join(cls.tmp, 'drive.bag')
        drive = generated_drive(['--scenario', 'urban', '--frames', str(SECONDS * 10), '--every',
                                 '5', '--seed', str(SEED), '--extrinsic-step',
                                 '%g,0.5,0.03,lidar' % STEP_S])
        subprocess.run(['rosrun', 'tescalib', 'kitti_to_bag', '--in', drive, '--out', bag],
                       check=True, stdout=subprocess.DEVNULL)
        cls.truth = ex.read_sim_info(os.path.join(drive, 'sim_info.txt'))
        time.sleep(3)  # the nodes subscribe
        subprocess.run(['rosbag', 'play', '--clock', '-d', '1', '--quiet', bag], check=True)
        time.sleep(5)  # the last solve

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    @classmethod
    def drive_time(cls, stamp):
        """Seconds of the drive (times.txt's) at a bag stamp (s)."""
        return stamp - cls.start if cls.start is not None else -1e9

    @classmethod
    def on_info(cls, msg):
        with cls.lock:
            if cls.start is None:
                cls.start = msg.header.stamp.to_sec()

    @classmethod
    def on_status(cls, msg):
        with cls.lock:
            cls.status.append((cls.drive_time(msg.header.stamp.to_sec()), msg.lidar_to_left))

    @classmethod
    def on_tf(cls, msg):
        for t in msg.transforms:
            if t.child_frame_id == 'tescalib_left':
                with cls.lock:
                    cls.tf.append((cls.drive_time(rospy.get_time()), ex.invert(*ex.from_msg(t.transform))))

    @classmethod
    def on_diag(cls, msg):
        for s in msg.status:
            if s.hardware_id == 'tescalib':
                with cls.lock:
                    cls.diag.append((cls.drive_time(rospy.get_time()), s.level, s.message))

    def error_to(self, T, truth):
        phi, tau = ex.error(T, self.truth[truth])
        return ex.norm(phi) * DEG, ex.norm(tau)

    def test_1_states_on_status(self):
        with self.lock:
            states = [s for _, s in self.status]
        rospy.loginfo('monitor: ~status %s', states)
        # The first published estimate, the change noticed, the window restarted, the new one.
        order = ['calibrated', 'suspect', 'recalibrating', 'calibrated']
        k = 0
        for s in states:
            if k < len(order) and s == order[k]:
                k += 1
        self.assertEqual(k, len(order), 'states %s lack the sequence %s' % (states, order))
        first_suspect = next(t for t, s in self.status if s == 'suspect')
        self.assertGreater(first_suspect, STEP_S)
        self.assertLess(first_suspect, STEP_S + 10)

    def test_2_tf_before_and_after(self):
        with self.lock:
            tf = list(self.tf)
        before = [T for t, T in tf if t < STEP_S]
        self.assertTrue(before, 'no extrinsic on /tf_static before the change')
        rot, trans = self.error_to(before[-1], 'T_cam_lidar')
        rospy.loginfo('monitor: tf before the change %.3f deg / %.2f cm off', rot, 100 * trans)
        self.assertLess(rot, 0.1)
        self.assertLess(trans, 0.015)
        rot, trans = self.error_to(tf[-1][1], 'T_cam_lidar_after_step')
        rospy.loginfo('monitor: tf at the end %.3f deg / %.2f cm off the new truth (%d on tf)',
                      rot, 100 * trans, len(tf))
        self.assertLess(rot, 0.1)
        self.assertLess(trans, 0.015)
        # Nothing on tf between the change and the recalibrated estimate is farther from the new
        # truth than the extrinsic it replaced (in units of 0.05 deg / 1 cm; a tenth of them is
        # a tie, as tescalib_eval --score-estimates counts).
        after = [T for t, T in tf if t >= STEP_S]
        errors = [max(r / 0.05, d / 0.01) for r, d in
                  (self.error_to(T, 'T_cam_lidar_after_step') for T in [before[-1]] + after)]
        rospy.loginfo('monitor: tf from the change on, errors in 0.05 deg / 1 cm: %s',
                      ' '.join('%.2f' % e for e in errors))
        for k in range(1, len(errors)):
            if errors[k - 1] <= 1:
                break
            self.assertLessEqual(errors[k], errors[k - 1] + 0.1, 'tf made worse: %s' % errors)

    def test_3_diagnostics_name_the_monitor(self):
        with self.lock:
            diag = list(self.diag)
        warned = [m for t, level, m in diag if level in (DiagnosticStatus.WARN,
                  DiagnosticStatus.ERROR) and 'monitor: lidar_to_left' in m]
        self.assertTrue(warned, 'no WARN / ERROR naming the monitor in %s' % diag[-20:])
        rospy.loginfo('monitor: diagnostics said "%s"', warned[0])
        # Recalibrated: the last report while the bag played is OK (after its end the node warns
        # that no synchronized set comes).
        playing = [d for d in diag if 'no synchronized set' not in d[2]]
        self.assertEqual(playing[-1][1], DiagnosticStatus.OK, playing[-1])


if __name__ == '__main__':
    rostest.rosrun('tescalib', 'test_online_monitor', OnlineMonitor)
