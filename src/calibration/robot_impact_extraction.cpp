#include "collision_response/calibration/robot_impact_extraction.h"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace collision_response::calibration {
namespace {

/// Per joint q(t) = a + b (t - t0) + c (t - t0)^2 fitted over samples [first, last] by least
/// squares.
struct QuadraticFit {
  double t0 = 0.0;
  Eigen::MatrixXd coefficients;  // 3 x joints
  double rms = 0.0;              // over joints and samples
  Eigen::VectorXd position(double t) const {
    const double s = t - t0;
    return coefficients.row(0).transpose() + s * coefficients.row(1).transpose() +
           s * s * coefficients.row(2).transpose();
  }
  Eigen::VectorXd velocity(double t) const {
    return coefficients.row(1).transpose() + 2.0 * (t - t0) * coefficients.row(2).transpose();
  }
};

QuadraticFit fitQuadratic(const JointTrack& track, int first, int last, double t0) {
  const int m = last - first + 1, n = static_cast<int>(track.names.size());
  Eigen::MatrixXd A(m, 3), Y(m, n);
  for (int i = 0; i < m; ++i) {
    const double s = track.time[first + i] - t0;
    A.row(i) << 1.0, s, s * s;
    Y.row(i) = track.position[first + i].transpose();
  }
  QuadraticFit fit;
  fit.t0 = t0;
  fit.coefficients = A.colPivHouseholderQr().solve(Y);
  fit.rms = std::sqrt((A * fit.coefficients - Y).squaredNorm() / (m * n));
  return fit;
}

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace

std::vector<RobotImpactExtraction> extractRobotImpacts(const JointTrack& track,
                                                       const RobotImpactOptions& options) {
  if (options.min_samples < 4 || options.window < options.min_samples ||
      !(options.min_jump > 0.0) || !(options.jump_factor > 0.0) || !(options.rms_factor > 0.0) ||
      !(options.min_rms >= 0.0))
    throw std::runtime_error(track.source +
                             ": impact extraction: window >= min_samples >= 4, min_jump, "
                             "jump_factor and rms_factor > 0, min_rms >= 0");
  const int n = track.size();
  if (n < 2 * options.min_samples + 1)
    throw std::runtime_error(track.source + ": " + std::to_string(n) +
                             " samples, too short for impacts (at least " +
                             std::to_string(2 * options.min_samples + 1) + ")");
  const int w = options.window;
  // The jump at each boundary k (between samples k and k + 1), both sides fitted over up to w
  // samples, the velocities compared at the boundary's middle.
  const int first = options.min_samples - 1, last = n - options.min_samples - 1;
  std::vector<double> jumps(n, 0.0), rms;
  for (int k = first; k <= last; ++k) {
    const double t = 0.5 * (track.time[k] + track.time[k + 1]);
    const QuadraticFit before = fitQuadratic(track, std::max(0, k - w + 1), k, t);
    const QuadraticFit after = fitQuadratic(track, k + 1, std::min(n - 1, k + w), t);
    jumps[k] = (after.velocity(t) - before.velocity(t)).norm();
    rms.push_back(before.rms);
  }
  const double threshold =
      std::max(options.min_jump,
               options.jump_factor *
                   median(std::vector<double>(jumps.begin() + first, jumps.begin() + last + 1)));
  const double rms_limit = std::max(options.min_rms, options.rms_factor * median(rms));
  // The impacts: the largest jump above the threshold, then the next outside its windows, ...
  std::vector<int> candidates;
  for (int k = first; k <= last; ++k)
    if (jumps[k] > threshold) candidates.push_back(k);
  std::stable_sort(candidates.begin(), candidates.end(),
                   [&](int a, int b) { return jumps[a] > jumps[b]; });
  std::vector<int> impacts;
  std::vector<char> taken(n, 0);
  for (int best : candidates) {
    if (taken[best]) continue;
    impacts.push_back(best);
    for (int k = std::max(0, best - w); k <= std::min(n - 1, best + w); ++k) taken[k] = 1;
  }
  std::sort(impacts.begin(), impacts.end());

  std::vector<RobotImpactExtraction> out;
  for (std::size_t i = 0; i < impacts.size(); ++i) {
    RobotImpactExtraction x;
    x.impact.source = track.source + " impact " + std::to_string(i);
    // Each side stops short of the neighbouring impacts' samples.
    const int lowest = i > 0 ? impacts[i - 1] + 1 : 0;
    const int highest = i + 1 < impacts.size() ? impacts[i + 1] : n - 1;
    // The jump may be found one boundary off (a window holding the kink still jumps): of the
    // boundaries next to it, the one whose two fits are the cleanest.
    double best_rms = INFINITY;
    for (int k = impacts[i] - 1; k <= impacts[i] + 1; ++k) {
      const int from = std::max(lowest, k - w + 1), to = std::min(highest, k + w);
      if (k - from + 1 < options.min_samples || to - k < options.min_samples) continue;
      const QuadraticFit before = fitQuadratic(track, from, k, track.time[k]);
      const QuadraticFit after = fitQuadratic(track, k + 1, to, track.time[k + 1]);
      if (before.rms + after.rms >= best_rms) continue;
      best_rms = before.rms + after.rms;
      RobotImpact& m = x.impact;
      m.t_before = track.time[k];
      m.t_after = track.time[k + 1];
      m.q_before = before.position(m.t_before);
      m.qdot_before = before.velocity(m.t_before);
      m.qdot_after = after.velocity(m.t_after);
      m.rms_before = before.rms;
      m.rms_after = after.rms;
    }
    if (!std::isfinite(best_rms)) {
      x.reason = "too close to another impact or an end of the recording";
    } else if (x.impact.rms_before > rms_limit || x.impact.rms_after > rms_limit) {
      x.reason = "no free motion before or after (fit residual above the noise)";
    } else if (!(x.impact.qdot_before.norm() >= options.min_jump)) {
      // The residuals are relative to the speed before: a robot at rest struck nothing.
      x.reason = "the joints at rest before the jump";
    } else {
      x.ok = true;
    }
    out.push_back(std::move(x));
  }
  return out;
}

}  // namespace collision_response::calibration
