#include "collision_response/ros/robot_uncertainty.h"

#include <cmath>
#include <limits>
#include <string>

#include "collision_response/robot/articulated_body.h"
#include "collision_response/ros/uncertainty_conversion.h"

namespace collision_response {
namespace {

// One thread's bodies: its own rigid bodies and robots, and the models pointing at them.
struct BodyCopy {
  std::vector<core::RigidBody> rigid;
  std::vector<robot::ArticulatedBody> robots;
  std::vector<core::BodyModel*> models;
};

}  // namespace

OutcomeDistribution robotOutcomeDistribution(
    const std::vector<ContactUncertainty>& uncertainties, const std::vector<core::RigidBody>& rigid,
    const std::vector<RequestRobot>& robots, const std::vector<core::ContactPoint>& points,
    const core::SolverOptions& options, const core::UncertaintyOptions& uncertainty,
    core::WorkerPool* pool, std::vector<core::Warning>& warnings) {
  // One set of copies per thread for the sampled method; the linear one solves once, on one set.
  const std::size_t copy_count =
      pool != nullptr && uncertainty.method == core::UncertaintyMethod::kSampled
          ? static_cast<std::size_t>(pool->threads())
          : 1;
  std::vector<BodyCopy> copies(copy_count);
  std::vector<std::vector<core::BodyModel*>> models;
  models.reserve(copy_count);
  for (BodyCopy& copy : copies) {
    copy.rigid = rigid;
    copy.robots.reserve(robots.size());
    for (const RequestRobot& robot : robots) copy.robots.push_back(*robot.model);
    for (core::RigidBody& body : copy.rigid) copy.models.push_back(&body);
    for (robot::ArticulatedBody& body : copy.robots) copy.models.push_back(&body);
    models.push_back(copy.models);
  }

  // The unknowns' offsets and limits, as computeBodyOutcomeDistribution() stacks them.
  const int rigid_count = static_cast<int>(rigid.size());
  std::vector<int> offset(models.front().size(), -1);
  int count = 0;
  for (std::size_t b = 0; b < offset.size(); ++b) {
    const int n = models.front()[b]->velocityCount();
    if (n == 0) continue;
    offset[b] = count;
    count += n;
  }
  Eigen::VectorXd limits =
      Eigen::VectorXd::Constant(count, std::numeric_limits<double>::infinity());
  for (std::size_t r = 0; r < robots.size(); ++r) {
    const int b = rigid_count + static_cast<int>(r);
    if (offset[b] < 0) continue;
    const robot::ArticulatedBody& model = *robots[r].model;
    for (int k = 0; k < model.velocityCount(); ++k) {
      const int joint = model.jointOfUnknown(k);
      if (joint >= 0) limits(offset[b] + k) = model.velocityLimit(joint);
    }
  }

  const core::OutcomeDistribution outcome = core::computeBodyOutcomeDistribution(
      models, points, fromMsg(uncertainties), limits, options, uncertainty, pool);
  OutcomeDistribution msg = toMsg(outcome);
  const std::vector<std::string> velocities = velocityLabels(offset, rigid_count, robots);
  for (std::size_t r = 0; r < velocities.size(); ++r) msg.labels[r] = velocities[r];
  for (std::size_t r = 0; r < velocities.size(); ++r) {
    if (!std::isfinite(limits(static_cast<Eigen::Index>(r)))) continue;
    msg.joint_limit_labels.push_back(velocities[r]);
    msg.joint_limit_probability.push_back(outcome.limit_probability[r]);
  }
  warnings.insert(warnings.end(), outcome.warnings.begin(), outcome.warnings.end());
  return msg;
}

}  // namespace collision_response
