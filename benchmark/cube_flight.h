// The tossed cube's free flight and its first contact with the table (z = 0), shared by the
// landing models of the real-tosses benchmark (real_tosses.cpp).
#pragma once

#include <array>

#include "landing_model.h"

namespace collision_response::bench {

constexpr double kTossGravityZ = -9.81;  ///< [m/s^2]

/// The state after `duration` [s] of free flight: the centre ballistic under gravity
/// (0, 0, kTossGravityZ), the rotation uniform at the constant angular velocity (exact torque-free
/// motion of a body of isotropic inertia such as the uniform cube). The table is not seen.
CubeState flyBallistic(const CubeState& state, double duration);

/// The cube's 8 corners, world [m].
std::array<Eigen::Vector3d, 8> cubeCorners(const CubeState& state, double half_width);

/// The first time t in [0, limit] [s] at which free flight from `state` brings a corner to the
/// table (lowest corner height <= tolerance [m], tolerance > 0), by conservative advancement: each
/// step is the lowest corner's height over a bound on its approach speed (|v| + |g| limit +
/// |w| h sqrt(3)), so no contact is stepped over. Returns a value > limit if there is none.
double firstTableContact(const CubeState& state, double half_width, double limit, double tolerance);

}  // namespace collision_response::bench
