#!/usr/bin/env bash
# Installs the Debian 12 packages the package needs (only those missing) and builds it into build/,
# with the devel space (source devel/setup.bash) in devel/ (scripts/build_dirs.sh says why).
# Environment: BUILD_DIR (default build), DEVEL_DIR, BUILD_TYPE (default Release), CMAKE_ARGS (extra).
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  build-essential cmake python3 python3-catkin-pkg catkin
  ros-core-dev ros-base-dev libroscpp-dev ros-message-generation rosbash
  libstd-msgs-dev libgeometry-msgs-dev libshape-msgs-dev python3-shape-msgs libsensor-msgs-dev python3-sensor-msgs libtf2-ros-dev python3-tf2-ros libtf2-eigen-dev libeigen3-dev libfcl-dev
  librostest-dev python3-rostest python3-rosservice python3-rostopic libgtest-dev
  python3-std-msgs python3-geometry-msgs libbenchmark-dev zlib1g-dev libceres-dev
  libnodelet-dev libnodeletlib-dev libnodeletlib-tools python3-nodelet pluginlib-dev
  libdynamic-reconfigure-config-init-mutex-dev python3-dynamic-reconfigure libdiagnostic-updater-dev
  libdiagnostic-msgs-dev libvisualization-msgs-dev python3-visualization-msgs librosbag-dev
  librosbag-storage-dev python3-rosbag python3-rospkg python3-matplotlib
  python3-diagnostic-msgs tf2-tools python3-tf2-msgs libtf2-msgs-dev
  liburdf-dev libkdl-parser-dev liborocos-kdl-dev libresource-retriever-dev libgeometric-shapes-dev
  ros-robot-state-publisher joint-state-publisher
)
scripts/install_packages.sh "${packages[@]}"

# roslaunch always starts its nodes on the machine named "localhost", and every ROS node announces
# itself under the machine's host name (unless ROS_HOSTNAME or ROS_IP say otherwise): both must
# resolve. Minimal roots (debootstrap, some containers) have no /etc/hosts entry for them; add
# them for the loopback address, as Debian's installer does for the host name.
add_host() {
  getent hosts "$1" >/dev/null && return 0
  echo "setup: adding '127.0.0.1 $1' to /etc/hosts (ROS nodes need their host name to resolve)"
  if [ "$(id -u)" -eq 0 ]; then echo "127.0.0.1 $1" >>/etc/hosts; else echo "127.0.0.1 $1" | sudo tee -a /etc/hosts >/dev/null; fi
}
add_host localhost
add_host "$(uname -n)"

source scripts/build_dirs.sh
# /usr/bin/python3: catkin needs Debian's python (with catkin_pkg), not one first on PATH.
cmake -S . -B "$build_dir" -DPYTHON_EXECUTABLE=/usr/bin/python3 \
  -DCATKIN_DEVEL_PREFIX="$(realpath -m "$devel_dir")" \
  -DCMAKE_BUILD_TYPE="${BUILD_TYPE:-Release}" ${CMAKE_ARGS:-} >/dev/null
log="$build_dir/build.log"
echo "setup: building in $build_dir (log: $log)"
make -C "$build_dir" -j"$(nproc)" --no-print-directory all "$@" >"$log" 2>&1 || {
  grep -E "error|Error" "$log" | head -n 40
  echo "setup: build failed, see $log" >&2
  exit 1
}
