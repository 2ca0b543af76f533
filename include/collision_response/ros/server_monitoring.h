#pragma once

// Monitoring of CollisionResponseServer: the request defaults that dynamic_reconfigure changes
// (cfg/Solver.cfg), the call records, and the diagnostics they give on /diagnostics at 1 Hz.

#include <ros/ros.h>

#include <cstdint>
#include <memory>
#include <mutex>

#include "collision_response/core/solver_options.h"

namespace diagnostic_updater {
class DiagnosticStatusWrapper;
class Updater;
}  // namespace diagnostic_updater
namespace dynamic_reconfigure {
template <class ConfigType>
class Server;
}  // namespace dynamic_reconfigure

namespace collision_response {

class SolverConfig;  // generated from cfg/Solver.cfg

/// The defaults of a request (parameters, then dynamic_reconfigure), read together so that a
/// reconfigure cannot land between them.
struct SolverDefaults {
  core::SolverOptions options;
  double contact_tolerance = 0.0;  ///< [m] detection's contact tolerance
};

/// What a server's service calls did since start, and at the last diagnostics update.
struct CallStatistics {
  std::uint64_t calls = 0;      ///< service calls (compute, compute_batch and the episodes')
  std::uint64_t scenes = 0;     ///< scenes solved or rejected (1 per compute call)
  std::uint64_t failures = 0;   ///< scenes answered with success = false
  double solve_time = 0.0;      ///< [s] total solver time
  double max_solve_time = 0.0;  ///< [s] largest per-call solver time since the last update
  std::uint64_t calls_at_update = 0;
  std::uint64_t failures_at_update = 0;
  ros::WallTime last_update;
};

/// The server's dynamic_reconfigure server (law, solver, multi_contact, tolerance, max_iterations,
/// integration_tolerance, contact_tolerance) and its diagnostics ("solver": call rate, failures,
/// solver time). Thread-safe: defaults() and recordCalls() may be called from any callback.
class ServerMonitoring {
 public:
  /// Writes `initial` (the validated parameters) back to the parameter server so that the first
  /// reconfigure callback changes nothing, then starts dynamic_reconfigure in `private_node` and
  /// the diagnostics (a 1 s wall timer).
  ServerMonitoring(const ros::NodeHandle& node, const ros::NodeHandle& private_node,
                   const SolverDefaults& initial);
  /// Stops the timer and the reconfigure server first (their callbacks use the members).
  ~ServerMonitoring();

  ServerMonitoring(const ServerMonitoring&) = delete;
  ServerMonitoring& operator=(const ServerMonitoring&) = delete;

  /// The current request defaults.
  SolverDefaults defaults() const;

  /// Adds to the statistics: `calls` service calls, `scenes` scenes of which `failures` failed,
  /// `solve_time` [s] of solver time in total and `max_solve_time` [s] the largest of one scene.
  void recordCalls(std::size_t calls, std::size_t scenes, std::size_t failures, double solve_time,
                   double max_solve_time);

 private:
  /// The dynamic_reconfigure callback: new defaults; an unknown law, solver or multi_contact name
  /// keeps the old value (with a warning, and `config` set back).
  void reconfigure(SolverConfig& config, uint32_t level);
  /// The diagnostics callback: the rate and failures since the last update, the totals.
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);

  mutable std::mutex defaults_mutex_;  // guards defaults_
  SolverDefaults defaults_;
  std::mutex statistics_mutex_;  // guards statistics_
  CallStatistics statistics_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  ros::WallTimer diagnostics_timer_;
  std::unique_ptr<dynamic_reconfigure::Server<SolverConfig>> reconfigure_server_;
};

}  // namespace collision_response
