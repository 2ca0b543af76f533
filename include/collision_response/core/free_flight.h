#pragma once

#include <Eigen/Core>

#include "collision_response/core/body_state.h"

namespace collision_response::core {

/// Local error tolerance of the adaptive integration of torque-free rotation (advanceFreeFlight()
/// on a body whose principal moments differ): per step, the orientation's error (a unit
/// quaternion's components, dimensionless) is kept below this. Over a flight of N steps the
/// orientation is accurate to about N times it; a tumbling box over several turns stays within
/// 1e-8 rad of the exact motion (test_free_flight).
constexpr double kFreeFlightTolerance = 1e-12;

/// True if the body-frame inertia tensor is a multiple of the identity to a relative 1e-12 (a
/// cube, a sphere): its torque-free angular velocity is then constant.
bool isotropicInertia(const Eigen::Matrix3d& inertia);

/// Moves `body` by `dt` [s] (>= 0) of free flight, in place: position, orientation and velocities.
/// A movable body's centre of mass follows the ballistic parabola under `gravity` [m/s^2, world]
/// in closed form; its rotation is torque-free (Euler's equations): its world angular momentum
/// L = R I R^T w is conserved, and the orientation solves dR/dt = [w]x R with w = R I^-1 R^T L.
/// An isotropic inertia (isotropicInertia()) keeps w constant: exact rotation by w dt. Otherwise an
/// embedded Runge-Kutta 5(4) pair (Dormand-Prince) with step control to kFreeFlightTolerance on
/// the unit quaternion, renormalised after each step; w is then R I^-1 R^T L of the final
/// orientation, so that L is conserved exactly (to round-off) and the kinetic energy to the
/// integration's accuracy. An immovable body moves at its constant (prescribed) velocities,
/// without gravity. The body's force and torque are not read (they belong to the resting
/// analysis).
void advanceFreeFlight(BodyState& body, double dt, const Eigen::Vector3d& gravity);

/// A bound on |w| [rad/s] over the body's whole free flight: |w| itself for an isotropic inertia
/// (constant), |L| / I_min otherwise (L the conserved world angular momentum, I_min the smallest
/// principal moment); |w| for an immovable body (constant).
double angularSpeedBound(const BodyState& body);

}  // namespace collision_response::core
