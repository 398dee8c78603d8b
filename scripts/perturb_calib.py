#!/usr/bin/env python3
"""A KITTI calib.txt whose LiDAR extrinsic Tr is moved by exactly ROT_DEG about a random axis
(R = Exp(phi) R, in the camera frame) and TRANS_M along a random direction, both drawn from SEED:
a known wrong calibration to check tescalib_validate with (make bench BENCH=validate).
Usage: perturb_calib.py IN OUT SEED ROT_DEG TRANS_M"""
import math, random, sys
src, dst, seed, rot_deg, trans = sys.argv[1], sys.argv[2], int(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5])
rng = random.Random(seed)
def unit():
    v = [rng.gauss(0, 1) for _ in range(3)]; n = math.sqrt(sum(x * x for x in v)); return [x / n for x in v]
a, d = unit(), unit()
th = math.radians(rot_deg)
K = [[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]]
I = [[1 if i == j else 0 for j in range(3)] for i in range(3)]
KK = [[sum(K[i][k] * K[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
R = [[I[i][j] + math.sin(th) * K[i][j] + (1 - math.cos(th)) * KK[i][j] for j in range(3)] for i in range(3)]
out = []
for line in open(src):
    if line.startswith('Tr:'):
        v = [float(x) for x in line.split()[1:]]
        M = [v[0:4], v[4:8], v[8:12]]
        Rn = [[sum(R[i][k] * M[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
        t = [M[i][3] + trans * d[i] for i in range(3)]
        line = 'Tr: ' + ' '.join('%.12g' % x for i in range(3) for x in Rn[i] + [t[i]]) + '\n'
    out.append(line)
open(dst, 'w').write(''.join(out))
