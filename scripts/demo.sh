#!/usr/bin/env bash
# The main job, end to end: install and build if needed, start a private ROS master on a free port,
# launch the node, send the sample request (a box dropped on a table, landing on one corner),
# print a summary of the answer (--raw: the whole answer) and the published message, stop
# everything.
# --robot: the robot demo instead (scripts/robot_demo.sh): launch/robot.launch (the shipped 7-DOF
# arm: URDF, joint_state_publisher holding it bent over a box on a table, robot_state_publisher,
# the node serving it as robot "arm") and scripts/robot_request.yaml (the arm swinging down so that
# its fingertips strike the box: joint velocities only, positions from /joint_states, base from tf,
# contacts found from the URDF's collision geometry and the bodies' shapes).
# --episode: the whole collision instead of one impact: ~compute_episode with
# scripts/episode_request.yaml (a cube dropped at an angle onto a table, under gravity), printing
# each impact (time, contacts, impulses) and how the episode ended (scripts/summarize_episode.py),
# and what was published on ~episodes.
set -euo pipefail
cd "$(dirname "$0")/.."
raw=no
robot=no
episode=no
for arg in "$@"; do
  case "$arg" in
    --raw) raw=yes ;;
    --robot) robot=yes ;;
    --episode) episode=yes ;;
    *) echo "usage: scripts/demo.sh [--robot | --episode] [--raw]" >&2; exit 2 ;;
  esac
done
if [ "$robot" = yes ] && [ "$episode" = yes ]; then
  echo "demo: --robot and --episode do not combine (the robot demo asks for one impact; ~compute_episode takes robots: docs/robots.md, \"Robots in episodes\")" >&2
  exit 2
fi
scripts/setup.sh
source scripts/ros_env.sh

start_master
echo "demo: ROS master at $ROS_MASTER_URI"
if [ "$robot" = yes ]; then
  LAUNCH_FILE=robot.launch launch_node
  # The request takes the joint positions from /joint_states: wait for joint_state_publisher.
  timeout 30 rostopic echo -n 1 /joint_states >/dev/null ||
    { echo "demo: nothing on /joint_states after 30 s (joint_state_publisher: $ROS_HOME/log)" >&2; exit 1; }
  request=scripts/robot_request.yaml
elif [ "$episode" = yes ]; then
  launch_node
  timeout 30 rostopic echo -n 1 /collision_response/episodes >"$ROS_HOME/published.out" 2>&1 &
  echo_pid=$!
  ros_pids+=("$echo_pid")
  sleep 1  # let the subscriber connect before the call
  request=scripts/episode_request.yaml
  echo "demo: calling /collision_response/compute_episode with $request"
  rosservice call /collision_response/compute_episode "$(cat "$request")" >"$ROS_HOME/answer.yaml"
  if [ "$raw" = yes ]; then
    cat "$ROS_HOME/answer.yaml"
  else
    /usr/bin/python3 scripts/summarize_episode.py "$ROS_HOME/answer.yaml" "$request"
  fi
  wait "$echo_pid" || echo "demo: nothing received on /collision_response/episodes within 30 s"
  echo "demo: published on /collision_response/episodes ($(grep -c . "$ROS_HOME/published.out") lines)"
  echo "demo: the whole answer: scripts/demo.sh --episode --raw"
  exit 0
else
  launch_node
  timeout 30 rostopic echo -n 1 /collision_response/responses >"$ROS_HOME/published.out" 2>&1 &
  echo_pid=$!
  ros_pids+=("$echo_pid")
  sleep 1  # let the subscriber connect before the call
  request=scripts/sample_request.yaml
fi
echo "demo: calling /collision_response/compute with $request"
rosservice call /collision_response/compute "$(cat "$request")" >"$ROS_HOME/answer.yaml"
if [ "$raw" = yes ]; then
  cat "$ROS_HOME/answer.yaml"
elif [ "$robot" = yes ]; then
  /usr/bin/python3 scripts/summarize_robot_response.py "$ROS_HOME/answer.yaml"
else
  /usr/bin/python3 scripts/summarize_response.py "$ROS_HOME/answer.yaml" "$request"
fi
[ "$robot" = yes ] && exit 0
wait "$echo_pid" || echo "demo: nothing received on /collision_response/responses within 30 s"
echo "demo: published on /collision_response/responses ($(grep -c . "$ROS_HOME/published.out") lines, first lines):"
head -n 6 "$ROS_HOME/published.out"
echo "demo: the whole answer: scripts/demo.sh --raw"
