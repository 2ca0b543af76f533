#pragma once

// Contact manifolds between convex shapes as pure plane geometry, without FCL (as Box2D keeps
// its manifold code apart): the support features of two shapes along the contact normal are
// projected onto the contact plane, classified (point, segment, convex polygon, plane) and clipped
// against each other; the region's points, lifted midway between the two surfaces, are the
// contacts. contact_detector.cpp finds the features with FCL's help and calls these;
// docs/detection.md.

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <vector>

#include "collision_response/detection/contact_detector.h"

namespace collision_response::detection {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;

/// An orthonormal frame (u, v, n) for projecting features onto the plane normal to n.
struct ContactPlaneBasis {
  Vec3 n, u, v;
  explicit ContactPlaneBasis(const Vec3& normal) : n(normal) {
    u = n.unitOrthogonal();
    v = n.cross(u);
  }
  Vec2 flat(const Vec3& p) const { return {u.dot(p), v.dot(p)}; }
  Vec3 lift(const Vec2& q, double t) const { return u * q.x() + v * q.y() + n * t; }
};

/// A support feature projected onto the contact plane, with its height along n.
struct PlanarFeature {
  enum class Kind { kPoint, kSegment, kPolygon, kPlane } kind = Kind::kPoint;
  std::vector<Vec2> poly;  ///< counter-clockwise; 1 point, 2 for a segment
  std::vector<Vec3> pts;   ///< the 3D points of poly
  bool has_plane = false;  ///< polygon or plane: plane_n . x = plane_d, plane_n pointing outwards
  Vec3 plane_n = Vec3::UnitZ();
  double plane_d = 0.0;

  double height(const ContactPlaneBasis& b, const Vec2& q) const {
    if (has_plane && std::abs(plane_n.dot(b.n)) >= 0.5) {
      return (plane_d - plane_n.dot(b.lift(q, 0.0))) / plane_n.dot(b.n);
    }
    if (kind == Kind::kSegment) {
      const Vec2 d = poly[1] - poly[0];
      const double t = std::clamp((q - poly[0]).dot(d) / d.squaredNorm(), 0.0, 1.0);
      return b.n.dot(pts[0] + t * (pts[1] - pts[0]));
    }
    double sum = 0.0;
    for (const Vec3& p : pts) sum += b.n.dot(p);
    return sum / static_cast<double>(pts.size());
  }
};

/// The feature of a solid half-space: the plane outward_normal . x = offset (outward_normal unit,
/// pointing out of the solid).
PlanarFeature planeFeature(const Vec3& outward_normal, double offset);

/// Projects a 3D feature and classifies it as a point, a segment or a convex polygon (delta: the
/// size below which extents vanish). outward: the direction the feature faces (out of its shape).
PlanarFeature projectFeature(const std::vector<Vec3>& pts, const ContactPlaneBasis& b,
                             const Vec3& outward, double delta);

/// Sutherland-Hodgman: subject clipped by the convex, counter-clockwise polygon clip.
std::vector<Vec2> clipPolygon(std::vector<Vec2> subject, const std::vector<Vec2>& clip,
                              double delta);

/// The part of segment s0-s1 inside the convex, counter-clockwise polygon clip.
std::vector<Vec2> clipSegment(const Vec2& s0, const Vec2& s1, const std::vector<Vec2>& clip,
                              double delta);

/// Overlap of two nearly collinear segments, as the pairs of facing points at the overlap's ends
/// (nothing if they are not within offset of each other there: crossing or apart). Two curved
/// surfaces in line contact (parallel cylinders) give parallel lines only as far apart as the
/// error of the normal allows, hence the offset.
std::vector<Vec2> overlapSegments(const PlanarFeature& a, const PlanarFeature& b, double offset);

/// The contact region in the plane: the intersection of the two features, empty when it is a
/// single point (or when the features do not overlap numerically).
std::vector<Vec2> contactRegion(const PlanarFeature& a, const PlanarFeature& b, double delta,
                                double offset);

/// Keeps at most max_count contacts: the deepest, then repeatedly the one farthest from those
/// kept (the corners of the region come first).
void reduceContacts(std::vector<DetectedContact>& contacts, std::size_t max_count);

/// Appends c unless a contact of the list is at the same point.
void addDistinctContact(std::vector<DetectedContact>& list, const DetectedContact& c, double delta);

}  // namespace collision_response::detection
