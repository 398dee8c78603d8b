#!/usr/bin/env bash
# Screenshot of rviz (rviz/tescalib.rviz) while the demo's generated bag plays through the online
# pipeline (looped, 1x, 2 deg / 0.2 m start, LiDAR-stereo only), rendered headless under Xvfb.
# Run `make demo` first (it generates and caches the bag). Needs xvfb and imagemagick
# (installed here when missing). Usage: scripts/rviz_screenshot.sh [OUT.png] [SECONDS]
set -o pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
# shellcheck source=scripts/ros_env.sh
source "$ROOT/scripts/ros_env.sh"
OUT=${1:-$ROOT/doc/rviz_demo.png}
WAIT=${2:-12}
BAG=$(ls "$ROOT"/build/demo/urban_f*_s*_*.bag 2>/dev/null | head -1)
[ -n "$BAG" ] || { echo "[rviz] no demo bag in build/demo: run make demo first"; exit 1; }
if ! command -v Xvfb >/dev/null || [ ! -x /usr/bin/import ]; then
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends xvfb \
    imagemagick >/dev/null
fi
DISPLAY_NUM=:${RVIZ_DISPLAY:-97}
Xvfb "$DISPLAY_NUM" -screen 0 1400x900x24 -nolisten tcp >/dev/null 2>&1 &
XVFB=$!
LAUNCH=
cleanup() {
  [ -n "$LAUNCH" ] && kill "$LAUNCH" 2>/dev/null && wait "$LAUNCH" 2>/dev/null
  kill "$XVFB" 2>/dev/null
}
trap cleanup EXIT
sleep 1
echo "[rviz] DISPLAY=$DISPLAY_NUM roslaunch tescalib kitti.launch bag:=$BAG loop:=true rviz:=true ..."
DISPLAY=$DISPLAY_NUM roslaunch tescalib kitti.launch bag:="$BAG" loop:=true rviz:=true \
  perturb_rot_deg:=2 perturb_trans_m:=0.2 estimate_stereo:=false >"$ROOT/build/rviz_screenshot.log" 2>&1 &
LAUNCH=$!
# Wait for the first overlay image, then let rviz draw a few more frames.
for _ in $(seq 60); do
  sleep 1
  timeout 2 rostopic echo -n 1 /tescalib_overlay/left/overlay/header >/dev/null 2>&1 && break
done
sleep "$WAIT"
/usr/bin/import -display "$DISPLAY_NUM" -window root "$OUT" && echo "[rviz] wrote $OUT"
