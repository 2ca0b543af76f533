#!/usr/bin/env bash
# The robot demo, end to end: install and build if needed, start a private ROS master, launch
# launch/robot.launch (the shipped 7-DOF arm: URDF, joint_state_publisher holding it bent over a
# box on a table, robot_state_publisher, the node serving it as robot "arm"), send
# scripts/robot_request.yaml (the arm swinging down so that its fingertips strike the box: joint
# velocities only, positions from /joint_states, base from tf, contacts found from the URDF's
# collision geometry and the bodies' shapes), print a summary (--raw: the whole answer), stop
# everything.
set -euo pipefail
cd "$(dirname "$0")/.."
raw=no
case "${1:-}" in
  --raw) raw=yes ;;
  "") ;;
  *) echo "usage: scripts/robot_demo.sh [--raw]" >&2; exit 2 ;;
esac
scripts/setup.sh
source scripts/ros_env.sh

start_master
echo "robot demo: ROS master at $ROS_MASTER_URI"
LAUNCH_FILE=robot.launch launch_node
# The request takes the joint positions from /joint_states: wait for joint_state_publisher.
timeout 30 rostopic echo -n 1 /joint_states >/dev/null
echo "robot demo: calling /collision_response/compute with scripts/robot_request.yaml"
rosservice call /collision_response/compute "$(cat scripts/robot_request.yaml)" >"$ROS_HOME/answer.yaml"
if [ "$raw" = yes ]; then
  cat "$ROS_HOME/answer.yaml"
else
  /usr/bin/python3 scripts/summarize_robot_response.py "$ROS_HOME/answer.yaml"
fi
