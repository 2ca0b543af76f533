// Recorded motion from CSV files (docs/calibration.md, "Input"): the cube tosses' layout, one file
// (plain or gzip-compressed) holding many recordings with the header toss,t,x,y,z,qw,qx,qy,qz (a
// recording's rows consecutive), or one recording per file with the header t,x,y,z,qw,qx,qy,qz.
// t [s], x y z the body origin [m] in a world frame with z up, qw qx qy qz the body-to-world
// rotation (normalised on reading).
#pragma once

#include <string>
#include <vector>

#include "collision_response/calibration/pose_track.h"

namespace collision_response::calibration {

struct NumberedTrack {
  /// The toss column's value; for a one-recording file, the number in its name (toss_012.csv:
  /// 12), else the file's position in the folder's sorted listing.
  int number = -1;
  PoseTrack track;  ///< source "<file>" or "<file> toss <n>"
};

/// Reads `path`: a file, or a folder whose *.csv and *.csv.gz files are read in name order.
/// Throws std::runtime_error naming the file and line for a wrong header, a row that is not the
/// header's count of comma-separated numbers, a non-finite value (naming the column), a zero
/// quaternion, time not increasing within a recording; naming the path if it cannot be read or a
/// folder holds no CSV file.
std::vector<NumberedTrack> readCsvTracks(const std::string& path);

}  // namespace collision_response::calibration
