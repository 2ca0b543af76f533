#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "collision_response/core/impact_derivatives.h"
#include "collision_response/core/solver_options.h"

namespace collision_response::core {

/// How differentiateImpulseSpace() went (for tests and benchmarks).
struct ImpulseSpaceSensitivityDetail {
  /// Dormand-Prince steps taken with the gradients (a turning slip), rejected ones included.
  std::size_t steps = 0;
  /// A turning slip's end was taken by the stick-approach series (stick_approach.h) with its
  /// gradient, as the prediction takes it, rather than integrated to the stop.
  bool series = false;
  /// The series' order (StickApproach::order()) when `series`.
  int series_order = 0;
  /// A turning slip was ended where it fell below 1e-13 of |u| (the sensitivity's own stop; the
  /// prediction ends such a slip by its closed-form last piece or integrates on).
  bool threshold_stop = false;
  /// Pieces of constant contact mode, counted as integrateSingleContact() counts them
  /// (ImpulseSpaceDetail::segments).
  std::size_t segments = 0;
  /// p_c, the normal impulse at maximum compression [N s], and W_c, the work of the normal
  /// impulse to it [J] (<= 0), as ImpulseSpaceDetail has them (0 without an impulse).
  double compression_impulse = 0.0;
  double compression_work = 0.0;
};

/// Analytic derivatives of the impulse of one isolated contact under the impulse-space laws
/// (integrateSingleContact(), kPoisson or kStronge; docs/physics.md, "Derivatives of the impact
/// map", "The impulse-space laws, one contact"), by a forward sensitivity carried through the same
/// phases: the closed-form segments (constant rates: sticking, slip resumed after a stop,
/// frictionless slip, the central stop) differentiated exactly, a rotating slip integrated with its
/// sensitivities (Dormand-Prince 5(4) in xi, dp/dxi = |u_t|, on the same state) until, as in the
/// prediction, the stick-approach series (stick_approach.h) takes the rest of it to its stop in
/// closed form (its gradient: with respect to the slip from its homogeneity and its invariance
/// along the flow, with respect to mu_d through the series' recurrence), and each event (maximum
/// compression, the end of the impact, the slip's stop) moving with the inputs by
/// dxi_event = -(dg/dy . dy + dg/dtheta) / (dg/dxi).
///
/// Inputs: the contact's normal n (unit, from a towards b), K its contact-space inverse mass
/// matrix [1/kg] (symmetric positive semi-definite; K_nn = 0 gives no impulse and zero
/// derivatives, a singular tangential block K_tt is refused), u its relative velocity before the
/// impact [m/s, world], e, mu_s, mu_d its coefficients, the law, and the integration's relative
/// tolerance (SolverOptions::integration_tolerance; the turning slip's sensitivity is integrated
/// to it, clamped to [1e-14, 1e-10]).
/// Outputs: dP_du (3x3, world: d P / d u, P = P_n n + P_t [N s] the impulse +P on b and -P on a)
/// [N s / (m/s) = kg] and dP_dcoefficients (3x3: columns d P / d e, d mu_s, d mu_d [N s]);
/// `mode` the contact's mode (sticking at the end of the impact, sliding, no impulse), method
/// kAnalytic, and the switches near which the derivative is one-sided (flagged, with which side).
/// `impulse`, if given, receives the impulse P the derivatives belong to [N s, world]; `detail`,
/// if given, how the sensitivity went.
/// Returns false (nothing usable: differentiate otherwise) for a singular K or K_tt, a law other
/// than kPoisson and kStronge, or an integration that exceeds its step budget.
bool differentiateImpulseSpace(const Eigen::Vector3d& n, const Eigen::Matrix3d& K,
                               const Eigen::Vector3d& u, double e, double mu_s, double mu_d,
                               ImpactLaw law, double tolerance, Eigen::Matrix3d& dP_du,
                               Eigen::Matrix3d& dP_dcoefficients, ContactDerivativeMode& mode,
                               Eigen::Vector3d* impulse = nullptr,
                               ImpulseSpaceSensitivityDetail* detail = nullptr);

/// The same contact's impulse differentiated also with respect to its K (a robot's joint positions
/// move its K = J M^-1 J^T; body_impact_derivatives.h): the forward sensitivity carries K's six
/// entries in the contact frame as well, and the turning slip is integrated to its stop (the
/// stick-approach series' gradient is known with respect to the slip and mu_d only). Per change
/// dK[k] (symmetric, world, [1/kg]) `dP_dK` receives dP [N s] (3 x dK.size()); `dP_du` and `mode`
/// as differentiateImpulseSpace() gives them on this run. The same refusals.
bool differentiateImpulseSpaceByK(const Eigen::Vector3d& n, const Eigen::Matrix3d& K,
                                  const Eigen::Vector3d& u, double e, double mu_s, double mu_d,
                                  ImpactLaw law, double tolerance,
                                  const std::vector<Eigen::Matrix3d>& dK,
                                  Eigen::Matrix<double, 3, Eigen::Dynamic>& dP_dK,
                                  Eigen::Matrix3d& dP_du, ContactDerivativeMode& mode);

}  // namespace collision_response::core
