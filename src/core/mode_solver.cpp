// The pyramid LCP of a small island solved by its modes (mode_solver.h).
//
// A mode gives each contact a state: separating (no unknowns), sticking (P_n, or P_n, P_t1, P_t2
// if frictional) or sliding along the pyramid direction d_k (P_n, with P = P_n (n + mu d_k)). Its
// active contacts' conditions (u'_n = target; sticking: u'_t = 0) are a square linear system K x =
// rhs in those unknowns, K built from the columns of the frame Delassus matrix A. It is solved by
// Gaussian elimination with complete pivoting on the stack; a rank-deficient K (redundant
// contacts) gets the least-norm solution of its consistent part, x = x_b - N (N^T N)^-1 N^T x_b
// with x_b the basic solution and N the null space read off the factors.
#include "collision_response/core/mode_solver.h"
#include "collision_response/core/constants.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

#include "collision_response/core/exact_solver.h"

namespace collision_response::core {
namespace {

constexpr int kD = kPyramidDirections;
using collision_response::core::kPi;

// The pyramid's directions d_k and the normals of its facets (between d_k and d_(k+1)), in (t1,
// t2).
struct Pyramid {
  std::array<Eigen::Vector2d, kD> direction;
  std::array<Eigen::Vector2d, kD> facet;
  double facet_distance;  // cos(pi / D): the facets' distance from the origin for unit d_k
  double sector_sine;     // sin(2 pi / D) = d_k x d_(k+1)
  Pyramid() {
    for (int k = 0; k < kD; ++k) {
      const double angle = 2.0 * kPi * k / kD;
      direction[k] = Eigen::Vector2d(std::cos(angle), std::sin(angle));
      facet[k] = Eigen::Vector2d(std::cos(angle + kPi / kD), std::sin(angle + kPi / kD));
    }
    facet_distance = std::cos(kPi / kD);
    sector_sine = std::sin(2.0 * kPi / kD);
  }
};
const Pyramid kPyramid;

int argmax(const Eigen::Vector2d& v, const std::array<Eigen::Vector2d, kD>& table) {
  int best = 0;
  double value = table[0].dot(v);
  for (int k = 1; k < kD; ++k) {
    const double d = table[k].dot(v);
    if (d > value) value = d, best = k;
  }
  return best;
}

}  // namespace

void solveLeastNorm(ModeMatrix& K, ModeVector& rhs, ModeVector& x) {
  const int m = static_cast<int>(K.rows());
  int column_of[kModeSolverMaxUnknowns];
  for (int i = 0; i < m; ++i) column_of[i] = i;
  // Elimination with complete pivoting, in place: K = P^T L U Q^T; rhs becomes L^-1 P rhs.
  int rank = 0;
  double first_pivot = 0.0;
  const double relative = m * std::numeric_limits<double>::epsilon();
  for (; rank < m; ++rank) {
    Eigen::Index r, c;
    const double pivot = K.bottomRightCorner(m - rank, m - rank).cwiseAbs().maxCoeff(&r, &c);
    if (rank == 0) first_pivot = pivot;
    if (!(pivot > relative * first_pivot) || pivot == 0.0) break;
    r += rank, c += rank;
    if (r != rank) K.row(r).swap(K.row(rank)), std::swap(rhs(r), rhs(rank));
    if (c != rank) K.col(c).swap(K.col(rank)), std::swap(column_of[c], column_of[rank]);
    const double inverse = 1.0 / K(rank, rank);
    for (int i = rank + 1; i < m; ++i) {
      const double factor = K(i, rank) * inverse;
      if (factor == 0.0) continue;
      K.row(i).tail(m - rank - 1) -= factor * K.row(rank).tail(m - rank - 1);
      rhs(i) -= factor * rhs(rank);
    }
  }
  // y (x in pivoted column order): the basic solution U11 y1 = c1, y2 = 0.
  ModeVector y = ModeVector::Zero(m);
  for (int i = rank - 1; i >= 0; --i) {
    const double sum = K.row(i).segment(i + 1, rank - i - 1).dot(y.segment(i + 1, rank - i - 1));
    y(i) = (rhs(i) - sum) / K(i, i);
  }
  if (rank < m) {
    // Null space N = [-U11^-1 U12; I]; y -= N (N^T N)^-1 N^T y.
    const int free = m - rank;
    ModeMatrix N = ModeMatrix::Zero(m, free);
    for (int j = 0; j < free; ++j) {
      N(rank + j, j) = 1.0;
      for (int i = rank - 1; i >= 0; --i) {
        const double sum =
            K.row(i).segment(i + 1, rank - i - 1).dot(N.col(j).segment(i + 1, rank - i - 1));
        N(i, j) = -(K(i, rank + j) + sum) / K(i, i);
      }
    }
    const ModeMatrix G = N.transpose() * N;
    const ModeVector g = N.transpose() * y;
    const Eigen::LDLT<ModeMatrix> ldlt(G);
    y -= N * ldlt.solve(g);
  }
  x.resize(m);
  for (int i = 0; i < m; ++i) x(column_of[i]) = y(i);
}

namespace {

std::uint64_t signature(const ModeContact* contacts, int count) {
  std::uint64_t s = 0;
  for (int i = 0; i < count; ++i) {
    const ModeContact& c = contacts[i];
    const std::uint64_t code = c.mode == ContactMode::kSeparating ? 0
                               : c.mode == ContactMode::kSticking ? 1
                               : c.mode == ContactMode::kSliding  ? 2 + c.direction
                                                                  : 2 + kD + c.direction;
    s = (s << 5) | code;
  }
  return s;
}

}  // namespace

void facetParts(const Eigen::Vector2d& P_t, int k, double& beta_k, double& beta_next) {
  const Eigen::Vector2d& a = kPyramid.direction[k];
  const Eigen::Vector2d& b = kPyramid.direction[(k + 1) % kD];
  // P_t = beta_k a + beta_next b: Cramer's rule with a x b = sin(2 pi / D).
  beta_k = (P_t.x() * b.y() - P_t.y() * b.x()) / kPyramid.sector_sine;
  beta_next = (a.x() * P_t.y() - a.y() * P_t.x()) / kPyramid.sector_sine;
}

double pyramidGauge(const Eigen::Vector2d& P_t, int& k, Eigen::Vector2d& beta) {
  k = argmax(P_t, kPyramid.facet);
  const Eigen::Vector2d& a = kPyramid.direction[k];
  const Eigen::Vector2d& b = kPyramid.direction[(k + 1) % kD];
  // P_t = beta_0 a + beta_1 b: Cramer's rule with a x b = sin(2 pi / D).
  beta(0) = (P_t.x() * b.y() - P_t.y() * b.x()) / kPyramid.sector_sine;
  beta(1) = (a.x() * P_t.y() - a.y() * P_t.x()) / kPyramid.sector_sine;
  return beta.sum();
}

int solveByModes(const ModeMatrix& A, ModeContact* contacts, int count, double speed, int max_modes,
                 double tolerance) {
  const double tolerance_v = tolerance * speed;
  static_assert(kModeSolverMaxUnknowns * 5 <= 64 && 2 + 2 * kD <= 32,
                "a mode's signature holds 5 bits per contact");
  std::uint64_t seen[64];
  const int n = static_cast<int>(A.rows());
  max_modes = std::min(max_modes, 64);
  // Repairs: every failing contact at once; after a cycle, one contact per mode (the first one
  // the checks would change, as in Murty's least-index rule), the modes seen counted afresh.
  bool one_at_a_time = false;
  int first_seen = 0;
  ContactMode previous_mode[kModeSolverMaxUnknowns];
  int previous_direction[kModeSolverMaxUnknowns];
  for (int tried = 1; tried <= max_modes; ++tried) {
    const std::uint64_t mode = signature(contacts, count);
    bool cycle = false;
    for (int s = first_seen; s < tried - 1 && !cycle; ++s) cycle = seen[s] == mode;
    if (cycle && one_at_a_time) return -(tried - 1);  // no mode found either way
    if (cycle) one_at_a_time = true, first_seen = tried - 1;
    seen[tried - 1] = mode;
    for (int i = 0; i < count; ++i) {
      previous_mode[i] = contacts[i].mode;
      previous_direction[i] = contacts[i].direction;
    }

    // The equations (rows of K) and unknowns (columns), contact by contact. An unknown is a
    // frame component l of its contact's impulse (sticking), P_n with friction mu P_n along a
    // direction (sliding: P = P_n (n + mu d)), or a tangential part along a direction; an
    // equation is a frame row of its contact or a tangential combination (a facet's).
    enum Kind : unsigned char { kUnit, kSlide, kTangent };
    int owner[kModeSolverMaxUnknowns];  // the contact of equation / unknown r
    Kind unknown[kModeSolverMaxUnknowns], equation[kModeSolverMaxUnknowns];
    int unit_row[kModeSolverMaxUnknowns], unit_column[kModeSolverMaxUnknowns];
    Eigen::Vector2d row_mix[kModeSolverMaxUnknowns], column_dir[kModeSolverMaxUnknowns];
    int m = 0;
    for (int i = 0; i < count; ++i) {
      const ModeContact& c = contacts[i];
      if (c.mode == ContactMode::kSeparating) continue;
      const Eigen::Vector2d& d = kPyramid.direction[c.direction];
      const Eigen::Vector2d& d_next = kPyramid.direction[(c.direction + 1) % kD];
      owner[m] = i;
      equation[m] = kUnit, unit_row[m] = 0;  // u'_n = target
      if (c.mode == ContactMode::kSliding) {
        unknown[m] = kSlide, column_dir[m++] = d;  // P = P_n (n + mu d_k)
      } else if (c.mode == ContactMode::kSlidingFacet) {
        // P = P_n (n + mu d_(k+1)) + beta_k (d_k - d_(k+1)); slip along the facet's bisector:
        // (d_k - d_(k+1)) . u'_t = 0.
        unknown[m] = kSlide, column_dir[m++] = d_next;
        owner[m] = i;
        equation[m] = kTangent, row_mix[m] = d - d_next;
        unknown[m] = kTangent, column_dir[m++] = d - d_next;
      } else {
        unknown[m] = kUnit, unit_column[m++] = 0;
        if (c.frictional) {
          for (int l = 1; l < 3; ++l, ++m) {  // u'_t = 0
            owner[m] = i;
            equation[m] = kUnit, unit_row[m] = l;
            unknown[m] = kUnit, unit_column[m] = l;
          }
        }
      }
    }
    ModeMatrix K(m, m);
    ModeVector rhs(m), x;
    // Column j of K at frame row `row`.
    const auto column = [&](int j, int row) {
      const ModeContact& c = contacts[owner[j]];
      const int f = c.first;
      switch (unknown[j]) {
        case kUnit:
          return A(row, f + unit_column[j]);
        case kSlide:
          return A(row, f) +
                 c.mu * (column_dir[j].x() * A(row, f + 1) + column_dir[j].y() * A(row, f + 2));
        default:
          return column_dir[j].x() * A(row, f + 1) + column_dir[j].y() * A(row, f + 2);
      }
    };
    for (int r = 0; r < m; ++r) {
      const ModeContact& c = contacts[owner[r]];
      if (equation[r] == kUnit) {
        const int l = unit_row[r];
        rhs(r) = (l == 0 ? c.target : 0.0) - c.u(l);
        for (int j = 0; j < m; ++j) K(r, j) = column(j, c.first + l);
      } else {
        rhs(r) = -row_mix[r].dot(c.u.tail<2>());
        for (int j = 0; j < m; ++j) {
          K(r, j) =
              row_mix[r].x() * column(j, c.first + 1) + row_mix[r].y() * column(j, c.first + 2);
        }
      }
    }
    if (m > 0) solveLeastNorm(K, rhs, x);

    // The frame impulses and velocities of the mode.
    ModeVector P = ModeVector::Zero(n);
    double largest = 0.0;
    for (int i = 0; i < count; ++i) contacts[i].P.setZero();
    for (int j = 0; j < m; ++j) {
      ModeContact& c = contacts[owner[j]];
      if (unknown[j] == kUnit) {
        c.P(unit_column[j]) = x(j);
      } else if (unknown[j] == kSlide) {
        c.P += x(j) * Eigen::Vector3d(1.0, c.mu * column_dir[j].x(), c.mu * column_dir[j].y());
      } else {
        c.P.tail<2>() += x(j) * column_dir[j];
      }
    }
    for (int i = 0; i < count; ++i) {
      const ModeContact& c = contacts[i];
      if (c.mode == ContactMode::kSeparating) continue;
      P.segment(c.first, c.frictional ? 3 : 1) = c.P.head(c.frictional ? 3 : 1);
      largest = std::max(largest, std::abs(c.P.x()));
    }
    if (!P.allFinite()) return -tried;
    const ModeVector change = A * P;
    const double tolerance_P = tolerance * largest;

    // Check every contact; repair those that fail.
    bool fits = true;
    int weakest = -1;     // the active contact with the smallest P_n
    bool missed = false;  // an active contact's normal target missed
    for (int i = 0; i < count; ++i) {
      ModeContact& c = contacts[i];
      Eigen::Vector3d u = c.u;
      u.head(c.frictional ? 3 : 1) += change.segment(c.first, c.frictional ? 3 : 1);
      const Eigen::Vector2d u_t =
          c.frictional ? Eigen::Vector2d(u.tail<2>()) : Eigen::Vector2d::Zero();
      if (c.mode == ContactMode::kSeparating) {
        if (u.x() >= c.target - tolerance_v) continue;
        fits = false;
        if (c.frictional && u_t.norm() > tolerance_v) {
          c.mode = ContactMode::kSliding;
          c.direction = argmax(-u_t, kPyramid.direction);
        } else {
          c.mode = ContactMode::kSticking;
        }
        continue;
      }
      // Active: the targets must be reached (a singular K solved in least squares may not; its
      // impulses still guide the repairs below, and an unchanged mode ends the search).
      if (std::abs(u.x() - c.target) > tolerance_v ||
          (c.mode == ContactMode::kSticking && u_t.norm() > tolerance_v)) {
        fits = false;
      }
      if (weakest < 0 || c.P.x() < contacts[weakest].P.x()) weakest = i;
      if (std::abs(u.x() - c.target) > tolerance_v) missed = true;
      if (c.P.x() < -tolerance_P) {
        fits = false;
        c.mode = ContactMode::kSeparating;
        continue;
      }
      if (!c.frictional) continue;
      if (c.mode == ContactMode::kSticking) {
        int k;
        Eigen::Vector2d beta;
        if (pyramidGauge(c.P.tail<2>(), k, beta) <= c.mu * std::max(c.P.x(), 0.0) + tolerance_P)
          continue;
        fits = false;
        c.mode = ContactMode::kSliding;
        c.direction = argmax(c.P.tail<2>(), kPyramid.direction);
        continue;
      }
      const Eigen::Vector2d& d = kPyramid.direction[c.direction];
      const int opposing = argmax(-u_t, kPyramid.direction);
      if (c.mode == ContactMode::kSlidingFacet) {
        // Friction on the facet between d_k and d_(k+1): both parts >= 0, the slip (along the
        // bisector, by the equations) opposed by them.
        const int next = (c.direction + 1) % kD;
        double beta_k, beta_next;
        facetParts(c.P.tail<2>(), c.direction, beta_k, beta_next);
        if (beta_k < -tolerance_P || beta_next < -tolerance_P) {
          fits = false;
          c.mode = ContactMode::kSliding;
          c.direction = beta_k < beta_next ? next : c.direction;
          continue;
        }
        if (d.dot(u_t) <= kPyramid.direction[opposing].dot(u_t) + tolerance_v) continue;
        fits = false;
        if (d.dot(u_t) > 0.0) {
          c.mode = ContactMode::kSticking;
        } else {
          c.mode = ContactMode::kSliding;
          c.direction = opposing;
        }
        continue;
      }
      // Sliding along d_k: the slip must be opposed by d_k, the most opposing direction.
      if (d.dot(u_t) <= kPyramid.direction[opposing].dot(u_t) + tolerance_v) continue;
      fits = false;
      if (d.dot(u_t) > 0.0) {
        c.mode = ContactMode::kSticking;  // friction reversed the slip: too strong to slide
      } else if (opposing == (c.direction + 1) % kD || c.direction == (opposing + 1) % kD) {
        // The slip turned into the neighbouring sector: friction on the facet between them (which
        // direction's friction turns the slip back across the bisector).
        c.mode = ContactMode::kSlidingFacet;
        c.direction = opposing == (c.direction + 1) % kD ? c.direction : opposing;
      } else {
        c.direction = opposing;
      }
    }
    if (!fits) {
      bool repaired = false;
      for (int i = 0; i < count; ++i) {
        ModeContact& c = contacts[i];
        if (c.mode == previous_mode[i] && c.direction == previous_direction[i]) continue;
        if (repaired && one_at_a_time)
          c.mode = previous_mode[i], c.direction = previous_direction[i];
        repaired = true;
      }
      // Nothing to repair (a singular K solved in least squares: redundant contacts whose targets
      // no motion reaches together, as a face's 4 corners with unequal restitutions), or, after a
      // cycle, a normal target missed: the active contact pushing least separates instead (the
      // mode would otherwise repeat, or the friction repairs go round it).
      if ((!repaired || (one_at_a_time && missed)) && weakest >= 0) {
        for (int i = 0; i < count; ++i)
          contacts[i].mode = previous_mode[i], contacts[i].direction = previous_direction[i];
        contacts[weakest].mode = ContactMode::kSeparating;
      }
      continue;
    }
    // A solution: impulses within round-off of the bounds are put on them exactly.
    for (int i = 0; i < count; ++i) {
      ModeContact& c = contacts[i];
      if (c.mode == ContactMode::kSeparating) continue;
      if (c.P.x() < 0.0) c.P.setZero();
      if (c.mode != ContactMode::kSticking || !c.frictional) continue;
      int k;
      Eigen::Vector2d beta;
      const double gauge = pyramidGauge(c.P.tail<2>(), k, beta);
      const double limit = c.mu * c.P.x();
      if (gauge > limit) c.P.tail<2>() *= gauge > 0.0 ? limit / gauge : 0.0;
    }
    return tried;
  }
  return -max_modes;
}

}  // namespace collision_response::core
