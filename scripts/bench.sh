#!/usr/bin/env bash
# make bench: the accuracy/speed benchmarks whose tables go into doc/benchmarks.md. Long; not in
# make test.
# BENCH=sim|kitti|all (default all) selects the generated-drive or the real-KITTI part; BENCH=core
# runs only the rows of doc/benchmarks.md's main table, one per benchmark target (about 25 minutes);
# BENCH=rigs only the random-rig rows (the RIG_SEEDS rigs drawn by tescalib_simulate --rig random:
# LiDAR-stereo from 3 deg / 0.3 m and 10 deg / 1 m, co; on residential and highway drives
# LiDAR-stereo from 3 deg; urban and residential again without the re-rectified pair's vertical
# low-pass; about 6 minutes per rig). BENCH=monitor
# runs the calibration monitor's rows (scripts/bench_monitor.sh, about 3 minutes per 60 s drive). BENCH=realism runs the rows of real sensors' errors
# (tescalib_simulate --realism kitti): urban drives of the default rig (REALISM_SEEDS) and of random
# rigs (REALISM_RIG_SEEDS), the rings' range offsets held (the default) and estimated, and each error
# source alone on REALISM_SOURCE_SEED (about 60 minutes in all). BENCH=validate runs
# tescalib_validate's criteria against the truth and on KITTI (scripts/bench_validate.sh).
source "$(dirname "$0")/bench_env.sh"
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
# The rows of doc/benchmarks.md's main table, run by BENCH=core and by the full bench alike; their
# JSON names start with $P ("core_" under BENCH=core, so that they do not overwrite the full
# bench's).
P=""
[ "$BENCH" = core ] && P=core_
D0930="$K/04,$K/05,$K/06,$K/07"  # KITTI 2011_09_30: 8 keyframes
D1003="$K/00,$K/02"              # KITTI 2011_10_03: 4 keyframes
urban_lidar_stereo() {  # method rot-deg trans-m seed [name suffix [options...]]: window 20
  run "${P}sim_urban_$1_$2deg${5:-}" --sequences "$URBAN" --mode lidar_stereo --method "$1" \
    --trials "$SIM_TRIALS" --init-rot-deg "$2" --init-trans-m "$3" --seed "$4" --window 20 "${@:6}"
}
urban_stereo() {  # seed [name suffix [options...]]: left-right from 1 deg / 0.1 m, window 20
  run "${P}sim_urban_stereo_1deg${2:-}" --sequences "$URBAN" --mode stereo --trials "$SIM_TRIALS" \
    --init-rot-deg 1 --init-trans-m 0.1 --seed "$1" --window 20 "${@:3}"
}
urban_both() {  # co|joint: both extrinsics, the 6 windows of three drives ($CO_SEQS), 30 starts
  run "${P}sim_urban_$1_3deg" --sequences "$CO_SEQS" --mode "$1" --trials "$SIM_TRIALS" \
    --init-rot-deg 3 --init-trans-m 0.3 --init-stereo-rot-deg 1 --init-stereo-trans-m 0.1 \
    --seed 1 --window 10 --windows disjoint
}
kitti_lidar_stereo() {  # day sequences method [name suffix [options...]]: 3 deg / 0.3 m, window 20
  run "${P}kitti_$1_$3_3deg${4:-}" --sequences "$2" --mode lidar_stereo --method "$3" \
    --trials "$TRIALS" --init-rot-deg 3 --init-trans-m 0.3 --seed 1 --window 20 "${@:5}"
}
kitti_stereo() {  # day sequences seed [name suffix [options...]]: left-right from 1 deg / 0.1 m
  run "${P}kitti_$1_stereo_1deg${4:-}" --sequences "$2" --mode stereo --trials "$TRIALS" \
    --init-rot-deg 1 --init-trans-m 0.1 --seed "$3" --window 20 "${@:5}"
}
kitti_co() {  # day sequences rot-deg trans-m: co from the LiDAR that far off, 10 starts
  run "${P}kitti_$1_co_$3deg" --sequences "$2" --mode co --trials 10 --init-rot-deg "$3" \
    --init-trans-m "$4" --init-stereo-rot-deg 1 --init-stereo-trans-m 0.1 --seed 1
}
case $BENCH in
  sim | kitti | all | core | rigs) ;;
  monitor) exec bash "$ROOT/scripts/bench_monitor.sh" ;;
  realism) exec bash "$ROOT/scripts/bench_realism.sh" ;;
  validate) exec bash "$ROOT/scripts/bench_validate.sh" ;;
  *) echo "[bench] BENCH=$BENCH: expected sim, kitti, all, core, rigs, monitor, realism or validate" >&2
     exit 2 ;;
esac
RIG_SEEDS=${RIG_SEEDS:-"301 302 303 304 305 306 307 308 309 310"}
# name rot-deg trans-m [options...]: three starts on each random rig's drive ($RIG_SCENE, default
# urban); the options default to LiDAR-stereo with the first 20 keyframes.
random_rigs() {
  local name=$1 rot=$2 trans=$3 files=() scene=${RIG_SCENE:-urban}
  shift 3
  local opts=("$@")
  [ ${#opts[@]} -gt 0 ] || opts=(--mode lidar_stereo --window 20)
  for seed in $RIG_SEEDS; do
    local dir="$OUT/sim_${scene}_rig$seed"
    [ -f "$dir/sim_info.txt" ] || rosrun tescalib tescalib_simulate --scenario "$scene" \
      --seed "$seed" --frames 100 --rig random --out "$dir" > /dev/null || exit 1
    rosrun tescalib tescalib_eval --sequences "$dir" --trials 3 --init-rot-deg "$rot" \
      --init-trans-m "$trans" --seed 1 "${opts[@]}" --json "$OUT/${name}_rig$seed.json" \
      > /dev/null || { echo "[bench] $name rig $seed failed" >&2; STATUS=1; }
    files+=("$OUT/${name}_rig$seed.json")
  done
  echo "=== $name"
  python3 "$ROOT/scripts/rig_summary.py" "$name" "${files[@]}"
}
# co on random rigs: LiDAR 3 deg / 0.3 m and the pair 1 deg / 0.1 m off, disjoint 10-keyframe
# windows (the node's window).
random_rigs_co() {
  random_rigs sim_urban_random_rigs_co 3 0.3 --mode co --init-stereo-rot-deg 1 \
    --init-stereo-trans-m 0.1 --window 10 --windows disjoint
}
# LiDAR-stereo from 3 deg / 0.3 m on the same rigs' residential and highway drives: whether the
# covariance stays honest and the highway's weak directions are flagged (not declared converged).
random_rigs_scenes() {
  RIG_SCENE=residential random_rigs sim_residential_random_rigs_3deg 3 0.3
  RIG_SCENE=highway random_rigs sim_highway_random_rigs_3deg 3 0.3
}
# The urban and residential LiDAR-stereo rows again without the re-rectified pair's vertical
# low-pass (stereo/rectified_vertical_blur_px 0): what it does on pairs off the x axis.
random_rigs_sharp() {
  local opts=(--mode lidar_stereo --window 20 --rectified-vertical-blur 0)
  random_rigs sim_urban_random_rigs_3deg_sharp 3 0.3 "${opts[@]}"
  RIG_SCENE=residential random_rigs sim_residential_random_rigs_3deg_sharp 3 0.3 "${opts[@]}"
}
if [ "$BENCH" = rigs ]; then
  random_rigs sim_urban_random_rigs_3deg 3 0.3
  random_rigs sim_urban_random_rigs_10deg 10 1.0
  random_rigs_co
  random_rigs_scenes
  random_rigs_sharp
  exit $STATUS
fi
if [ "$BENCH" = core ]; then
  # doc/benchmarks.md's main table: each generated-drive target, the baseline
  # a user would pick, and the real-KITTI rows (skipped without the frames).
  URBAN=$(simulate urban 1 100) || exit 1
  urban_lidar_stereo tescalib 3 0.3 1
  urban_lidar_stereo pcl_gicp 3 0.3 1
  urban_lidar_stereo tescalib 10 1.0 2
  urban_stereo 4
  urban_stereo 5 _lidar_off --lidar-rot-deg 1 --lidar-trans-m 0.1
  S11=$(simulate urban 11 100) && S12=$(simulate urban 12 100) || exit 1
  CO_SEQS=$URBAN,$S11,$S12
  urban_both co
  urban_both joint
  if [ ! -d "$K" ]; then echo "[bench] no KITTI frames at $K: skipping the real-data rows"; exit $STATUS; fi
  for day in "0930 $D0930" "1003 $D1003"; do
    read -r name seqs <<< "$day"
    kitti_lidar_stereo "$name" "$seqs" tescalib
    kitti_stereo "$name" "$seqs" 4
    kitti_co "$name" "$seqs" 3 0.3
  done
  echo "[bench] JSON files in $OUT"
  exit $STATUS
fi
if [ "$BENCH" != kitti ]; then
  random_rigs sim_urban_random_rigs_3deg 3 0.3
  random_rigs sim_urban_random_rigs_10deg 10 1.0
  random_rigs_co
  random_rigs_scenes
  random_rigs_sharp
  echo "=== tescalib_simulate speed"
  bash "$ROOT/scripts/bench_simulate.sh"
  URBAN=$(simulate urban 1 100)
  # LiDAR-stereo: window 20 (the paper's protocol), 3 deg / 0.3 m and the wide basin 10 deg / 1 m.
  urban_lidar_stereo tescalib 3 0.3 1
  urban_lidar_stereo pcl_gicp 3 0.3 1
  # Sparser LiDARs from the same drive: every 2nd ring (32) and every 4th (16, about a VLP-16).
  for keep in 2 4; do
    urban_lidar_stereo tescalib 3 0.3 1 "_rings$((64 / keep))" --keep-rings $keep
  done
  urban_lidar_stereo tescalib 10 1.0 2
  # Beyond it: 15 deg / 1.5 m and 20 deg / 2 m, with the wide-basin search (the default) and
  # without it (doc/benchmarks.md).
  for start in "15 1.5" "20 2.0"; do
    read -r rot trans <<< "$start"
    for search in 10 0; do
      run "sim_urban_tescalib_${rot}deg_search${search}" --sequences "$URBAN" --mode lidar_stereo \
        --trials 20 --init-rot-deg "$rot" --init-trans-m "$trans" --seed 7 --window 20 \
        --search-deg $search
    done
  done
  # The same with the clouds' scale and yaw as nuisances.
  urban_lidar_stereo tescalib 3 0.3 1 _scale_yaw --stereo-scale 1 --stereo-yaw 1
  urban_lidar_stereo tescalib 10 1.0 2 _scale_yaw --stereo-scale 1 --stereo-yaw 1
  # The offline tool on the same drive, from its folder and from its bag (doc/offline.md): the
  # node's pipeline, as fast as the CPU allows.
  echo "=== tescalib_calibrate (folder, then bag), 3 deg / 0.3 m"
  rosrun tescalib tescalib_calibrate --sequences "$URBAN" --perturb-rot-deg 3 --perturb-trans-m 0.3 |
    grep -E '^[0-9]+ keyframes|^error against' || STATUS=1
  [ -f "$OUT/sim_urban_s1.bag" ] || rosrun tescalib kitti_to_bag --in "$URBAN" --out "$OUT/sim_urban_s1.bag" > /dev/null
  rosrun tescalib tescalib_calibrate --bag "$OUT/sim_urban_s1.bag" --perturb-rot-deg 3 --perturb-trans-m 0.3 |
    grep -E '^[0-9]+ keyframes|^error against' || STATUS=1
  # Both extrinsics with the offline tool, alternation and joint problem: the last estimate and
  # the per-update solve times.
  for m in co joint; do
    echo "=== tescalib_calibrate --mode $m, LiDAR 2 deg / 0.2 m"
    rosrun tescalib tescalib_calibrate --sequences "$URBAN" --mode $m --perturb-rot-deg 2 \
      --perturb-trans-m 0.2 --seed 1 | grep -E '^[0-9]+ keyframes|^NEES of|against' || STATUS=1
  done
  # Raw swept scans (the same drive, each scan swept over its revolution): de-skewed (the
  # default for such data) and as they are.
  SWEPT=$(simulate_swept urban 1 100)
  run "sim_urban_swept_tescalib_3deg_deskew" --sequences "$SWEPT" --mode lidar_stereo \
    --trials "$SIM_TRIALS" --init-rot-deg 3 --init-trans-m 0.3 --seed 1 --window 20
  run "sim_urban_swept_tescalib_3deg_raw" --sequences "$SWEPT" --mode lidar_stereo \
    --trials "$SIM_TRIALS" --init-rot-deg 3 --init-trans-m 0.3 --seed 1 --window 20 --deskew 0
  # Left-right: left-right from 1 deg / 0.1 m, with the LiDAR at the truth and 1 deg / 0.1 m off.
  urban_stereo 4
  # The baseline a user would pick: an essential matrix from left-right feature matches (rotation
  # and baseline direction; the length stays the start's).
  urban_stereo 4 _features --method features
  LIDAR_OFF=(--lidar-rot-deg 1 --lidar-trans-m 0.1)
  urban_stereo 5 _lidar_off "${LIDAR_OFF[@]}"
  urban_stereo 5 _lidar_off_smooth8 "${LIDAR_OFF[@]}" --smooth-keypoints 8
  # The same with free key point depth (PhotometricSettings::depth_prior_sigma), and at the truth.
  urban_stereo 5 _lidar_off_free_depth "${LIDAR_OFF[@]}" --depth-prior 0.05
  # ... and with the LiDAR's error a nuisance of the depths (its prior: the per-axis sigma of a
  # 1 deg / 0.1 m perturbation, PhotometricSettings::lidar_error_sigma_*).
  urban_stereo 5 _lidar_off_free_depth_nuisance "${LIDAR_OFF[@]}" --depth-prior 0.01 \
    --lidar-sigma 0.58,0.058
  urban_stereo 4 _free_depth --depth-prior 0.05
  # Covariance (NEES): NEES over independent windows of 10 keyframes (15 urban drives; 4 held out).
  NEES_SEQS=$URBAN
  for s in 11 12 13 14 15 16 21 22 23 24 31 32 33 34; do NEES_SEQS=$NEES_SEQS,$(simulate urban $s 100); done
  run "sim_urban_nees" --sequences "$NEES_SEQS" --mode lidar_stereo --trials 60 \
    --init-rot-deg 3 --init-trans-m 0.3 --seed 21 --window 10 --windows disjoint
  # Co-calibration: the 6 windows of three drives from 30 starts, and the co covariance
  # over 54 starts on 18 held-out windows (its model error is fitted on s1, s11-s16, s21-s24).
  CO_SEQS=$URBAN,$(simulate urban 11 100),$(simulate urban 12 100)
  urban_both co
  # From the LiDAR 10 deg / 1 m off: round 1's stereo pair from feature matches, LiDAR first
  # (CoCalibrationSettings::stereo_from_features; 30 % of these starts without it).
  run "sim_urban_co_10deg" --sequences "$CO_SEQS" --mode co --trials "$SIM_TRIALS" \
    --init-rot-deg 10 --init-trans-m 1 --init-stereo-rot-deg 1 --init-stereo-trans-m 0.1 \
    --seed 1 --window 10 --windows disjoint
  CO_HELD_OUT=$(simulate urban 31 100)
  for s in 32 33 34 51 52 53 54 55; do CO_HELD_OUT=$CO_HELD_OUT,$(simulate urban $s 100); done
  run "sim_urban_co_nees_held_out" --sequences "$CO_HELD_OUT" --mode co --trials 54 \
    --init-rot-deg 3 --init-trans-m 0.3 --init-stereo-rot-deg 1 --init-stereo-trans-m 0.1 \
    --seed 61 --window 10 --windows disjoint
  # The joint problem (--mode joint) on the same starts: its model error is fitted on the first
  # run's converged starts, the second is held out.
  urban_both joint
  run "sim_urban_joint_nees_held_out" --sequences "$CO_HELD_OUT" --mode joint --trials 54 \
    --init-rot-deg 3 --init-trans-m 0.3 --init-stereo-rot-deg 1 --init-stereo-trans-m 0.1 \
    --seed 61 --window 10 --windows disjoint
  # The LiDAR-stereo model error by scene type (doc/benchmarks.md): one start per window on the
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
for day in "0930 $D0930" "1003 $D1003"; do
  read -r name seqs <<< "$day"
  kitti_lidar_stereo "$name" "$seqs" tescalib
  kitti_lidar_stereo "$name" "$seqs" pcl_gicp
  # The clouds' yaw as a nuisance (on in co-calibration, off by default in LiDAR-stereo mode).
  kitti_lidar_stereo "$name" "$seqs" tescalib _stereo_yaw --stereo-yaw 1
  kitti_lidar_stereo "$name" "$seqs" tescalib _scale_yaw --stereo-scale 1 --stereo-yaw 1
  kitti_stereo "$name" "$seqs" 4
  kitti_stereo "$name" "$seqs" 4 _features --method features
  # KITTI's stated LiDAR calibration accuracy propagated into the stereo covariance.
  kitti_stereo "$name" "$seqs" 4 _lidar_sigma --lidar-sigma 0.1,0.02
  kitti_co "$name" "$seqs" 3 0.3
done
run "kitti_0930_tescalib_10deg" --sequences "$D0930" --mode lidar_stereo \
  --trials "$TRIALS" --init-rot-deg 10 --init-trans-m 1.0 --seed 2 --window 20
run "kitti_0930_tescalib_from_gt" --sequences "$D0930" --mode lidar_stereo \
  --trials 1 --init-rot-deg 0 --init-trans-m 0 --seed 3 --window 20
kitti_stereo 0930 "$D0930" 5 _lidar_off --lidar-rot-deg 1 --lidar-trans-m 0.1
kitti_co 0930 "$D0930" 1 0.1
echo "[bench] JSON files in $OUT"
exit $STATUS
