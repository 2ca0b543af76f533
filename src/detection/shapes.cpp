#include "collision_response/detection/shapes.h"

#include <cmath>
#include <sstream>
#include <string>

#include "collision_response/core/errors.h"
#include "collision_response/core/validation.h"

namespace collision_response::detection {

namespace {

std::string indexed(const std::string& prefix, std::size_t i) {
  return prefix + "[" + std::to_string(i) + "]";
}

// Lengths beyond core::MagnitudeLimits::kLength are rejected like the bodies' positions.
void checkLength(double length, const std::string& field) {
  if (length > core::MagnitudeLimits::kLength) {
    std::ostringstream os;
    os << "length " << length << " m exceeds the accepted " << core::MagnitudeLimits::kLength
       << " m";
    throw core::InvalidInput(field, os.str());
  }
}

/// field: a callable giving the pose's field name (spelled out only for an error).
template <typename Field>
void checkPose(const Eigen::Isometry3d& pose, const Field& field) {
  if (!pose.matrix().allFinite()) throw core::InvalidInput(field(), "has a non-finite entry");
  const Eigen::Matrix3d r = pose.linear();
  const double err = (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (err > 1e-6 || r.determinant() < 0.0)
    throw core::InvalidInput(field(), "is not a rigid transform");
  const double length = pose.translation().norm();
  if (length > core::MagnitudeLimits::kLength) checkLength(length, field() + ".position");
}

}  // namespace

void validateGeometry(const std::vector<BodyGeometry>& geometry, std::size_t body_count) {
  if (!geometry.empty() && geometry.size() != body_count) {
    throw core::InvalidInput("bodies", "geometry given for " + std::to_string(geometry.size()) +
                                           " bodies, expected " + std::to_string(body_count) +
                                           " (or none)");
  }
  // Field names are only spelled out for an error: this runs on every detection call.
  for (std::size_t b = 0; b < geometry.size(); ++b) {
    std::size_t primitive = 0, mesh = 0, plane = 0;
    for (const Shape& shape : geometry[b].shapes) {
      switch (shape.type) {
        case Shape::Type::kBox:
        case Shape::Type::kSphere:
        case Shape::Type::kCylinder:
        case Shape::Type::kCone: {
          auto field = [&] { return indexed("bodies", b) + indexed(".primitives", primitive); };
          const std::size_t expected =
              shape.type == Shape::Type::kBox ? 3 : (shape.type == Shape::Type::kSphere ? 1 : 2);
          if (shape.dimensions.size() != expected) {
            throw core::InvalidInput(field() + ".dimensions",
                                     "has " + std::to_string(shape.dimensions.size()) +
                                         " values, expected " + std::to_string(expected));
          }
          for (std::size_t k = 0; k < expected; ++k) {
            const double v = shape.dimensions[k];
            if (!std::isfinite(v) || !(v > 0.0)) {
              std::ostringstream os;
              os << "must be finite and > 0 (entry " << k << " is " << v << ")";
              throw core::InvalidInput(field() + ".dimensions", os.str());
            }
            if (v > core::MagnitudeLimits::kLength) checkLength(v, field() + ".dimensions");
          }
          checkPose(shape.pose,
                    [&] { return indexed("bodies", b) + indexed(".primitive_poses", primitive); });
          ++primitive;
          break;
        }
        case Shape::Type::kMesh: {
          auto field = [&] { return indexed("bodies", b) + indexed(".meshes", mesh); };
          if (shape.vertices.empty()) throw core::InvalidInput(field() + ".vertices", "is empty");
          for (std::size_t k = 0; k < shape.vertices.size(); ++k) {
            if (!shape.vertices[k].allFinite()) {
              throw core::InvalidInput(field() + indexed(".vertices", k), "is not finite");
            }
            const double length = shape.vertices[k].norm();
            if (length > core::MagnitudeLimits::kLength) {
              checkLength(length, field() + indexed(".vertices", k));
            }
          }
          if (shape.triangles.empty()) throw core::InvalidInput(field() + ".triangles", "is empty");
          const long n = static_cast<long>(shape.vertices.size());
          for (std::size_t k = 0; k < shape.triangles.size(); ++k) {
            const auto& t = shape.triangles[k];
            for (int idx : t) {
              if (idx < 0 || idx >= n) {
                throw core::InvalidInput(field() + indexed(".triangles", k),
                                         "vertex index " + std::to_string(idx) +
                                             " is out of range [0, " + std::to_string(n) + ")");
              }
            }
            if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
              throw core::InvalidInput(field() + indexed(".triangles", k),
                                       "repeats a vertex index");
            }
          }
          checkPose(shape.pose,
                    [&] { return indexed("bodies", b) + indexed(".mesh_poses", mesh); });
          ++mesh;
          break;
        }
        case Shape::Type::kPlane: {
          auto field = [&] { return indexed("bodies", b) + indexed(".planes", plane); };
          if (shape.dimensions.size() != 4) {
            throw core::InvalidInput(field(), "has " + std::to_string(shape.dimensions.size()) +
                                                  " coefficients, expected 4");
          }
          for (double v : shape.dimensions) {
            if (!std::isfinite(v))
              throw core::InvalidInput(field(), "has a non-finite coefficient");
          }
          const double norm =
              Eigen::Vector3d(shape.dimensions[0], shape.dimensions[1], shape.dimensions[2]).norm();
          if (!(norm > 1e-12)) throw core::InvalidInput(field(), "has a zero normal (a, b, c)");
          const double offset = std::abs(shape.dimensions[3]) / norm;
          if (offset > core::MagnitudeLimits::kLength) checkLength(offset, field() + ".coef[3]");
          checkPose(shape.pose,
                    [&] { return indexed("bodies", b) + indexed(".plane_poses", plane); });
          ++plane;
          break;
        }
      }
    }
  }
}

// ------------------------------------------------------------------------------------------------
// Geometry helpers
// ------------------------------------------------------------------------------------------------

}  // namespace collision_response::detection
