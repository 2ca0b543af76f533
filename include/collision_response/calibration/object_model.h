// The recorded object and what it lands on, as calibration needs them (docs/calibration.md,
// "The object file"): its shape (for the lowest point and the contacts), mass and inertia, the
// pair of materials the coefficients are for, and the floor.
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <string>

#include "collision_response/detection/shapes.h"

namespace collision_response::calibration {

struct ObjectModel {
  std::string source;  ///< where it was read from, for messages ("cube.yaml")
  /// Box, sphere or cylinder (detection::Shape's dimensions conventions), centred on the tracked
  /// frame, whose axes are the shape's (shape.pose is the identity); or a closed mesh
  /// (Shape::vertices in the tracked frame [m], Shape::triangles; checked by meshProblem()). The
  /// tracked origin is the centre of mass.
  detection::Shape shape;
  double mass = 0.0;                                  ///< [kg], > 0
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();  ///< about the origin, body axes [kg m^2]
  std::string material_a;                             ///< the object's material
  std::string material_b;                             ///< the floor's material
  /// The floor's height in the recording's world frame [m] (z up); unset: the median lowest-point
  /// height over each recording's last samples, where the object lies at rest.
  std::optional<double> floor_height;
  /// Robot recordings only (docs/calibration.md, "Robot recordings"): the object is the fixed
  /// obstacle the robot strikes, its shape's frame at this pose in the robot's base frame [m]
  /// (mass and inertia then unused). Landings ignore it.
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
};

/// Height [m] of the shape's lowest point (world z) with its frame at (position, orientation); for
/// a mesh, its lowest vertex.
double lowestPointHeight(const detection::Shape& shape, const Eigen::Vector3d& position,
                         const Eigen::Quaterniond& orientation);

/// The length [m] that turns angular velocities into velocities in the scores and fit checks: half
/// the box's largest side, the sphere's radius, the larger of the cylinder's radius and half
/// length; for a mesh, half the largest side of its vertices' bounding box along the shape axes
/// (the same rule: a box given as a mesh has the box's length).
double lengthScale(const detection::Shape& shape);

/// Inertia [kg m^2] of the shape about its centre, body axes, for uniform density and mass [kg].
/// For a mesh: about the origin of its frame, of the solid it encloses (the volume integrals by
/// the divergence theorem, one signed tetrahedron per triangle with the origin; either winding),
/// which needs a closed, consistently wound mesh (meshProblem() empty).
Eigen::Matrix3d uniformInertia(const detection::Shape& shape, double mass);

/// The volume [m^3] a closed, consistently wound mesh encloses and its centroid [m] (mesh frame).
struct MeshVolume {
  double volume = 0.0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
};
MeshVolume meshVolume(const detection::Shape& mesh);

/// Why a mesh cannot be the object (empty if it can), naming the key under "shape." it concerns:
/// fewer than 4 vertices, a non-finite vertex, fewer than 4 triangles, an index out of range or
/// repeated in a triangle, a vertex no triangle uses, an edge not shared by exactly two triangles
/// (an open mesh) or by two of the same direction (inconsistent winding), no enclosed volume.
/// Convexity is not needed: the floor meets the object at its vertices.
std::string meshProblem(const detection::Shape& mesh);

}  // namespace collision_response::calibration
