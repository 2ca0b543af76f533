// A triangle mesh from an STL file (binary or ASCII), for the object file's `shape: {type: mesh,
// file: ...}` (docs/calibration.md, "The object file").
#pragma once

#include <string>

#include "collision_response/detection/shapes.h"

namespace collision_response::calibration {

/// Reads `path` (binary STL when its size is 84 + 50 n bytes for the n triangles its header
/// states, ASCII "solid ... facet ... outer loop vertex x y z ..." otherwise) into a kMesh shape:
/// coordinates times `scale` (> 0; e.g. 0.001 for a file in millimetres) [m], vertices at equal
/// coordinates merged into one (STL repeats them per triangle), triangles in file order with the
/// file's winding. Facet normals are ignored. Throws std::runtime_error "<path>: <what>" (with
/// the line for ASCII) if the file is not a regular file or cannot be read, is truncated or
/// malformed, holds a non-finite coordinate or no triangle. The mesh is not otherwise checked
/// (meshProblem() does that).
detection::Shape readStl(const std::string& path, double scale = 1.0);

}  // namespace collision_response::calibration
