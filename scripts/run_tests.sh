#!/usr/bin/env bash
# Builds and runs every gtest and rostest of the package, then prints one summary line.
# Exit code is non-zero when any test failed or errored.
# --fast (make test-fast): only the gtests that take seconds; test/slow_tests.txt lists the others.
set -o pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$ROOT/build
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
# shellcheck disable=SC1091
source "$BUILD/devel/setup.bash"
# shellcheck disable=SC1091
source "$ROOT/scripts/ros_hostname.sh"
rm -rf "$BUILD/test_results"
make --no-print-directory -C "$BUILD" -j"${JOBS:-2}" tests || { echo "[test] building the tests failed"; exit 1; }
if [ "${1:-}" = "--fast" ]; then
  # Every gtest binary but the rostest's, without the tests that test/slow_tests.txt names.
  mkdir -p "$BUILD/test_results/fast"
  slow=$(grep -v -E '^\s*(#|$)' "$ROOT/test/slow_tests.txt" | paste -sd: -)
  start=$(date +%s)
  rc=0
  for bin in "$BUILD"/devel/lib/tescalib/test_*; do
    name=$(basename "$bin")
    [ "$name" = test_params_node ] && continue
    "$bin" --gtest_filter="-$slow" --gtest_output="xml:$BUILD/test_results/fast/$name.xml" \
      > "$BUILD/test_results/$name.fast.log" 2>&1 || rc=1
    grep -E '^\[  FAILED  \] [A-Za-z]' "$BUILD/test_results/$name.fast.log" | sort -u
  done
  /usr/bin/python3 "$ROOT/scripts/test_summary.py" "$BUILD/test_results/fast" || rc=1
  echo "[test] took $(( $(date +%s) - start )) s (fast tier)"
  exit $rc
fi
# Again: the tests' build may have created folders (Python messages) setup.bash adds only if present.
# shellcheck disable=SC1091
source "$BUILD/devel/setup.bash"
start=$(date +%s)
# The gtest binaries run two at a time (TEST_JOBS; each binary's output stays whole in its own
# log), the rostests one at a time (each starts a ROS master on the same port).
shown='^\[ *(RUN|  +OK|  FAILED|  SKIPPED|  PASSED) |^\[ROSTEST\]|SKIP|Skipped|FAILURE|ERROR'
{
  make --no-print-directory -C "$BUILD" -j"${TEST_JOBS:-2}" -O run_tests_tescalib_gtest 2>&1
  make --no-print-directory -C "$BUILD" -j1 run_tests_tescalib_rostest \
    run_tests_tescalib_roslaunch-check 2>&1
} | tee "$BUILD/run_tests.log" | grep -E "$shown" || true
/usr/bin/python3 "$ROOT/scripts/test_summary.py" "$BUILD/test_results"
rc=$?
echo "[test] took $(( $(date +%s) - start )) s"
exit $rc
