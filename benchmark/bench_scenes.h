// Benchmark scenes with a known answer, shared by the accuracy sweep and its peer adapters.
// Units: SI (kg, m, s, kg m^2, N s); every vector in the scene's common (world) frame.
#pragma once

#include <Eigen/Core>
#include <map>
#include <string>
#include <vector>

#include "collision_response/core/scene.h"
#include "collision_response/core/solver_options.h"

namespace collision_response::bench {

/// Post-impact velocities of every body of one scene instance, in Scene::bodies order.
struct Velocities {
  std::vector<Eigen::Vector3d> linear;   ///< [m/s]
  std::vector<Eigen::Vector3d> angular;  ///< [rad/s]
};

/// One benchmark scene: one or more instances (a random batch has many) and, per impact law, the
/// reference post-impact velocities of each instance.
struct BenchScene {
  std::string name;    ///< e.g. "head_on"
  std::string family;  ///< "closed_form", "random", "many_contacts", "mass_ratio"
  /// How the reference was obtained, e.g. "closed form" or "integrator at 1e-14 (same law)".
  std::string reference;
  /// Static and dynamic friction differ somewhere: a one-coefficient peer cannot express it.
  bool friction_split = false;
  std::vector<core::Scene> instances;
  /// reference_by_law[law][instance] for the laws "newton" (the closed-form single-contact rule:
  /// sliding along the sticking impulse's tangential part), "newton_lcp" (Newton restitution with
  /// friction opposing the final slip: what simultaneous-contact solvers, ours and the peers',
  /// converge to; it differs from "newton" only for 3D sliding), "poisson" and "stronge".
  std::map<std::string, std::vector<Velocities>> reference_by_law;

  std::size_t contactsPerInstance() const { return instances.front().contacts.size(); }
  const std::vector<Velocities>& referenceFor(const std::string& law) const {
    return reference_by_law.at(law);
  }
};

/// Every scene of the sweep: closed forms (head-on spheres, a sphere sliding and one sticking,
/// a cube flat on the ground with 4 contacts), the rod tip on a rough floor (equal and split
/// friction), random off-centre frictional impacts (against a fine reference of the same law),
/// mass ratios 1e3 and 1e6, a chain of 16 spheres (15 contacts), a stack of 4 cubes on the
/// ground (16 frictional contacts), and two symmetric multi-contact landings whose reference is
/// one contact by symmetry: a box on an edge (2 contacts) and a thin plate on its 4 corners.
std::vector<BenchScene> makeScenes();

/// Pre-impact velocities of an instance (the "before" state).
Velocities velocitiesBefore(const core::Scene& scene);

}  // namespace collision_response::bench
