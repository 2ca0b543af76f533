#include "cube_flight.h"

#include <algorithm>
#include <cmath>

namespace collision_response::bench {

CubeState flyBallistic(const CubeState& state, double duration) {
  CubeState out = state;
  const Eigen::Vector3d g(0.0, 0.0, kTossGravityZ);
  out.position = state.position + duration * state.linear_velocity + 0.5 * duration * duration * g;
  out.linear_velocity = state.linear_velocity + duration * g;
  const Eigen::Vector3d turn = state.angular_velocity * duration;
  const double angle = turn.norm();
  if (angle > 0.0)
    out.orientation =
        (Eigen::Quaterniond(Eigen::AngleAxisd(angle, turn / angle)) * state.orientation)
            .normalized();
  return out;
}

std::array<Eigen::Vector3d, 8> cubeCorners(const CubeState& state, double half_width) {
  std::array<Eigen::Vector3d, 8> corners;
  const Eigen::Matrix3d R = state.orientation.toRotationMatrix();
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d local((i & 1) ? half_width : -half_width,
                                (i & 2) ? half_width : -half_width,
                                (i & 4) ? half_width : -half_width);
    corners[i] = state.position + R * local;
  }
  return corners;
}

namespace {
double lowestHeight(const CubeState& state, double half_width) {
  return state.position.z() -
         half_width * state.orientation.toRotationMatrix().row(2).cwiseAbs().sum();
}
}  // namespace

double firstTableContact(const CubeState& state, double half_width, double limit,
                         double tolerance) {
  const double bound = state.linear_velocity.norm() + std::abs(kTossGravityZ) * limit +
                       state.angular_velocity.norm() * half_width * std::sqrt(3.0);
  if (bound <= 0.0) return lowestHeight(state, half_width) <= tolerance ? 0.0 : 2.0 * limit + 1.0;
  double t = 0.0;
  for (int step = 0; step < 100000; ++step) {
    const double height = lowestHeight(flyBallistic(state, t), half_width);
    if (height <= tolerance) return t;
    t += height / bound;
    if (t > limit) return t;
  }
  return t;
}

}  // namespace collision_response::bench
