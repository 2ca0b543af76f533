// Finding the landings in a recorded motion (docs/calibration.md, "Extraction"): the floor's
// height, the first sample within a clearance of it, a ballistic fit to the flight before and one
// to the first clear flight after; landings without such flights are skipped with a reason.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "collision_response/calibration/flight_fit.h"
#include "collision_response/calibration/motion_state.h"
#include "collision_response/calibration/pose_track.h"
#include "collision_response/detection/shapes.h"

namespace collision_response::calibration {

/// What makes a landing usable, and the windows.
struct ExtractionOptions {
  double gravity_z = -9.81;  ///< [m/s^2]
  /// A sample is in flight when the object's lowest point is more than this above the floor [m];
  /// the first sample at or below it is the landing's first contact.
  double clearance = 0.002;
  int rest_frames = 10;      ///< samples at the end that give the floor height (when not given)
  int min_pre_frames = 6;    ///< flight samples before the first contact, at least
  int max_pre_frames = 30;   ///< the pre-impact fit uses at most the last this many of them
  int min_post_frames = 4;   ///< samples of the first clear flight after the landing, at least
  int max_post_frames = 30;  ///< the post-landing fit uses at most the first this many of them
  /// The post-landing flight must start within this of the first contact [s]: later flights follow
  /// a second landing (the object has settled and been thrown up again by rocking).
  double max_landing_duration = 0.15;
  /// A fit whose origin residuals exceed this RMS [m] (or whose rotation residuals, times the
  /// shape's lengthScale(), do) is no free flight: the landing is skipped.
  double max_fit_rms = 0.001;
  /// Landings taken per recording, >= 1, in time order (the next one is looked for after the
  /// previous one's post-landing flight).
  int max_landings = 1;
  /// With a given floor height: the object lying at rest (the last rest_frames samples) with its
  /// lowest point more than this below the floor [m] is an error (the shape does not match).
  double rest_tolerance = 0.003;
};

/// One landing, the floor moved to z = 0.
struct Landing {
  std::string source;      ///< the recording's (PoseTrack::source)
  int recording = -1;      ///< the caller's number of the recording (e.g. the toss)
  double table = 0.0;      ///< the floor's height in the recording's frame [m] (subtracted)
  int contact_frame = -1;  ///< the first sample at or below the clearance
  FlightFit pre, post;     ///< the fits before the first contact and after the landing
  double t_before = 0.0;   ///< [s] the last pre-impact flight sample's time
  double t_after = 0.0;    ///< [s] the first post-landing flight sample's time
  MotionState before;      ///< the pre-impact fit at t_before
  MotionState after;       ///< the post-landing fit at t_after (the measured outcome)
};

/// A landing, or why there is none ("" when ok).
struct Extraction {
  bool ok = false;
  /// The recording holds no landing at all (too few samples, the object never in flight, or never
  /// within the clearance of the floor): an error for the caller, not a skipped landing.
  bool no_landing = false;
  std::string reason;
  Landing landing;
};

/// The floor's height [m]: the median lowest-point height over the last `rest_frames` samples.
double restingFloorHeight(const PoseTrack& track, const detection::Shape& shape, int rest_frames);

/// The first options.max_landings landings of `track` (at least one entry: a skipped or missing
/// landing says why). floor_height: the floor's z in the track's frame, or unset (from rest).
/// Throws std::runtime_error naming track.source if the object rests below a given floor (see
/// ExtractionOptions::rest_tolerance).
std::vector<Extraction> extractLandings(const PoseTrack& track, const detection::Shape& shape,
                                        const std::optional<double>& floor_height,
                                        const ExtractionOptions& options = {});

}  // namespace collision_response::calibration
