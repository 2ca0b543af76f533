#include "collision_response/calibration/object_model.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

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
    default:
      throw std::invalid_argument("calibration: only box, sphere and cylinder shapes");
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
    default:
      throw std::invalid_argument("calibration: only box, sphere and cylinder shapes");
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
    default:
      throw std::invalid_argument("calibration: only box, sphere and cylinder shapes");
  }
}

}  // namespace collision_response::calibration
