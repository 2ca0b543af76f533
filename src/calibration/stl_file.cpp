#include "collision_response/calibration/stl_file.h"

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace collision_response::calibration {
namespace {

/// Merges equal vertices while triangles are added.
struct MeshBuilder {
  detection::Shape shape;
  std::map<std::array<double, 3>, int> index;
  double scale = 1.0;

  int vertex(const std::array<double, 3>& p) {
    const auto [it, added] = index.emplace(p, static_cast<int>(shape.vertices.size()));
    if (added) shape.vertices.emplace_back(scale * p[0], scale * p[1], scale * p[2]);
    return it->second;
  }
  void triangle(const std::array<std::array<double, 3>, 3>& corners) {
    shape.triangles.push_back({vertex(corners[0]), vertex(corners[1]), vertex(corners[2])});
  }
};

float littleEndianFloat(const unsigned char* bytes) {
  const std::uint32_t bits = std::uint32_t(bytes[0]) | std::uint32_t(bytes[1]) << 8 |
                             std::uint32_t(bytes[2]) << 16 | std::uint32_t(bytes[3]) << 24;
  float value;
  std::memcpy(&value, &bits, sizeof value);
  return value;
}

void readBinary(const std::string& data, const std::string& path, MeshBuilder& mesh) {
  const auto* bytes = reinterpret_cast<const unsigned char*>(data.data());
  const std::size_t count = (data.size() - 84) / 50;
  for (std::size_t k = 0; k < count; ++k) {
    const unsigned char* facet = bytes + 84 + 50 * k + 12;  // after the normal
    std::array<std::array<double, 3>, 3> corners;
    for (int v = 0; v < 3; ++v) {
      for (int i = 0; i < 3; ++i) {
        corners[v][i] = littleEndianFloat(facet + 12 * v + 4 * i);
        if (!std::isfinite(corners[v][i]))
          throw std::runtime_error(path + ": triangle " + std::to_string(k) +
                                   ": non-finite coordinate");
      }
    }
    mesh.triangle(corners);
  }
}

void readAscii(const std::string& data, const std::string& path, MeshBuilder& mesh) {
  std::istringstream lines(data);
  std::string line;
  std::vector<std::array<double, 3>> loop;
  bool in_loop = false;
  for (int number = 1; std::getline(lines, line); ++number) {
    std::istringstream words(line);
    std::string word;
    if (!(words >> word)) continue;
    const std::string where = path + ":" + std::to_string(number) + ": ";
    if (word == "outer") {
      if (in_loop) throw std::runtime_error(where + "'outer loop' inside a loop");
      in_loop = true;
      loop.clear();
    } else if (word == "vertex") {
      if (!in_loop) throw std::runtime_error(where + "'vertex' outside 'outer loop'");
      std::array<double, 3> p;
      for (double& x : p) {
        std::string text;
        char* end = nullptr;
        if (!(words >> text) || (x = std::strtod(text.c_str(), &end), *end != '\0'))
          throw std::runtime_error(where + "'vertex' needs three numbers");
        if (!std::isfinite(x)) throw std::runtime_error(where + "non-finite coordinate");
      }
      loop.push_back(p);
    } else if (word == "endloop") {
      if (!in_loop || loop.size() != 3)
        throw std::runtime_error(where + "a facet's loop must have exactly 3 vertices");
      mesh.triangle({loop[0], loop[1], loop[2]});
      in_loop = false;
    } else if (word != "solid" && word != "facet" && word != "endfacet" && word != "endsolid") {
      throw std::runtime_error(where + "unexpected '" + word + "' (not an ASCII STL?)");
    }
  }
  if (in_loop) throw std::runtime_error(path + ": ends inside a facet");
}

}  // namespace

detection::Shape readStl(const std::string& path, double scale) {
  if (!(scale > 0.0) || !std::isfinite(scale))
    throw std::runtime_error(path + ": the scale must be finite and > 0");
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error))  // not a directory, a FIFO, /dev/zero...
    throw std::runtime_error(path + ": cannot read (not a regular file)");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot read");
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string data = buffer.str();
  MeshBuilder mesh;
  mesh.scale = scale;
  mesh.shape.type = detection::Shape::Type::kMesh;
  bool binary = false;
  if (data.size() >= 84) {
    const auto* b = reinterpret_cast<const unsigned char*>(data.data()) + 80;
    const std::uint64_t count = std::uint32_t(b[0]) | std::uint32_t(b[1]) << 8 |
                                std::uint32_t(b[2]) << 16 | std::uint32_t(b[3]) << 24;
    binary = data.size() == 84 + 50 * count;
  }
  const bool ascii = data.compare(0, 5, "solid") == 0;
  if (binary) {
    readBinary(data, path, mesh);
  } else if (ascii) {
    readAscii(data, path, mesh);
  } else {
    throw std::runtime_error(path +
                             ": neither a binary STL (84 + 50 n bytes) nor an ASCII one ('solid')");
  }
  if (mesh.shape.triangles.empty()) throw std::runtime_error(path + ": no triangle");
  return mesh.shape;
}

}  // namespace collision_response::calibration
