#!/usr/bin/env python3
"""Waits for tescalib's first published estimates and prints them, their per-axis sigma and their
error against the reference on /tf_static (the dataset's calibration), then exits.
After the first estimate it keeps listening for `settle_s` seconds (the window keeps filling) and
reports the last one. Usage: demo_report.py [timeout_s] [settle_s] [reference_camera_frame]"""
import math
import time
import sys

import rospy
from tescalib.msg import ExtrinsicEstimate
from tf2_msgs.msg import TFMessage


def qmul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


def qconj(q):
    return (q[0], -q[1], -q[2], -q[3])


def rotate(q, v):
    w, x, y, z = qmul(qmul(q, (0.0,) + tuple(v)), qconj(q))
    return (x, y, z)


def invert(q, t):
    qi = qconj(q)
    ti = rotate(qi, t)
    return qi, (-ti[0], -ti[1], -ti[2])


def rotvec(q):
    w = max(-1.0, min(1.0, q[0]))
    if w < 0:
        q = tuple(-c for c in q)
        w = -w
    s = math.sqrt(max(0.0, 1 - w * w))
    angle = 2 * math.atan2(s, w)
    if s < 1e-12:
        return (0.0, 0.0, 0.0)
    return tuple(angle * c / s for c in q[1:])


def main():
    timeout = float(sys.argv[1]) if len(sys.argv) > 1 else 120.0
    settle = float(sys.argv[2]) if len(sys.argv) > 2 else 20.0
    ref_frame = sys.argv[3] if len(sys.argv) > 3 else 'camera_color_left'
    rospy.init_node('tescalib_demo_report', anonymous=True)
    ref = {}
    latest = {}

    def on_est(msg):
        latest['lidar'] = msg
        latest['count'] = latest.get('count', 0) + 1

    def on_tf(msg):
        for t in msg.transforms:
            if t.child_frame_id == ref_frame:
                r = t.transform.rotation
                p = t.transform.translation
                # tf gives T_lidar_cam (camera points into the LiDAR frame): invert.
                ref['T'] = invert((r.w, r.x, r.y, r.z), (p.x, p.y, p.z))
    rospy.Subscriber('/tf_static', TFMessage, on_tf)
    rospy.Subscriber('/tescalib/lidar_to_left', ExtrinsicEstimate, on_est)
    start = time.time()
    while 'lidar' not in latest and time.time() - start < timeout and not rospy.is_shutdown():
        time.sleep(0.2)
    if 'lidar' not in latest:
        print('[demo] no converged estimate within %.0f s (see the node log)' % timeout)
        return 1
    first = time.time() - start
    print('[demo] first estimate %.1f s after start; listening %.0f s more' % (first, settle))
    time.sleep(settle)
    est = latest['lidar']
    print('[demo] %d estimates published' % latest['count'])
    stereo = None
    try:
        stereo = rospy.wait_for_message('/tescalib/left_to_right', ExtrinsicEstimate, timeout=2.0)
    except rospy.ROSException:
        pass
    r, p = est.transform.rotation, est.transform.translation
    q, t = (r.w, r.x, r.y, r.z), (p.x, p.y, p.z)
    print('[demo] T_cam_lidar (LiDAR -> left camera) from %d keyframes, converged=%s, %d iterations'
          % (est.keyframes_used, est.converged, est.iterations))
    print('       translation [%.4f %.4f %.4f] m, rotation vector [%s] deg' % (
        t[0], t[1], t[2], ' '.join('%.4f' % math.degrees(c) for c in rotvec(q))))
    print('       sigma rot [%s] deg, sigma trans [%s] cm, observable %s' % (
        ' '.join('%.4f' % s for s in est.sigma_rot_deg),
        ' '.join('%.2f' % (100 * s) for s in est.sigma_trans_m), list(est.observable)))
    if stereo is not None:
        sp = stereo.transform.translation
        print('[demo] T_right_left: translation [%.4f %.4f %.4f] m, sigma trans [%s] cm' % (
            sp.x, sp.y, sp.z, ' '.join('%.2f' % (100 * s) for s in stereo.sigma_trans_m)))
    time.sleep(0.5)  # wall time: a looping bag moves sim time backwards
    if 'T' in ref:
        qg, tg = ref['T']
        phi = rotvec(qmul(q, qconj(qg)))
        tau = tuple(a - b for a, b in zip(t, tg))
        print('[demo] error against %s on /tf_static: rotation [%s] deg (norm %.4f), translation '
              '[%s] cm (norm %.2f)' % (
                  ref_frame, ' '.join('%.4f' % math.degrees(c) for c in phi),
                  math.degrees(math.sqrt(sum(c * c for c in phi))),
                  ' '.join('%.2f' % (100 * c) for c in tau), 100 * math.sqrt(sum(c * c for c in tau))))
    return 0


if __name__ == '__main__':
    sys.exit(main())
