// The real cube tosses (benchmark/data/cube_tosses) as the benchmark uses them (docs/benchmarks.md,
// "Real tosses"): the recordings read and each toss's first landing extracted by the calibration
// library (calibration/csv_tracks.h, calibration/landing_extraction.h) for the tossed cube's box.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "collision_response/calibration/flight_fit.h"
#include "collision_response/calibration/landing_extraction.h"
#include "collision_response/calibration/pose_track.h"
#include "landing_model.h"

namespace collision_response::bench {

/// One toss as tracked: samples in time order. Positions in the tracking frame (z up) [m], the
/// table not yet at z = 0.
struct TossFrames : calibration::PoseTrack {
  int index = -1;  ///< the `toss` column
};

/// Reads every toss of the gzip-compressed CSV (columns toss,t,x,y,z,qw,qx,qy,qz; a toss's rows
/// consecutive). Throws std::runtime_error naming the file and line on any malformed row.
std::vector<TossFrames> readTosses(const std::string& gz_path);

/// The cube's box (side 2 half_width) as the calibration's shape.
detection::Shape cubeShape(const TossedCube& cube);

/// Height of the cube's lowest corner [m] at a pose (world z).
double lowestCornerHeight(const Eigen::Vector3d& position, const Eigen::Quaterniond& orientation,
                          double half_width);

/// The table's height [m]: the median lowest-corner height over the last `rest_frames` frames of
/// the toss, where the cube lies on a face at rest (so 4 corners touch).
double tableHeight(const TossFrames& toss, double half_width, int rest_frames);

using calibration::Extraction;
using calibration::ExtractionOptions;
using calibration::fitFlight;
using calibration::FlightFit;
using calibration::Landing;  ///< Landing::recording is the toss's index

/// Extracts the first landing of a toss (calibration::extractLandings() with the table found from
/// the cube at rest), its recording set to the toss's index.
Extraction extractLanding(const TossFrames& toss, const TossedCube& cube,
                          const ExtractionOptions& options = {});

/// Kinetic plus potential energy of the cube [J] (table at z = 0; uniform-cube inertia).
double cubeEnergy(const CubeState& state, const TossedCube& cube, double gravity_z);

}  // namespace collision_response::bench
