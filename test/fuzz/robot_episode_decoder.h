// Decodes arbitrary bytes into an impact episode with a robot (a URDF, generated or given as text;
// the robot's joint positions and velocities, base pose, torque model and gravity; a world of rigid
// bodies with boxes, spheres, planes, ...; EpisodeOptions) and runs it the way ~compute_episode
// does with `robots` (CollisionResponseServer::solveRobotEpisode(), src/ros/episode_service.cpp),
// without a ROS master; checks the outcome. Shared by the libFuzzer target
// (fuzz_robot_episode.cpp) and the regression test (test_fuzz_robot_episode_regressions.cpp), so a
// saved input replays exactly as the fuzzer saw it.
//
// The path, through the same public functions as the service: ServedRobot (URDF, link collision
// geometry), robotAtRequestState() (the identity stands in for tf2's base pose when the request
// gives none; no joint-state topic), the robot's gravity checked against the episode's, the links
// with geometry as detection bodies (robot::linkBody(), one collision group), core::SceneValidator
// and checkGeometrySize(), detection::ShapeGaps over the rigid bodies and the links,
// core::RigidEpisodeBody and robot::RobotEpisodeBody, core::computeBodyEpisode() and toMsg().
//
// Input layout: the URDF first (robot_decoder.h's urdfFromBytes(): byte 0 even, generated from the
// bytes; odd, text up to the first 0x00: the seeds hold urdf/arm7.urdf and test/robot/*.urdf), then
// the EpisodeOptions (episode_decoder.h's decodeOptions(): law, solver, a 0.05 s time budget,
// gravity, horizon, max_impacts, contact tolerance), the ~robots entry, the RobotState (joint
// positions, velocities, efforts as robot_decoder.h's jointStateMessage() draws them, base pose,
// gravity, joint_torques), then 0 to 3 rigid bodies (episode_decoder.h's decodeWorld(): a floor
// plane first, bodies above it) and the materials. Missing bytes read as 0, the sane choice.
//
// Outcomes: core::InvalidInput naming a field, and SolverTimeout, are expected; any other
// exception, an InvalidInput with no field, or a successful episode that breaks an invariant
// (non-finite end state, impulse, resting force or message number; end_time outside [0, horizon];
// impacts out of time order, after the end or past max_impacts; an immovable body moved) is a bug.
#pragma once

#include <cmath>
#include <cstdint>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "collision_response/core/body_episode.h"
#include "collision_response/core/rigid_episode_body.h"
#include "collision_response/robot/link_bodies.h"
#include "collision_response/robot/robot_episode_body.h"
#include "collision_response/ros/episode_conversion.h"
#include "episode_decoder.h"
#include "robot_decoder.h"

namespace collision_response::fuzz {

constexpr std::size_t kMaxEpisodeRigidBodies = 3;

/// What running a robot-episode input gave.
struct RobotEpisodeOutcome {
  bool loaded = false;      ///< ServedRobot accepted the URDF and the entry
  bool solved = false;      ///< computeBodyEpisode() returned
  bool skipped = false;     ///< the URDF text names a URL the harness does not fetch
  std::string invalid;      ///< the InvalidInput message, if any
  std::string timeout;      ///< the SolverTimeout message, if any
  std::string bug;          ///< non-empty: an unexpected exception or a broken invariant
  std::string description;  ///< the decoded input, readable
  std::size_t impacts = 0;  ///< impacts listed
  std::size_t links_with_geometry = 0;
  core::EpisodeEnd end = core::EpisodeEnd::kSeparated;
};

namespace robot_episode_detail {

inline bool allFinite(const std::vector<double>& values) {
  for (const double v : values)
    if (!std::isfinite(v)) return false;
  return true;
}

/// Invariants of a successful episode with `rigid_count` rigid bodies (`start`: as given) and one
/// robot; the first one broken, or "".
inline std::string checkRobotEpisode(const core::BodyEpisodeResult& r,
                                     const core::EpisodeOptions& o,
                                     const std::vector<core::BodyState>& start,
                                     const std::vector<core::EpisodeBody*>& bodies,
                                     const EpisodeResult& message) {
  std::ostringstream out;
  out.precision(17);
  const std::size_t n = bodies.size();
  if (r.outcomes.size() != n) {
    out << r.outcomes.size() << " outcomes for " << n << " bodies";
    return out.str();
  }
  if (static_cast<int>(r.impacts.size()) > o.max_impacts) {
    out << r.impacts.size() << " impacts listed, max_impacts " << o.max_impacts;
    return out.str();
  }
  if (r.resting.size() != r.resting_contacts.size()) {
    out << r.resting_contacts.size() << " resting contacts, " << r.resting.size() << " forces";
    return out.str();
  }
  if (!std::isfinite(r.end_time)) {
    out << "non-finite end_time " << r.end_time;
    return out.str();
  }
  Eigen::VectorXd state;
  for (std::size_t i = 0; i < n; ++i) {
    bodies[i]->saveState(state);
    if (!state.allFinite()) {
      out << "bodies[" << i << "]: non-finite state at the end: " << state.transpose();
      return out.str();
    }
  }
  const double slack = 1e-12 * std::max(1.0, o.horizon);
  if (r.end_time < 0.0 || r.end_time > o.horizon + slack) {
    out << "end_time " << r.end_time << " outside [0, horizon " << o.horizon << "]";
    return out.str();
  }
  double previous = 0.0;
  for (std::size_t k = 0; k < r.impacts.size(); ++k) {
    const core::BodyEpisodeImpact& impact = r.impacts[k];
    if (!std::isfinite(impact.time) || impact.time < previous - slack ||
        impact.time > r.end_time + slack) {
      out << "impacts[" << k << "].time " << impact.time << " out of order (previous " << previous
          << ", end_time " << r.end_time << ")";
      return out.str();
    }
    previous = impact.time;
    if (impact.impulses.size() != impact.contacts.size()) {
      out << "impacts[" << k << "]: " << impact.contacts.size() << " contacts, "
          << impact.impulses.size() << " impulses";
      return out.str();
    }
    for (std::size_t c = 0; c < impact.impulses.size(); ++c) {
      const core::ContactImpulse& p = impact.impulses[c];
      if (!std::isfinite(p.normal_impulse) || !p.friction_impulse.allFinite() ||
          !std::isfinite(p.normal_velocity_before) || !std::isfinite(p.normal_velocity_after)) {
        out << "impacts[" << k << "].impulses[" << c << "]: non-finite";
        return out.str();
      }
    }
    for (std::size_t i = 0; i < impact.states_after.size(); ++i) {
      if (!impact.states_after[i].allFinite()) {
        out << "impacts[" << k << "].states_after[" << i << "]: non-finite";
        return out.str();
      }
    }
    for (std::size_t i = 0; i < impact.velocities_after.size(); ++i) {
      if (!impact.velocities_after[i].allFinite()) {
        out << "impacts[" << k << "].velocities_after[" << i << "]: non-finite";
        return out.str();
      }
    }
  }
  for (std::size_t c = 0; c < r.resting.size(); ++c) {
    if (!std::isfinite(r.resting[c].normal_force) || !r.resting[c].friction_force.allFinite()) {
      out << "resting[" << c << "]: non-finite force";
      return out.str();
    }
  }
  // Immovable rigid bodies keep their velocities.
  for (std::size_t i = 0; i < start.size(); ++i) {
    const core::BodyState& end = static_cast<const core::RigidEpisodeBody*>(bodies[i])->state();
    if (start[i].immovable() && (end.linear_velocity != start[i].linear_velocity ||
                                 end.angular_velocity != start[i].angular_velocity)) {
      out << "bodies[" << i << "]: an immovable body's velocity changed";
      return out.str();
    }
  }
  // The message: every number finite.
  if (!std::isfinite(message.end_time) || message.impacts.size() != r.impacts.size() ||
      message.robots.size() != 1) {
    out << "message: end_time " << message.end_time << ", " << message.impacts.size()
        << " impacts, " << message.robots.size() << " robots";
    return out.str();
  }
  for (const EpisodeRobot& robot : message.robots) {
    if (!allFinite(robot.joint_state.position) || !allFinite(robot.joint_state.velocity)) {
      out << "message: robots[0].joint_state non-finite";
      return out.str();
    }
  }
  for (std::size_t k = 0; k < message.impacts.size(); ++k) {
    for (const sensor_msgs::JointState& joints : message.impacts[k].robots) {
      if (!allFinite(joints.position) || !allFinite(joints.velocity)) {
        out << "message: impacts[" << k << "].robots non-finite";
        return out.str();
      }
    }
  }
  return "";
}

}  // namespace robot_episode_detail

/// Decodes `data` and runs it (see the file comment). `print_before_solving`: print the decoded
/// input before the episode runs.
inline RobotEpisodeOutcome runRobotEpisodeInput(const std::uint8_t* data, std::size_t size,
                                                bool print_before_solving = false) {
  using namespace robot_detail;
  RobotEpisodeOutcome outcome;
  std::ostringstream text;
  text.precision(17);

  std::string urdf;
  bool text_mode = false;
  std::optional<ByteReader> in = urdfFromBytes(data, size, urdf, text_mode);
  if (!in) {
    outcome.skipped = true;
    outcome.description = "URDF (text, not run: it names a URL the harness does not fetch)\n";
    return outcome;
  }
  ByteReader& bytes = *in;
  text << "URDF (" << (text_mode ? "text" : "generated") << "):\n" << urdf << "\n";

  const ros::Time now(1000.0);
  try {
    DecodedEpisode world;  // the rigid bodies, their shapes and materials, the options
    world.options = episode_detail::decodeOptions(bytes);
    const core::EpisodeOptions& options = world.options;

    // The ~robots entry: fixed base (floating now and then: episodes refuse it), locked joints.
    RobotParameters parameters;
    parameters.name = kRobotName;
    parameters.description_param = "/fuzz_description";
    parameters.joint_states_topic = "/fuzz/joint_states";
    const std::uint8_t entry = bytes.byte();
    parameters.floating = entry % 16 == 15;
    std::unique_ptr<ServedRobot> served =
        std::make_unique<ServedRobot>(parameters, urdf, "~robots[0]");
    const std::vector<std::string> joints = served->model().jointNames();
    if (entry % 8 == 3) {
      parameters.locked_joints =
          jointNames(bytes, joints, bytes.byte() % (joints.size() + 1), (entry & 0x80) != 0);
      served = std::make_unique<ServedRobot>(parameters, urdf, "~robots[0]");
    }
    text << "entry: floating " << parameters.floating << ", locked_joints "
         << list(parameters.locked_joints) << "\n";
    outcome.loaded = true;

    // The request's RobotState: every joint (now and then a subset, hostile values), a base pose
    // (or none: the identity for tf2's), gravity (zero: the episode's; the episode's; another),
    // the torque model.
    const std::uint8_t state_mode = bytes.byte();
    const bool wild = state_mode % 8 == 7;
    RobotState message;
    message.name = kRobotName;
    message.joint_state = jointStateMessage(bytes, joints, wild);
    const std::uint8_t pose = bytes.byte();
    if (pose % 4 != 0) {
      const Eigen::Quaterniond q =
          pose % 4 == 1 ? Eigen::Quaterniond::Identity() : bytes.unitQuaternion();
      message.base_pose.orientation.w = q.w();
      message.base_pose.orientation.x = q.x();
      message.base_pose.orientation.y = q.y();
      message.base_pose.orientation.z = q.z();
      const Eigen::Vector3d p = bytes.vector(wild, -0.5, 0.5);
      message.base_pose.position.x = p.x();
      message.base_pose.position.y = p.y();
      message.base_pose.position.z = p.z();
    }
    if (wild && (state_mode & 0x80)) {  // a base twist on a fixed base
      const Eigen::Vector3d v = bytes.vector(true, -1.0, 1.0);
      message.base_twist.linear.x = v.x();
      message.base_twist.linear.y = v.y();
      message.base_twist.linear.z = v.z();
    }
    const std::uint8_t gravity = bytes.byte();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    if (gravity % 4 == 1) g = options.gravity;
    if (gravity % 4 == 2) g = bytes.vector(wild, -20, 20);
    message.gravity.x = g.x();
    message.gravity.y = g.y();
    message.gravity.z = g.z();
    const std::uint8_t torques = bytes.byte();
    message.joint_torques = wild && torques >= 0xf0 ? torques : torques % 3;
    text << "request robots[0]: joint_state name " << list(message.joint_state.name)
         << ", position " << list(message.joint_state.position) << ", velocity "
         << list(message.joint_state.velocity) << ", effort " << list(message.joint_state.effort)
         << "\n  base_pose position [" << message.base_pose.position.x << ", "
         << message.base_pose.position.y << ", " << message.base_pose.position.z
         << "], orientation (w x y z) " << message.base_pose.orientation.w << " "
         << message.base_pose.orientation.x << " " << message.base_pose.orientation.y << " "
         << message.base_pose.orientation.z << ", base_twist.linear ["
         << message.base_twist.linear.x << ", " << message.base_twist.linear.y << ", "
         << message.base_twist.linear.z << "], gravity " << vec(g) << ", joint_torques "
         << int(message.joint_torques) << "\n";

    // The world: 0 to 3 rigid bodies (a floor plane first), their shapes and materials.
    const std::size_t count = (bytes.byte() + 2) % (kMaxEpisodeRigidBodies + 1);  // 2 by default
    episode_detail::decodeWorld(bytes, count, world);
    text << describe(world);
    if (print_before_solving) {
      std::fputs(text.str().c_str(), stdout);
      std::fflush(stdout);
      text.str("");
    }

    // The service's sequence (CollisionResponseServer::solveEpisode, solveRobotEpisode).
    core::Scene scene;
    scene.bodies = world.bodies;
    const core::RequestLimits limits;
    const core::SceneValidator validator(scene, options.solver, limits);
    Eigen::Isometry3d base_pose = Eigen::Isometry3d::Identity();  // tf2's answer stands in
    if (const std::optional<Eigen::Isometry3d> given = basePoseFromMsg(message, "robots[0]"))
      base_pose = *given;
    std::vector<std::string> warnings;
    robot::ArticulatedBody robot = robotAtRequestState(*served, message, base_pose, now,
                                                       kJointStateTimeout, "robots[0]", &warnings);
    const Eigen::Vector3d own = g;
    if (!own.isZero(0.0) && (own - options.gravity).norm() > 1e-9 * options.gravity.norm()) {
      throw core::InvalidInput("robots[0].gravity", "differs from the episode's gravity");
    }
    detection::DetectionInput input = world.input;
    input.collision_groups.assign(scene.bodies.size(), -1);
    if (input.materials.size() < scene.bodies.size()) input.materials.resize(scene.bodies.size());
    std::vector<core::BodyState> part_states = scene.bodies;
    std::vector<core::EpisodePart> parts;
    const int rigid_count = static_cast<int>(scene.bodies.size());
    for (int i = 0; i < rigid_count; ++i) parts.push_back({i, 0});
    std::size_t shapes = 0, vertices = 0, triangles = 0;
    for (const detection::BodyGeometry& geometry : input.geometry) {
      for (const detection::Shape& shape : geometry.shapes) {
        ++shapes;
        vertices += shape.vertices.size();
        triangles += shape.triangles.size();
      }
    }
    for (int link = 0; link < robot.linkCount(); ++link) {
      const detection::BodyGeometry& geometry = served->linkGeometry()[link];
      if (geometry.shapes.empty()) continue;
      part_states.push_back(robot::linkBody(robot, link, served->linkIds()[link]));
      parts.push_back({rigid_count, link});
      input.geometry.push_back(geometry);
      input.materials.emplace_back();
      input.collision_groups.push_back(0);
      for (const detection::Shape& shape : geometry.shapes) {
        ++shapes;
        vertices += shape.vertices.size();
        triangles += shape.triangles.size();
      }
    }
    outcome.links_with_geometry = parts.size() - static_cast<std::size_t>(rigid_count);
    core::checkGeometrySize(shapes, vertices, triangles, limits);
    const detection::ShapeGaps geometry(part_states, input, world.materials, limits);

    std::vector<core::RigidEpisodeBody> rigid;
    rigid.reserve(scene.bodies.size());
    for (const core::BodyState& body : scene.bodies) rigid.emplace_back(body);
    std::optional<robot::RobotEpisodeBody> moving;
    try {
      moving.emplace(std::move(robot));
    } catch (const core::InvalidInput& e) {
      throw e.prefixed("robots[0]");
    }
    std::vector<core::EpisodeBody*> bodies;
    for (core::RigidEpisodeBody& body : rigid) bodies.push_back(&body);
    bodies.push_back(&*moving);
    const core::BodyEpisodeResult episode =
        core::computeBodyEpisode(bodies, parts, geometry, options);
    outcome.solved = true;
    outcome.impacts = episode.impacts.size();
    outcome.end = episode.end;

    std::vector<core::BodyState> bodies_end;
    for (const core::RigidEpisodeBody& body : rigid) bodies_end.push_back(body.state());
    std_msgs::Header header;
    header.frame_id = "world";
    const EpisodeResult answer = toMsg(episode, scene.bodies, bodies_end,
                                       {{kRobotName, &moving->robot(), base_pose}}, header);
    text << "answer: end " << core::toString(episode.end) << " at " << episode.end_time << " s, "
         << episode.impacts.size() << " impacts, " << episode.steps << " steps";
    for (const EpisodeRobot& answered : answer.robots) {
      text << ", robot joints " << list(answered.joint_state.position) << ", velocities "
           << list(answered.joint_state.velocity);
    }
    text << "\n";
    outcome.bug =
        robot_episode_detail::checkRobotEpisode(episode, options, scene.bodies, bodies, answer);
  } catch (const core::InvalidInput& error) {
    outcome.invalid = error.what();
    text << "outcome: InvalidInput: " << error.what() << "\n";
    if (error.field().empty())
      outcome.bug = std::string("InvalidInput names no field: ") + error.what();
  } catch (const core::SolverTimeout& error) {
    outcome.timeout = error.what();
    text << "outcome: SolverTimeout: " << error.what() << "\n";
  } catch (const std::exception& error) {
    outcome.bug = std::string("unexpected exception: ") + error.what();
  } catch (...) {
    outcome.bug = "unexpected exception of unknown type";
  }
  outcome.description += text.str();
  return outcome;
}

}  // namespace collision_response::fuzz
