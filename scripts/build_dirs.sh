# Sourced by the scripts: where the build tree and the devel space go.
#   build_dir  the CMake build tree: $BUILD_DIR, default build
#   devel_dir  the catkin devel space (setup.bash, the programs, the generated messages)
# rosrun skips every file below <package>/build/, so the default build puts its devel space beside
# it, at devel/, as a catkin workspace does (build/ and devel/ side by side); other build trees
# (sanitizers, fuzzing, a path of your own) keep theirs inside. DEVEL_DIR overrides.
build_dir=${BUILD_DIR:-build}
if [ -n "${DEVEL_DIR:-}" ]; then
  devel_dir=$DEVEL_DIR
elif [ "$(realpath -m "$build_dir")" = "$(realpath -m build)" ]; then
  devel_dir=devel
else
  devel_dir=$build_dir/devel
fi
