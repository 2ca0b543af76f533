#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <vector>

namespace collision_response::detection {

/// One piece of collision geometry of a body, mirroring the fields of moveit_msgs/CollisionObject
/// (shape_msgs/SolidPrimitive, shape_msgs/Mesh, shape_msgs/Plane). Lengths in metres; everything is
/// expressed in the body frame (the frame placed by core::BodyState::position / orientation).
struct Shape {
  enum class Type { kBox, kSphere, kCylinder, kCone, kMesh, kPlane };
  Type type = Type::kBox;

  /// Primitives (shape_msgs/SolidPrimitive conventions, all centred on the shape frame's origin):
  ///   kBox:      [x, y, z]        full side lengths along the shape frame's axes [m]
  ///   kSphere:   [radius]         [m]
  ///   kCylinder: [height, radius] axis along the shape frame's z, centred (caps at +-height/2)
  ///   kCone:     [height, radius] axis along z, centred on its bounding box: base disc at
  ///                               z = -height/2, apex at z = +height/2
  /// kPlane: the coefficients [a, b, c, d] of shape_msgs/Plane: the points with
  ///   a x + b y + c z + d = 0 (shape frame) form the surface, the solid is the half-space
  ///   a x + b y + c z + d <= 0, and the normal (a, b, c) points OUT of the solid (towards free
  ///   space). (a, b, c) need not be unit: it is normalised (with d) before use.
  /// kMesh: unused (empty).
  std::vector<double> dimensions;

  /// kMesh only (shape_msgs/Mesh): vertices in the shape frame [m] and triangles as indices into
  /// vertices. A mesh whose vertices all lie on one side of every triangle's plane (a convex
  /// polyhedron, e.g. a convex hull) is treated as that solid convex polyhedron; any other mesh
  /// as a triangle soup (surface only).
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<int, 3>> triangles;

  /// Placement of the shape frame in the body frame (primitive_poses / mesh_poses / plane_poses).
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();

  bool isPrimitive() const { return type != Type::kMesh && type != Type::kPlane; }
};

/// The collision geometry of one body of a scene: the union of its shapes, possibly empty (a body
/// without geometry never gets detected contacts).
///
/// Field names in errors follow moveit_msgs/CollisionObject: shapes are numbered per kind, in the
/// order they appear in `shapes`: primitives (box, sphere, cylinder, cone) as "primitives[i]",
/// meshes as "meshes[i]", planes as "planes[i]". A ROS layer converting a CollisionObject should
/// therefore append its primitives, then its meshes, then its planes, each in message order. That
/// layer also checks that primitive_poses / mesh_poses / plane_poses have as many entries as
/// primitives / meshes / planes ("bodies[0].primitive_poses": count mismatch): it cannot be
/// represented here, where every Shape carries its own pose.
struct BodyGeometry {
  std::vector<Shape> shapes;
};

/// Checks geometry for detection and throws core::InvalidInput naming the first offending field:
///  - "bodies": geometry is neither empty (no geometry at all) nor one entry per body
///    (body_count);
///  - "bodies[i].primitives[j].dimensions": wrong count for the type (box 3, sphere 1, cylinder
///    2, cone 2), or a size that is not finite and > 0;
///  - "bodies[i].primitive_poses[j]" / "mesh_poses[j]" / "plane_poses[j]": a pose with a
///    non-finite entry or a linear part that is not a rotation;
///  - "bodies[i].meshes[j].vertices[k]": non-finite; "bodies[i].meshes[j].triangles": empty;
///    "bodies[i].meshes[j].triangles[k]": an index out of range or a repeated index;
///  - "bodies[i].planes[j]": not 4 coefficients, non-finite, or a zero normal (a, b, c).
void validateGeometry(const std::vector<BodyGeometry>& geometry, std::size_t body_count);

}  // namespace collision_response::detection
