// A ballistic fit to the free flight of a recorded object (docs/calibration.md, "Extraction"):
// the origin quadratic in time under gravity, the rotation uniform about a constant world axis.
#pragma once

#include "collision_response/calibration/motion_state.h"
#include "collision_response/calibration/pose_track.h"

namespace collision_response::calibration {

/// A fit over the samples [first, last] (inclusive) of a track: the origin p0 + v0 tau + g tau^2/2
/// (least squares on p0, v0 with gravity fixed), the orientation exp(w tau) q0 with w constant in
/// the world frame (the exact torque-free motion of a body with isotropic inertia, a first-order
/// model of any other over a short flight; Gauss-Newton on the residual rotation vectors).
/// tau = t - t_ref.
struct FlightFit {
  int first = 0, last = -1;  ///< samples fitted
  double t_ref = 0.0;        ///< [s] the time of the fitted state (sample `first`)
  Eigen::Vector3d position = Eigen::Vector3d::Zero();               ///< at t_ref [m]
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();        ///< at t_ref [m/s]
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< at t_ref
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();       ///< world, constant [rad/s]
  double position_rms = 0.0;  ///< RMS of the origin's residuals [m]
  double rotation_rms = 0.0;  ///< RMS of the residual rotation angles [rad]
  /// The state at time t [s] on the fitted flight (gravity g along z [m/s^2]).
  MotionState stateAt(double t, double gravity_z) const;
};

/// Fits samples [first, last] of `track` (needs last - first >= 2; throws std::invalid_argument
/// otherwise). gravity_z [m/s^2], e.g. -9.81.
FlightFit fitFlight(const PoseTrack& track, int first, int last, double gravity_z);

/// Rotation vector [rad] of a unit quaternion (the shortest rotation: angle in [0, pi]).
Eigen::Vector3d rotationVector(Eigen::Quaterniond q);
/// Unit quaternion of a rotation vector [rad].
Eigen::Quaterniond quaternionOf(const Eigen::Vector3d& rotation_vector);

}  // namespace collision_response::calibration
