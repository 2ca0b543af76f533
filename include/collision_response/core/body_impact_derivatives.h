#pragma once

#include <Eigen/Core>
#include <vector>

#include "collision_response/core/body_model.h"
#include "collision_response/core/body_response.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/impact_derivatives.h"
#include "collision_response/core/solver_options.h"

namespace collision_response::core {

/// Jacobians of the impact map of general bodies (body_model.h: robots, free rigid bodies) as
/// computeBodyResponse() solves it (docs/physics.md, "Derivatives of the impact map", "General
/// bodies"), with the prediction they were taken at.
///
/// Rows: every body's post-impact velocity unknowns (BodyModel::velocity(): a robot's base twist
/// then its free joints' velocities, a rigid body's twist), body after body from
/// `velocity_offset[b]` (bodies without unknowns have none), velocity_count rows in all; then per
/// contact 4 rows: the normal impulse and the friction impulse x, y, z [N s, world].
/// Columns: the same unknowns before the impact, then per contact e, mu_s, mu_d.
struct BodyImpactDerivatives {
  BodyResponse result;               ///< the prediction (computeBodyResponse())
  std::vector<int> velocity_offset;  ///< per body: its first row / column, -1 without unknowns
  Eigen::Index velocity_count = 0;   ///< the unknowns of all bodies
  std::size_t contact_count = 0;
  Eigen::MatrixXd jacobian;  ///< (velocity_count + 4C) x (velocity_count + 3C)
  /// kAnalytic when every impacting contact was differentiated in closed form, else
  /// kFiniteDifference.
  DerivativeMethod method = DerivativeMethod::kAnalytic;
  std::vector<ContactDerivativeMode> contacts;  ///< one per contact

  /// d (velocities after) / d (velocities before).
  Eigen::MatrixXd velocitiesByVelocities() const {
    return jacobian.topLeftCorner(velocity_count, velocity_count);
  }
  /// d (velocities after) / d (e, mu_s, mu_d of each contact).
  Eigen::MatrixXd velocitiesByCoefficients() const {
    return jacobian.topRightCorner(velocity_count, jacobian.cols() - velocity_count);
  }
};

/// Predicts the impact as computeBodyResponse() does (the bodies are left at their post-impact
/// velocities, as it leaves them) and differentiates it. Analytic under Newton's law with the
/// automatic or exact solver when every contact is frictionless and every island was solved in
/// closed form or by the exact solver (not iteratively, not as resting contacts): on the final
/// active set A (the contacts with an impulse), W_AA P_A = -(1 + e_A) u_A along the normals, so
/// dP_A / dv = -W_AA^+ (1 + e_A) J_A and dP_A / de_i = -W_AA^+ 1_i u_i (least-norm for redundant
/// contacts), the friction columns by one-sided differences (friction raised from 0, flagged).
/// Analytic too: one contact under Poisson or Stronge (integrated to its end), from its 3x3
/// W = J M^-1 J^T and u = J v by differentiateImpulseSpace(): dv'/dv = I + M^-1 J^T (dP/du) J,
/// dv'/dtheta = M^-1 J^T dP/dtheta, with that function's mode and switch flags.
/// Everything else (friction under Newton, several contacts under Poisson or Stronge, the
/// iterative solver) by central differences of
/// computeBodyResponse() itself (one-sided where a coefficient sits at its bound), reported per
/// contact as kFiniteDifference; the differences are not mode-checked (a column across a
/// stick/slip switch mixes both sides). options.time_budget bounds the whole call (the prediction
/// and every perturbed solve): SolverTimeout when it runs out. Throws what computeBodyResponse()
/// throws.
BodyImpactDerivatives computeBodyImpactDerivatives(const std::vector<BodyModel*>& bodies,
                                                   const std::vector<ContactPoint>& contacts,
                                                   const SolverOptions& options = {});

}  // namespace collision_response::core
