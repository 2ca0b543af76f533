// The real cube tosses (benchmark/data/cube_tosses): reading them, and extracting each toss's first
// landing as the benchmark uses it (docs/benchmarks.md, "Real tosses"): the pre-impact state from a
// ballistic fit to the flight before the first contact, the measured outcome from a ballistic fit
// to the first clear free flight after it.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "landing_model.h"

namespace collision_response::bench {

/// One toss as tracked: frames in time order. Positions in the tracking frame (z up) [m], the
/// table not yet at z = 0.
struct TossFrames {
  int index = -1;                               ///< the `toss` column
  std::vector<double> time;                     ///< [s]
  std::vector<Eigen::Vector3d> position;        ///< cube centre [m]
  std::vector<Eigen::Quaterniond> orientation;  ///< cube frame to world (unit)
  int size() const { return static_cast<int>(time.size()); }
};

/// Reads every toss of the gzip-compressed CSV (columns toss,t,x,y,z,qw,qx,qy,qz; a toss's rows
/// consecutive). Throws std::runtime_error naming the file and line on any malformed row.
std::vector<TossFrames> readTosses(const std::string& gz_path);

/// Height of the cube's lowest corner [m] at a pose (world z).
double lowestCornerHeight(const Eigen::Vector3d& position, const Eigen::Quaterniond& orientation,
                          double half_width);

/// The table's height [m]: the median lowest-corner height over the last `rest_frames` frames of
/// the toss, where the cube lies on a face at rest (so 4 corners touch).
double tableHeight(const TossFrames& toss, double half_width, int rest_frames);

/// A ballistic fit over the frames [first, last] (inclusive) of a toss: the centre quadratic in
/// time with gravity fixed (least squares on position and velocity at t_ref), the rotation uniform
/// at a constant world angular velocity (exact torque-free motion of the isotropic cube;
/// Gauss-Newton on the rotation vectors of the residual rotations). Positions as in the toss (shift
/// them first).
struct FlightFit {
  int first = 0, last = -1;  ///< frames fitted
  double t_ref = 0.0;        ///< [s] the time of the fitted state (frame `first`)
  Eigen::Vector3d position = Eigen::Vector3d::Zero();               ///< at t_ref [m]
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();        ///< at t_ref [m/s]
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< at t_ref
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();       ///< world, constant [rad/s]
  double position_rms = 0.0;  ///< RMS of the centre's residuals [m]
  double rotation_rms = 0.0;  ///< RMS of the residual rotation angles [rad]
  /// The cube's state at time t [s] on the fitted flight (gravity g along z [m/s^2]).
  CubeState stateAt(double t, double gravity_z) const;
};

/// Fits frames [first, last] (needs last - first >= 2). gravity_z [m/s^2], e.g. -9.81.
FlightFit fitFlight(const TossFrames& toss, int first, int last, double gravity_z);

/// What makes a landing usable, and the windows (docs/benchmarks.md, "Real tosses").
struct ExtractionOptions {
  double gravity_z = -9.81;  ///< [m/s^2]
  /// A frame is in flight when the cube's lowest corner is more than this above the table [m];
  /// the first frame at or below it is the first contact's frame.
  double clearance = 0.002;
  int rest_frames = 10;      ///< frames at the end that give the table height
  int min_pre_frames = 6;    ///< flight frames before the first contact, at least
  int max_pre_frames = 30;   ///< the pre-impact fit uses at most the last this many of them
  int min_post_frames = 4;   ///< frames of the first clear flight after the landing, at least
  int max_post_frames = 30;  ///< the post-landing fit uses at most the first this many of them
  /// The post-landing flight must start within this of the first contact's frame [s]: later
  /// flights follow a second landing (the cube has settled and been thrown up again by rocking).
  double max_landing_duration = 0.15;
  /// A fit whose centre residuals exceed this RMS [m] (or whose rotation residuals, times the half
  /// width, do) is no free flight: the toss is dropped.
  double max_fit_rms = 0.001;
};

/// A toss's first landing, shifted so that the table is z = 0.
struct Landing {
  int toss = -1;
  double table = 0.0;      ///< the table's height in the tracking frame [m] (subtracted)
  int contact_frame = -1;  ///< the first frame at or below the clearance
  FlightFit pre, post;     ///< the fits before the first contact and after the landing
  double t_before = 0.0;   ///< [s] the last pre-impact flight frame's time
  double t_after = 0.0;    ///< [s] the first post-landing flight frame's time
  CubeState before;        ///< the pre-impact fit at t_before
  CubeState after;         ///< the post-landing fit at t_after (the measured outcome)
};

/// Why a toss gave no landing ("" when it gave one).
struct Extraction {
  bool ok = false;
  std::string reason;
  Landing landing;
};

/// Extracts the first landing of a toss (see ExtractionOptions; the toss's frames shifted by its
/// table height).
Extraction extractLanding(const TossFrames& toss, const TossedCube& cube,
                          const ExtractionOptions& options = {});

/// Kinetic plus potential energy of the cube [J] (table at z = 0; uniform-cube inertia).
double cubeEnergy(const CubeState& state, const TossedCube& cube, double gravity_z);

}  // namespace collision_response::bench
