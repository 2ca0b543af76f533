# Sourced by the scripts: the package's devel environment and a private ROS master port and log
# directory, so nothing here touches a ROS system already running on the machine.
set +u  # catkin's setup scripts read unset variables
# shellcheck disable=SC1091
source "${BUILD_DIR:-build}/devel/setup.bash"
set -u
free_port() { /usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }
export ROS_HOSTNAME=127.0.0.1
export ROS_HOME=${ROS_HOME:-$(mktemp -d /tmp/collision_response_ros.XXXXXX)}
export ROS_LOG_DIR=$ROS_HOME/log
