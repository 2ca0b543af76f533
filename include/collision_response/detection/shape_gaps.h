#pragma once

#include <memory>
#include <vector>

#include "collision_response/core/gap_query.h"
#include "collision_response/core/solver_options.h"
#include "collision_response/detection/detect_contacts.h"
#include "collision_response/detection/materials.h"

namespace collision_response::detection {

/// core::GapQuery from the bodies' shapes (primitives, meshes, planes): what an episode needs to
/// find the next contact (docs/detection.md, "Gaps for impact episodes").
///
/// Pairs with a plane are answered in closed form, without FCL: the signed distance to the plane
/// of a sphere's lowest point, of each corner of a box, of each vertex of a mesh (convex or not),
/// of the lowest rim point of each cap of a cylinder and of 16 points around each rim, of a cone's
/// apex, the lowest point of its base rim and 16 points around that rim. Every such point whose
/// gap is at most the query's range is a contact (at most
/// DetectionInput::options.max_contacts_per_pair per pair of shapes, the deepest always kept): a
/// tilting face shows each corner with its own gap. The smallest gap of a pair is exact.
///
/// Every other pair of shapes goes to ContactDetector with contact_tolerance = range: FCL's
/// signed distance (or penetration) between the shapes, then the manifold of their support
/// features within DetectionOptions::feature_band = min(range, kFeatureBand) of the support plane,
/// each point with its own gap. A pair apart by at most range thus reports its true distance (the
/// smallest gap of its points) however large range is; a pair apart by more reports nothing.
///
/// Coefficients per pair from the material table, as detectContacts(). Pairs of two immovable
/// bodies (mass 0 in the states given to the constructor), of one body, or of one collision group
/// (>= 0) never appear.
///
/// Thread safety: gaps() is const and may run on several threads at once; each call borrows one
/// of the query's detectors (a lock-free pool; a call finding every one busy uses a fresh one),
/// so no call waits on another.
class ShapeGaps final : public core::GapQuery {
 public:
  /// Points of a support feature farther than this from the support plane [m] are left out of an
  /// FCL pair's manifold even when the range is larger (a band as wide as a body would mix the
  /// vertices of several faces into one feature).
  static constexpr double kFeatureBand = 1e-3;
  /// The largest range gaps() takes [m]: FCL's broadphase inflates every bounding box by the range,
  /// and boxes of ~1e200 m overflow its tree's costs (a null child, a segmentation fault). An
  /// episode asks for at most max(1 m, 1e4 contact tolerances) of at most 1 m each.
  static constexpr double kMaxRange = 1e12;

  /// Validates and prepares the shapes once: `input` as detectContacts() does (geometry with
  /// validateGeometry(), sizes against `limits`, material names against `materials`, the default
  /// coefficients "detection.restitution"...; options.max_contacts_per_pair >= 1), and from
  /// `bodies` (one per body, the scene's states at any time) only what does not change: which
  /// bodies are immovable (mass 0) and their centres of mass (BodyState::com, body frame), about
  /// which radius() is measured. Throws core::InvalidInput naming the field ("bodies" for a count
  /// mismatch, "bodies[i].com", "bodies[i].mass", "bodies[i].primitives[j].dimensions",
  /// "bodies[i].material", ...). input.options.contact_tolerance and deadline are not used (each
  /// call's range replaces the tolerance).
  ShapeGaps(const std::vector<core::BodyState>& bodies, const DetectionInput& input,
            const MaterialTable& materials, const core::RequestLimits& limits = {});
  ~ShapeGaps() override;
  ShapeGaps(const ShapeGaps&) = delete;
  ShapeGaps& operator=(const ShapeGaps&) = delete;

  /// core::GapQuery::gaps(). Reads only position and orientation (normalised) of `bodies`. Throws
  /// core::InvalidInput: "bodies" if their number is not bodyCount(), "range" unless in
  /// [0, kMaxRange], "bodies[i].position" / "bodies[i].orientation" if not finite (or a zero
  /// quaternion).
  void gaps(const std::vector<core::BodyState>& bodies, double range,
            std::vector<core::GapContact>& out) const override;
  /// Farthest point of body i's shapes from its centre of mass [m], exact for every primitive and
  /// mesh (the largest over its shapes); infinity if the body has a plane, 0 if it has no shapes.
  /// Throws std::out_of_range for i outside [0, bodyCount()).
  double radius(int body) const override;
  /// True for a body of exactly one box, sphere, cylinder or cone (meshes are not assumed
  /// convex); throws std::out_of_range as radius().
  bool convex(int body) const override;
  /// Exact over the body's shapes (the largest of theirs; infinity with a plane, 0 without
  /// shapes); throws std::out_of_range as radius().
  double support(int body, const Eigen::Vector3d& direction) const override;
  int bodyCount() const override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace collision_response::detection
