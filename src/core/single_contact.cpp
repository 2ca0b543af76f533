#include "collision_response/core/single_contact.h"

#include <Eigen/Core>
#include <cmath>

#include "collision_response/core/least_norm.h"

namespace collision_response::core {
namespace {

// The textbook two-pass procedure (docs/physics.md, "The textbook two-pass procedure and its
// pitfalls"): the frictionless impulse formula alone, then friction from the pre-impact
// tangential velocity with the effective mass along the tangent, 1 / (t^T K t).
Eigen::Vector3d twoPassImpulse(const ProblemContact& contact, const Eigen::Vector3d& u, double u_n,
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

// The impulse P [N s] into `impulse` as its parts along n: P_n = P.n and P_t = P - P_n n.
[[gnu::always_inline]] inline void setImpulse(const Eigen::Vector3d& P, const Eigen::Vector3d& n,
                                              ContactImpulse& impulse) {
  // Both parts computed before either is stored: `impulse` may alias n for the compiler.
  const double P_n = P.dot(n);
  const Eigen::Vector3d P_t = P - P_n * n;
  impulse.normal_impulse = P_n;
  impulse.friction_impulse = P_t;
}

// Newton restitution without friction: P = -(1 + e) u_n / K_nn n into `impulse`; false (no
// impulse) when nothing moves along n (K_nn = 0).
bool frictionlessNewtonImpulse(const ProblemContact& contact, double u_n, ContactImpulse& impulse) {
  const Eigen::Vector3d& n = contact.normal;
  const Eigen::Matrix3d& K = contact.delassus;
  const double K_nn = n.dot(K * n);
  if (!(K_nn > kSingularRelative * K.trace())) {
    setImpulse(Eigen::Vector3d::Zero(), n, impulse);
    return false;
  }
  setImpulse((-(1.0 + contact.restitution) * u_n / K_nn) * n, n, impulse);
  return true;
}

// Newton restitution with Coulomb friction (a contact with friction), normal and tangential
// impulses solved together: sets the impulse's normal and friction parts and `sticking`; false
// when the impulse cannot give u'_n = -e u_n (n^T K n = 0). The sticking branch has P_n and P_t
// already and writes them as they are (the values setImpulse() would compute from P_stick).
[[gnu::always_inline]] inline bool coupledNewton(const ProblemContact& contact,
                                                 const Eigen::Vector3d& u, double u_n,
                                                 ContactImpulse& impulse) {
  const Eigen::Vector3d& n = contact.normal;
  const Eigen::Matrix3d& K = contact.delassus;
  // K x = rhs by the adjugate when K is regular (the fast path, no decomposition).
  const double a = K(0, 0), b = K(0, 1), c = K(0, 2), d = K(1, 1), e = K(1, 2), f = K(2, 2);
  const double A = d * f - e * e, B = c * e - b * f, C = b * e - c * d;
  const double det = a * A + b * B + c * C;
  const double trace = a + d + f;
  if (!(det > kSingularRelative * trace * trace * trace)) {
    bool reached_target = true;
    setImpulse(singularNewton(contact, u, u_n, impulse.sticking, reached_target), n, impulse);
    return reached_target;
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
    impulse.sticking = true;
    impulse.normal_impulse = P_n;
    impulse.friction_impulse = P_t;
    return true;
  }
  // Sliding along the direction the sticking impulse wanted, on the dynamic cone (slidingImpulse()
  // written out here: this is the hot path, and |P_t| is known).
  const double P_t_norm = std::sqrt(P_t_squared);
  if (P_t_norm == 0.0) {
    setImpulse(frictionlessImpulse(contact, u_n), n, impulse);
    return true;
  }
  const Eigen::Vector3d direction = n + (contact.dynamic_friction / P_t_norm) * P_t;
  const double denominator = n.dot(K * direction);
  if (!(denominator > 0.0)) {
    impulse.sticking = true;  // Painleve-like: no sliding impulse exists
    impulse.normal_impulse = P_n;
    impulse.friction_impulse = P_t;
    return true;
  }
  setImpulse((-(1.0 + contact.restitution) * u_n / denominator) * direction, n, impulse);
  return true;
}

}  // namespace

// solveSingleContact()'s paths (single_contact.h): one function each, so that none pays for the
// set-up (stack frame, spilled registers) of another.
namespace single_contact_paths {

ContactImpulse frictionlessNewton(const ProblemContact& contact, const Eigen::Vector3d& u) {
  ContactImpulse impulse;
  const double u_n = u.dot(contact.normal);
  impulse.normal_velocity_before = u_n;
  impulse.normal_velocity_after = u_n;
  if (u_n < 0.0 && frictionlessNewtonImpulse(contact, u_n, impulse)) {
    impulse.normal_velocity_after = -contact.restitution * u_n;
  }
  return impulse;
}

ContactImpulse frictionalNewton(const ProblemContact& contact, const Eigen::Vector3d& u) {
  ContactImpulse impulse;
  const double u_n = u.dot(contact.normal);
  impulse.normal_velocity_before = u_n;
  impulse.normal_velocity_after = u_n;
  if (u_n < 0.0 && coupledNewton(contact, u, u_n, impulse)) {
    impulse.normal_velocity_after = -contact.restitution * u_n;
  }
  return impulse;
}

ContactImpulse seedOnePass(const ProblemContact& contact, const Eigen::Vector3d& u) {
  ContactImpulse impulse;
  const double u_n = u.dot(contact.normal);
  impulse.normal_velocity_before = u_n;
  impulse.normal_velocity_after = u_n;
  if (u_n >= 0.0) return impulse;
  // The second pass changes u'_n, so it is measured.
  const Eigen::Vector3d P = twoPassImpulse(contact, u, u_n, impulse.sticking);
  setImpulse(P, contact.normal, impulse);
  impulse.normal_velocity_after = u_n + contact.normal.dot(contact.delassus * P);
  return impulse;
}

}  // namespace single_contact_paths

}  // namespace collision_response::core
