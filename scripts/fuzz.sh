#!/usr/bin/env bash
# Fuzzes the request paths with libFuzzer, AddressSanitizer and UndefinedBehaviorSanitizer, one
# target after the other, no ROS master, no catkin (clang-14):
#  - core:  test/fuzz/fuzz_compute_response.cpp, rigid-body requests through core::computeResponse
#           (src/core, src/detection); inputs decoded by test/fuzz/scene_decoder.h.
#  - robot: test/fuzz/fuzz_robot_request.cpp, what robot users send (a URDF, generated or given
#           as text, with <mimic> tags; a ~robots entry; joint-state messages; a RobotState with
#           locked joints, base pose and twist, gravity and torques; contacts on links) through
#           the node's robot path (ServedRobot, robotAtRequestState(), core::computeBodyResponse(),
#           toMsg(), the outcome distribution and the derivatives by the joint positions; src/core,
#           src/detection, src/robot and the ROS-free part of src/ros, with the
#           messages' headers generated here by gencpp); inputs decoded by test/fuzz/robot_decoder.h.
#  - episode: test/fuzz/fuzz_episode.cpp, impact episodes (bodies with boxes, spheres, cylinders,
#           cones, small meshes and planes, materials, gravity, horizon, impact cap, contact
#           tolerance, a 0.05 s time budget) through detection::ShapeGaps and core::computeEpisode
#           as ~compute_episode calls them; inputs decoded by test/fuzz/episode_decoder.h.
#  - identify: test/fuzz/fuzz_identify_inputs.cpp, the identify program's inputs (an object file
#           and a CSV recording) through calibration::parseObjectModel, readCsvTracks and
#           extractLandings (src/calibration, no Ceres); inputs split by
#           test/fuzz/identify_inputs_check.h; its seeds also committed in test/fuzz/corpus/identify/.
#  - robot_episode: test/fuzz/fuzz_robot_episode.cpp, impact episodes with a robot (a URDF, given
#           as text or generated, its joint positions, velocities, base pose, gravity and torque
#           model; rigid bodies with shapes; the episode's options, a 0.05 s time budget) through
#           the path of ~compute_episode with `robots` (ServedRobot, robotAtRequestState(), the
#           links' geometry in detection::ShapeGaps, RobotEpisodeBody, core::computeBodyEpisode(),
#           toMsg()); inputs decoded by test/fuzz/robot_episode_decoder.h (which reuses
#           robot_decoder.h's URDFs and joint states and episode_decoder.h's world and options).
# Each target seeds its corpus with inputs it writes itself (the robot target from the package's
# URDFs, test/robot/*.urdf and urdf/arm7.urdf, and generated ones), and fuzzes for its share of the
# time and runs. Exits non-zero if libFuzzer finds a crash, a sanitizer report, an unexpected
# exception or a non-finite answer.
#
#   scripts/fuzz.sh                      fuzz every target of FUZZ_TARGETS
#   scripts/fuzz.sh --replay PATH...     run the given inputs (files or directories) once each, on
#                                        the robot target if a path is one of its (crash files
#                                        robot-crash-*, corpus-robot/, test/fuzz/regressions/robot/),
#                                        on the episode target if it is one of the episode's
#                                        (episode-crash-*, corpus-episode/,
#                                        test/fuzz/regressions/episode/), on the robot_episode
#                                        target if it is one of its (robot_episode-crash-*,
#                                        corpus-robot_episode/, test/fuzz/corpus/robot_episode/,
#                                        test/fuzz/regressions/robot_episode/), on the identify
#                                        target if it is one of the identify target's
#                                        (identify-crash-*, corpus-identify/,
#                                        test/fuzz/regressions/identify/), on the core target
#                                        otherwise (FUZZ_TARGETS overrides)
#
# Environment: BUILD_DIR (default build-fuzz; corpora, crash artifacts and logs live there, out of
# git), FUZZ_TARGETS (default "core robot episode robot_episode identify"), FUZZ_SECONDS (default
# 120: the time cap of the whole run, split between the targets by the shares below), FUZZ_RUNS
# (the executions of the whole run, split likewise; unset: no cap), FUZZ_ROBOT_SHARE and
# FUZZ_ROBOT_RUNS_SHARE (the robot target's share of the time and of the runs, in percent; default
# 38 and 24), FUZZ_EPISODE_SHARE and FUZZ_EPISODE_RUNS_SHARE (the episode target's; default 21 and
# 3), FUZZ_ROBOT_EPISODE_SHARE and FUZZ_ROBOT_EPISODE_RUNS_SHARE (the robot_episode target's;
# default 6 and 2; the core target has the rest of each; the shares of the targets run are scaled
# to the whole), FUZZ_IDENTIFY_SECONDS and FUZZ_IDENTIFY_RUNS (the identify target's own budget, on
# top of FUZZ_SECONDS and FUZZ_RUNS, which it does not share unless it is the only target; default
# 60 s and 10000 runs: about 20 s under the sanitizers), FUZZ_SEED (libFuzzer's -seed; default 0, a new random seed each run: with a
# fixed seed and FUZZ_RUNS, and an empty corpus, a run is reproducible, as CI's is), FUZZ_ARGS
# (extra libFuzzer flags), FUZZ_PRINT=1 (print each decoded request and its outcome; useful with
# --replay), FUZZ_SKIP_EXTREME=1 (core target: excuse non-finite answers to requests holding finite
# but extreme magnitudes, |x| > 1e20 or < 1e-20: a known overflow class; set it to look past it).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

mode=fuzz
replay=()
if [ "${1:-}" = "--replay" ]; then
  shift
  [ $# -gt 0 ] || { echo "usage: scripts/fuzz.sh --replay FILE_OR_DIR..." >&2; exit 2; }
  mode=replay
  replay=("$@")
elif [ $# -gt 0 ]; then
  echo "usage: scripts/fuzz.sh [--replay FILE_OR_DIR...]" >&2
  exit 2
fi

targets=${FUZZ_TARGETS:-core robot episode robot_episode identify}
if [ "$mode" = replay ] && [ -z "${FUZZ_TARGETS:-}" ]; then
  case "${replay[*]}" in
    *robot_episode*) targets=robot_episode ;;
    */robot-* | robot-* | *regressions/robot* | *-robot*) targets=robot ;;
    */episode-* | episode-* | *regressions/episode* | *-episode*) targets=episode ;;
    */identify-* | identify-* | *regressions/identify* | *-identify* | *corpus/identify*) targets=identify ;;
    *) targets=core ;;
  esac
fi
want_robot=false
case " $targets " in *" robot "* | *" robot_episode "*) want_robot=true ;; esac

# The core target links the detection library's sources too (the request path can detect contacts),
# and with them FCL; the robot target KDL, urdf, resource_retriever and geometric_shapes (the links'
# collision geometry), and the headers of the ROS messages it uses (generated below).
packages=(clang-14 libclang-rt-14-dev libeigen3-dev libfcl-dev zlib1g-dev)
if $want_robot; then
  packages+=(liborocos-kdl-dev libkdl-parser-dev liburdf-dev libresource-retriever-dev
    libgeometric-shapes-dev libroscpp-core-dev libroslib-dev libconsole-bridge-dev python3-gencpp
    libstd-msgs-dev libgeometry-msgs-dev libsensor-msgs-dev libshape-msgs-dev ros-std-msgs
    ros-geometry-msgs ros-sensor-msgs ros-shape-msgs)
fi
scripts/install_packages.sh "${packages[@]}"

build_dir=${BUILD_DIR:-build-fuzz}
mkdir -p "$build_dir/obj"
build_dir=$(cd "$build_dir" && pwd)
flags=(-std=c++17 -fsanitize=address,undefined -fno-sanitize-recover=undefined
  -fno-omit-frame-pointer -O1 -g)
includes=(-Iinclude -I"$build_dir/gen" -isystem /usr/include/eigen3)
cxx=(clang++-14)
command -v ccache >/dev/null && cxx=(ccache clang++-14)

# The messages' C++ headers (what catkin's generate_messages() writes to devel/include), from
# msg/ and srv/ with gencpp.
if $want_robot; then
  gen="$build_dir/gen/collision_response"
  if [ ! -f "$gen/RobotState.h" ] || [ -n "$(find msg srv -newer "$gen/RobotState.h" -type f -print -quit)" ]; then
    mkdir -p "$gen"
    for file in msg/*.msg srv/*.srv; do
      /usr/bin/python3 /usr/lib/gencpp/gen_cpp.py "$file" -Icollision_response:msg \
        -Istd_msgs:/usr/share/std_msgs/msg -Igeometry_msgs:/usr/share/geometry_msgs/msg \
        -Ishape_msgs:/usr/share/shape_msgs/msg -Isensor_msgs:/usr/share/sensor_msgs/msg \
        -p collision_response -o "$gen" -e /usr/share/gencpp >/dev/null
    done
  fi
fi

# Objects of the library sources (fuzzer-instrumented, shared by the targets), rebuilt when the
# source or any header is newer; then each target linked with its main source.
compile() {  # source -> object; prints the object
  local source=$1 object headers=(include)
  object="$build_dir/obj/$(echo "$source" | tr / _).o"
  case "$source" in
    test/fuzz/*) headers+=(test/fuzz "$build_dir/gen") ;;
    src/ros/*) headers+=("$build_dir/gen") ;;
  esac
  if [ ! -f "$object" ] || [ "$source" -nt "$object" ] ||
    [ -n "$(find "${headers[@]}" -newer "$object" -type f -print -quit 2>/dev/null)" ]; then
    echo "$source" >>"$build_dir/compile.list"
  fi
  echo "$object"
}
core_sources=(src/core/*.cpp src/detection/*.cpp)
# What identify reads before it fits: the object file, the CSV recordings, the landings.
identify_sources=(src/calibration/csv_lines.cpp src/calibration/csv_tracks.cpp src/calibration/flight_fit.cpp
  src/calibration/landing_extraction.cpp src/calibration/object_file.cpp
  src/calibration/object_model.cpp src/calibration/simple_yaml.cpp src/calibration/stl_file.cpp)
robot_libs=(-lfcl -lccd -lorocos-kdl -lkdl_parser -lurdf -lurdfdom_model -lresource_retriever
  -lgeometric_shapes -lroslib -lrostime -lroscpp_serialization -lconsole_bridge)
robot_sources=(src/robot/*.cpp src/ros/message_conversion.cpp src/ros/joint_state_cache.cpp
  src/ros/served_robot.cpp src/ros/robot_conversion.cpp src/ros/robot_geometry.cpp)
build_target() {  # name main-source sources... -- libraries...
  local name=$1 main=$2 target="$build_dir/$1"
  shift 2
  local sources=() libs=() objects=()
  while [ $# -gt 0 ] && [ "$1" != "--" ]; do sources+=("$1"); shift; done
  [ $# -gt 0 ] && shift
  libs=("$@")
  rm -f "$build_dir/compile.list"
  for source in "${sources[@]}" "$main"; do objects+=("$(compile "$source")"); done
  if [ -f "$build_dir/compile.list" ] || [ ! -x "$target" ]; then
    echo "fuzz: building $target"
    if [ -f "$build_dir/compile.list" ]; then
      # Two at a time (the machines that run this have two cores).
      # shellcheck disable=SC2016
      xargs -P 2 -I{} sh -c 'exec "$@" -c {} -o "$0/obj/$(echo {} | tr / _).o"' "$build_dir" \
        "${cxx[@]}" -fsanitize=fuzzer-no-link "${flags[@]}" "${includes[@]}" \
        <"$build_dir/compile.list" 2>"$build_dir/build.log" || {
        head -n 40 "$build_dir/build.log"
        echo "fuzz: build failed, see $build_dir/build.log" >&2
        exit 1
      }
    fi
    clang++-14 -fsanitize=fuzzer "${flags[@]}" "${objects[@]}" "${libs[@]}" -o "$target.tmp" \
      2>"$build_dir/link.log" || {
      head -n 40 "$build_dir/link.log"
      echo "fuzz: linking $target failed, see $build_dir/link.log" >&2
      exit 1
    }
    mv "$target.tmp" "$target"
  fi
}
for name in $targets; do
  case "$name" in
    core)
      build_target fuzz_compute_response test/fuzz/fuzz_compute_response.cpp "${core_sources[@]}" \
        -- -lfcl -lccd
      ;;
    episode)
      build_target fuzz_episode test/fuzz/fuzz_episode.cpp "${core_sources[@]}" -- -lfcl -lccd
      ;;
    identify)
      build_target fuzz_identify_inputs test/fuzz/fuzz_identify_inputs.cpp "${identify_sources[@]}" \
        -- -lz
      ;;
    robot)
      build_target fuzz_robot_request test/fuzz/fuzz_robot_request.cpp "${core_sources[@]}" \
        "${robot_sources[@]}" -- "${robot_libs[@]}"
      ;;
    robot_episode)
      build_target fuzz_robot_episode test/fuzz/fuzz_robot_episode.cpp "${core_sources[@]}" \
        "${robot_sources[@]}" src/ros/episode_conversion.cpp -- "${robot_libs[@]}"
      ;;
    *)
      echo "fuzz: unknown target '$name' in FUZZ_TARGETS (core, robot, episode, robot_episode, identify)" >&2
      exit 2
      ;;
  esac
done

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:symbolize=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
# Third-party leaks only (urdfdom on URDFs whose joints form a loop): test/fuzz/lsan.supp.
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$root/test/fuzz/lsan.supp:print_suppressions=0}
# package:// mesh URLs of the URDFs (urdf/arm7.urdf's hand) resolve to this package only.
export ROS_PACKAGE_PATH="$root"
artifacts="$build_dir/artifacts"
mkdir -p "$artifacts"

executable() {
  case "$1" in
    core) echo "$build_dir/fuzz_compute_response" ;;
    robot) echo "$build_dir/fuzz_robot_request" ;;
    episode) echo "$build_dir/fuzz_episode" ;;
    identify) echo "$build_dir/fuzz_identify_inputs" ;;
    robot_episode) echo "$build_dir/fuzz_robot_episode" ;;
  esac
}

if [ "$mode" = replay ]; then
  files=()
  for path in "${replay[@]}"; do
    if [ -d "$path" ]; then
      while IFS= read -r -d '' file; do files+=("$file"); done < <(find "$path" -maxdepth 1 -type f ! -name '.*' ! -name '*.md' -print0 | sort -z)
    elif [ -f "$path" ]; then
      files+=("$path")
    else
      echo "fuzz: no such file or directory: $path" >&2
      exit 2
    fi
  done
  [ ${#files[@]} -gt 0 ] || { echo "fuzz: nothing to replay" >&2; exit 2; }
  echo "fuzz: replaying ${#files[@]} input(s) on the $targets target"
  # Given files (not directories), libFuzzer runs each once and stops at the first failure.
  # shellcheck disable=SC2086
  "$(executable "$targets")" -timeout=10 -rss_limit_mb=2048 ${FUZZ_ARGS:-} "${files[@]}"
  echo "fuzz: replay passed"
  exit 0
fi

count() { find "$1" -maxdepth 1 -type f | wc -l; }
total_seconds=${FUZZ_SECONDS:-120}
# A robot input costs many core inputs (a URDF parsed, a KDL tree built, meshes read), and an
# episode input far more (a flight stepped, gaps queried at every step, impacts solved; up to its
# 0.05 s time budget, and under the sanitizers about 20 inputs a second), so the robot target gets
# a quarter of the runs in 38 % of the time, the episode target 3 % of the runs in 21 % of the
# time, the robot episode target (a robot's forward dynamics at every step besides; about 50 inputs
# a second under the sanitizers) 2 % of the runs in 6 % of the time, the core target the rest (CI:
# 29,110 core, 9,840 robot, 1,230 episode and 820 robot episode runs in 136, 148, 81 and 23 s at
# most).
robot_share=${FUZZ_ROBOT_SHARE:-38}
robot_runs_share=${FUZZ_ROBOT_RUNS_SHARE:-24}
episode_share=${FUZZ_EPISODE_SHARE:-21}
episode_runs_share=${FUZZ_EPISODE_RUNS_SHARE:-3}
robot_episode_share=${FUZZ_ROBOT_EPISODE_SHARE:-6}
robot_episode_runs_share=${FUZZ_ROBOT_EPISODE_RUNS_SHARE:-2}
target_count=$(echo $targets | wc -w)
# The targets that share FUZZ_SECONDS and FUZZ_RUNS (identify has its own budget beside them).
sharing=$(echo $targets | tr ' ' '\n' | grep -vx identify | tr '\n' ' ' || true)
sharing_count=$(echo $sharing | wc -w)
status=0
core_share=$((100 - robot_share - episode_share - robot_episode_share))
core_runs_share=$((100 - robot_runs_share - episode_runs_share - robot_episode_runs_share))
shareOf() {  # target -> "time-share runs-share" in percent, of the whole
  case "$1" in
    robot) echo "$robot_share $robot_runs_share" ;;
    episode) echo "$episode_share $episode_runs_share" ;;
    robot_episode) echo "$robot_episode_share $robot_episode_runs_share" ;;
    *) echo "$core_share $core_runs_share" ;;
  esac
}
# The shares of the targets run, scaled so that they split the whole time and runs.
share_sum=0 runs_share_sum=0
for name in $sharing; do
  read -r s r < <(shareOf "$name")
  share_sum=$((share_sum + s)) runs_share_sum=$((runs_share_sum + r))
done
for name in $targets; do
  # This target's share of the time and of the runs (all of them for a single target).
  share=100 runs_share=100
  if [ "$name" != identify ] && [ "$sharing_count" -gt 1 ]; then
    read -r share runs_share < <(shareOf "$name")
    share=$((share * 100 / share_sum)) runs_share=$((runs_share * 100 / runs_share_sum))
  fi
  seconds=$((total_seconds * share / 100))
  runs=-1
  [ -n "${FUZZ_RUNS:-}" ] && runs=$((FUZZ_RUNS * runs_share / 100))
  if [ "$name" = identify ] && [ "$target_count" -gt 1 ]; then
    seconds=${FUZZ_IDENTIFY_SECONDS:-60} runs=${FUZZ_IDENTIFY_RUNS:-10000}
  fi
  target=$(executable "$name")
  # Seeds: valid, solvable inputs the target finds itself, rewritten each run; the corpus grows
  # across runs.
  seeds="$build_dir/seeds-$name"
  corpus="$build_dir/corpus-$name"
  [ "$name" = core ] && corpus="$build_dir/corpus"  # where earlier runs kept it
  rm -rf "$seeds"
  mkdir -p "$seeds" "$corpus"
  FUZZ_SEED_URDFS="$(ls test/robot/*.urdf urdf/arm7.urdf | tr '\n' ':')" FUZZ_EMIT_SEEDS="$seeds" \
    "$target" >"$build_dir/seeds-$name.log" 2>&1 || {
    tail -n 40 "$build_dir/seeds-$name.log"
    echo "fuzz: $name: writing the seeds failed (a bug on a seed input?), see $build_dir/seeds-$name.log" >&2
    exit 1
  }
  # A committed seed corpus (test/fuzz/corpus/<target>/), read as seeds too.
  committed=()
  [ -d "test/fuzz/corpus/$name" ] && committed=("test/fuzz/corpus/$name")
  log="$build_dir/fuzz-$name.log"
  prefix="$artifacts/"
  [ "$name" = robot ] && prefix="$artifacts/robot-"
  [ "$name" = episode ] && prefix="$artifacts/episode-"
  [ "$name" = robot_episode ] && prefix="$artifacts/robot_episode-"
  [ "$name" = identify ] && prefix="$artifacts/identify-"
  # The identify target's inputs are text (an object file and a CSV recording): room for a
  # recording.
  target_flags=()
  [ "$name" = identify ] && target_flags=(-max_len=16384)
  echo "fuzz: $name: $(count "$seeds") seeds, corpus $corpus ($(count "$corpus") inputs), ${seconds} s at most, $([ "$runs" -ge 0 ] && echo "$runs" || echo unlimited) runs, seed ${FUZZ_SEED:-random} (log: $log)"
  target_status=0
  # Inputs slower than 3 s are saved as ${prefix}slow-unit-* (not a failure; worth a look).
  # shellcheck disable=SC2086
  "$target" -max_total_time="$seconds" -runs="$runs" -seed="${FUZZ_SEED:-0}" \
    -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
    -report_slow_units=3 -artifact_prefix="$prefix" ${FUZZ_ARGS:-} "${target_flags[@]}" "$corpus" "$seeds" \
    "${committed[@]}" >"$log" 2>&1 || target_status=$?
  executions=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
  if [ -z "$executions" ]; then  # no final stats after a crash: the last progress line
    executions=$(grep -oE '^#[0-9]+' "$log" | tail -n 1 | tr -d '#')
  fi
  echo "fuzz: $name: ${executions:-0} executions in ${seconds} s at most; corpus now $(count "$corpus") inputs"
  slow=$(grep -c "^slow input:" "$log" || true)
  [ "$slow" -eq 0 ] || echo "fuzz: $name: $slow input(s) ran past their 5 s solver budget (SolverTimeout); slow units: ${prefix}slow-unit-*"
  if [ "$target_status" -ne 0 ]; then
    grep -E "BUG:|ERROR: |SUMMARY: |runtime error|Test unit written|==[0-9]+==" "$log" | head -n 20 || true
    echo "fuzz: $name: FAILED (status $target_status): see $log; the input is in $artifacts/;"
    echo "fuzz: replay it with: FUZZ_PRINT=1 scripts/fuzz.sh --replay ${prefix}<crash-file>"
    status=$target_status
  fi
done
[ "$status" -eq 0 ] || exit "$status"
echo "fuzz: no failure found"
