#pragma once

#include <Eigen/Core>
#include <stdexcept>

namespace collision_response::core {

struct RigidBody;

/// A body as the contact problem sees it (docs/physics.md, "The contact problem"): n velocity
/// unknowns v (6 for a free rigid body: the velocity of its centre of mass [m/s] and its angular
/// velocity [rad/s], world; 0 for an immovable body; for an articulated robot its n joint
/// velocities), a symmetric positive definite mass matrix M(q) in those unknowns, and for every
/// material point p the 3 x n Jacobian J(p) that gives the point's world velocity, J(p) v [m/s].
/// An impulse P [N s] applied at p changes v by M^-1 J(p)^T P, and an impulse P at p moves the
/// velocity of a point p' by J(p') M^-1 J(p)^T P: the blocks of the Delassus operator.
///
/// The contact problem (contact_problem.h) asks a body for these once, when it is built, and
/// gives the solvers no body: a new kind of body (a robot with M(q) from CRBA and a Cholesky
/// factor of it) implements this interface and needs no change in any solver. A free rigid body
/// (RigidBody) says so through asRigidBody(), and the problem then uses its closed forms (lever
/// arms, 3x3 blocks; no n x 3 matrices and no virtual call per operation).
class BodyModel {
 public:
  virtual ~BodyModel() = default;

  /// n, the number of velocity unknowns; 0 for a body whose motion is prescribed (immovable).
  virtual int velocityCount() const = 0;
  /// v, the n velocity unknowns (units per unknown: m/s for translations, rad/s for rotations).
  virtual Eigen::VectorXd velocity() const = 0;
  /// World velocity of the material point of the body that sits at the world point p [m/s]
  /// (including prescribed motion: an immovable body may move).
  virtual Eigen::Vector3d materialPointVelocity(const Eigen::Vector3d& point) const = 0;
  /// J(p), 3 x n: the velocity of the material point at world p per unit of each unknown.
  virtual Eigen::Matrix<double, 3, Eigen::Dynamic> pointJacobian(
      const Eigen::Vector3d& point) const = 0;
  /// M^-1 J(p)^T, n x 3: the change of v per unit impulse [N s] applied at world p.
  virtual Eigen::Matrix<double, Eigen::Dynamic, 3> inverseMassJacobianTranspose(
      const Eigen::Vector3d& point) const = 0;
  /// v += change (n entries). Does nothing for a body without unknowns.
  virtual void addVelocityChange(const Eigen::Ref<const Eigen::VectorXd>& change) = 0;
  /// Bodies made of several parts (the links of a robot, articulated_body.h) resolve a contact's
  /// point on the part it names (ContactPoint::part_a / part_b): these take that part, -1 for
  /// "the body's own" (the default: the methods above, for single-part bodies).
  virtual Eigen::Vector3d partPointVelocity(int /*part*/, const Eigen::Vector3d& point) const {
    return materialPointVelocity(point);
  }
  virtual Eigen::Matrix<double, 3, Eigen::Dynamic> partPointJacobian(
      int /*part*/, const Eigen::Vector3d& point) const {
    return pointJacobian(point);
  }
  virtual Eigen::Matrix<double, Eigen::Dynamic, 3> partInverseMassJacobianTranspose(
      int /*part*/, const Eigen::Vector3d& point) const {
    return inverseMassJacobianTranspose(point);
  }
  /// Resting contacts (docs/physics.md, "Resting contacts"): the world acceleration [m/s^2] of
  /// the material point of `part` (-1: the body's own) at world p under the body's own loads alone
  /// (no contact force): what its wrench, gravity or actuators give, with the velocity-product
  /// terms (w x (w x r) of a rigid body, J-dot v of a robot). The default, for a model that knows
  /// of no load, is 0. A model may compute it on first use and keep it (a robot does): like the
  /// setters, not to be called on one object from several threads at once.
  virtual Eigen::Vector3d partPointFreeAcceleration(int /*part*/,
                                                    const Eigen::Vector3d& /*point*/) const {
    return Eigen::Vector3d::Zero();
  }
  /// The free rigid body behind this model (the solvers' closed-form fast path), or nullptr.
  virtual const RigidBody* asRigidBody() const { return nullptr; }

  // --- Configuration derivatives (docs/physics.md, "Derivatives with respect to a robot's joint
  // positions"): a body whose M and J depend on coordinates q of its own (a robot's joint
  // positions, robot/configuration_derivatives.h) gives their derivatives, so that the impact can
  // be differentiated by them in closed form (core::computeBodyImpactDerivatives()). Columns: the
  // body's configurationCount() coordinates, in its order; per rad (revolute) or m (prismatic). A
  // world point p named with a part is the part's material point at p, held in the world.
  /// The number of configuration coordinates this body can differentiate by (0: none, the default).
  /// A body that returns more than 0 overrides every method below; their defaults refuse
  /// (std::logic_error), so that a model missing one fails loudly instead of differentiating
  /// with a wrong answer.
  virtual int configurationCount() const { return 0; }
  /// d/dq of the world velocity of the material point of `part` at p at the body's own motion
  /// (prescribed motion included), 3 x configurationCount() [m/s per coordinate unit].
  virtual Eigen::Matrix<double, 3, Eigen::Dynamic> partPointVelocityByConfiguration(
      int /*part*/, const Eigen::Vector3d& /*point*/) const {
    throw std::logic_error("BodyModel::partPointVelocityByConfiguration() not provided");
  }
  /// d/dq of J(p) x for the unknowns' values x (velocityCount()), 3 x configurationCount().
  virtual Eigen::Matrix<double, 3, Eigen::Dynamic> partJacobianProductByConfiguration(
      int /*part*/, const Eigen::Vector3d& /*point*/, const Eigen::VectorXd& /*x*/) const {
    throw std::logic_error("BodyModel::partJacobianProductByConfiguration() not provided");
  }
  /// d/dq of J(p)^T F, velocityCount() x configurationCount() (F [N] or [N s] applied at p).
  virtual Eigen::MatrixXd partJacobianTransposeProductByConfiguration(
      int /*part*/, const Eigen::Vector3d& /*point*/, const Eigen::Vector3d& /*force*/) const {
    throw std::logic_error("BodyModel::partJacobianTransposeProductByConfiguration() not provided");
  }
  /// d/dq of M x, velocityCount() x configurationCount().
  virtual Eigen::MatrixXd massMatrixProductByConfiguration(const Eigen::VectorXd& /*x*/) const {
    throw std::logic_error("BodyModel::massMatrixProductByConfiguration() not provided");
  }
  /// M^-1 x for every column of x (velocityCount() rows).
  virtual Eigen::MatrixXd inverseMassTimes(const Eigen::MatrixXd& /*x*/) const {
    throw std::logic_error("BodyModel::inverseMassTimes() not provided");
  }

  /// Applies the impulse P [N s] at world p: v += M^-1 J(p)^T P.
  void applyImpulseAt(const Eigen::Vector3d& point, const Eigen::Vector3d& impulse) {
    if (velocityCount() > 0) addVelocityChange(inverseMassJacobianTranspose(point) * impulse);
  }
};

}  // namespace collision_response::core
