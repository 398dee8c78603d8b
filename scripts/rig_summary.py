#!/usr/bin/env python3
"""Pools tescalib_eval JSON files of several rigs (make bench's random-rig rows) into one table row:
converged and successful trials, per-axis median and worst |error| and mean NEES (6 DoF) of the
converged trials, of the LiDAR extrinsic and, where the pair is estimated (co, joint), the pair's;
of the trials not declared converged, the weakest direction they flag and their NEES.
Usage: rig_summary.py NAME FILE.json [FILE.json ...]"""
import json
import statistics
import sys


def nees(trial, extrinsic="lidar"):
    """e^T C^-1 e of one extrinsic ("lidar" or "stereo"; rotation in rad, translation in m), or
    None."""
    est = trial[extrinsic]
    cov = est.get("covariance")
    if not cov or len(cov) != 36 or any(c is None for c in cov):
        return None
    err = [x * 3.141592653589793 / 180 for x in est["rot_err_deg"]] + list(est["trans_err_m"])
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


def print_extrinsic(label, conv, extrinsic, digits):
    """Median and worst |error| per axis and mean NEES of one extrinsic over the converged
    trials."""
    rot = [[abs(t[extrinsic]["rot_err_deg"][i]) for t in conv] for i in range(3)]
    tra = [[abs(t[extrinsic]["trans_err_m"][i]) * 1000 for t in conv] for i in range(3)]
    med = lambda xs: statistics.median(xs) if xs else float("nan")
    worst = lambda xs: max(xs, default=float("nan"))
    r, m = f"{{:.{digits}f}}", f"{{:.{digits - 2}f}}"
    print(f"  {label} median |err| rot x y z deg: " + " ".join(r.format(med(x)) for x in rot) +
          "; trans x y z mm: " + " ".join(m.format(med(x)) for x in tra))
    print(f"  {label} worst  |err| rot x y z deg: " + " ".join(r.format(worst(x)) for x in rot) +
          "; trans x y z mm: " + " ".join(m.format(worst(x)) for x in tra))
    values = [v for v in (nees(t, extrinsic) for t in conv) if v is not None]
    if values:
        print(f"  {label} mean NEES of the converged trials (6 DoF, ideal 6): "
              f"{statistics.mean(values):.2f} ({len(values)} trials)")


def print_flags(trials):
    """The trials not declared converged: how many are within the targets anyway, their weakest
    direction (what the estimate flags) and the mean NEES of those with a covariance."""
    flagged = [t for t in trials if not t["converged"]]
    if not flagged:
        return
    ok = sum(1 for t in flagged if t["success"])
    words = {}
    for t in flagged:
        w = t.get("lidar_weakest_direction") or {}
        top = (w.get("in_words") or "?").split(" + ")[0].split(" - ")[0]
        words.setdefault(top.split()[-1], []).append(w.get("ratio", float("nan")))
    print(f"  not converged: {len(flagged)} ({ok} of them within the targets anyway); weakest "
          "direction's main axis (count, trust-limit ratios): " +
          ", ".join(f"{k} {len(v)} ({min(v):.1f}-{max(v):.1f}x)" for k, v in sorted(words.items())))
    values = [v for v in (nees(t) for t in flagged) if v is not None]
    if values:
        print(f"  not converged: mean NEES {statistics.mean(values):.2f} ({len(values)} trials)")


def main():
    name, files = sys.argv[1], sys.argv[2:]
    trials = [t for f in files for t in json.load(open(f))["trials"]]
    conv = [t for t in trials if t["converged"]]
    succ = sum(1 for t in trials if t["success"])
    print(f"{name}: {len(files)} rigs, {len(trials)} trials, converged {len(conv)}, "
          f"success {succ} ({100.0 * succ / max(len(trials), 1):.0f} %)")
    print_extrinsic("LiDAR", conv, "lidar", 3)
    print_flags(trials)
    if any(t["stereo"].get("estimated") for t in trials):
        print_extrinsic("pair", conv, "stereo", 4)


if __name__ == "__main__":
    main()
