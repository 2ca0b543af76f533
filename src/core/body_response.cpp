#include "collision_response/core/body_response.h"

#include <cmath>

#include "collision_response/core/solve_islands.h"
#include "collision_response/core/validation.h"

namespace collision_response::core {

BodyResponse computeBodyResponse(const std::vector<BodyModel*>& bodies,
                                 const std::vector<ContactPoint>& contacts,
                                 const SolverOptions& options) {
  validateContactPoints(bodies, contacts);
  BodyResponse result;
  // Normals within kUnitTolerance of unit length are normalised, as a Scene's are; the copy is
  // made only when one is not unit length to rounding.
  for (const ContactPoint& contact : contacts) {
    if (std::abs(contact.normal.squaredNorm() - 1.0) <= 1e-14) continue;
    std::vector<ContactPoint> normalised = contacts;
    for (ContactPoint& point : normalised) point.normal.normalize();
    solveIslands(bodies, normalised, options, result);
    return result;
  }
  solveIslands(bodies, contacts, options, result);
  return result;
}

}  // namespace collision_response::core
