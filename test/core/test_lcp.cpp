// Lemke's complementary pivoting (core/lcp.h) against LCPs with known solutions: the solution
// checked from its definition (z >= 0, w = M z + q >= 0, z.w = 0), degenerate and singular
// problems, rays, the pivot cap.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <random>

#include "collision_response/core/lcp.h"

namespace cr = collision_response::core;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

// z >= 0, w = M z + q >= 0, z.w = 0, to tol relative to the problem's scale.
void expectLcpSolution(const MatrixXd& M, const VectorXd& q, const VectorXd& z, double tol) {
  const VectorXd w = M * z + q;
  const double scale = std::max({1.0, q.cwiseAbs().maxCoeff(), z.cwiseAbs().maxCoeff()});
  EXPECT_GE(z.minCoeff(), -tol * scale);
  EXPECT_GE(w.minCoeff(), -tol * scale);
  EXPECT_LE(z.cwiseProduct(w).cwiseAbs().maxCoeff(), tol * scale * scale);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Lemke

TEST(Lcp, NonNegativeQGivesZeroWithoutPivoting) {
  const MatrixXd M = MatrixXd::Identity(3, 3);
  const cr::LcpResult r = cr::solveLcp(M, VectorXd::Constant(3, 0.5));
  EXPECT_EQ(r.status, cr::LcpStatus::kSolved);
  EXPECT_EQ(r.pivots, 0u);
  EXPECT_EQ(r.z, VectorXd::Zero(3));
}

TEST(Lcp, PositiveDefiniteKnownSolution) {
  // z2 = 0 guessed: [2 0; 0 2] (z1, z3) = (1, 1) gives z1 = z3 = 1/2, and w2 = 4 + 1/2 + 1/2 = 5.
  MatrixXd M(3, 3);
  M << 2, 1, 0, 1, 2, 1, 0, 1, 2;
  const VectorXd q = (VectorXd(3) << -1, 4, -1).finished();
  const cr::LcpResult r = cr::solveLcp(M, q);
  ASSERT_EQ(r.status, cr::LcpStatus::kSolved);
  EXPECT_NEAR(r.z(0), 0.5, 1e-12);
  EXPECT_NEAR(r.z(1), 0.0, 1e-12);
  EXPECT_NEAR(r.z(2), 0.5, 1e-12);
  EXPECT_NEAR((M * r.z + q)(1), 5.0, 1e-12);
}

TEST(Lcp, AllActivePositiveDefinite) {
  // M z = -q: z = M^-1 (5, 6) = (1/3) [2 -1; -1 2] (5, 6) = (4/3, 7/3).
  MatrixXd M(2, 2);
  M << 2, 1, 1, 2;
  const cr::LcpResult r = cr::solveLcp(M, Eigen::Vector2d(-5, -6));
  ASSERT_EQ(r.status, cr::LcpStatus::kSolved);
  EXPECT_NEAR(r.z(0), 4.0 / 3.0, 1e-12);
  EXPECT_NEAR(r.z(1), 7.0 / 3.0, 1e-12);
}

TEST(Lcp, SkewSymmetricIsCopositivePlus) {
  // w1 = z2 - 1, w2 = 1 - z1: z2 >= 1 > 0 forces w2 = 0, so z1 = 1 > 0 forces w1 = 0: z = (1, 1).
  MatrixXd M(2, 2);
  M << 0, 1, -1, 0;
  const cr::LcpResult r = cr::solveLcp(M, Eigen::Vector2d(-1, 1));
  ASSERT_EQ(r.status, cr::LcpStatus::kSolved);
  EXPECT_NEAR(r.z(0), 1.0, 1e-12);
  EXPECT_NEAR(r.z(1), 1.0, 1e-12);
}

TEST(Lcp, SingularDegenerateProblemDoesNotCycle) {
  // M = 1 1^T (rank 1, four duplicated contacts): every z >= 0 with sum 1 solves it, and every
  // ratio test ties.
  const MatrixXd M = MatrixXd::Ones(4, 4);
  const VectorXd q = VectorXd::Constant(4, -1.0);
  const cr::LcpResult r = cr::solveLcp(M, q);
  ASSERT_EQ(r.status, cr::LcpStatus::kSolved);
  EXPECT_NEAR(r.z.sum(), 1.0, 1e-12);
  expectLcpSolution(M, q, r.z, 1e-12);

  // Rank 2 of size 6 with zeros in q (degenerate basic solutions from the start).
  MatrixXd B(6, 2);
  B << 1, 0, 1, 0, 0, 1, 0, 1, 1, 1, 1, 1;
  const MatrixXd S = B * B.transpose();
  const VectorXd q2 = (VectorXd(6) << -1, -1, 0, 0, -2, -2).finished();
  const cr::LcpResult r2 = cr::solveLcp(S, q2);
  ASSERT_EQ(r2.status, cr::LcpStatus::kSolved);
  expectLcpSolution(S, q2, r2.z, 1e-12);
}

TEST(Lcp, RandomFeasibleSingularPsdProblems) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::uniform_int_distribution<int> coin(0, 2);
  for (int trial = 0; trial < 300; ++trial) {
    const int n = 2 + trial % 12;
    const int rank = 1 + trial % n;
    MatrixXd B(n, rank), K(n, n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < rank; ++j) B(i, j) = uniform(rng);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) K(i, j) = uniform(rng);
    // PSD, possibly non-symmetric (skew part), often with duplicated rows.
    MatrixXd M = B * B.transpose();
    if (trial % 2) M += 0.5 * (K - K.transpose());
    if (trial % 3 == 0) M.row(n - 1) = M.row(0), M.col(n - 1) = M.col(0);
    // A feasible q: a complementary pair (z*, w*) with q = w* - M z*.
    VectorXd z(n), w(n);
    for (int i = 0; i < n; ++i) {
      const int kind = coin(rng);
      z(i) = kind == 0 ? std::abs(uniform(rng)) : 0.0;
      w(i) = kind == 1 ? std::abs(uniform(rng)) : 0.0;
    }
    const VectorXd q = w - M * z;
    const cr::LcpResult r = cr::solveLcp(M, q);
    ASSERT_EQ(r.status, cr::LcpStatus::kSolved) << "trial " << trial;
    expectLcpSolution(M, q, r.z, 1e-9);
  }
}

TEST(Lcp, InfeasibleProblemEndsOnARay) {
  // w1 = z1 - z2 - 1.5 >= 0 and w2 = z2 - z1 + 1 >= 0 cannot both hold (PSD M: a ray proves it).
  MatrixXd M(2, 2);
  M << 1, -1, -1, 1;
  const cr::LcpResult r = cr::solveLcp(M, Eigen::Vector2d(-1.5, 1.0));
  EXPECT_EQ(r.status, cr::LcpStatus::kRayTermination);
  EXPECT_EQ(r.z, VectorXd::Zero(2));
  EXPECT_EQ(cr::solveLcp(MatrixXd::Zero(1, 1), VectorXd::Constant(1, -1.0)).status,
            cr::LcpStatus::kRayTermination);
}

TEST(Lcp, PivotCap) {
  MatrixXd M(3, 3);
  M << 2, 1, 0, 1, 2, 1, 0, 1, 2;
  cr::LcpOptions options;
  options.max_pivots = 1;
  const cr::LcpResult r = cr::solveLcp(M, (VectorXd(3) << -1, 4, -1).finished(), options);
  EXPECT_EQ(r.status, cr::LcpStatus::kPivotCap);
  EXPECT_EQ(r.pivots, 1u);
  EXPECT_STREQ(cr::toString(r.status), "pivot_cap");
}
