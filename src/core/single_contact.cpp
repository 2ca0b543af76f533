#include "collision_response/core/single_contact.h"

#include <Eigen/Core>
#include <cmath>

#include "collision_response/core/least_norm.h"

namespace collision_response::core {
namespace {

// The textbook two-pass procedure (docs/physics.md, "The textbook two-pass procedure and its
// pitfalls"): the frictionless impulse formula alone, then friction from the pre-impact
// tangential velocity with the effective mass along the tangent, 1 / (t^T K t).
Eigen::Vector3d seedOnePass(const ProblemContact& contact, const Eigen::Vector3d& u, double u_n,
                            bool& sticking) {
  const Eigen::Vector3d& n = contact.normal;
  const Eigen::Matrix3d& K = contact.delassus;
  sticking = false;
  const double K_nn = n.dot(K * n);
  const double singular = kSingularRelative * K.trace();
  if (!(K_nn > singular)) return Eigen::Vector3d::Zero();  // nothing moves along n
  const double j_r = -(1.0 + contact.restitution) * u_n / K_nn;
  Eigen::Vector3d P = j_r * n;
  const Eigen::Vector3d u_t = u - u_n * n;
  const double slip = u_t.norm();
  if (contact.frictionless() || slip == 0.0) return P;
  const Eigen::Vector3d t = u_t / slip;
  const double K_tt = t.dot(K * t);
  if (!(K_tt > singular)) return P;  // no impulse along t changes the slip: none is applied
  const double j_stick = slip / K_tt;
  if (j_stick <= contact.static_friction * j_r) {
    sticking = true;
    P -= j_stick * t;
  } else {
    P -= contact.dynamic_friction * j_r * t;
  }
  return P;
}

Eigen::Vector3d frictionlessImpulse(const ProblemContact& contact, double u_n) {
  const Eigen::Vector3d& n = contact.normal;
  return (-(1.0 + contact.restitution) * u_n / n.dot(contact.delassus * n)) * n;
}

// Sliding on the dynamic cone along the tangential direction the sticking impulse P_t wanted,
// sized so that u'_n = -e u_n. False if P_t is zero or the denominator is not positive.
bool slidingImpulse(const ProblemContact& contact, double u_n, const Eigen::Vector3d& P_t,
                    Eigen::Vector3d& P) {
  const double P_t_norm = P_t.norm();
  if (P_t_norm == 0.0) return false;
  const Eigen::Vector3d& n = contact.normal;
  const Eigen::Vector3d direction = n + (contact.dynamic_friction / P_t_norm) * P_t;
  const double denominator = n.dot(contact.delassus * direction);
  if (!(denominator > 0.0)) return false;
  P = (-(1.0 + contact.restitution) * u_n / denominator) * direction;
  return true;
}

// Newton with friction for a singular K (the rare path of solveSingleContact()'s documentation).
// Sets reached_target false when the impulse cannot give u'_n = -e u_n (n^T K n = 0).
[[gnu::cold, gnu::noinline]] Eigen::Vector3d singularNewton(const ProblemContact& contact,
                                                            const Eigen::Vector3d& u, double u_n,
                                                            bool& sticking, bool& reached_target) {
  const Eigen::Vector3d& n = contact.normal;
  const Eigen::Matrix3d& K = contact.delassus;
  sticking = false;
  reached_target = true;
  if (!(n.dot(K * n) > kSingularRelative * K.trace())) {
    reached_target = false;
    return Eigen::Vector3d::Zero();
  }
  const Eigen::Vector3d change = -u - contact.restitution * u_n * n;  // to u' = -e u_n n
  const Eigen::Vector3d P_stick = solveSymmetricLeastNorm(K, change);
  const bool reachable = (K * P_stick - change).norm() <= 1e-9 * std::max(change.norm(), u.norm());
  const double P_n = P_stick.dot(n);
  const Eigen::Vector3d P_t = P_stick - P_n * n;
  if (reachable && P_n >= 0.0 && P_t.norm() <= contact.static_friction * P_n) {
    sticking = true;
    return P_stick;
  }
  Eigen::Vector3d P;
  if (slidingImpulse(contact, u_n, P_t, P)) return P;
  return frictionlessImpulse(contact, u_n);
}

// Newton restitution with Coulomb friction, normal and tangential impulses solved together.
Eigen::Vector3d coupledNewton(const ProblemContact& contact, const Eigen::Vector3d& u, double u_n,
                              bool& sticking, bool& reached_target) {
  const Eigen::Vector3d& n = contact.normal;
  const Eigen::Matrix3d& K = contact.delassus;
  sticking = false;
  reached_target = true;
  if (contact.frictionless()) {
    const double K_nn = n.dot(K * n);
    if (!(K_nn > kSingularRelative * K.trace())) {  // nothing moves along n: no impulse
      reached_target = false;
      return Eigen::Vector3d::Zero();
    }
    return (-(1.0 + contact.restitution) * u_n / K_nn) * n;
  }
  // K x = rhs by the adjugate when K is regular (the fast path, no decomposition).
  const double a = K(0, 0), b = K(0, 1), c = K(0, 2), d = K(1, 1), e = K(1, 2), f = K(2, 2);
  const double A = d * f - e * e, B = c * e - b * f, C = b * e - c * d;
  const double det = a * A + b * B + c * C;
  const double trace = a + d + f;
  if (!(det > kSingularRelative * trace * trace * trace)) {
    return singularNewton(contact, u, u_n, sticking, reached_target);
  }

  // Sticking: u' = -e u_n n, i.e. the change -(1 + e) u_n n - u_t = -u - e u_n n.
  const Eigen::Vector3d rhs = -u - contact.restitution * u_n * n;
  const double D = a * f - c * c, E = b * c - a * e, F = a * d - b * b;
  const double inverse_det = 1.0 / det;
  const Eigen::Vector3d P_stick =
      inverse_det * Eigen::Vector3d(A * rhs.x() + B * rhs.y() + C * rhs.z(),
                                    B * rhs.x() + D * rhs.y() + E * rhs.z(),
                                    C * rhs.x() + E * rhs.y() + F * rhs.z());
  const double P_n = P_stick.dot(n);
  const Eigen::Vector3d P_t = P_stick - P_n * n;
  const double limit = contact.static_friction * P_n;
  const double P_t_squared = P_t.squaredNorm();
  if (P_n >= 0.0 && P_t_squared <= limit * limit) {
    sticking = true;
    return P_stick;
  }
  // Sliding along the direction the sticking impulse wanted, on the dynamic cone (slidingImpulse()
  // written out here: this is the hot path, and |P_t| is known).
  const double P_t_norm = std::sqrt(P_t_squared);
  if (P_t_norm == 0.0) return frictionlessImpulse(contact, u_n);
  const Eigen::Vector3d direction = n + (contact.dynamic_friction / P_t_norm) * P_t;
  const double denominator = n.dot(K * direction);
  if (!(denominator > 0.0)) {
    sticking = true;  // Painleve-like: no sliding impulse exists
    return P_stick;
  }
  return (-(1.0 + contact.restitution) * u_n / denominator) * direction;
}

}  // namespace

ContactImpulse solveSingleContact(const ProblemContact& contact, const Eigen::Vector3d& u,
                                  ImpactLaw law) {
  ContactImpulse impulse;
  const double u_n = u.dot(contact.normal);
  impulse.normal_velocity_before = u_n;
  impulse.normal_velocity_after = u_n;
  if (u_n >= 0.0) return impulse;

  bool reached_target = true;
  const Eigen::Vector3d P = law == ImpactLaw::kSeedOnePass
                                ? seedOnePass(contact, u, u_n, impulse.sticking)
                                : coupledNewton(contact, u, u_n, impulse.sticking, reached_target);
  impulse.normal_impulse = P.dot(contact.normal);
  impulse.friction_impulse = P - impulse.normal_impulse * contact.normal;
  // The coupled law meets u'_n = -e u_n by construction (every branch that reaches its target);
  // the two-pass procedure's second pass changes it, so it is measured.
  if (law == ImpactLaw::kSeedOnePass) {
    impulse.normal_velocity_after = u_n + contact.normal.dot(contact.delassus * P);
  } else if (reached_target) {
    impulse.normal_velocity_after = -contact.restitution * u_n;
  }
  return impulse;
}

}  // namespace collision_response::core
