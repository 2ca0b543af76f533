#pragma once

#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "collision_response/core/compute_response.h"
#include "collision_response/core/scene.h"
#include "collision_response/core/solver_options.h"

namespace collision_response::core {

/// How a block of derivatives was obtained (docs/physics.md, "Derivatives of the impact map").
enum class DerivativeMethod {
  /// Differentiated in closed form: Newton's single-contact formulas, the linear equations of
  /// the exact solver's final active set (implicit differentiation), or the forward sensitivity
  /// of the impulse-space integration of one contact (impulse_space_derivatives.h).
  kAnalytic,
  /// Central differences of the solver itself within the contacts' modes (one-sided, second order,
  /// on the side that keeps the modes where a central difference would cross a switch): the
  /// impulse-space laws at several contacts, the iterative solver, the one-pass law.
  kFiniteDifference,
};

/// The mode a contact's derivative belongs to.
enum class ImpactMode {
  kNoImpulse,  ///< separating or not pushed: P = 0
  kSticking,   ///< active without slip at the end: u'_t = 0, u'_n at its target
  /// Active and slipping: friction on the boundary of its cone (Newton's closed form) or pyramid
  /// (exact solver) with mu_d; a frictionless active contact is reported sliding (P_t = 0).
  kSliding,
};

const char* toString(DerivativeMethod method);  ///< "analytic", "finite_difference"
const char* toString(ImpactMode mode);          ///< "no_impulse", "sticking", "sliding"

/// What one contact's derivatives mean.
struct ContactDerivativeMode {
  ImpactMode mode = ImpactMode::kNoImpulse;
  DerivativeMethod method = DerivativeMethod::kAnalytic;
  /// The contact is at a mode switch, or within kSwitchTolerance (relative) of one: the
  /// derivative is one-sided, that of `mode` (it holds for perturbations that keep the contact in
  /// `mode`; across the switch the map has a kink or, with mu_s > mu_d at stick/slide, a jump).
  bool at_switch = false;
  /// Which switch, and which side the derivative is (empty when at_switch is false), e.g.
  /// "stick/slide: |P_t| = mu_s P_n; sticking side".
  std::string switch_detail;
};

/// Relative distance below which a contact is reported at a mode switch.
constexpr double kSwitchTolerance = 1e-9;

/// Jacobians of the impact map of a rigid-body scene (docs/physics.md, "Derivatives of the impact
/// map"), with the prediction they were taken at.
///
/// Outputs (rows of `jacobian`): for each movable body i of the scene, in scene order, its
/// post-impact twist (linear velocity of the centre of mass [m/s], angular velocity [rad/s],
/// world: the request frame), 6 rows "bodies[i].twist.linear.x" .. "bodies[i].twist.angular.z";
/// then for each contact c, in scene order, 4 rows: "impulses[c].normal_impulse" [N s] and
/// "impulses[c].friction_impulse.x/y/z" [N s, world].
/// Inputs (columns): for each movable body i, its pre-impact twist, 6 columns named like the rows
/// ("bodies[i].twist.linear.x" ..., the request's fields); then for each contact c, 3 columns
/// "contacts[c].restitution", "contacts[c].static_friction", "contacts[c].dynamic_friction"
/// (dimensionless). Immovable bodies have neither rows nor columns (their velocities are
/// prescribed). Entry (r, k) is d output_r / d input_k, in the units of the two labels.
struct ImpactDerivatives {
  CollisionResult result;           ///< the prediction (computeResponse()) at the given scene
  std::vector<int> movable_bodies;  ///< scene indices of the movable bodies, in order
  std::size_t contact_count = 0;    ///< contacts of the scene
  Eigen::MatrixXd jacobian;         ///< outputs x inputs, layout above
  /// kAnalytic if every island was differentiated analytically, else kFiniteDifference.
  DerivativeMethod method = DerivativeMethod::kAnalytic;
  std::vector<ContactDerivativeMode> contacts;  ///< one per contact of the scene

  Eigen::Index velocityCount() const {
    return 6 * static_cast<Eigen::Index>(movable_bodies.size());
  }
  Eigen::Index impulseCount() const { return 4 * static_cast<Eigen::Index>(contact_count); }
  Eigen::Index coefficientCount() const { return 3 * static_cast<Eigen::Index>(contact_count); }
  /// d (post-impact twists) / d (pre-impact twists), 6B x 6B.
  Eigen::MatrixXd velocitiesByVelocities() const {
    return jacobian.topLeftCorner(velocityCount(), velocityCount());
  }
  /// d (post-impact twists) / d (e, mu_s, mu_d), 6B x 3C.
  Eigen::MatrixXd velocitiesByCoefficients() const {
    return jacobian.topRightCorner(velocityCount(), coefficientCount());
  }
  /// d (normal impulse, friction impulse) / d (pre-impact twists), 4C x 6B.
  Eigen::MatrixXd impulsesByVelocities() const {
    return jacobian.bottomLeftCorner(impulseCount(), velocityCount());
  }
  /// d (normal impulse, friction impulse) / d (e, mu_s, mu_d), 4C x 3C.
  Eigen::MatrixXd impulsesByCoefficients() const {
    return jacobian.bottomRightCorner(impulseCount(), coefficientCount());
  }
  /// Labels of the rows and columns, as above (built on request: strings cost more than the
  /// derivatives of a single contact).
  std::vector<std::string> rowLabels() const;
  std::vector<std::string> columnLabels() const;
};

/// Validates the scene (throws InvalidInput naming the field), predicts the impact as
/// computeResponse() does and differentiates it. Analytic for the Newton law when each impacting
/// island is solved in closed form (one contact under SolverMethod::kAuto) or by the exact solver
/// (its final active set; redundant contacts sliding with friction excepted, whose impulses are
/// not unique), and for Poisson and Stronge at an island of one contact integrated to its end
/// (differentiateImpulseSpace(): regular K_tt, no fallback); finite differences of the solver
/// otherwise (reported per contact and in `method`; 2 to 4 further solves per input column;
/// options.time_budget bounds the whole call, prediction and differences together: past it,
/// SolverTimeout). Resting islands and islands where nothing approaches get no impulse: their
/// bodies' derivatives are the identity (a contact touching at u_n = 0 is flagged at a switch). The
/// prediction in `result` is the one computeResponse() gives.
ImpactDerivatives computeImpactDerivatives(const Scene& scene, const SolverOptions& options = {},
                                           const RequestLimits& limits = {});

/// Which input columns of ImpactDerivatives::jacobian to compute, for callers that need a few
/// (the linear uncertainty: the uncertain coefficients). Columns left out are 0 in the answer
/// (the velocity columns too: not the identity); the rows, the prediction and the modes are
/// those of the full call.
struct DerivativeColumns {
  bool velocities = true;  ///< the pre-impact twists' columns
  /// One entry per coefficient column (3 per contact: e, mu_s, mu_d), true: computed; empty: all.
  std::vector<bool> coefficients;

  /// Whether coefficient column k (3 c + 0, 1, 2 for contact c's e, mu_s, mu_d) is asked for.
  bool wantsCoefficient(Eigen::Index k) const {
    return coefficients.empty() || coefficients[static_cast<std::size_t>(k)];
  }
};

/// computeImpactDerivatives() on a scene validate() has accepted (`contact_bodies` its answer),
/// computing only the `columns` asked for (each one as the full call computes it).
ImpactDerivatives computeValidatedImpactDerivatives(
    const Scene& scene, const std::vector<std::pair<int, int>>& contact_bodies,
    const SolverOptions& options, const DerivativeColumns& columns);

/// The same, written into `out`, whose storage (the Jacobian, the per-contact lists) is reused:
/// for a caller that differentiates one scene shape after another on one thread (the linear
/// uncertainty keeps one per thread). Every field of `out` is overwritten.
void computeValidatedImpactDerivatives(const Scene& scene,
                                       const std::vector<std::pair<int, int>>& contact_bodies,
                                       const SolverOptions& options,
                                       const DerivativeColumns& columns, ImpactDerivatives& out);

}  // namespace collision_response::core
