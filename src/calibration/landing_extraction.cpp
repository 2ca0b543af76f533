#include "collision_response/calibration/landing_extraction.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "collision_response/calibration/object_model.h"

namespace collision_response::calibration {
namespace {

/// The samples of a flight run: the first sample at index >= from whose lowest point is above the
/// clearance, and the end of its run (exclusive). {-1, -1} if none.
std::pair<int, int> nextFlightRun(const std::vector<double>& lowest, int from, double clearance) {
  int start = from;
  while (start < static_cast<int>(lowest.size()) && lowest[start] <= clearance) ++start;
  if (start >= static_cast<int>(lowest.size())) return {-1, -1};
  int end = start;
  while (end < static_cast<int>(lowest.size()) && lowest[end] > clearance) ++end;
  return {start, end};
}

}  // namespace

double restingFloorHeight(const PoseTrack& track, const detection::Shape& shape, int rest_frames) {
  const int n = std::min(rest_frames, track.size());
  if (n <= 0) throw std::runtime_error(track.source + ": no samples");
  std::vector<double> heights;
  for (int k = track.size() - n; k < track.size(); ++k)
    heights.push_back(lowestPointHeight(shape, track.position[k], track.orientation[k]));
  std::nth_element(heights.begin(), heights.begin() + heights.size() / 2, heights.end());
  return heights[heights.size() / 2];
}

std::vector<Extraction> extractLandings(const PoseTrack& raw, const detection::Shape& shape,
                                        const std::optional<double>& floor_height,
                                        const ExtractionOptions& options) {
  std::vector<Extraction> results;
  auto stop = [&](Extraction& result, const char* reason, bool no_landing) {
    result.reason = reason;
    result.no_landing = no_landing && results.empty();
    results.push_back(result);
    return results;
  };
  Extraction result;
  result.landing.source = raw.source;
  if (raw.size() < options.rest_frames + options.min_pre_frames + options.min_post_frames)
    return stop(result, "too few samples", true);
  double table = 0.0;
  if (floor_height) {
    table = *floor_height;
    const double rest = restingFloorHeight(raw, shape, options.rest_frames) - table;
    if (rest < -options.rest_tolerance)
      throw std::runtime_error(raw.source + ": the object at rest (the last " +
                               std::to_string(options.rest_frames) + " samples) is " +
                               std::to_string(-1e3 * rest) +
                               " mm below the floor: does the object file's shape match?");
  } else {
    table = restingFloorHeight(raw, shape, options.rest_frames);
  }
  PoseTrack track = raw;
  for (auto& p : track.position) p.z() -= table;
  std::vector<double> lowest(track.size());
  for (int k = 0; k < track.size(); ++k)
    lowest[k] = lowestPointHeight(shape, track.position[k], track.orientation[k]);
  const double length = lengthScale(shape);
  if (std::none_of(lowest.begin(), lowest.end(), [&](double h) { return h > options.clearance; }))
    return stop(result, "the object is never in flight (never above the floor by the clearance)",
                true);

  int flight_start = 0;  // where the flight before the next contact starts
  while (static_cast<int>(results.size()) < options.max_landings) {
    result = Extraction();
    Landing& landing = result.landing;
    landing.source = raw.source;
    landing.table = table;
    // Before: the flight samples up to the first one at or below the clearance.
    int contact = flight_start;
    while (contact < track.size() && lowest[contact] > options.clearance) ++contact;
    landing.contact_frame = contact;
    if (contact == track.size()) {
      if (!results.empty()) break;  // no further landing
      return stop(result, "no contact", true);
    }
    if (contact - flight_start < options.min_pre_frames) {
      stop(result, "short flight before the landing", false);
    } else {
      const int pre_first = std::max(flight_start, contact - options.max_pre_frames);
      landing.pre = fitFlight(track, pre_first, contact - 1, options.gravity_z);
      // After: the first run of flight samples long enough to fit, starting soon enough.
      int from = contact;
      std::pair<int, int> run{-1, -1};
      bool found = true;
      while (true) {
        run = nextFlightRun(lowest, from, options.clearance);
        if (run.first < 0 ||
            track.time[run.first] - track.time[contact] > options.max_landing_duration) {
          found = false;
          break;
        }
        if (run.second - run.first >= options.min_post_frames) break;
        from = run.second;
      }
      if (!found) {
        stop(result, "no clear flight after the landing", false);
        if (run.first < 0) break;
        flight_start = run.first;
        continue;
      }
      const int post_last = std::min(run.second - 1, run.first + options.max_post_frames - 1);
      landing.post = fitFlight(track, run.first, post_last, options.gravity_z);
      flight_start = run.first;
      const double rms_limit = options.max_fit_rms;
      if (landing.pre.position_rms > rms_limit || landing.pre.rotation_rms * length > rms_limit) {
        stop(result, "the flight before the landing is not ballistic", false);
        continue;
      }
      if (landing.post.position_rms > rms_limit || landing.post.rotation_rms * length > rms_limit) {
        stop(result, "the flight after the landing is not ballistic", false);
        continue;
      }
      landing.t_before = track.time[contact - 1];
      landing.t_after = track.time[run.first];
      landing.before = landing.pre.stateAt(landing.t_before, options.gravity_z);
      landing.after = landing.post.stateAt(landing.t_after, options.gravity_z);
      result.ok = true;
      results.push_back(result);
      continue;
    }
    // A short flight before: look on after the next flight run.
    const auto run = nextFlightRun(lowest, contact, options.clearance);
    if (run.first < 0) break;
    flight_start = run.first;
  }
  return results;
}

}  // namespace collision_response::calibration
