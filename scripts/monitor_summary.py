#!/usr/bin/env python3
"""Sums up one row of scripts/bench_monitor.sh: the score.json (tescalib_eval --score-estimates)
of every run in ROW_DIR/SEED/: a summary line with the figures doc/limitations.md's monitoring
paragraph shows, and one line per run. Usage: monitor_summary.py ROW_DIR"""
import json
import math
import os
import statistics
import sys

DETECT_S, RECOVER_S = 10.0, 30.0  # the targets: changed within 10 s, right again within 30 s


def runs(row_dir):
    for seed in sorted(os.listdir(row_dir)):
        path = os.path.join(row_dir, seed, 'score.json')
        if os.path.isfile(path):
            with open(path) as f:
                yield seed, json.load(f)['extrinsics'], memory(os.path.join(row_dir, seed))


def memory(run_dir):
    """The calibrator's resident memory (MB) 30 s into the run (its window full) and at its last
    sample within the keyframe loop (calibrate.log's closing "... N s"; after it the tool scores
    the estimate's quality, which the node does not do this way), or None."""
    try:
        with open(os.path.join(run_dir, 'memory.txt')) as f:
            rss = [(int(t), int(kb) / 1024) for t, kb in (line.split() for line in f
                                                          if len(line.split()) == 2)]
    except OSError:
        return None
    if not rss:
        return None
    start = next((mb for t, mb in rss if t >= 30), rss[-1][1])
    in_loop = [mb for t, mb in rss if t <= loop_seconds(run_dir)]
    return start, (in_loop or [rss[-1][1]])[-1]


def loop_seconds(run_dir):
    """How long tescalib_calibrate's keyframe loop ran (its summary line), or infinity."""
    try:
        with open(os.path.join(run_dir, 'calibrate.log')) as f:
            for line in f:
                words = line.split()
                if 'keyframes,' in words and 'solves,' in words and words[-1] == 's':
                    return float(words[-2])
    except (OSError, ValueError):
        pass
    return math.inf


def value(x):
    return math.nan if x is None else x


def stepped(extrinsics):
    """The extrinsic that steps (or the LiDAR's without a step) and its score."""
    for name, s in extrinsics.items():
        if s['step_at_s'] is not None:
            return name, s
    return 'lidar_to_left', extrinsics['lidar_to_left']


def fmt(x, spec='.1f'):
    return '-' if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def main(row_dir):
    rows = list(runs(row_dir))
    if not rows:
        print('no scored runs in', row_dir)
        return 1
    print(f'{"seed":>6} {"extrinsic":>13} {"suspect":>8} {"changed":>8} {"1st pub":>8} '
          f'{"its deg":>8} {"its cm":>7} {"right":>6} {"worse":>5} {"false":>5} {"susp%":>6} '
          f'{"last deg":>8} {"last cm":>7} {"MB start/end":>13}')
    for seed, ex, mem in rows:
        name, s = stepped(ex)
        false = sum(e['false_changes'] for e in ex.values())
        print(f'{seed:>6} {name:>13} {fmt(s["suspect_delay_s"]):>8} {fmt(s["changed_delay_s"]):>8} '
              f'{fmt(s["first_published_delay_s"]):>8} {fmt(s["first_published_rot_deg"], ".3f"):>8} '
              f'{fmt(value(s["first_published_trans_m"]) * 100, ".2f"):>7} '
              f'{fmt(s["recovered_delay_s"]):>6} {s["worse_replacements"]:>5} {false:>5} '
              f'{100 * s["suspect_share"]:>6.1f} {fmt(s["last_rot_deg"], ".3f"):>8} '
              f'{fmt(value(s["last_trans_m"]) * 100, ".2f"):>7} '
              f'{(fmt(mem[0], ".0f") + "/" + fmt(mem[1], ".0f")) if mem else "-":>13}')
    summary(rows)
    return 0


def summary(rows):
    scores = [stepped(ex)[1] for _, ex, _ in rows]
    n = len(rows)
    false = sum(e['false_changes'] for _, ex, _ in rows for e in ex.values())
    suspect = 100 * statistics.mean(s['suspect_share'] for s in scores)
    if scores[0]['step_at_s'] is None:
        print(f'summary: {n} runs without a step: {false} false changed, suspect in '
              f'{suspect:.1f} % of the solves')
        return
    changed = [value(s['changed_delay_s']) for s in scores]
    recovered = [value(s['recovered_delay_s']) for s in scores]
    detected = sum(d <= DETECT_S for d in changed)
    right = [d for d in recovered if d <= RECOVER_S]
    worse = sum(s['worse_replacements'] > 0 for s in scores)
    finite = [d for d in changed if not math.isnan(d)]
    print(f'summary: {n} runs: changed within {DETECT_S:.0f} s in {detected}/{n} '
          f'({100 * detected / n:.0f} %; delay median {fmt(statistics.median(finite)) if finite else "-"}'
          f' s, largest {fmt(max(finite)) if finite else "-"} s); within 0.05 deg / 1 cm within '
          f'{RECOVER_S:.0f} s in {len(right)}/{n} (median {fmt(statistics.median(right)) if right else "-"} s); '
          f'runs with a published estimate worse than the one it replaced: {worse}; false changed: '
          f'{false}; suspect in {suspect:.1f} % of the solves')


if __name__ == '__main__':
    sys.exit(main(sys.argv[1]))
