#pragma once

#include <Eigen/Core>
#include <vector>

#include "collision_response/core/body_model.h"
#include "collision_response/core/body_state.h"

namespace collision_response::core {

/// A free rigid body prepared for the solvers: world-frame inverse mass properties and velocities
/// of the centre of mass. As a BodyModel its 6 velocity unknowns are (v, w), world, with
/// M = diag(m I3, Iw) and J(p) = [I3, -[r]x], r = p - c (docs/physics.md, "Symbols and
/// conventions"). An immovable body has inverse_mass 0 and a zero inverse inertia, no unknowns,
/// and is never changed (its velocity is prescribed).
struct RigidBody final : BodyModel {
  double inverse_mass = 0.0;                                   ///< [1/kg]
  Eigen::Matrix3d inverse_inertia = Eigen::Matrix3d::Zero();   ///< R I^-1 R^T, world [1/(kg m^2)]
  Eigen::Vector3d com = Eigen::Vector3d::Zero();               ///< centre of mass, world [m]
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();   ///< world [m/s]
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  ///< world [rad/s]
  /// Resting contacts: the accelerations under the body's wrench alone (setFreeAcceleration()),
  /// centre of mass [m/s^2] and angular [rad/s^2], world; zero unless set.
  Eigen::Vector3d linear_acceleration = Eigen::Vector3d::Zero();
  Eigen::Vector3d angular_acceleration = Eigen::Vector3d::Zero();

  bool movable() const { return inverse_mass > 0.0; }

  /// Velocity of the material point at offset r from the centre of mass [m/s].
  Eigen::Vector3d pointVelocity(const Eigen::Vector3d& r) const {
    return linear_velocity + angular_velocity.cross(r);
  }

  /// Acceleration of the material point at offset r from the centre of mass under the wrench
  /// alone [m/s^2]: a + alpha x r + w x (w x r).
  Eigen::Vector3d pointFreeAcceleration(const Eigen::Vector3d& r) const {
    return linear_acceleration + angular_acceleration.cross(r) +
           angular_velocity.cross(angular_velocity.cross(r));
  }

  /// Applies the impulse p [N s] at offset r from the centre of mass (no-op for immovable bodies).
  void applyImpulse(const Eigen::Vector3d& p, const Eigen::Vector3d& r) {
    if (!movable()) return;
    linear_velocity += inverse_mass * p;
    angular_velocity += inverse_inertia * r.cross(p);
  }

  // BodyModel (world points; the solvers use the closed forms above through asRigidBody()).
  int velocityCount() const override { return movable() ? 6 : 0; }
  Eigen::VectorXd velocity() const override;
  Eigen::Vector3d materialPointVelocity(const Eigen::Vector3d& point) const override {
    return pointVelocity(point - com);
  }
  Eigen::Matrix<double, 3, Eigen::Dynamic> pointJacobian(
      const Eigen::Vector3d& point) const override;
  Eigen::Matrix<double, Eigen::Dynamic, 3> inverseMassJacobianTranspose(
      const Eigen::Vector3d& point) const override;
  void addVelocityChange(const Eigen::Ref<const Eigen::VectorXd>& change) override;
  Eigen::Vector3d partPointFreeAcceleration(int /*part*/,
                                            const Eigen::Vector3d& point) const override {
    return pointFreeAcceleration(point - com);
  }
  const RigidBody* asRigidBody() const override { return this; }
};

/// Builds the solver's view of a validated body state (velocities; no accelerations: impacts do
/// not need them).
RigidBody makeRigidBody(const BodyState& state);

/// Sets body.linear_acceleration and angular_acceleration from the state's wrench (resting
/// contacts): a = F / m, alpha = Iw^-1 (tau - w x Iw w); zero for an immovable body.
void setFreeAcceleration(const BodyState& state, RigidBody& body);

/// The solver's view of each of `states`, in order, into `bodies` (cleared first; its storage is
/// reused): makeRigidBody() of each, velocities only. The one place a request's rigid bodies are
/// built, for computeResponse() and for requests with robots alike.
void makeRigidBodies(const std::vector<BodyState>& states, std::vector<RigidBody>& bodies);

/// setFreeAcceleration() of each body from its state (`bodies` built from `states` by
/// makeRigidBodies(), same order): the free accelerations resting contacts read.
void setFreeAccelerations(const std::vector<BodyState>& states, std::vector<RigidBody>& bodies);

/// [r]x, the matrix with [r]x y = r x y (inline: K of every rigid contact is built from it).
inline Eigen::Matrix3d skew(const Eigen::Vector3d& r) {
  Eigen::Matrix3d s;
  s << 0.0, -r.z(), r.y(), r.z(), 0.0, -r.x(), -r.y(), r.x(), 0.0;
  return s;
}

}  // namespace collision_response::core
