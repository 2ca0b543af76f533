#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <vector>

#include "collision_response/core/body_state.h"
#include "collision_response/core/deadline.h"
#include "collision_response/detection/shapes.h"

namespace collision_response::detection {

struct DetectionOptions {
  /// Pairs closer than this (or touching, or penetrating) get contacts; pairs separated by more get
  /// none [m]. Also the height band of a support feature: the points of a shape within this
  /// distance of its support plane along the contact normal take part in the manifold, unless
  /// feature_band says otherwise.
  double contact_tolerance = 1e-3;
  /// The height band of a support feature, if >= 0 [m] (at most contact_tolerance): the points of a
  /// shape within this distance of its support plane take part in the manifold. Negative (the
  /// default): contact_tolerance. A caller asking for the distance of pairs far apart (a large
  /// contact_tolerance) keeps the band small: a band as thick as a shape mixes the vertices of
  /// several of its faces into one feature. Not finite and positive: core::InvalidInput.
  double feature_band = -1.0;
  /// At most this many points per pair of shapes (a body pair made of several shapes can have more
  /// in total); extra points are dropped keeping the deepest one and the extreme corners. >= 1.
  std::size_t max_contacts_per_pair = 8;
  /// detect() throws core::InvalidInput ("bodies") once it has found more contacts than this: a
  /// scene whose contacts the solver would refuse costs no more detection.
  std::size_t max_contacts = static_cast<std::size_t>(-1);
  /// Checked while pairs are tested; throws core::SolverTimeout once expired. Never, by default.
  core::Deadline deadline;
};

struct DetectedContact {
  int body_a = 0;  ///< index into the bodies given to detect(); always body_a < body_b
  int body_b = 0;
  /// Contact point, world [m]: midway between the two surfaces along the normal.
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< unit, world, from body_a towards body_b
  /// Along the normal [m]: > 0 penetrating by depth, 0 touching, < 0 separated by -depth (only down
  /// to -contact_tolerance).
  double depth = 0.0;
};

/// Contact detection between the bodies of a scene from their collision geometry, with FCL: a
/// dynamic AABB tree broadphase over the shapes of all bodies (bounding boxes inflated by the
/// contact tolerance; planes, whose boxes are infinite, are tested against every other shape's box
/// directly), then per candidate pair of shapes of two different bodies, not both immovable, FCL's
/// narrowphase (fcl::collide, or fcl::distance when not touching) for the normal. Between convex
/// shapes the contact manifold is built from the support features of both shapes along the normal
/// (the face, edge or vertex within the tolerance of the support plane), clipped against each
/// other: a box resting flat gives its 4 corners, a box on an edge 2 points, a cylinder on its side
/// 2, on its base the rim. Non-convex meshes give FCL's triangle contacts.
///
/// Keeps FCL collision objects between calls, per body, while the body's shapes are unchanged;
/// only the transforms are updated. Not thread-safe (one detector per thread).
class ContactDetector {
 public:
  struct Stats {
    std::size_t broadphase_pairs = 0;   ///< shape pairs whose inflated boxes overlap (any bodies)
    std::size_t narrowphase_pairs = 0;  ///< of those, pairs of two bodies that were tested exactly
    std::size_t cached_objects_reused = 0;  ///< FCL objects kept from the previous call
    std::size_t objects_built = 0;          ///< FCL objects (re)built in this call
  };

  ContactDetector();
  ~ContactDetector();
  ContactDetector(const ContactDetector&) = delete;
  ContactDetector& operator=(const ContactDetector&) = delete;
  ContactDetector(ContactDetector&&) noexcept;
  ContactDetector& operator=(ContactDetector&&) noexcept;

  /// Contacts between bodies (poses from core::BodyState::position / orientation, the orientation
  /// is normalised) with geometry (empty, or one entry per body: checked with validateGeometry(),
  /// throws core::InvalidInput). Two immovable bodies (mass 0) never get contacts. Ordered by body
  /// pair.
  ///
  /// collision_groups: empty, or one group per body (else core::InvalidInput, "bodies"). Two
  /// bodies of the same group >= 0 are never paired: the links of one robot, given as one body
  /// each, whose neighbours overlap at their joints. A negative group (-1) pairs with everything.
  std::vector<DetectedContact> detect(const std::vector<core::BodyState>& bodies,
                                      const std::vector<BodyGeometry>& geometry,
                                      const DetectionOptions& options = {},
                                      const std::vector<int>& collision_groups = {});

  /// Counters of the last detect() call.
  const Stats& lastStats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace collision_response::detection
