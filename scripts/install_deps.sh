#!/usr/bin/env bash
# Idempotent, non-interactive install of everything tescalib needs, from Debian's archive only.
# Quick (a dpkg query) when everything is already present. With --dev (make test) also the
# developer tools the tests use: clang-format (Style.EveryCppFileIsClangFormatted) and catkin-lint
# (Package.CatkinLintFindsNoProblem).
set -euo pipefail
PKGS=(ros-core rosbash libnodeletlib-dev libnodeletlib-tools libtf2-ros-dev libtf2-eigen-dev
  libcv-bridge-dev libimage-transport-dev ros-stereo-msgs libstereo-msgs-dev
  ros-visualization-msgs libvisualization-msgs-dev libpcl-conversions-dev libceres-dev
  librosbag-dev python3-rostest librostest-dev libgtest-dev python3-stereo-msgs
  python3-visualization-msgs python3-geometry-msgs python3-sensor-msgs
  libdiagnostic-updater-dev python3-diagnostic-msgs libdiagnostic-msgs-dev rviz python3-tf2-msgs
  libstd-srvs-dev ros-std-srvs python3-std-srvs tf2-tools python3-rosgraph-msgs libyaml-cpp-dev
  libcli11-dev nlohmann-json3-dev cmake g++ make)
[ "${1:-}" = "--dev" ] && PKGS+=(clang-format catkin-lint)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "[deps] all ${#PKGS[@]} packages present"
  exit 0
fi
echo "[deps] installing ${#missing[@]} missing packages: ${missing[*]}"
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "[deps] done"
