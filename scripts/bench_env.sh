# Sourced by the make bench scripts: pipefail, the project's root (ROOT), the build's ROS
# environment, the KITTI frames (K) and the folder of the results (OUT, created).
set -o pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
source "$ROOT/build/devel/setup.bash"
K=$ROOT/../shared/data/kitti_odometry_mini/sequences
OUT=$ROOT/build/bench
mkdir -p "$OUT"
