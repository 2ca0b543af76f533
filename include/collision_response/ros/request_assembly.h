#pragma once

// Request assembly for CollisionResponseServer: a ~compute request's bodies in the request frame
// (tf2), the robots it involves at their state (base poses from the request or tf2), their links as
// bodies of detection, the body models and the contacts placed on them. Small free functions over
// the served robots and a tf2 buffer; the server keeps the callbacks (collision_response_server.h).

#include <collision_response/ComputeResponse.h>
#include <collision_response/ImpactDerivatives.h>
#include <collision_response/RobotResult.h>
#include <collision_response/RobotState.h>
#include <ros/duration.h>
#include <ros/time.h>
#include <tf2_ros/buffer.h>

#include <Eigen/Geometry>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "collision_response/core/body_impact_derivatives.h"
#include "collision_response/core/body_model.h"
#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/scene.h"
#include "collision_response/core/validation.h"
#include "collision_response/detection/shapes.h"
#include "collision_response/robot/articulated_body.h"
#include "collision_response/ros/response_markers.h"
#include "collision_response/ros/served_robot.h"

namespace collision_response {

/// The served robots (~robots, in order).
using ServedRobots = std::vector<std::unique_ptr<ServedRobot>>;

/// The served robot called `name`, or nullptr.
ServedRobot* findServedRobot(const ServedRobots& robots, const std::string& name);

/// Whether a request involves robots: it lists some, or a contact names an id that is no body's
/// and starts with a served robot's name and '/' ("<robot>/<link>").
bool involvesRobots(const ComputeResponse::Request& request, const ServedRobots& robots);

/// The request's bodies and contacts as a core scene in the request frame (header.frame_id): a body
/// whose frame_id is another frame is transformed by the tf2 transform at header.stamp (waiting at
/// most `timeout`). Sizes are checked against `limits` first. Throws core::InvalidInput naming
/// "bodies[i].frame_id" when the transform is not available. Nothing else is validated.
core::Scene sceneInRequestFrame(const ComputeResponse::Request& request, const tf2_ros::Buffer& tf,
                                const ros::Duration& timeout, const core::RequestLimits& limits);

/// Whether the request's contacts are to be found from the bodies' shapes (detection.mode);
/// `robot_geometry`: a robot taking part has link collision geometry (MODE_AUTO counts it). Throws
/// core::InvalidInput naming "detection.mode" for an unknown mode.
bool wantsDetection(const ComputeResponse::Request& request, bool robot_geometry = false);

/// A robot taking part in a request: the served robot, its message (the request's, or a default
/// one for a robot only named by contacts), and its body at the request's state.
struct RequestRobot {
  ServedRobot* served = nullptr;
  RobotState message;
  std::string field;  ///< "robots[i]", or "contacts[k]" (the first contact naming it)
  Eigen::Isometry3d base_pose = Eigen::Isometry3d::Identity();  ///< root link, request frame
  std::optional<robot::ArticulatedBody> model;  ///< at the request's state (placeRobots())
  Eigen::VectorXd velocity_before;              ///< its velocity unknowns before the impact
  double energy_before = 0.0;                   ///< [J] kinetic energy before the impact
};

/// The robots a request involves, in order: those listed in request.robots, then those only named
/// by its contacts ("<robot>/<link>" that is not the id of one of `scene_bodies`). Their states are
/// not set yet (placeRobots()). Throws core::InvalidInput naming "robots[i].name" for a name no
/// served robot has or one listed twice.
std::vector<RequestRobot> requestRobots(const ComputeResponse::Request& request,
                                        const std::vector<core::BodyState>& scene_bodies,
                                        const ServedRobots& served);

/// A robot's base pose (its root link in the request frame `header.frame_id`): the request's
/// (basePoseFromMsg()), else the tf2 transform of its base frame at header.stamp (waiting at most
/// `timeout`). Throws core::InvalidInput naming robot.field + ".base_pose..." for a bad pose, or
/// when none is given and tf2 has none.
Eigen::Isometry3d robotBasePose(const RequestRobot& robot, const std_msgs::Header& header,
                                const tf2_ros::Buffer& tf, const ros::Duration& timeout);

/// Each robot at its state: base pose (robotBasePose()), joints from the request or the latest
/// joint states no older than `joint_state_timeout` [s] at `now` (robotAtRequestState(), which
/// adds its warnings to `warnings`), and its velocity and kinetic energy before the impact.
void placeRobots(std::vector<RequestRobot>& robots, const std_msgs::Header& header,
                 const tf2_ros::Buffer& tf, const ros::Duration& timeout, const ros::Time& now,
                 double joint_state_timeout, std::vector<std::string>& warnings);

/// The robots' links as ids contacts may name (SceneValidator::addOtherBodyIds()): `ids[k]` is
/// "<robot>/<link>", link `robot_link[k].second` of robots[robot_link[k].first].
struct RobotLinkIds {
  std::vector<std::string> ids;
  std::vector<std::pair<int, int>> robot_link;  ///< (robot, link) of ids[k]
};
RobotLinkIds robotLinkIds(const std::vector<RequestRobot>& robots);

/// Whether any of the robots has link collision geometry.
bool anyRobotGeometry(const std::vector<RequestRobot>& robots);

/// Robots' links as bodies of detection: each link with collision geometry placed at its pose
/// (request frame), in the collision group of its robot (links of one robot are never paired).
struct LinkBodies {
  std::vector<core::BodyState> bodies;  ///< id "<robot>/<link>", pose linkPose(link), 1 kg
  std::vector<const detection::BodyGeometry*> geometry;  ///< link frame, the served robot's
  std::vector<int> groups;    ///< the robot's index in the request's robots
  std::vector<int> link_ids;  ///< the link's index in robotLinkIds(robots).ids
  std::size_t shapes = 0, vertices = 0, triangles = 0;  ///< totals, for the request limits
};

/// The links with collision geometry of the placed robots (placeRobots()) as bodies of detection
/// (robot::linkBody(): at the link's pose, a stand-in mass; detection reads only poses and shapes).
LinkBodies linkBodies(const std::vector<RequestRobot>& robots);

/// The body indices of detected contacts (detection::DetectedContacts::bodies, indices into the
/// scene's `rigid_count` bodies followed by links.bodies) in the numbering of
/// core::SceneValidator::contactBodies() with the robots' link ids added (robotLinkIds()): a rigid
/// body keeps its index, link body k becomes rigid_count + links.link_ids[k]. No id is looked up.
std::vector<std::pair<int, int>> detectedContactBodies(
    const std::vector<std::pair<int, int>>& detected, int rigid_count, const LinkBodies& links);

/// The body models of a request: the rigid bodies (models 0 .. rigid.size() - 1, built by
/// core::makeRigidBodies() with their free accelerations), then one per placed robot. The pointers
/// are into `rigid` and `robots`.
std::vector<core::BodyModel*> bodyModels(std::vector<core::RigidBody>& rigid,
                                         std::vector<RequestRobot>& robots);

/// Per contact point, the frame of the robot link it lies on (for the markers,
/// response_markers.h): a contact on a robot's link (part_a, else part_b >= 0) gets the link's
/// name and pose in the request frame; others an empty frame. Robots are the models from
/// `rigid_count` on.
std::vector<ContactLinkFrame> contactLinkFrames(const std::vector<core::ContactPoint>& points,
                                                const std::vector<RequestRobot>& robots,
                                                int rigid_count);

/// The robots' answers, in order: each robot after the impact (`model`), the joint torques
/// [N m | N] its resting contacts take (ArticulatedBody::restingContactTorques() with `impulses`,
/// the robot being model rigid_count + r), and the safety outputs per joint: the velocity limits
/// and the impact's joint impulses (robot/joint_safety.h). Frames: the request's `header`.
std::vector<RobotResult> robotAnswers(const std::vector<RequestRobot>& robots, int rigid_count,
                                      const std::vector<core::ContactPoint>& points,
                                      const std::vector<core::ContactImpulse>& impulses,
                                      const std_msgs::Header& header);

/// The safety outputs per contact (docs/robots.md, "Safety outputs"): the response's
/// reflected_masses_a / _b, approach_speeds and transferred_energies from core::contactSafety()
/// over `models` (the bodies after the impact: the masses depend on the configuration only) and
/// the answer's `impulses`; and a warning "robots[r].joint_state.velocity[j]: ..." in `warnings`
/// for each joint that the impact leaves beyond its velocity limit (r the answer's robot index).
void addSafetyOutputs(const std::vector<core::BodyModel*>& models,
                      const std::vector<core::ContactPoint>& points,
                      const std::vector<core::ContactImpulse>& impulses,
                      const std::vector<RequestRobot>& robots, ComputeResponse::Response& response);

/// The labels of the velocity unknowns of a request's body models (bodyModels(): rigid bodies
/// 0 .. rigid_count - 1, then the robots), body b's from velocity_offset[b] (-1: none):
/// "bodies[i].twist.linear.x" .. "angular.z", a floating robot's "robots[r].base_twist.linear.x"
/// .. "angular.z", then "robots[r].joint_state.velocity[j]" per free joint j.
std::vector<std::string> velocityLabels(const std::vector<int>& velocity_offset, int rigid_count,
                                        const std::vector<RequestRobot>& robots);

/// The Jacobians of a request with robots as the response's `derivatives` (ImpactDerivatives.msg):
/// rows and columns labelled by the fields they are read from, the rigid bodies' twists
/// "bodies[i].twist.linear.x" .. (the models before `rigid_count`, those with unknowns), each
/// robot's unknowns "robots[r].base_twist.linear.x" .. (floating) and
/// "robots[r].joint_state.velocity[j]" (a free joint, or a mimic group's root), the impulses and
/// coefficients per contact as for rigid bodies, then one column per configuration coordinate,
/// "robots[r].joint_state.position[j]" for coordinate_joints[k] = (r, j).
ImpactDerivatives toMsg(const core::BodyImpactDerivatives& derivatives, int rigid_count,
                        const std::vector<RequestRobot>& robots,
                        const std::vector<std::pair<int, int>>& coordinate_joints = {});

}  // namespace collision_response
