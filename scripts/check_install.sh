#!/bin/bash
# `make install-check`: builds the package into a separate build folder, installs it with catkin's
# install rules (as a release or a Debian package would) and checks the install space on its own,
# without the devel space: the package is found, the nodelets are registered and load, the tools
# run, the message and service modules import, launch files and config are there.
# Usage: scripts/check_install.sh [WORKDIR] (default build/.install_check; about 4 min on 2 cores).
# The default is a dot folder: roslaunch finds a launch file by walking the package's folder and
# skips only dot folders, so an install space under build/install_check made `roslaunch tescalib
# demo.launch` (and `make demo`) fail with "multiple files named [demo.launch]".
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
WORK=${1:-$ROOT/build/.install_check}
mkdir -p "$WORK/build"
export PATH=/usr/bin:/bin:/usr/sbin:/sbin
echo "[install-check] building into $WORK/install"
(cd "$WORK/build" && cmake "$ROOT" -DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=/usr/bin/python3 \
  -DPython3_EXECUTABLE=/usr/bin/python3 -DCATKIN_DEVEL_PREFIX="$WORK/devel" \
  -DCMAKE_INSTALL_PREFIX="$WORK/install" -DCATKIN_ENABLE_TESTING=OFF > cmake.log &&
  make -j"${JOBS:-2}" install > make.log) || { tail -20 "$WORK/build/make.log"; exit 1; }
env -i HOME="$HOME" PATH="$PATH" WORK="$WORK" ROOT="$ROOT" bash -euo pipefail -c '
  set +u  # ROS setup files read unset variables
  # shellcheck disable=SC1091
  source "$WORK/install/setup.bash"
  set -u
  fail() { echo "[install-check] FAILED: $*"; exit 1; }
  [ "$(rospack find tescalib)" = "$WORK/install/share/tescalib" ] || fail "rospack find tescalib"
  rospack plugins --attrib=plugin nodelet | grep -q "^tescalib " || fail "nodelet plugins not registered"
  for f in launch/kitti.launch launch/live.launch launch/calibration.launch launch/overlay.launch \
           config/kitti.yaml config/expert.yaml config/live.yaml rviz/tescalib.rviz; do
    [ -f "$WORK/install/share/tescalib/$f" ] || fail "$f not installed"
  done
  python3 -c "import tescalib.msg, tescalib.srv" || fail "python messages"
  for t in tescalib_simulate tescalib_calibrate tescalib_eval kitti_to_bag tescalib_check_data tescalib_validate; do
    out=$(rosrun tescalib $t --help 2>&1 || true)
    echo "$out" | grep -q "usage" || fail "$t: $out"
  done
  port=$(python3 -c "import socket; s = socket.socket(); s.bind((\"\", 0)); print(s.getsockname()[1])")
  export ROS_MASTER_URI=http://localhost:$port ROS_HOME="$WORK/ros_home"
  # shellcheck disable=SC1091
  source "$ROOT/scripts/ros_hostname.sh"
  roscore -p "$port" > /dev/null 2>&1 &
  core=$!
  trap "kill $core 2> /dev/null || true" EXIT
  for _ in $(seq 50); do rostopic list > /dev/null 2>&1 && break; sleep 0.2; done
  roslaunch tescalib live.launch points:=/check/points left:=/check/left right:=/check/right \
    > "$WORK/live.log" 2>&1 &
  launch=$!
  ok=0
  for _ in $(seq 60); do
    if rosservice list 2> /dev/null | grep -q "^/tescalib/save$"; then ok=1; break; fi
    sleep 0.5
  done
  kill -INT $launch; wait $launch || true
  [ $ok = 1 ] || { tail -20 "$WORK/live.log"; fail "live.launch: /tescalib/save never appeared"; }
  echo "[install-check] install space OK: package, nodelets (loaded by live.launch), tools, messages, launch files"
'
