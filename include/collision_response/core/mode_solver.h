#pragma once

#include <Eigen/Core>

namespace collision_response::core {

/// Largest island the mode solver takes, in frame unknowns: 3 per frictional contact (P_n, P_t1,
/// P_t2), 1 per frictionless one (P_n). 12: four frictional contacts. Its matrices are fixed-size
/// at this bound (on the stack: no heap allocation per solve).
constexpr int kModeSolverMaxUnknowns = 12;

/// A square matrix of at most kModeSolverMaxUnknowns rows, on the stack.
using ModeMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor,
                                 kModeSolverMaxUnknowns, kModeSolverMaxUnknowns>;
using ModeVector =
    Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kModeSolverMaxUnknowns, 1>;

/// What a contact does in a mode of the island (docs/solvers.md, "The exact solver on small
/// islands").
enum class ContactMode : unsigned char {
  kSeparating,  ///< P = 0, u'_n >= target
  kSticking,    ///< u'_n = target, u'_t = 0, P_n >= 0, P_t inside the friction pyramid of mu P_n
  kSliding,     ///< u'_n = target, P_t = mu P_n d_k, P_n >= 0, -u'_t in the pyramid sector of d_k
  /// u'_n = target, P_t = beta_k d_k + beta_(k+1) d_(k+1) on the pyramid's facet between them
  /// (beta_k, beta_(k+1) >= 0, sum mu P_n), -u'_t along the facet's bisector, equally opposed by
  /// both: the slip that friction along d_k would turn one way and along d_(k+1) the other.
  kSlidingFacet,
};

/// One contact of the island as the mode solver sees it, in its frame (n, t1, t2): frame vectors
/// are (normal, t1, t2) components. The friction pyramid is exact_solver.h's: directions
/// d_k = (cos 2 pi k / D, sin 2 pi k / D) in (t1, t2), k = 0..D-1, D = kPyramidDirections.
struct ModeContact {
  // Input.
  bool frictional = false;
  int first = 0;  ///< its first row in the frame Delassus matrix (1 row, or 3 if frictional)
  Eigen::Vector3d u = Eigen::Vector3d::Zero();  ///< pre-impact relative velocity, frame [m/s]
  double target = 0.0;                          ///< target normal velocity [m/s]
  double mu = 0.0;                              ///< friction coefficient of this solve
  // Warm start (input) and answer (output).
  ContactMode mode = ContactMode::kSticking;
  int direction = 0;  ///< k of a sliding contact's friction direction d_k (or facet's first d_k)
  // Output.
  Eigen::Vector3d P = Eigen::Vector3d::Zero();  ///< impulse, frame [N s] (+P on body b)
};

/// The Newton-law pyramid LCP of exact_solver.h for a small island, solved by its modes instead
/// of by pivoting. A is the island's Delassus matrix in the contacts' frames (A = S^T W S,
/// S = blockdiag(n_i, or [n_i t1_i t2_i] for frictional contacts): the frame velocities change by
/// A P). Starting from each contact's `mode` (the warm start), a mode of the island is checked in
/// closed form: the impulses that give the active contacts their targets (sticking: no slip,
/// sliding: friction mu P_n along d_k) are one linear solve (complete-pivoting LU; the least-norm
/// solution if the system is singular, as for redundant contacts, and rejected unless it reaches
/// the targets); then every contact's conditions are checked: P_n >= 0, a sticking contact's P_t
/// inside the pyramid, a sliding contact's slip opposed by d_k (d_k . u'_t <= d_j . u'_t for every
/// j), a separating contact not approaching. A mode that fails is repaired contact by contact (a
/// contact pulling separates, a separating one that approaches becomes active, a sticking one
/// outside its pyramid slides along the pyramid direction nearest its friction, a sliding one whose
/// slip is reversed sticks, one whose slip has turned slides along the direction opposing it, or
/// on the facet between the two when that direction is the neighbour of its own; a facet-sliding
/// one with a negative part slides along the other direction) and checked again, at most
/// `max_modes` modes in all. A mode that fails with nothing to repair (targets missed by a
/// least-squares answer) has its active contact of least P_n separate. After a cycle (a mode seen
/// before) the search goes on repairing one contact per mode (the first the checks change; the
/// weakest one separating instead while a normal target is missed), and stops at its next cycle.
/// Any search that found a mode before these two rules were added finds the same one: they act
/// only where the search used to stop.
///
/// Returns the number of modes checked, positive if the last one is a solution (then every
/// contact's mode, direction and P are the answer: an exact solution of the pyramid LCP, to the
/// round-off `tolerance` relative to `speed` and to the largest impulse), negative (minus the
/// number checked) if none fitted: the caller falls back to Lemke's method (lcp.h).
/// `speed`: the island's velocity scale [m/s] (largest pre-impact |u| and |target|).
int solveByModes(const ModeMatrix& A, ModeContact* contacts, int count, double speed, int max_modes,
                 double tolerance = 1e-10);

/// x with K x = rhs for a square K of at most kModeSolverMaxUnknowns rows, by Gaussian elimination
/// with complete pivoting; if K is singular to round-off (a pivot below rows x machine epsilon of
/// the first, the rank test of Eigen's complete orthogonal decomposition), the least-norm x that
/// solves the consistent part (x = x_b - N (N^T N)^-1 N^T x_b, x_b the basic solution, N the null
/// space from the factors). Whether K x = rhs holds is the caller's to check. K and rhs are
/// overwritten (the factors, L^-1 P rhs).
void solveLeastNorm(ModeMatrix& K, ModeVector& rhs, ModeVector& x);

/// The friction impulse P_t (t1, t2 components) written as sum_k beta_k d_k on the two pyramid
/// directions around it: returns sum_k beta_k (the pyramid's gauge of P_t: P_t lies inside the
/// pyramid of mu P_n iff it is <= mu P_n) and the sector's first direction k, (beta_k,
/// beta_(k+1)) in `beta`.
double pyramidGauge(const Eigen::Vector2d& P_t, int& k, Eigen::Vector2d& beta);

/// The friction impulse P_t (t1, t2 components) written as beta_k d_k + beta_next d_(k+1) on the
/// two pyramid directions of facet k (either part negative if P_t lies outside that sector).
void facetParts(const Eigen::Vector2d& P_t, int k, double& beta_k, double& beta_next);

}  // namespace collision_response::core
