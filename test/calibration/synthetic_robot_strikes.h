// Synthetic recordings of a robot striking a fixed obstacle for the robot calibration's tests: the
// planar 2R arm of striking_arm.urdf (passive joints; gravity along -z, out of its plane) whose tip
// ball (radius 0.05 m) strikes a fixed sphere (radius 0.1 m). The true motion is the package's
// robot episode (core::computeBodyEpisode() over robot::RobotEpisodeBody) with known coefficients,
// on a closed-form ball-against-sphere gap query (independent of detection::ShapeGaps, which the
// identification's predictions use), sampled at 500 Hz with seeded Gaussian noise on the joint
// positions.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "collision_response/calibration/joint_track.h"
#include "collision_response/calibration/landing_prediction.h"
#include "collision_response/calibration/object_model.h"
#include "collision_response/calibration/robot_impact_prediction.h"
#include "collision_response/core/body_episode.h"
#include "collision_response/core/gap_query.h"
#include "collision_response/core/rigid_episode_body.h"
#include "collision_response/robot/robot_episode_body.h"
#include "collision_response/robot/urdf_loader.h"

namespace collision_response::calibration::test {

constexpr double kArmRate = 500.0;  // [Hz]
constexpr double kL1 = 1.0, kL2 = 0.8, kTipRadius = 0.05, kObstacleRadius = 0.1;
inline const Eigen::Vector3d kObstacleCentre(1.2, 0.6, 0.0);

/// The fixed sphere as the object file would give it (material pair arm / post).
inline ObjectModel strikeObstacle() {
  ObjectModel o;
  o.source = "synthetic post";
  o.shape.type = detection::Shape::Type::kSphere;
  o.shape.dimensions = {kObstacleRadius};
  o.mass = 1.0;
  o.inertia = uniformInertia(o.shape, o.mass);
  o.material_a = "arm";
  o.material_b = "post";
  o.position = kObstacleCentre;
  return o;
}

/// The arm from striking_arm.urdf and its tip ball (the URDF's collision, written out here).
inline RobotDescription strikingArm(const std::string& urdf) {
  RobotDescription d;
  d.source = urdf;
  d.robot = std::make_shared<const robot::ArticulatedBody>(robot::robotFromUrdfFile(urdf));
  detection::Shape ball;
  ball.type = detection::Shape::Type::kSphere;
  ball.dimensions = {kTipRadius};
  d.links["tip"].shapes = {ball};
  return d;
}

/// Closed form: body 0 the fixed sphere, body 1 the tip ball (its part frame's origin the centre).
class TipAndPost final : public core::GapQuery {
 public:
  explicit TipAndPost(const Coefficients& c) : c_(c) {}
  void gaps(const std::vector<core::BodyState>& bodies, double range,
            std::vector<core::GapContact>& out) const override {
    out.clear();
    const Eigen::Vector3d centre = bodies[1].position;
    core::GapContact g;
    g.body_a = 0;
    g.body_b = 1;
    g.normal = (centre - kObstacleCentre).normalized();
    g.gap = (centre - kObstacleCentre).norm() - kTipRadius - kObstacleRadius;
    g.point = centre - kTipRadius * g.normal;
    g.restitution = c_.restitution;
    g.static_friction = c_.static_friction;
    g.dynamic_friction = c_.dynamic_friction;
    if (g.gap <= range) out.push_back(g);
  }
  double radius(int body) const override { return body == 1 ? kTipRadius : kObstacleRadius; }
  bool convex(int) const override { return true; }
  int bodyCount() const override { return 2; }

 private:
  Coefficients c_;
};

/// One strike: the tip ball reaches the post at angle `phi` around it (the contact normal's
/// direction in the plane) at tip speed `speed` [m/s], `beta` [rad] off head-on (a glancing blow
/// slides), about `lead` [s] after the recording starts (the joints' state then is the contact
/// state less its velocities times lead: the arm's slight Coriolis curvature moves the contact a
/// little), recorded for `duration` [s].
struct Strike {
  double phi = 0.0, speed = 1.0, beta = 0.0, lead = 0.1, duration = 0.3;
  /// Gravity in the base frame [m/s^2] (along -z: out of the arm's plane) and the torque model:
  /// passive joints, or holding the arm against gravity (tau = g(q)).
  Eigen::Vector3d gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  bool gravity_compensation = false;
};

struct StrikeRecording {
  JointTrack track;
  /// The true joint velocities just before and after the first impact (from the episode), and
  /// its time [s], for checking the extraction.
  Eigen::VectorXd qdot_before, qdot_after;
  double impact_time = -1.0;
};

/// The recording of `strike` under `truth` (law `law`), noise `noise` [rad] on each joint
/// position, seeded.
inline StrikeRecording strikeRecording(const RobotDescription& arm, const Strike& strike,
                                       const Coefficients& truth, core::ImpactLaw law, double noise,
                                       unsigned seed) {
  // The tip's centre at contact and its inverse kinematics (elbow positive).
  const Eigen::Vector2d n(std::cos(strike.phi), std::sin(strike.phi));
  const Eigen::Vector2d tip = kObstacleCentre.head<2>() + (kTipRadius + kObstacleRadius) * n;
  const double d2 = tip.squaredNorm();
  const double q2 = std::acos((d2 - kL1 * kL1 - kL2 * kL2) / (2 * kL1 * kL2));
  const double q1 =
      std::atan2(tip.y(), tip.x()) - std::atan2(kL2 * std::sin(q2), kL1 + kL2 * std::cos(q2));
  Eigen::Matrix2d J;
  J << -kL1 * std::sin(q1) - kL2 * std::sin(q1 + q2), -kL2 * std::sin(q1 + q2),
      kL1 * std::cos(q1) + kL2 * std::cos(q1 + q2), kL2 * std::cos(q1 + q2);
  const Eigen::Vector2d t(-n.y(), n.x());
  const Eigen::Vector2d v = strike.speed * (-std::cos(strike.beta) * n + std::sin(strike.beta) * t);
  const Eigen::Vector2d qdot_c = J.lu().solve(v);
  const Eigen::Vector2d q_c(q1, q2);

  robot::ArticulatedBody model = *arm.robot;
  model.setState(q_c - strike.lead * qdot_c, qdot_c);
  if (strike.gravity_compensation)
    model.setGravityCompensation(strike.gravity);
  else
    model.setLoads(Eigen::VectorXd::Zero(2), strike.gravity);
  const int link = model.linkIndex("tip");
  robot::RobotEpisodeBody body(std::move(model));
  core::BodyState post;
  post.id = "post";
  post.position = kObstacleCentre;
  core::RigidEpisodeBody fixed(post);
  const TipAndPost gaps(truth);
  core::EpisodeOptions options;
  options.gravity = strike.gravity;
  options.horizon = 1.0 / kArmRate;
  options.max_impacts = 100;
  options.contact_tolerance = 1e-6;
  options.solver.law = law;

  StrikeRecording out;
  out.track.source = "synthetic strike";
  out.track.names = {"shoulder", "elbow"};
  std::mt19937 random(seed);
  std::normal_distribution<double> gauss(0.0, noise);
  const int samples = static_cast<int>(std::lround(strike.duration * kArmRate));
  for (int k = 0; k < samples; ++k) {
    const double time = k / kArmRate;
    Eigen::VectorXd q = body.robot().jointPositions();
    for (int j = 0; j < q.size(); ++j) q[j] += gauss(random);
    out.track.time.push_back(time);
    out.track.position.push_back(q);
    // On to the next sample: the episode, then free motion for what is left of the interval.
    const Eigen::VectorXd before = body.robot().jointVelocities();
    const core::BodyEpisodeResult r =
        core::computeBodyEpisode({&fixed, &body}, {{0, 0}, {1, link}}, gaps, options);
    if (options.horizon - r.end_time > 0.0) body.advance(options.horizon - r.end_time);
    if (!r.impacts.empty() && out.impact_time < 0.0) {
      out.impact_time = time + r.impacts.front().time;
      out.qdot_before = before;  // (free motion changes it by ~1e-4 over a sample)
      out.qdot_after = r.impacts.front().velocities_after[1];
    }
  }
  return out;
}

}  // namespace collision_response::calibration::test
