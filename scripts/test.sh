#!/usr/bin/env bash
# Every test: install and build if needed, build the tests, run them (unit tests, rostests, the
# downstream package, the README's blocks), and fail if any test fails.
#
# The tests run through CTest, TEST_JOBS at a time (default: the number of cores): catkin registers
# every run_tests target with CTest too, with the same command and result file, so `make run_tests`
# (and catkin_make run_tests) run the same tests one after another. They are independent: each
# rostest starts its own master on a free port, the README's blocks and scripts pick free ports,
# and every test writes its own result file. A line per test as it ends, its time, and at the end
# the slowest tests; the whole CTest output is in $BUILD_DIR/run_tests.log.
#
# Environment: BUILD_DIR (default build), TEST_JOBS, BUILD_TYPE and CMAKE_ARGS (scripts/setup.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${BUILD_DIR:-build}
jobs=${TEST_JOBS:-$(nproc)}
start=$SECONDS
since() {
  local s=$((SECONDS - $1))
  printf '%dm%02ds' $((s / 60)) $((s % 60))
}

echo "test: installing missing packages, building the package and its tests in $build_dir"
scripts/setup.sh tests
echo "test: built in $(since "$start")"
source scripts/ros_env.sh

rm -rf "$build_dir/test_results"
count=$(ctest --test-dir "$build_dir" -N | sed -n 's/^Total Tests: *//p')
echo "test: running ${count:-?} tests, $jobs at a time (unit tests, rostests, downstream package," \
  "README blocks); log: $build_dir/run_tests.log"
tests_start=$SECONDS
log="$build_dir/run_tests.log"
# CTest's line for each test that ends ("3/31 Test #7: _ctest_collision_response_gtest_test_lcp
# ....   Passed   2.04 sec") as "test:  3/31 gtest test_lcp: passed (2.0 s)". A test's own result
# (its <failure> elements) is what catkin_test_results reads below; CTest's verdict only says
# that a program or its result file failed. Generous time-out: each rostest has its own limit.
ctest --test-dir "$build_dir" -j "$jobs" --timeout 3600 2>&1 | tee "$log" |
  sed -nuE 's/^ *([0-9]+\/[0-9]+) Test +#[0-9]+: _ctest_collision_response_([a-z]+)_([^ ]+) \.* *\**(.*[^ ]) +([0-9.]+) sec$/\1 \2 \3 \5 \4/p' |
  while read -r progress kind name time verdict; do
    case "$verdict" in Passed) verdict=passed ;; *) verdict="FAILED ($verdict)" ;; esac
    printf 'test: %7s %s %s: %s (%.1f s)\n' "$progress" "$kind" "${name%.test}" "$verdict" "$time"
  done || true
echo "test: tests ran in $(since "$tests_start"); slowest:" \
  "$(sed -nE 's/^ *[0-9]+\/[0-9]+ Test +#[0-9]+: _ctest_collision_response_([a-z]+)_([^ ]+) .* ([0-9.]+) sec$/\3 \1 \2/p' "$log" |
    sort -rn | head -n 4 | awk '{sub(/\.test$/, "", $3); printf "%s%s %s %.0f s", (NR > 1 ? ", " : ""), $2, $3, $1}')"

# Every test CTest knows must have run to the end (CTest itself stopped early: a failure too).
ran=$(grep -cE '^ *[0-9]+/[0-9]+ Test +#' "$log" || true)
status=0
if [ "$ran" != "${count:-}" ]; then
  echo "test: only $ran of ${count:-?} tests ran to the end; see $log"
  status=1
fi
summary=$(catkin_test_results --verbose "$build_dir/test_results") || status=1
echo "$summary" | grep -vE '^\s*$|^Summary:' | tail -n 40
# The closing line CI reads, counted from the <testcase> elements of the result files (the totals
# of catkin_test_results count every gtest case twice): N passed, N failed, N skipped.
counts=0
/usr/bin/python3 scripts/count_test_results.py "$build_dir/test_results" || counts=$?
if [ "$status" -ne 0 ] || [ "$counts" -ne 0 ]; then
  [ "$counts" -eq 2 ] && echo "test: no test ran"
  echo "test: FAILED"
  exit 1
fi
echo "test: passed: all ${count:-?} tests passed ($(since "$start") in all)"
