#pragma once

#include <Eigen/Core>

namespace collision_response::core {

/// s with (lambda I + M) s = b, |s| = 1, lambda > 0, for a symmetric positive semi-definite 2x2 M
/// and |M^+ b| > 1 (or b outside the range of M): the slip direction of maximal dissipation.
/// Safeguarded Newton on 1 - 1/|s(lambda)| (nearly linear in lambda), bracketed by the
/// eigenvalues of M. Used by the impulse-space integrator (slip resuming after stick, M = mu_d A)
/// and by solveFrictionDisk() (M = radius K_tt).
Eigen::Vector2d slipDirection(const Eigen::Matrix2d& M, const Eigen::Vector2d& b);

/// The friction subproblem of one contact (docs/physics.md, "The iterative solver"): the
/// tangential impulse x (in the contact's (t1, t2) basis) in the disk |x| <= radius that leaves
/// the slip u'_t = u0 + K x with maximal dissipation, i.e. that minimizes x^T u0 + x^T K x / 2:
///   stick: x = -K^+ u0 if |x| <= radius (u'_t = 0; singular K: the least-norm friction, the
///          range of K: least_norm.h);
///   slip:  x = -radius s on the circle with (K + lambda I) x = -u0, lambda > 0, so that the slip
///          it leaves is u'_t = lambda radius s: friction exactly opposite to the slip it leaves
///          (s = slipDirection(radius K, u0)). Not -radius K^-1 u0 / |K^-1 u0| (a radial
///          projection of the sticking impulse), which for an anisotropic K turns friction off
///          the slip.
/// K [1/kg] is the contact's tangential Delassus block T^T W_ii T, u0 the tangential velocity
/// [m/s] (or acceleration [m/s^2]) the contact would have without its own tangential impulse
/// (force), radius = mu P_n [N s] (or mu F_n [N]). Returns x; `sticking` says which case.
Eigen::Vector2d solveFrictionDisk(const Eigen::Matrix2d& K, const Eigen::Vector2d& u0,
                                  double radius, bool& sticking);

/// One contact's block of the all-stick problem of the resting contacts (docs/physics.md, "Static
/// friction first"): the force x (world frame) in the friction cone |x_t| <= mu x_n (x_n = n.x,
/// x_t its part along t1, t2) that minimizes x^T b + x^T A x / 2, for the contact's 3x3 Delassus
/// block A [1/kg] (symmetric positive semi-definite) and b [m/s^2] the relative acceleration it
/// would have without its own force. Inside the cone the minimizer leaves A x + b = 0 (the contact
/// stopped); on the cone's surface x = r (n + mu e(theta)), the angle found by bisection on the
/// sign of the derivative around the best of 72 samples; the apex x = 0 when nothing better.
/// mu = 0: the force along n alone, max(0, -n.b / n^T A n) n.
Eigen::Vector3d solveFrictionCone(const Eigen::Matrix3d& A, const Eigen::Vector3d& b,
                                  const Eigen::Vector3d& n, const Eigen::Vector3d& t1,
                                  const Eigen::Vector3d& t2, double mu);

/// What solveFrictionCone() computes from the block alone, once for many right-hand sides b (the
/// all-stick sweeps solve each contact's block again at every sweep with a new b only): the
/// contact's frame T = [n t1 t2], the block in it A_l = T^T A T [1/kg] and A_l's pseudo-inverse
/// [kg] (least_norm.h), mu and trace(A).
struct FrictionConeBlock {
  Eigen::Matrix3d frame = Eigen::Matrix3d::Identity();             // T, columns n, t1, t2 (world)
  Eigen::Matrix3d local = Eigen::Matrix3d::Zero();                 // A_l [1/kg]
  Eigen::Matrix3d local_pseudo_inverse = Eigen::Matrix3d::Zero();  // A_l^+ [kg]
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  Eigen::Matrix3d delassus = Eigen::Matrix3d::Zero();  // A [1/kg], world
  double trace = 0.0;
  double mu = 0.0;
};
FrictionConeBlock prepareFrictionCone(const Eigen::Matrix3d& A, const Eigen::Vector3d& n,
                                      const Eigen::Vector3d& t1, const Eigen::Vector3d& t2,
                                      double mu);
/// solveFrictionCone() on a prepared block: the same operations in the same order, so the same
/// answer to the last bit.
Eigen::Vector3d solveFrictionCone(const FrictionConeBlock& block, const Eigen::Vector3d& b);

}  // namespace collision_response::core
