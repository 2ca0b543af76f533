#include "collision_response/ros/uncertainty_conversion.h"

#include <string>

#include "collision_response/core/errors.h"

namespace collision_response {

namespace {

std::optional<core::CoefficientDistribution> fromMsg(const Distribution& msg,
                                                     const std::string& field) {
  switch (msg.type) {
    case Distribution::TYPE_NONE:
      return std::nullopt;
    case Distribution::TYPE_NORMAL:
      return core::CoefficientDistribution::normal(msg.mean, msg.std_dev);
    case Distribution::TYPE_INTERVAL:
      return core::CoefficientDistribution::interval(msg.min, msg.max);
    default:
      throw core::InvalidInput(field + ".type", "unknown type " + std::to_string(msg.type) +
                                                    " (0 none, 1 normal, 2 interval)");
  }
}

}  // namespace

std::vector<core::ContactUncertainty> fromMsg(const std::vector<ContactUncertainty>& msgs) {
  std::vector<core::ContactUncertainty> uncertainties;
  uncertainties.reserve(msgs.size());
  for (std::size_t k = 0; k < msgs.size(); ++k) {
    const std::string field = "uncertainties[" + std::to_string(k) + "].";
    core::ContactUncertainty uncertainty;
    uncertainty.contact = msgs[k].contact;
    uncertainty.restitution = fromMsg(msgs[k].restitution, field + "restitution");
    uncertainty.static_friction = fromMsg(msgs[k].static_friction, field + "static_friction");
    uncertainty.dynamic_friction = fromMsg(msgs[k].dynamic_friction, field + "dynamic_friction");
    uncertainty.normal_std_dev = msgs[k].normal_std_dev;
    uncertainty.point_std_dev = {msgs[k].point_std_dev.x, msgs[k].point_std_dev.y,
                                 msgs[k].point_std_dev.z};
    uncertainties.push_back(uncertainty);
  }
  return uncertainties;
}

core::UncertaintyOptions uncertaintyOptions(const SolverOptions& msg) {
  core::UncertaintyOptions options;
  switch (msg.uncertainty) {
    case SolverOptions::UNCERTAINTY_NONE:
      options.method = core::UncertaintyMethod::kNone;
      break;
    case SolverOptions::UNCERTAINTY_LINEAR:
      options.method = core::UncertaintyMethod::kLinear;
      break;
    case SolverOptions::UNCERTAINTY_SAMPLED:
      options.method = core::UncertaintyMethod::kSampled;
      break;
    default:
      throw core::InvalidInput(
          "options.uncertainty",
          "unknown method " + std::to_string(msg.uncertainty) + " (0 none, 1 linear, 2 sampled)");
  }
  if (msg.uncertainty_samples != 0) options.samples = msg.uncertainty_samples;
  return options;
}

OutcomeDistribution toMsg(const core::OutcomeDistribution& outcome) {
  OutcomeDistribution msg;
  msg.method = core::toString(outcome.method);
  msg.samples = static_cast<std::uint32_t>(outcome.samples);
  msg.labels = outcome.labels;
  msg.mean.assign(outcome.mean.data(), outcome.mean.data() + outcome.mean.size());
  const Eigen::Index n = outcome.covariance.rows();
  msg.covariance.reserve(static_cast<std::size_t>(n * n));
  for (Eigen::Index r = 0; r < n; ++r)
    for (Eigen::Index c = 0; c < n; ++c) msg.covariance.push_back(outcome.covariance(r, c));
  msg.q05.assign(outcome.q05.data(), outcome.q05.data() + outcome.q05.size());
  msg.q95.assign(outcome.q95.data(), outcome.q95.data() + outcome.q95.size());
  msg.stick_probability = outcome.stick_probability;
  return msg;
}

}  // namespace collision_response
