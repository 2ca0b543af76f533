#include "collision_response/core/single_contact.h"

#include <Eigen/Core>
#include <cmath>

namespace collision_response::core {
namespace {

// The textbook two-pass procedure (docs/physics.md, "The textbook two-pass procedure and its
// pitfalls"): the frictionless impulse formula alone, then friction from the pre-impact
// tangential velocity with the effective mass along the tangent, 1 / (t^T K t).
Eigen::Vector3d seedOnePass(const ContactRow& row, const Eigen::Vector3d& u, double u_n,
                            bool& sticking) {
  const Eigen::Vector3d& n = row.normal;
  const Eigen::Matrix3d& K = row.space.K;
  const double j_r = -(1.0 + row.restitution) * u_n / n.dot(K * n);
  Eigen::Vector3d P = j_r * n;
  sticking = false;
  const Eigen::Vector3d u_t = u - u_n * n;
  const double slip = u_t.norm();
  if (row.frictionless() || slip == 0.0) return P;
  const Eigen::Vector3d t = u_t / slip;
  const double j_stick = slip / t.dot(K * t);
  if (j_stick <= row.static_friction * j_r) {
    sticking = true;
    P -= j_stick * t;
  } else {
    P -= row.dynamic_friction * j_r * t;
  }
  return P;
}

// x with K x = rhs for a symmetric 3x3 K, by its adjugate (K is positive definite here: at least
// one body is movable).
Eigen::Vector3d solveSymmetric(const Eigen::Matrix3d& K, const Eigen::Vector3d& rhs) {
  const double a = K(0, 0), b = K(0, 1), c = K(0, 2), d = K(1, 1), e = K(1, 2), f = K(2, 2);
  const double A = d * f - e * e, B = c * e - b * f, C = b * e - c * d;
  const double D = a * f - c * c, E = b * c - a * e, F = a * d - b * b;
  const double inverse_det = 1.0 / (a * A + b * B + c * C);
  return inverse_det * Eigen::Vector3d(A * rhs.x() + B * rhs.y() + C * rhs.z(),
                                       B * rhs.x() + D * rhs.y() + E * rhs.z(),
                                       C * rhs.x() + E * rhs.y() + F * rhs.z());
}

// Newton restitution with Coulomb friction, normal and tangential impulses solved together.
Eigen::Vector3d coupledNewton(const ContactRow& row, const Eigen::Vector3d& u, double u_n,
                              bool& sticking) {
  const Eigen::Vector3d& n = row.normal;
  const Eigen::Matrix3d& K = row.space.K;
  sticking = false;
  if (row.frictionless()) return (-(1.0 + row.restitution) * u_n / n.dot(K * n)) * n;

  // Sticking: u' = -e u_n n, i.e. the change -(1 + e) u_n n - u_t = -u - e u_n n.
  const Eigen::Vector3d P_stick = solveSymmetric(K, -u - row.restitution * u_n * n);
  const double P_n = P_stick.dot(n);
  const Eigen::Vector3d P_t = P_stick - P_n * n;
  const double limit = row.static_friction * P_n;
  const double P_t_squared = P_t.squaredNorm();
  if (P_n >= 0.0 && P_t_squared <= limit * limit) {
    sticking = true;
    return P_stick;
  }
  const double P_t_norm = std::sqrt(P_t_squared);
  // Sliding along the direction the sticking impulse wanted, on the dynamic cone.
  if (P_t_norm == 0.0) return (-(1.0 + row.restitution) * u_n / n.dot(K * n)) * n;
  const Eigen::Vector3d direction = n + (row.dynamic_friction / P_t_norm) * P_t;
  const double denominator = n.dot(K * direction);
  if (!(denominator > 0.0)) {
    sticking = true;
    return P_stick;
  }
  return (-(1.0 + row.restitution) * u_n / denominator) * direction;
}

}  // namespace

ContactImpulse solveSingleContact(const RigidBody& a, const RigidBody& b, const ContactRow& row,
                                  ImpactLaw law) {
  ContactImpulse impulse;
  const Eigen::Vector3d u = row.space.relativeVelocity(a, b);
  const double u_n = u.dot(row.normal);
  impulse.normal_velocity_before = u_n;
  impulse.normal_velocity_after = u_n;
  if (u_n >= 0.0) return impulse;

  const Eigen::Vector3d P = law == ImpactLaw::kSeedOnePass
                                ? seedOnePass(row, u, u_n, impulse.sticking)
                                : coupledNewton(row, u, u_n, impulse.sticking);
  impulse.normal_impulse = P.dot(row.normal);
  impulse.friction_impulse = P - impulse.normal_impulse * row.normal;
  // The coupled law meets u'_n = -e u_n by construction (every branch); the two-pass
  // procedure's second pass changes it, so it is measured.
  impulse.normal_velocity_after = law == ImpactLaw::kSeedOnePass
                                      ? u_n + row.normal.dot(row.space.K * P)
                                      : -row.restitution * u_n;
  return impulse;
}

}  // namespace collision_response::core
