#!/usr/bin/env bash
# The catkin workspace route of the README, on its first configure: a fresh workspace whose src/
# holds this package (a symlink), configured by catkin_make in the environment of a fresh shell
# (no devel space sourced), and the package's Python messages generated; then, in the environment
# `catkin_make run_tests` runs the tests in (build/catkin_generated/env_cached.sh, catkin's
# snapshot of the configure), the messages must import from the workspace's devel space, as the
# rostests' Python clients (test/ros/test_example_clients.py) import them. catkin's snapshot takes
# only folders that exist on configure: CMakeLists.txt creates the devel space's Python folder
# first. Building and running every test in a workspace is what `catkin_make run_tests` does
# (README, "In a catkin workspace"); this checks the configure step that once broke it, in seconds.
# Usage: scripts/test_workspace.sh RESULT_XML   (the log goes beside it, RESULT_XML's name .log)
# The workspace is a temporary folder outside the package, removed at the end: inside it (below
# build/) rospack would find the package a second time through the workspace's symlink, and
# `roslaunch collision_response ...` in the tests running beside this one would refuse to choose.
set -uo pipefail
source_dir=$(cd "$(dirname "$0")/.." && pwd)
result=$1
mkdir -p "$(dirname "$result")"
log=${result%.xml}.log
work=$(mktemp -d "${TMPDIR:-/tmp}/collision_response_workspace.XXXXXX")
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/src"
: >"$log"

report() {  # report FAILURE_MESSAGE (empty: passed)
  local failure=""
  [ -n "$1" ] && failure="      <failure message=\"$1\">see $log</failure>"
  cat >"$result" <<XML
<?xml version="1.0" encoding="UTF-8"?>
<testsuites tests="1" failures="$([ -n "$1" ] && echo 1 || echo 0)" errors="0" name="workspace">
  <testsuite name="Workspace" tests="1" failures="$([ -n "$1" ] && echo 1 || echo 0)" errors="0">
    <testcase name="FirstConfigureFindsTheGeneratedMessages" classname="Workspace">
$failure
    </testcase>
  </testsuite>
</testsuites>
XML
  if [ -n "$1" ]; then
    echo "test_workspace: $1 (log: $log)" >&2
    tail -n 30 "$log" >&2
    exit 1
  fi
  echo "test_workspace: the first configure's environment imports the messages from $work/devel"
}

ln -s "$source_dir" "$work/src/collision_response"
ln -s /usr/share/catkin/cmake/toplevel.cmake "$work/src/CMakeLists.txt"  # catkin_init_workspace
# A fresh shell's environment: nothing of ROS or of this package's own build.
fresh=(env -i HOME="$HOME" LANG=C.UTF-8 PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin)
"${fresh[@]}" catkin_make -C "$work" -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCATKIN_ENABLE_TESTING=ON \
  collision_response_generate_messages_py >"$log" 2>&1 ||
  report "catkin_make failed to configure the workspace or generate the messages"
found=$("${fresh[@]}" "$work/build/catkin_generated/env_cached.sh" /usr/bin/python3 -c \
  'import collision_response.srv, collision_response.msg; print(collision_response.__file__)' 2>>"$log")
case "$found" in
  "$work/devel/"*) report "" ;;
  *) report "in the workspace's test environment the messages do not import from its devel space (${found:-no module})" ;;
esac
