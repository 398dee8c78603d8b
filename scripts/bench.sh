#!/usr/bin/env bash
# make bench: the accuracy/speed benchmarks whose tables go into the README. Long; not in make test.
# BENCH=sim|kitti|all (default all) selects the generated-drive or the real-KITTI part; BENCH=core
# runs only the rows of the README's headline table, one per issue target (about 25 minutes).
set -o pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
source "$ROOT/build/devel/setup.bash"
K=$ROOT/../shared/data/kitti_odometry_mini/sequences
OUT=$ROOT/build/bench
mkdir -p "$OUT"
TRIALS=${TRIALS:-20}
SIM_TRIALS=${SIM_TRIALS:-30}
BENCH=${BENCH:-all}
STATUS=0  # the exit status: 1 when a run failed (its name is printed; the others still run)
run() {  # name, args...
  local name=$1; shift
  echo "=== $name"
  rosrun tescalib tescalib_eval "$@" --json "$OUT/$name.json" | grep -v '^  keyframe [0-9]' |
    sed -n '/^summary/,$p' || { echo "[bench] $name failed" >&2; STATUS=1; }
}
simulate() {  # scenario seed frames [noise] -> prints the folder (generated once, then cached)
  local dir="$OUT/sim_$1_s$2_f$3_${4:-default}"
  [ -f "$dir/sim_info.txt" ] || rosrun tescalib tescalib_simulate --scenario "$1" --seed "$2" \
    --frames "$3" --noise "${4:-default}" --out "$dir" > /dev/null || exit 1
  echo "$dir"
}
simulate_swept() {  # scenario seed frames: raw (swept, motion-skewed) scans, default noise
  local dir="$OUT/sim_$1_s$2_f$3_default_sweep"
  [ -f "$dir/sim_info.txt" ] || rosrun tescalib tescalib_simulate --scenario "$1" --seed "$2" \
    --frames "$3" --noise default --lidar-sweep 1 --out "$dir" > /dev/null || exit 1
  echo "$dir"
}
case $BENCH in
  sim | kitti | all | core) ;;
  *) echo "[bench] BENCH=$BENCH: expected sim, kitti, all or core" >&2; exit 2 ;;
esac
if [ "$BENCH" = core ]; then
  # The README's headline table ("Benchmarks"): each issue's generated-drive target, the baseline
  # a user would pick, and the real-KITTI rows (skipped without the frames).
  URBAN=$(simulate urban 1 100) || exit 1
  for method in tescalib pcl_gicp; do
    run "core_sim_urban_${method}_3deg" --sequences "$URBAN" --mode lidar_stereo --method $method \
      --trials "$SIM_TRIALS" --init-rot-deg 3 --init-trans-m 0.3 --seed 1 --window 20
  done
  run "core_sim_urban_tescalib_10deg" --sequences "$URBAN" --mode lidar_stereo \
    --trials "$SIM_TRIALS" --init-rot-deg 10 --init-trans-m 1.0 --seed 2 --window 20
  run "core_sim_urban_stereo_1deg" --sequences "$URBAN" --mode stereo --trials "$SIM_TRIALS" \
    --init-rot-deg 1 --init-trans-m 0.1 --seed 4 --window 20
  run "core_sim_urban_stereo_1deg_lidar_off" --sequences "$URBAN" --mode stereo \
    --trials "$SIM_TRIALS" --init-rot-deg 1 --init-trans-m 0.1 --lidar-rot-deg 1 \
    --lidar-trans-m 0.1 --seed 5 --window 20
  S11=$(simulate urban 11 100) && S12=$(simulate urban 12 100) || exit 1
  CO_SEQS=$URBAN,$S11,$S12
  for mode in co joint; do
    run "core_sim_urban_${mode}_3deg" --sequences "$CO_SEQS" --mode $mode --trials "$SIM_TRIALS" \
      --init-rot-deg 3 --init-trans-m 0.3 --init-stereo-rot-deg 1 --init-stereo-trans-m 0.1 \
      --seed 1 --window 10 --windows disjoint
  done
  if [ ! -d "$K" ]; then echo "[bench] no KITTI frames at $K: skipping the real-data rows"; exit $STATUS; fi
  for day in "0930 $K/04,$K/05,$K/06,$K/07" "1003 $K/00,$K/02"; do
    read -r name seqs <<< "$day"
    run "core_kitti_${name}_tescalib_3deg" --sequences "$seqs" --mode lidar_stereo \
      --trials "$TRIALS" --init-rot-deg 3 --init-trans-m 0.3 --seed 1 --window 20
    run "core_kitti_${name}_stereo_1deg" --sequences "$seqs" --mode stereo \
      --trials "$TRIALS" --init-rot-deg 1 --init-trans-m 0.1 --seed 4 --window 20
    run "core_kitti_${name}_co_3deg" --sequences "$seqs" --mode co --trials 10 \
      --init-rot-deg 3 --init-trans-m 0.3 --init-stereo-rot-deg 1 --init-stereo-trans-m 0.1 --seed 1
  done
  echo "[bench] JSON files in $OUT"
  exit $STATUS
fi
if [ "$BENCH" != kitti ]; then
  echo "=== tescalib_simulate speed"
  bash "$ROOT/scripts/bench_simulate.sh"
  URBAN=$(simulate urban 1 100)
  # Issue 4: window 20 (the paper's protocol), 3 deg / 0.3 m and the wide basin 10 deg / 1 m.
  for method in tescalib pcl_gicp; do
    run "sim_urban_${method}_3deg" --sequences "$URBAN" --mode lidar_stereo --method $method \
      --trials "$SIM_TRIALS" --init-rot-deg 3 --init-trans-m 0.3 --seed 1 --window 20
  done
  # Sparser LiDARs from the same drive: every 2nd ring (32) and every 4th (16, about a VLP-16).
  for keep in 2 4; do
    run "sim_urban_tescalib_3deg_rings$((64 / keep))" --sequences "$URBAN" --mode lidar_stereo \
      --trials "$SIM_TRIALS" --init-rot-deg 3 --init-trans-m 0.3 --seed 1 --window 20 --keep-rings $keep
  done
  run "sim_urban_tescalib_10deg" --sequences "$URBAN" --mode lidar_stereo \
    --trials "$SIM_TRIALS" --init-rot-deg 10 --init-trans-m 1.0 --seed 2 --window 20
  # Beyond it: 15 deg / 1.5 m and 20 deg / 2 m, with the wide-basin search (the default) and
  # without it (README, "Benchmarks").
  for start in "15 1.5" "20 2.0"; do
    read -r rot trans <<< "$start"
    for search in 10 0; do
      run "sim_urban_tescalib_${rot}deg_search${search}" --sequences "$URBAN" --mode lidar_stereo \
        --trials 20 --init-rot-deg "$rot" --init-trans-m "$trans" --seed 7 --window 20 \
        --search-deg $search
    done
  done
  # The same with the clouds' scale and yaw as nuisances (README, "Benchmarks").
  run "sim_urban_tescalib_3deg_scale_yaw" --sequences "$URBAN" --mode lidar_stereo \
    --trials "$SIM_TRIALS" --init-rot-deg 3 --init-trans-m 0.3 --seed 1 --window 20 \
    --stereo-scale 1 --stereo-yaw 1
  run "sim_urban_tescalib_10deg_scale_yaw" --sequences "$URBAN" --mode lidar_stereo \
    --trials "$SIM_TRIALS" --init-rot-deg 10 --init-trans-m 1.0 --seed 2 --window 20 \
    --stereo-scale 1 --stereo-yaw 1
  # The offline tool on the same drive, from its folder and from its bag (README, "Calibrating a
  # recording offline"): the node's pipeline, as fast as the CPU allows.
  echo "=== tescalib_calibrate (folder, then bag), 3 deg / 0.3 m"
  rosrun tescalib tescalib_calibrate --sequences "$URBAN" --perturb-rot-deg 3 --perturb-trans-m 0.3 |
    grep -E '^[0-9]+ keyframes|^error against' || STATUS=1
  [ -f "$OUT/sim_urban_s1.bag" ] || rosrun tescalib kitti_to_bag --in "$URBAN" --out "$OUT/sim_urban_s1.bag" > /dev/null
  rosrun tescalib tescalib_calibrate --bag "$OUT/sim_urban_s1.bag" --perturb-rot-deg 3 --perturb-trans-m 0.3 |
    grep -E '^[0-9]+ keyframes|^error against' || STATUS=1
  # Both extrinsics with the offline tool, alternation and joint problem (README, "Known limits",
  # joint mode): the last estimate and the per-update solve times.
  for m in co joint; do
    echo "=== tescalib_calibrate --mode $m, LiDAR 2 deg / 0.2 m"
    rosrun tescalib tescalib_calibrate --sequences "$URBAN" --mode $m --perturb-rot-deg 2 \
      --perturb-trans-m 0.2 --seed 1 | grep -E '^[0-9]+ keyframes|^NEES of|against' || STATUS=1
  done
  # Raw swept scans (the same drive, each scan swept over its revolution): de-skewed (the
  # default for such data) and as they are (README, "Motion compensation").
  SWEPT=$(simulate_swept urban 1 100)
  run "sim_urban_swept_tescalib_3deg_deskew" --sequences "$SWEPT" --mode lidar_stereo \
    --trials "$SIM_TRIALS" --init-rot-deg 3 --init-trans-m 0.3 --seed 1 --window 20
  run "sim_urban_swept_tescalib_3deg_raw" --sequences "$SWEPT" --mode lidar_stereo \
    --trials "$SIM_TRIALS" --init-rot-deg 3 --init-trans-m 0.3 --seed 1 --window 20 --deskew 0
  # Issue 5: left-right from 1 deg / 0.1 m, with the LiDAR at the truth and 1 deg / 0.1 m off.
  run "sim_urban_stereo_1deg" --sequences "$URBAN" --mode stereo --trials "$SIM_TRIALS" \
    --init-rot-deg 1 --init-trans-m 0.1 --seed 4 --window 20
  # The baseline a user would pick: an essential matrix from left-right feature matches (rotation
  # and baseline direction; the length stays the start's).
  run "sim_urban_stereo_1deg_features" --sequences "$URBAN" --mode stereo --method features \
    --trials "$SIM_TRIALS" --init-rot-deg 1 --init-trans-m 0.1 --seed 4 --window 20
  run "sim_urban_stereo_1deg_lidar_off" --sequences "$URBAN" --mode stereo \
    --trials "$SIM_TRIALS" --init-rot-deg 1 --init-trans-m 0.1 --lidar-rot-deg 1 \
    --lidar-trans-m 0.1 --seed 5 --window 20
  run "sim_urban_stereo_1deg_lidar_off_smooth8" --sequences "$URBAN" --mode stereo \
    --trials "$SIM_TRIALS" --init-rot-deg 1 --init-trans-m 0.1 --lidar-rot-deg 1 \
    --lidar-trans-m 0.1 --seed 5 --window 20 --smooth-keypoints 8
  # The same with free key point depth (PhotometricSettings::depth_prior_sigma), and at the truth.
  run "sim_urban_stereo_1deg_lidar_off_free_depth" --sequences "$URBAN" --mode stereo \
    --trials "$SIM_TRIALS" --init-rot-deg 1 --init-trans-m 0.1 --lidar-rot-deg 1 \
    --lidar-trans-m 0.1 --seed 5 --window 20 --depth-prior 0.05
  # ... and with the LiDAR's error a nuisance of the depths (its prior: the per-axis sigma of a
  # 1 deg / 0.1 m perturbation, PhotometricSettings::lidar_error_sigma_*).
  run "sim_urban_stereo_1deg_lidar_off_free_depth_nuisance" --sequences "$URBAN" --mode stereo \
    --trials "$SIM_TRIALS" --init-rot-deg 1 --init-trans-m 0.1 --lidar-rot-deg 1 \
    --lidar-trans-m 0.1 --seed 5 --window 20 --depth-prior 0.01 --lidar-sigma 0.58,0.058
  run "sim_urban_stereo_1deg_free_depth" --sequences "$URBAN" --mode stereo \
    --trials "$SIM_TRIALS" --init-rot-deg 1 --init-trans-m 0.1 --seed 4 --window 20 --depth-prior 0.05
  # Issue 6: NEES over independent windows of 10 keyframes (15 urban drives; 4 held out).
  NEES_SEQS=$URBAN
  for s in 11 12 13 14 15 16 21 22 23 24 31 32 33 34; do NEES_SEQS=$NEES_SEQS,$(simulate urban $s 100); done
  run "sim_urban_nees" --sequences "$NEES_SEQS" --mode lidar_stereo --trials 60 \
    --init-rot-deg 3 --init-trans-m 0.3 --seed 21 --window 10 --windows disjoint
  # Issue 6, co-calibration: the 6 windows of three drives from 30 starts, and the co covariance
  # over 54 starts on 18 held-out windows (its model error is fitted on s1, s11-s16, s21-s24;
  # README).
  CO_SEQS=$URBAN,$(simulate urban 11 100),$(simulate urban 12 100)
  run "sim_urban_co_3deg" --sequences "$CO_SEQS" --mode co --trials "$SIM_TRIALS" \
    --init-rot-deg 3 --init-trans-m 0.3 --init-stereo-rot-deg 1 --init-stereo-trans-m 0.1 \
    --seed 1 --window 10 --windows disjoint
  # From the LiDAR 10 deg / 1 m off: round 1's stereo pair from feature matches, LiDAR first
  # (CoCalibrationSettings::stereo_from_features; 30 % of these starts without it, session 27).
  run "sim_urban_co_10deg" --sequences "$CO_SEQS" --mode co --trials "$SIM_TRIALS" \
    --init-rot-deg 10 --init-trans-m 1 --init-stereo-rot-deg 1 --init-stereo-trans-m 0.1 \
    --seed 1 --window 10 --windows disjoint
  CO_HELD_OUT=$(simulate urban 31 100)
  for s in 32 33 34 51 52 53 54 55; do CO_HELD_OUT=$CO_HELD_OUT,$(simulate urban $s 100); done
  run "sim_urban_co_nees_held_out" --sequences "$CO_HELD_OUT" --mode co --trials 54 \
    --init-rot-deg 3 --init-trans-m 0.3 --init-stereo-rot-deg 1 --init-stereo-trans-m 0.1 \
    --seed 61 --window 10 --windows disjoint
  # The joint problem (--mode joint) on the same starts: its model error is fitted on the first
  # run's converged starts, the second is held out (README, "Co-calibration").
  run "sim_urban_joint_3deg" --sequences "$CO_SEQS" --mode joint --trials "$SIM_TRIALS" \
    --init-rot-deg 3 --init-trans-m 0.3 --init-stereo-rot-deg 1 --init-stereo-trans-m 0.1 \
    --seed 1 --window 10 --windows disjoint
  run "sim_urban_joint_nees_held_out" --sequences "$CO_HELD_OUT" --mode joint --trials 54 \
    --init-rot-deg 3 --init-trans-m 0.3 --init-stereo-rot-deg 1 --init-stereo-trans-m 0.1 \
    --seed 61 --window 10 --windows disjoint
  # The LiDAR-stereo model error by scene type (README, "Uncertainty"): one start per window on the
  # windows it was fitted on (urban: 20 drives, residential 41-46, highway 1-5), then held out.
  nees_scene() {  # name scenario seed-list seed
    local seqs="" s
    for s in $3; do seqs=$seqs,$(simulate "$2" "$s" 100); done
    seqs=${seqs#,}
    run "$1" --sequences "$seqs" --mode lidar_stereo --trials $((2 * $(echo $3 | wc -w))) \
      --init-rot-deg 3 --init-trans-m 0.3 --seed "$4" --window 10 --windows disjoint
  }
  nees_scene sim_urban_nees_by_scene urban "1 11 12 13 14 15 16 21 22 23 24 31 32 33 34 51 52 53 54 55" 71
  nees_scene sim_residential_nees residential "41 42 43 44 45 46" 71
  nees_scene sim_highway_nees highway "1 2 3 4 5" 71
  nees_scene sim_urban_nees_held_out urban "56 57" 73
  nees_scene sim_residential_nees_held_out residential "47 48" 73
  nees_scene sim_highway_nees_held_out highway "6 7 8" 73
fi
[ "$BENCH" = sim ] && { echo "[bench] JSON files in $OUT"; exit $STATUS; }
if [ ! -d "$K" ]; then echo "[bench] no KITTI frames at $K: skipping the real-data benchmarks"; exit $STATUS; fi
for method in tescalib pcl_gicp; do
  run "kitti_0930_${method}_3deg" --sequences "$K/04,$K/05,$K/06,$K/07" --mode lidar_stereo \
    --method $method --trials "$TRIALS" --init-rot-deg 3 --init-trans-m 0.3 --seed 1 --window 20
  run "kitti_1003_${method}_3deg" --sequences "$K/00,$K/02" --mode lidar_stereo \
    --method $method --trials "$TRIALS" --init-rot-deg 3 --init-trans-m 0.3 --seed 1 --window 20
done
# The clouds' yaw as a nuisance (on in co-calibration, off by default in LiDAR-stereo mode).
run "kitti_0930_tescalib_3deg_stereo_yaw" --sequences "$K/04,$K/05,$K/06,$K/07" --mode lidar_stereo \
  --trials "$TRIALS" --init-rot-deg 3 --init-trans-m 0.3 --seed 1 --window 20 --stereo-yaw 1
run "kitti_1003_tescalib_3deg_stereo_yaw" --sequences "$K/00,$K/02" --mode lidar_stereo \
  --trials "$TRIALS" --init-rot-deg 3 --init-trans-m 0.3 --seed 1 --window 20 --stereo-yaw 1
run "kitti_0930_tescalib_3deg_scale_yaw" --sequences "$K/04,$K/05,$K/06,$K/07" \
  --mode lidar_stereo --trials "$TRIALS" --init-rot-deg 3 --init-trans-m 0.3 --seed 1 --window 20 \
  --stereo-scale 1 --stereo-yaw 1
run "kitti_1003_tescalib_3deg_scale_yaw" --sequences "$K/00,$K/02" --mode lidar_stereo \
  --trials "$TRIALS" --init-rot-deg 3 --init-trans-m 0.3 --seed 1 --window 20 --stereo-scale 1 \
  --stereo-yaw 1
run "kitti_0930_tescalib_10deg" --sequences "$K/04,$K/05,$K/06,$K/07" --mode lidar_stereo \
  --trials "$TRIALS" --init-rot-deg 10 --init-trans-m 1.0 --seed 2 --window 20
run "kitti_0930_tescalib_from_gt" --sequences "$K/04,$K/05,$K/06,$K/07" --mode lidar_stereo \
  --trials 1 --init-rot-deg 0 --init-trans-m 0 --seed 3 --window 20
run "kitti_0930_stereo_1deg" --sequences "$K/04,$K/05,$K/06,$K/07" --mode stereo \
  --trials "$TRIALS" --init-rot-deg 1 --init-trans-m 0.1 --seed 4 --window 20
run "kitti_1003_stereo_1deg" --sequences "$K/00,$K/02" --mode stereo \
  --trials "$TRIALS" --init-rot-deg 1 --init-trans-m 0.1 --seed 4 --window 20
run "kitti_0930_stereo_1deg_features" --sequences "$K/04,$K/05,$K/06,$K/07" --mode stereo \
  --method features --trials "$TRIALS" --init-rot-deg 1 --init-trans-m 0.1 --seed 4 --window 20
run "kitti_1003_stereo_1deg_features" --sequences "$K/00,$K/02" --mode stereo \
  --method features --trials "$TRIALS" --init-rot-deg 1 --init-trans-m 0.1 --seed 4 --window 20
# The same with KITTI's stated LiDAR calibration accuracy propagated into the stereo covariance.
run "kitti_0930_stereo_1deg_lidar_sigma" --sequences "$K/04,$K/05,$K/06,$K/07" --mode stereo \
  --trials "$TRIALS" --init-rot-deg 1 --init-trans-m 0.1 --seed 4 --window 20 --lidar-sigma 0.1,0.02
run "kitti_1003_stereo_1deg_lidar_sigma" --sequences "$K/00,$K/02" --mode stereo \
  --trials "$TRIALS" --init-rot-deg 1 --init-trans-m 0.1 --seed 4 --window 20 --lidar-sigma 0.1,0.02
run "kitti_0930_stereo_1deg_lidar_off" --sequences "$K/04,$K/05,$K/06,$K/07" --mode stereo \
  --trials "$TRIALS" --init-rot-deg 1 --init-trans-m 0.1 --lidar-rot-deg 1 --lidar-trans-m 0.1 \
  --seed 5 --window 20
run "kitti_0930_co_3deg" --sequences "$K/04,$K/05,$K/06,$K/07" --mode co --trials 10 \
  --init-rot-deg 3 --init-trans-m 0.3 --init-stereo-rot-deg 1 --init-stereo-trans-m 0.1 --seed 1
run "kitti_1003_co_3deg" --sequences "$K/00,$K/02" --mode co --trials 10 \
  --init-rot-deg 3 --init-trans-m 0.3 --init-stereo-rot-deg 1 --init-stereo-trans-m 0.1 --seed 1
run "kitti_0930_co_1deg" --sequences "$K/04,$K/05,$K/06,$K/07" --mode co --trials 10 \
  --init-rot-deg 1 --init-trans-m 0.1 --init-stereo-rot-deg 1 --init-stereo-trans-m 0.1 --seed 1
echo "[bench] JSON files in $OUT"
exit $STATUS
