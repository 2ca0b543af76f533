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
echo "$summary" | grep -vE '^\s*$' | tail -n 40
# The plain closing line CI reads: N passed, N failed.
echo "$summary" | awk '/^Summary:/ {
  gsub(",", ""); tests = $2; errors = $4; failures = $6; skipped = $8;
  printf "%d passed, %d failed, %d skipped\n", tests - errors - failures - skipped, errors + failures, skipped }'
if [ "$status" -ne 0 ]; then
  echo "test: FAILED"
  exit "$status"
fi
grep -q "^Summary: [1-9]" <<<"$summary" || { echo "test: no test ran"; exit 1; }
