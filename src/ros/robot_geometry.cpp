#include "collision_response/ros/robot_geometry.h"

#include <geometric_shapes/mesh_operations.h>
#include <geometric_shapes/shapes.h>
#include <resource_retriever/retriever.h>
#include <urdf/model.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "collision_response/core/errors.h"
#include "collision_response/robot/urdf_text.h"

namespace collision_response {
namespace {

using detection::Shape;

/// Thrown for one <collision> element; the caller prefixes the link and the element's index.
struct ElementError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

void requirePositive(double value, const char* what) {
  if (!std::isfinite(value) || value <= 0.0) {
    std::ostringstream message;
    message << what << " must be finite and > 0, not " << value;
    throw ElementError(message.str());
  }
}

/// urdf::Pose (position [m], unit quaternion) as the shape frame's placement in the link frame.
Eigen::Isometry3d toIsometry(const urdf::Pose& pose) {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.translation() = Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z);
  const urdf::Rotation& r = pose.rotation;
  out.linear() = Eigen::Quaterniond(r.w, r.x, r.y, r.z).normalized().toRotationMatrix();
  return out;
}

/// A mesh file's triangles through resource_retriever (the URL) and assimp (geometric_shapes), in
/// the file's frame with each axis scaled.
Shape loadMesh(const urdf::Mesh& mesh) {
  const Eigen::Vector3d scale(mesh.scale.x, mesh.scale.y, mesh.scale.z);
  if (!scale.allFinite() || (scale.array() == 0.0).any()) {
    throw ElementError("mesh '" + mesh.filename + "': scale components must be finite and != 0");
  }
  resource_retriever::MemoryResource resource;
  try {
    resource = resource_retriever::Retriever().get(mesh.filename);
  } catch (const resource_retriever::Exception& e) {
    throw ElementError("cannot load mesh '" + mesh.filename + "': " + e.what());
  }
  // assimp picks its reader by the file's extension, lower case.
  std::string extension = mesh.filename.substr(mesh.filename.find_last_of('.') + 1);
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  const std::unique_ptr<shapes::Mesh> loaded(shapes::createMeshFromBinary(
      reinterpret_cast<const char*>(resource.data.get()), resource.size, scale, extension));
  if (!loaded || loaded->triangle_count == 0) {
    throw ElementError("cannot load mesh '" + mesh.filename +
                       "': no triangles (not a mesh format assimp reads, or empty)");
  }
  // geometric_shapes has assimp join identical vertices: a closed file stays one closed surface
  // (STL repeats every vertex per facet).
  Shape shape;
  shape.type = Shape::Type::kMesh;
  for (unsigned int k = 0; k < loaded->vertex_count; ++k) {
    const double* v = loaded->vertices + 3 * k;
    shape.vertices.emplace_back(v[0], v[1], v[2]);
  }
  for (unsigned int t = 0; t < loaded->triangle_count; ++t) {
    const unsigned int* tri = loaded->triangles + 3 * t;
    shape.triangles.push_back(
        {static_cast<int>(tri[0]), static_cast<int>(tri[1]), static_cast<int>(tri[2])});
  }
  return shape;
}

Shape primitive(Shape::Type type, std::vector<double> dimensions) {
  Shape shape;
  shape.type = type;
  shape.dimensions = std::move(dimensions);
  return shape;
}

/// One <collision> element as a shape in the link frame.
Shape toShape(const urdf::Collision& collision) {
  if (!collision.geometry) throw ElementError("has no <geometry>");
  const urdf::Geometry& geometry = *collision.geometry;
  Shape shape;
  switch (geometry.type) {
    case urdf::Geometry::BOX: {
      const urdf::Vector3& size = static_cast<const urdf::Box&>(geometry).dim;
      requirePositive(size.x, "box size x");
      requirePositive(size.y, "box size y");
      requirePositive(size.z, "box size z");
      shape = primitive(Shape::Type::kBox, {size.x, size.y, size.z});
      break;
    }
    case urdf::Geometry::SPHERE: {
      const double radius = static_cast<const urdf::Sphere&>(geometry).radius;
      requirePositive(radius, "sphere radius");
      shape = primitive(Shape::Type::kSphere, {radius});
      break;
    }
    case urdf::Geometry::CYLINDER: {
      const auto& cylinder = static_cast<const urdf::Cylinder&>(geometry);
      requirePositive(cylinder.length, "cylinder length");
      requirePositive(cylinder.radius, "cylinder radius");
      // Both URDF and shape_msgs centre the cylinder on its frame with the axis along z.
      shape = primitive(Shape::Type::kCylinder, {cylinder.length, cylinder.radius});
      break;
    }
    case urdf::Geometry::MESH:
      shape = loadMesh(static_cast<const urdf::Mesh&>(geometry));
      break;
    default:
      throw ElementError("unknown geometry type " + std::to_string(geometry.type));
  }
  shape.pose = toIsometry(collision.origin);
  return shape;
}

}  // namespace

std::map<std::string, detection::BodyGeometry> linkCollisionGeometry(
    const urdf::ModelInterface& model) {
  std::map<std::string, detection::BodyGeometry> out;
  for (const auto& [name, link] : model.links_) {
    detection::BodyGeometry& geometry = out[name];
    for (std::size_t k = 0; k < link->collision_array.size(); ++k) {
      try {
        if (!link->collision_array[k]) throw ElementError("is empty");
        geometry.shapes.push_back(toShape(*link->collision_array[k]));
      } catch (const ElementError& e) {
        throw std::invalid_argument("link '" + name + "' collision[" + std::to_string(k) +
                                    "]: " + e.what());
      }
    }
  }
  return out;
}

std::map<std::string, detection::BodyGeometry> linkCollisionGeometryFromUrdf(
    const std::string& xml) {
  try {
    robot::requireUrdfText(xml);  // before TinyXML, which reads past a cut UTF-8 sequence
  } catch (const core::InvalidInput& e) {
    throw std::invalid_argument(e.what());
  }
  urdf::Model model;
  if (!model.initString(xml)) throw std::invalid_argument("URDF: the document does not parse");
  return linkCollisionGeometry(model);
}

}  // namespace collision_response
