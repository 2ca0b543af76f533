// Closed forms of the planar 2R arm of test/robot/two_link.urdf (both joints about z; link 1:
// m1 = 2 kg, l1 = 1 m, centre of mass at lc1 = 0.5 m; link 2: m2 = 1 kg, l2 = 0.8 m, lc2 = 0.4 m;
// uniform rods, I_i = m_i l_i^2 / 12 about z, 0.001 kg m^2 about their own axis), from the
// textbook (Spong, Hutchinson and Vidyasagar, Robot Modeling and Control, 7.4.2), written here by
// hand: the tests' references, independent of the robot library.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace two_link {

constexpr double m1 = 2.0, l1 = 1.0, lc1 = 0.5, I1 = m1 * l1 * l1 / 12.0;
constexpr double m2 = 1.0, l2 = 0.8, lc2 = 0.4, I2 = m2 * l2 * l2 / 12.0;

// M11 = m1 lc1^2 + m2 (l1^2 + lc2^2 + 2 l1 lc2 cos q2) + I1 + I2
// M12 = m2 (lc2^2 + l1 lc2 cos q2) + I2,   M22 = m2 lc2^2 + I2.
inline Eigen::Matrix2d massMatrix(double q2) {
  Eigen::Matrix2d m;
  m(0, 0) = m1 * lc1 * lc1 + m2 * (l1 * l1 + lc2 * lc2 + 2 * l1 * lc2 * std::cos(q2)) + I1 + I2;
  m(0, 1) = m(1, 0) = m2 * (lc2 * lc2 + l1 * lc2 * std::cos(q2)) + I2;
  m(1, 1) = m2 * lc2 * lc2 + I2;
  return m;
}

// C(q, qdot) qdot with h = -m2 l1 lc2 sin q2: (h (2 qdot1 qdot2 + qdot2^2), -h qdot1^2).
inline Eigen::Vector2d coriolis(double q2, const Eigen::Vector2d& qdot) {
  const double h = -m2 * l1 * lc2 * std::sin(q2);
  return {h * (2 * qdot(0) * qdot(1) + qdot(1) * qdot(1)), -h * qdot(0) * qdot(0)};
}

// g(q) for gravity g [m/s^2] along -y (the angles are measured from x):
// ((m1 lc1 + m2 l1) g cos q1 + m2 lc2 g cos(q1 + q2), m2 lc2 g cos(q1 + q2)).
inline Eigen::Vector2d gravity(double q1, double q2, double g) {
  const double c12 = std::cos(q1 + q2);
  return {(m1 * lc1 + m2 * l1) * g * std::cos(q1) + m2 * lc2 * g * c12, m2 * lc2 * g * c12};
}

// The tip (the end of link 2), its Jacobian (x, y rows) and J-dot qdot.
inline Eigen::Vector2d tip(double q1, double q2) {
  return {l1 * std::cos(q1) + l2 * std::cos(q1 + q2), l1 * std::sin(q1) + l2 * std::sin(q1 + q2)};
}
inline Eigen::Matrix2d tipJacobian(double q1, double q2) {
  Eigen::Matrix2d j;
  j << -l1 * std::sin(q1) - l2 * std::sin(q1 + q2), -l2 * std::sin(q1 + q2),
      l1 * std::cos(q1) + l2 * std::cos(q1 + q2), l2 * std::cos(q1 + q2);
  return j;
}
// Centripetal acceleration of the tip: -l1 qdot1^2 e(q1) - l2 (qdot1 + qdot2)^2 e(q1 + q2).
inline Eigen::Vector2d tipVelocityProduct(double q1, double q2, const Eigen::Vector2d& qdot) {
  const double w2 = qdot(0) + qdot(1);
  return -l1 * qdot(0) * qdot(0) * Eigen::Vector2d(std::cos(q1), std::sin(q1)) -
         l2 * w2 * w2 * Eigen::Vector2d(std::cos(q1 + q2), std::sin(q1 + q2));
}

// Both joints locked: one rigid body of mass m1 + m2, centre of mass c and inertia I about it
// (world axes), base at the identity.
struct Composite {
  double mass = 0.0;
  Eigen::Vector3d com = Eigen::Vector3d::Zero();
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
};
inline Composite composite(double q1, double q2) {
  const Eigen::Matrix3d R1 = Eigen::AngleAxisd(q1, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Matrix3d R2 =
      Eigen::AngleAxisd(q1 + q2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d c1 = R1 * Eigen::Vector3d(lc1, 0, 0);
  const Eigen::Vector3d c2 = R1 * Eigen::Vector3d(l1, 0, 0) + R2 * Eigen::Vector3d(lc2, 0, 0);
  const Eigen::Matrix3d J1 = Eigen::Vector3d(0.001, I1, I1).asDiagonal();
  const Eigen::Matrix3d J2 = Eigen::Vector3d(0.001, I2, I2).asDiagonal();
  Composite out;
  out.mass = m1 + m2;
  out.com = (m1 * c1 + m2 * c2) / out.mass;
  const auto shift = [&](double mi, const Eigen::Vector3d& r) {
    return Eigen::Matrix3d(mi *
                           (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose()));
  };
  out.inertia = R1 * J1 * R1.transpose() + shift(m1, c1 - out.com) + R2 * J2 * R2.transpose() +
                shift(m2, c2 - out.com);
  return out;
}

}  // namespace two_link
