#!/usr/bin/env bash
# The benchmark of the README, end to end: installs what it needs, builds (Release, portable flags)
# into build/ (or $BUILD_DIR) with the benchmark targets, then runs
#   1. Google Benchmark micro figures (bench_solvers)          -> benchmark/data/micro.json
#   2. the accuracy sweep, ours and the peers Bullet, ODE and Simbody -> benchmark/data/results.csv
#      the robot: bench_robot (Google Benchmark)                -> benchmark/data/robot.json
#      and robot_compare (ours and DART on the same impact)     -> benchmark/data/robot_dart.csv
#      the real tosses (real_tosses: every landing model fitted and scored on the cube tosses of
#      benchmark/data/cube_tosses)                             -> benchmark/data/real_tosses.md
#   3. the service load (private ROS master on a free port; rigid bodies, and the shipped arm
#      striking a box)                                          -> benchmark/data/service_load.csv
#      and the soak: the load rostest at 10x                    -> benchmark/data/service_soak.txt
#   4. benchmark/report.py                                      -> benchmark/RESULTS.md, pareto.png
# Environment: BUILD_DIR (default build), SWEEP_REPS (default 31), LOAD_CALLS (default 2000).
# scripts/benchmark.sh --robots: only the robot figures (builds bench_robot and robot_compare in an
# already configured build dir, runs them, and updates just the robot rows and the Robots section
# of benchmark/RESULTS.md with report.py --robots-only).
set -euo pipefail
cd "$(dirname "$0")/.."
start=$(date +%s)
out=benchmark/data  # generated inputs of the report (not committed)

robot_figures() {
  echo "benchmark: robot (bench_robot; robot_compare: ours and DART) -> $out/robot.json, $out/robot_dart.csv"
  "$bin/bench_robot" --benchmark_repetitions=9 --benchmark_min_time=0.1 \
    --benchmark_out="$out/robot.json" --benchmark_out_format=json >"$build_dir/robot.txt" 2>&1
  "$bin/robot_compare" --out "$out/robot_dart.csv" >"$build_dir/robot_compare.txt" 2>&1
}

if [ "${1:-}" = "--robots" ]; then
  scripts/install_packages.sh libbenchmark-dev libdart-dev libdart-utils-urdf-dev
  source scripts/build_dirs.sh
  [ -f "$build_dir/CMakeCache.txt" ] || { echo "benchmark: configure $build_dir first (scripts/benchmark.sh)" >&2; exit 1; }
  cmake "$build_dir" -DCOLLISION_RESPONSE_BENCHMARKS=ON >/dev/null
  make -C "$build_dir" -j"$(nproc)" --no-print-directory bench_robot robot_compare \
    >"$build_dir/build.log" 2>&1 || { tail -n 30 "$build_dir/build.log"; exit 1; }
  bin=$devel_dir/lib/collision_response
  mkdir -p "$out"
  robot_figures
  /usr/bin/python3 benchmark/report.py --dir benchmark --data "$out" --robots-only \
    --command "${BUILD_DIR:+BUILD_DIR=$BUILD_DIR }scripts/benchmark.sh --robots"
  echo "benchmark: robots done in $(($(date +%s) - start)) s"
  exit 0
fi

fresh=$([ -d "${BUILD_DIR:-build}" ] && echo no || echo yes)
scripts/install_packages.sh libbenchmark-dev libbullet-dev libode-dev pkg-config python3-matplotlib \
  libdart-dev libdart-utils-urdf-dev libsimbody-dev libmujoco-dev zlib1g-dev
CMAKE_ARGS="-DCOLLISION_RESPONSE_BENCHMARKS=ON ${CMAKE_ARGS:-}" scripts/setup.sh
build_s=$(($(date +%s) - start))
source scripts/build_dirs.sh
bin=$devel_dir/lib/collision_response
mkdir -p "$out"

echo "benchmark: micro figures (Google Benchmark) -> $out/micro.json"
"$bin/bench_solvers" --benchmark_repetitions=9 --benchmark_min_time=0.1 \
  --benchmark_out="$out/micro.json" \
  --benchmark_out_format=json >"$build_dir/micro.txt"

echo "benchmark: accuracy sweep (ours, Bullet, ODE, Simbody) -> $out/results.csv"
"$bin/accuracy_sweep" --out "$out/results.csv" --reps "${SWEEP_REPS:-31}"

robot_figures

if [ -x "$bin/real_tosses" ]; then
  echo "benchmark: real tosses (every landing model fitted on the even tosses, scored on the odd) -> $out/real_tosses.md"
  "$bin/real_tosses" --markdown "$out/real_tosses.md" >"$build_dir/real_tosses.txt"
fi

echo "benchmark: service load -> $out/service_load.csv"
source scripts/ros_env.sh
start_master
rosparam load config/collision_response.yaml /collision_response
# The robot rows: the shipped arm as robot "arm" (config/robot.yaml), its base at the world origin;
# service_load publishes its joint states itself.
rosparam set -t urdf/arm7.urdf /robot_description
rosparam load config/robot.yaml /collision_response
rosrun tf2_ros static_transform_publisher 0 0 0 0 0 0 world base_link >"$ROS_HOME/tf.out" 2>&1 &
ros_pids+=($!)
"$bin/collision_response_node" __name:=collision_response >"$ROS_HOME/node.out" 2>&1 &
node_pid=$!
ros_pids+=("$node_pid")
"$bin/service_load" --calls "${LOAD_CALLS:-2000}" --out "$out/service_load.csv" \
  --node-pid "$node_pid"
stop_all

echo "benchmark: soak (the load rostest at 10x: 4 clients, 40,000 mixed calls) -> $out/service_soak.txt"
make -C "$build_dir" --no-print-directory tests >/dev/null
CR_LOAD_SCALE=10 rostest --text collision_response load.test >"$build_dir/soak.log" 2>&1 || {
  tail -n 30 "$build_dir/soak.log"
  echo "benchmark: the soak failed" >&2
  exit 1
}
grep -E "^load: " "$build_dir/soak.log" >"$out/service_soak.txt"

elapsed=$(($(date +%s) - start))
echo "benchmark: report -> benchmark/RESULTS.md, benchmark/pareto.png"
/usr/bin/python3 benchmark/report.py --dir benchmark --data "$out" \
  --command "${BUILD_DIR:+BUILD_DIR=$BUILD_DIR }scripts/benchmark.sh (fresh build dir: ${fresh})" \
  --elapsed "$elapsed" --build-seconds "$build_s"
echo "benchmark: done in $(($(date +%s) - start)) s"
