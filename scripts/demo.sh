#!/usr/bin/env bash
# make demo: the online pipeline, headless, on a built-in default, printing what it measured.
# Until the scene generator lands, the default drive is the real KITTI 2011_09_30 keyframes
# (sequences 04-07 of ../shared/data/kitti_odometry_mini, converted with kitti_to_bag), replayed at
# 1x and looped, with the initial LiDAR extrinsic deliberately 2 deg / 0.2 m off KITTI's. The
# calibration nodelet runs LiDAR-stereo only (co-calibration is not yet stable on these frames, see
# README "Known limits"). Then the offline evaluation of the same frames. RVIZ=1 opens rviz.
set -o pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
source "$ROOT/build/devel/setup.bash"
export ROS_HOME=${ROS_HOME:-$ROOT/build/ros_home}
K=$ROOT/../shared/data/kitti_odometry_mini/sequences
OUT=$ROOT/build/demo
mkdir -p "$OUT"
if [ ! -d "$K" ]; then
  echo "[demo] no KITTI frames at $K (../shared/data/kitti_odometry_mini); nothing to run"; exit 1
fi
BAG=$OUT/kitti_0930.bag
[ -f "$BAG" ] || rosrun tescalib kitti_to_bag --in "$K/04,$K/05,$K/06,$K/07" --out "$BAG" | tail -1
RVIZ_ARG=false; [ "${RVIZ:-0}" = "1" ] && RVIZ_ARG=true
echo "[demo] roslaunch tescalib kitti.launch bag:=$BAG loop:=true perturb_rot_deg:=2 perturb_trans_m:=0.2 estimate_stereo:=false"
roslaunch tescalib kitti.launch bag:="$BAG" loop:=true perturb_rot_deg:=2 perturb_trans_m:=0.2 \
  estimate_stereo:=false rviz:=$RVIZ_ARG > "$OUT/roslaunch.log" 2>&1 &
LAUNCH=$!
trap 'kill $LAUNCH 2>/dev/null; wait $LAUNCH 2>/dev/null' EXIT
/usr/bin/python3 "$ROOT/scripts/demo_report.py" 120 20
rc=$?
echo "[demo] node log: $OUT/roslaunch.log"
grep -E "tescalib: (new estimate|not converged|rig)" "$OUT/roslaunch.log" | sed 's/\x1b\[[0-9;]*m//g' | head -8
if [ "${RVIZ:-0}" = "1" ]; then echo "[demo] rviz is open; Ctrl-C to stop"; wait $LAUNCH; fi
kill $LAUNCH 2>/dev/null; wait $LAUNCH 2>/dev/null
trap - EXIT
echo
echo "[demo] offline evaluation of the same window (tescalib_eval, 3 trials from 3 deg / 0.3 m):"
rosrun tescalib tescalib_eval --sequences "$K/04,$K/05,$K/06,$K/07" --mode lidar_stereo \
  --trials 3 --init-rot-deg 3 --init-trans-m 0.3 --seed 1 --window 20 | sed -n '/^summary/,$p'
exit $rc
