#!/usr/bin/env python3
"""compare_runs.py REF NEW: compares two folders of scripts/regression_runs.sh.

Every number of the tescalib_eval JSON must agree to a relative 1e-7 (the stereo and joint runs
differ between two runs of the same binary in the 9th-10th significant digit: threaded sums), and
everything else must be identical; times ("seconds") are left out. tescalib_calibrate's printout
is compared with its times and the drives' folder masked. Exit status 1 on any difference."""
import difflib
import glob
import json
import math
import os
import re
import sys

ref, new = sys.argv[1], sys.argv[2]
problems = []


def compare(a, b, path):
    if isinstance(a, dict) and isinstance(b, dict):
        a = {k: v for k, v in a.items() if k != "seconds"}
        b = {k: v for k, v in b.items() if k != "seconds"}
        if set(a) != set(b):
            problems.append(f"{path}: keys differ: {sorted(set(a) ^ set(b))}")
            return
        for k in a:
            compare(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            problems.append(f"{path}: {len(a)} vs {len(b)} entries")
            return
        for i, (x, y) in enumerate(zip(a, b)):
            compare(x, y, f"{path}[{i}]")
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)) and \
            not isinstance(a, bool) and not isinstance(b, bool):
        same = a == b or (math.isnan(a) and math.isnan(b)) or \
            abs(a - b) <= max(1e-15, 1e-7 * max(abs(a), abs(b)))
        if not same:
            problems.append(f"{path}: {a} vs {b}")
    elif a != b:
        problems.append(f"{path}: {a!r} vs {b!r}")


for f in sorted(glob.glob(os.path.join(ref, "*.json"))):
    g = os.path.join(new, os.path.basename(f))
    if not os.path.exists(g):
        problems.append(f"{g} is missing")
        continue
    compare(json.load(open(f)), json.load(open(g)), os.path.basename(f))


def calibrate_lines(folder):
    """tescalib_calibrate's lines with times and the drives' folder masked."""
    lines = open(os.path.join(folder, "calibrate_co.txt"))
    return [re.sub(r"\S*/(urban_s\d)\b", r"\1", re.sub(r"\d+\.\d+ s\b|\d+ ms\b", "T", line))
            for line in lines]


masked, other = calibrate_lines(ref), calibrate_lines(new)
if masked != other:
    problems.append("calibrate_co.txt differs:\n" +
                    "".join(list(difflib.unified_diff(masked, other, "ref", "new"))[:40]))
for p in problems:
    print(p)
print("[compare] identical" if not problems else f"[compare] {len(problems)} differences")
sys.exit(1 if problems else 0)
