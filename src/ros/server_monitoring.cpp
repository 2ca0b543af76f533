#include "collision_response/ros/server_monitoring.h"

#include <collision_response/SolverConfig.h>
#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>

#include <algorithm>
#include <string>

#include "collision_response/ros/server_parameters.h"

namespace collision_response {

ServerMonitoring::ServerMonitoring(const ros::NodeHandle& node, const ros::NodeHandle& private_node,
                                   const SolverDefaults& initial)
    : defaults_(initial) {
  // dynamic_reconfigure starts from the validated parameters: write them back first so that the
  // server's first callback (with the values it reads from the parameter server) changes nothing.
  const core::SolverOptions& options = defaults_.options;
  ros::NodeHandle reconfigure_node(private_node);
  reconfigure_node.setParam("law", std::string(core::toString(options.law)));
  reconfigure_node.setParam("solver", std::string(core::toString(options.method)));
  reconfigure_node.setParam("multi_contact",
                            std::string(multiContactName(options.simultaneous_impulse_space)));
  reconfigure_node.setParam("tolerance", options.tolerance);
  reconfigure_node.setParam("max_iterations", static_cast<int>(options.max_iterations));
  reconfigure_node.setParam("integration_tolerance", options.integration_tolerance);
  reconfigure_node.setParam("contact_tolerance", defaults_.contact_tolerance);
  reconfigure_server_ = std::make_unique<dynamic_reconfigure::Server<SolverConfig>>(private_node);
  reconfigure_server_->setCallback(
      [this](SolverConfig& config, uint32_t level) { reconfigure(config, level); });

  statistics_.last_update = ros::WallTime::now();
  diagnostics_ = std::make_unique<diagnostic_updater::Updater>(node, private_node,
                                                               private_node.getNamespace());
  diagnostics_->setHardwareID("none");
  diagnostics_->add("solver", this, &ServerMonitoring::diagnose);
  diagnostics_timer_ = private_node.createWallTimer(
      ros::WallDuration(1.0), [this](const ros::WallTimerEvent&) { diagnostics_->force_update(); });
}

ServerMonitoring::~ServerMonitoring() {
  diagnostics_timer_.stop();
  reconfigure_server_.reset();
}

SolverDefaults ServerMonitoring::defaults() const {
  std::lock_guard<std::mutex> lock(defaults_mutex_);
  return defaults_;
}

void ServerMonitoring::reconfigure(SolverConfig& config, uint32_t /*level*/) {
  std::lock_guard<std::mutex> lock(defaults_mutex_);
  core::SolverOptions options = defaults_.options;
  // String enums are not enforced by dynamic_reconfigure: an unknown name keeps the old value.
  if (!core::fromString(config.law, options.law)) {
    ROS_WARN("collision_response: reconfigure: unknown law '%s', keeping '%s'", config.law.c_str(),
             core::toString(options.law));
    config.law = core::toString(options.law);
  }
  if (!core::fromString(config.solver, options.method)) {
    ROS_WARN("collision_response: reconfigure: unknown solver '%s', keeping '%s'",
             config.solver.c_str(), core::toString(options.method));
    config.solver = core::toString(options.method);
  }
  if (!multiContactFromName(config.multi_contact, options.simultaneous_impulse_space)) {
    ROS_WARN("collision_response: reconfigure: unknown multi_contact '%s', keeping '%s'",
             config.multi_contact.c_str(), multiContactName(options.simultaneous_impulse_space));
    config.multi_contact = multiContactName(options.simultaneous_impulse_space);
  }
  options.tolerance = config.tolerance;
  options.max_iterations = static_cast<std::size_t>(std::max(1, config.max_iterations));
  options.integration_tolerance = config.integration_tolerance;
  defaults_.options = options;
  defaults_.contact_tolerance = config.contact_tolerance;
  ROS_INFO(
      "collision_response: solver defaults: law %s, solver %s, multi_contact %s, tolerance %g, "
      "max_iterations %zu, integration_tolerance %g, contact_tolerance %g m",
      core::toString(options.law), core::toString(options.method),
      multiContactName(options.simultaneous_impulse_space), options.tolerance,
      options.max_iterations, options.integration_tolerance, defaults_.contact_tolerance);
}

void ServerMonitoring::recordCalls(std::size_t calls, std::size_t scenes, std::size_t failures,
                                   double solve_time, double max_solve_time) {
  std::lock_guard<std::mutex> lock(statistics_mutex_);
  statistics_.calls += calls;
  statistics_.scenes += scenes;
  statistics_.failures += failures;
  statistics_.solve_time += solve_time;
  statistics_.max_solve_time = std::max(statistics_.max_solve_time, max_solve_time);
}

void ServerMonitoring::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(statistics_mutex_);
  CallStatistics& s = statistics_;
  const ros::WallTime now = ros::WallTime::now();
  const double period = std::max(1e-9, (now - s.last_update).toSec());
  const double rate = static_cast<double>(s.calls - s.calls_at_update) / period;
  const std::uint64_t new_failures = s.failures - s.failures_at_update;
  if (new_failures == 0) {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "serving");
  } else {
    status.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "%lu failed scenes in the last %.1f s",
                    static_cast<unsigned long>(new_failures), period);
  }
  status.add("call rate [1/s]", rate);
  status.add("calls", s.calls);
  status.add("scenes", s.scenes);
  status.add("failures", s.failures);
  status.add("mean solver time per scene [s]",
             s.scenes > 0 ? s.solve_time / static_cast<double>(s.scenes) : 0.0);
  status.add("max solver time per call since last update [s]", s.max_solve_time);
  s.calls_at_update = s.calls;
  s.failures_at_update = s.failures;
  s.max_solve_time = 0.0;
  s.last_update = now;
}

}  // namespace collision_response
