// Free flight (free_flight.h) against closed forms and an independent reference integration:
// the ballistic parabola; for an axisymmetric body the closed-form torque-free precession
// (rotation about the fixed angular momentum at |L| / A composed with spin about the symmetry
// axis at (1/C - 1/A) L_3); for an asymmetric body conservation of the world angular momentum and
// of the kinetic energy, and a fixed-step RK4 integration of Euler's equations in the body frame
// at a step far below the adaptive one.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "collision_response/core/free_flight.h"

namespace core = collision_response::core;

namespace {

const Eigen::Vector3d kGravity(0.3, -0.2, -9.81);

double angleBetween(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return a.normalized().angularDistance(b.normalized());
}

core::BodyState body(const Eigen::Matrix3d& inertia, const Eigen::Vector3d& w) {
  core::BodyState s;
  s.id = "b";
  s.mass = 2.0;
  s.inertia = inertia;
  s.com = {0.01, -0.02, 0.03};
  s.position = {0.1, 0.2, 1.0};
  s.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  s.linear_velocity = {1.0, -0.5, 2.0};
  s.angular_velocity = w;
  return s;
}

// Kinetic energy of rotation and world angular momentum.
double rotationalEnergy(const core::BodyState& s) {
  const Eigen::Matrix3d R = s.orientation.toRotationMatrix();
  const Eigen::Vector3d wb = R.transpose() * s.angular_velocity;
  return 0.5 * wb.dot(s.inertia * wb);
}
Eigen::Vector3d momentum(const core::BodyState& s) {
  const Eigen::Matrix3d R = s.orientation.toRotationMatrix();
  return R * s.inertia * R.transpose() * s.angular_velocity;
}

TEST(FreeFlight, CentreOfMassFollowsTheParabola) {
  core::BodyState s = body(Eigen::Matrix3d::Identity() * 0.1, {3.0, -1.0, 2.0});
  const Eigen::Vector3d c0 = s.worldCom(), v0 = s.linear_velocity;
  const double t = 0.73;
  core::advanceFreeFlight(s, t, kGravity);
  EXPECT_LT((s.worldCom() - (c0 + v0 * t + 0.5 * t * t * kGravity)).norm(), 1e-12);
  EXPECT_LT((s.linear_velocity - (v0 + t * kGravity)).norm(), 1e-12);
}

TEST(FreeFlight, IsotropicBodyTurnsAtConstantAngularVelocity) {
  const Eigen::Vector3d w(3.0, -1.0, 2.0);
  core::BodyState s = body(Eigen::Matrix3d::Identity() * 0.1, w);
  const Eigen::Quaterniond q0 = s.orientation;
  const double t = 2.1;
  core::advanceFreeFlight(s, t, kGravity);
  // Rotation by the angle |w| t about w: a point of the body frame's x axis turns by Rodrigues.
  const Eigen::Vector3d k = w.normalized();
  const double angle = w.norm() * t;
  const Eigen::Vector3d x0 = q0 * Eigen::Vector3d::UnitX();
  const Eigen::Vector3d x_expected = x0 * std::cos(angle) + k.cross(x0) * std::sin(angle) +
                                     k * k.dot(x0) * (1.0 - std::cos(angle));
  EXPECT_LT((s.orientation * Eigen::Vector3d::UnitX() - x_expected).norm(), 1e-12);
  EXPECT_LT((s.angular_velocity - w).norm(), 1e-15);
}

TEST(FreeFlight, AxisymmetricBodyPrecessesInClosedForm) {
  const double A = 0.3, C = 0.1;  // a rod-like body: axis 3 has the small moment
  const Eigen::Vector3d w0(2.0, -3.0, 7.0);
  core::BodyState s = body(Eigen::Vector3d(A, A, C).asDiagonal(), w0);
  const Eigen::Matrix3d R0 = s.orientation.toRotationMatrix();
  const Eigen::Vector3d L = R0 * Eigen::Vector3d(A, A, C).asDiagonal() * R0.transpose() * w0;
  const double L3 = (R0.transpose() * L).z();
  const double spin = (1.0 / C - 1.0 / A) * L3;
  for (const double t : {0.01, 0.5, 3.0}) {
    core::BodyState moved = s;
    core::advanceFreeFlight(moved, t, kGravity);
    const Eigen::Matrix3d R =
        Eigen::AngleAxisd(L.norm() / A * t, L.normalized()).toRotationMatrix() * R0 *
        Eigen::AngleAxisd(spin * t, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    EXPECT_LT(angleBetween(moved.orientation, Eigen::Quaterniond(R)), 1e-8) << "t = " << t;
    const Eigen::Vector3d w = L / A + (1.0 / C - 1.0 / A) * L3 * (R * Eigen::Vector3d::UnitZ());
    EXPECT_LT((moved.angular_velocity - w).norm(), 1e-8 * w.norm()) << "t = " << t;
  }
}

// Euler's equations in the body frame, I dw/dt = (I w) x w, dq/dt = q (0, w) / 2: classical RK4 at
// a fixed step.
Eigen::Quaterniond referenceRotation(const Eigen::Matrix3d& I, Eigen::Quaterniond q,
                                     Eigen::Vector3d wb, double t, int steps) {
  const Eigen::Matrix3d Iinv = I.inverse();
  using State = Eigen::Matrix<double, 7, 1>;
  const auto f = [&](const State& y) {
    const Eigen::Vector3d w = y.head<3>();
    const Eigen::Quaterniond qq(y(6), y(3), y(4), y(5));
    State d;
    d.head<3>() = Iinv * (I * w).cross(w);
    const Eigen::Quaterniond dq = qq * Eigen::Quaterniond(0.0, w.x(), w.y(), w.z());
    d(3) = 0.5 * dq.x();
    d(4) = 0.5 * dq.y();
    d(5) = 0.5 * dq.z();
    d(6) = 0.5 * dq.w();
    return d;
  };
  State y;
  y << wb, q.x(), q.y(), q.z(), q.w();
  const double h = t / steps;
  for (int i = 0; i < steps; ++i) {
    const State k1 = f(y), k2 = f(y + 0.5 * h * k1), k3 = f(y + 0.5 * h * k2), k4 = f(y + h * k3);
    y += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
  }
  return Eigen::Quaterniond(y(6), y(3), y(4), y(5)).normalized();
}

TEST(FreeFlight, AsymmetricBodyConservesMomentumAndEnergyAndMatchesAReference) {
  // A general tensor (principal moments 0.1, 0.2, 0.25 along tilted axes), turning near its
  // unstable middle axis: the tumbling that tests an integrator.
  const Eigen::Matrix3d axes =
      Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, -1, 2).normalized()).toRotationMatrix();
  const Eigen::Matrix3d I = axes * Eigen::Vector3d(0.1, 0.2, 0.25).asDiagonal() * axes.transpose();
  core::BodyState s = body(I, Eigen::Vector3d::Zero());
  s.angular_velocity = s.orientation * (axes * Eigen::Vector3d(0.5, 8.0, 0.6));
  const double energy0 = rotationalEnergy(s);
  const Eigen::Vector3d L0 = momentum(s);
  const double t = 4.0;
  core::BodyState moved = s;
  core::advanceFreeFlight(moved, t, Eigen::Vector3d::Zero());
  EXPECT_LT((momentum(moved) - L0).norm(), 1e-12 * L0.norm());
  EXPECT_LT(std::abs(rotationalEnergy(moved) - energy0), 1e-9 * energy0);
  const Eigen::Quaterniond reference =
      referenceRotation(I, s.orientation, s.orientation.inverse() * s.angular_velocity, t, 400000);
  EXPECT_LT(angleBetween(moved.orientation, reference), 1e-8);
  // The angular velocity tumbles (the flight is not a steady spin) ...
  EXPECT_GT((moved.angular_velocity - s.angular_velocity).norm(), 1.0);
  // ... and many short flights give the same motion as one long one.
  core::BodyState stepped = s;
  for (int i = 0; i < 400; ++i) core::advanceFreeFlight(stepped, t / 400, Eigen::Vector3d::Zero());
  EXPECT_LT(angleBetween(stepped.orientation, reference), 1e-8);
}

TEST(FreeFlight, ImmovableBodyMovesAtItsPrescribedVelocityWithoutGravity) {
  core::BodyState s;
  s.id = "platform";
  s.position = {1.0, 0.0, 0.0};
  s.linear_velocity = {0.0, 0.5, 0.0};
  s.angular_velocity = {0.0, 0.0, 1.0};
  core::advanceFreeFlight(s, 2.0, kGravity);
  EXPECT_LT((s.position - Eigen::Vector3d(1.0, 1.0, 0.0)).norm(), 1e-12);
  EXPECT_LT((s.linear_velocity - Eigen::Vector3d(0.0, 0.5, 0.0)).norm(), 1e-15);
  EXPECT_NEAR(angleBetween(s.orientation, Eigen::Quaterniond::Identity()), 2.0, 1e-12);
}

TEST(FreeFlight, SpeedBoundHoldsOverATumble) {
  const Eigen::Matrix3d I = Eigen::Vector3d(0.1, 0.2, 0.25).asDiagonal();
  core::BodyState s = body(I, Eigen::Vector3d(0.3, 6.0, 0.2));
  const double bound = core::angularSpeedBound(s);
  for (int i = 0; i < 200; ++i) {
    core::advanceFreeFlight(s, 0.02, Eigen::Vector3d::Zero());
    EXPECT_LE(s.angular_velocity.norm(), bound * (1 + 1e-12));
  }
}

}  // namespace
