#include "collision_response/ros/request_assembly.h"

#include <tf2_eigen/tf2_eigen.h>

#include <algorithm>
#include <unordered_set>

#include "collision_response/core/contact_safety.h"
#include "collision_response/core/errors.h"
#include "collision_response/robot/joint_safety.h"
#include "collision_response/robot/link_bodies.h"
#include "collision_response/ros/message_conversion.h"
#include "collision_response/ros/robot_conversion.h"

namespace collision_response {

ServedRobot* findServedRobot(const ServedRobots& robots, const std::string& name) {
  for (const auto& robot : robots)
    if (robot->name() == name) return robot.get();
  return nullptr;
}

bool involvesRobots(const ComputeResponse::Request& request, const ServedRobots& robots) {
  if (!request.robots.empty()) return true;
  if (robots.empty()) return false;
  const auto names_link = [&](const std::string& id) {
    const std::size_t slash = id.find('/');
    if (slash == std::string::npos || findServedRobot(robots, id.substr(0, slash)) == nullptr)
      return false;
    for (const BodyState& body : request.bodies)
      if (body.id == id) return false;
    return true;
  };
  for (const Contact& contact : request.contacts)
    if (names_link(contact.body_a) || names_link(contact.body_b)) return true;
  return false;
}

core::Scene sceneInRequestFrame(const ComputeResponse::Request& request, const tf2_ros::Buffer& tf,
                                const ros::Duration& timeout, const core::RequestLimits& limits) {
  const std::string& request_frame = request.header.frame_id;
  core::Scene scene;
  // Size first, so an oversized request costs no conversion.
  core::checkSize(request.bodies.size(), request.contacts.size(), limits);
  scene.bodies.reserve(request.bodies.size());
  for (std::size_t i = 0; i < request.bodies.size(); ++i) {
    const BodyState& msg = request.bodies[i];
    core::BodyState state = fromMsg(msg);
    if (!msg.frame_id.empty() && msg.frame_id != request_frame) {
      const std::string field = "bodies[" + std::to_string(i) + "].frame_id";
      geometry_msgs::TransformStamped transform;
      try {
        transform = tf.lookupTransform(request_frame, msg.frame_id, request.header.stamp, timeout);
      } catch (const tf2::TransformException& e) {
        throw core::InvalidInput(field, "no transform from '" + msg.frame_id + "' to '" +
                                            request_frame + "': " + e.what());
      }
      state = core::transformed(state, tf2::transformToEigen(transform));
    }
    scene.bodies.push_back(std::move(state));
  }
  scene.contacts.reserve(request.contacts.size());
  for (const Contact& contact : request.contacts) scene.contacts.push_back(fromMsg(contact));
  return scene;
}

bool wantsDetection(const ComputeResponse::Request& request, bool robot_geometry) {
  switch (request.detection.mode) {
    case DetectionOptions::MODE_AUTO:
      return request.contacts.empty() &&
             (robot_geometry ||
              std::any_of(request.bodies.begin(), request.bodies.end(),
                          [](const BodyState& body) { return hasGeometry(body); }));
    case DetectionOptions::MODE_ALWAYS:
      return true;
    case DetectionOptions::MODE_NEVER:
      return false;
    default:
      throw core::InvalidInput("detection.mode", "unknown value " +
                                                     std::to_string(request.detection.mode) +
                                                     " (MODE_AUTO 0, MODE_ALWAYS 1, MODE_NEVER 2)");
  }
}

namespace {

// The index in `robots` of the robot whose served robot is called `name`, or -1.
int listedRobot(const std::vector<RequestRobot>& robots, const std::string& name) {
  for (std::size_t r = 0; r < robots.size(); ++r)
    if (robots[r].served->name() == name) return static_cast<int>(r);
  return -1;
}

void addRobot(std::vector<RequestRobot>& robots, ServedRobot* served, const RobotState& message,
              const std::string& field) {
  robots.emplace_back();
  robots.back().served = served;
  robots.back().message = message;
  robots.back().field = field;
}

// The robots request.robots lists, in order.
void addListedRobots(const ComputeResponse::Request& request, const ServedRobots& served,
                     std::vector<RequestRobot>& robots) {
  for (std::size_t i = 0; i < request.robots.size(); ++i) {
    const std::string field = "robots[" + std::to_string(i) + "]";
    ServedRobot* robot = findServedRobot(served, request.robots[i].name);
    if (robot == nullptr) {
      throw core::InvalidInput(field + ".name",
                               "names no robot of ~robots ('" + request.robots[i].name + "')");
    }
    if (listedRobot(robots, robot->name()) >= 0)
      throw core::InvalidInput(field + ".name", "repeats robot '" + robot->name() + "'");
    addRobot(robots, robot, request.robots[i], field);
  }
}

// The robots not listed that the request's contacts name ("<robot>/<link>", not a body's id), in
// the order of the contacts, each with a default message.
void addRobotsNamedByContacts(const ComputeResponse::Request& request,
                              const std::vector<core::BodyState>& scene_bodies,
                              const ServedRobots& served, std::vector<RequestRobot>& robots) {
  std::unordered_set<std::string> body_ids;
  for (const core::BodyState& body : scene_bodies) body_ids.insert(body.id);
  for (std::size_t c = 0; c < request.contacts.size(); ++c) {
    for (const std::string* id : {&request.contacts[c].body_a, &request.contacts[c].body_b}) {
      const std::size_t slash = id->find('/');
      if (slash == std::string::npos || body_ids.count(*id) > 0) continue;
      ServedRobot* robot = findServedRobot(served, id->substr(0, slash));
      if (robot == nullptr || listedRobot(robots, robot->name()) >= 0) continue;
      RobotState message;
      message.name = robot->name();
      addRobot(robots, robot, message, "contacts[" + std::to_string(c) + "]");
    }
  }
}

}  // namespace

std::vector<RequestRobot> requestRobots(const ComputeResponse::Request& request,
                                        const std::vector<core::BodyState>& scene_bodies,
                                        const ServedRobots& served) {
  std::vector<RequestRobot> robots;
  addListedRobots(request, served, robots);
  addRobotsNamedByContacts(request, scene_bodies, served, robots);
  return robots;
}

Eigen::Isometry3d robotBasePose(const RequestRobot& robot, const std_msgs::Header& header,
                                const tf2_ros::Buffer& tf, const ros::Duration& timeout) {
  if (const std::optional<Eigen::Isometry3d> pose = basePoseFromMsg(robot.message, robot.field))
    return *pose;
  const std::string& base_frame = robot.served->baseFrame();
  try {
    return tf2::transformToEigen(
        tf.lookupTransform(header.frame_id, base_frame, header.stamp, timeout));
  } catch (const tf2::TransformException& e) {
    throw core::InvalidInput(robot.field + ".base_pose", "not given, and no transform from '" +
                                                             base_frame + "' to '" +
                                                             header.frame_id + "': " + e.what());
  }
}

void placeRobots(std::vector<RequestRobot>& robots, const std_msgs::Header& header,
                 const tf2_ros::Buffer& tf, const ros::Duration& timeout, const ros::Time& now,
                 double joint_state_timeout, std::vector<std::string>& warnings) {
  for (RequestRobot& robot : robots) {
    robot.base_pose = robotBasePose(robot, header, tf, timeout);
    robot.model = robotAtRequestState(*robot.served, robot.message, robot.base_pose, now,
                                      joint_state_timeout, robot.field, &warnings);
    robot.velocity_before = robot.model->velocity();
    robot.energy_before = robot.model->kineticEnergy();
  }
}

RobotLinkIds robotLinkIds(const std::vector<RequestRobot>& robots) {
  RobotLinkIds links;
  for (std::size_t r = 0; r < robots.size(); ++r) {
    const std::vector<std::string>& ids = robots[r].served->linkIds();
    for (std::size_t link = 0; link < ids.size(); ++link) {
      links.ids.push_back(ids[link]);
      links.robot_link.emplace_back(static_cast<int>(r), static_cast<int>(link));
    }
  }
  return links;
}

bool anyRobotGeometry(const std::vector<RequestRobot>& robots) {
  return std::any_of(robots.begin(), robots.end(),
                     [](const RequestRobot& robot) { return robot.served->hasGeometry(); });
}

LinkBodies linkBodies(const std::vector<RequestRobot>& robots) {
  LinkBodies links;
  int link_id = 0;  // the link's index in robotLinkIds(robots).ids
  for (std::size_t r = 0; r < robots.size(); ++r) {
    const robot::ArticulatedBody& model = *robots[r].model;
    for (int link = 0; link < model.linkCount(); ++link, ++link_id) {
      const detection::BodyGeometry& geometry = robots[r].served->linkGeometry()[link];
      if (geometry.shapes.empty()) continue;
      links.bodies.push_back(robot::linkBody(model, link, robots[r].served->linkIds()[link]));
      links.geometry.push_back(&geometry);
      links.groups.push_back(static_cast<int>(r));
      links.link_ids.push_back(link_id);
      links.shapes += geometry.shapes.size();
      for (const detection::Shape& shape : geometry.shapes) {
        links.vertices += shape.vertices.size();
        links.triangles += shape.triangles.size();
      }
    }
  }
  return links;
}

std::vector<std::pair<int, int>> detectedContactBodies(
    const std::vector<std::pair<int, int>>& detected, int rigid_count, const LinkBodies& links) {
  const auto index = [&](int body) {
    return body < rigid_count ? body : rigid_count + links.link_ids[body - rigid_count];
  };
  std::vector<std::pair<int, int>> bodies;
  bodies.reserve(detected.size());
  for (const auto& [a, b] : detected) bodies.emplace_back(index(a), index(b));
  return bodies;
}

std::vector<core::BodyModel*> bodyModels(std::vector<core::RigidBody>& rigid,
                                         std::vector<RequestRobot>& robots) {
  std::vector<core::BodyModel*> models;
  models.reserve(rigid.size() + robots.size());
  for (core::RigidBody& body : rigid) models.push_back(&body);
  for (RequestRobot& robot : robots) models.push_back(&*robot.model);
  return models;
}

std::vector<ContactLinkFrame> contactLinkFrames(const std::vector<core::ContactPoint>& points,
                                                const std::vector<RequestRobot>& robots,
                                                int rigid_count) {
  std::vector<ContactLinkFrame> frames(points.size());
  for (std::size_t c = 0; c < points.size(); ++c) {
    const bool on_a = points[c].part_a >= 0;
    const int part = on_a ? points[c].part_a : points[c].part_b;
    if (part < 0) continue;
    const robot::ArticulatedBody& model =
        *robots[(on_a ? points[c].body_a : points[c].body_b) - rigid_count].model;
    frames[c] = {model.linkName(part), model.linkPose(part)};
  }
  return frames;
}

std::vector<RobotResult> robotAnswers(const std::vector<RequestRobot>& robots, int rigid_count,
                                      const std::vector<core::ContactPoint>& points,
                                      const std::vector<core::ContactImpulse>& impulses,
                                      const std_msgs::Header& header) {
  std::vector<RobotResult> answers;
  answers.reserve(robots.size());
  for (std::size_t r = 0; r < robots.size(); ++r) {
    const RequestRobot& robot = robots[r];
    answers.push_back(toMsg(robot.served->name(), *robot.model, robot.velocity_before,
                            robot.energy_before, robot.base_pose, header));
    const Eigen::VectorXd torques =
        robot.model->restingContactTorques(rigid_count + static_cast<int>(r), points, impulses);
    answers.back().contact_joint_torques.assign(torques.data(), torques.data() + torques.size());
    const robot::ArticulatedBody& model = *robot.model;
    for (int joint = 0; joint < model.jointCount(); ++joint)
      answers.back().joint_velocity_limits.push_back(model.velocityLimit(joint));
    const Eigen::VectorXd impulse =
        robot::impactJointImpulses(model, rigid_count + static_cast<int>(r), points, impulses);
    answers.back().joint_impulses.assign(impulse.data(), impulse.data() + impulse.size());
  }
  return answers;
}

void addSafetyOutputs(const std::vector<core::BodyModel*>& models,
                      const std::vector<core::ContactPoint>& points,
                      const std::vector<core::ContactImpulse>& impulses,
                      const std::vector<RequestRobot>& robots,
                      ComputeResponse::Response& response) {
  for (const core::ContactSafety& contact : core::contactSafety(models, points, impulses)) {
    response.reflected_masses_a.push_back(contact.reflected_mass_a);
    response.reflected_masses_b.push_back(contact.reflected_mass_b);
    response.approach_speeds.push_back(contact.approach_speed);
    response.transferred_energies.push_back(contact.transferred_energy);
  }
  for (std::size_t r = 0; r < robots.size(); ++r) {
    const std::string field = "robots[" + std::to_string(r) + "]";
    for (const core::Warning& warning : robot::velocityLimitWarnings(*robots[r].model, field))
      response.warnings.push_back(warning.text());
  }
}

std::vector<std::string> velocityLabels(const std::vector<int>& velocity_offset, int rigid_count,
                                        const std::vector<RequestRobot>& robots) {
  std::vector<std::string> velocities;
  for (std::size_t b = 0; b < velocity_offset.size(); ++b) {
    if (velocity_offset[b] < 0) continue;
    const int index = static_cast<int>(b);
    if (index < rigid_count) {
      const std::string name = "bodies[" + std::to_string(index) + "].twist.";
      for (const char* part : {"linear.", "angular."})
        for (const char* axis : {"x", "y", "z"}) velocities.push_back(name + part + axis);
      continue;
    }
    const std::string name = "robots[" + std::to_string(index - rigid_count) + "].";
    const robot::ArticulatedBody& model = *robots[index - rigid_count].model;
    for (int k = 0; k < model.velocityCount(); ++k) {
      const int joint = model.jointOfUnknown(k);
      if (joint >= 0) {
        velocities.push_back(name + "joint_state.velocity[" + std::to_string(joint) + "]");
      } else {
        velocities.push_back(name + "base_twist." + (k < 3 ? "linear." : "angular.") +
                             std::string(1, static_cast<char>('x' + k % 3)));
      }
    }
  }
  return velocities;
}

ImpactDerivatives toMsg(const core::BodyImpactDerivatives& derivatives, int rigid_count,
                        const std::vector<RequestRobot>& robots,
                        const std::vector<std::pair<int, int>>& coordinate_joints) {
  std::vector<std::string> rows = velocityLabels(derivatives.velocity_offset, rigid_count, robots);
  std::vector<std::string> columns = rows;
  for (std::size_t c = 0; c < derivatives.contact_count; ++c) {
    const std::string impulse = "impulses[" + std::to_string(c) + "].";
    rows.push_back(impulse + "normal_impulse");
    for (const char* axis : {"x", "y", "z"}) rows.push_back(impulse + "friction_impulse." + axis);
    const std::string contact = "contacts[" + std::to_string(c) + "].";
    for (const char* field : {"restitution", "static_friction", "dynamic_friction"})
      columns.push_back(contact + field);
  }
  for (const auto& [robot, joint] : coordinate_joints) {
    columns.push_back("robots[" + std::to_string(robot) + "].joint_state.position[" +
                      std::to_string(joint) + "]");
  }
  ImpactDerivatives msg = derivativesMsg(derivatives.method, derivatives.jacobian, std::move(rows),
                                         std::move(columns), derivatives.contacts);
  if (!coordinate_joints.empty())
    msg.joint_position_method = core::toString(derivatives.coordinate_method);
  return msg;
}

}  // namespace collision_response
