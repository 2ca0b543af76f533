// Lemke's complementary pivoting method, tableau form.
//
// The system  w - M z - d z0 = q  (d the covering vector, z0 the artificial variable) is kept as
// the tableau T = B^-1 [I  -M  -d  q] for the current basis B, with columns
//   [0, n)     w      (these columns hold B^-1, used by the lexicographic test)
//   [n, 2n)    z
//   2n         z0
//   2n + 1     rhs    (the values of the basic variables)
// Variable k is w_k for k < n, z_(k-n) for n <= k < 2n, z0 for k = 2n; w_i and z_i are
// complements. Every basic solution visited has x_B = rhs >= 0 and (except z0's pair) w_i z_i = 0.
#include "collision_response/core/lcp.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

namespace collision_response::core {
namespace {

using Eigen::Index;

using Tableau = Eigen::Map<Eigen::MatrixXd>;
using Column = Eigen::Map<Eigen::VectorXd>;
constexpr Index kStackUnknowns = 12;

// The pivot's row reduction, T(:, j) -= pivot_row(j) * column for every column j whose factor is
// not 0 (T column-major, `rows` x `cols`; `column` 0 in the pivot row). Plain loops: the tableaux
// are small, where an Eigen expression per column costs more in set-up than its few entries.
// Element by element (no sum, no fused multiply-add), so that every instruction set gives the same
// numbers: on x86-64 GCC also builds an AVX copy, chosen at load time where the processor has AVX,
// which takes four entries per instruction instead of two.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
__attribute__((target_clones("avx", "default")))
#endif
void reduceColumns(double* __restrict T, Index rows, Index cols, const double* __restrict pivot_row,
                   const double* __restrict column) {
  for (Index j = 0; j < cols; ++j) {
    const double factor = pivot_row[j];
    if (factor == 0.0) continue;
    double* __restrict t = T + j * rows;
    for (Index i = 0; i < rows; ++i) t[i] -= factor * column[i];
  }
}

// Keeps, among `rows`, those whose ratio T(i, column) / a(i) is smallest, up to the relative
// tolerance (scale: the largest |ratio| among them).
void keepMinimumRatios(const Tableau& T, Index column, const Column& a, double tolerance,
                       std::vector<Index>& rows) {
  // Ties are judged against the size of the minimum and of the column's entries, never against the
  // largest ratio (a tiny a_i makes that huge and would let a clearly larger ratio tie).
  double minimum = INFINITY;
  double column_scale = 0.0;
  double a_scale = 0.0;
  for (Index i : rows) {
    minimum = std::min(minimum, T(i, column) / a(i));
    column_scale = std::max(column_scale, std::abs(T(i, column)));
    a_scale = std::max(a_scale, a(i));
  }
  const double limit = minimum + tolerance * (std::abs(minimum) + column_scale / a_scale);
  rows.erase(std::remove_if(rows.begin(), rows.end(),
                            [&](Index i) { return T(i, column) / a(i) > limit; }),
             rows.end());
}

// Leaving row for the entering column a: the lexicographic minimum of [rhs_i, (B^-1)_i] / a_i
// over the rows with a_i > 0, z0's row first if it ties on rhs. -1 if no row bounds the step.
Index lexicographicMinimumRatio(const Tableau& T, const Column& a, const std::vector<Index>& basis,
                                double tolerance, std::vector<Index>& rows) {
  const Index n = T.rows();
  const Index rhs = 2 * n + 1;
  const Index z0 = 2 * n;
  // Entries at round-off level relative to the column's largest |entry| are zeros.
  const double threshold = tolerance * a.cwiseAbs().maxCoeff();
  rows.clear();
  for (Index i = 0; i < n; ++i) {
    if (a(i) > threshold) rows.push_back(i);
  }
  if (rows.empty()) return -1;
  keepMinimumRatios(T, rhs, a, tolerance, rows);
  for (Index i : rows) {
    if (basis[i] == z0) return i;
  }
  for (Index column = 0; column < n && rows.size() > 1; ++column) {
    keepMinimumRatios(T, column, a, tolerance, rows);
  }
  return rows.front();
}

}  // namespace

LcpResult solveLcp(const Eigen::MatrixXd& M, const Eigen::VectorXd& q, const LcpOptions& options) {
  const Index n = q.size();
  LcpResult result;
  result.z = Eigen::VectorXd::Zero(n);
  if (n == 0 || q.minCoeff() >= 0.0) return result;

  const Index z0 = 2 * n;
  const Index rhs = 2 * n + 1;
  const std::size_t max_pivots =
      options.max_pivots > 0 ? options.max_pivots : 50 * static_cast<std::size_t>(n + 1);

  // The tableau and the pivoting's column and row: on the stack for up to kStackUnknowns
  // unknowns (the simultaneous integration's compressing contacts call this at most steps), on
  // the heap beyond.
  const Index cols = 2 * n + 2;
  double stack_tableau[kStackUnknowns * (2 * kStackUnknowns + 2)];
  double stack_vectors[kStackUnknowns + 2 * kStackUnknowns + 2];
  Eigen::VectorXd heap;
  double* tableau = stack_tableau;
  double* vectors = stack_vectors;
  if (n > kStackUnknowns) {
    heap.resize(n * cols + n + cols);
    tableau = heap.data();
    vectors = tableau + n * cols;
  }
  Tableau T(tableau, n, cols);
  T.leftCols(n).setIdentity();
  T.middleCols(n, n) = -M;
  T.col(z0).setConstant(-1.0);  // -d
  T.col(rhs) = q;
  std::vector<Index> basis(n);
  std::iota(basis.begin(), basis.end(), Index{0});

  Column column(vectors, n);
  Eigen::Map<Eigen::RowVectorXd> pivot_row(vectors + n, cols);
  std::vector<Index> rows;
  rows.reserve(n);

  // Exchanges basis[r] for `entering`; returns the variable that left.
  auto pivot = [&](Index r, Index entering) {
    column = T.col(entering);
    pivot_row = T.row(r) / column(r);
    column(r) = 0.0;
    // Row-reduce; the columns of the other basic variables (0 in row r) do not change.
    reduceColumns(T.data(), n, T.cols(), pivot_row.data(), column.data());
    T.row(r) = pivot_row;
    T.col(entering).setZero();
    T(r, entering) = 1.0;
    const Index leaving = basis[r];
    basis[r] = entering;
    ++result.pivots;
    return leaving;
  };

  // z0 enters at the smallest z0 making w = q + d z0 >= 0: the lexicographic minimum of
  // [q_i, e_i] / d_i (the most negative q_i), which leaves every row lexicographically positive.
  column.setOnes();
  const Index z0_row = lexicographicMinimumRatio(T, column, basis, options.tolerance, rows);
  Index leaving = pivot(z0_row, z0);

  // Every basic solution on the path solves w = M z + q + d z0 with w_i z_i = 0, so the path can
  // also stop once z0 is at round-off level (degenerate steps with z0 = 0 could otherwise run on
  // into a spurious ray).
  const double z0_zero = options.tolerance * q.cwiseAbs().maxCoeff();
  Index z0_at = z0_row;  // the row z0 is basic in, while it is
  for (;;) {
    if (leaving == z0 || T(z0_at, rhs) <= z0_zero) break;
    if (result.pivots % 16 == 0) options.deadline.check("the exact (Lemke) solver");
    if (result.pivots >= max_pivots) {
      result.status = LcpStatus::kPivotCap;
      return result;
    }
    const Index entering = leaving < n ? leaving + n : leaving - n;  // the complement
    column = T.col(entering);
    const Index r = lexicographicMinimumRatio(T, column, basis, options.tolerance, rows);
    if (r < 0) {
      result.status = LcpStatus::kRayTermination;
      return result;
    }
    leaving = pivot(r, entering);
    if (r == z0_at) z0_at = -1;
    for (Index i = 0; z0_at < 0 && i < n; ++i) {
      if (basis[i] == z0) z0_at = i;
    }
    if (z0_at < 0) break;  // z0 left the basis: z0 = 0
  }

  for (Index i = 0; i < n; ++i) {
    if (basis[i] >= n && basis[i] < 2 * n) result.z(basis[i] - n) = std::max(T(i, rhs), 0.0);
  }
  // Trust the answer, not the path: z >= 0, w = M z + q >= 0 and z.w = 0 to round-off.
  const Eigen::VectorXd w = M * result.z + q;
  const double scale = std::max(q.cwiseAbs().maxCoeff(), (M * result.z).cwiseAbs().maxCoeff());
  const double slack = std::sqrt(options.tolerance) * scale;
  const bool feasible = w.minCoeff() >= -slack;
  const bool complementary = (result.z.cwiseProduct(w)).cwiseAbs().maxCoeff() <=
                             slack * std::max(result.z.cwiseAbs().maxCoeff(), 1e-300);
  if (!feasible || !complementary) {
    result.status = LcpStatus::kInaccurate;
    result.z.setZero();
    return result;
  }
  result.status = LcpStatus::kSolved;
  return result;
}

const char* toString(LcpStatus status) {
  switch (status) {
    case LcpStatus::kSolved:
      return "solved";
    case LcpStatus::kRayTermination:
      return "ray_termination";
    case LcpStatus::kPivotCap:
      return "pivot_cap";
    case LcpStatus::kInaccurate:
      return "inaccurate";
  }
  return "unknown";
}

}  // namespace collision_response::core
