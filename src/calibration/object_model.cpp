#include "collision_response/calibration/object_model.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <utility>

namespace collision_response::calibration {

using detection::Shape;

double lowestPointHeight(const Shape& shape, const Eigen::Vector3d& position,
                         const Eigen::Quaterniond& orientation) {
  const Eigen::Matrix3d R = orientation.toRotationMatrix();
  switch (shape.type) {
    case Shape::Type::kBox:
      // The corner whose signs oppose the third row of the rotation.
      return position.z() -
             0.5 * (R.row(2).cwiseAbs().transpose().array() *
                    Eigen::Vector3d(shape.dimensions[0], shape.dimensions[1], shape.dimensions[2])
                        .array())
                       .sum();
    case Shape::Type::kSphere:
      return position.z() - shape.dimensions[0];
    case Shape::Type::kCylinder: {
      // The lowest rim point of the lower cap: half the height along the axis, the radius across.
      const double az = std::abs(R(2, 2));
      return position.z() - 0.5 * shape.dimensions[0] * az -
             shape.dimensions[1] * std::sqrt(std::max(0.0, 1.0 - az * az));
    }
    case Shape::Type::kMesh: {
      double lowest = std::numeric_limits<double>::infinity();
      for (const auto& v : shape.vertices) lowest = std::min(lowest, R.row(2).dot(v));
      return position.z() + lowest;
    }
    default:
      throw std::invalid_argument("calibration: only box, sphere, cylinder and mesh shapes");
  }
}

double lengthScale(const Shape& shape) {
  switch (shape.type) {
    case Shape::Type::kBox:
      return 0.5 * *std::max_element(shape.dimensions.begin(), shape.dimensions.end());
    case Shape::Type::kSphere:
      return shape.dimensions[0];
    case Shape::Type::kCylinder:
      return std::max(shape.dimensions[1], 0.5 * shape.dimensions[0]);
    case Shape::Type::kMesh: {
      Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
      Eigen::Vector3d hi = -lo;
      for (const auto& v : shape.vertices) {
        lo = lo.cwiseMin(v);
        hi = hi.cwiseMax(v);
      }
      return 0.5 * (hi - lo).maxCoeff();
    }
    default:
      throw std::invalid_argument("calibration: only box, sphere, cylinder and mesh shapes");
  }
}

Eigen::Matrix3d uniformInertia(const Shape& shape, double mass) {
  const auto& d = shape.dimensions;
  switch (shape.type) {
    case Shape::Type::kBox:
      return (mass / 12.0 *
              Eigen::Vector3d(d[1] * d[1] + d[2] * d[2], d[0] * d[0] + d[2] * d[2],
                              d[0] * d[0] + d[1] * d[1]))
          .asDiagonal();
    case Shape::Type::kSphere:
      return 0.4 * mass * d[0] * d[0] * Eigen::Matrix3d::Identity();
    case Shape::Type::kCylinder: {
      const double h = d[0], r = d[1];
      const double across = mass * (3.0 * r * r + h * h) / 12.0;
      return Eigen::Vector3d(across, across, 0.5 * mass * r * r).asDiagonal();
    }
    case Shape::Type::kMesh: {
      // Per triangle (a, b, c), the signed tetrahedron (0, a, b, c) of volume det[a b c] / 6 has
      // the second moment V / 20 (a a' + b b' + c c' + s s'), s = a + b + c; summed over a closed
      // mesh these give the enclosed solid's (with the sign of the winding, which the ratio to the
      // summed volume cancels).
      double volume = 0.0;
      Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
      for (const auto& t : shape.triangles) {
        const Eigen::Vector3d& a = shape.vertices[t[0]];
        const Eigen::Vector3d& b = shape.vertices[t[1]];
        const Eigen::Vector3d& c = shape.vertices[t[2]];
        const double v = a.dot(b.cross(c)) / 6.0;
        const Eigen::Vector3d s = a + b + c;
        volume += v;
        second += v / 20.0 *
                  (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose());
      }
      const Eigen::Matrix3d per_mass = second / volume;
      return mass * (per_mass.trace() * Eigen::Matrix3d::Identity() - per_mass);
    }
    default:
      throw std::invalid_argument("calibration: only box, sphere, cylinder and mesh shapes");
  }
}

MeshVolume meshVolume(const Shape& mesh) {
  MeshVolume out;
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d& a = mesh.vertices[t[0]];
    const Eigen::Vector3d& b = mesh.vertices[t[1]];
    const Eigen::Vector3d& c = mesh.vertices[t[2]];
    const double v = a.dot(b.cross(c)) / 6.0;
    out.volume += v;
    first += v / 4.0 * (a + b + c);
  }
  if (out.volume != 0.0) out.centroid = first / out.volume;
  out.volume = std::abs(out.volume);
  return out;
}

std::string meshProblem(const Shape& mesh) {
  const int n = static_cast<int>(mesh.vertices.size());
  if (n < 4)
    return "shape.vertices: a closed mesh needs at least 4 vertices, not " + std::to_string(n);
  for (int k = 0; k < n; ++k) {
    if (!mesh.vertices[k].allFinite())
      return "shape.vertices[" + std::to_string(k) + "]: must be finite";
  }
  if (mesh.triangles.size() < 4)
    return "shape.triangles: a closed mesh needs at least 4 triangles, not " +
           std::to_string(mesh.triangles.size());
  std::vector<char> used(n, 0);
  // Each directed edge i -> j of a closed, consistently wound mesh is in exactly one triangle and
  // its reverse in exactly one other.
  std::map<std::pair<int, int>, int> edges;
  for (std::size_t k = 0; k < mesh.triangles.size(); ++k) {
    const auto& t = mesh.triangles[k];
    const std::string field = "shape.triangles[" + std::to_string(k) + "]";
    for (int i : t) {
      if (i < 0 || i >= n)
        return field + ": index " + std::to_string(i) + " is not a vertex (0.." +
               std::to_string(n - 1) + ")";
      used[i] = 1;
    }
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) return field + ": repeats a vertex";
    for (int e = 0; e < 3; ++e) {
      if (++edges[{t[e], t[(e + 1) % 3]}] > 1)
        return field + ": its edge " + std::to_string(t[e]) + "-" + std::to_string(t[(e + 1) % 3]) +
               " is in another triangle in the same direction (the triangles must be wound "
               "consistently, and each edge shared by two triangles)";
    }
  }
  for (int k = 0; k < n; ++k) {
    if (!used[k]) return "shape.vertices[" + std::to_string(k) + "]: is in no triangle";
  }
  for (const auto& [edge, count] : edges) {
    if (edges.find({edge.second, edge.first}) == edges.end())
      return "shape.triangles: the mesh is open: edge " + std::to_string(edge.first) + "-" +
             std::to_string(edge.second) + " belongs to one triangle only";
  }
  const double length = lengthScale(mesh);
  const MeshVolume solid = meshVolume(mesh);
  if (!std::isfinite(length * length * length) || !std::isfinite(solid.volume))
    return "shape.vertices: too large (the solid's volume integrals overflow)";
  if (!(solid.volume > 1e-9 * length * length * length))
    return "shape.triangles: the mesh encloses no volume";
  if (!solid.centroid.allFinite() || !uniformInertia(mesh, 1.0).allFinite())
    return "shape.vertices: too large (the solid's volume integrals overflow)";
  return "";
}

}  // namespace collision_response::calibration
