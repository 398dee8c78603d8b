#!/usr/bin/env python3
"""Bad input to the running nodes (test/bad_input.test): CalibrationNodelet and OverlayNodelet in
their nodelet manager,
fed by this test with what a user's recording can contain: images without the other topics,
unusable camera_info, no initial tf, empty and all-NaN clouds, unsupported encodings, images of the
wrong size, LiDAR and image stamps too far apart, stamps going backwards. Each must be named in
/diagnostics ("last problem"; the log lines are throttled) and leave the node running, with
nothing published as an estimate and nothing on tf; the overlay keeps showing the images with
what the node waits for."""
import math
import random
import threading
import time
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import TransformStamped
from sensor_msgs import point_cloud2
from sensor_msgs.msg import CameraInfo, Image, PointCloud2, PointField
from tescalib.msg import ExtrinsicEstimate
from std_srvs.srv import Trigger
from tescalib.srv import Save
from tf2_msgs.msg import TFMessage

W, H, FX = 160, 120, 100.0
BASELINE = 0.54


def camera_info(stamp, frame, tx, width=W, height=H, fx=FX):
    m = CameraInfo()
    m.header.stamp, m.header.frame_id = stamp, frame
    m.width, m.height = width, height
    m.K = [fx, 0, width / 2.0, 0, fx, height / 2.0, 0, 0, 1]
    m.R = [1, 0, 0, 0, 1, 0, 0, 0, 1]
    m.P = [fx, 0, width / 2.0, tx, 0, fx, height / 2.0, 0, 0, 0, 1, 0]
    return m


def image(stamp, frame, width=W, height=H, encoding='rgb8', seed=0, black=False):
    m = Image()
    m.header.stamp, m.header.frame_id = stamp, frame
    m.width, m.height, m.encoding = width, height, encoding
    channels = {'rgb8': 3, 'mono8': 1, '32FC1': 4}[encoding]
    m.step = width * channels
    rng = random.Random(seed)
    if encoding == 'rgb8':  # grey texture: whatever the overlay draws in colour stands out
        m.data = bytes(v for v in rng.randbytes(height * width) for _ in range(3))
    else:
        m.data = rng.randbytes(height * m.step)
    if black:
        m.data = bytes(len(m.data))
    return m


def cloud(stamp, points):
    fields = [PointField(n, 4 * i, PointField.FLOAT32, 1)
              for i, n in enumerate(('x', 'y', 'z', 'intensity'))]
    header = rospy.Header(stamp=stamp, frame_id='velo_link')
    return point_cloud2.create_cloud(header, fields, [tuple(p) + (0.5,) for p in points])


def ring_cloud(stamp):
    """A few rings of a spinning LiDAR looking at a wall 10 m ahead (x forward, KITTI's LiDAR)."""
    pts = []
    for ring in range(8):
        elev = math.radians(-8 + 2 * ring)
        for k in range(360):
            az = math.radians(k)
            d = (math.cos(elev) * math.cos(az), math.cos(elev) * math.sin(az), math.sin(elev))
            r = 10.0 / d[0] if d[0] > 0.5 else 20.0
            pts.append(tuple(r * c for c in d))
    return cloud(stamp, pts)


class BadInput(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_bad_input')
        cls.lock = threading.Lock()
        cls.diag = []
        cls.bad_params_diag = []
        cls.bad_transport_diag = []
        cls.published = []
        cls.tf_children = set()
        rospy.Subscriber('/diagnostics', DiagnosticArray, cls.on_diag)
        for topic in ('/tescalib/lidar_to_left', '/tescalib/left_to_right'):
            rospy.Subscriber(topic, ExtrinsicEstimate, cls.on_estimate, topic)
        for tf_topic in ('/tf', '/tf_static'):  # the estimate goes on /tf_static
            rospy.Subscriber(tf_topic, TFMessage, cls.on_tf)
        cls.overlays = []
        rospy.Subscriber('/tescalib_overlay/left/overlay', Image, cls.on_overlay)
        cls.right_overlays = []
        rospy.Subscriber('/tescalib_overlay/right/overlay', Image,
                         lambda m: cls.right_overlays.append((m.width, m.height, m.encoding)))
        cls.candidate_pub = rospy.Publisher('/tescalib/candidate/lidar_to_left', ExtrinsicEstimate,
                                            queue_size=1, latch=True)
        cls.pub = {
            'points': rospy.Publisher('/bad/points', PointCloud2, queue_size=10),
            'left': rospy.Publisher('/bad/left/image_raw', Image, queue_size=10),
            'left_info': rospy.Publisher('/bad/left/camera_info', CameraInfo, queue_size=10),
            'right': rospy.Publisher('/bad/right/image_raw', Image, queue_size=10),
            'right_info': rospy.Publisher('/bad/right/camera_info', CameraInfo, queue_size=10),
        }
        deadline = time.time() + 30
        while time.time() < deadline and not (
                all(p.get_num_connections() > 0 for p in cls.pub.values()) and cls.diag):
            time.sleep(0.1)
        assert cls.diag, 'the node publishes no /diagnostics'
        cls.t = rospy.Time(1000.0)  # stamps of the sets this test sends, 1 s apart

    @classmethod
    def on_diag(cls, msg):
        for s in msg.status:
            if s.hardware_id == 'tescalib' and 'bad_params' in s.name:
                with cls.lock:
                    cls.bad_params_diag.append((s.level, s.message))
            elif s.hardware_id == 'tescalib' and 'bad_transport' in s.name:
                with cls.lock:
                    cls.bad_transport_diag.append((s.level, s.message))
            elif s.hardware_id == 'tescalib':
                with cls.lock:
                    cls.diag.append((time.time(), s.message, {kv.key: kv.value for kv in s.values}))

    @classmethod
    def on_estimate(cls, msg, topic):
        with cls.lock:
            cls.published.append(topic)

    @classmethod
    def on_overlay(cls, msg):
        # Pixels below the status band whose colour is not grey: LiDAR points drawn.
        d = msg.data
        coloured = sum(1 for i in range(3 * msg.width * 60, len(d) - 2, 3)
                       if d[i] != d[i + 1] or d[i + 1] != d[i + 2])
        with cls.lock:
            cls.overlays.append((time.time(), msg.width, msg.height, msg.encoding, coloured))

    @classmethod
    def on_tf(cls, msg):
        with cls.lock:
            cls.tf_children.update(t.child_frame_id for t in msg.transforms)

    def next_stamp(self, step=1.0):
        BadInput.t += rospy.Duration(step)
        return BadInput.t

    def send(self, left_info=None, right_info=None, left=None, right=None, points=None,
             cloud_offset=0.0, stamp=None):
        """One set on all five topics (cloud stamped `cloud_offset` s after the images)."""
        t = stamp if stamp is not None else self.next_stamp()
        tc = t + rospy.Duration(cloud_offset)
        self.pub['points'].publish(points(tc) if points else ring_cloud(tc))
        self.pub['left_info'].publish(left_info(t) if left_info else
                                      camera_info(t, 'camera_color_left', 0.0))
        self.pub['right_info'].publish(right_info(t) if right_info else
                                       camera_info(t, 'camera_color_right', -FX * BASELINE))
        self.pub['left'].publish(left(t) if left else image(t, 'camera_color_left', seed=1))
        self.pub['right'].publish(right(t) if right else image(t, 'camera_color_right', seed=2))

    def latest(self):
        with self.lock:
            return self.diag[-1] if self.diag else (0, '', {})

    def wait_problem(self, text, resend=None, timeout=15.0):
        """Waits until /diagnostics' last problem contains `text`, calling `resend` every 0.5 s
        (approximate sync emits a set once a newer message shows it is complete)."""
        deadline = time.time() + timeout
        while time.time() < deadline:
            if resend:
                resend()
            time.sleep(0.5)
            _, _, values = self.latest()
            if text in values.get('last problem', ''):
                return values
        self.fail('no "%s" in /diagnostics; last problem: "%s"' %
                  (text, self.latest()[2].get('last problem')))

    def test_0_parameters(self):
        # The misspelled key is named; the node with window/size 0 says so as an error.
        self.assertEqual(self.latest()[2].get('unknown parameters'), '/tescalib/sync/max_skw')
        deadline = time.time() + 15
        while time.time() < deadline and not self.bad_params_diag:
            time.sleep(0.2)
        self.assertTrue(self.bad_params_diag, 'the node with invalid parameters is silent')
        level, message = self.bad_params_diag[-1]
        self.assertEqual(level, DiagnosticStatus.ERROR)
        self.assertIn('invalid parameters: window/size must be >= 1 (got 0)', message)

    def test_0b_an_image_transport_that_is_not_installed(self):
        # The node stays inert and names the transport and the ones it could load.
        deadline = time.time() + 15
        while time.time() < deadline and not self.bad_transport_diag:
            time.sleep(0.2)
        self.assertTrue(self.bad_transport_diag, 'the node with a missing transport is silent')
        level, message = self.bad_transport_diag[-1]
        self.assertEqual(level, DiagnosticStatus.ERROR)
        self.assertIn('image_transport "no_such_transport" cannot be used: installed here: ',
                      message)
        self.assertIn('raw', message.split('installed here: ')[1])

    def test_1_images_without_the_other_topics(self):
        for _ in range(25):
            t = self.next_stamp(0.1)
            self.pub['left'].publish(image(t, 'camera_color_left'))
            self.pub['right'].publish(image(t, 'camera_color_right'))
            time.sleep(0.03)
        self.wait_problem('images but no synchronized set')
        _, message, values = self.latest()
        # It names the topics that have had nothing (the cloud and both camera_infos here).
        self.assertIn('nothing on /bad/points, /bad/left/camera_info, /bad/right/camera_info',
                      values['last problem'])
        self.assertTrue(message.startswith('waiting for synchronized data: '), message)
        self.assertIn('nothing on /bad/points', message)
        self.assertEqual(values['synchronized sets'], '0')

    def test_2_unusable_camera_info(self):
        no_p = lambda t: camera_info(t, 'camera_color_left', 0.0, fx=0.0)
        self.wait_problem('camera_info has no rectified projection matrix P',
                          lambda: self.send(left_info=no_p))
        no_baseline = lambda t: camera_info(t, 'camera_color_right', 0.0)
        self.wait_problem('the right camera must sit to the right of the left one', lambda: self.send(right_info=no_baseline))
        # Sets come but cannot start the node: the summary says why.
        self.assertTrue(self.latest()[1].startswith('not started: right camera_info P[3]'),
                        self.latest()[1])

    def test_3_no_initial_extrinsic(self):
        self.wait_problem('no initial extrinsic: tf velo_link -> camera_color_left', self.send)
        # Now the rig's tf, as kitti2bag bags carry it: camera <- LiDAR (x forward, z up).
        BadInput.static_tf = rospy.Publisher('/tf_static', TFMessage, queue_size=1, latch=True)
        ts = TransformStamped()
        ts.header.stamp = rospy.Time.now()
        ts.header.frame_id, ts.child_frame_id = 'camera_color_left', 'velo_link'
        ts.transform.translation.y, ts.transform.translation.z = -0.08, -0.27
        ts.transform.rotation.x, ts.transform.rotation.y = -0.5, 0.5
        ts.transform.rotation.z, ts.transform.rotation.w = -0.5, 0.5
        BadInput.static_tf.publish(TFMessage([ts]))

    def rejected(self):
        return int(self.latest()[2].get('rejected frames', '0'))

    def test_4_empty_and_nan_clouds(self):
        # The calibrator is created with the first usable set; then clouds are checked.
        self.wait_problem('point cloud rejected: point cloud is empty',
                          lambda: self.send(points=lambda t: cloud(t, [])))
        before = self.rejected()
        nan = [(float('nan'),) * 3] * 100
        self.wait_problem('point cloud rejected: point cloud has no finite points (100 dropped)',
                          lambda: self.send(points=lambda t: cloud(t, nan)))
        self.assertGreater(self.rejected(), before)

    def test_5_bad_images(self):
        float_image = lambda t: image(t, 'camera_color_left', encoding='32FC1')
        self.wait_problem("image rejected: left image: unsupported image encoding '32FC1'",
                          lambda: self.send(left=float_image))
        small = lambda frame: (lambda t: image(t, frame, width=W // 2, height=H // 2))
        self.wait_problem('frame rejected: image size 80x60 / 80x60 does not match camera_info '
                          '160x120', lambda: self.send(left=small('camera_color_left'),
                                                       right=small('camera_color_right')))
        # A right camera gone black (covered, or its driver failing).
        black = lambda t: image(t, 'camera_color_right', black=True)
        self.wait_problem("frame rejected: the right image has almost no contrast (grey values' "
                          "standard deviation 0.00", lambda: self.send(right=black))

    def test_6_lidar_and_images_not_synchronized(self):
        self.wait_problem('frame rejected: LiDAR and image stamps differ by',
                          lambda: self.send(cloud_offset=0.2))
        # A right image from another moment (a dropped frame paired with the one before).
        late_right = lambda t: image(t + rospy.Duration(0.2), 'camera_color_right', seed=2)
        late_info = lambda t: camera_info(t + rospy.Duration(0.2), 'camera_color_right',
                                          -FX * BASELINE)
        self.wait_problem('left and right image stamps differ by 0.2',
                          lambda: self.send(right=late_right, right_info=late_info))
        # 40 ms: within sync/max_skew (LiDAR vs images), beyond sync/max_stereo_skew (0.02 s).
        right_40 = lambda t: image(t + rospy.Duration(0.04), 'camera_color_right', seed=2)
        info_40 = lambda t: camera_info(t + rospy.Duration(0.04), 'camera_color_right',
                                        -FX * BASELINE)
        self.wait_problem('left and right image stamps differ by 0.04',
                          lambda: self.send(right=right_40, right_info=info_40))

    def test_7_time_going_backwards(self):
        # A set accepted as far as its stamps go (its toy scan then gives a keyframe or not), and
        # one 30 s earlier, as when a bag loops.
        self.send()
        time.sleep(1.0)
        back = self.t - rospy.Duration(30.0)
        self.wait_problem('time went backwards by 3', lambda: self.send(stamp=back))

    def test_7b_camera_info_changing_after_start_up(self):
        # The rig is made from the first usable camera_infos; a later change is said, not used.
        other_fx = lambda t: camera_info(t, 'camera_color_left', 0.0, fx=FX * 1.1)
        self.wait_problem('camera_info changed since start-up',
                          lambda: self.send(left_info=other_fx))

    def test_8_node_still_running_and_silent(self):
        t0 = time.time()
        time.sleep(2.5)
        with self.lock:
            recent = [d for d in self.diag if d[0] > t0]
            published = list(self.published)
            children = set(self.tf_children)
        self.assertGreaterEqual(len(recent), 2, 'diagnostics stopped: the node died?')
        values = recent[-1][2]
        self.assertGreaterEqual(int(values['synchronized sets']), 8)
        self.assertGreaterEqual(int(values['rejected frames']), 5)
        self.assertEqual(values['converged'], 'False')
        self.assertEqual(published, [], 'an estimate was published from bad input')
        self.assertNotIn('tescalib_left', children)
        with self.lock:
            overlays = list(self.overlays)
        self.assertTrue(overlays, 'no overlay image')
        self.assertEqual(overlays[-1][1:4], (W, H, 'bgr8'))
        self.assertEqual(overlays[-1][4], 0, 'LiDAR points drawn without any estimate')
        # The right pane is not left empty before the first estimate: the image with the status.
        self.assertTrue(self.right_overlays, 'no right overlay image before an estimate')
        self.assertEqual(self.right_overlays[-1], (W, H, 'bgr8'))
        save = rospy.ServiceProxy('/tescalib/save', Save)
        res = save(path='/tmp/tescalib_bad_input_never_written')
        self.assertFalse(res.success)
        self.assertIn('no converged estimate', res.message)
        self.assertTrue(rospy.ServiceProxy('/tescalib/reset', Trigger)().success)


    def test_9_overlay_draws_an_untrusted_candidate(self):
        # Where nothing converges (real KITTI) the overlay draws the last solve, labelled as not
        # trusted; here a candidate as the calibration nodelet publishes one (the rig's tf).
        c = ExtrinsicEstimate()
        c.parent_frame_id, c.child_frame_id = 'tescalib_left', 'velo_link'
        c.transform.translation.y, c.transform.translation.z = -0.08, -0.27
        c.transform.rotation.x, c.transform.rotation.y = -0.5, 0.5
        c.transform.rotation.z, c.transform.rotation.w = -0.5, 0.5
        c.converged, c.keyframes_used = False, 8
        c.status = 'not converged: a test candidate'
        self.candidate_pub.publish(c)
        deadline = time.time() + 15
        while time.time() < deadline:
            self.send()
            time.sleep(0.5)
            with self.lock:
                if self.overlays and self.overlays[-1][4] > 100:
                    break
        with self.lock:
            last = self.overlays[-1]
        self.assertGreater(last[4], 100, 'the candidate is not drawn into the overlay')
        with self.lock:
            self.assertEqual(self.published, [])  # a candidate is never an estimate


if __name__ == '__main__':
    rostest.rosrun('tescalib', 'bad_input', BadInput)
