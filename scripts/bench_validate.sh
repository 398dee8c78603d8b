#!/usr/bin/env bash
# BENCH=validate (make bench): tescalib_validate's criteria against the truth (doc/validation.md).
#  - generated drives (60 frames written every 5th: 12 keyframes) of the default rig
#    (VALIDATE_SEEDS; residential when the seed is a multiple of 3, else urban) and of random rigs
#    (VALIDATE_RIG_SEEDS), each with realism none and kitti: the truth against steps of 0.1 deg /
#    1 cm (--perturbed 0.1,1) and each criterion's optimum searched from the truth and from a
#    calibration 0.3 deg / 3 cm off (perturb_calib.py), pooled by validate_summary.py;
#  - both KITTI days: their calibration against 0.5 deg / 5 cm steps with the optima, and the optima
#    searched on one part of the day and scored on the other (--fit-sequences).
# About 15 minutes.
source "$(dirname "$0")/bench_env.sh"
VALIDATE_SEEDS=${VALIDATE_SEEDS:-"1330 1331 1332 1333 1334 1335"}
VALIDATE_RIG_SEEDS=${VALIDATE_RIG_SEEDS-"1340 1341 1342 1343"}
STATUS=0
validate() {  # json, tescalib_validate options...
  rosrun tescalib tescalib_validate --json "$1" "${@:2}" > "${1%.json}.txt" ||
    { echo "[bench] $1 failed" >&2; STATUS=1; }
}
drive() {  # seed rig realism -> prints the folder (generated once)
  local scenario=urban dir="$OUT/validate_s$1_$2_$3"
  [ $(($1 % 3)) -eq 0 ] && scenario=residential
  [ -f "$dir/sim_info.txt" ] || rosrun tescalib tescalib_simulate --scenario $scenario --seed "$1" \
    --frames 60 --every 5 --rig "$2" --realism "$3" --out "$dir" > /dev/null || exit 1
  echo "$dir"
}
for realism in none kitti; do
  files=()
  for rig_seed in $(for s in $VALIDATE_SEEDS; do echo "default:$s"; done) \
                  $(for s in $VALIDATE_RIG_SEEDS; do echo "random:$s"; done); do
    rig=${rig_seed%%:*} seed=${rig_seed#*:}
    dir=$(drive "$seed" "$rig" "$realism")
    python3 "$ROOT/scripts/perturb_calib.py" "$dir/calib.txt" "$dir/calib_off.txt" "$seed" 0.3 0.03
    json="$OUT/validate_s${seed}_${rig}_$realism.json"
    validate "$json" --sequences "$dir" --calib "off=$dir/calib_off.txt" --perturbed 0.1,1 --optimum 1
    files+=("$json")
  done
  echo "=== realism $realism"
  python3 "$ROOT/scripts/validate_summary.py" "realism $realism" "${files[@]}"
done
if [ -d "$K" ]; then
  for day in "0930:$K/04,$K/05,$K/06,$K/07" "1003:$K/00,$K/02"; do
    name=${day%%:*} seqs=${day#*:}
    validate "$OUT/validate_kitti_$name.json" --sequences "$seqs" --perturbed 0.5,5 --optimum 1
    echo "=== KITTI $name"
    cat "$OUT/validate_kitti_$name.txt"
  done
  for split in "0930a:$K/07:$K/04,$K/05,$K/06" "0930b:$K/04,$K/05,$K/06:$K/07" \
               "1003a:$K/00:$K/02" "1003b:$K/02:$K/00"; do
    IFS=: read -r name fit scored <<< "$split"
    validate "$OUT/validate_kitti_held_out_$name.json" --sequences "$scored" --frames all \
      --fit-sequences "$fit" --fit-frames all
    echo "=== KITTI held out $name (searched on $fit, scored on $scored)"
    grep -E "its optimum|uncertainty|^  [a-z_]+ +r" "$OUT/validate_kitti_held_out_$name.txt"
  done
else
  echo "[bench] $K absent: the KITTI rows are skipped"
fi
echo "[bench] JSON files in $OUT"
exit $STATUS
