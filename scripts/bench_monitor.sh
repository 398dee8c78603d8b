#!/usr/bin/env bash
# The calibration monitor's benchmark (BENCH=monitor in make bench; doc/online.md, Monitoring):
# generated drives with and without a change of the rig, calibrated by tescalib_calibrate as the
# node does (monitor defaults) and scored by tescalib_eval --score-estimates against the truth of
# each estimate's moment. A drive is one frame per keyframe (tescalib_simulate --every 5); its
# images and scans are deleted once calibrated (the truth and the estimates stay).
#   RUNS   runs per step row (default 20); HIGHWAY_RUNS runs of the highway rows (default 5);
#          SEED0 the first seed (default 7000)
#   ROWS   which rows (default all): a space-separated subset of
#          urban_lidar residential_lidar urban_stereo_co urban_small_long urban_none_long highway_none
#          urban_then_highway (30 s of town, then 120 s of highway: the weak directions of a rig the
#          monitor watches), and urban_lidar_co (a LiDAR bump under co-calibration: the pair, checked
#          through the LiDAR's depth, must not be declared changed; not in the default rows)
#   LONG_S the length of the long drives in seconds (default 600)
set -o pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
source "$ROOT/build/devel/setup.bash"
OUT=${MONITOR_OUT:-$ROOT/build/bench/monitor}
RUNS=${RUNS:-20}
HIGHWAY_RUNS=${HIGHWAY_RUNS:-5}
SEED0=${SEED0:-7000}
LONG_S=${LONG_S:-600}
ROWS=${ROWS:-urban_lidar residential_lidar urban_stereo_co urban_small_long urban_none_long highway_none urban_then_highway}
mkdir -p "$OUT"

# One run: name scenario seconds seed mode step ("" for none). Leaves estimates.json,
# calibrate.log, score.json, memory.txt (the calibrator's resident memory in kB, sampled every
# 10 s) and the drive's calib*.txt / sim_info.txt / times.txt in $OUT/name/seed; what is there
# already is not run again.
run_one() {
  local name=$1 scenario=$2 seconds=$3 seed=$4 mode=$5 step=$6
  local dir="$OUT/$name/$seed"
  mkdir -p "$dir"
  [ -f "$dir/estimates.json" ] || calibrate_one "$@" || return 1
  [ -f "$dir/score.json" ] || rosrun tescalib tescalib_eval --sequences "$dir/drive" \
    --score-estimates "$dir/estimates.json" --json "$dir/score.json" > "$dir/score.log" ||
    { echo "[bench] $name $seed: scoring failed" >&2; return 1; }
}

# Generates the drive and calibrates it (the arguments of run_one); the images and scans go.
# scenario "urban+highway": 30 s of urban (drive/), then `seconds` of highway (drive_2/), one rig.
calibrate_one() {
  local name=$1 scenario=$2 seconds=$3 seed=$4 mode=$5 step=$6
  local dir="$OUT/$name/$seed" sequences="$dir/drive"
  if [ "$scenario" = urban+highway ]; then
    simulate "$dir/drive" urban 30 "$seed" "" && simulate "$dir/drive_2" highway "$seconds" \
      "$seed" "" || { echo "[bench] $name $seed: tescalib_simulate failed" >&2; return 1; }
    sequences="$dir/drive,$dir/drive_2"
  else
    simulate "$dir/drive" "$scenario" "$seconds" "$seed" "$step" ||
      { echo "[bench] $name $seed: tescalib_simulate failed" >&2; return 1; }
  fi
  rosrun tescalib tescalib_calibrate --sequences "$sequences" --mode "$mode" \
    --json "$dir/estimates.json" > "$dir/calibrate.log" 2>&1 &
  local pid=$! start=$SECONDS  # rosrun execs the tool: $pid is the calibrator
  : > "$dir/memory.txt"
  while kill -0 "$pid" 2> /dev/null; do
    awk -v t=$((SECONDS - start)) '/VmRSS/ {print t, $2}' "/proc/$pid/status" \
      >> "$dir/memory.txt" 2> /dev/null
    sleep 10
  done
  # Exit status 1 with the estimates written: nothing converged (a highway drive from the start),
  # an outcome to score like any other.
  wait "$pid"
  local status=$?
  if [ "$status" -ne 0 ] && ! { [ "$status" -eq 1 ] && [ -s "$dir/estimates.json" ]; }; then
    echo "[bench] $name $seed: tescalib_calibrate failed (exit status $status)" >&2
    return 1
  fi
  rm -rf "$dir"/drive*/image_2 "$dir"/drive*/image_3 "$dir"/drive*/velodyne
}

# simulate OUT SCENARIO SECONDS SEED STEP: one frame per keyframe (--every 5).
simulate() {
  rosrun tescalib tescalib_simulate --scenario "$2" --frames $(($3 * 10)) --seed "$4" --every 5 \
    ${5:+--extrinsic-step "$5"} --out "$1" > /dev/null
}

# A row: name scenario seconds first-seed runs mode step.
row() {
  local name=$1 scenario=$2 seconds=$3 first=$4 runs=$5 mode=$6 step=$7
  echo "=== $name: $runs x $scenario, $seconds s, mode $mode, step ${step:-none}"
  for ((i = 0; i < runs; ++i)); do run_one "$name" "$scenario" "$seconds" $((first + i)) \
    "$mode" "$step"; done
  [ -n "$NO_SUMMARY" ] || python3 "$ROOT/scripts/monitor_summary.py" "$OUT/$name"
}

for r in $ROWS; do
  case $r in
    urban_lidar) row "$r" urban 60 $((SEED0 + 1)) "$RUNS" lidar_stereo 30,0.5,0.03,lidar ;;
    residential_lidar) row "$r" residential 60 $((SEED0 + 101)) "$RUNS" lidar_stereo 30,0.5,0.03,lidar ;;
    urban_stereo_co) row "$r" urban 60 $((SEED0 + 201)) "$RUNS" co 30,0.2,0.005,stereo ;;
    urban_lidar_co) row "$r" urban 60 $((SEED0 + 701)) "$RUNS" co 30,0.5,0.03,lidar ;;
    urban_small_long) row "$r" urban "$LONG_S" $((SEED0 + 301)) 1 lidar_stereo 30,0.05,0.005,lidar ;;
    urban_none_long) row "$r" urban "$LONG_S" $((SEED0 + 401)) 1 lidar_stereo "" ;;
    highway_none) row "$r" highway 120 $((SEED0 + 501)) "$HIGHWAY_RUNS" lidar_stereo "" ;;
    urban_then_highway) row "$r" urban+highway 120 $((SEED0 + 601)) "$HIGHWAY_RUNS" lidar_stereo "" ;;
    *) echo "[bench] unknown monitor row $r" >&2; exit 2 ;;
  esac
done
