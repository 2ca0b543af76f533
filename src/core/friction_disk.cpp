#include "collision_response/core/friction_disk.h"

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>

#include "collision_response/core/constants.h"
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

FrictionConeBlock prepareFrictionCone(const Eigen::Matrix3d& A, const Eigen::Vector3d& n,
                                      const Eigen::Vector3d& t1, const Eigen::Vector3d& t2,
                                      double mu) {
  FrictionConeBlock block;
  block.delassus = A;
  block.normal = n;
  block.mu = mu;
  block.trace = A.trace();
  if (!(block.trace > 0.0) || mu == 0.0) return block;
  // Local frame (n, t1, t2).
  block.frame << n, t1, t2;
  block.local = block.frame.transpose() * A * block.frame;
  block.local_pseudo_inverse = symmetricPseudoInverse(block.local);
  return block;
}

Eigen::Vector3d solveFrictionCone(const Eigen::Matrix3d& A, const Eigen::Vector3d& b,
                                  const Eigen::Vector3d& n, const Eigen::Vector3d& t1,
                                  const Eigen::Vector3d& t2, double mu) {
  return solveFrictionCone(prepareFrictionCone(A, n, t1, t2, mu), b);
}

Eigen::Vector3d solveFrictionCone(const FrictionConeBlock& block, const Eigen::Vector3d& b) {
  const Eigen::Matrix3d& A = block.delassus;
  const Eigen::Vector3d& n = block.normal;
  const double mu = block.mu;
  const double trace = block.trace;
  if (!(trace > 0.0)) return Eigen::Vector3d::Zero();
  if (mu == 0.0) {
    const double a_nn = n.dot(A * n);
    return a_nn > kSingularRelative * trace ? Eigen::Vector3d(std::max(0.0, -n.dot(b) / a_nn) * n)
                                            : Eigen::Vector3d::Zero();
  }
  const Eigen::Matrix3d& T = block.frame;
  const Eigen::Matrix3d& Al = block.local;
  const Eigen::Vector3d bl = T.transpose() * b;
  // The unconstrained minimizer, if it reaches A x + b = 0 inside the cone.
  const Eigen::Vector3d inside = -(block.local_pseudo_inverse * bl);
  if (inside.x() >= 0.0 && inside.tail<2>().norm() <= mu * inside.x() &&
      (Al * inside + bl).norm() <= 1e-12 * bl.norm()) {
    return T * inside;
  }
  // The surface: x = r d(theta), d = (1, mu cos, mu sin); for each theta the best r is
  // max(0, -c / q) with c = b.d, q = d^T A d, worth -c^2 / (2 q) when c < 0.
  const auto direction = [&](double theta) {
    return Eigen::Vector3d(1.0, mu * std::cos(theta), mu * std::sin(theta));
  };
  const double tiny = kSingularRelative * trace * (1.0 + mu * mu);
  const auto value = [&](double theta) {
    const Eigen::Vector3d d = direction(theta);
    const double c = bl.dot(d), q = d.dot(Al * d);
    return c < 0.0 && q > tiny ? -c * c / (2.0 * q) : 0.0;
  };
  // sign of d(value)/dtheta where c < 0: the sign of 2 c' q - c q'.
  const auto slope = [&](double theta) {
    const Eigen::Vector3d d = direction(theta);
    const Eigen::Vector3d dd(0.0, -mu * std::sin(theta), mu * std::cos(theta));
    const double c = bl.dot(d), q = d.dot(Al * d);
    return 2.0 * bl.dot(dd) * q - c * 2.0 * dd.dot(Al * d);
  };
  constexpr int kSamples = 72;
  constexpr double kStep = 2.0 * kPi / kSamples;
  // The samples' cosines and sines, computed once (the same values as direction(k * kStep)).
  static const std::array<std::array<double, 2>, kSamples> kUnit = [] {
    std::array<std::array<double, 2>, kSamples> unit{};
    for (int k = 0; k < kSamples; ++k) unit[k] = {std::cos(k * kStep), std::sin(k * kStep)};
    return unit;
  }();
  int best = -1;
  double best_value = 0.0;  // the apex
  for (int k = 0; k < kSamples; ++k) {
    const Eigen::Vector3d d(1.0, mu * kUnit[k][0], mu * kUnit[k][1]);
    const double c = bl.dot(d), q = d.dot(Al * d);
    const double v = c < 0.0 && q > tiny ? -c * c / (2.0 * q) : 0.0;
    if (v < best_value) {
      best_value = v;
      best = k;
    }
  }
  if (best < 0) return Eigen::Vector3d::Zero();
  double lo = (best - 1) * kStep, hi = (best + 1) * kStep, theta = best * kStep;
  if (value(lo) < 0.0 && value(hi) < 0.0 && slope(lo) < 0.0 && slope(hi) > 0.0) {
    for (int i = 0; i < 100 && hi - lo > 1e-15; ++i) {
      const double mid = 0.5 * (lo + hi);
      (slope(mid) < 0.0 ? lo : hi) = mid;
    }
    const double refined = 0.5 * (lo + hi);
    if (value(refined) <= best_value) theta = refined;
  }
  const Eigen::Vector3d d = direction(theta);
  const double r = std::max(0.0, -bl.dot(d) / d.dot(Al * d));
  return T * (r * d);
}

}  // namespace collision_response::core
