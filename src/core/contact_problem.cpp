#include "collision_response/core/contact_problem.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "collision_response/core/contact_space.h"

namespace collision_response::core {
namespace {

constexpr double kSideSign[2] = {-1.0, 1.0};  // body a receives -P, body b +P

// Sets the frame, coefficients and index fields of a problem entry (in place: entries are large).
void setEntry(int source, const ContactPoint& contact, ProblemContact& out) {
  out.source = source;
  out.body_a = contact.body_a;
  out.body_b = contact.body_b;
  out.normal = contact.normal;
  tangentBasis(out.normal, out.tangent1, out.tangent2);
  out.restitution = contact.restitution;
  out.static_friction = contact.static_friction;
  out.dynamic_friction = contact.dynamic_friction;
}

// The fields of a resting entry (its acceleration and Jacobians aside) for the relative velocity
// u [m/s] at the contact: e = 0, no velocity, the direction of a slip faster than slip_velocity,
// the slow slip of one within it.
void setRestingFields(const Eigen::Vector3d& u, double slip_velocity, ProblemContact& entry) {
  entry.restitution = 0.0;
  entry.free_velocity.setZero();
  entry.target_normal_velocity = 0.0;
  const Eigen::Vector3d u_t = u - u.dot(entry.normal) * entry.normal;
  if (entry.frictionless()) return;
  if (u_t.norm() > slip_velocity) {
    entry.slip_direction = u_t.normalized();
  } else {
    entry.slow_slip = u_t;
  }
}

void setTarget(ProblemContact& c) {
  const double u_n = c.free_velocity.dot(c.normal);
  c.target_normal_velocity = u_n < 0.0 ? -c.restitution * u_n : 0.0;
}

// Sets every impact field of `out` for a contact between two free rigid bodies: frame,
// coefficients, lever arms r = p - c [m], K [1/kg], u [m/s] and the target normal velocity.
void setRigidImpact(const RigidBody& a, const RigidBody& b, const ContactPoint& contact,
                    ProblemContact& out) {
  setEntry(-1, contact, out);
  const ContactSpace space(a, b, contact.point);
  out.lever_arm_a = space.r_a;
  out.lever_arm_b = space.r_b;
  out.delassus = space.K;
  out.free_velocity = space.relativeVelocity(a, b);
  setTarget(out);
}

}  // namespace

void ContactProblem::clear(ProblemLevel level) {
  level_ = level;
  // finish() resets these; a build that threw before it (a general body refusing its Jacobian)
  // left them set, and a reused problem must not see them.
  for (const ProblemBody& body : bodies_) local_of_[body.index] = -1;
  bodies_.clear();
  contacts_.clear();
  general_sides_.clear();
  applied_impulses_.clear();
  couplings_.clear();
  couplings_built_ = false;
}

int ContactProblem::addRigidBody(int index, const RigidBody& body, std::vector<int>& local_of) {
  if (!body.movable()) return -1;
  if (local_of[index] >= 0) return local_of[index];
  local_of[index] = static_cast<int>(bodies_.size());
  ProblemBody& out = bodies_.emplace_back();
  out.index = index;
  out.unknowns = 6;
  out.inverse_mass = body.inverse_mass;
  out.inverse_inertia = body.inverse_inertia;
  return local_of[index];
}

int ContactProblem::addGeneralBody(int index, const BodyModel& body, std::vector<int>& local_of) {
  if (body.velocityCount() == 0) return -1;
  if (local_of[index] >= 0) return local_of[index];
  local_of[index] = static_cast<int>(bodies_.size());
  ProblemBody& out = bodies_.emplace_back();
  out.index = index;
  out.unknowns = body.velocityCount();
  out.model = &body;
  return local_of[index];
}

void ContactProblem::finish() {
  Eigen::Index offset = 0;
  for (ProblemBody& body : bodies_) {
    local_of_[body.index] = -1;  // ready for the next build
    body.offset = offset;
    offset += body.unknowns;
  }
  velocity_changes_.setZero(offset);
  applied_impulses_.assign(contacts_.size(), Eigen::Vector3d::Zero());
}

ProblemContact ContactProblem::rigidImpactContact(const RigidBody& a, const RigidBody& b,
                                                  const ContactPoint& contact) {
  ProblemContact out;
  setRigidImpact(a, b, contact, out);
  return out;
}

// The one impact builder: `body_at(i)` gives body i of the list (a RigidBody for the rigid list:
// its asRigidBody() is then resolved at compile time). A contact between two free rigid bodies
// takes the closed form (ContactSpace: lever arms, K from 3x3 blocks), any other the general entry.
template <typename BodyAt>
void ContactProblem::buildImpactOf(std::size_t body_count, const BodyAt& body_at,
                                   const std::vector<ContactPoint>& contacts,
                                   const std::vector<int>& island) {
  clear(ProblemLevel::kVelocity);
  contacts_.reserve(island.size());
  if (local_of_.size() < body_count) local_of_.resize(body_count, -1);
  for (const int c : island) {
    const ContactPoint& point = contacts[c];
    const auto& a = body_at(point.body_a);
    const auto& b = body_at(point.body_b);
    const RigidBody* rigid_a = a.asRigidBody();
    const RigidBody* rigid_b = b.asRigidBody();
    if (rigid_a != nullptr && rigid_b != nullptr) {
      ProblemContact& entry = contacts_.emplace_back();
      setRigidImpact(*rigid_a, *rigid_b, point, entry);
      entry.source = c;
      entry.local_a = addRigidBody(point.body_a, *rigid_a, local_of_);
      entry.local_b = addRigidBody(point.body_b, *rigid_b, local_of_);
    } else {
      setTarget(addGeneralEntry(a, b, rigid_a, rigid_b, c, point, island.size()));
    }
  }
  finish();
}

void ContactProblem::buildImpact(const std::vector<RigidBody>& bodies,
                                 const std::vector<ContactPoint>& contacts,
                                 const std::vector<int>& island) {
  buildImpactOf(
      bodies.size(), [&](int i) -> const RigidBody& { return bodies[i]; }, contacts, island);
}

void ContactProblem::buildImpact(const std::vector<const BodyModel*>& bodies,
                                 const std::vector<ContactPoint>& contacts,
                                 const std::vector<int>& island) {
  buildImpactOf(
      bodies.size(), [&](int i) -> const BodyModel& { return *bodies[i]; }, contacts, island);
}

ProblemContact& ContactProblem::addGeneralEntry(const BodyModel& body_a, const BodyModel& body_b,
                                                const RigidBody* rigid_a, const RigidBody* rigid_b,
                                                int c, const ContactPoint& point,
                                                std::size_t max_contacts) {
  const std::size_t row = contacts_.size();
  ProblemContact& entry = contacts_.emplace_back();
  setEntry(c, point, entry);
  const BodyModel* side_body[2] = {&body_a, &body_b};
  const RigidBody* side_rigid[2] = {rigid_a, rigid_b};
  const int index[2] = {point.body_a, point.body_b};
  const int part[2] = {point.part_a, point.part_b};
  int* local[2] = {&entry.local_a, &entry.local_b};
  Eigen::Vector3d* lever_arm[2] = {&entry.lever_arm_a, &entry.lever_arm_b};
  const bool resting = level_ == ProblemLevel::kAcceleration;
  for (int side = 0; side < 2; ++side) {
    const BodyModel& body = *side_body[side];
    entry.free_velocity += kSideSign[side] * body.partPointVelocity(part[side], point.point);
    if (resting) {
      entry.free_acceleration +=
          kSideSign[side] * body.partPointFreeAcceleration(part[side], point.point);
    }
    if (const RigidBody* rigid = side_rigid[side]) {
      *lever_arm[side] = point.point - rigid->com;
      entry.delassus += rigidContactBlock(*rigid, *lever_arm[side]);
      *local[side] = addRigidBody(index[side], *rigid, local_of_);
      continue;
    }
    *local[side] = addGeneralBody(index[side], body, local_of_);
    if (*local[side] < 0) continue;
    if (general_sides_.empty()) general_sides_.resize(2 * max_contacts);
    GeneralSide& out = general_sides_[2 * row + side];
    out.jacobian = body.partPointJacobian(part[side], point.point);
    out.inverse_mass_jacobian_t = body.partInverseMassJacobianTranspose(part[side], point.point);
    entry.delassus += out.jacobian * out.inverse_mass_jacobian_t;
  }
  // Both sides on one general body (two links of one robot): u = (J_b - J_a) v, so W also has
  // the cross terms -(J_a M^-1 J_b^T + J_b M^-1 J_a^T).
  if (entry.local_a >= 0 && entry.local_a == entry.local_b && !bodies_[entry.local_a].rigid()) {
    const GeneralSide& a = general_sides_[2 * row];
    const GeneralSide& b = general_sides_[2 * row + 1];
    entry.delassus -=
        a.jacobian * b.inverse_mass_jacobian_t + b.jacobian * a.inverse_mass_jacobian_t;
  }
  // Symmetric in exact arithmetic; make it so (a general body's products may round apart).
  entry.delassus = 0.5 * (entry.delassus + entry.delassus.transpose()).eval();
  return entry;
}

// The one resting builder, as buildImpactOf(): `rigid_free_acceleration(i, body, r)` gives the free
// acceleration [m/s^2] of the material point at lever arm r of the free rigid body i.
template <typename BodyAt, typename RigidFreeAcceleration>
void ContactProblem::buildRestingOf(std::size_t body_count, const BodyAt& body_at,
                                    const RigidFreeAcceleration& rigid_free_acceleration,
                                    const std::vector<ContactPoint>& contacts,
                                    const std::vector<int>& island, double resting_velocity,
                                    double slip_velocity) {
  clear(ProblemLevel::kAcceleration);
  if (slip_velocity < 0.0) slip_velocity = resting_velocity;
  if (local_of_.size() < body_count) local_of_.resize(body_count, -1);
  for (const int c : island) {
    const ContactPoint& point = contacts[c];
    const auto& a = body_at(point.body_a);
    const auto& b = body_at(point.body_b);
    const RigidBody* rigid_a = a.asRigidBody();
    const RigidBody* rigid_b = b.asRigidBody();
    if (rigid_a != nullptr && rigid_b != nullptr) {
      const ContactSpace space(*rigid_a, *rigid_b, point.point);
      const Eigen::Vector3d u = space.relativeVelocity(*rigid_a, *rigid_b);
      if (std::abs(u.dot(point.normal)) > resting_velocity) continue;
      ProblemContact& entry = contacts_.emplace_back();
      setEntry(c, point, entry);
      setRestingFields(u, slip_velocity, entry);
      entry.lever_arm_a = space.r_a;
      entry.lever_arm_b = space.r_b;
      entry.delassus = space.K;
      entry.free_acceleration = rigid_free_acceleration(point.body_b, *rigid_b, space.r_b) -
                                rigid_free_acceleration(point.body_a, *rigid_a, space.r_a);
      entry.local_a = addRigidBody(point.body_a, *rigid_a, local_of_);
      entry.local_b = addRigidBody(point.body_b, *rigid_b, local_of_);
      continue;
    }
    const Eigen::Vector3d u = b.partPointVelocity(point.part_b, point.point) -
                              a.partPointVelocity(point.part_a, point.point);
    if (std::abs(u.dot(point.normal)) > resting_velocity) continue;
    setRestingFields(u, slip_velocity,
                     addGeneralEntry(a, b, rigid_a, rigid_b, c, point, island.size()));
  }
  finish();
}

void ContactProblem::buildResting(const std::vector<BodyState>& states,
                                  const std::vector<RigidBody>& bodies,
                                  const std::vector<ContactPoint>& contacts,
                                  const std::vector<int>& island, double resting_velocity,
                                  double slip_velocity) {
  // The bodies' free accelerations from their states' wrenches, on copies.
  const auto free_acceleration = [&](int i, const RigidBody& body, const Eigen::Vector3d& r) {
    RigidBody accelerated = body;
    setFreeAcceleration(states[i], accelerated);
    return accelerated.pointFreeAcceleration(r);
  };
  buildRestingOf(
      bodies.size(), [&](int i) -> const RigidBody& { return bodies[i]; }, free_acceleration,
      contacts, island, resting_velocity, slip_velocity);
}

void ContactProblem::buildResting(const std::vector<const BodyModel*>& bodies,
                                  const std::vector<ContactPoint>& contacts,
                                  const std::vector<int>& island, double resting_velocity,
                                  double slip_velocity) {
  const auto free_acceleration = [](int, const RigidBody& body, const Eigen::Vector3d& r) {
    return body.pointFreeAcceleration(r);
  };
  buildRestingOf(
      bodies.size(), [&](int i) -> const BodyModel& { return *bodies[i]; }, free_acceleration,
      contacts, island, resting_velocity, slip_velocity);
}

void ContactProblem::makePlastic() {
  for (ProblemContact& c : contacts_) {
    c.restitution = 0.0;
    c.target_normal_velocity = 0.0;
  }
}

Eigen::Vector3d ContactProblem::generalMotionChange(std::size_t i,
                                                    const Eigen::VectorXd& velocity_changes) const {
  const ProblemContact& c = contacts_[i];
  Eigen::Vector3d change = Eigen::Vector3d::Zero();
  const int local[2] = {c.local_a, c.local_b};
  const Eigen::Vector3d* lever_arm[2] = {&c.lever_arm_a, &c.lever_arm_b};
  for (int side = 0; side < 2; ++side) {
    if (local[side] < 0) continue;
    const ProblemBody& body = bodies_[local[side]];
    Eigen::Vector3d point_change;
    if (body.rigid()) {
      point_change = velocity_changes.segment<3>(body.offset) +
                     velocity_changes.segment<3>(body.offset + 3).cross(*lever_arm[side]);
    } else {
      point_change = general_sides_[2 * i + side].jacobian *
                     velocity_changes.segment(body.offset, body.unknowns);
    }
    if (side == 0) {
      change -= point_change;
    } else {
      change += point_change;
    }
  }
  return change;
}

void ContactProblem::generalAddImpulse(std::size_t i, const Eigen::Vector3d& impulse,
                                       Eigen::VectorXd& velocity_changes) const {
  const ProblemContact& c = contacts_[i];
  const int local[2] = {c.local_a, c.local_b};
  const Eigen::Vector3d* lever_arm[2] = {&c.lever_arm_a, &c.lever_arm_b};
  for (int side = 0; side < 2; ++side) {
    if (local[side] < 0) continue;
    const ProblemBody& body = bodies_[local[side]];
    const Eigen::Vector3d p = side == 0 ? Eigen::Vector3d(-impulse) : impulse;
    if (body.rigid()) {
      velocity_changes.segment<3>(body.offset) += body.inverse_mass * p;
      velocity_changes.segment<3>(body.offset + 3) +=
          body.inverse_inertia * lever_arm[side]->cross(p);
    } else {
      // noalias(): no temporary on the heap (the product's three terms summed, then added, as
      // before).
      velocity_changes.segment(body.offset, body.unknowns).noalias() +=
          general_sides_[2 * i + side].inverse_mass_jacobian_t * p;
    }
  }
}

double ContactProblem::kineticEnergyChange() const {
  double change = 0.0;
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    if (applied_impulses_[i].isZero(0.0)) continue;
    change += 0.5 * applied_impulses_[i].dot(freeMotion(i) + relativeMotion(i));
  }
  return change;
}

Eigen::Matrix3d ContactProblem::sideBlock(std::size_t i, int side_i, std::size_t j,
                                          int side_j) const {
  const ProblemContact& ci = contacts_[i];
  const ProblemContact& cj = contacts_[j];
  const ProblemBody& body = bodies_[side_i == 0 ? ci.local_a : ci.local_b];
  if (body.rigid()) {
    // Point velocity change at r_i per unit impulse at r_j: I3 / m - [r_i]x Iw^-1 [r_j]x.
    const Eigen::Vector3d& r_i = side_i == 0 ? ci.lever_arm_a : ci.lever_arm_b;
    const Eigen::Vector3d& r_j = side_j == 0 ? cj.lever_arm_a : cj.lever_arm_b;
    Eigen::Matrix3d block = -skew(r_i) * body.inverse_inertia * skew(r_j);
    block.diagonal().array() += body.inverse_mass;
    return block;
  }
  return general_sides_[2 * i + side_i].jacobian *
         general_sides_[2 * j + side_j].inverse_mass_jacobian_t;
}

Eigen::Matrix3d ContactProblem::delassusBlock(std::size_t i, std::size_t j) const {
  if (i == j) return contacts_[i].delassus;
  Eigen::Matrix3d block = Eigen::Matrix3d::Zero();
  const int local_i[2] = {contacts_[i].local_a, contacts_[i].local_b};
  const int local_j[2] = {contacts_[j].local_a, contacts_[j].local_b};
  for (int si = 0; si < 2; ++si) {
    if (local_i[si] < 0) continue;
    for (int sj = 0; sj < 2; ++sj) {
      if (local_j[sj] != local_i[si]) continue;
      block += (kSideSign[si] * kSideSign[sj]) * sideBlock(i, si, j, sj);
    }
  }
  return block;
}

const std::vector<std::pair<int, int>>& ContactProblem::couplings() const {
  if (couplings_built_) return couplings_;
  std::vector<std::pair<int, int>> incidences;  // (body, contact)
  incidences.reserve(2 * contacts_.size());
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    if (contacts_[i].local_a >= 0) incidences.emplace_back(contacts_[i].local_a, int(i));
    if (contacts_[i].local_b >= 0) incidences.emplace_back(contacts_[i].local_b, int(i));
  }
  std::sort(incidences.begin(), incidences.end());
  for (std::size_t begin = 0, end = 0; begin < incidences.size(); begin = end) {
    end = begin + 1;
    while (end < incidences.size() && incidences[end].first == incidences[begin].first) ++end;
    for (std::size_t x = begin; x < end; ++x) {
      for (std::size_t y = x + 1; y < end; ++y) {
        if (incidences[x].second != incidences[y].second) {
          couplings_.emplace_back(incidences[x].second, incidences[y].second);
        }
      }
    }
  }
  std::sort(couplings_.begin(), couplings_.end());
  couplings_.erase(std::unique(couplings_.begin(), couplings_.end()), couplings_.end());
  couplings_built_ = true;
  return couplings_;
}

void ContactProblem::addVelocityChangesTo(std::vector<RigidBody>& bodies) const {
  for (const ProblemBody& body : bodies_) {
    RigidBody& out = bodies[body.index];
    out.linear_velocity += velocity_changes_.segment<3>(body.offset);
    out.angular_velocity += velocity_changes_.segment<3>(body.offset + 3);
  }
}

void ContactProblem::addVelocityChangesTo(const std::vector<BodyModel*>& bodies) const {
  for (const ProblemBody& body : bodies_) {
    BodyModel& out = *bodies[body.index];
    if (body.rigid()) {  // a free rigid body (asRigidBody() of this very, non-const, object)
      RigidBody& rigid = const_cast<RigidBody&>(*out.asRigidBody());
      rigid.linear_velocity += velocity_changes_.segment<3>(body.offset);
      rigid.angular_velocity += velocity_changes_.segment<3>(body.offset + 3);
    } else {
      out.addVelocityChange(velocity_changes_.segment(body.offset, body.unknowns));
    }
  }
}

void ContactProblem::scatterImpulses(const std::vector<ContactImpulse>& solved,
                                     std::vector<ContactImpulse>& impulses) const {
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    ContactImpulse& out = impulses[contacts_[i].source];
    out.normal_impulse = solved[i].normal_impulse;
    out.friction_impulse = solved[i].friction_impulse;
    out.sticking = solved[i].sticking;
  }
}

void ContactProblem::scatterForces(const std::vector<ContactImpulse>& solved,
                                   std::vector<ContactImpulse>& impulses) const {
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    ContactImpulse& out = impulses[contacts_[i].source];
    out.resting = true;
    out.normal_force = solved[i].normal_force;
    out.friction_force = solved[i].friction_force;
    out.sticking = solved[i].sticking;
  }
}

}  // namespace collision_response::core
