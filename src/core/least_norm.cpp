#include "collision_response/core/least_norm.h"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>

namespace collision_response::core {

Eigen::Matrix3d symmetricPseudoInverse(const Eigen::Matrix3d& A) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(A);
  const Eigen::Vector3d& values = eigen.eigenvalues();  // ascending
  const double cutoff = kSingularRelative * std::max(values(2), 0.0);
  Eigen::Vector3d inverse = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k) {
    if (values(k) > cutoff && values(k) > 0.0) inverse(k) = 1.0 / values(k);
  }
  return eigen.eigenvectors() * inverse.asDiagonal() * eigen.eigenvectors().transpose();
}

Eigen::Vector3d solveSymmetricLeastNorm(const Eigen::Matrix3d& K, const Eigen::Vector3d& rhs) {
  const double a = K(0, 0), b = K(0, 1), c = K(0, 2), d = K(1, 1), e = K(1, 2), f = K(2, 2);
  const double A = d * f - e * e, B = c * e - b * f, C = b * e - c * d;
  const double D = a * f - c * c, E = b * c - a * e, F = a * d - b * b;
  const double det = a * A + b * B + c * C;
  const double trace = a + d + f;
  if (det > kSingularRelative * trace * trace * trace) {
    const double inverse_det = 1.0 / det;
    return inverse_det * Eigen::Vector3d(A * rhs.x() + B * rhs.y() + C * rhs.z(),
                                         B * rhs.x() + D * rhs.y() + E * rhs.z(),
                                         C * rhs.x() + E * rhs.y() + F * rhs.z());
  }
  return symmetricPseudoInverse(K) * rhs;
}

Eigen::Vector2d symmetricEigenvalues(const Eigen::Matrix2d& A) {
  const double mean = 0.5 * A.trace();
  const double half_gap = std::hypot(0.5 * (A(0, 0) - A(1, 1)), A(0, 1));
  return Eigen::Vector2d(mean - half_gap, mean + half_gap);
}

Eigen::Matrix2d symmetricPseudoInverse(const Eigen::Matrix2d& A) {
  const double trace = A(0, 0) + A(1, 1);
  const double det = A(0, 0) * A(1, 1) - A(0, 1) * A(1, 0);
  if (det > kSingularRelative * trace * trace) return A.inverse();
  // Rank one (or zero): A ~ trace v v^T with v the unit eigenvector of the largest eigenvalue,
  // and A^+ = v v^T / trace.
  if (!(trace > 0.0)) return Eigen::Matrix2d::Zero();
  const Eigen::Vector2d column = A(0, 0) >= A(1, 1) ? A.col(0) : A.col(1);
  const Eigen::Vector2d v = column.normalized();
  return (v * v.transpose()) / trace;
}

}  // namespace collision_response::core
