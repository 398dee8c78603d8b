#!/usr/bin/env python3
"""Pools tescalib_eval JSON files of several rigs (make bench's random-rig rows) into one table row:
converged and successful trials, per-axis median and worst |error|, mean NEES (6 DoF) of the
converged trials. Usage: rig_summary.py NAME FILE.json [FILE.json ...]"""
import json
import statistics
import sys


def nees(trial):
    """e^T C^-1 e of the LiDAR extrinsic (rotation in rad, translation in m), or None."""
    lidar = trial["lidar"]
    cov = lidar.get("covariance")
    if not cov or len(cov) != 36:
        return None
    err = [x * 3.141592653589793 / 180 for x in lidar["rot_err_deg"]] + list(lidar["trans_err_m"])
    a = [cov[6 * r:6 * r + 6] + [err[r]] for r in range(6)]
    for c in range(6):  # Gauss-Jordan elimination on [C | e]
        p = max(range(c, 6), key=lambda r: abs(a[r][c]))
        if abs(a[p][c]) < 1e-30:
            return None
        a[c], a[p] = a[p], a[c]
        for r in range(6):
            if r != c:
                f = a[r][c] / a[c][c]
                a[r] = [x - f * y for x, y in zip(a[r], a[c])]
    return sum(err[r] * a[r][6] / a[r][r] for r in range(6))


def main():
    name, files = sys.argv[1], sys.argv[2:]
    trials = [t for f in files for t in json.load(open(f))["trials"]]
    conv = [t for t in trials if t["converged"]]
    succ = sum(1 for t in trials if t["success"])
    rot = [[abs(t["lidar"]["rot_err_deg"][i]) for t in conv] for i in range(3)]
    tra = [[abs(t["lidar"]["trans_err_m"][i]) * 1000 for t in conv] for i in range(3)]
    values = [v for v in (nees(t) for t in conv) if v is not None]
    med = lambda xs: statistics.median(xs) if xs else float("nan")
    print(f"{name}: {len(files)} rigs, {len(trials)} trials, converged {len(conv)}, "
          f"success {succ} ({100.0 * succ / max(len(trials), 1):.0f} %)")
    print("  median |err| rot x y z deg: " + " ".join(f"{med(r):.3f}" for r in rot) +
          "; trans x y z mm: " + " ".join(f"{med(t):.1f}" for t in tra))
    print("  worst  |err| rot x y z deg: " + " ".join(f"{max(r, default=float('nan')):.3f}" for r in rot) +
          "; trans x y z mm: " + " ".join(f"{max(t, default=float('nan')):.1f}" for t in tra))
    if values:
        print(f"  mean NEES of the converged trials (6 DoF, ideal 6): {statistics.mean(values):.2f}")


if __name__ == "__main__":
    main()
