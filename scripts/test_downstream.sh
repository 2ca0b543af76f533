#!/usr/bin/env bash
# Builds test/downstream (a catkin package that does find_package(catkin REQUIRED COMPONENTS
# collision_response)) against a build's devel space and runs its gtest.
# Usage: scripts/test_downstream.sh BUILD_DIR DEVEL_DIR RESULT_XML
# Writes the gtest JUnit XML to RESULT_XML; if configuring or building fails, a failing one.
set -uo pipefail
source_dir=$(cd "$(dirname "$0")/.." && pwd)
build_dir=$(cd "$1" && pwd)
devel_dir=$(cd "$2" && pwd)
result=$3
out=$build_dir/downstream
mkdir -p "$out" "$(dirname "$result")"
log=$out/build.log

fail() {
  echo "test_downstream: $1 (log: $log)" >&2
  tail -n 30 "$log" >&2
  cat >"$result" <<XML
<?xml version="1.0" encoding="UTF-8"?>
<testsuites tests="1" failures="1" errors="0" name="downstream">
  <testsuite name="Downstream" tests="1" failures="1" errors="0">
    <testcase name="BuildsAgainstTheExport" classname="Downstream">
      <failure message="$1">see $log</failure>
    </testcase>
  </testsuite>
</testsuites>
XML
  exit 1
}

set +u  # catkin's setup scripts read unset variables
# shellcheck disable=SC1091
source "$devel_dir/setup.bash"
set -u
rm -f "$result"
cmake -S "$source_dir/test/downstream" -B "$out" -DPYTHON_EXECUTABLE=/usr/bin/python3 \
  -DCMAKE_BUILD_TYPE=Release >"$log" 2>&1 || fail "configuring the downstream package failed"
make -C "$out" -j2 --no-print-directory test_downstream >>"$log" 2>&1 ||
  fail "building the downstream package against the exported library failed"
binary=$(find "$out" -type f -name test_downstream -perm -u+x | head -n 1)
[ -n "$binary" ] || fail "no test_downstream binary"
"$binary" --gtest_output="xml:$result"
