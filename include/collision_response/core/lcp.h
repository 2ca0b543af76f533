#pragma once

#include <Eigen/Core>

#include <cstddef>
#include "collision_response/core/deadline.h"

namespace collision_response::core {

/// How solveLcp() ended.
enum class LcpStatus {
  kSolved,          ///< z solves the LCP (to round-off)
  kRayTermination,  ///< Lemke's path left on an unbounded ray: no solution found
  kPivotCap,        ///< the pivot cap was reached first
  kInaccurate,      ///< the path ended but its z fails the check w = M z + q >= 0, z.w = 0
};

struct LcpOptions {
  /// Largest number of pivots; 0 means 50 (n + 1).
  std::size_t max_pivots = 0;
  /// Relative tolerance (dimensionless): a tableau entry below tolerance x the largest entry of
  /// its column is not a pivot candidate, and ratios within tolerance x their scale are ties.
  double tolerance = 1e-12;
  /// Checked every few pivots; throws SolverTimeout once expired.
  Deadline deadline;
};

struct LcpResult {
  LcpStatus status = LcpStatus::kSolved;
  std::size_t pivots = 0;
  Eigen::VectorXd z;  ///< the solution if kSolved, otherwise zero
};

/// Solves the linear complementarity problem LCP(q, M): find z with
///   z >= 0,  w = M z + q >= 0,  z^T w = 0,
/// for a dense square M, by Lemke's complementary pivoting method with the covering vector
/// d = (1, ..., 1) and a lexicographic minimum-ratio test (rows of [B^-1 q, B^-1] compared in
/// order), so that degenerate problems (ties in the ratio test, e.g. a singular positive
/// semi-definite M from redundant contacts) cannot cycle. The path stops when z0 leaves the basis
/// (preferred among tied leaving rows) or falls to tolerance x max|q|: then |w - (M z + q)| is at
/// most that, and z^T w = 0 exactly.
///
/// Guarantees (Cottle, Pang and Stone, The Linear Complementarity Problem, 1992, sec. 4.4): the
/// method always terminates. If M is copositive-plus (this includes every positive semi-definite
/// M, symmetric or not), ray termination happens only when the LCP has no solution. For other M
/// (e.g. copositive only) it may end on a ray although a solution exists; the status says so.
/// If q >= 0 the answer is z = 0 with no pivot.
///
/// Cost: one n x (2n + 2) tableau, O(n^2) per pivot, no allocation per pivot.
LcpResult solveLcp(const Eigen::MatrixXd& M, const Eigen::VectorXd& q,
                   const LcpOptions& options = LcpOptions());

const char* toString(LcpStatus status);

}  // namespace collision_response::core
