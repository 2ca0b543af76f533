#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <utility>
#include <vector>

#include "collision_response/core/body_model.h"
#include "collision_response/core/body_state.h"
#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/problem_contact.h"
#include "collision_response/core/rigid_body.h"

namespace collision_response::core {

/// What the problem's motions and its contacts' answers are (docs/physics.md, "The contact
/// problem").
enum class ProblemLevel {
  /// An impact: relative velocities [m/s] (ProblemContact::free_velocity), impulses [N s].
  kVelocity,
  /// Resting contacts: relative accelerations [m/s^2] (ProblemContact::free_acceleration), contact
  /// forces [N]. The same W maps forces to accelerations as impulses to velocities.
  kAcceleration,
};

/// A body of the problem with velocity unknowns.
struct ProblemBody {
  int index = -1;             ///< in the body list the problem was built from
  Eigen::Index offset = 0;    ///< first of its unknowns in ContactProblem::velocityChanges()
  int unknowns = 0;           ///< n: 6 for a free rigid body, (v [m/s], w [rad/s]) world
  double inverse_mass = 0.0;  ///< free rigid body: 1 / m [1/kg]
  Eigen::Matrix3d inverse_inertia = Eigen::Matrix3d::Zero();  ///< free rigid body: Iw^-1, world
  /// A general body (its Jacobians were taken at build time), nullptr for a free rigid body.
  const BodyModel* model = nullptr;

  bool rigid() const { return model == nullptr; }
};

/// The contact problem of one island, built once and the only thing the solvers read
/// (docs/physics.md, "The contact problem"). For contact i with bodies a, b and Jacobians J_ia,
/// J_ib of their material points at p_i, the contact Jacobian is J_i = J_ib - J_ia and
///   u_i' = u_i + sum_j W_ij P_j,   W_ij = J_i M^-1 J_j^T   (the Delassus operator),
/// W_ij nonzero only when i and j share a body with unknowns. The problem holds, per contact, the
/// free relative motion (velocity for impacts, acceleration for resting contacts, in separately
/// named fields), the target normal velocity, the frame (n, t1, t2), the coefficients and the
/// diagonal block W_ii; the off-diagonal blocks on request (delassusBlock()); and the map from
/// contact impulses to the bodies' velocity unknowns, so that solvers can sweep in body space
/// (O(contacts) per sweep) instead of forming W.
///
/// It also carries the state of a solve: the velocity changes dv of the bodies' unknowns that the
/// impulses applied so far make (applyImpulse()), so that relativeMotion(i) = u_i + J_i dv is the
/// current relative motion, and several solvers can act one after another on one problem (the
/// two-phase scheme). Nothing is written to the bodies until addVelocityChangesTo().
///
/// One builder per problem kind (buildImpact(), buildResting(); the overloads for a list of
/// RigidBody are the same code). Free rigid bodies take a closed-form path inside it (lever arms,
/// 3x3 blocks, fixed-size 3-vectors in a stacked vector of unknowns; no virtual call but the one
/// asRigidBody() per side at build time): the stacked Eigen::VectorXd of unknowns is one
/// allocation per problem, and every per-contact operation on a rigid side is fixed-size. General
/// bodies (BodyModel) store J (3 x n) and M^-1 J^T (n x 3) per contact side, taken once.
class ContactProblem {
 public:
  /// The velocity changes and the accumulated impulses, to restore a problem to an earlier point.
  struct State {
    Eigen::VectorXd velocity_changes;
    std::vector<Eigen::Vector3d> applied_impulses;
  };

  ContactProblem() = default;

  /// The impact problem of the contacts listed in `island` (indices into `contacts`), between
  /// general bodies (body_model.h). A contact between two free rigid bodies (asRigidBody()) takes
  /// the closed form: lever arms, K from 3x3 blocks, no Jacobians stored. Reuses this object's
  /// storage.
  void buildImpact(const std::vector<const BodyModel*>& bodies,
                   const std::vector<ContactPoint>& contacts, const std::vector<int>& island);
  /// The same builder for a list of free rigid bodies (every contact on the closed form).
  void buildImpact(const std::vector<RigidBody>& bodies, const std::vector<ContactPoint>& contacts,
                   const std::vector<int>& island);
  /// The resting problem (ProblemLevel::kAcceleration) of the contacts of `island` with
  /// |u_n| <= resting_velocity [m/s]: free relative accelerations from each side's
  /// BodyModel::partPointFreeAcceleration() (a rigid body's as set by setFreeAcceleration():
  /// a = F / m, alpha = Iw^-1 (tau - w x Iw w), with the centripetal terms; a robot's from its
  /// loads), e = 0, the slip direction of contacts already slipping faster than slip_velocity
  /// [m/s], the slow slip of those slipping slower (ProblemContact::slow_slip). A negative
  /// slip_velocity (the default) is resting_velocity. The episodes pass a normal threshold from
  /// their contact tolerance and a slip threshold of the solver's resting velocity: a slip above
  /// round-off is Coulomb's sliding (docs/physics.md, "Slow slips").
  /// Other contacts are left out (ProblemContact::source says which are in).
  void buildResting(const std::vector<const BodyModel*>& bodies,
                    const std::vector<ContactPoint>& contacts, const std::vector<int>& island,
                    double resting_velocity, double slip_velocity = -1.0);
  /// The same builder for a list of free rigid bodies whose free accelerations come from the
  /// wrenches of `states` (the same order; the bodies are not changed).
  void buildResting(const std::vector<BodyState>& states, const std::vector<RigidBody>& bodies,
                    const std::vector<ContactPoint>& contacts, const std::vector<int>& island,
                    double resting_velocity, double slip_velocity = -1.0);

  /// One contact between two free rigid bodies as a problem entry on its own (local_a, local_b
  /// unset), for the closed forms: K, the frame and u = free_velocity, target -e u_n.
  static ProblemContact rigidImpactContact(const RigidBody& a, const RigidBody& b,
                                           const ContactPoint& contact);

  ProblemLevel level() const { return level_; }
  std::size_t size() const { return contacts_.size(); }
  bool empty() const { return contacts_.empty(); }
  const ProblemContact& contact(std::size_t i) const { return contacts_[i]; }
  /// Resting problems: poses contact i as sliding along the unit tangential `direction`
  /// (ProblemContact::slip_direction: friction -mu_d F_n along it).
  void setSlipDirection(std::size_t i, const Eigen::Vector3d& direction) {
    contacts_[i].slip_direction = direction;
  }
  const std::vector<ProblemContact>& contacts() const { return contacts_; }
  /// The bodies with velocity unknowns, in the order of their first contact.
  const std::vector<ProblemBody>& bodies() const { return bodies_; }
  /// Total number of velocity unknowns.
  Eigen::Index unknowns() const { return velocity_changes_.size(); }

  /// Sets every contact's restitution and target normal velocity to 0 (the plastic problem of the
  /// two-phase scheme's compression and clean-up phases).
  void makePlastic();

  /// The free relative motion of contact i: free_velocity (kVelocity) [m/s] or free_acceleration
  /// (kAcceleration) [m/s^2].
  const Eigen::Vector3d& freeMotion(std::size_t i) const {
    return level_ == ProblemLevel::kVelocity ? contacts_[i].free_velocity
                                             : contacts_[i].free_acceleration;
  }
  /// The normal motion contact i is to end with: target_normal_velocity, or 0 for accelerations.
  double targetNormal(std::size_t i) const {
    return level_ == ProblemLevel::kVelocity ? contacts_[i].target_normal_velocity : 0.0;
  }
  /// Current relative motion of contact i: freeMotion(i) + J_i dv.
  Eigen::Vector3d relativeMotion(std::size_t i) const {
    return freeMotion(i) + motionChange(i, velocity_changes_);
  }
  /// J_i dv for given velocity changes dv of the unknowns.
  Eigen::Vector3d motionChange(std::size_t i, const Eigen::VectorXd& velocity_changes) const {
    if (!general_sides_.empty()) return generalMotionChange(i, velocity_changes);
    // Every body a free rigid body: inline closed form, J = [I3, -[r]x] per side.
    const ProblemContact& c = contacts_[i];
    Eigen::Vector3d change = Eigen::Vector3d::Zero();
    if (c.local_a >= 0) change -= rigidPointChange(c.local_a, c.lever_arm_a, velocity_changes);
    if (c.local_b >= 0) change += rigidPointChange(c.local_b, c.lever_arm_b, velocity_changes);
    return change;
  }
  /// dv += M^-1 J_i^T P for the impulse P (+P on b, -P on a) of contact i.
  void addImpulse(std::size_t i, const Eigen::Vector3d& impulse,
                  Eigen::VectorXd& velocity_changes) const {
    if (!general_sides_.empty()) return generalAddImpulse(i, impulse, velocity_changes);
    const ProblemContact& c = contacts_[i];
    if (c.local_a >= 0) addRigidImpulse(c.local_a, c.lever_arm_a, -impulse, velocity_changes);
    if (c.local_b >= 0) addRigidImpulse(c.local_b, c.lever_arm_b, impulse, velocity_changes);
  }
  /// Applies the impulse P [N s] (force [N] at kAcceleration) at contact i to the problem's state.
  void applyImpulse(std::size_t i, const Eigen::Vector3d& impulse) {
    addImpulse(i, impulse, velocity_changes_);
    applied_impulses_[i] += impulse;
  }
  /// Sum of the impulses applied at contact i so far.
  const Eigen::Vector3d& appliedImpulse(std::size_t i) const { return applied_impulses_[i]; }
  const Eigen::VectorXd& velocityChanges() const { return velocity_changes_; }
  State state() const { return {velocity_changes_, applied_impulses_}; }
  void restore(const State& state) {
    velocity_changes_ = state.velocity_changes;
    applied_impulses_ = state.applied_impulses;
  }
  /// Change of the bodies' kinetic energy from the impulses applied so far [J] (kVelocity):
  /// sum_i P_i . (u_i + u_i') / 2, the energy identity of docs/physics.md, "Energy of an impulse",
  /// summed over the contacts (exact for any W).
  double kineticEnergyChange() const;

  /// W_ij = J_i M^-1 J_j^T [1/kg], computed on request (W_ii is contact(i).delassus).
  Eigen::Matrix3d delassusBlock(std::size_t i, std::size_t j) const;
  /// Pairs (i, j), i < j, of contacts that share a body with unknowns: the nonzero off-diagonal
  /// blocks of W. Built on the first call (quadratic in the contacts per body).
  const std::vector<std::pair<int, int>>& couplings() const;

  /// Adds the velocity changes to the bodies the problem was built from (the same list).
  void addVelocityChangesTo(std::vector<RigidBody>& bodies) const;
  void addVelocityChangesTo(const std::vector<BodyModel*>& bodies) const;
  /// Writes a solver's answer (`solved`, in problem order) into `impulses`, the list of the
  /// contacts the problem was built from, at each contact's source index: normal and friction
  /// impulse and sticking (normal velocities are the caller's).
  void scatterImpulses(const std::vector<ContactImpulse>& solved,
                       std::vector<ContactImpulse>& impulses) const;
  /// The same for the answer of solveRestingIsland() (kAcceleration): resting, normal and
  /// friction force, sticking.
  void scatterForces(const std::vector<ContactImpulse>& solved,
                     std::vector<ContactImpulse>& impulses) const;

 private:
  // J (3 x n) and M^-1 J^T (n x 3) of a general body on one side of a contact.
  struct GeneralSide {
    Eigen::Matrix<double, 3, Eigen::Dynamic> jacobian;
    Eigen::Matrix<double, Eigen::Dynamic, 3> inverse_mass_jacobian_t;
  };
  void clear(ProblemLevel level);
  int addRigidBody(int index, const RigidBody& body, std::vector<int>& local_of);
  int addGeneralBody(int index, const BodyModel& body, std::vector<int>& local_of);
  void finish();
  // The one impact and the one resting builder behind each pair of overloads (body_at(i): body i
  // of the list; contact_problem.cpp).
  template <typename BodyAt>
  void buildImpactOf(std::size_t body_count, const BodyAt& body_at,
                     const std::vector<ContactPoint>& contacts, const std::vector<int>& island);
  template <typename BodyAt, typename RigidFreeAcceleration>
  void buildRestingOf(std::size_t body_count, const BodyAt& body_at,
                      const RigidFreeAcceleration& rigid_free_acceleration,
                      const std::vector<ContactPoint>& contacts, const std::vector<int>& island,
                      double resting_velocity, double slip_velocity);
  // Appends the entry of contact c (`point`) between bodies a and b (rigid_a, rigid_b: their
  // asRigidBody()), not both free rigid bodies:
  // frame, coefficients, u, K (with the cross terms when both sides are parts of one body), the
  // general sides' J and M^-1 J^T, and at kAcceleration the free acceleration. max_contacts: the
  // island's size (general_sides_).
  ProblemContact& addGeneralEntry(const BodyModel& a, const BodyModel& b, const RigidBody* rigid_a,
                                  const RigidBody* rigid_b, int c, const ContactPoint& point,
                                  std::size_t max_contacts);
  // motionChange() and addImpulse() when some body is general (any side kind).
  Eigen::Vector3d generalMotionChange(std::size_t i, const Eigen::VectorXd& velocity_changes) const;
  void generalAddImpulse(std::size_t i, const Eigen::Vector3d& impulse,
                         Eigen::VectorXd& velocity_changes) const;
  // dv_l + dw x r of the rigid problem body `local` (its 6 unknowns (dv_l, dw) at body.offset).
  Eigen::Vector3d rigidPointChange(int local, const Eigen::Vector3d& r,
                                   const Eigen::VectorXd& velocity_changes) const {
    const double* v = velocity_changes.data() + bodies_[local].offset;
    return Eigen::Map<const Eigen::Vector3d>(v) + Eigen::Map<const Eigen::Vector3d>(v + 3).cross(r);
  }
  // The rigid problem body `local` receives the impulse p at lever arm r.
  void addRigidImpulse(int local, const Eigen::Vector3d& r, const Eigen::Vector3d& p,
                       Eigen::VectorXd& velocity_changes) const {
    const ProblemBody& body = bodies_[local];
    double* v = velocity_changes.data() + body.offset;
    Eigen::Map<Eigen::Vector3d>(v) += body.inverse_mass * p;
    Eigen::Map<Eigen::Vector3d>(v + 3) += body.inverse_inertia * r.cross(p);
  }
  // The 3x3 block side `side_i` of contact i gives side `side_j` of contact j through their common
  // body (both sides on that body), without signs.
  Eigen::Matrix3d sideBlock(std::size_t i, int side_i, std::size_t j, int side_j) const;

  ProblemLevel level_ = ProblemLevel::kVelocity;
  std::vector<ProblemBody> bodies_;
  std::vector<ProblemContact> contacts_;
  std::vector<GeneralSide> general_sides_;  // 2 i + side; empty if every body is rigid
  Eigen::VectorXd velocity_changes_;
  std::vector<Eigen::Vector3d> applied_impulses_;
  std::vector<int> local_of_;  // body list index -> bodies_ index, -1 (kept all -1 between builds)
  mutable std::vector<std::pair<int, int>> couplings_;
  mutable bool couplings_built_ = false;
};

/// The rigid-body form of a solver (the solvers' convenience overloads): builds the impact problem
/// of `island` between free rigid bodies, runs `solve(problem, solved)`, applies the velocity
/// changes to `bodies` and writes the impulses into `impulses` at the contacts' indices.
template <typename Solve>
auto solveRigidIsland(std::vector<RigidBody>& bodies, const std::vector<ContactPoint>& contacts,
                      const std::vector<int>& island, std::vector<ContactImpulse>& impulses,
                      Solve solve) {
  ContactProblem problem;
  problem.buildImpact(bodies, contacts, island);
  std::vector<ContactImpulse> solved;
  auto report = solve(problem, solved);
  problem.addVelocityChangesTo(bodies);
  problem.scatterImpulses(solved, impulses);
  report.contacts = island;
  return report;
}

}  // namespace collision_response::core
