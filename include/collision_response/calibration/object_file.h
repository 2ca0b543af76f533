// Reading the object file of `identify --object OBJECT.yaml` (docs/calibration.md, "The object
// file"):
//
//   shape: {type: box, size: [0.1048, 0.1048, 0.1048]}   # [m]; or {type: sphere, radius: R},
//                                                        # {type: cylinder, radius: R, length: L}
//                                 # or {type: mesh, vertices: [[x, y, z], ...],
//                                 #     triangles: [[i, j, k], ...]} or {type: mesh,
//                                 #     file: part.stl, scale: 0.001} (path relative to this file)
//   mass: 0.37                     # [kg]
//   inertia: [ixx, iyy, izz]       # optional [kg m^2], body axes (or 9 numbers, row-major);
//                                  # default: uniform density
//   material_a: cube               # the object's material (the ~materials entry's a)
//   material_b: table              # the floor's material (its b)
//   floor_height: 0.0              # optional [m]: the floor's z in the recording's frame;
//                                  # default: found per recording from the object at rest
//   position: [x, y, z]            # optional [m], robot recordings: the fixed obstacle's pose
//   orientation: [qw, qx, qy, qz]  # optional, in the robot's base frame (default identity)
#pragma once

#include <string>

#include "collision_response/calibration/object_model.h"

namespace collision_response::calibration {

/// Parses an object file's text. Throws std::runtime_error "<source>: <field>: <what>" for a
/// missing or malformed field, an unknown key, a non-positive size or mass, an inertia that is not
/// symmetric positive definite, an empty material name.
ObjectModel parseObjectModel(const std::string& text, const std::string& source);

/// Reads and parses the file at `path` (errors as parseObjectModel(), or "cannot read").
ObjectModel loadObjectModel(const std::string& path);

}  // namespace collision_response::calibration
