#include "collision_response/core/free_flight.h"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>

namespace collision_response::core {
namespace {

using Vector4 = Eigen::Vector4d;  // quaternion coefficients in Eigen's order (x, y, z, w)

// Torque-free rotation with world angular momentum L: dq/dt = 1/2 (0, w) q, w = R I^-1 R^T L.
struct TorqueFree {
  Eigen::Matrix3d inverse_inertia;  // body frame
  Eigen::Vector3d momentum;         // world, conserved

  Eigen::Vector3d angularVelocity(const Vector4& q) const {
    const Eigen::Matrix3d R = Eigen::Quaterniond(q).normalized().toRotationMatrix();
    return R * (inverse_inertia * (R.transpose() * momentum));
  }
  Vector4 derivative(const Vector4& q) const {
    const Eigen::Vector3d w = angularVelocity(q);
    const Eigen::Vector3d v = q.head<3>();
    Vector4 dq;
    dq.head<3>() = 0.5 * (q.w() * w + w.cross(v));
    dq.w() = -0.5 * w.dot(v);
    return dq;
  }
};

// Dormand-Prince 5(4) on the quaternion over [0, dt], local extrapolation (the 5th-order solution
// is kept), first-same-as-last. Returns the normalised quaternion at dt.
Vector4 integrateRotation(const TorqueFree& f, Vector4 q, double dt, double speed_bound) {
  constexpr double a21 = 1.0 / 5.0;
  constexpr double a31 = 3.0 / 40.0, a32 = 9.0 / 40.0;
  constexpr double a41 = 44.0 / 45.0, a42 = -56.0 / 15.0, a43 = 32.0 / 9.0;
  constexpr double a51 = 19372.0 / 6561.0, a52 = -25360.0 / 2187.0, a53 = 64448.0 / 6561.0,
                   a54 = -212.0 / 729.0;
  constexpr double a61 = 9017.0 / 3168.0, a62 = -355.0 / 33.0, a63 = 46732.0 / 5247.0,
                   a64 = 49.0 / 176.0, a65 = -5103.0 / 18656.0;
  constexpr double b1 = 35.0 / 384.0, b3 = 500.0 / 1113.0, b4 = 125.0 / 192.0,
                   b5 = -2187.0 / 6784.0, b6 = 11.0 / 84.0;
  // 5th-order minus 4th-order weights: the error estimate.
  constexpr double e1 = 71.0 / 57600.0, e3 = -71.0 / 16695.0, e4 = 71.0 / 1920.0,
                   e5 = -17253.0 / 339200.0, e6 = 22.0 / 525.0, e7 = -1.0 / 40.0;

  // First step: a rotation of about 0.01 rad at the largest angular speed, then step control.
  double h = speed_bound > 0.0 ? std::min(dt, 0.01 / speed_bound) : dt;
  double t = 0.0;
  Vector4 k1 = f.derivative(q);
  int rejected_in_a_row = 0;
  while (t < dt) {
    const bool last = t + h >= dt;
    if (last) h = dt - t;
    const Vector4 k2 = f.derivative(q + h * a21 * k1);
    const Vector4 k3 = f.derivative(q + h * (a31 * k1 + a32 * k2));
    const Vector4 k4 = f.derivative(q + h * (a41 * k1 + a42 * k2 + a43 * k3));
    const Vector4 k5 = f.derivative(q + h * (a51 * k1 + a52 * k2 + a53 * k3 + a54 * k4));
    const Vector4 k6 = f.derivative(q + h * (a61 * k1 + a62 * k2 + a63 * k3 + a64 * k4 + a65 * k5));
    Vector4 next = q + h * (b1 * k1 + b3 * k3 + b4 * k4 + b5 * k5 + b6 * k6);
    const Vector4 k7 = f.derivative(next);
    const double error =
        (h * (e1 * k1 + e3 * k3 + e4 * k4 + e5 * k5 + e6 * k6 + e7 * k7)).cwiseAbs().maxCoeff();
    // Accept within the tolerance (or at a step so small that round-off dominates).
    if (error <= kFreeFlightTolerance || h <= 1e-14 * dt || rejected_in_a_row > 50) {
      t = last ? dt : t + h;
      q = next.normalized();
      k1 = f.derivative(q);
      rejected_in_a_row = 0;
    } else {
      ++rejected_in_a_row;
    }
    const double factor = error > 0.0 ? 0.9 * std::pow(kFreeFlightTolerance / error, 0.2) : 5.0;
    h *= std::clamp(factor, 0.2, 5.0);
  }
  return q;
}

Eigen::Vector3d worldMomentum(const BodyState& body, const Eigen::Matrix3d& R) {
  return R * (body.inertia * (R.transpose() * body.angular_velocity));
}

}  // namespace

bool isotropicInertia(const Eigen::Matrix3d& inertia) {
  const double mean = inertia.trace() / 3.0;
  return (inertia - mean * Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <=
         1e-12 * std::abs(mean);
}

double angularSpeedBound(const BodyState& body) {
  const double speed = body.angular_velocity.norm();
  if (body.immovable() || speed == 0.0 || isotropicInertia(body.inertia)) return speed;
  const Eigen::Matrix3d R = body.orientation.normalized().toRotationMatrix();
  const double smallest_moment =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(body.inertia, Eigen::EigenvaluesOnly)
          .eigenvalues()(0);
  return std::max(speed, worldMomentum(body, R).norm() / smallest_moment);
}

void advanceFreeFlight(BodyState& body, double dt, const Eigen::Vector3d& gravity) {
  if (dt <= 0.0) return;
  const Eigen::Quaterniond q0 = body.orientation.normalized();
  // (A centre of mass at the body frame's origin, the usual case, needs no rotation.)
  const bool com_at_origin = body.com.isZero(0.0);
  const Eigen::Vector3d com_world = com_at_origin ? body.position : body.position + q0 * body.com;
  const Eigen::Vector3d& w = body.angular_velocity;
  const double speed = w.norm();
  Eigen::Quaterniond q1 = q0;
  if (speed > 0.0) {
    if (body.immovable() || isotropicInertia(body.inertia)) {
      q1 = Eigen::Quaterniond(Eigen::AngleAxisd(speed * dt, w / speed)) * q0;
    } else {
      const Eigen::Matrix3d R = q0.toRotationMatrix();
      TorqueFree f{body.inertia.inverse(), worldMomentum(body, R)};
      q1 = Eigen::Quaterniond(integrateRotation(f, q0.coeffs(), dt, angularSpeedBound(body)));
      body.angular_velocity = f.angularVelocity(q1.coeffs());
    }
    q1.normalize();
  }
  Eigen::Vector3d com_next = com_world + dt * body.linear_velocity;
  if (!body.immovable()) {
    com_next += 0.5 * dt * dt * gravity;
    body.linear_velocity += dt * gravity;
  }
  body.orientation = q1;
  body.position = com_at_origin ? com_next : com_next - q1 * body.com;
}

}  // namespace collision_response::core
