#include "toss_data.h"

#include <zlib.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

namespace collision_response::bench {
namespace {

/// Rotation vector of a unit quaternion (shortest rotation: angle in [0, pi]).
Eigen::Vector3d logMap(Eigen::Quaterniond q) {
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  const double s = q.vec().norm();
  if (s < 1e-12) return 2.0 * q.vec();
  return 2.0 * std::atan2(s, q.w()) / s * q.vec();
}

/// Quaternion of a rotation vector.
Eigen::Quaterniond expMap(const Eigen::Vector3d& v) {
  const double angle = v.norm();
  if (angle < 1e-12)
    return Eigen::Quaterniond(1.0, 0.5 * v.x(), 0.5 * v.y(), 0.5 * v.z()).normalized();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, v / angle));
}

/// Parses one CSV line of 9 numbers; false if it is not one.
bool parseRow(const char* line, double (&values)[9]) {
  const char* p = line;
  for (int i = 0; i < 9; ++i) {
    char* end = nullptr;
    values[i] = std::strtod(p, &end);
    if (end == p || !std::isfinite(values[i])) return false;
    p = end;
    if (i < 8) {
      if (*p != ',') return false;
      ++p;
    }
  }
  while (*p == '\r' || *p == '\n' || *p == ' ') ++p;
  return *p == '\0';
}

/// Least-squares centre fit: p_k - g tau_k^2 / 2 = p0 + v0 tau_k over the frames.
void fitCentre(const TossFrames& toss, int first, int last, double gravity_z, FlightFit& fit) {
  const int n = last - first + 1;
  double st = 0.0, stt = 0.0;
  Eigen::Vector3d sp = Eigen::Vector3d::Zero(), stp = Eigen::Vector3d::Zero();
  const Eigen::Vector3d g(0.0, 0.0, gravity_z);
  for (int k = first; k <= last; ++k) {
    const double tau = toss.time[k] - fit.t_ref;
    const Eigen::Vector3d y = toss.position[k] - 0.5 * tau * tau * g;
    st += tau;
    stt += tau * tau;
    sp += y;
    stp += tau * y;
  }
  const double det = n * stt - st * st;
  fit.linear_velocity = (n * stp - st * sp) / det;
  fit.position = (sp - st * fit.linear_velocity) / n;
  double sum = 0.0;
  for (int k = first; k <= last; ++k) {
    const double tau = toss.time[k] - fit.t_ref;
    const Eigen::Vector3d model = fit.position + tau * fit.linear_velocity + 0.5 * tau * tau * g;
    sum += (toss.position[k] - model).squaredNorm();
  }
  fit.position_rms = std::sqrt(sum / n);
}

/// Uniform-rotation fit q(tau) = exp(w tau) q0 (w world): the initial w from consecutive frames,
/// then Gauss-Newton on the residual rotation vectors log(q_k (exp(w tau_k) q0)^-1) over the 6
/// coordinates q0 <- exp(a) q0, w <- w + b, with the Jacobian by central differences (so that the
/// fixed point is the least-squares fit itself, not that of an approximate Jacobian).
void fitRotation(const TossFrames& toss, int first, int last, FlightFit& fit) {
  Eigen::Vector3d w = Eigen::Vector3d::Zero();
  for (int k = first; k < last; ++k) {
    const Eigen::Quaterniond step = toss.orientation[k + 1] * toss.orientation[k].conjugate();
    w += logMap(step) / (toss.time[k + 1] - toss.time[k]);
  }
  w /= (last - first);
  Eigen::Quaterniond q0 = toss.orientation[first];
  const int n = last - first + 1;
  auto residuals = [&](const Eigen::Quaterniond& q, const Eigen::Vector3d& omega) {
    Eigen::VectorXd r(3 * n);
    for (int k = first; k <= last; ++k)
      r.segment<3>(3 * (k - first)) = logMap(
          toss.orientation[k] * (expMap(omega * (toss.time[k] - fit.t_ref)) * q).conjugate());
    return r;
  };
  auto perturbed = [&](const Eigen::Matrix<double, 6, 1>& x) {
    return residuals(expMap(x.head<3>()) * q0, w + x.tail<3>());
  };
  Eigen::MatrixXd J(3 * n, 6);
  constexpr double kStep = 1e-6;
  for (int iteration = 0; iteration < 20; ++iteration) {
    const Eigen::VectorXd r = residuals(q0, w);
    for (int j = 0; j < 6; ++j) {
      Eigen::Matrix<double, 6, 1> dx = Eigen::Matrix<double, 6, 1>::Zero();
      dx[j] = kStep;
      J.col(j) = (perturbed(dx) - perturbed(-dx)) / (2.0 * kStep);
    }
    const Eigen::Matrix<double, 6, 1> step = -J.colPivHouseholderQr().solve(r);
    q0 = (expMap(step.head<3>()) * q0).normalized();
    w += step.tail<3>();
    if (step.norm() < 1e-13) break;
  }
  fit.orientation = q0;
  fit.angular_velocity = w;
  fit.rotation_rms = std::sqrt(residuals(q0, w).squaredNorm() / n);
}

/// The frames of a flight run: the first frame at index >= from whose lowest corner is above the
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

std::vector<TossFrames> readTosses(const std::string& gz_path) {
  gzFile file = gzopen(gz_path.c_str(), "rb");
  if (file == nullptr) throw std::runtime_error(gz_path + ": cannot open");
  std::vector<TossFrames> tosses;
  char line[512];
  int line_number = 0;
  while (gzgets(file, line, sizeof line) != nullptr) {
    ++line_number;
    if (line_number == 1) {
      if (std::string(line).rfind("toss,t,x,y,z,qw,qx,qy,qz", 0) != 0) {
        gzclose(file);
        throw std::runtime_error(gz_path + ":1: header is not toss,t,x,y,z,qw,qx,qy,qz");
      }
      continue;
    }
    double v[9];
    if (!parseRow(line, v)) {
      gzclose(file);
      throw std::runtime_error(gz_path + ":" + std::to_string(line_number) +
                               ": not 9 comma-separated numbers");
    }
    const int index = static_cast<int>(v[0]);
    if (tosses.empty() || tosses.back().index != index) {
      tosses.emplace_back();
      tosses.back().index = index;
    }
    TossFrames& toss = tosses.back();
    if (!toss.time.empty() && v[1] <= toss.time.back()) {
      gzclose(file);
      throw std::runtime_error(gz_path + ":" + std::to_string(line_number) +
                               ": time not increasing within toss " + std::to_string(index));
    }
    toss.time.push_back(v[1]);
    toss.position.emplace_back(v[2], v[3], v[4]);
    toss.orientation.push_back(Eigen::Quaterniond(v[5], v[6], v[7], v[8]).normalized());
  }
  const bool error = gzeof(file) == 0;
  gzclose(file);
  if (error) throw std::runtime_error(gz_path + ": read error (corrupt gzip?)");
  return tosses;
}

double lowestCornerHeight(const Eigen::Vector3d& position, const Eigen::Quaterniond& orientation,
                          double half_width) {
  // The lowest corner's height is the centre's minus h (|R_z0| + |R_z1| + |R_z2|): the corner whose
  // signs oppose the third row of the rotation.
  const Eigen::Matrix3d R = orientation.toRotationMatrix();
  return position.z() - half_width * R.row(2).cwiseAbs().sum();
}

double tableHeight(const TossFrames& toss, double half_width, int rest_frames) {
  const int n = std::min(rest_frames, toss.size());
  std::vector<double> heights;
  for (int k = toss.size() - n; k < toss.size(); ++k)
    heights.push_back(lowestCornerHeight(toss.position[k], toss.orientation[k], half_width));
  std::nth_element(heights.begin(), heights.begin() + heights.size() / 2, heights.end());
  return heights[heights.size() / 2];
}

CubeState FlightFit::stateAt(double t, double gravity_z) const {
  const double tau = t - t_ref;
  CubeState state;
  const Eigen::Vector3d g(0.0, 0.0, gravity_z);
  state.position = position + tau * linear_velocity + 0.5 * tau * tau * g;
  state.linear_velocity = linear_velocity + tau * g;
  state.orientation = (expMap(angular_velocity * tau) * orientation).normalized();
  state.angular_velocity = angular_velocity;
  return state;
}

FlightFit fitFlight(const TossFrames& toss, int first, int last, double gravity_z) {
  if (first < 0 || last >= toss.size() || last - first < 2)
    throw std::invalid_argument("fitFlight: needs at least 3 frames within the toss");
  FlightFit fit;
  fit.first = first;
  fit.last = last;
  fit.t_ref = toss.time[first];
  fitCentre(toss, first, last, gravity_z, fit);
  fitRotation(toss, first, last, fit);
  return fit;
}

Extraction extractLanding(const TossFrames& raw, const TossedCube& cube,
                          const ExtractionOptions& options) {
  Extraction result;
  Landing& landing = result.landing;
  landing.toss = raw.index;
  if (raw.size() < options.rest_frames + options.min_pre_frames + options.min_post_frames) {
    result.reason = "too few frames";
    return result;
  }
  landing.table = tableHeight(raw, cube.half_width, options.rest_frames);
  TossFrames toss = raw;
  for (auto& p : toss.position) p.z() -= landing.table;
  std::vector<double> lowest(toss.size());
  for (int k = 0; k < toss.size(); ++k)
    lowest[k] = lowestCornerHeight(toss.position[k], toss.orientation[k], cube.half_width);

  // Before: the flight frames up to the first one at or below the clearance.
  int contact = 0;
  while (contact < toss.size() && lowest[contact] > options.clearance) ++contact;
  landing.contact_frame = contact;
  if (contact == toss.size()) {
    result.reason = "no contact";
    return result;
  }
  if (contact < options.min_pre_frames) {
    result.reason = "short flight before the landing";
    return result;
  }
  const int pre_first = std::max(0, contact - options.max_pre_frames);
  landing.pre = fitFlight(toss, pre_first, contact - 1, options.gravity_z);

  // After: the first run of flight frames long enough to fit, starting soon enough.
  int from = contact;
  std::pair<int, int> run{-1, -1};
  while (true) {
    run = nextFlightRun(lowest, from, options.clearance);
    if (run.first < 0 || toss.time[run.first] - toss.time[contact] > options.max_landing_duration) {
      result.reason = "no clear flight after the landing";
      return result;
    }
    if (run.second - run.first >= options.min_post_frames) break;
    from = run.second;
  }
  const int post_last = std::min(run.second - 1, run.first + options.max_post_frames - 1);
  landing.post = fitFlight(toss, run.first, post_last, options.gravity_z);

  const double rms_limit = options.max_fit_rms;
  if (landing.pre.position_rms > rms_limit ||
      landing.pre.rotation_rms * cube.half_width > rms_limit) {
    result.reason = "the flight before the landing is not ballistic";
    return result;
  }
  if (landing.post.position_rms > rms_limit ||
      landing.post.rotation_rms * cube.half_width > rms_limit) {
    result.reason = "the flight after the landing is not ballistic";
    return result;
  }
  landing.t_before = toss.time[contact - 1];
  landing.t_after = toss.time[run.first];
  landing.before = landing.pre.stateAt(landing.t_before, options.gravity_z);
  landing.after = landing.post.stateAt(landing.t_after, options.gravity_z);
  result.ok = true;
  return result;
}

double cubeEnergy(const CubeState& state, const TossedCube& cube, double gravity_z) {
  return 0.5 * cube.mass * state.linear_velocity.squaredNorm() +
         0.5 * cube.inertia * state.angular_velocity.squaredNorm() -
         cube.mass * gravity_z * state.position.z();
}

}  // namespace collision_response::bench
