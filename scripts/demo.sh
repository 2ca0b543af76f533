#!/usr/bin/env bash
# The main job, end to end: install and build if needed, start a private ROS master on a free port,
# launch the node, send the sample request (a box dropped on a table, landing on one corner),
# print a summary of the answer (--raw: the whole answer) and the published message, stop
# everything.
set -euo pipefail
cd "$(dirname "$0")/.."
raw=no
case "${1:-}" in
  --raw) raw=yes ;;
  "") ;;
  *) echo "usage: scripts/demo.sh [--raw]" >&2; exit 2 ;;
esac
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
rosservice call /collision_response/compute "$(cat scripts/sample_request.yaml)" >"$ROS_HOME/answer.yaml"
if [ "$raw" = yes ]; then
  cat "$ROS_HOME/answer.yaml"
else
  /usr/bin/python3 scripts/summarize_response.py "$ROS_HOME/answer.yaml" scripts/sample_request.yaml
fi
wait "$echo_pid" || true
echo "demo: published on /collision_response/responses ($(grep -c . "$ROS_HOME/published.out") lines, first lines):"
head -n 6 "$ROS_HOME/published.out"
echo "demo: the whole answer: scripts/demo.sh --raw"
