#!/usr/bin/env python3
"""Listens to a running tescalib pipeline (roslaunch tescalib kitti.launch ...) and prints what it
measured: the last published extrinsics (T_cam_lidar and, when co-calibrating, T_right_left), their
per-axis sigma and observability, their error against a reference, and the node's timings from
/diagnostics (first estimate, keyframe builds, solves, keyframe-to-estimate latency, drops).

The reference is the generator's ground truth (--ground-truth DIR/sim_info.txt) or, for a real
KITTI bag, the dataset's calibration on /tf_static (--ref-tf-frame camera_color_left).

It stops when the bag has ended (/clock stood still for --idle s) and the node is idle (two
diagnostics in a row without a solve running or a set pending), or --settle s after the first
estimate (for a looping bag), or at --timeout."""
import argparse
import os
import sys
import threading
import time

import rospy
from diagnostic_msgs.msg import DiagnosticArray
from rosgraph_msgs.msg import Clock
from tescalib.msg import ExtrinsicEstimate
from tf2_msgs.msg import TFMessage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import extrinsics as ex  # noqa: E402

AXES = 'rx ry rz tx ty tz'.split()


class Listener:
    def __init__(self, ref_tf_frame):
        self.lock = threading.Lock()
        self.estimates = {'lidar_to_left': [], 'left_to_right': [], 'candidate': []}
        self.diag = []  # (wall time, {key: value})
        self.clock_wall = None  # wall time /clock last advanced
        self.clock_value = None
        self.ref_tf_frame = ref_tf_frame
        self.ref = None
        self.tf_estimate = None  # last tf LiDAR -> tescalib_left seen on /tf_static
        self.left_frame = None
        rospy.Subscriber('/tescalib/lidar_to_left', ExtrinsicEstimate, self.on_est,
                         'lidar_to_left')
        rospy.Subscriber('/tescalib/left_to_right', ExtrinsicEstimate, self.on_est,
                         'left_to_right')
        rospy.Subscriber('/tescalib/candidate/lidar_to_left', ExtrinsicEstimate, self.on_est,
                         'candidate')
        rospy.Subscriber('/diagnostics', DiagnosticArray, self.on_diag)
        rospy.Subscriber('/clock', Clock, self.on_clock)
        rospy.Subscriber('/tf_static', TFMessage, self.on_tf_static)

    def on_est(self, msg, name):
        with self.lock:
            self.estimates[name].append((time.time(), msg))
            if name == 'lidar_to_left':
                self.left_frame = msg.parent_frame_id

    def on_diag(self, msg):
        for s in msg.status:
            if s.hardware_id == 'tescalib':
                with self.lock:
                    self.diag.append((time.time(), {kv.key: kv.value for kv in s.values}))

    def on_clock(self, msg):
        with self.lock:
            if self.clock_value is None or msg.clock != self.clock_value:
                self.clock_value = msg.clock
                self.clock_wall = time.time()

    def on_tf(self, msg):
        for t in msg.transforms:
            if self.left_frame is not None and t.child_frame_id == self.left_frame:
                with self.lock:
                    # tf carries T_lidar_left (left camera points into the LiDAR frame).
                    self.tf_estimate = ex.invert(*ex.from_msg(t.transform))

    def on_tf_static(self, msg):
        self.on_tf(msg)  # the node's estimate is on /tf_static too
        for t in msg.transforms:
            if self.ref_tf_frame and t.child_frame_id == self.ref_tf_frame:
                with self.lock:
                    self.ref = {'T_cam_lidar': ex.invert(*ex.from_msg(t.transform))}

    def bag_ended(self, idle):
        with self.lock:
            return self.clock_wall is not None and time.time() - self.clock_wall > idle

    def node_idle_since(self, t):
        """Two diagnostics after wall time t, the last two both idle with the same solve count."""
        with self.lock:
            d = [v for w, v in self.diag if w > t]
        if len(d) < 2:
            return False
        a, b = d[-2], d[-1]
        idle = all(x.get('solving') == 'False' and x.get('pending sets') == '0' for x in (a, b))
        return idle and a.get('solves') == b.get('solves')


def fmt(values, scale=1.0, digits=4):
    return ' '.join('%.*f' % (digits, scale * v) for v in values)


def trust_line(msg, published):
    """One line on whether the estimate can be used, from its per-axis trust flags."""
    if min(msg.sigma_rot_deg) < 0 or min(msg.sigma_trans_m) < 0:  # -1: unknown
        return 'trusted: no - the solve ended before its covariance'
    if not msg.estimated:
        return 'trusted: no - not estimated (the given value)'
    weak = [a for a, o in zip(AXES, msg.observable) if not o]
    if weak:
        return 'trusted: no - %s looser than %s trust limit%s' % (
            ' '.join(weak), 'its' if len(weak) == 1 else 'their', '' if len(weak) == 1 else 's')
    if not published:
        return 'trusted: no - every axis is within its limit, but the solve was not published'
    return 'trusted: yes, every axis within its trust limit (1 sigma)'


def print_estimate(title, msg, ref, published=True):
    q, t = ex.from_msg(msg.transform)
    # The message holds T_parent_child (T_cam_lidar); tf publishes its inverse, from the LiDAR
    # frame (child_frame_id) to the camera: shown in that direction, as a user reads tf.
    q_tf, t_tf = ex.invert(q, t)
    if q_tf[0] < 0:
        q_tf = tuple(-c for c in q_tf)
    print('  %s, %s -> %s: converged=%s, %d keyframes, %d iterations%s' % (
        title, msg.child_frame_id, msg.parent_frame_id, msg.converged, msg.keyframes_used,
        msg.iterations, '' if msg.estimated else ' (not estimated: the given value)'))
    print('    translation [%s] m' % fmt(t_tf))
    print('    quaternion (x y z w) [%s]' % fmt(q_tf[1:] + q_tf[:1], digits=6))
    print('    roll/pitch/yaw [%s] deg (R = Rz(yaw) Ry(pitch) Rx(roll), as tf)' % fmt(
        ex.roll_pitch_yaw(q_tf), 57.29577951308232))
    if min(msg.sigma_rot_deg) < 0 or min(msg.sigma_trans_m) < 0:  # -1: unknown
        print('    no covariance (the solve ended before it)')
    else:
        print('    sigma rot [%s] deg, sigma trans [%s] cm (about and along %s\'s x y z)' % (
            fmt(msg.sigma_rot_deg), fmt(msg.sigma_trans_m, 100, 2), msg.parent_frame_id))
    print('    %s' % trust_line(msg, published))
    if msg.weakest_ratio > 0:
        comps = [(c, a) for c, a in sorted(zip(msg.weakest_direction, AXES),
                                           key=lambda p: -abs(p[0])) if abs(c) >= 0.2]
        words = '%.2f %s' % comps[0] + ''.join(
            ' %s %.2f %s' % ('-' if c < 0 else '+', abs(c), a) for c, a in comps[1:])
        print('    weakest direction: %s, %.2fx the trust limit (above 1: looser than the limits)' % (
            words, msg.weakest_ratio))
    if ref is not None:
        phi, tau = ex.error((q, t), ref)
        print('    error vs reference: rotation [%s] deg (norm %.4f deg), translation [%s] cm '
              '(norm %.2f cm)' % (fmt(phi, 57.29577951308232), ex.norm(phi) * 57.29577951308232,
                                  fmt(tau, 100, 2), 100 * ex.norm(tau)))
        n = (ex.nees(phi, tau, list(msg.covariance))
             if msg.estimated and msg.covariance[0] >= 0 else None)
        if n is not None:
            print('    NEES against it %.1f (e^T P^-1 e over 6 DoF: mean 6 when the covariance '
                  'tells the truth)' % n)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--ground-truth', help='sim_info.txt of the generated drive')
    ap.add_argument('--ref-tf-frame', default='',
                    help='camera frame on /tf_static to compare T_cam_lidar with (real KITTI)')
    ap.add_argument('--frames', type=int, default=0, help='frames in the bag (for the drop count)')
    ap.add_argument('--timeout', type=float, default=150.0)
    ap.add_argument('--idle', type=float, default=2.0)
    ap.add_argument('--settle', type=float, default=0.0,
                    help='> 0: stop this long after the first estimate (looping bag)')
    args = ap.parse_args(rospy.myargv()[1:])
    rospy.init_node('tescalib_demo_report', anonymous=True)
    ref = ex.read_sim_info(args.ground_truth) if args.ground_truth else None
    lis = Listener(args.ref_tf_frame)
    start = time.time()
    first = None
    ended_at = None
    while not rospy.is_shutdown() and time.time() - start < args.timeout:
        time.sleep(0.2)
        with lis.lock:
            if first is None and lis.estimates['lidar_to_left']:
                first = lis.estimates['lidar_to_left'][0][0]
        if args.settle > 0:
            if first is not None and time.time() - first > args.settle:
                break
            continue
        if ended_at is None and lis.bag_ended(args.idle):
            ended_at = time.time()
        if ended_at is not None and lis.node_idle_since(ended_at):
            break
    timed_out = time.time() - start >= args.timeout
    with lis.lock:
        est = {k: list(v) for k, v in lis.estimates.items()}
        diag = lis.diag[-1][1] if lis.diag else {}
        tf_est = lis.tf_estimate
        if ref is None and lis.ref is not None:
            ref = lis.ref
    if timed_out:
        print('[demo] stopped listening after the %.0f s timeout' % args.timeout)
    if diag:
        sets, frames = int(diag['synchronized sets']), args.frames
        print('[demo] pipeline: %s synchronized sets%s, %s keyframes built, %s keyframe candidates '
              'dropped (preprocessing behind), %s frames rejected' % (
                  sets, ' of %d frames in the bag' % frames if frames else '', diag['keyframes'],
                  diag['dropped keyframe candidates'], diag['rejected frames']))
        print('[demo] timings (wall clock): keyframe build mean %.2f s, max %.2f s; %s solves, mean '
              '%.2f s, max %.2f s; keyframe arrival -> estimate from a window including it: '
              'mean %.2f s, max %.2f s over %s keyframes' % (
                  float(diag['keyframe build mean seconds']),
                  float(diag['keyframe build max seconds']), diag['solves'],
                  float(diag['solve mean seconds']), float(diag['solve max seconds']),
                  float(diag['update latency mean seconds']),
                  float(diag['update latency max seconds']), diag['update latency count']))
        if int(diag['first estimate after keyframes']) > 0:
            print('[demo] first estimate: after %s keyframes, %.2f s (wall) after the first '
                  'synchronized set, from the first %.1f s of the drive' % (
                      diag['first estimate after keyframes'],
                      float(diag['first estimate wall seconds']),
                      float(diag['first estimate sensor seconds'])))
        print('[demo] last solve: %s' % diag.get('last solve', ''))
    else:
        print('[demo] no /diagnostics from tescalib received')
    if not est['lidar_to_left']:
        print('[demo] no estimate was published (no solve converged); see the node log')
        if est['candidate']:
            cand = est['candidate'][-1][1]
            print('[demo] the last solve, not trusted (/tescalib/candidate/lidar_to_left): %s'
                  % cand.status)
            print_estimate('LiDAR -> left camera', cand, ref['T_cam_lidar'] if ref else None,
                           published=False)
        return 1
    print('[demo] %d estimates published; the last one:' % len(est['lidar_to_left']))
    lidar = est['lidar_to_left'][-1][1]
    print_estimate('LiDAR -> left camera', lidar, ref['T_cam_lidar'] if ref else None)
    co = [i for i, (_, m) in enumerate(est['left_to_right']) if any(s > 0 for s in m.sigma_trans_m)]
    if co and est['lidar_to_left']:
        print('[demo] first co-calibrated estimate (T_right_left estimated too): estimate %d of %d, '
              '%.2f s (wall) after the first estimate' % (
                  co[0] + 1, len(est['left_to_right']),
                  est['left_to_right'][co[0]][0] - est['lidar_to_left'][0][0]))
    stereo = est['left_to_right'][-1][1] if est['left_to_right'] else None
    if stereo is not None and any(s > 0 for s in stereo.sigma_trans_m):
        print_estimate('left -> right camera', stereo, ref.get('T_right_left') if ref else None)
    elif stereo is not None:
        print('  left -> right camera: not estimated (LiDAR-stereo only, or co-calibration not yet run), '
              'kept at the camera_info baseline %.4f m' % -stereo.transform.translation.x)
    if tf_est is not None:
        phi, tau = ex.error(tf_est, ex.from_msg(lidar.transform))
        print('[demo] tf %s -> %s agrees with it to %.1e deg / %.1e m' % (
            lidar.child_frame_id, lidar.parent_frame_id, ex.norm(phi) * 57.29577951308232,
            ex.norm(tau)))
    return 0


if __name__ == '__main__':
    sys.exit(main())
