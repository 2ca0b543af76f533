#include "collision_response/core/stick_certificate.h"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>

#include "collision_response/core/least_norm.h"

namespace collision_response::core {
namespace {

// An eigenvalue of a block between kSingularRelative and this fraction of its trace leaves the
// null space and the range too close for the certificate (its eigenvectors' rounding grows as
// eps trace / gap): the pair gives no residual, and no certificate.
constexpr double kClearGap = 1e-6;
// Rounding allowance of the certificate's inequalities, relative to the terms compared (the
// decompositions above keep their rounding within about eps / kClearGap = 2e-10 of them).
constexpr double kRounding = 1e-9;

}  // namespace

double pairResidual(const ContactProblem& problem, const std::vector<Eigen::Vector3d>& free,
                    std::size_t i, std::size_t j) {
  Eigen::Matrix<double, 6, 6> W;
  W.topLeftCorner<3, 3>() = problem.contact(i).delassus;
  W.bottomRightCorner<3, 3>() = problem.contact(j).delassus;
  W.topRightCorner<3, 3>() = problem.delassusBlock(i, j);
  W.bottomLeftCorner<3, 3>() = W.topRightCorner<3, 3>().transpose();
  Eigen::Matrix<double, 6, 1> a;
  a << free[i], free[j];
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eigen(W);
  const double trace = std::max(W.trace(), 0.0);
  const double threshold = kSingularRelative * trace;
  double squared = 0.0;
  for (int k = 0; k < 6; ++k) {
    const double lambda = eigen.eigenvalues()(k);
    // No clear gap between the null space and the range: its split is not reliable.
    if (lambda > threshold && lambda <= kClearGap * trace) return kNotClear;
    if (lambda > threshold) continue;
    squared += std::pow(eigen.eigenvectors().col(k).dot(a), 2);
  }
  return std::sqrt(squared);
}

bool noStuckAnswer(const ContactProblem& problem, const std::vector<Eigen::Vector3d>& free,
                   double tolerance) {
  const std::size_t size = problem.size();
  if (size < 2 || !(tolerance >= 0.0)) return false;
  // Z empty: the free accelerations themselves would have to separate every contact.
  bool separates = true;
  for (std::size_t i = 0; i < size; ++i) {
    separates = separates && problem.contact(i).normal.dot(free[i]) > tolerance;
  }
  if (separates) return false;
  // |Z| >= 2: every pair of contacts inconsistent.
  for (std::size_t i = 0; i < size; ++i) {
    for (std::size_t j = i + 1; j < size; ++j) {
      const double scale = std::hypot(free[i].norm(), free[j].norm());
      if (!(pairResidual(problem, free, i, j) > 2.0 * tolerance + kRounding * scale)) return false;
    }
  }
  // |Z| = 1, contact k: some other contact cannot separate under the force that stops k.
  const double radius = std::sqrt(2.0) * tolerance;  // |e| = |a'_k| at most
  for (std::size_t k = 0; k < size; ++k) {
    const Eigen::Matrix3d& W_kk = problem.contact(k).delassus;
    // Well conditioned only (its inverse's rounding within kRounding of the terms).
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;
    eigen.computeDirect(W_kk);
    if (!(eigen.eigenvalues()(0) > kClearGap * eigen.eigenvalues()(2))) return false;
    const Eigen::Matrix3d inverse = W_kk.inverse();
    const Eigen::Vector3d stop = inverse * free[k];  // -F_k at e = 0
    bool ruled_out = false;
    for (std::size_t j = 0; j < size && !ruled_out; ++j) {
      if (j == k) continue;
      const Eigen::Vector3d& n_j = problem.contact(j).normal;
      const Eigen::Vector3d row = problem.delassusBlock(j, k).transpose() * n_j;  // W_kj n_j
      const double base = n_j.dot(free[j]) - row.dot(stop);
      const double largest = base + radius * (inverse * row).norm();
      ruled_out =
          largest + kRounding * (std::abs(n_j.dot(free[j])) + std::abs(row.dot(stop))) <= tolerance;
    }
    if (!ruled_out) return false;
  }
  return true;
}

}  // namespace collision_response::core
