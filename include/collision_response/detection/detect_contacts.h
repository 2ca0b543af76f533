#pragma once

#include <string>
#include <utility>
#include <vector>

#include "collision_response/core/body_state.h"
#include "collision_response/core/contact.h"
#include "collision_response/core/solver_options.h"
#include "collision_response/detection/contact_detector.h"
#include "collision_response/detection/materials.h"
#include "collision_response/detection/shapes.h"

namespace collision_response::detection {

/// What contact detection needs of a scene besides the bodies' states.
struct DetectionInput {
  std::vector<BodyGeometry> geometry;  ///< empty (no geometry) or one entry per body
  /// Empty or one per body; "" = no material. A name must appear in the material table.
  std::vector<std::string> materials;
  /// Empty or one per body: bodies sharing a group >= 0 are never paired (the links of one robot,
  /// each a body, overlap where they are joined); -1 pairs with every body.
  /// ContactDetector::detect().
  std::vector<int> collision_groups;
  DetectionOptions options;  ///< contact tolerance, points per pair
  ContactMaterial defaults;  ///< coefficients of pairs the material table does not name
};

/// Contacts found from the bodies' shapes, ready for computeResponse().
struct DetectedContacts {
  std::vector<core::Contact> contacts;  ///< scene frame; normal from body_a towards body_b
  std::vector<double> depths;  ///< [m], one per contact: > 0 penetrating, 0 touching, < 0 apart
  /// One per contact: the indices of its body_a and body_b in the bodies given to
  /// detectContacts() (body_a < body_b), so that a caller keeps them instead of looking the ids up
  /// (core::SceneValidator::checkContacts() with body indices).
  std::vector<std::pair<int, int>> bodies;
};

/// Finds the contacts between `bodies` (already validated: validate()) from their geometry with
/// `detector` (which keeps its FCL objects for the next call) and gives each contact the
/// coefficients of its pair of materials (MaterialTable::lookup(), falling back to
/// input.defaults). Throws core::InvalidInput naming the field ("detection.contact_tolerance",
/// "detection.restitution", "bodies[i].primitives[j].dimensions", "bodies[i].material" for a name
/// in no table entry, "bodies" for geometry or contacts beyond the limits, ...) and
/// core::SolverTimeout past input.options.deadline.
DetectedContacts detectContacts(ContactDetector& detector,
                                const std::vector<core::BodyState>& bodies,
                                const DetectionInput& input, const MaterialTable& materials,
                                const core::RequestLimits& limits = {});

}  // namespace collision_response::detection
