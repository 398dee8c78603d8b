#!/usr/bin/env bash
# make demo: runs the main job on a built-in default and prints what it measured.
# Until the calibration pipeline lands, the main job is the data check on the real KITTI frames
# (reader, ring recovery, LiDAR-predicted disparity against the images) and a bag conversion.
set -o pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
source "$ROOT/build/devel/setup.bash"
KITTI=$ROOT/../shared/data/kitti_odometry_mini/sequences
OUT=$ROOT/build/demo
mkdir -p "$OUT"
if [ ! -d "$KITTI" ]; then
  echo "[demo] no KITTI frames at $KITTI"; exit 1
fi
rosrun tescalib tescalib_check_data "$KITTI"/00 "$KITTI"/07 || exit 1
rosrun tescalib kitti_to_bag --in "$KITTI/00" --out "$OUT/kitti_00.bag" || exit 1
rosbag info "$OUT/kitti_00.bag" | sed -n '1,40p'
