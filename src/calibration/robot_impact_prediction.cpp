#include "collision_response/calibration/robot_impact_prediction.h"

#include <algorithm>
#include <stdexcept>

#include "collision_response/calibration/coefficient_gaps.h"
#include "collision_response/core/body_episode.h"
#include "collision_response/core/rigid_episode_body.h"
#include "collision_response/detection/shape_gaps.h"
#include "collision_response/robot/robot_episode_body.h"

namespace collision_response::calibration {

struct RobotImpactPredictor::Impl {
  std::shared_ptr<const robot::ArticulatedBody> robot;
  core::BodyState obstacle;
  std::vector<core::EpisodePart> parts;  // the obstacle, then the links with geometry
  std::unique_ptr<detection::ShapeGaps> gaps;
};

RobotImpactPredictor::RobotImpactPredictor(const RobotDescription& robot,
                                           const std::vector<std::string>& joints,
                                           const std::string& recording,
                                           const ObjectModel& obstacle,
                                           const RobotPredictionOptions& options)
    : options_(options), impl_(new Impl) {
  if (!robot.robot) throw std::runtime_error(robot.source + ": no robot model");
  const robot::ArticulatedBody& model = *robot.robot;
  impl_->robot = robot.robot;
  for (const std::string& name : joints) {
    const auto& names = model.jointNames();
    const int index = static_cast<int>(std::find(names.begin(), names.end(), name) - names.begin());
    if (index == static_cast<int>(names.size()))
      throw std::runtime_error(recording + ": joint '" + name + "' is not a joint of " +
                               robot.source);
    index_.push_back(index);
  }
  for (int j = 0; j < model.jointCount(); ++j)
    if (std::find(index_.begin(), index_.end(), j) == index_.end())
      throw std::runtime_error(recording + ": joint '" + model.jointNames()[j] + "' of " +
                               robot.source + " is not recorded");

  impl_->obstacle.id = "obstacle";  // no mass: immovable
  impl_->obstacle.position = obstacle.position;
  impl_->obstacle.orientation = obstacle.orientation;
  detection::DetectionInput input;
  detection::BodyGeometry obstacle_geometry;
  obstacle_geometry.shapes = {obstacle.shape};
  input.geometry.push_back(obstacle_geometry);
  input.collision_groups.push_back(-1);
  impl_->parts.push_back({0, 0});
  for (int link = 0; link < model.linkCount(); ++link) {
    const auto it = robot.links.find(model.linkName(link));
    if (it == robot.links.end() || it->second.shapes.empty()) continue;
    input.geometry.push_back(it->second);
    input.collision_groups.push_back(0);  // the robot's links are never paired with each other
    impl_->parts.push_back({1, link});
  }
  if (impl_->parts.size() == 1)
    throw std::runtime_error(robot.source + ": no link has collision geometry");
  input.options.max_contacts_per_pair = 16;
  // The parts' states for the detection's set-up (the robot at its model's state).
  std::vector<core::BodyState> states;
  try {
    robot::RobotEpisodeBody body(model);  // refuses a floating base, a singular mass matrix
    core::RigidEpisodeBody fixed(impl_->obstacle);
    for (const core::EpisodePart& p : impl_->parts)
      states.push_back(p.body == 0 ? fixed.partGeometry(0) : body.partGeometry(p.part));
  } catch (const std::exception& e) {
    throw std::runtime_error(robot.source + ": " + e.what());
  }
  try {
    impl_->gaps = std::make_unique<detection::ShapeGaps>(states, input, detection::MaterialTable());
  } catch (const std::exception& e) {
    throw std::runtime_error(obstacle.source + " with " + robot.source + ": " + e.what());
  }
}

RobotImpactPredictor::~RobotImpactPredictor() = default;

Eigen::VectorXd RobotImpactPredictor::predict(const RobotImpact& impact,
                                              const Coefficients& c) const {
  robot::ArticulatedBody arm = *impl_->robot;
  Eigen::VectorXd q = arm.jointPositions(), qdot = Eigen::VectorXd::Zero(arm.jointCount());
  for (std::size_t j = 0; j < index_.size(); ++j) {
    q[index_[j]] = impact.q_before[j];
    qdot[index_[j]] = impact.qdot_before[j];
  }
  arm.setState(q, qdot);
  if (options_.gravity_compensation)
    arm.setGravityCompensation(options_.gravity);
  else
    arm.setLoads(Eigen::VectorXd::Zero(arm.jointCount()), options_.gravity);
  robot::RobotEpisodeBody body(std::move(arm));
  core::RigidEpisodeBody fixed(impl_->obstacle);
  const CoefficientGaps gaps(*impl_->gaps, c);
  const double duration = impact.t_after - impact.t_before;
  core::EpisodeOptions options;
  options.gravity = options_.gravity;
  options.horizon = duration;
  options.max_impacts = options_.single_impact ? 1 : 100;
  options.contact_tolerance = 1e-4;
  options.solver.law = options_.law;
  const core::BodyEpisodeResult result =
      core::computeBodyEpisode({&fixed, &body}, impl_->parts, gaps, options);
  // The rest of the interval by the robot's dynamics alone (it separated, or one impact only).
  if (duration - result.end_time > 0.0) body.advance(duration - result.end_time);
  Eigen::VectorXd out(index_.size());
  for (std::size_t j = 0; j < index_.size(); ++j)
    out[j] = body.robot().jointVelocities()[index_[j]];
  return out;
}

Eigen::VectorXd RobotImpactPredictor::residual(const RobotImpact& impact,
                                               const Coefficients& c) const {
  return (predict(impact, c) - impact.qdot_after) / impact.qdot_before.norm();
}

}  // namespace collision_response::calibration
