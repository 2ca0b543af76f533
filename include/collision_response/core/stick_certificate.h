#pragma once

#include <Eigen/Core>
#include <vector>

#include "collision_response/core/contact_problem.h"

namespace collision_response::core {

/// A certificate that a resting problem has no stuck answer (docs/physics.md, "No stuck answer"),
/// computed from the free relative accelerations `free` [m/s^2] (one per problem contact, before
/// any force) and the Delassus blocks of `problem` (ContactProblem::delassusBlock()), without
/// solving. A stuck answer, as the resting all-stick solve accepts it, leaves every loaded contact
/// with |a'| <= tolerance, every unloaded one with a'_n > tolerance or with |a'_n|, |a'_t| <=
/// tolerance; call Z the contacts with |a'| <= sqrt(2) tolerance (the loaded ones among them).
/// The force acts on Z only, and a' = a + W F. True only if each case is impossible:
///   |Z| >= 2: for every pair p of contacts, a'_p - a_p lies in range(W_pp) (range(J_p A J^T) is
///     in range(J_p A J_p^T) for the bodies' positive semi-definite inverse inertia A), so
///     |a'_p| >= the least-squares residual of W_pp x = -a_p, the part of a_p along the
///     eigenvectors of W_pp whose eigenvalues are at most kSingularRelative times its trace
///     (the directions no force moves, e.g. the centripetal accelerations of a body turning on
///     a table); every pair's residual above 2 tolerance rules the case out (a pair without a
///     clear gap in its spectrum, pairResidual() kNotClear, gives no certificate).
///   |Z| = 1, contact k: F = W_kk^-1 (e - a_k) with |e| <= sqrt(2) tolerance (W_kk's condition
///     number below 1e6, otherwise no certificate), so some other contact j has a'_n =
///     n_j.(a_j - W_jk W_kk^-1 a_k) + n_j.W_jk W_kk^-1 e <= tolerance for every such e.
/// Each inequality keeps a rounding allowance of 1e-9 of the terms it compares.
///   Z empty: F = 0, some contact has a_n <= tolerance.
/// Costs one 6x6 eigen-decomposition per pair until a pair is consistent (then false at once).
/// False means "not proven": the stuck answer may or may not exist.
bool noStuckAnswer(const ContactProblem& problem, const std::vector<Eigen::Vector3d>& free,
                   double tolerance);

/// pairResidual()'s answer when W_pp has an eigenvalue between kSingularRelative and 1e-6 of its
/// trace (no clear gap between its null space and its range: no reliable residual).
constexpr double kNotClear = -1.0;

/// The least-squares residual |(I - W_pp W_pp^+) a_p| of contacts i and j (the test in
/// noStuckAnswer(), W_pp^+ dropping eigenvalues at most kSingularRelative times the trace), or
/// kNotClear.
double pairResidual(const ContactProblem& problem, const std::vector<Eigen::Vector3d>& free,
                    std::size_t i, std::size_t j);

}  // namespace collision_response::core
