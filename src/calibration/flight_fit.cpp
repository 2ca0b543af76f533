#include "collision_response/calibration/flight_fit.h"

#include <Eigen/Dense>
#include <cmath>
#include <stdexcept>

namespace collision_response::calibration {
namespace {

/// Least-squares origin fit: p_k - g tau_k^2 / 2 = p0 + v0 tau_k over the samples.
void fitCentre(const PoseTrack& track, int first, int last, double gravity_z, FlightFit& fit) {
  const int n = last - first + 1;
  double st = 0.0, stt = 0.0;
  Eigen::Vector3d sp = Eigen::Vector3d::Zero(), stp = Eigen::Vector3d::Zero();
  const Eigen::Vector3d g(0.0, 0.0, gravity_z);
  for (int k = first; k <= last; ++k) {
    const double tau = track.time[k] - fit.t_ref;
    const Eigen::Vector3d y = track.position[k] - 0.5 * tau * tau * g;
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
    const double tau = track.time[k] - fit.t_ref;
    const Eigen::Vector3d model = fit.position + tau * fit.linear_velocity + 0.5 * tau * tau * g;
    sum += (track.position[k] - model).squaredNorm();
  }
  fit.position_rms = std::sqrt(sum / n);
}

/// Uniform-rotation fit q(tau) = exp(w tau) q0 (w world): the initial w from consecutive samples,
/// then Gauss-Newton on the residual rotation vectors log(q_k (exp(w tau_k) q0)^-1) over the 6
/// coordinates q0 <- exp(a) q0, w <- w + b, with the Jacobian by central differences (so that the
/// fixed point is the least-squares fit itself, not that of an approximate Jacobian).
void fitRotation(const PoseTrack& track, int first, int last, FlightFit& fit) {
  Eigen::Vector3d w = Eigen::Vector3d::Zero();
  for (int k = first; k < last; ++k) {
    const Eigen::Quaterniond step = track.orientation[k + 1] * track.orientation[k].conjugate();
    w += rotationVector(step) / (track.time[k + 1] - track.time[k]);
  }
  w /= (last - first);
  Eigen::Quaterniond q0 = track.orientation[first];
  const int n = last - first + 1;
  auto residuals = [&](const Eigen::Quaterniond& q, const Eigen::Vector3d& omega) {
    Eigen::VectorXd r(3 * n);
    for (int k = first; k <= last; ++k)
      r.segment<3>(3 * (k - first)) =
          rotationVector(track.orientation[k] *
                         (quaternionOf(omega * (track.time[k] - fit.t_ref)) * q).conjugate());
    return r;
  };
  auto perturbed = [&](const Eigen::Matrix<double, 6, 1>& x) {
    return residuals(quaternionOf(x.head<3>()) * q0, w + x.tail<3>());
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
    q0 = (quaternionOf(step.head<3>()) * q0).normalized();
    w += step.tail<3>();
    if (step.norm() < 1e-13) break;
  }
  fit.orientation = q0;
  fit.angular_velocity = w;
  fit.rotation_rms = std::sqrt(residuals(q0, w).squaredNorm() / n);
}

}  // namespace

Eigen::Vector3d rotationVector(Eigen::Quaterniond q) {
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  const double s = q.vec().norm();
  if (s < 1e-12) return 2.0 * q.vec();
  return 2.0 * std::atan2(s, q.w()) / s * q.vec();
}

Eigen::Quaterniond quaternionOf(const Eigen::Vector3d& v) {
  const double angle = v.norm();
  if (angle < 1e-12)
    return Eigen::Quaterniond(1.0, 0.5 * v.x(), 0.5 * v.y(), 0.5 * v.z()).normalized();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, v / angle));
}

MotionState FlightFit::stateAt(double t, double gravity_z) const {
  const double tau = t - t_ref;
  MotionState state;
  const Eigen::Vector3d g(0.0, 0.0, gravity_z);
  state.position = position + tau * linear_velocity + 0.5 * tau * tau * g;
  state.linear_velocity = linear_velocity + tau * g;
  state.orientation = (quaternionOf(angular_velocity * tau) * orientation).normalized();
  state.angular_velocity = angular_velocity;
  return state;
}

FlightFit fitFlight(const PoseTrack& track, int first, int last, double gravity_z) {
  if (first < 0 || last >= track.size() || last - first < 2)
    throw std::invalid_argument("fitFlight: needs at least 3 samples within the track");
  FlightFit fit;
  fit.first = first;
  fit.last = last;
  fit.t_ref = track.time[first];
  fitCentre(track, first, last, gravity_z, fit);
  fitRotation(track, first, last, fit);
  return fit;
}

}  // namespace collision_response::calibration
