#include "collision_response/ros/message_conversion.h"

#include "collision_response/errors.h"

namespace collision_response {
namespace {

Eigen::Vector3d toEigen(const geometry_msgs::Vector3& v) {
  return {v.x, v.y, v.z};
}
Eigen::Vector3d toEigen(const geometry_msgs::Point& p) {
  return {p.x, p.y, p.z};
}

geometry_msgs::Vector3 toVector3(const Eigen::Vector3d& v) {
  geometry_msgs::Vector3 out;
  out.x = v.x();
  out.y = v.y();
  out.z = v.z();
  return out;
}

}  // namespace

core::BodyState fromMsg(const BodyState& msg) {
  core::BodyState state;
  state.id = msg.id;
  const geometry_msgs::Inertia& inertia = msg.inertia;
  state.mass = inertia.m;
  state.com = toEigen(inertia.com);
  state.inertia << inertia.ixx, inertia.ixy, inertia.ixz,  //
      inertia.ixy, inertia.iyy, inertia.iyz,               //
      inertia.ixz, inertia.iyz, inertia.izz;
  state.position = toEigen(msg.pose.position);
  const geometry_msgs::Quaternion& q = msg.pose.orientation;
  state.orientation = Eigen::Quaterniond(q.w, q.x, q.y, q.z);
  state.linear_velocity = toEigen(msg.twist.linear);
  state.angular_velocity = toEigen(msg.twist.angular);
  state.force = toEigen(msg.wrench.force);
  state.torque = toEigen(msg.wrench.torque);
  return state;
}

BodyState toMsg(const core::BodyState& state, const std::string& frame_id) {
  BodyState msg;
  msg.id = state.id;
  msg.frame_id = frame_id;
  msg.inertia.m = state.mass;
  msg.inertia.com = toVector3(state.com);
  msg.inertia.ixx = state.inertia(0, 0);
  msg.inertia.ixy = state.inertia(0, 1);
  msg.inertia.ixz = state.inertia(0, 2);
  msg.inertia.iyy = state.inertia(1, 1);
  msg.inertia.iyz = state.inertia(1, 2);
  msg.inertia.izz = state.inertia(2, 2);
  msg.pose.position.x = state.position.x();
  msg.pose.position.y = state.position.y();
  msg.pose.position.z = state.position.z();
  msg.pose.orientation.w = state.orientation.w();
  msg.pose.orientation.x = state.orientation.x();
  msg.pose.orientation.y = state.orientation.y();
  msg.pose.orientation.z = state.orientation.z();
  msg.twist.linear = toVector3(state.linear_velocity);
  msg.twist.angular = toVector3(state.angular_velocity);
  msg.wrench.force = toVector3(state.force);
  msg.wrench.torque = toVector3(state.torque);
  return msg;
}

core::Contact fromMsg(const Contact& msg) {
  core::Contact contact;
  contact.body_a = msg.body_a;
  contact.body_b = msg.body_b;
  contact.point = toEigen(msg.point);
  contact.normal = toEigen(msg.normal);
  contact.restitution = msg.restitution;
  contact.static_friction = msg.static_friction;
  contact.dynamic_friction = msg.dynamic_friction;
  return contact;
}

ContactImpulse toMsg(const core::ContactImpulse& impulse) {
  ContactImpulse msg;
  msg.normal_impulse = impulse.normal_impulse;
  msg.friction_impulse = toVector3(impulse.friction_impulse);
  msg.sticking = impulse.sticking;
  msg.normal_velocity_before = impulse.normal_velocity_before;
  msg.normal_velocity_after = impulse.normal_velocity_after;
  msg.resting = impulse.resting;
  msg.normal_force = impulse.normal_force;
  msg.friction_force = toVector3(impulse.friction_force);
  return msg;
}

IslandReport toMsg(const core::IslandReport& report) {
  IslandReport msg;
  msg.contact_indices.assign(report.contacts.begin(), report.contacts.end());
  msg.method = report.method;
  msg.iterations = static_cast<uint32_t>(report.iterations);
  msg.residual = report.residual;
  msg.converged = report.converged;
  return msg;
}

core::SolverOptions fromMsg(const SolverOptions& msg, const core::SolverOptions& defaults) {
  core::SolverOptions options = defaults;
  switch (msg.law) {
    case SolverOptions::LAW_DEFAULT:
      break;
    case SolverOptions::LAW_NEWTON:
      options.law = core::ImpactLaw::kNewton;
      break;
    case SolverOptions::LAW_SEED_ONE_PASS:
      options.law = core::ImpactLaw::kSeedOnePass;
      break;
    case SolverOptions::LAW_POISSON:
      options.law = core::ImpactLaw::kPoisson;
      break;
    case SolverOptions::LAW_STRONGE:
      options.law = core::ImpactLaw::kStronge;
      break;
    default:
      throw core::InvalidInput("options.law", "unknown value " + std::to_string(msg.law));
  }
  switch (msg.solver) {
    case SolverOptions::SOLVER_DEFAULT:
      break;
    case SolverOptions::SOLVER_AUTO:
      options.method = core::SolverMethod::kAuto;
      break;
    case SolverOptions::SOLVER_ITERATIVE:
      options.method = core::SolverMethod::kIterative;
      break;
    case SolverOptions::SOLVER_EXACT:
      options.method = core::SolverMethod::kExact;
      break;
    default:
      throw core::InvalidInput("options.solver", "unknown value " + std::to_string(msg.solver));
  }
  if (msg.tolerance != 0.0) options.tolerance = msg.tolerance;
  if (msg.max_iterations != 0) options.max_iterations = msg.max_iterations;
  if (msg.integration_tolerance != 0.0) options.integration_tolerance = msg.integration_tolerance;
  if (msg.resting_velocity != 0.0) options.resting_velocity = msg.resting_velocity;
  if (msg.time_budget != 0.0) options.time_budget = msg.time_budget;
  return options;
}

}  // namespace collision_response
