#include "collision_response/detection/detect_contacts.h"

#include <cmath>

#include "collision_response/core/errors.h"
#include "collision_response/core/validation.h"

namespace collision_response::detection {

DetectedContacts detectContacts(ContactDetector& detector,
                                const std::vector<core::BodyState>& bodies,
                                const DetectionInput& input, const MaterialTable& materials,
                                const core::RequestLimits& limits) {
  core::requireInRange(input.options.contact_tolerance, core::option_ranges::kContactTolerance,
                       "detection.contact_tolerance", "m");
  core::validateCoefficients(input.defaults.restitution, input.defaults.static_friction,
                             input.defaults.dynamic_friction, "detection");
  if (!input.materials.empty() && input.materials.size() != bodies.size()) {
    throw core::InvalidInput("bodies", "materials given for " +
                                           std::to_string(input.materials.size()) +
                                           " bodies, expected " + std::to_string(bodies.size()));
  }
  std::size_t shapes = 0, vertices = 0, triangles = 0;
  for (const BodyGeometry& body : input.geometry) {
    shapes += body.shapes.size();
    for (const Shape& shape : body.shapes) {
      vertices += shape.vertices.size();
      triangles += shape.triangles.size();
    }
  }
  core::checkGeometrySize(shapes, vertices, triangles, limits);
  for (std::size_t i = 0; i < input.materials.size(); ++i) {
    if (!input.materials[i].empty() && !materials.knows(input.materials[i])) {
      throw core::InvalidInput("bodies[" + std::to_string(i) + "].material",
                               "'" + input.materials[i] + "' is in no entry of the material table");
    }
  }

  DetectedContacts out;
  const std::vector<DetectedContact> found =
      detector.detect(bodies, input.geometry, input.options, input.collision_groups);
  out.contacts.reserve(found.size());
  out.depths.reserve(found.size());
  out.bodies.reserve(found.size());
  static const std::string kNone;
  for (const DetectedContact& d : found) {
    const std::string& material_a = input.materials.empty() ? kNone : input.materials[d.body_a];
    const std::string& material_b = input.materials.empty() ? kNone : input.materials[d.body_b];
    const ContactMaterial m = materials.lookup(material_a, material_b, input.defaults);
    core::Contact c;
    c.body_a = bodies[d.body_a].id;
    c.body_b = bodies[d.body_b].id;
    c.point = d.point;
    c.normal = d.normal;
    c.restitution = m.restitution;
    c.static_friction = m.static_friction;
    c.dynamic_friction = m.dynamic_friction;
    out.contacts.push_back(std::move(c));
    out.depths.push_back(d.depth);
    out.bodies.emplace_back(d.body_a, d.body_b);
  }
  return out;
}

}  // namespace collision_response::detection
