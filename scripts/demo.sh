#!/usr/bin/env bash
# make demo: runs the main job on a built-in default and prints what it measured.
# Until the scene generator and the online pipeline land, the main job is the offline LiDAR-stereo
# calibration of the real KITTI 2011_09_30 window (sequences 04-07, 8 keyframes) from three
# perturbed initial guesses (3 deg / 0.3 m), compared with KITTI's own calibration.
set -o pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
source "$ROOT/build/devel/setup.bash"
K=$ROOT/../shared/data/kitti_odometry_mini/sequences
if [ ! -d "$K" ]; then
  echo "[demo] no KITTI frames at $K (../shared/data/kitti_odometry_mini); nothing to run"; exit 1
fi
rosrun tescalib tescalib_check_data "$K/07" || exit 1
rosrun tescalib tescalib_eval --sequences "$K/04,$K/05,$K/06,$K/07" --mode lidar_stereo \
  --trials 3 --init-rot-deg 3 --init-trans-m 0.3 --seed 1 --window 20 --json "$ROOT/build/demo.json"
