#pragma once

#include <memory>
#include <vector>

#include "collision_response/core/gap_query.h"
#include "collision_response/detection/detect_contacts.h"
#include "collision_response/detection/materials.h"

namespace collision_response::detection {

/// core::GapQuery from the bodies' shapes (primitives, meshes, planes): what an episode needs to
/// find the next contact. Pairs with closed forms are answered without FCL (a sphere, a box or a
/// convex mesh against a plane: the signed distance of each vertex / the sphere's lowest point);
/// other pairs by FCL's signed distance between the shapes. The coefficients of a pair come from
/// the material table as for detectContacts().
class ShapeGaps final : public core::GapQuery {
 public:
  /// Validates `input` (validateGeometry(), materials) for `body_count` bodies and prepares the
  /// shapes once. Throws core::InvalidInput naming the field.
  ShapeGaps(const DetectionInput& input, const MaterialTable& materials, int body_count);
  ~ShapeGaps() override;

  void gaps(const std::vector<core::BodyState>& bodies, double range,
            std::vector<core::GapContact>& out) const override;
  double radius(int body) const override;
  int bodyCount() const override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace collision_response::detection
