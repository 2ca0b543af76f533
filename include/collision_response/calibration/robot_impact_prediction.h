// The predicted outcome of a robot's recorded impact under given coefficients (docs/calibration.md,
// "Robot recordings"): the robot (a fixed-base model from its URDF, its links' collision geometry)
// from its state at the last sample before the jump against a fixed obstacle (the object file's
// shape at its position), by the episode of general bodies (core::computeBodyEpisode(), the robot
// moving by its forward dynamics under its torque model) or one impact, then by its forward
// dynamics alone to the first sample after the jump, where the measured velocities are; and the
// residual the fit minimises.
#pragma once

#include <Eigen/Core>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "collision_response/calibration/landing_prediction.h"
#include "collision_response/calibration/object_model.h"
#include "collision_response/calibration/robot_impact_extraction.h"
#include "collision_response/detection/shapes.h"
#include "collision_response/robot/articulated_body.h"

namespace collision_response::calibration {

/// The recorded robot: its dynamics and its links' collision geometry (by link name, in the link
/// frames, as the ros library's linkCollisionGeometry() gives it; links without geometry are
/// absent or empty). `source` names it for messages (the URDF file).
struct RobotDescription {
  std::string source;
  std::shared_ptr<const robot::ArticulatedBody> robot;
  std::map<std::string, detection::BodyGeometry> links;
};

struct RobotPredictionOptions {
  core::ImpactLaw law = core::ImpactLaw::kStronge;
  /// One impact only: the episode stops at its second impact and the robot moves on by its
  /// dynamics alone, as if the obstacle were gone.
  bool single_impact = false;
  /// Gravity in the robot's base frame [m/s^2] (the base frame is the world; z up by default).
  Eigen::Vector3d gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  /// The torque model between impacts: the joint torques that hold the robot against gravity
  /// (tau = g(q)); false: none (the joints passive, the robot swinging under gravity).
  bool gravity_compensation = false;
};

/// The residual of one robot impact: (qdot_predicted - qdot_measured) / |qdot_before| over the
/// recorded joints (the track's order) at the first sample after the jump, relative to the speed
/// of the joints just before it (so that fast and slow strikes weigh alike).
class RobotImpactPredictor {
 public:
  /// The scene of `robot`, whose every joint `joints` must name once (the recorded joints, in the
  /// track's order; `recording` names them in messages), against `obstacle` fixed at its pose
  /// (ObjectModel::position, orientation; its mass and inertia are not used). Throws
  /// std::runtime_error naming the recording and the robot's source for a joint not in the robot
  /// or a robot joint not recorded, naming the robot for links without geometry or a model that
  /// episodes refuse (a floating base, a singular mass matrix), naming the obstacle's source for a
  /// shape the detection rejects.
  RobotImpactPredictor(const RobotDescription& robot, const std::vector<std::string>& joints,
                       const std::string& recording, const ObjectModel& obstacle,
                       const RobotPredictionOptions& options);
  ~RobotImpactPredictor();
  RobotImpactPredictor(const RobotImpactPredictor&) = delete;
  RobotImpactPredictor& operator=(const RobotImpactPredictor&) = delete;

  /// The recorded joints' velocities at impact.t_after predicted from the state at t_before.
  /// Thread safe (const). Throws what computeBodyEpisode() throws.
  Eigen::VectorXd predict(const RobotImpact& impact, const Coefficients& coefficients) const;
  Eigen::VectorXd residual(const RobotImpact& impact, const Coefficients& coefficients) const;
  int joints() const { return static_cast<int>(index_.size()); }

 private:
  struct Impl;
  std::vector<int> index_;  // recorded joint j is the robot's joint index_[j]
  RobotPredictionOptions options_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace collision_response::calibration
