// The identification's result as the node reads it (docs/calibration.md, "Output"): entries of the
// `~materials` list ({a, b, restitution, static_friction, dynamic_friction}, as
// ros::readMaterials() takes them), with the intervals, the data and the held-out error in
// comments.
#pragma once

#include <string>
#include <vector>

#include "collision_response/calibration/cross_validation.h"
#include "collision_response/calibration/identification.h"

namespace collision_response::calibration {

/// One pair's identification and what it came from.
struct MaterialsEntry {
  std::string material_a, material_b;
  IdentificationResult fit;
  CrossValidation held_out;                          ///< folds 0: not done
  std::vector<std::string> sources;                  ///< the input files / bags
  int recordings = 0;                                ///< recordings read
  std::vector<std::pair<std::string, int>> skipped;  ///< landings skipped, by reason
  std::string method;  ///< e.g. "episode, stronge, one mu, Cauchy loss 0.25"
  /// A robot's impacts (docs/calibration.md, "Robot recordings"): the data are impacts, the errors
  /// those of the joint velocities (rms_cases), not landings' v and w.
  bool robot = false;
};

/// The YAML text: a comment header, then `materials:` with one entry per pair.
std::string materialsYaml(const std::vector<MaterialsEntry>& entries);

/// Writes `text` to `path` through a temporary file renamed over it (a failure leaves no partial
/// file). Throws std::runtime_error naming the path.
void writeFileAtomically(const std::string& path, const std::string& text);

}  // namespace collision_response::calibration
