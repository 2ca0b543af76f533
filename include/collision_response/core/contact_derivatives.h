#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/impact_derivatives.h"
#include "collision_response/core/solve_report.h"
#include "collision_response/core/solver_options.h"

namespace collision_response::core {

/// The contact-space part of the derivatives of the impact map, shared by the rigid-body path
/// (computeImpactDerivatives()) and the general-body path (computeBodyImpactDerivatives()): which
/// islands are analytic, the switch flags, the islands without an impulse, and Newton's law
/// differentiated in contact space at the answer's final mode (docs/physics.md, "Derivatives of
/// the impact map", "What is analytic"): the derivatives of the impulses P of one island's contacts
/// with respect to their pre-impact relative velocities and their coefficients. Nothing here knows
/// what the bodies are: the caller gives the contacts' Jacobian J (u = J v, v the velocity
/// unknowns it chooses: a rigid island's twists, or every body's unknowns, a robot's joint
/// velocities among them) and M^-1 J^T, and maps dP back to its own rows
/// (dv'/dv = I + M^-1 J^T dP/dv, dv'/dtheta = M^-1 J^T dP/dtheta).

/// How an island that got an impulse is differentiated analytically, from how it was solved.
enum class AnalyticIsland {
  kNone,              ///< not analytically: differenced
  kNewtonClosedForm,  ///< one contact, Newton's closed form: differentiateNewtonContact()
  kNewtonExact,       ///< Newton, the exact solver: differentiateNewtonIsland()
  /// One contact under Poisson or Stronge integrated to its end (converged, no fallback):
  /// differentiateImpulseSpace() (impulse_space_derivatives.h).
  kImpulseSpaceContact,
  /// Two to kSimultaneousMaxContacts contacts under Poisson or Stronge integrated together to
  /// their end (SolvedBy::kSimultaneousImpulseSpace, converged, no fallback):
  /// differentiateSimultaneousImpulseSpace() (simultaneous_impact.h).
  kImpulseSpaceIsland,
};

/// The analytic path for an island solved as `island` reports under `law`.
AnalyticIsland analyticIslandOf(const SolveReport& island, ImpactLaw law);

/// A contact's coefficients (dimensionless): e in [0, 1], 0 <= mu_d <= mu_s.
struct NewtonCoefficients {
  double restitution = 0.0;
  double static_friction = 0.0;
  double dynamic_friction = 0.0;
  bool frictionless() const { return static_friction == 0.0 && dynamic_friction == 0.0; }
};

/// Column offsets of a contact's coefficients in dP/dtheta (3 per contact: e, mu_s, mu_d).
constexpr int kRestitutionColumn = 0, kStaticColumn = 1, kDynamicColumn = 2;

/// Flags `mode` at a switch with `detail` (appended to any earlier detail, "; " between).
void flagSwitch(ContactDerivativeMode& mode, const std::string& detail);

/// An island that got no impulse (SolvedBy::kNone: nothing approaches; resting contacts, whose
/// answer is forces): its contacts are marked kNoImpulse, and one touching at u_n = 0 (within
/// kSwitchTolerance of the island's largest |u_n|) is flagged, since approaching would start an
/// impact. False (nothing marked) for an island with an impact. `impulses`, `modes`: per contact
/// of the whole answer (the island's SolveReport::contacts index them).
bool markNoImpulseIsland(const SolveReport& island, const std::vector<ContactImpulse>& impulses,
                         std::vector<ContactDerivativeMode>& modes);

/// One contact solved by the closed form of "Newton restitution with Coulomb friction"
/// (solveSingleContact()): dP/du (3 x 3) and dP/d(e, mu_s, mu_d) (3 x 3, columns as above) from
/// its unit normal n (from a to b), its K = J M^-1 J^T [1/kg] and its pre-impact relative velocity
/// u = v_b - v_a [m/s] (world). Sets `mode` (its mode, kAnalytic, the switch flags). False when K
/// is singular or a sliding contact has no slip direction (the caller then differences).
/// `dP_dK` (if given) receives, per change dK[k] of K (symmetric, [1/kg]), the impulse's change
/// dP [N s] (3 x dK.size()): a robot's joint positions move its K (body_impact_derivatives.h).
bool differentiateNewtonContact(const Eigen::Vector3d& n, const Eigen::Matrix3d& K,
                                const Eigen::Vector3d& u, const NewtonCoefficients& coefficients,
                                Eigen::Matrix3d& dP_du, Eigen::Matrix3d& dP_dtheta,
                                ContactDerivativeMode& mode,
                                const std::vector<Eigen::Matrix3d>& dK = {},
                                Eigen::Matrix<double, 3, Eigen::Dynamic>* dP_dK = nullptr);

/// One contact of a NewtonIsland, in world coordinates.
struct NewtonContactState {
  Eigen::Vector3d normal;      ///< unit normal, from a to b
  Eigen::Vector3d u, u_after;  ///< u = v_b - v_a at the point, before and after [m/s]
  Eigen::Vector3d P;           ///< the impulse on b [N s]
  NewtonCoefficients coefficients;
};

/// A free rigid body's mass [kg] and world inertia about its centre of mass [kg m^2].
struct RigidMass {
  double mass = 0.0;
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
};

/// An island as the exact solver answered it, in contact space: m contacts, rows 3i..3i+2 of J
/// those of contact i (world x, y, z of u_i = v_b - v_a at its point).
struct NewtonIsland {
  std::vector<int> contacts;  ///< the caller's contact indices (of `modes`, of `columns`)
  Eigen::MatrixXd J;          ///< 3m x L: u = J v (+ the part of bodies without unknowns)
  Eigen::MatrixXd MinvJt;     ///< L x 3m: M^-1 J^T
  /// Per contact, in the order of `contacts` (one vector: one allocation per island).
  std::vector<NewtonContactState> state;
  /// Free rigid bodies only, v their twists, 6 unknowns each (v [m/s], w [rad/s]): per body, for
  /// the body-space solve of a face's redundant sticking contacts (W^+ = J G^-1 M G^-1 J^T).
  /// Empty for other bodies (W is decomposed).
  std::vector<RigidMass> rigid;

  /// W = J M^-1 J^T (3m x 3m), formed on first use.
  const Eigen::MatrixXd& W() const;
  /// Forgets the W formed (for a NewtonIsland whose storage is refilled for another island).
  void clearW() { W_.resize(0, 0); }

 private:
  mutable Eigen::MatrixXd W_;
};

/// The exact solver's static pyramid (kPyramidDirections directions d_k = cos(2 pi k / D) t1 +
/// sin(2 pi k / D) t2, t1 along the contact's pre-impact slip when it slides, tangentBasis(n)
/// otherwise) at a contact of unit normal `n` and pre-impact relative velocity `u` = v_b - v_a
/// [m/s]: the unit outward normal (tangential, world) of the facet between the two directions
/// around the friction impulse `friction` [N s] (on b). Its facet lies at cos(pi / D) mu P_n from
/// the axis: the impulse is inside the pyramid of friction mu iff facet . P_t <= cos(pi / D) mu
/// P_n. Zero for a zero tangential impulse.
Eigen::Vector3d pyramidFacetNormal(const Eigen::Vector3d& n, const Eigen::Vector3d& u,
                                   const Eigen::Vector3d& friction);

/// Changes of an island's contact space along Q directions (a robot's joint positions), 3m x Q
/// each: `pre` the change of u (the pre-impact relative velocities), `post` the further change of
/// u' = u + W P at fixed impulses, (dW) P [m/s per unit of the direction].
struct ConfigurationChange {
  Eigen::MatrixXd pre, post;
};

/// Implicit differentiation of the exact solver's answer on `island` (solveExact()): each contact
/// contributes three equations of its final mode (no impulse, sticking, sliding on a pyramid edge
/// or facet), F(P, u, theta) = 0, and F_P dP = -(F_u du + F_theta dtheta). `all_sticking`: the
/// answer came without a pivot (SolveReport::iterations 0: every contact sticking inside its
/// static cone). Computes dP/dv (3m x L; when columns.velocities, else empty) and dP/dtheta (3m x
/// 3m, per contact e, mu_s, mu_d; only the coefficient columns `columns` asks for, by the caller's
/// contact index, the rest 0) and sets modes[contacts[i]] (mode, kAnalytic, switch flags). False
/// for redundant contacts sliding with friction (impulses not unique: the caller differences;
/// the contacts are flagged). With `configuration`, also dP/dq (3m x Q) into `dP_dq`: the rows'
/// dependence on u (F_u) takes `pre`, their dependence on u' (the W rows of F_P) `post`; left
/// empty (0 x 0) for redundant contacts (F_P singular), whose least-norm impulses' change with a
/// moving W is not the least-norm change (the caller differences those columns).
bool differentiateNewtonIsland(const NewtonIsland& island, bool all_sticking,
                               const DerivativeColumns& columns, Eigen::MatrixXd& dP_dv,
                               Eigen::MatrixXd& dP_dtheta,
                               std::vector<ContactDerivativeMode>& modes,
                               const ConfigurationChange* configuration = nullptr,
                               Eigen::MatrixXd* dP_dq = nullptr);

}  // namespace collision_response::core
