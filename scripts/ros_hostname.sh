# Sourced by the scripts that start ROS nodes (ros_env.sh, run_tests.sh). ROS nodes advertise
# their XML-RPC servers under the machine's hostname unless ROS_HOSTNAME or ROS_IP says otherwise;
# where that hostname does not resolve (a container or chroot whose /etc/hosts lacks it) every
# node fails with "Unable to contact my own server". Everything here runs on this machine, so
# localhost is then used, and said.
if [ -z "${ROS_HOSTNAME:-}" ] && [ -z "${ROS_IP:-}" ] &&
  ! /usr/bin/python3 -c 'import socket; socket.gethostbyname(socket.gethostname())' 2>/dev/null; then
  echo "[ros] this machine's hostname ($(/usr/bin/python3 -c 'import socket; print(socket.gethostname())')) does not resolve: ROS_HOSTNAME=localhost"
  export ROS_HOSTNAME=localhost
fi
