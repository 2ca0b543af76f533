// Finding a robot's impacts in its recorded joint positions (docs/calibration.md, "Robot
// recordings"): an impact is a jump in the joint velocities between two samples. The free motion
// on either side is fitted per joint by a quadratic in time, which gives the velocities just
// before and just after the jump; an impact without a clean fit on both sides is skipped and
// counted by reason.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "collision_response/calibration/joint_track.h"

namespace collision_response::calibration {

struct RobotImpactOptions {
  /// The most samples of each side's fit (fewer where the recording or another impact is nearer);
  /// at 500 Hz 25 samples span 50 ms.
  int window = 25;
  /// The fewest samples of a side's fit (below: skipped, "too close to another impact or an end").
  int min_samples = 8;
  /// A jump is |qdot_after - qdot_before| (Euclidean over the joints [rad/s | m/s]) at a boundary
  /// between two samples; an impact is a local maximum above the larger of `min_jump` and
  /// `jump_factor` times the median jump over all boundaries (the noise of the velocities' fits,
  /// as almost every boundary lies in free motion).
  double min_jump = 0.05;
  double jump_factor = 10.0;
  /// A side's fit is free motion if its RMS residual (over joints and samples) is at most this
  /// times the median RMS of the fits over all boundaries (the tracking noise), or `min_rms` [rad
  /// | m] when that is larger.
  double rms_factor = 2.5;
  double min_rms = 1e-9;
};

/// One impact as measured: the state at the last sample before the jump and the velocities at the
/// first sample after it, from the quadratic fits.
struct RobotImpact {
  std::string source;                        ///< "<recording> impact <k>"
  double t_before = 0.0, t_after = 0.0;      ///< the samples either side of the jump [s]
  Eigen::VectorXd q_before, qdot_before;     ///< at t_before, the track's joint order
  Eigen::VectorXd qdot_after;                ///< at t_after
  double rms_before = 0.0, rms_after = 0.0;  ///< the fits' RMS residuals [rad | m]
};

struct RobotImpactExtraction {
  bool ok = false;
  std::string reason;  ///< why skipped (when !ok)
  RobotImpact impact;  ///< when ok
};

/// The impacts of `track` in time order, each found or skipped with its reason (too close to
/// another impact or an end; a side's fit not free motion; the joints slower than min_jump before
/// the jump: a robot at rest strikes nothing, and the residual is relative to that speed). Throws
/// std::runtime_error naming the track's source when the options are out of range or the track
/// is shorter than 2 min_samples + 1 samples.
std::vector<RobotImpactExtraction> extractRobotImpacts(const JointTrack& track,
                                                       const RobotImpactOptions& options = {});

}  // namespace collision_response::calibration
