#!/usr/bin/env bash
# The main job, end to end: install and build if needed, start a private ROS master on a free port,
# launch the node, send the sample request (a box dropped on a table, landing on one corner),
# print the answer and the published message, stop everything.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
source scripts/ros_env.sh

port=$(free_port)
export ROS_MASTER_URI=http://127.0.0.1:$port
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill -INT "$pid" 2>/dev/null || true; done
  wait 2>/dev/null || true
}
trap cleanup EXIT

echo "demo: ROS master on port $port"
roscore -p "$port" >"$ROS_HOME/roscore.out" 2>&1 &
pids+=($!)
roslaunch --wait collision_response collision_response.launch >"$ROS_HOME/node.out" 2>&1 &
pids+=($!)
for _ in $(seq 1 300); do
  rosservice list 2>/dev/null | grep -qx /collision_response/compute && break
  sleep 0.1
done
rosservice list 2>/dev/null | grep -qx /collision_response/compute || {
  echo "demo: the node did not come up; its output:" >&2
  cat "$ROS_HOME/node.out" >&2
  exit 1
}

rostopic echo -n 1 /collision_response/responses >"$ROS_HOME/published.out" 2>&1 &
echo_pid=$!
sleep 1  # let the subscriber connect before the call
echo "demo: calling /collision_response/compute with scripts/sample_request.yaml"
rosservice call /collision_response/compute "$(cat scripts/sample_request.yaml)"
wait "$echo_pid" || true
echo "demo: message published on /collision_response/responses:"
head -n 12 "$ROS_HOME/published.out"
echo "  ..."
