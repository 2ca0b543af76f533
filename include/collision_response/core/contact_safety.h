#pragma once

#include <Eigen/Core>
#include <vector>

#include "collision_response/core/body_model.h"
#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/contact_point.h"

namespace collision_response::core {

/// One contact's figures for a safety assessment, as ISO/TS 15066's transient contact model states
/// them (docs/robots.md, "Safety outputs"): each side's own mass along the normal, the speed at
/// which the sides approach, and the energy the contact transfers. World frame, SI units.
struct ContactSafety {
  /// Body a's own mass along the normal at the point, 1 / (n^T J_a M_a^-1 J_a^T n) [kg], with J_a
  /// and M_a body a's alone (a robot link: the robot's reflected mass, its free joints with their
  /// armature and its floating base); infinity when body a cannot move the point along n
  /// (immovable, or every unknown locked or orthogonal to n).
  double reflected_mass_a = 0.0;
  double reflected_mass_b = 0.0;  ///< the same for body b [kg]
  /// The relative normal speed before the impact [m/s], >= 0: -u_n when the contact approaches
  /// (u_n = n . (v_b - v_a) < 0), 0 when it separates or slides along.
  double approach_speed = 0.0;
  /// 1 / (1 / m_a + 1 / m_b) [kg]: the other side's mass when one is infinite, infinity when both
  /// are. Two sides on one robot (a self-contact) are coupled through its joints: this sum of
  /// inverses then leaves out the coupling (BodyResponse::effective_masses has it).
  double reduced_mass = 0.0;
  /// 0.5 reduced_mass approach_speed^2 [J]: the kinetic energy of the relative normal motion, the
  /// most a perfectly inelastic contact turns into deformation; infinity when both sides are
  /// immovable and approach (nothing can stop them), 0 when the contact does not approach.
  double transferred_energy = 0.0;
};

/// 1 / (n^T J(p) M^-1 J(p)^T n) of `part` of `body` (-1: the body's own) at world point p along
/// the unit normal n [kg]: the mass the body alone puts up against an impulse along n at p.
/// Infinity when the body has no unknowns or n^T W n (W = J M^-1 J^T) is at round-off of W,
/// 1e-12 of its trace or less: nothing of the body moves the point along n.
double reflectedMass(const BodyModel& body, int part, const Eigen::Vector3d& point,
                     const Eigen::Vector3d& normal);

/// ContactSafety of every contact (indices into `bodies`, as computeBodyResponse() takes them),
/// the approach speed from impulses[i].normal_velocity_before. The masses depend on the bodies'
/// configurations only, so the bodies may already carry their post-impact velocities.
/// `impulses` has one entry per contact.
std::vector<ContactSafety> contactSafety(const std::vector<BodyModel*>& bodies,
                                         const std::vector<ContactPoint>& contacts,
                                         const std::vector<ContactImpulse>& impulses);

}  // namespace collision_response::core
