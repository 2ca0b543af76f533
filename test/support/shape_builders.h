// Collision shapes shared by the detection tests and benchmarks (core types only).
#pragma once

#include <Eigen/Geometry>
#include <utility>
#include <vector>

#include "collision_response/detection/shapes.h"

namespace collision_response::testing {

/// A primitive or plane with the dimensions (or plane coefficients) of detection::Shape.
inline detection::Shape primitive(detection::Shape::Type type, std::vector<double> dimensions,
                                  const Eigen::Isometry3d& pose = Eigen::Isometry3d::Identity()) {
  detection::Shape s;
  s.type = type;
  s.dimensions = std::move(dimensions);
  s.pose = pose;
  return s;
}

/// The closed surface of an axis-aligned box of sides x, y, z centred on the origin, as a triangle
/// mesh (its own convex hull); faces split in two triangles with deliberately mixed winding.
inline detection::Shape boxMesh(double x = 1.0, double y = 1.0, double z = 1.0) {
  detection::Shape s;
  s.type = detection::Shape::Type::kMesh;
  for (int k = 0; k < 8; ++k) {
    s.vertices.emplace_back((k & 1 ? 0.5 : -0.5) * x, (k & 2 ? 0.5 : -0.5) * y,
                            (k & 4 ? 0.5 : -0.5) * z);
  }
  const int quads[6][4] = {{0, 1, 3, 2}, {4, 5, 7, 6}, {0, 1, 5, 4},
                           {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    s.triangles.push_back({q[0], q[1], q[2]});
    s.triangles.push_back({q[0], q[2], q[3]});
  }
  return s;
}

}  // namespace collision_response::testing
