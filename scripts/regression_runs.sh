#!/usr/bin/env bash
# Fixed-seed runs whose results must not change in a behaviour-preserving change (a refactoring):
#   bash scripts/regression_runs.sh OUT        (after make build; about 1-3 minutes)
#   python3 scripts/compare_runs.py REF_OUT NEW_OUT
# tescalib_eval in every mode (lidar_stereo, stereo, co, joint, the GICP baseline, real KITTI when
# ../shared/data is present) and tescalib_calibrate's online co-calibration, on two generated
# drives kept in build/regression_drives.
set -o pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
OUT=${1:?usage: regression_runs.sh OUT}
mkdir -p "$OUT"
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
# shellcheck disable=SC1091
source "$ROOT/build/devel/setup.bash"
K=$ROOT/../shared/data/kitti_odometry_mini/sequences
DRIVES=$ROOT/build/regression_drives
for s in 3 4; do
  [ -f "$DRIVES/urban_s$s/sim_info.txt" ] || rosrun tescalib tescalib_simulate --scenario urban \
    --seed $s --frames 61 --out "$DRIVES/urban_s$s" > /dev/null || exit 1
done
U=$DRIVES/urban_s3
U2=$DRIVES/urban_s3,$DRIVES/urban_s4
BOTH=(--init-rot-deg 3 --init-trans-m 0.3 --init-stereo-rot-deg 1 --init-stereo-trans-m 0.1)
run() {  # name, tescalib_eval arguments
  local name=$1; shift
  rosrun tescalib tescalib_eval "$@" --json "$OUT/$name.json" > "$OUT/$name.txt" 2>&1 ||
    echo "[regression] $name failed (see $OUT/$name.txt)"
}
run ls --sequences "$U" --mode lidar_stereo --trials 3 --init-rot-deg 3 --init-trans-m 0.3 \
  --seed 1 --window 20 &
run st --sequences "$U" --mode stereo --trials 3 --init-rot-deg 1 --init-trans-m 0.1 --seed 2 \
  --window 20
wait
run co --sequences "$U2" --mode co --trials 2 "${BOTH[@]}" --seed 1 --window 10 \
  --windows disjoint &
run joint --sequences "$U2" --mode joint --trials 2 "${BOTH[@]}" --seed 1 --window 10 \
  --windows disjoint
wait
run gicp --sequences "$U" --mode lidar_stereo --method pcl_gicp --trials 1 --init-rot-deg 3 \
  --init-trans-m 0.3 --seed 1 --window 10 &
[ -d "$K/04" ] && run kitti_ls --sequences "$K/04,$K/05" --mode lidar_stereo --trials 2 \
  --init-rot-deg 3 --init-trans-m 0.3 --seed 1 --window 20
wait
rosrun tescalib tescalib_calibrate --sequences "$U" --mode co --perturb-rot-deg 2 \
  --perturb-trans-m 0.2 --seed 3 > "$OUT/calibrate_co.txt" 2>&1
echo "[regression] runs written to $OUT"
