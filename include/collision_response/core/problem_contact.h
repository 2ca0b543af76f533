#pragma once

#include <Eigen/Core>

namespace collision_response::core {

/// One contact of a contact problem (contact_problem.h), everything a solver reads about it.
/// Symbols of docs/physics.md, "Symbols and conventions" and "The contact problem"; world frame.
/// The impulse P at the contact acts +P on body b and -P on body a. The fields a closed form reads
/// (K, n, the coefficients, the lever arms: the first 168 bytes) come first, so that a batch of
/// entries touches fewer cache lines; the indices, the tangent frame and the resting fields follow.
struct ProblemContact {
  /// K = W_ii = J_i M^-1 J_i^T, the diagonal 3x3 block of the Delassus operator: the change of
  /// the relative velocity per unit impulse at this contact [1/kg].
  /// Symmetric, positive semi-definite; singular when the bodies have fewer freedoms than the
  /// contact has directions.
  Eigen::Matrix3d delassus = Eigen::Matrix3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< n, unit, from a towards b
  double restitution = 0.0;                           ///< e
  double static_friction = 0.0;                       ///< mu_s
  double dynamic_friction = 0.0;                      ///< mu_d
  /// r = p - c of a free rigid body on side a (b) [m]: its closed-form Jacobian [I3, -[r]x].
  /// Unused (zero) for a side without unknowns or with a general body.
  Eigen::Vector3d lever_arm_a = Eigen::Vector3d::Zero();
  Eigen::Vector3d lever_arm_b = Eigen::Vector3d::Zero();
  /// Impact problems (ProblemLevel::kVelocity): u, the relative velocity of the contact points
  /// before the impact, v_b(p) - v_a(p) [m/s]. Zero in resting problems.
  Eigen::Vector3d free_velocity = Eigen::Vector3d::Zero();
  /// Impact problems: the normal velocity the contact is to end with, u'_n = -e u_n for an
  /// approaching contact (u_n < 0), 0 for a touching or separating one [m/s]. Zero in resting
  /// problems, whose target normal acceleration is always 0.
  double target_normal_velocity = 0.0;
  int source = -1;  ///< index of the ContactPoint in the list the problem was built from
  int body_a = -1;  ///< index of body a in the body list the problem was built from
  int body_b = -1;  ///< index of body b
  /// Index of body a (b) in ContactProblem::bodies(), -1 if it has no velocity unknowns
  /// (immovable: it adds nothing to W and receives nothing).
  int local_a = -1;
  int local_b = -1;
  Eigen::Vector3d tangent1 = Eigen::Vector3d::UnitX();  ///< t1, unit, (t1, t2, n) right-handed
  Eigen::Vector3d tangent2 = Eigen::Vector3d::UnitY();  ///< t2 (tangentBasis(n))
  /// Resting problems (ProblemLevel::kAcceleration): the relative acceleration of the contact
  /// points under the bodies' wrenches alone, with the centripetal terms
  /// w_b x (w_b x r_b) - w_a x (w_a x r_a) [m/s^2] (docs/physics.md, "Resting contacts"). Zero in
  /// impact problems.
  Eigen::Vector3d free_acceleration = Eigen::Vector3d::Zero();
  /// Resting problems: the unit direction of a slip that already exists (|u_t| above the builder's
  /// slip velocity, ContactProblem::buildResting()), friction being -mu_d F_n along it; zero for a
  /// contact without slip.
  Eigen::Vector3d slip_direction = Eigen::Vector3d::Zero();
  /// Resting problems: the tangential relative velocity u_t [m/s] of a contact whose slip is
  /// within the builder's slip velocity (slip_direction zero: the solver's resting velocity in the
  /// episodes, a round-off slip), so slow that the contact may count as not slipping; zero for a
  /// contact without slip, a frictionless one, one with a slip direction, and in impact problems.
  /// solveRestingIsland() poses the contact as sliding along it when the island has no stuck
  /// answer (docs/physics.md, "Slow slips").
  Eigen::Vector3d slow_slip = Eigen::Vector3d::Zero();

  bool frictionless() const { return static_friction == 0.0 && dynamic_friction == 0.0; }
  /// K_nn = n^T K n [1/kg]: 1 / K_nn is the effective mass along the normal (0: the bodies cannot
  /// move along n at this point, and no impulse can push the contact).
  double normalDelassus() const { return normal.dot(delassus * normal); }
};

}  // namespace collision_response::core
