// DART (libdart-dev, libdart-utils-urdf-dev) as a peer for the robot benchmark: the arm of
// urdf/arm7.urdf striking the free box of robot_scene.h, one frictional contact.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "robot_scene.h"

namespace collision_response::bench {

/// How DART resolves the contact.
struct DartArmBoxConfig {
  bool pgs = false;   ///< DART's projected Gauss-Seidel boxed LCP; else Dantzig (+ PGS backup)
  double cfm = 1e-5;  ///< ContactConstraint's relative constraint force mixing (DART's default)
  double time_step = 1e-6;  ///< [s]; the velocity jump does not depend on it (no depth, no gravity)
};

/// DART's answer and cost.
struct DartArmBoxRun {
  Eigen::VectorXd joint_velocity_change;  ///< [rad/s, m/s], in the order of the given joint names
  Eigen::Vector3d box_velocity_change;    ///< the box centre's [m/s]
  Eigen::Vector3d hand_origin;            ///< DART's hand frame origin, the contact point [m]
  double normal_velocity_before = 0.0;    ///< u_n at the contact, box less hand [m/s]
  double normal_velocity_after = 0.0;     ///< u_n' [m/s]; Newton's law: -e u_n
  double ns_per_step = 0.0;               ///< median wall time of World::step() [ns]
  std::string note;                       ///< anything the table should say
};

/// Loads the URDF with dart::utils::DartLoader (package://collision_response/ resolved to
/// `package_dir`, fixed base, joint limits not enforced), adds the box (FreeJoint, BoxShape,
/// its mass and inertia) and a world without gravity. The contact is not left to collision
/// detection (DART's would put it elsewhere on the hand's mesh): the world's collision group is
/// emptied and one dart::constraint::ContactConstraint is built at the hand's origin with the
/// scene's normal, depth 0 (no error correction), restitution e (DART multiplies the two sides':
/// hand 1, box e) and friction mu_d (DART takes the smaller side's: both mu_d; DART has one
/// coefficient), then one World::step() is timed, `repetitions` times from the same state (the
/// state and constraint are set again before each, untimed). The velocity change is the step's
/// velocities less those of the same step without the contact, so the step's smooth dynamics
/// (Coriolis over `time_step`) cancel.
DartArmBoxRun runDartArmBox(const std::string& urdf_file, const std::string& package_dir,
                            const std::vector<std::string>& joint_names, const ArmBoxScene& scene,
                            const DartArmBoxConfig& config, int repetitions);

}  // namespace collision_response::bench
