#!/usr/bin/env bash
# Renders what config/collision_response.rviz shows into docs/markers.png, headlessly: a private ROS
# master, the node, RViz under Xvfb (software OpenGL), scripts/marker_demo_request.yaml sent in a
# loop, a screenshot of the virtual screen (xwd), cropped to the 3D view. Installs rviz, xvfb, xauth,
# x11-apps and python3-pil if missing. GALLIUM_DRIVER (default llvmpipe), RVIZ_ARGS: passed on.
# --robot: the robot demo instead (launch/robot.launch, config/robot.rviz with the arm's model,
# scripts/robot_request.yaml) into docs/robot_markers.png.
#   scripts/render_markers.sh [--robot] [OUTPUT.png]
set -euo pipefail
cd "$(dirname "$0")/.."
# Only this script needs them (not the build or the tests).
scripts/install_packages.sh rviz xvfb xauth x11-apps python3-pil
scripts/setup.sh
source scripts/ros_env.sh
rviz_config=config/collision_response.rviz
request_file=scripts/marker_demo_request.yaml
output=docs/markers.png
if [ "${1:-}" = --robot ]; then
  shift
  export LAUNCH_FILE=robot.launch
  rviz_config=config/robot.rviz
  request_file=scripts/robot_request.yaml
  output=docs/robot_markers.png
fi
output=${1:-$output}
mkdir -p "$(dirname "$output")"

start_master
launch_node

display=:$((90 + RANDOM % 100))
Xvfb "$display" -screen 0 1280x800x24 >"$ROS_HOME/xvfb.out" 2>&1 &
ros_pids+=($!)
sleep 2
DISPLAY=$display LIBGL_ALWAYS_SOFTWARE=1 GALLIUM_DRIVER=${GALLIUM_DRIVER:-llvmpipe} rviz -d "$rviz_config" ${RVIZ_ARGS:-} \
  >"$ROS_HOME/rviz.out" 2>&1 &
ros_pids+=($!)

# Send the request twice a second while RViz starts and subscribes (markers go to subscribers only).
[ -n "${LAUNCH_FILE:-}" ] && timeout 30 rostopic echo -n 1 /joint_states >/dev/null  # robot demo
request=$(cat "$request_file")
for _ in $(seq 1 12); do
  rosservice call /collision_response/compute "$request" >/dev/null
  sleep 0.5
done
DISPLAY=$display xwd -root -silent >"$ROS_HOME/screen.xwd"
/usr/bin/python3 scripts/xwd_to_png.py "$ROS_HOME/screen.xwd" "$output"
echo "render_markers: wrote $output"
