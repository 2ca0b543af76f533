# Sourced by the scripts: the package's devel environment and a private ROS master port and log
# directory, so nothing here touches a ROS system already running on the machine.
set +u  # catkin's setup scripts read unset variables
# shellcheck disable=SC1091
source scripts/build_dirs.sh
# shellcheck disable=SC1091
source "$devel_dir/setup.bash"
set -u
# Debian's ROS Python programs (joint_state_publisher, rostopic, ...) start with
# "#!/usr/bin/env python3": they need Debian's interpreter (with rospy), not one first on PATH.
export PATH=/usr/bin:$PATH
free_port() { /usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }
export ROS_HOSTNAME=127.0.0.1
export ROS_HOME=${ROS_HOME:-$(mktemp -d /tmp/collision_response_ros.XXXXXX)}
export ROS_LOG_DIR=$ROS_HOME/log

# Processes the scripts start in the background; stop_all (the EXIT trap once a master is up)
# stops them.
ros_pids=()
stop_all() {
  for pid in "${ros_pids[@]}"; do kill -INT "$pid" 2>/dev/null || true; done
  wait 2>/dev/null || true
  ros_pids=()
}
# A private roscore on a free port (exports ROS_MASTER_URI); returns once it answers.
start_master() {
  local port
  port=$(free_port)
  export ROS_MASTER_URI=http://127.0.0.1:$port
  roscore -p "$port" >"$ROS_HOME/roscore.out" 2>&1 &
  ros_pids+=($!)
  trap stop_all EXIT
  for _ in $(seq 1 100); do rosparam list >/dev/null 2>&1 && return 0; sleep 0.1; done
  echo "roscore did not come up; its output:" >&2
  cat "$ROS_HOME/roscore.out" >&2
  return 1
}
# launch/collision_response.launch, or launch/$LAUNCH_FILE (extra args: roslaunch args); returns once
# the service is up.
launch_node() {
  roslaunch --wait collision_response "${LAUNCH_FILE:-collision_response.launch}" "$@" >"$ROS_HOME/node.out" 2>&1 &
  ros_pids+=($!)
  for _ in $(seq 1 300); do
    rosservice list 2>/dev/null | grep -qx /collision_response/compute && return 0
    sleep 0.1
  done
  echo "the node did not come up; its output:" >&2
  cat "$ROS_HOME/node.out" >&2
  return 1
}
