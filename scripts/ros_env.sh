# Sourced by the scripts that start ROS nodes (demo.sh, rviz_screenshot.sh): the package's devel
# space, ROS_HOME under build/, and its own master on a free port, so a roscore already running on
# this machine is left alone. Expects ROOT (the repository) to be set.
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
# shellcheck disable=SC1091
source "$ROOT/build/devel/setup.bash"
export ROS_HOME=${ROS_HOME:-$ROOT/build/ros_home}
ROS_PORT=$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("", 0)); print(s.getsockname()[1])')
export ROS_MASTER_URI=http://localhost:$ROS_PORT
# shellcheck disable=SC1091
source "$ROOT/scripts/ros_hostname.sh"
