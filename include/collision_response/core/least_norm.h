#pragma once

#include <Eigen/Core>

namespace collision_response::core {

/// Relative size below which an eigenvalue of a Delassus block (or its determinant, against the
/// cube of its trace) counts as zero: the block is singular, the bodies cannot move along that
/// direction at the contact.
constexpr double kSingularRelative = 1e-12;

/// x = K^+ rhs for a symmetric positive semi-definite 3x3 K (a Delassus block), the least-norm
/// least-squares solution: by the adjugate when det K > kSingularRelative trace(K)^3 (the
/// closed-form path, no decomposition), otherwise by an eigen-decomposition dropping eigenvalues
/// below kSingularRelative times the largest (rare). K = 0 gives x = 0.
Eigen::Vector3d solveSymmetricLeastNorm(const Eigen::Matrix3d& K, const Eigen::Vector3d& rhs);

/// A^+ for a symmetric positive semi-definite 2x2 A: the inverse when det A > kSingularRelative
/// trace(A)^2, otherwise the pseudo-inverse (the rank-one part, or 0).
Eigen::Matrix2d symmetricPseudoInverse(const Eigen::Matrix2d& A);

/// Eigenvalues of a symmetric 2x2 A in closed form, ascending: trace/2 -+ hypot((a00 - a11)/2,
/// a01).
Eigen::Vector2d symmetricEigenvalues(const Eigen::Matrix2d& A);

/// A^+ for a symmetric positive semi-definite 3x3 A (eigen-decomposition, same threshold).
Eigen::Matrix3d symmetricPseudoInverse(const Eigen::Matrix3d& A);

}  // namespace collision_response::core
