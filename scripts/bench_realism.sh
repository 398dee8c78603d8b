#!/usr/bin/env bash
# BENCH=realism (make bench): LiDAR-stereo on generated urban drives with real sensors' errors
# (tescalib_simulate --realism kitti, doc/scene_generator.md), from 3 deg / 0.3 m, window 20.
#  - REALISM_SEEDS (default rig) and REALISM_RIG_SEEDS (random rigs), 200 frames written every 5th,
#    STARTS starts each: the rings' range offsets held (the default) and estimated
#    (--ring-range-sigma 0.1), pooled per row by rig_summary.py;
#  - each error source alone (the others set to 0) on REALISM_SOURCE_SEED, 100 frames, window 20,
#    SOURCE_STARTS starts, held and estimated (SOURCE_STARTS=0: not run).
source "$(dirname "$0")/bench_env.sh"
REALISM_SEEDS=${REALISM_SEEDS:-"1201 1202 1203 1204 1205"}
REALISM_RIG_SEEDS=${REALISM_RIG_SEEDS:-"1211 1212 1213"}
REALISM_SOURCE_SEED=${REALISM_SOURCE_SEED:-1221}
STARTS=${STARTS:-4}
SOURCE_STARTS=${SOURCE_STARTS:-3}
SOURCES="right_rotation_deg baseline_scale lens_k1 right_blur_px vignetting laser_range_offset_m
laser_elevation_deg range_scale mixed_pixel_fraction lidar_time_offset_s asphalt_texture"
STATUS=0
drive() {  # name seed frames every rig realism-set -> prints the folder (generated once)
  local dir="$OUT/realism_$1"
  [ -f "$dir/sim_info.txt" ] || rosrun tescalib tescalib_simulate --scenario urban --seed "$2" \
    --frames "$3" --every "$4" --rig "$5" --realism kitti ${6:+--realism-set "$6"} \
    --out "$dir" > /dev/null || exit 1
  echo "$dir"
}
evaluate() {  # json dir window starts [options...]
  rosrun tescalib tescalib_eval --sequences "$2" --mode lidar_stereo --trials "$4" \
    --init-rot-deg 3 --init-trans-m 0.3 --seed 1 --window "$3" --json "$1" "${@:5}" > /dev/null ||
    { echo "[bench] $1 failed" >&2; STATUS=1; }
}
pooled() {  # row name, tescalib_eval options...
  local files=()
  for seed in $REALISM_SEEDS; do
    evaluate "$OUT/$1_s$seed.json" "$(drive "kitti_s$seed" "$seed" 200 5 default)" 20 "$STARTS" "${@:2}"
    files+=("$OUT/$1_s$seed.json")
  done
  for seed in $REALISM_RIG_SEEDS; do
    evaluate "$OUT/$1_rig$seed.json" "$(drive "kitti_rig$seed" "$seed" 200 5 random)" 20 "$STARTS" "${@:2}"
    files+=("$OUT/$1_rig$seed.json")
  done
  echo "=== $1"
  python3 "$ROOT/scripts/rig_summary.py" "$1" "${files[@]}"
}
pooled sim_urban_realism_kitti
pooled sim_urban_realism_kitti_ring_offsets --ring-range-sigma 0.1
[ "$SOURCE_STARTS" -gt 0 ] || SOURCES=""
for source in $([ -n "$SOURCES" ] && echo clean) $SOURCES; do
  others=""
  for s in $SOURCES; do  # off: 0, the asphalt's texture 1 (as clean)
    [ "$s" = "$source" ] || others="$others${others:+,}$s=$([ "$s" = asphalt_texture ] && echo 1 || echo 0)"
  done
  dir=$(drive "source_${source}_s$REALISM_SOURCE_SEED" "$REALISM_SOURCE_SEED" 100 5 default "$others")
  evaluate "$OUT/realism_source_$source.json" "$dir" 20 "$SOURCE_STARTS"
  evaluate "$OUT/realism_source_${source}_ring_offsets.json" "$dir" 20 "$SOURCE_STARTS" \
    --ring-range-sigma 0.1
  echo "=== $source"
  python3 "$ROOT/scripts/rig_summary.py" "$source" "$OUT/realism_source_$source.json"
  python3 "$ROOT/scripts/rig_summary.py" "$source (ring offsets)" \
    "$OUT/realism_source_${source}_ring_offsets.json"
done
echo "[bench] JSON files in $OUT"
exit $STATUS
