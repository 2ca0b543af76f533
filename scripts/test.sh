#!/usr/bin/env bash
# Every test: install and build if needed, build the tests, run them (unit tests and rostests, each
# rostest with its own master on a free port), and fail if any test fails.
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${BUILD_DIR:-build}
scripts/setup.sh tests
source scripts/ros_env.sh

rm -rf "$build_dir/test_results"
# run_tests exits 0 even when tests fail: catkin_test_results decides.
make -C "$build_dir" -j1 --no-print-directory run_tests >"$build_dir/run_tests.log" 2>&1 || {
  tail -n 50 "$build_dir/run_tests.log"
  echo "test: run_tests failed to run"
  exit 1
}
status=0
summary=$(catkin_test_results --verbose "$build_dir/test_results") || status=$?
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
