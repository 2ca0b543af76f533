#include "collision_response/core/friction_disk.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

#include "collision_response/core/least_norm.h"

namespace collision_response::core {

Eigen::Vector2d slipDirection(const Eigen::Matrix2d& M, const Eigen::Vector2d& b) {
  const Eigen::Vector2d eigenvalues = symmetricEigenvalues(M);
  const double b_norm = b.norm();
  double lo = std::max(0.0, b_norm - eigenvalues(1));
  double hi = std::max(lo, b_norm - eigenvalues(0));
  auto solve = [&](double lambda) {
    Eigen::Matrix2d L = M;
    L.diagonal().array() += lambda;
    return Eigen::Vector2d(L.inverse() * b);
  };
  double lambda = 0.5 * (lo + hi);
  for (int i = 0; i < 60 && hi - lo > 1e-15 * hi; ++i) {
    Eigen::Matrix2d L = M;
    L.diagonal().array() += lambda;
    const Eigen::Matrix2d Li = L.inverse();
    const Eigen::Vector2d s = Li * b;
    const double norm = s.norm();
    const double phi = 1.0 - 1.0 / norm;  // decreasing in lambda
    if (phi > 0.0)
      lo = lambda;
    else
      hi = lambda;
    const double dphi = -s.dot(Li * s) / (norm * norm * norm);
    double next = dphi < 0.0 ? lambda - phi / dphi : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - lambda) <= 1e-15 * lambda) {
      lambda = next;
      break;
    }
    lambda = next;
  }
  return solve(lambda).normalized();
}

Eigen::Vector2d solveFrictionDisk(const Eigen::Matrix2d& K, const Eigen::Vector2d& u0,
                                  double radius, bool& sticking) {
  const Eigen::Vector2d stick = -(symmetricPseudoInverse(K) * u0);
  sticking = stick.norm() <= radius;
  if (sticking) return stick;
  if (!(radius > 0.0)) return Eigen::Vector2d::Zero();
  const Eigen::Vector2d s = slipDirection(radius * K, u0);
  if (!s.allFinite()) return stick * (radius / stick.norm());  // degenerate: radial projection
  return -radius * s;
}

}  // namespace collision_response::core
