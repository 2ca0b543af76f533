#include "collision_response/ros/robot_conversion.h"

#include <cmath>
#include <sstream>
#include <vector>

#include "collision_response/core/errors.h"
#include "collision_response/core/validation.h"
#include "collision_response/ros/message_conversion.h"

namespace collision_response {
namespace {

using Limits = core::MagnitudeLimits;

// A mimic joint's given position [rad | m] or velocity [rad/s | m/s] that differs from the one its
// root's gives by more than this gets a warning (docs/robots.md, "Mimic joints").
constexpr double kMimicTolerance = 1e-6;

std::string indexed(const std::string& field, std::size_t k) {
  return field + "[" + std::to_string(k) + "]";
}

void requireFiniteWithin(double value, double limit, const std::string& field, const char* unit) {
  if (!std::isfinite(value)) throw core::InvalidInput(field, "is not finite");
  if (std::abs(value) > limit) {
    throw core::InvalidInput(field, "exceeds " + std::to_string(limit) + " " + unit +
                                        " in magnitude (" + std::to_string(value) + ")");
  }
}

void requireFinite(const Eigen::Vector3d& v, double limit, const std::string& field,
                   const char* unit) {
  for (int k = 0; k < 3; ++k) {
    static const char* const kAxis[] = {"x", "y", "z"};
    requireFiniteWithin(v(k), limit, field + "." + kAxis[k], unit);
  }
}

// Throws naming `field` if a value stamped `stamp` (`what` on `topic`) is older than `timeout` [s]
// at `now`.
void requireRecent(const ros::Time& stamp, const ros::Time& now, double timeout,
                   const std::string& field, const std::string& what, const std::string& topic) {
  const double age = (now - stamp).toSec();
  if (age > timeout) {
    throw core::InvalidInput(field, "the latest " + what + " on " + topic + " is " +
                                        std::to_string(age) +
                                        " s old, beyond ~joint_state_timeout (" +
                                        std::to_string(timeout) + " s); give it in the request");
  }
}

// tau from joint_state.effort (JOINT_TORQUES_EFFORT): each joint's from the request, else from the
// joint-state topic; locked joints need none (their acceleration is 0).
Eigen::VectorXd requestEfforts(const ServedRobot& robot, const RobotState& msg,
                               const robot::ArticulatedBody& model, const ros::Time& now,
                               double timeout, const std::string& field) {
  const sensor_msgs::JointState& given = msg.joint_state;
  const std::string effort_field = field + ".joint_state.effort";
  if (!given.effort.empty() && given.effort.size() != given.name.size()) {
    throw core::InvalidInput(effort_field, "has " + std::to_string(given.effort.size()) +
                                               " entries for " + std::to_string(given.name.size()) +
                                               " names (empty: the latest message's)");
  }
  const int joints = model.jointCount();
  Eigen::VectorXd torques = Eigen::VectorXd::Zero(joints);
  std::vector<bool> has_effort(joints, false);
  for (std::size_t k = 0; k < given.effort.size(); ++k) {
    const std::string name_field = indexed(field + ".joint_state.name", k);
    const int joint = robot.jointIndex(given.name[k], name_field);
    if (has_effort[joint])
      throw core::InvalidInput(name_field, "repeats joint '" + given.name[k] + "'");
    requireFiniteWithin(given.effort[k], Limits::kForce, indexed(effort_field, k), "N m or N");
    torques(joint) = given.effort[k];
    has_effort[joint] = true;
  }
  std::vector<JointStateCache::Sample> latest;
  const std::string& topic = robot.parameters().joint_states_topic;
  for (int joint = 0; joint < joints; ++joint) {
    if (has_effort[joint] || model.unknownOfJoint(joint) < 0) continue;
    if (latest.empty()) latest = robot.jointStates().snapshot();
    const JointStateCache::Sample& sample = latest[joint];
    const std::string& name = model.jointNames()[joint];
    if (model.mimicRoot(joint) != joint) {
      // A mimic joint needs no actuator of its own (the coupling drives it): its effort counts
      // when it is given, recent and finite, and is 0 otherwise.
      if (sample.has_effort && (now - sample.effort_stamp).toSec() <= timeout &&
          std::isfinite(sample.effort) && std::abs(sample.effort) <= Limits::kForce)
        torques(joint) = sample.effort;
      continue;
    }
    if (!sample.has_effort) {
      throw core::InvalidInput(effort_field, "joint '" + name +
                                                 "' has no effort (joint_torques is "
                                                 "JOINT_TORQUES_EFFORT): not in the request and "
                                                 "none received on " +
                                                 topic);
    }
    requireRecent(sample.effort_stamp, now, timeout, effort_field, "effort of joint '" + name + "'",
                  topic);
    if (!std::isfinite(sample.effort) || std::abs(sample.effort) > Limits::kForce) {
      throw core::InvalidInput(effort_field, "the latest effort of joint '" + name + "' on " +
                                                 topic + " is not finite or beyond " +
                                                 std::to_string(Limits::kForce) + " N m or N");
    }
    torques(joint) = sample.effort;
  }
  return torques;
}

// The loads of a resting analysis (RobotState.gravity and joint_torques). Gravity compensation
// is the model's own (computed only if a resting island needs it).
void setRestingLoads(const ServedRobot& robot, const RobotState& msg, const ros::Time& now,
                     double timeout, const std::string& field, robot::ArticulatedBody& model) {
  const Eigen::Vector3d gravity = toEigen(msg.gravity);
  requireFinite(gravity, Limits::kAcceleration, field + ".gravity", "m/s^2");
  Eigen::VectorXd torques = Eigen::VectorXd::Zero(model.jointCount());
  switch (msg.joint_torques) {
    case RobotState::JOINT_TORQUES_GRAVITY_COMPENSATION:
      model.setGravityCompensation(gravity);
      return;
    case RobotState::JOINT_TORQUES_EFFORT:
      torques = requestEfforts(robot, msg, model, now, timeout, field);
      break;
    case RobotState::JOINT_TORQUES_NONE:
      break;
    default:
      throw core::InvalidInput(field + ".joint_torques",
                               "is " + std::to_string(msg.joint_torques) +
                                   ": not JOINT_TORQUES_GRAVITY_COMPENSATION (0), "
                                   "JOINT_TORQUES_EFFORT (1) or JOINT_TORQUES_NONE (2)");
  }
  model.setLoads(torques, gravity);
}

}  // namespace

std::optional<Eigen::Isometry3d> basePoseFromMsg(const RobotState& msg, const std::string& field) {
  const geometry_msgs::Quaternion& q = msg.base_pose.orientation;
  const geometry_msgs::Point& p = msg.base_pose.position;
  const std::string pose_field = field + ".base_pose";
  if (q.x == 0.0 && q.y == 0.0 && q.z == 0.0 && q.w == 0.0) {
    // An all-zero pose is the message's default: not given (the base from tf). A position with
    // the default quaternion is a pose half written: refused rather than replaced by tf's.
    if (p.x == 0.0 && p.y == 0.0 && p.z == 0.0) return std::nullopt;
    throw core::InvalidInput(pose_field + ".orientation",
                             "is all zero while base_pose.position is given: set an orientation "
                             "(w: 1 for none), or leave the whole base_pose zero to take the base "
                             "from tf");
  }
  requireFinite(toEigen(msg.base_pose.position), Limits::kLength, pose_field + ".position", "m");
  Eigen::Quaterniond rotation(q.w, q.x, q.y, q.z);
  if (!rotation.coeffs().allFinite())
    throw core::InvalidInput(pose_field + ".orientation", "is not finite");
  if (std::abs(rotation.norm() - 1.0) > core::kUnitTolerance) {
    throw core::InvalidInput(
        pose_field + ".orientation",
        "is not a unit quaternion (norm " + std::to_string(rotation.norm()) + ")");
  }
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation.normalized().toRotationMatrix();
  pose.translation() = toEigen(msg.base_pose.position);
  return pose;
}

robot::ArticulatedBody robotAtRequestState(const ServedRobot& robot, const RobotState& msg,
                                           const Eigen::Isometry3d& base_pose, const ros::Time& now,
                                           double timeout, const std::string& field,
                                           std::vector<std::string>* warnings) {
  robot::ArticulatedBody model =
      msg.override_locked_joints
          ? robot.modelWithLockedJoints(msg.locked_joints, field + ".locked_joints")
          : robot.model();
  if (!model.singularJoint().empty())
    throw core::InvalidInput(field + ".locked_joints", model.singularJoint());

  // The request's own values first.
  const sensor_msgs::JointState& given = msg.joint_state;
  const std::string state_field = field + ".joint_state";
  const std::size_t count = given.name.size();
  if (!given.position.empty() && given.position.size() != count) {
    throw core::InvalidInput(state_field + ".position",
                             "has " + std::to_string(given.position.size()) + " entries for " +
                                 std::to_string(count) + " names (empty: the latest message's)");
  }
  if (!given.velocity.empty() && given.velocity.size() != count) {
    throw core::InvalidInput(state_field + ".velocity",
                             "has " + std::to_string(given.velocity.size()) + " entries for " +
                                 std::to_string(count) + " names (empty: the latest message's)");
  }
  const int joints = model.jointCount();
  Eigen::VectorXd q = Eigen::VectorXd::Zero(joints), qdot = Eigen::VectorXd::Zero(joints);
  std::vector<bool> has_position(joints, false), has_velocity(joints, false);
  for (std::size_t k = 0; k < count; ++k) {
    const std::string& name = given.name[k];
    const int joint = robot.jointIndex(name, indexed(state_field + ".name", k));
    if (has_position[joint] || has_velocity[joint])
      throw core::InvalidInput(indexed(state_field + ".name", k), "repeats joint '" + name + "'");
    if (!given.position.empty()) {
      requireFiniteWithin(given.position[k], Limits::kLength, indexed(state_field + ".position", k),
                          "rad or m");
      q(joint) = given.position[k];
      has_position[joint] = true;
    }
    if (!given.velocity.empty()) {
      requireFiniteWithin(given.velocity[k], Limits::kSpeed, indexed(state_field + ".velocity", k),
                          "rad/s or m/s");
      qdot(joint) = given.velocity[k];
      has_velocity[joint] = true;
    }
  }

  // The rest from the latest joint-state messages, if recent enough. A mimic joint's state is
  // derived from its root's (below): it needs none.
  std::vector<std::string> resting;  // joints whose velocity nobody gave
  const auto isMimic = [&model](int joint) { return model.mimicRoot(joint) != joint; };
  bool complete = true;
  for (int joint = 0; joint < joints && complete; ++joint)
    complete = isMimic(joint) || (has_position[joint] && has_velocity[joint]);
  std::vector<JointStateCache::Sample> latest;
  if (!complete || model.hasMimicJoints()) latest = robot.jointStates().snapshot();
  if (!complete) {
    const std::string& topic = robot.parameters().joint_states_topic;
    for (int joint = 0; joint < joints; ++joint) {
      if (isMimic(joint) || (has_position[joint] && has_velocity[joint])) continue;
      const JointStateCache::Sample& sample = latest[joint];
      const std::string& name = model.jointNames()[joint];
      if (!has_position[joint] && !sample.has_position) {
        throw core::InvalidInput(state_field, "joint '" + name +
                                                  "' has no position: not in the request and "
                                                  "none received on " +
                                                  topic);
      }
      // Only a value taken from the topic must be recent: a joint whose position the request gives
      // and whose velocity was never received is at rest (below), whatever the topic's age.
      const bool velocity_from_topic = !has_velocity[joint] && sample.has_velocity;
      if (!has_position[joint] || velocity_from_topic) {
        requireRecent(sample.stamp, now, timeout, state_field, "state of joint '" + name + "'",
                      topic);
      }
      if (!has_position[joint]) {
        requireFiniteWithin(sample.position, Limits::kLength, state_field, "rad or m");
        q(joint) = sample.position;
      }
      if (!has_velocity[joint]) {
        // Publishers of positions only (joint_state_publisher, many drivers): a joint whose
        // velocity nobody gives is at rest, said in a warning.
        if (velocity_from_topic) {
          requireFiniteWithin(sample.velocity, Limits::kSpeed, state_field, "rad/s or m/s");
          qdot(joint) = sample.velocity;
        } else {
          qdot(joint) = 0.0;
          resting.push_back(name);
        }
      }
    }
  }

  // Mimic joints: derived from their roots; a value given in the request, or recent on the topic,
  // that differs is named in a warning (and not used).
  for (int joint = 0; joint < joints && model.hasMimicJoints(); ++joint) {
    if (!isMimic(joint)) continue;
    const int root = model.mimicRoot(joint);
    const double m = model.mimicMultiplier(joint);
    const double derived[2] = {m * q(root) + model.mimicOffset(joint), m * qdot(root)};
    const JointStateCache::Sample& sample = latest[joint];
    const bool recent = (now - sample.stamp).toSec() <= timeout;
    const bool from_request[2] = {has_position[joint], has_velocity[joint]};
    const bool from_topic[2] = {!from_request[0] && recent && sample.has_position,
                                !from_request[1] && recent && sample.has_velocity};
    const double given[2] = {from_request[0] ? q(joint) : sample.position,
                             from_request[1] ? qdot(joint) : sample.velocity};
    static const char* const kWhat[2] = {"position", "velocity"};
    for (int k = 0; k < 2; ++k) {
      if (!(from_request[k] || from_topic[k]) ||
          !(std::abs(given[k] - derived[k]) > kMimicTolerance))
        continue;
      if (warnings == nullptr) continue;
      std::ostringstream text;
      text.precision(9);
      text << state_field << ": joint '" << model.jointNames()[joint] << "' mimics '"
           << model.jointNames()[root] << "' (q = " << m << " q_leader + "
           << model.mimicOffset(joint) << "): its " << kWhat[k] << " "
           << (from_request[k] ? "in the request" : "on " + robot.parameters().joint_states_topic)
           << ", " << given[k] << ", differs from the derived " << derived[k] << " by more than "
           << kMimicTolerance << "; the derived one is used";
      warnings->push_back(text.str());
    }
  }

  if (!resting.empty() && warnings != nullptr) {
    std::string list;
    for (const std::string& name : resting) list += (list.empty() ? "'" : ", '") + name + "'";
    warnings->push_back(state_field + ": no velocity in the request, and none ever received on " +
                        robot.parameters().joint_states_topic + ", for " + list +
                        ": taken as 0 (at rest)");
  }
  Eigen::Vector3d base_linear = Eigen::Vector3d::Zero(), base_angular = Eigen::Vector3d::Zero();
  if (model.baseType() == robot::BaseType::kFloating) {
    base_linear = toEigen(msg.base_twist.linear);
    base_angular = toEigen(msg.base_twist.angular);
    requireFinite(base_linear, Limits::kSpeed, field + ".base_twist.linear", "m/s");
    requireFinite(base_angular, Limits::kSpeed, field + ".base_twist.angular", "rad/s");
  }
  try {
    model.setState(q, qdot, base_pose, base_linear, base_angular);
  } catch (const core::InvalidInput& e) {
    // M(q) singular at this configuration (a free joint moving no mass here): the library names
    // the configuration, "q"; here it is the request's joint state.
    throw e.withFirstSegment(state_field);
  }
  setRestingLoads(robot, msg, now, timeout, field, model);
  return model;
}

RobotResult toMsg(const std::string& name, const robot::ArticulatedBody& after,
                  const Eigen::VectorXd& velocity_before, double energy_before,
                  const Eigen::Isometry3d& base_pose, const std_msgs::Header& header) {
  RobotResult result;
  result.name = name;
  result.joint_state.header = header;
  result.joint_state.name = after.jointNames();
  const int joints = after.jointCount();
  result.joint_state.position.assign(after.jointPositions().data(),
                                     after.jointPositions().data() + joints);
  result.joint_state.velocity.assign(after.jointVelocities().data(),
                                     after.jointVelocities().data() + joints);
  result.joint_state.effort.assign(joints, 0.0);
  result.joint_state_before.header = header;
  result.joint_state_before.name = result.joint_state.name;
  result.joint_state_before.position = result.joint_state.position;
  result.joint_state_before.velocity = result.joint_state.velocity;  // locked joints keep theirs
  const Eigen::VectorXd impulse = after.generalizedImpulse(after.velocity() - velocity_before);
  for (int joint = 0; joint < joints; ++joint) {
    const int k = after.unknownOfJoint(joint);
    if (k < 0) continue;
    // A mimic joint (multiplier m) shares its root's unknown: its velocity is m times the root's,
    // and its entry is the group's generalized impulse in its own coordinate, Q_root / m (the
    // same power Q qdot for every joint of the group; 0 when m = 0: it does not move).
    const double m = after.mimicMultiplier(joint);
    result.joint_state.effort[joint] = m == 0.0 ? 0.0 : impulse(k) / m;
    result.joint_state_before.velocity[joint] = m * velocity_before(k);
  }
  result.floating = after.baseType() == robot::BaseType::kFloating;
  const Eigen::Quaterniond rotation(base_pose.linear());
  result.base_pose.position = toPoint(base_pose.translation());
  result.base_pose.orientation.w = rotation.w();
  result.base_pose.orientation.x = rotation.x();
  result.base_pose.orientation.y = rotation.y();
  result.base_pose.orientation.z = rotation.z();
  if (result.floating) {
    result.base_twist.linear = toVector3(after.baseLinearVelocity());
    result.base_twist.angular = toVector3(after.baseAngularVelocity());
  }
  result.kinetic_energy_before = energy_before;
  result.kinetic_energy_after = after.kineticEnergy();
  return result;
}

std::vector<core::ContactPoint> placeContacts(
    const std::vector<core::Contact>& contacts,
    const std::vector<std::pair<int, int>>& contact_bodies, int rigid_count,
    const std::vector<std::pair<int, int>>& robot_link_of_id) {
  const auto place = [&](int index, int& body, int& part) {
    if (index < rigid_count) {
      body = index;
      return;
    }
    const auto [robot, link] = robot_link_of_id[index - rigid_count];
    body = rigid_count + robot;
    part = link;
  };
  std::vector<core::ContactPoint> points;
  points.reserve(contacts.size());
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const core::Contact& contact = contacts[c];
    core::ContactPoint point(-1, -1, contact.point, contact.normal.normalized(),
                             contact.restitution, contact.static_friction,
                             contact.dynamic_friction);
    place(contact_bodies[c].first, point.body_a, point.part_a);
    place(contact_bodies[c].second, point.body_b, point.part_b);
    points.push_back(point);
  }
  return points;
}

}  // namespace collision_response
