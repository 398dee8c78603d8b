#!/usr/bin/env python3
"""Pools tescalib_validate JSON files of generated drives (make bench BENCH=validate), where the
recording's calibration is the truth, into two tables per criterion:
- steps: the truth against the --perturbed rows on the axes the criterion claims to see
  (doc/validation.md): how many score worse than the truth, and how many significantly;
- optima: per axis the rms distance of the criterion's optima from the truth, the median stated
  sigma, the share of resolved optima within 2 sigma of the truth, and the truth's mean chi2
  per degree of freedom against the optima's covariances (1 when the uncertainty holds).
Usage: validate_summary.py NAME FILE.json [FILE.json ...]"""
import json
import math
import statistics
import sys

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from extrinsics import error  # noqa: E402

AXES = ["rx", "ry", "rz", "tx", "ty", "tz"]
# The axes each criterion claims to see at 0.1 deg / 1 cm (doc/validation.md, test_validation).
CLAIMED = {"edge_alignment": ["rx", "ry", "ty"],
           "photometric_residual": ["rx", "ry", "tx", "ty"],
           "disparity_residual": ["rx", "ry", "ty"]}


def pose(j):
    x, y, z, w = j["quaternion_xyzw"]
    return (w, x, y, z), tuple(j["translation"])


# The two-sided 95 % quantiles of Student's t for 1..30 degrees of freedom (as the tool's).
T95 = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
       2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
       2.052, 2.048, 2.045, 2.042]


def advantage(truth, moved, higher_better):
    """The truth's mean advantage over a moved calibration, frame by frame, and whether it is
    significantly positive (two-sided 95 %)."""
    d = [(t - m) if higher_better else (m - t) for t, m in zip(truth, moved)]
    mean = statistics.mean(d)
    if len(d) < 2:
        return mean, False
    se = statistics.stdev(d) / math.sqrt(len(d))
    t = T95[len(d) - 2] if len(d) - 1 <= 30 else 1.96
    return mean, mean > t * se


def steps(docs, crit):
    worse = significant = total = 0
    for d in docs:
        truth = d["calibrations"][0]["frame_scores"][crit]
        for c in d["calibrations"][1:]:
            if c["name"][:2] not in CLAIMED[crit] or c["name"][2:3] not in "+-":
                continue
            mean, sig = advantage(truth, c["frame_scores"][crit], d["higher_is_better"][crit])
            total += 1
            worse += mean > 0
            significant += sig
    return worse, significant, total


def optima(docs, crit):
    rows = []
    for d in docs:
        truth = pose(d["calibrations"][0]["T_cam_lidar"])
        for c in d["calibrations"]:
            o = c.get("optimum", {}).get(crit)
            if o:
                phi, tau = error(pose(o["T_cam_lidar"]), truth)
                rows.append((tuple(phi) + tuple(tau), o["uncertainty"]))
    return rows


def main():
    name, docs = sys.argv[1], [json.load(open(f)) for f in sys.argv[2:]]
    print("%s: %d drives" % (name, len(docs)))
    for crit in CLAIMED:
        worse, sig, total = steps(docs, crit)
        rows = optima(docs, crit)
        chi2 = [u["recording_chi2"] / u["rank"] for _, u in rows if u["rank"] > 0]
        print("  %s: truth better than %d of %d steps on %s (%d significantly); %d optima, "
              "truth's chi2/DoF mean %s" % (crit, worse, total, " ".join(CLAIMED[crit]), sig,
                                             len(rows), "%.2f" % statistics.mean(chi2) if chi2 else "-"))
        for k, axis in enumerate(AXES):
            scale, unit = (180 / math.pi, "deg") if k < 3 else (100.0, "cm")
            err = [e[k] * scale for e, _ in rows]
            res = [(e[k] * scale, u["sigma"][k] * scale) for e, u in rows if u["sigma"][k]]
            within = sum(abs(e) < 2 * s for e, s in res)
            print("    %s rms %.3f %s, median sigma %s, resolved %d/%d, within 2 sigma %d/%d" % (
                axis, math.sqrt(statistics.mean([x * x for x in err])) if err else 0, unit,
                "%.3f" % statistics.median(s for _, s in res) if res else "-", len(res), len(rows),
                within, len(res)))


if __name__ == "__main__":
    main()
