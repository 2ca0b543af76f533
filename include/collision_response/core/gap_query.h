#pragma once

#include <Eigen/Core>
#include <vector>

#include "collision_response/core/body_state.h"

namespace collision_response::core {

/// One candidate contact between two bodies' shapes at given poses: the closest features of a
/// pair, with their signed distance. What an episode (episode.h) asks of the geometry.
struct GapContact {
  int body_a = -1;  ///< index into the bodies given to GapQuery::gaps()
  int body_b = -1;  ///< index into the bodies; body_a < body_b is not required
  /// The contact point, world [m]: on the surface of body_a's shape, or midway between the two
  /// closest points (either is within the query's tolerance of the other when touching).
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< unit, world, from body_a towards body_b
  /// Signed distance along the normal [m]: > 0 apart, 0 touching, < 0 penetrating.
  double gap = 0.0;
  // The pair's coefficients (their materials, or the query's defaults).
  double restitution = 0.0;       ///< e in [0, 1]
  double static_friction = 0.0;   ///< mu_s >= 0
  double dynamic_friction = 0.0;  ///< 0 <= mu_d <= mu_s
  /// Optional, false unless the query can promise all of this (a box, a convex mesh's vertices or
  /// a sphere against a plane): body_a is immovable and not turning, its surface here the plane
  /// through `point` with normal `normal`, and `gap` is the distance of one fixed material point of
  /// body_b (a vertex; a sphere's centre) to that plane less a constant (0; the sphere's radius);
  /// and every such point of the pair within the query's range is listed. An episode then bounds
  /// each point's gap to second order (its normal velocity now, its acceleration bounded by
  /// gravity and the body's turning) instead of the pair's closing speed, which takes far fewer
  /// steps. Wrongly set, contacts can be missed.
  bool point_on_plane = false;
};

/// The geometry an episode follows: the bodies' shapes, queried at the poses of the moment.
/// Implemented in the detection library from primitives, meshes and planes
/// (detection/shape_gaps.h); tests may implement it from closed forms. Thread safety: gaps() is
/// const and may be called from several threads at once on one query.
class GapQuery {
 public:
  virtual ~GapQuery() = default;

  /// Appends to `out` (cleared first) the candidate contacts of every pair of bodies whose gap is
  /// at most `range` [m], at the poses of `bodies` (position, orientation; the other fields are not
  /// read). A pair touching along an edge or a face gives the points that span the contact (the
  /// corners of the touching face, the ends of the edge), each with its own gap, so that a body
  /// tilting onto a face sees each corner's gap. Pairs farther apart than `range` may be left out;
  /// a pair with no geometry never appears. The answer must depend on the poses and `range`
  /// only: an episode reuses it while the poses stay (after an impact) at the same range, or at
  /// a smaller one when every contact is point_on_plane (then keeping those within it).
  virtual void gaps(const std::vector<BodyState>& bodies, double range,
                    std::vector<GapContact>& out) const = 0;

  /// A bound on how far any point of body i's geometry lies from its centre of mass [m] (infinite
  /// for unbounded shapes such as planes; those bodies are immovable). Conservative advancement
  /// bounds the rate at which a gap can close from it: |v| + |w| * radius(i).
  virtual double radius(int body) const = 0;

  /// Whether body i's geometry is one convex solid (false unless the query can promise it; a
  /// plane or several shapes are not). For a pair of convex bodies the plane through a contact of
  /// the pair's smallest gap, normal to its `normal`, separates them by that gap (up to the query's
  /// accuracy), so an episode may bound the gap's closing by the pair's normal relative velocity
  /// plus what turning and acceleration can add, and a pair moving apart takes long steps. Wrongly
  /// true, contacts can be missed.
  virtual bool convex(int /*body*/) const { return false; }

  /// The support of body i's geometry about its centre of mass (BodyState::com): the largest
  /// direction . (x - com) over its points x, `direction` in the body frame (any length) [m times
  /// its length]. An episode bounds how fast turning moves a convex body's points along a pair's
  /// normal from it. The default, radius(i) |direction|, is a bound; a query may give it exactly.
  virtual double support(int body, const Eigen::Vector3d& direction) const {
    return radius(body) * direction.norm();
  }

  /// The number of bodies the geometry describes (gaps() needs that many states).
  virtual int bodyCount() const = 0;
};

}  // namespace collision_response::core
