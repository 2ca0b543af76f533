// Error measures of one post-impact answer against the reference answer of a benchmark scene.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "bench_scenes.h"

namespace collision_response::bench {

/// Errors of one answer; all dimensionless. A batch of instances keeps the largest of each.
struct Errors {
  /// max over movable bodies of |v - v_ref| + rho |w - w_ref| (rho the body's radius of
  /// gyration), relative to the largest |v| + rho |w| before the impact.
  double velocity = 0.0;
  /// |KE' - KE'_ref| / KE before.
  double energy = 0.0;
  /// max(0, KE' - KE) / KE before: energy created by the impact.
  double energy_gain = 0.0;
  /// Restitution law: max over contacts of |u'_n - u'_n,ref| / max |u_n| before.
  double restitution = 0.0;
  /// Contact left approaching: max over contacts of max(0, -u'_n) / max |u_n| before.
  double approach = 0.0;
  /// Friction cone: max over contacts of max(0, |P_t| - mu_s P_n) / |P| (NaN if the impulses are
  /// unknown).
  double cone = 0.0;
  /// KE' / KE before (largest over a batch).
  double energy_ratio = 0.0;
};

/// Kinetic energy [J] of the movable bodies of `scene` moving with `v`.
double kineticEnergy(const core::Scene& scene, const Velocities& v);

/// `impulses`: the impulse of each contact, world frame, acting +P on body b [N s]; empty if the
/// method does not report them.
Errors measure(const core::Scene& scene, const Velocities& after,
               const std::vector<Eigen::Vector3d>& impulses, const Velocities& reference);

/// Keeps the largest of each error.
void accumulate(Errors& total, const Errors& one);

}  // namespace collision_response::bench
