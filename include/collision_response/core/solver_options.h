#pragma once

#include <cstddef>
#include <string>

#include "collision_response/core/deadline.h"

namespace collision_response::core {

/// Impact law relating post- to pre-impact velocities at a contact.
enum class ImpactLaw {
  /// Newton restitution u'_n = -e u_n with Coulomb friction, normal and tangential impulses solved
  /// together: the contact sticks if the sticking impulse lies in the static cone |P_t| <= mu_s
  /// P_n,
  /// otherwise it slides with |P_t| = mu_d P_n, and u'_n = -e u_n holds in both cases.
  kNewton,
  /// The textbook two-pass procedure (docs/physics.md, "The textbook two-pass procedure and its
  /// pitfalls"), kept so its error can be measured: the frictionless impulse formula
  /// (docs/physics.md, "The frictionless impulse formula"), then a friction impulse from the
  /// pre-impact tangential velocity (with the effective mass 1/(t^T K t) along the tangent) applied
  /// in a second pass. For off-centre contacts the second pass changes the normal velocity and
  /// breaks u'_n = -e u_n.
  kSeedOnePass,
  /// Poisson (kinetic) restitution: the normal impulse of restitution is e times that of
  /// compression,
  /// P_n = (1 + e) P_c, with Coulomb friction integrated along the impact in impulse space (Routh's
  /// method: slip, stick and slip reversal tracked as they happen).
  kPoisson,
  /// Stronge (energetic) restitution: the work of the normal impulse during restitution is -e^2
  /// times
  /// its work during compression, with friction integrated as for kPoisson. Kinetic energy never
  /// increases and the contact separates.
  kStronge,
};

/// How a group of coupled contacts (an island) is to be solved: the option (what was used is the
/// report's SolvedBy, solve_report.h).
enum class SolverMethod {
  /// Per island: one contact in closed form (Newton) or by impulse-space integration (Poisson,
  /// Stronge); up to kExactSolverMaxContacts (12) contacts the exact solver, falling back to the
  /// iterative one if it finds no solution; more contacts the iterative solver.
  kAuto,
  kIterative,  ///< projected Gauss-Seidel on accumulated impulses, for any number of contacts
  kExact,      ///< pivoting (Lemke) solve of the linear complementarity problem, for few contacts
};

/// How the simultaneous impulse-space integration (simultaneous_impact.h) shares the normal impulse
/// among the contacts active at each instant (docs/physics.md, "Simultaneous impulse-space
/// integration"). Both rules end each contact on its own condition (Poisson impulse, Stronge
/// work); they differ where the simultaneous problem is not unique.
enum class SimultaneousSharing {
  /// Equal linear springs, one per contact (Liu, Zhao and Brogliato's distribution with eta = 1):
  /// rates in the ratios of the springs' compressions in a fictitious time.
  kSpring,
  /// Rates that keep the normal velocities consistent: the compressing contacts take the plastic
  /// complementarity rates that bring their normal velocities to 0 together (friction included,
  /// least norm on redundant contacts), the restituting ones the impulse each still has to deliver
  /// (Poisson: (1 + e) p_c - P_n; Stronge: the same, then the remaining work over u_n). A face
  /// landing flat whose plastic answer does not rotate does not rotate, however its contact
  /// points are sampled.
  kVelocityConsistent,
};

struct SolverOptions {
  ImpactLaw law = ImpactLaw::kStronge;  ///< physically possible by default
  SolverMethod method = SolverMethod::kAuto;
  /// Iterative solver: stop when the largest impulse change of an iteration is at most tolerance
  /// times the largest accumulated impulse (relative, dimensionless).
  double tolerance = 1e-12;
  /// Iterative solver: iteration cap; an island that reaches it is reported as not converged.
  std::size_t max_iterations = 10000;
  /// Impulse-space integration of one contact (kPoisson, kStronge): relative error tolerance on the
  /// impulse. The simultaneous integration of several contacts has no error control and does not
  /// read it (docs/physics.md, "Simultaneous impulse-space integration", "Resolution").
  double integration_tolerance = 1e-10;
  /// kAuto only: Poisson / Stronge islands of 2 to kSimultaneousMaxContacts contacts by the
  /// simultaneous impulse-space integration (simultaneous_impact.h), each contact with its own
  /// phases, slip and stick; an island it cannot finish within its step budget (jammed contacts)
  /// or half of the time budget left is solved again from the start by the two-phase scheme
  /// (reported two_phase_*). Off: the
  /// two-phase scheme for every such island (docs/physics.md, "Several simultaneous contacts").
  /// ROS: ~multi_contact, SolverOptions.multi_contact.
  bool simultaneous_impulse_space = true;
  /// The sharing rule of the simultaneous integration (no unit).
  SimultaneousSharing simultaneous_sharing = SimultaneousSharing::kVelocityConsistent;
  /// A contact with |u_n| at or below this [m/s], in an island where nothing approaches, is
  /// resting: it gets contact forces from the bodies' wrenches instead of an impulse.
  double resting_velocity = 1e-6;
  /// Wall time one computeResponse() may spend solving [s], in (0, 3600]; past it, it throws
  /// SolverTimeout.
  double time_budget = 1.0;
  /// Set by computeResponse() from time_budget; callers of the low-level solvers may set it.
  Deadline deadline;
};

/// Largest request accepted; larger ones are rejected before any work is done.
struct RequestLimits {
  std::size_t max_bodies = 1000;
  std::size_t max_contacts = 10000;
  std::size_t max_shapes = 10000;            ///< collision shapes over all bodies
  std::size_t max_mesh_vertices = 1000000;   ///< mesh vertices over all bodies
  std::size_t max_mesh_triangles = 1000000;  ///< mesh triangles over all bodies
};

const char* toString(ImpactLaw law);
const char* toString(SolverMethod method);
/// Parse the names toString() gives; false if `name` is none of them.
bool fromString(const std::string& name, ImpactLaw& law);
bool fromString(const std::string& name, SolverMethod& method);

}  // namespace collision_response::core
