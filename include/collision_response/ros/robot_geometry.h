#pragma once

#include <urdf_model/model.h>

#include <map>
#include <string>

#include "collision_response/detection/shapes.h"

namespace collision_response {

/// The collision geometry of a robot's links, for contact detection (docs/robots.md, "Link
/// geometry"): for every link of the model, by name (an empty BodyGeometry for a link without
/// <collision>), its <collision> elements in document order, each one detection::Shape expressed
/// in the LINK frame: the frame its parent joint's <origin> (and joint motion) places, which is
/// the frame robot::ArticulatedBody::linkPose() gives in the world. So a link is placed as a body
/// whose pose is linkPose(link). Each element's <origin> becomes Shape::pose; its geometry:
///  - <box size="x y z">                 -> kBox [x, y, z] (full side lengths) [m];
///  - <sphere radius="r">                -> kSphere [r];
///  - <cylinder radius="r" length="l">   -> kCylinder [l, r] (both centred, axis along the
///                                          shape frame's z);
///  - <mesh filename="url" scale="sx sy sz"> -> kMesh: the triangles of the file (any format
///    assimp reads: STL, COLLADA, OBJ, ...), fetched with resource_retriever (package://name/...
///    found through ROS_PACKAGE_PATH, file:///absolute/path, http://), each vertex coordinate
///    multiplied by the scale component of its axis, in the file's own frame (assimp joins
///    identical vertices). A closed convex mesh is a solid for detection (shapes.h).
/// Throws std::invalid_argument naming the link and the element's index among the link's
/// collisions: "link 'hand' collision[0]: cannot load mesh 'package://...': <why>", also for a
/// size, radius, length or scale that is not finite and > 0 (a scale component may not be 0, may
/// be negative: a mirror image).
std::map<std::string, detection::BodyGeometry> linkCollisionGeometry(
    const urdf::ModelInterface& model);

/// The same from a URDF document (plain URDF, no xacro); throws std::invalid_argument if its text
/// is not UTF-8 or holds a NUL (robot::requireUrdfText()), or it does not parse.
std::map<std::string, detection::BodyGeometry> linkCollisionGeometryFromUrdf(
    const std::string& xml);

}  // namespace collision_response
