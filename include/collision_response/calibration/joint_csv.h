// A robot's recorded joint positions from a CSV file (docs/calibration.md, "Robot recordings"):
// the header `t,<joint>,<joint>,...` (URDF joint names), then one row per sample: time [s] and
// each joint's position [rad | m]. Plain or gzip-compressed.
#pragma once

#include <string>

#include "collision_response/calibration/joint_track.h"

namespace collision_response::calibration {

/// Reads the file at `path`. Throws std::runtime_error naming the file and line for a header that
/// is not `t` and at least one unique joint name, a row that is not the header's count of
/// comma-separated numbers, a non-finite value (naming the joint's column), time not increasing;
/// naming the path if it cannot be read or holds fewer than 2 samples.
JointTrack readJointCsv(const std::string& path);

}  // namespace collision_response::calibration
