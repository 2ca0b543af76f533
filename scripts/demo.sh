#!/usr/bin/env bash
# The main job, end to end: install and build if needed, start a private ROS master on a free port,
# launch the node, send the sample request (a box dropped on a table, landing on one corner),
# print the answer and the published message, stop everything.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
source scripts/ros_env.sh

start_master
echo "demo: ROS master at $ROS_MASTER_URI"
launch_node

rostopic echo -n 1 /collision_response/responses >"$ROS_HOME/published.out" 2>&1 &
echo_pid=$!
ros_pids+=("$echo_pid")
sleep 1  # let the subscriber connect before the call
echo "demo: calling /collision_response/compute with scripts/sample_request.yaml"
rosservice call /collision_response/compute "$(cat scripts/sample_request.yaml)"
wait "$echo_pid" || true
echo "demo: message published on /collision_response/responses:"
head -n 12 "$ROS_HOME/published.out"
echo "  ..."
