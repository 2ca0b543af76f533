#!/usr/bin/env bash
# Builds the package with what its tests run (core, ROS layer, node, nodelet, example client, unit
# tests, rostests; not the benchmarks) with AddressSanitizer, and UndefinedBehaviorSanitizer in the
# product's own files, into a second build directory and runs every test through scripts/test.sh (several at a time). Fails if
# any test fails or if any process (unit test, node, rostest client) wrote a sanitizer report:
# memory error, undefined behaviour, or a leak not suppressed by test/sanitizer/lsan.supp
# (third-party frames only).
#
# Environment: BUILD_DIR (default build/asan: below build/, whose programs rosrun skips, so that
# `rosrun collision_response collision_response_node` stays unambiguous). The flags go in through CMAKE_ARGS as an initial
# cache file (-C): setup.sh splits CMAKE_ARGS on spaces, so a multi-flag -DCMAKE_CXX_FLAGS=...
# cannot be passed there directly.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

build_dir=${BUILD_DIR:-build/asan}
mkdir -p "$build_dir"
build_dir=$(cd "$build_dir" && pwd)
case "$build_dir" in *" "*)
  echo "sanitize: the build directory must not contain spaces: $build_dir" >&2
  exit 1
  ;;
esac

# EIGEN_MALLOC_ALREADY_ALIGNED=1: Eigen turns to its own aligned allocator under AddressSanitizer
# (malloc plus an offset kept before the block), while the uninstrumented libraries the tests link
# (KDL) instantiate the same Eigen templates with plain malloc; the dynamic linker binds every
# caller to one instantiation, so a decomposition constructed by KDL's copy and freed by ours read
# 8 bytes before its block (a heap-buffer-overflow report in test_robot_episode, at c1aa2f1). glibc's
# malloc and the sanitizer's both return 16-byte aligned blocks on x86-64, which is what Eigen needs.
flags="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined -DEIGEN_MALLOC_ALREADY_ALIGNED=1"
# AddressSanitizer in every file; UndefinedBehaviorSanitizer in the product's own files (its
# libraries, node, nodelet, identify, example client: COLLISION_RESPONSE_PRODUCT_CXX_FLAGS), not in
# the tests' own files. With GCC 12 at -O2, -fsanitize=undefined doubles an Eigen-heavy file's
# compile time (test_episode.cpp: 35.8 s with both, 17.0 s with ASan alone, 9.3 s with neither),
# and the instrumented build was two thirds of CI's time. An inline function of our headers that a
# test compiles too may be bound to the test's uninstrumented copy; the fuzz targets (clang, both
# sanitizers in every file) cover those.
asan_flags="-fsanitize=address -fno-omit-frame-pointer -DEIGEN_MALLOC_ALREADY_ALIGNED=1"
# Without UBSan's per-access checks that ASan already reports here (null: a SEGV report;
# object-size: an overflow report) or that the clang fuzz pass keeps in every file (alignment,
# vptr, nonnull attributes): simultaneous_impact.cpp compiles in 109 s instead of 166 s (ASan
# alone: 99 s), measured side by side on 2026-12-02; the full set made this stage 43 of CI's 72 min.
ubsan_flags="-fsanitize=undefined -fno-sanitize=alignment,null,object-size,vptr,nonnull-attribute,returns-nonnull-attribute -fno-sanitize-recover=undefined"
cache="$build_dir/sanitize.cmake"
cat >"$cache" <<EOF
# Written by scripts/sanitize.sh.
set(CMAKE_C_FLAGS "$asan_flags" CACHE STRING "" FORCE)
set(CMAKE_CXX_FLAGS "$asan_flags" CACHE STRING "" FORCE)
set(COLLISION_RESPONSE_PRODUCT_CXX_FLAGS "$ubsan_flags" CACHE STRING "" FORCE)
set(CMAKE_EXE_LINKER_FLAGS "-fsanitize=address,undefined" CACHE STRING "" FORCE)
set(CMAKE_SHARED_LINKER_FLAGS "-fsanitize=address,undefined" CACHE STRING "" FORCE)
set(CMAKE_MODULE_LINKER_FLAGS "-fsanitize=address,undefined" CACHE STRING "" FORCE)
# RelWithDebInfo with -g1: line tables and inlined frames, which is what a report's stack trace
# shows, without the variables' and types' descriptions, which cost compile and link time here.
set(CMAKE_C_FLAGS_RELWITHDEBINFO "-O2 -g1 -DNDEBUG" CACHE STRING "" FORCE)
set(CMAKE_CXX_FLAGS_RELWITHDEBINFO "-O2 -g1 -DNDEBUG" CACHE STRING "" FORCE)
# Only what the tests run: no Google Benchmark binaries.
set(COLLISION_RESPONSE_BENCH_BINARIES OFF CACHE BOOL "" FORCE)
EOF
# The messages in C++ (the programs) and Python (the Python clients and nodes of the rostests) only:
# no Lisp. Read when CMake configures.
export ROS_LANG_DISABLE=genlisp

# Every instrumented process writes its reports to files here (catkin's run_tests.py and roslaunch
# do not fail a test whose process reports a leak at exit after its results were written).
logs="$build_dir/sanitizer-logs"
rm -rf "$logs"
mkdir -p "$logs"
# quarantine_size_mb=1: ASan's default 256 MB quarantine of freed memory makes the node's resident
# memory grow, which the load rostest's memory check reports as a leak; 1 MB still catches
# immediate use-after-free. Real leaks are LeakSanitizer's job (detect_leaks=1, at every exit).
# The property suite checks 150,000 scenes in the normal build; 20,000 keep this run short.
export CR_PROPERTY_SCENES=${CR_PROPERTY_SCENES:-20000}
# The impulse-space integrator's suites against their long-double reference: 50 random contacts
# each instead of 150 and 200 (the reference costs most of the normal build's 45 s CPU there).
export CR_REFERENCE_CASES=${CR_REFERENCE_CASES:-50}
# The stress suite's 1000-contact landings (408 s of the sanitizer run, 23 s normally): 100 contacts
# already take the same iterative path (test/core/test_stress.cpp).
export CR_STRESS_MAX_CONTACTS=${CR_STRESS_MAX_CONTACTS:-100}
# The calibration's synthetic identifications (test_identification, test_identify_options): fewer
# landings where a smaller set still decides each assertion (the spread of 16 noise draws over 8
# tosses instead of 14, the shrinking intervals over 4..24 landings instead of 6..36, ...): 93 and
# 65 s of CPU here instead of 158 and 107.
export CR_CALIBRATION_SMALL=${CR_CALIBRATION_SMALL:-1}
export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1:abort_on_error=0:check_initialization_order=1:detect_stack_use_after_return=1:quarantine_size_mb=1:log_path=$logs/asan"
# Third-party reports only (test/sanitizer/asan.supp: Debian's nodelet manager at exit).
ASAN_OPTIONS="$ASAN_OPTIONS:suppressions=$root/test/sanitizer/asan.supp"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:log_path=$logs/ubsan"
supp="$root/test/sanitizer/lsan.supp"
export LSAN_OPTIONS="print_suppressions=1"
[ -f "$supp" ] && LSAN_OPTIONS="$LSAN_OPTIONS:suppressions=$supp"

# Programs built outside this CMake project load the instrumented libraries too: the downstream
# package of the tests (configured afresh: CMake takes CXXFLAGS and LDFLAGS as its initial flags),
# and Debian's nodelet manager, which is not instrumented, so the ASan runtime is preloaded into it
# (test/embedding.test passes CR_NODELET_PREFIX as the launch file's launch_prefix).
export CXXFLAGS="$flags" LDFLAGS="-fsanitize=address,undefined"
CR_NODELET_PREFIX="env LD_PRELOAD=$(g++ -print-file-name=libasan.so)"
export CR_NODELET_PREFIX

echo "sanitize: building into $build_dir with $asan_flags, and $ubsan_flags in the product's files (RelWithDebInfo, -O2 -g1)"
status=0
# The README's command blocks check the documentation, not memory (they start the node with rosrun,
# which finds the normal build's program): skipped here, run by scripts/test.sh.
export CR_README_BLOCKS=skip
BUILD_DIR="$build_dir" BUILD_TYPE=RelWithDebInfo CMAKE_ARGS="-C$cache" scripts/test.sh || status=$?

# Reports: a file per process that found something. Suppressed leaks alone are not failures.
reports=0
for log in "$logs"/*; do
  [ -e "$log" ] || continue
  if grep -qE "ERROR: (AddressSanitizer|LeakSanitizer)|runtime error:|SUMMARY: (AddressSanitizer|UndefinedBehaviorSanitizer)" "$log"; then
    reports=$((reports + 1))
    echo "---- sanitizer report: $log"
    grep -vE "^\s*$" "$log" | head -n 60
  fi
done
echo "sanitize: $reports sanitizer report(s) (logs: $logs)"
if [ "$status" -ne 0 ] || [ "$reports" -ne 0 ]; then
  echo "sanitize: FAILED (tests status $status, $reports report(s))"
  exit 1
fi
echo "sanitize: passed"
