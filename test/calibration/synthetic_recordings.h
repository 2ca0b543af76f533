// Synthetic recordings of a cube tossed onto the floor z = 0 for the calibration's tests: the true
// motion from core::computeEpisode() with known coefficients and a closed-form cube-against-plane
// gap query (the 8 corners; independent of detection::ShapeGaps, which the calibration's
// predictions use), sampled at 148 Hz, with seeded Gaussian tracking noise on the positions and
// the orientations.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "collision_response/calibration/object_model.h"
#include "collision_response/calibration/pose_track.h"
#include "collision_response/core/episode.h"
#include "collision_response/core/gap_query.h"

namespace collision_response::calibration::test {

constexpr double kSampleRate = 148.0;  // [Hz], the cube tosses' tracking rate
constexpr double kGravityZ = -9.81;

inline ObjectModel syntheticCube() {
  ObjectModel cube;
  cube.source = "synthetic cube";
  cube.shape.type = detection::Shape::Type::kBox;
  cube.shape.dimensions = {0.1048, 0.1048, 0.1048};
  cube.mass = 0.37;
  cube.inertia = uniformInertia(cube.shape, cube.mass);
  cube.material_a = "cube";
  cube.material_b = "floor";
  cube.floor_height = 0.0;
  return cube;
}

/// The cube (body 1, half width h) against the plane z = 0 (body 0): its 8 corners' heights.
class CubeCorners final : public core::GapQuery {
 public:
  CubeCorners(double h, double e, double mu) : h_(h), e_(e), mu_(mu) {}
  void gaps(const std::vector<core::BodyState>& bodies, double range,
            std::vector<core::GapContact>& out) const override {
    out.clear();
    const Eigen::Matrix3d R = bodies[1].orientation.normalized().toRotationMatrix();
    for (int i = 0; i < 8; ++i) {
      const Eigen::Vector3d corner(i & 1 ? h_ : -h_, i & 2 ? h_ : -h_, i & 4 ? h_ : -h_);
      const Eigen::Vector3d p = bodies[1].position + R * corner;
      if (p.z() > range) continue;
      core::GapContact c;
      c.body_a = 0;
      c.body_b = 1;
      c.point = p;
      c.normal = Eigen::Vector3d::UnitZ();
      c.gap = p.z();
      c.restitution = e_;
      c.static_friction = mu_;
      c.dynamic_friction = mu_;
      out.push_back(c);
    }
  }
  double radius(int body) const override {
    return body == 0 ? std::numeric_limits<double>::infinity() : h_ * std::sqrt(3.0);
  }
  int bodyCount() const override { return 2; }

 private:
  double h_, e_, mu_;
};

/// A toss from a random state (seeded by `rng`) with coefficients (e, mu) under `law`, sampled
/// noise-free for `duration` [s] or until the episode ends in sustained contact. Empty if the
/// episode hit its impact cap or time budget, or closed an accumulation of bounces (whose impacts
/// are not listed one by one, so the motion between them cannot be sampled here).
inline PoseTrack trueToss(std::mt19937& rng, double e, double mu, core::ImpactLaw law,
                          double duration = 0.5) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const ObjectModel cube = syntheticCube();
  core::BodyState floor, body;
  floor.id = "floor";
  body.id = "cube";
  body.mass = cube.mass;
  body.inertia = cube.inertia;
  body.position = Eigen::Vector3d(0.0, 0.0, 0.28);
  body.orientation = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized();
  body.linear_velocity = Eigen::Vector3d(1.2 * u(rng), 1.2 * u(rng), -0.5 - 1.0 * (u(rng) + 1.0));
  body.angular_velocity = 8.0 * Eigen::Vector3d(u(rng), u(rng), u(rng));
  core::EpisodeOptions options;
  options.gravity = Eigen::Vector3d(0.0, 0.0, kGravityZ);
  options.horizon = duration;
  options.solver.law = law;
  const CubeCorners gaps(0.0524, e, mu);
  const core::EpisodeResult result = core::computeEpisode({floor, body}, gaps, options);
  PoseTrack track;
  track.source = "synthetic toss";
  if (result.end == core::EpisodeEnd::kImpactCap || result.end == core::EpisodeEnd::kTimeBudget ||
      result.accumulated_impacts > 0)
    return track;
  const double last =
      result.end == core::EpisodeEnd::kSustainedContact ? result.end_time : duration;
  for (int k = 0;; ++k) {
    const double t = k / kSampleRate;
    if (t > last) break;
    // The last impact at or before t, then free flight (constant angular velocity: isotropic).
    core::BodyState s = body;
    double t0 = 0.0;
    for (const auto& impact : result.impacts)
      if (impact.time <= t) {
        s = impact.bodies_after[1];
        t0 = impact.time;
      }
    const double tau = t - t0;
    const Eigen::Vector3d w = s.angular_velocity;
    const double angle = w.norm() * tau;
    const Eigen::Quaterniond turn =
        angle > 0.0 ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, w.normalized()))
                    : Eigen::Quaterniond::Identity();
    track.time.push_back(t);
    track.position.push_back(s.position + tau * s.linear_velocity +
                             0.5 * tau * tau * options.gravity);
    track.orientation.push_back((turn * s.orientation).normalized());
  }
  return track;
}

/// The track with Gaussian noise: sigma_position [m] on each coordinate, sigma_rotation [rad] on
/// each component of a small rotation applied to the orientation.
inline PoseTrack noisy(const PoseTrack& track, std::mt19937& rng, double sigma_position,
                       double sigma_rotation) {
  std::normal_distribution<double> n(0.0, 1.0);
  PoseTrack out = track;
  for (int k = 0; k < out.size(); ++k) {
    out.position[k] += sigma_position * Eigen::Vector3d(n(rng), n(rng), n(rng));
    const Eigen::Vector3d r = sigma_rotation * Eigen::Vector3d(n(rng), n(rng), n(rng));
    out.orientation[k] =
        (Eigen::Quaterniond(Eigen::AngleAxisd(r.norm(), r.normalized())) * out.orientation[k])
            .normalized();
  }
  return out;
}

}  // namespace collision_response::calibration::test
