#pragma once

#include <Eigen/Core>
#include <vector>

#include "collision_response/core/body_model.h"
#include "collision_response/core/body_response.h"
#include "collision_response/core/configuration_coordinate.h"
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
/// Columns: the same unknowns before the impact, then per contact e, mu_s, mu_d, then the
/// configuration coordinates the call was given (a robot's joint positions), in their order.
struct BodyImpactDerivatives {
  BodyResponse result;               ///< the prediction (computeBodyResponse())
  std::vector<int> velocity_offset;  ///< per body: its first row / column, -1 without unknowns
  Eigen::Index velocity_count = 0;   ///< the unknowns of all bodies
  std::size_t contact_count = 0;
  Eigen::Index coordinate_count = 0;  ///< K, the configuration coordinates' columns
  Eigen::MatrixXd jacobian;           ///< (velocity_count + 4C) x (velocity_count + 3C + K)
  /// kAnalytic when every impacting contact was differentiated in closed form, else
  /// kFiniteDifference.
  DerivativeMethod method = DerivativeMethod::kAnalytic;
  /// How the configuration coordinates' columns were taken: kAnalytic in closed form (every
  /// coordinate names its body, ConfigurationCoordinate::body, and every island with an impulse
  /// is analytic: Newton's law without redundant contacts, or one contact under Poisson or
  /// Stronge), else kFiniteDifference (also without coordinates).
  DerivativeMethod coordinate_method = DerivativeMethod::kFiniteDifference;
  std::vector<ContactDerivativeMode> contacts;  ///< one per contact

  /// d (velocities after) / d (velocities before).
  Eigen::MatrixXd velocitiesByVelocities() const {
    return jacobian.topLeftCorner(velocity_count, velocity_count);
  }
  /// d (velocities after) / d (e, mu_s, mu_d of each contact).
  Eigen::MatrixXd velocitiesByCoefficients() const {
    return jacobian.block(0, velocity_count, velocity_count,
                          jacobian.cols() - velocity_count - coordinate_count);
  }
  /// d (velocities after) / d (each configuration coordinate).
  Eigen::MatrixXd velocitiesByCoordinates() const {
    return jacobian.topRightCorner(velocity_count, coordinate_count);
  }
};

/// Predicts the impact as computeBodyResponse() does (the bodies are left at their post-impact
/// velocities, as it leaves them) and differentiates it, island by island, in contact space: an
/// island's contacts have the Jacobian J (3m x N, rows J_b - J_a of each contact's point, from
/// BodyModel::partPointJacobian()), M^-1 J^T (partInverseMassJacobianTranspose()) and u = J v (+
/// the velocity of a body without unknowns); from dP/du and dP/d(e, mu_s, mu_d) of its contacts,
/// dv'/dv = I + M^-1 J^T (dP/du) J, dv'/dtheta = M^-1 J^T dP/dtheta (contact_derivatives.h).
/// Analytic (each contact reported kAnalytic with its mode and switch flags, as
/// computeImpactDerivatives() reports them) for
/// - Newton's law, one contact under the automatic solver: the closed form's derivative
///   (sticking, sliding, frictionless; differentiateNewtonContact());
/// - Newton's law, an island the exact solver answered: implicit differentiation of its final
///   mode (no impulse, sticking, sliding on a pyramid edge or facet per contact;
///   differentiateNewtonIsland());
/// - one contact under Poisson or Stronge integrated to its end: the integration's sensitivity
///   (differentiateImpulseSpace()). A call with that one contact alone (automatic solver,
///   integration tolerance in [1e-12, 1e-10]) takes the sensitivity first and, where it took only
///   closed forms and the stick-approach series, writes the prediction from it (the same answer
///   to round-off, report included) instead of running the solver;
/// - islands without an impulse (nothing approaching, resting contacts): the identity.
/// Everything else (the iterative solver or the exact solver's iterative fallback, several
/// contacts under Poisson or Stronge, the one-pass law, a singular K, redundant contacts sliding
/// with friction) makes every column a central difference of computeBodyResponse() itself
/// (one-sided where a coefficient sits at its bound), each contact reported kFiniteDifference;
/// the differences are not mode-checked (a column across a stick/slip switch mixes both sides).
/// The columns of `coordinates` (a robot's joint positions, robot/joint_position_coordinates.h)
/// are the derivatives with the contacts' points and normals held where they are in the world: the
/// derivative of the impact at that contact when the bodies' models (M(q), the links' Jacobians at
/// the point) change, not of where the bodies would touch. In closed form (coordinate_method
/// kAnalytic; docs/physics.md, "Derivatives with respect to a robot's joint positions") when every
/// coordinate names its body (ConfigurationCoordinate::body) and every island with an impulse is
/// Newton's closed form, the exact solver's final mode without redundant contacts, or one contact
/// integrated under Poisson or Stronge: the coordinate moves u by dJ v and, at fixed impulses, the
/// velocities after by M^-1 (dJ^T P - dM (v' - v)), and the island's equations give dP (one
/// contact through dK = d(J M^-1 J^T) too: the closed form's, or the sensitivity carrying K's
/// entries, differentiateImpulseSpaceByK()). Otherwise (several contacts under Poisson or Stronge;
/// redundant contacts; a coordinate without its body) central differences of
/// computeBodyResponse() with the coordinate moved by +-h (h = 1e-6 max(1, |value|)) through its
/// set(). A column whose perturbed solve changes
/// a contact's mode (no impulse, sticking, sliding) on one side is one-sided on the other (the
/// contact reported at_switch); on both sides, central, mixing both modes, also reported. The
/// coordinates end at their values, also when the call throws; the bodies' velocities end at the
/// prediction's to round-off (v + (v' - v), as after the differenced columns).
/// options.time_budget bounds the whole call (the prediction and every perturbed solve):
/// SolverTimeout when it runs out. Throws what computeBodyResponse() throws.
BodyImpactDerivatives computeBodyImpactDerivatives(
    const std::vector<BodyModel*>& bodies, const std::vector<ContactPoint>& contacts,
    const SolverOptions& options = {},
    const std::vector<ConfigurationCoordinate>& coordinates = {});

}  // namespace collision_response::core
