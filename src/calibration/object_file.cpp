#include "collision_response/calibration/object_file.h"

#include <Eigen/Eigenvalues>
#include <array>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "collision_response/calibration/object_model.h"
#include "collision_response/calibration/simple_yaml.h"
#include "collision_response/calibration/stl_file.h"

namespace collision_response::calibration {
namespace {

struct Reader {
  std::string source;
  [[noreturn]] void fail(const std::string& field, const std::string& what) const {
    throw std::runtime_error(source + ": " + field + ": " + what);
  }
  double number(const YamlNode& node, const std::string& field) const {
    if (node.kind != YamlNode::Kind::kScalar) fail(field, "must be a number");
    char* end = nullptr;
    const double value = std::strtod(node.scalar.c_str(), &end);
    if (end == node.scalar.c_str() || *end != '\0')
      fail(field, "must be a number, not '" + node.scalar + "'");
    if (!std::isfinite(value)) fail(field, "must be finite");
    return value;
  }
  double positive(const YamlNode& node, const std::string& field) const {
    const double value = number(node, field);
    if (!(value > 0.0)) fail(field, "must be > 0");
    return value;
  }
  const YamlNode& member(const YamlNode& map, const std::string& key,
                         const std::string& field) const {
    const YamlNode* node = map.find(key);
    if (node == nullptr) fail(field, "is missing");
    return *node;
  }
  std::string text(const YamlNode& node, const std::string& field) const {
    if (node.kind != YamlNode::Kind::kScalar || node.scalar.empty())
      fail(field, "must be a non-empty name");
    return node.scalar;
  }
  int index(const YamlNode& node, const std::string& field) const {
    if (node.kind != YamlNode::Kind::kScalar) fail(field, "must be a vertex index");
    char* end = nullptr;
    const long value = std::strtol(node.scalar.c_str(), &end, 10);
    if (end == node.scalar.c_str() || *end != '\0' || value < INT_MIN || value > INT_MAX)
      fail(field, "must be an integer vertex index, not '" + node.scalar + "'");
    return static_cast<int>(value);
  }
  /// A sequence of [a, b, c] under `key` of `map`.
  const YamlNode& triples(const YamlNode& map, const std::string& key,
                          const std::string& field) const {
    const YamlNode& list = member(map, key, field);
    if (list.kind != YamlNode::Kind::kSequence) fail(field, "must be a list [[a, b, c], ...]");
    for (std::size_t k = 0; k < list.items.size(); ++k) {
      if (list.items[k].kind != YamlNode::Kind::kSequence || list.items[k].items.size() != 3)
        fail(field + "[" + std::to_string(k) + "]", "must be [a, b, c]");
    }
    return list;
  }
  void onlyKeys(const YamlNode& map, const std::string& field,
                std::initializer_list<const char*> keys) const {
    for (const auto& [k, v] : map.map) {
      bool known = false;
      for (const char* key : keys) known |= k == key;
      if (!known) fail(field.empty() ? k : field + "." + k, "unknown key");
    }
  }
};

}  // namespace

ObjectModel parseObjectModel(const std::string& text, const std::string& source) {
  const Reader r{source};
  const YamlNode root = parseYaml(text, source);
  r.onlyKeys(root, "",
             {"shape", "mass", "inertia", "material_a", "material_b", "floor_height", "position",
              "orientation"});
  ObjectModel object;
  object.source = source;
  const YamlNode& shape = r.member(root, "shape", "shape");
  if (shape.kind != YamlNode::Kind::kMapping) r.fail("shape", "must be a mapping {type: ...}");
  const std::string type = r.text(r.member(shape, "type", "shape.type"), "shape.type");
  if (type == "box") {
    r.onlyKeys(shape, "shape", {"type", "size"});
    const YamlNode& size = r.member(shape, "size", "shape.size");
    if (size.kind != YamlNode::Kind::kSequence || size.items.size() != 3)
      r.fail("shape.size", "must be [x, y, z]");
    object.shape.type = detection::Shape::Type::kBox;
    for (int i = 0; i < 3; ++i)
      object.shape.dimensions.push_back(
          r.positive(size.items[i], "shape.size[" + std::to_string(i) + "]"));
  } else if (type == "sphere") {
    r.onlyKeys(shape, "shape", {"type", "radius"});
    object.shape.type = detection::Shape::Type::kSphere;
    object.shape.dimensions = {
        r.positive(r.member(shape, "radius", "shape.radius"), "shape.radius")};
  } else if (type == "cylinder") {
    r.onlyKeys(shape, "shape", {"type", "radius", "length"});
    object.shape.type = detection::Shape::Type::kCylinder;
    object.shape.dimensions = {
        r.positive(r.member(shape, "length", "shape.length"), "shape.length"),
        r.positive(r.member(shape, "radius", "shape.radius"), "shape.radius")};
  } else if (type == "mesh") {
    r.onlyKeys(shape, "shape", {"type", "vertices", "triangles", "file", "scale"});
    if (const YamlNode* file = shape.find("file")) {
      if (shape.find("vertices") != nullptr || shape.find("triangles") != nullptr)
        r.fail("shape.file", "give either file or vertices and triangles, not both");
      const double scale =
          shape.find("scale") != nullptr ? r.positive(*shape.find("scale"), "shape.scale") : 1.0;
      std::filesystem::path path = r.text(*file, "shape.file");
      if (path.is_relative()) path = std::filesystem::path(source).parent_path() / path;
      try {
        object.shape = readStl(path.string(), scale);
      } catch (const std::exception& e) {
        r.fail("shape.file", e.what());
      }
      if (const std::string problem = meshProblem(object.shape); !problem.empty())
        r.fail("shape.file", path.string() + ": " + problem);
    } else {
      if (shape.find("scale") != nullptr) r.fail("shape.scale", "only with shape.file");
      object.shape.type = detection::Shape::Type::kMesh;
      const YamlNode& vertices = r.triples(shape, "vertices", "shape.vertices");
      for (std::size_t k = 0; k < vertices.items.size(); ++k) {
        Eigen::Vector3d v;
        for (int i = 0; i < 3; ++i)
          v[i] = r.number(vertices.items[k].items[i],
                          "shape.vertices[" + std::to_string(k) + "][" + std::to_string(i) + "]");
        object.shape.vertices.push_back(v);
      }
      const YamlNode& triangles = r.triples(shape, "triangles", "shape.triangles");
      for (std::size_t k = 0; k < triangles.items.size(); ++k) {
        std::array<int, 3> t;
        for (int i = 0; i < 3; ++i)
          t[i] = r.index(triangles.items[k].items[i],
                         "shape.triangles[" + std::to_string(k) + "][" + std::to_string(i) + "]");
        object.shape.triangles.push_back(t);
      }
      if (const std::string problem = meshProblem(object.shape); !problem.empty())
        throw std::runtime_error(source + ": " + problem);
    }
  } else {
    r.fail("shape.type", "must be box, sphere, cylinder or mesh (not '" + type + "')");
  }
  object.mass = r.positive(r.member(root, "mass", "mass"), "mass");
  if (const YamlNode* inertia = root.find("inertia")) {
    if (inertia->kind != YamlNode::Kind::kSequence ||
        (inertia->items.size() != 3 && inertia->items.size() != 9))
      r.fail("inertia", "must be [ixx, iyy, izz] or 9 numbers (row-major)");
    if (inertia->items.size() == 3) {
      for (int i = 0; i < 3; ++i)
        object.inertia(i, i) = r.positive(inertia->items[i], "inertia[" + std::to_string(i) + "]");
    } else {
      for (int i = 0; i < 9; ++i)
        object.inertia(i / 3, i % 3) =
            r.number(inertia->items[i], "inertia[" + std::to_string(i) + "]");
    }
    if (!object.inertia.isApprox(object.inertia.transpose(), 1e-9))
      r.fail("inertia", "must be symmetric");
    if (!(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(object.inertia).eigenvalues().minCoeff() >
          0.0))
      r.fail("inertia", "must be positive definite");
  } else {
    if (object.shape.type == detection::Shape::Type::kMesh) {
      // Uniform density puts the centre of mass at the solid's centroid: it must be the origin.
      const Eigen::Vector3d centroid = meshVolume(object.shape).centroid;
      if (!(centroid.norm() <= 1e-3 * lengthScale(object.shape))) {
        std::ostringstream at;
        at << "the mesh's centroid (" << centroid.x() << ", " << centroid.y() << ", "
           << centroid.z()
           << ") m is not the origin, which is the centre of mass: move the vertices, or give "
              "inertia";
        r.fail("shape", at.str());
      }
    }
    object.inertia = uniformInertia(object.shape, object.mass);
  }
  object.material_a = r.text(r.member(root, "material_a", "material_a"), "material_a");
  object.material_b = r.text(r.member(root, "material_b", "material_b"), "material_b");
  if (const YamlNode* floor = root.find("floor_height"))
    object.floor_height = r.number(*floor, "floor_height");
  if (const YamlNode* position = root.find("position")) {
    if (position->kind != YamlNode::Kind::kSequence || position->items.size() != 3)
      r.fail("position", "must be [x, y, z]");
    for (int i = 0; i < 3; ++i)
      object.position[i] = r.number(position->items[i], "position[" + std::to_string(i) + "]");
  }
  if (const YamlNode* orientation = root.find("orientation")) {
    if (orientation->kind != YamlNode::Kind::kSequence || orientation->items.size() != 4)
      r.fail("orientation", "must be [qw, qx, qy, qz]");
    double v[4];
    for (int i = 0; i < 4; ++i)
      v[i] = r.number(orientation->items[i], "orientation[" + std::to_string(i) + "]");
    const Eigen::Quaterniond q(v[0], v[1], v[2], v[3]);
    if (!(std::abs(q.norm() - 1.0) <= 1e-3)) r.fail("orientation", "must be a unit quaternion");
    object.orientation = q.normalized();
  }
  return object;
}

ObjectModel loadObjectModel(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot read");
  std::stringstream text;
  text << in.rdbuf();
  return parseObjectModel(text.str(), path);
}

}  // namespace collision_response::calibration
