#!/usr/bin/env bash
# Fuzzes the core's request path (core::computeResponse) with libFuzzer, AddressSanitizer and
# UndefinedBehaviorSanitizer: builds test/fuzz/fuzz_compute_response.cpp with the core sources
# (src/core and src/detection, no ROS, no catkin) using clang-14, seeds a corpus with valid scenes that the target
# writes itself, and fuzzes for a bounded time. Exits non-zero if libFuzzer finds a crash, a
# sanitizer report, an unexpected exception or a non-finite answer (test/fuzz/scene_decoder.h).
#
#   scripts/fuzz.sh                      fuzz for FUZZ_SECONDS (default 120)
#   scripts/fuzz.sh --replay PATH...     run the given inputs (files or directories) once each
#
# Environment: BUILD_DIR (default build-fuzz; corpus, crash artifacts and log live there, out of
# git), FUZZ_SECONDS (default 120: the time cap), FUZZ_RUNS (stop after this many executions;
# unset: no cap), FUZZ_SEED (libFuzzer's -seed; default 0, a new random seed each run: with a
# fixed seed and FUZZ_RUNS, and an empty corpus, a run is reproducible, as CI's is), FUZZ_ARGS
# (extra libFuzzer flags), FUZZ_PRINT=1 (print each
# decoded request and its outcome; useful with --replay), FUZZ_SKIP_EXTREME=1 (excuse non-finite
# answers to requests holding finite but extreme magnitudes, |x| > 1e20 or < 1e-20: a known
# overflow class; set it to look past it).
set -euo pipefail
cd "$(dirname "$0")/.."

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

packages=(clang-14 libclang-rt-14-dev libeigen3-dev)
# The target links the detection library's sources too (the request path can detect contacts),
# and with them FCL.
packages+=(libfcl-dev)
link_libs=(-lfcl -lccd)
scripts/install_packages.sh "${packages[@]}"

build_dir=${BUILD_DIR:-build-fuzz}
mkdir -p "$build_dir"
target="$build_dir/fuzz_compute_response"
sources=(src/core/*.cpp src/detection/*.cpp test/fuzz/fuzz_compute_response.cpp)
# Rebuild when any source or header is newer than the binary: every source compiled to its own object,
# as many at once as there are cores, then linked.
if [ ! -x "$target" ] || [ -n "$(find src include test/fuzz -newer "$target" -type f -print -quit)" ]; then
  echo "fuzz: building $target (${#sources[@]} sources, $(nproc) at a time)"
  objects="$build_dir/objects"
  rm -rf "$objects"
  for source in "${sources[@]}"; do mkdir -p "$objects/$(dirname "$source")"; done
  flags=(-std=c++17 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined
    -fno-omit-frame-pointer -O1 -g -Iinclude -isystem /usr/include/eigen3)
  objs=()
  for source in "${sources[@]}"; do objs+=("$objects/$source.o"); done
  # xargs appends the source to the flags: the compiler's log goes beside its object.
  export FUZZ_OBJECTS=$objects
  printf '%s\0' "${sources[@]}" |
    xargs -0 -n 1 -P "$(nproc)" bash -c 'src=${!#}; log=$FUZZ_OBJECTS/$src.log
      clang++-14 "${@:1:$#-1}" -c "$src" -o "$FUZZ_OBJECTS/$src.o" 2>"$log" || { cat "$log"; exit 1; }' \
      compile "${flags[@]}" >"$build_dir/build.log" 2>&1 &&
    clang++-14 "${flags[@]}" "${objs[@]}" "${link_libs[@]}" -o "$target.tmp" >>"$build_dir/build.log" 2>&1 || {
    head -n 40 "$build_dir/build.log"
    echo "fuzz: build failed, see $build_dir/build.log" >&2
    exit 1
  }
  mv "$target.tmp" "$target"
fi

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:symbolize=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
artifacts="$build_dir/artifacts"
mkdir -p "$artifacts"

if [ "$mode" = replay ]; then
  files=()
  for path in "${replay[@]}"; do
    if [ -d "$path" ]; then
      while IFS= read -r -d '' file; do files+=("$file"); done < <(find "$path" -type f ! -name '.*' ! -name '*.md' -print0 | sort -z)
    elif [ -f "$path" ]; then
      files+=("$path")
    else
      echo "fuzz: no such file or directory: $path" >&2
      exit 2
    fi
  done
  [ ${#files[@]} -gt 0 ] || { echo "fuzz: nothing to replay" >&2; exit 2; }
  echo "fuzz: replaying ${#files[@]} input(s)"
  # Given files (not directories), libFuzzer runs each once and stops at the first failure.
  # shellcheck disable=SC2086
  "$target" -timeout=10 -rss_limit_mb=2048 ${FUZZ_ARGS:-} "${files[@]}"
  echo "fuzz: replay passed"
  exit 0
fi

# Seeds: valid, solvable scenes that the target finds itself (one per law, solver and island
# method met), rewritten each run; the corpus grows across runs.
seeds="$build_dir/seeds"
corpus="$build_dir/corpus"
rm -rf "$seeds"
mkdir -p "$seeds" "$corpus"
FUZZ_EMIT_SEEDS="$seeds" "$target" >"$build_dir/seeds.log" 2>&1 || {
  tail -n 40 "$build_dir/seeds.log"
  echo "fuzz: writing the seeds failed (a bug on a seed scene?), see $build_dir/seeds.log" >&2
  exit 1
}
count() { find "$1" -maxdepth 1 -type f | wc -l; }
seconds=${FUZZ_SECONDS:-120}
log="$build_dir/fuzz.log"
echo "fuzz: $(count "$seeds") seeds, corpus $corpus ($(count "$corpus") inputs), ${seconds} s at most, ${FUZZ_RUNS:-unlimited} runs, seed ${FUZZ_SEED:-random} (log: $log)"
status=0
# shellcheck disable=SC2086
# Inputs slower than 3 s are saved as $artifacts/slow-unit-* (not a failure; worth a look).
"$target" -max_total_time="$seconds" -runs="${FUZZ_RUNS:--1}" -seed="${FUZZ_SEED:-0}" \
  -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
  -report_slow_units=3 -artifact_prefix="$artifacts/" ${FUZZ_ARGS:-} "$corpus" "$seeds" >"$log" 2>&1 || status=$?
executions=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
if [ -z "$executions" ]; then  # no final stats after a crash: the last progress line
  executions=$(grep -oE '^#[0-9]+' "$log" | tail -n 1 | tr -d '#')
fi
echo "fuzz: ${executions:-0} executions in ${seconds} s at most; corpus now $(count "$corpus") inputs"
slow=$(grep -c "^slow input:" "$log" || true)
[ "$slow" -eq 0 ] || echo "fuzz: $slow input(s) ran past their 5 s solver budget (SolverTimeout); slow units: $artifacts/slow-unit-*"
if [ "$status" -ne 0 ]; then
  grep -E "BUG:|ERROR: |SUMMARY: |runtime error|Test unit written|==[0-9]+==" "$log" | head -n 20
  echo "fuzz: FAILED (status $status): see $log; the input is in $artifacts/;"
  echo "fuzz: replay it with: FUZZ_PRINT=1 scripts/fuzz.sh --replay $artifacts/<crash-file>"
  exit "$status"
fi
echo "fuzz: no failure found"
