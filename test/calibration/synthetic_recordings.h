// Synthetic recordings of a cube (or a sphere) tossed onto the floor z = 0 for the calibration's
// tests: the true motion from core::computeEpisode() with known coefficients (e, mu_s, mu_d, the
// impact law, the inertia's scale) and a closed-form shape-against-plane gap query (the cube's 8
// corners, the sphere's lowest point; independent of detection::ShapeGaps, which the
// calibration's predictions use), sampled at 148 Hz, with seeded Gaussian tracking noise on the
// positions and the orientations.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "collision_response/calibration/object_model.h"
#include "collision_response/calibration/pose_track.h"
#include "collision_response/core/episode.h"
#include "collision_response/core/gap_query.h"

namespace collision_response::calibration::test {

/// CR_CALIBRATION_SMALL set (and not "0"): the tests fit fewer synthetic landings (the sanitizer
/// pass, scripts/sanitize.sh, sets it: there a prediction costs about 20 times as much).
inline bool smallDataSet() {
  const char* v = std::getenv("CR_CALIBRATION_SMALL");
  return v != nullptr && *v != '\0' && std::string(v) != "0";
}

/// `full` normally, `small` when smallDataSet().
inline int sized(int full, int small) {
  return smallDataSet() ? small : full;
}

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

inline ObjectModel syntheticSphere() {
  ObjectModel sphere;
  sphere.source = "synthetic sphere";
  sphere.shape.type = detection::Shape::Type::kSphere;
  sphere.shape.dimensions = {0.05};
  sphere.mass = 0.2;
  sphere.inertia = uniformInertia(sphere.shape, sphere.mass);
  sphere.material_a = "sphere";
  sphere.material_b = "floor";
  sphere.floor_height = 0.0;
  return sphere;
}

/// The true coefficients of a synthetic toss.
struct TrueCoefficients {
  double e = 0.45;
  double mu_s = 0.3, mu_d = 0.3;
  double inertia_scale = 1.0;  ///< the body's inertia is this times the object model's
  core::ImpactLaw law = core::ImpactLaw::kStronge;
};

/// The ranges of a toss's random initial state.
struct TossRanges {
  double horizontal_speed = 1.2;  ///< [m/s] each horizontal component in +- this
  double spin = 8.0;              ///< [rad/s] each angular velocity component in +- this
  double height = 0.28;           ///< [m] the centre's start above the floor
  double min_fall_speed = 0.5;    ///< [m/s] the downward start speed, uniform in [min, max]
  double max_fall_speed = 2.5;
};

/// The sphere (body 1, radius r) against the plane z = 0 (body 0): its lowest point's height.
class SphereBottom final : public core::GapQuery {
 public:
  SphereBottom(double r, const TrueCoefficients& c) : r_(r), c_(c) {}
  void gaps(const std::vector<core::BodyState>& bodies, double range,
            std::vector<core::GapContact>& out) const override {
    out.clear();
    const Eigen::Vector3d p = bodies[1].position - r_ * Eigen::Vector3d::UnitZ();
    if (p.z() > range) return;
    core::GapContact c;
    c.body_a = 0;
    c.body_b = 1;
    c.point = p;
    c.normal = Eigen::Vector3d::UnitZ();
    c.gap = p.z();
    c.restitution = c_.e;
    c.static_friction = c_.mu_s;
    c.dynamic_friction = c_.mu_d;
    out.push_back(c);
  }
  double radius(int body) const override {
    return body == 0 ? std::numeric_limits<double>::infinity() : r_;
  }
  int bodyCount() const override { return 2; }

 private:
  double r_;
  TrueCoefficients c_;
};

/// The cube (body 1, half width h) against the plane z = 0 (body 0): its 8 corners' heights.
class CubeCorners final : public core::GapQuery {
 public:
  CubeCorners(double h, double e, double mu) : h_(h), e_(e), mu_s_(mu), mu_d_(mu) {}
  CubeCorners(double h, const TrueCoefficients& c) : h_(h), e_(c.e), mu_s_(c.mu_s), mu_d_(c.mu_d) {}
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
      c.static_friction = mu_s_;
      c.dynamic_friction = mu_d_;
      out.push_back(c);
    }
  }
  double radius(int body) const override {
    return body == 0 ? std::numeric_limits<double>::infinity() : h_ * std::sqrt(3.0);
  }
  int bodyCount() const override { return 2; }

 private:
  double h_, e_, mu_s_, mu_d_;
};

/// A toss of `object` (syntheticCube() or syntheticSphere(): isotropic inertias, so that the free
/// flight turns at a constant angular velocity) from a random state (seeded by `rng`) with the
/// coefficients `c`, sampled noise-free for `duration` [s] or until the episode ends in sustained
/// contact. Empty if the episode hit its impact cap or time budget, or closed an accumulation of
/// bounces (whose impacts are not listed one by one, so the motion between them cannot be sampled
/// here).
inline PoseTrack trueToss(std::mt19937& rng, const ObjectModel& object, const TrueCoefficients& c,
                          double duration = 0.5, const TossRanges& ranges = {}) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  core::BodyState floor, body;
  floor.id = "floor";
  body.id = "object";
  body.mass = object.mass;
  body.inertia = c.inertia_scale * object.inertia;
  body.position = Eigen::Vector3d(0.0, 0.0, ranges.height);
  body.orientation = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized();
  const double vh = ranges.horizontal_speed;
  const double fall = ranges.max_fall_speed - ranges.min_fall_speed;
  body.linear_velocity = Eigen::Vector3d(vh * u(rng), vh * u(rng),
                                         -ranges.min_fall_speed - 0.5 * fall * (u(rng) + 1.0));
  body.angular_velocity = ranges.spin * Eigen::Vector3d(u(rng), u(rng), u(rng));
  core::EpisodeOptions options;
  options.gravity = Eigen::Vector3d(0.0, 0.0, kGravityZ);
  options.horizon = duration;
  options.solver.law = c.law;
  const bool sphere = object.shape.type == detection::Shape::Type::kSphere;
  const CubeCorners corners(0.5 * object.shape.dimensions[0], c);
  const SphereBottom bottom(object.shape.dimensions[0], c);
  const core::GapQuery& gaps = sphere ? static_cast<const core::GapQuery&>(bottom) : corners;
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

/// A toss of the synthetic cube with coefficients (e, mu_s = mu_d = mu) under `law`.
inline PoseTrack trueToss(std::mt19937& rng, double e, double mu, core::ImpactLaw law,
                          double duration = 0.5) {
  TrueCoefficients c;
  c.e = e;
  c.mu_s = c.mu_d = mu;
  c.law = law;
  return trueToss(rng, syntheticCube(), c, duration);
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
