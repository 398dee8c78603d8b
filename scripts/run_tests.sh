#!/usr/bin/env bash
# Builds and runs every gtest and rostest of the package, then prints one summary line.
# Exit code is non-zero when any test failed or errored.
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
# Again: the tests' build may have created folders (Python messages) setup.bash adds only if present.
# shellcheck disable=SC1091
source "$BUILD/devel/setup.bash"
start=$(date +%s)
make --no-print-directory -C "$BUILD" -j1 run_tests 2>&1 | tee "$BUILD/run_tests.log" | grep -E '^\[ *(RUN|  +OK|  FAILED|  SKIPPED|  PASSED) |^\[ROSTEST\]|SKIP|Skipped|FAILURE|ERROR' || true
/usr/bin/python3 "$ROOT/scripts/test_summary.py" "$BUILD/test_results"
rc=$?
echo "[test] took $(( $(date +%s) - start )) s"
exit $rc
