#!/usr/bin/env bash
# Times tescalib_simulate on 100 frames of the urban scenario (the speed figure in doc/benchmarks.md).
# TESCALIB_SIMULATE: the command to run (default: rosrun tescalib tescalib_simulate from the main
# build). FRAMES, SCENARIO, SEED, THREADS: what to generate (defaults 100, urban, 1, all cores).
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
FRAMES=${FRAMES:-100}
SCENARIO=${SCENARIO:-urban}
SEED=${SEED:-1}
if [ -z "${TESCALIB_SIMULATE:-}" ]; then
  # shellcheck disable=SC1091
  source "$ROOT/build/devel/setup.bash"
  TESCALIB_SIMULATE="rosrun tescalib tescalib_simulate"
fi
EXTRA=()
if [ -n "${THREADS:-}" ]; then EXTRA=(--threads "$THREADS"); fi
OUT=$(mktemp -d /tmp/tescalib_bench_simulate.XXXXXX)
trap 'rm -rf "$OUT"' EXIT
start=$(date +%s.%N)
$TESCALIB_SIMULATE --scenario "$SCENARIO" --frames "$FRAMES" --seed "$SEED" --out "$OUT/seq" \
  "${EXTRA[@]}" > /dev/null
end=$(date +%s.%N)
seconds=$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.1f", b - a }')
per_frame=$(awk -v s="$seconds" -v n="$FRAMES" 'BEGIN { printf "%.3f", s / n }')
size=$(du -sh "$OUT/seq" | cut -f1)
echo "[bench_simulate] $FRAMES $SCENARIO frames in $seconds s ($per_frame s/frame, $(nproc) cores, $size on disk)"
