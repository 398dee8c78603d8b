#!/usr/bin/env bash
# make demo: the online pipeline, headless, on a generated drive with exact ground truth.
#  1. tescalib_simulate writes a short urban drive (cached in build/demo, keyed by its arguments),
#     kitti_to_bag turns it into a kitti2bag-style bag.
#  2. roslaunch tescalib demo.launch (kitti.launch with the demo's defaults) plays it at 1x with
#     the initial LiDAR extrinsic deliberately 2 deg / 0.2 m off; scripts/demo_report.py prints
#     the estimates, sigma, observability, the error against the generator's ground truth and the
#     node's timings.
#  3. Only when ../shared/data/kitti_odometry_mini exists: the same on real KITTI frames
#     (2011_09_30, sequences 04-07), played once, errors against KITTI's calibration.
# LiDAR-stereo only by default: online co-calibration (DEMO_STEREO=1, estimate_stereo:=true) gives
# its first estimate only after about 7 s here, and its updates take about 1 s.
# RVIZ=1 opens rviz on part 2 and keeps it open.
# Settings: DEMO_FRAMES (100), DEMO_SEED (1), DEMO_SCENARIO (urban), DEMO_NOISE (default),
# DEMO_STEREO (0: LiDAR-stereo only; 1: co-calibration, both extrinsics; joint: co-calibration by
# the one-problem joint solve, joint:=true),
# DEMO_KITTI (1: run part 3 when the data exists; 0: skip it), DEMO_ROT_DEG / DEMO_TRANS_M (2 / 0.2:
# how far the initial LiDAR extrinsic is deliberately perturbed),
# DEMO_SWEEP (0; 1: raw swept scans, tescalib_simulate --lidar-sweep 1, de-skewed online unless
# DEMO_DESKEW=0).
set -o pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
# shellcheck source=scripts/ros_env.sh
source "$ROOT/scripts/ros_env.sh"
FRAMES=${DEMO_FRAMES:-100}
SEED=${DEMO_SEED:-1}
SCENARIO=${DEMO_SCENARIO:-urban}
NOISE=${DEMO_NOISE:-default}
ROT=${DEMO_ROT_DEG:-2}
TRANS=${DEMO_TRANS_M:-0.2}
OUT=$ROOT/build/demo
mkdir -p "$OUT"
RVIZ_ARG=false
[ "${RVIZ:-0}" = "1" ] && RVIZ_ARG=true
LAUNCH=

wait_master() {  # the report must not start before roslaunch's master is up
  for _ in $(seq 50); do rostopic list >/dev/null 2>&1 && return; sleep 0.2; done
}
stop_launch() {
  [ -n "$LAUNCH" ] && kill "$LAUNCH" 2>/dev/null && wait "$LAUNCH" 2>/dev/null
  LAUNCH=
}
trap stop_launch EXIT

# --- 1. the drive ------------------------------------------------------------------------------
SWEEP_ARGS=()
DESKEW=false
KEY=${SCENARIO}_f${FRAMES}_s${SEED}_${NOISE}
if [ "${DEMO_SWEEP:-0}" = "1" ]; then
  SWEEP_ARGS=(--lidar-sweep 1)
  KEY=${KEY}_sweep
  [ "${DEMO_DESKEW:-1}" = "1" ] && DESKEW=true
fi
DRIVE=$OUT/$KEY
BAG=$OUT/$KEY.bag
if [ -f "$BAG" ] && [ -f "$DRIVE/sim_info.txt" ]; then
  echo "[demo] cached drive $DRIVE ($BAG)"
else
  rm -rf "$DRIVE" "$BAG"
  start=$SECONDS
  echo "[demo] rosrun tescalib tescalib_simulate --scenario $SCENARIO --frames $FRAMES --seed $SEED --noise $NOISE ${SWEEP_ARGS[*]} --out $DRIVE"
  rosrun tescalib tescalib_simulate --scenario "$SCENARIO" --frames "$FRAMES" --seed "$SEED" \
    --noise "$NOISE" "${SWEEP_ARGS[@]}" --out "$DRIVE" | grep wrote || exit 1
  echo "[demo] rosrun tescalib kitti_to_bag --in $DRIVE --out $BAG"
  rosrun tescalib kitti_to_bag --in "$DRIVE" --out "$BAG.tmp" | tail -1 && mv "$BAG.tmp" "$BAG" || exit 1
  # The bag holds everything the demo plays; keep only the calibration and the ground truth.
  rm -rf "$DRIVE/image_2" "$DRIVE/image_3" "$DRIVE/velodyne"
  echo "[demo] generated and converted in $((SECONDS - start)) s (cached for the next run)"
fi

# --- 2. online, headless, 1x ---------------------------------------------------------------------
echo
STEREO=false
JOINT=false
[ "${DEMO_STEREO:-0}" = "1" ] && STEREO=true
[ "${DEMO_STEREO:-0}" = "joint" ] && STEREO=true && JOINT=true
echo "[demo] roslaunch tescalib demo.launch bag:=$BAG perturb_rot_deg:=$ROT perturb_trans_m:=$TRANS estimate_stereo:=$STEREO joint:=$JOINT deskew:=$DESKEW rviz:=$RVIZ_ARG"
if [ "$STEREO" = false ]; then
  echo "[demo] LiDAR-stereo only (the default; DEMO_STEREO=1 for co-calibration), so T_right_left"
  echo "       stays at the camera_info baseline"
fi
roslaunch tescalib demo.launch bag:="$BAG" perturb_rot_deg:=$ROT perturb_trans_m:=$TRANS \
  estimate_stereo:=$STEREO joint:=$JOINT deskew:=$DESKEW rviz:=$RVIZ_ARG > "$OUT/roslaunch_sim.log" 2>&1 &
LAUNCH=$!
wait_master
/usr/bin/python3 "$ROOT/scripts/demo_report.py" --ground-truth "$DRIVE/sim_info.txt" \
  --frames "$FRAMES" --timeout 150
rc=$?
echo "[demo] node log: $OUT/roslaunch_sim.log"
if [ "${RVIZ:-0}" = "1" ]; then
  echo "[demo] rviz is open (the bag has ended; the overlay shows its last frame); Ctrl-C to stop"
  wait "$LAUNCH"
fi
stop_launch

# --- 3. optional: real KITTI frames --------------------------------------------------------------
K=$ROOT/../shared/data/kitti_odometry_mini/sequences
if [ "${DEMO_KITTI:-1}" = "1" ] && [ -d "$K/04" ] && [ "${RVIZ:-0}" != "1" ]; then
  echo
  KBAG=$OUT/kitti_0930.bag
  [ -f "$KBAG" ] || rosrun tescalib kitti_to_bag --in "$K/04,$K/05,$K/06,$K/07" --out "$KBAG" | tail -1
  # Played once: a looped bag replays the same frames, and its loop would clear the window while
  # the solve from all 8 keyframes runs (that solve's result is then discarded).
  echo "[demo] real KITTI 2011_09_30 (sequences 04-07, 16 frames, 8 keyframes), played once at 1x,"
  echo "       LiDAR-stereo only, same 2 deg / 0.2 m start; reference: KITTI's calibration"
  roslaunch tescalib kitti.launch bag:="$KBAG" perturb_rot_deg:=$ROT \
    perturb_trans_m:=$TRANS estimate_stereo:=false > "$OUT/roslaunch_kitti.log" 2>&1 &
  LAUNCH=$!
  wait_master
  /usr/bin/python3 "$ROOT/scripts/demo_report.py" --ref-tf-frame camera_color_left \
    --timeout 90 || true
  echo "[demo] node log: $OUT/roslaunch_kitti.log"
  stop_launch
fi
exit $rc
