"""Plain-Python helpers (no numpy) shared by scripts/demo_report.py and the end-to-end rostest:
rigid transforms as (quaternion wxyz, translation), errors in tescalib's perturbation model
(R = Exp(phi) R_ref, t = t_ref + tau), reading the generator's ground truth, and a positive
definiteness check."""
import math


def qmul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


def qconj(q):
    return (q[0], -q[1], -q[2], -q[3])


def rotate(q, v):
    _, x, y, z = qmul(qmul(q, (0.0,) + tuple(v)), qconj(q))
    return (x, y, z)


def invert(q, t):
    qi = qconj(q)
    ti = rotate(qi, t)
    return qi, (-ti[0], -ti[1], -ti[2])


def rotvec(q):
    """Rotation vector (rad) of a unit quaternion (w, x, y, z)."""
    w = max(-1.0, min(1.0, q[0]))
    if w < 0:
        q = tuple(-c for c in q)
        w = -w
    s = math.sqrt(max(0.0, 1 - w * w))
    if s < 1e-12:
        return (0.0, 0.0, 0.0)
    angle = 2 * math.atan2(s, w)
    return tuple(angle * c / s for c in q[1:])


def roll_pitch_yaw(q):
    """Roll, pitch, yaw (rad) of a unit quaternion (w, x, y, z): R = Rz(yaw) Ry(pitch) Rx(roll),
    about the parent's fixed x, y, z axes, as ROS tf (getRPY) and URDF's rpy."""
    w, x, y, z = q
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def quat_from_matrix(R):
    """Unit quaternion (w, x, y, z) of a 3x3 rotation given as nested lists."""
    tr = R[0][0] + R[1][1] + R[2][2]
    if tr > 0:
        s = 2 * math.sqrt(tr + 1)
        q = (0.25 * s, (R[2][1] - R[1][2]) / s, (R[0][2] - R[2][0]) / s, (R[1][0] - R[0][1]) / s)
    elif R[0][0] > R[1][1] and R[0][0] > R[2][2]:
        s = 2 * math.sqrt(1 + R[0][0] - R[1][1] - R[2][2])
        q = ((R[2][1] - R[1][2]) / s, 0.25 * s, (R[0][1] + R[1][0]) / s, (R[0][2] + R[2][0]) / s)
    elif R[1][1] > R[2][2]:
        s = 2 * math.sqrt(1 + R[1][1] - R[0][0] - R[2][2])
        q = ((R[0][2] - R[2][0]) / s, (R[0][1] + R[1][0]) / s, 0.25 * s, (R[1][2] + R[2][1]) / s)
    else:
        s = 2 * math.sqrt(1 + R[2][2] - R[0][0] - R[1][1])
        q = ((R[1][0] - R[0][1]) / s, (R[0][2] + R[2][0]) / s, (R[1][2] + R[2][1]) / s, 0.25 * s)
    n = math.sqrt(sum(c * c for c in q))
    return tuple(c / n for c in q)


def from_3x4(values):
    """(q, t) of a 3x4 row-major matrix given as 12 numbers."""
    R = [values[0:3], values[4:7], values[8:11]]
    return quat_from_matrix(R), (values[3], values[7], values[11])


def from_msg(transform):
    """(q, t) of a geometry_msgs/Transform."""
    r, p = transform.rotation, transform.translation
    return (r.w, r.x, r.y, r.z), (p.x, p.y, p.z)


def read_sim_info(path):
    """Ground truth of a tescalib_simulate drive: {'T_cam_lidar': (q, t), 'T_right_left': (q, t)}
    from its sim_info.txt (3x4 row-major lists); with --extrinsic-step also the truth after it
    ('T_cam_lidar_after_step', 'T_right_left_after_step') and 'extrinsic_step_at_s'."""
    out = {}
    with open(path) as f:
        for line in f:
            key, _, value = line.partition(':')
            if key in ('T_cam_lidar', 'T_right_left', 'T_cam_lidar_after_step',
                       'T_right_left_after_step'):
                out[key] = from_3x4([float(v) for v in value.strip().strip('[]').split(',')])
            elif key == 'extrinsic_step_at_s':
                out[key] = float(value)
    if 'T_cam_lidar' not in out or 'T_right_left' not in out:
        raise ValueError('%s: T_cam_lidar or T_right_left missing' % path)
    return out


def error(est, ref):
    """(phi, tau): rotation (rad) and translation (m) error vectors of est against ref, in the
    model R_est = Exp(phi) R_ref, t_est = t_ref + tau."""
    (q, t), (qr, tr) = est, ref
    return rotvec(qmul(q, qconj(qr))), tuple(a - b for a, b in zip(t, tr))


def norm(v):
    return math.sqrt(sum(c * c for c in v))


def cholesky(m, n=6, rel_tol=1e-9):
    """Lower-triangular L with L L^T = m for the row-major n x n matrix m, or None when m is not
    symmetric (to rel_tol of its largest entry) or a pivot is not positive."""
    scale = max(abs(v) for v in m) or 1.0
    a = [[m[i * n + j] for j in range(n)] for i in range(n)]
    for i in range(n):
        for j in range(i):
            if abs(a[i][j] - a[j][i]) > rel_tol * scale:
                return None
    L = [[0.0] * n for _ in range(n)]
    for i in range(n):
        for j in range(i + 1):
            s = a[i][j] - sum(L[i][k] * L[j][k] for k in range(j))
            if i == j:
                if s <= 0:
                    return None
                L[i][i] = math.sqrt(s)
            else:
                L[i][j] = s / L[j][j]
    return L


def is_symmetric_positive_definite(m, n=6, rel_tol=1e-9):
    """True when the row-major n x n matrix m is symmetric (to rel_tol of its largest entry)
    and its Cholesky factorisation succeeds with positive pivots."""
    return cholesky(m, n, rel_tol) is not None


def nees(phi, tau, cov, n=6):
    """e^T P^-1 e for e = [phi; tau] and the row-major 6x6 covariance P over the same [phi; tau]
    (the normalised estimation error squared: mean 6 when P tells the truth); None when P is not
    positive definite."""
    L = cholesky(cov, n)
    if L is None:
        return None
    e = list(phi) + list(tau)
    y = [0.0] * n  # L y = e; e^T P^-1 e = |y|^2
    for i in range(n):
        y[i] = (e[i] - sum(L[i][k] * y[k] for k in range(i))) / L[i][i]
    return sum(v * v for v in y)
