#include "collision_response/detection/manifold.h"

#include <algorithm>
#include <limits>
#include <utility>

namespace collision_response::detection {
namespace {

double cross2(const Vec2& a, const Vec2& b) {
  return a.x() * b.y() - a.y() * b.x();
}

}  // namespace

PlanarFeature planeFeature(const Vec3& outward_normal, double offset) {
  PlanarFeature f;
  f.kind = PlanarFeature::Kind::kPlane;
  f.has_plane = true;
  f.plane_n = outward_normal;
  f.plane_d = offset;
  return f;
}

/// Projects a 3D feature and classifies it as a point, a segment or a convex polygon (delta: the
/// size below which extents vanish). outward: the direction the feature faces (out of its shape).
PlanarFeature projectFeature(const std::vector<Vec3>& pts, const ContactPlaneBasis& b,
                             const Vec3& outward, double delta) {
  const std::size_t n = pts.size();
  std::vector<Vec2> q(n);
  for (std::size_t k = 0; k < n; ++k) q[k] = b.flat(pts[k]);
  std::vector<int> idx(n);
  for (std::size_t k = 0; k < n; ++k) idx[k] = static_cast<int>(k);
  std::sort(idx.begin(), idx.end(), [&](int i, int j) {
    return q[i].x() < q[j].x() || (q[i].x() == q[j].x() && q[i].y() < q[j].y());
  });
  // Andrew's monotone chain, counter-clockwise, collinear points dropped.
  std::vector<int> hull;
  if (n == 1) {
    hull = idx;
  } else {
    std::vector<int> h(2 * n);
    std::size_t k = 0;
    for (std::size_t i = 0; i < n; ++i) {
      while (k >= 2 && cross2(q[h[k - 1]] - q[h[k - 2]], q[idx[i]] - q[h[k - 2]]) <= 0.0) --k;
      h[k++] = idx[i];
    }
    for (std::size_t i = n - 1, t = k + 1; i-- > 0;) {
      while (k >= t && cross2(q[h[k - 1]] - q[h[k - 2]], q[idx[i]] - q[h[k - 2]]) <= 0.0) --k;
      h[k++] = idx[i];
    }
    h.resize(k - 1);
    hull = std::move(h);
  }
  // Diameter and width.
  int i0 = hull[0], i1 = hull[0];
  double diam = 0.0;
  for (int a : hull) {
    for (int c : hull) {
      const double dd = (q[a] - q[c]).norm();
      if (dd > diam) diam = dd, i0 = a, i1 = c;
    }
  }
  PlanarFeature f;
  if (diam <= delta) {
    f.kind = PlanarFeature::Kind::kPoint;
    f.poly = {q[hull[0]]};
    f.pts = {pts[hull[0]]};
    return f;
  }
  const Vec2 dir = (q[i1] - q[i0]) / diam;
  double width = 0.0;
  for (int a : hull) width = std::max(width, std::abs(cross2(dir, q[a] - q[i0])));
  if (hull.size() < 3 || width <= delta) {
    f.kind = PlanarFeature::Kind::kSegment;
    f.poly = {q[i0], q[i1]};
    f.pts = {pts[i0], pts[i1]};
    return f;
  }
  f.kind = PlanarFeature::Kind::kPolygon;
  f.poly.reserve(hull.size());
  f.pts.reserve(hull.size());
  for (int a : hull) {
    f.poly.push_back(q[a]);
    f.pts.push_back(pts[a]);
  }
  // Newell's plane through the polygon.
  Vec3 normal = Vec3::Zero(), centre = Vec3::Zero();
  for (std::size_t k = 0; k < f.pts.size(); ++k) {
    const Vec3& a = f.pts[k];
    const Vec3& c = f.pts[(k + 1) % f.pts.size()];
    normal += Vec3((a.y() - c.y()) * (a.z() + c.z()), (a.z() - c.z()) * (a.x() + c.x()),
                   (a.x() - c.x()) * (a.y() + c.y()));
    centre += a;
  }
  centre /= static_cast<double>(f.pts.size());
  if (normal.norm() > 0.0) {
    normal.normalize();
    if (normal.dot(outward) < 0.0) normal = -normal;
    f.has_plane = true;
    f.plane_n = normal;
    f.plane_d = normal.dot(centre);
  }
  return f;
}

/// Sutherland-Hodgman: subject clipped by the convex, counter-clockwise polygon clip.
std::vector<Vec2> clipPolygon(std::vector<Vec2> subject, const std::vector<Vec2>& clip,
                              double delta) {
  for (std::size_t e = 0; e < clip.size() && !subject.empty(); ++e) {
    const Vec2 c0 = clip[e], c1 = clip[(e + 1) % clip.size()];
    const Vec2 edge = c1 - c0;
    const double len = edge.norm();
    auto side = [&](const Vec2& p) { return cross2(edge, p - c0) / len + delta; };
    std::vector<Vec2> out;
    out.reserve(2 * subject.size());  // each vertex gives at most itself and a crossing
    for (std::size_t k = 0; k < subject.size(); ++k) {
      const Vec2& p = subject[k];
      const Vec2& r = subject[(k + 1) % subject.size()];
      const double sp = side(p), sr = side(r);
      if (sp >= 0.0) out.push_back(p);
      if ((sp >= 0.0) != (sr >= 0.0)) out.push_back(p + (r - p) * (sp / (sp - sr)));
    }
    subject = std::move(out);
  }
  return subject;
}

/// The part of segment s0-s1 inside the convex, counter-clockwise polygon clip.
std::vector<Vec2> clipSegment(const Vec2& s0, const Vec2& s1, const std::vector<Vec2>& clip,
                              double delta) {
  double lo = 0.0, hi = 1.0;
  for (std::size_t e = 0; e < clip.size(); ++e) {
    const Vec2 c0 = clip[e], edge = clip[(e + 1) % clip.size()] - c0;
    const double len = edge.norm();
    const double f0 = cross2(edge, s0 - c0) / len + delta;
    const double f1 = cross2(edge, s1 - c0) / len + delta;
    if (f0 < 0.0 && f1 < 0.0) return {};
    if (f0 < 0.0) lo = std::max(lo, f0 / (f0 - f1));
    if (f1 < 0.0) hi = std::min(hi, f0 / (f0 - f1));
  }
  if (lo > hi) return {};
  return {s0 + lo * (s1 - s0), s0 + hi * (s1 - s0)};
}

/// Overlap of two nearly collinear segments, as the pairs of facing points at the overlap's ends
/// (nothing if they are not within offset of each other there: crossing or apart). Two curved
/// surfaces in line contact (parallel cylinders) give parallel lines only as far apart as the
/// error of the normal allows, hence the offset.
std::vector<Vec2> overlapSegments(const PlanarFeature& a, const PlanarFeature& b, double offset) {
  const Vec2 d = a.poly[1] - a.poly[0];
  const double len2 = d.squaredNorm();
  const double t0 = (b.poly[0] - a.poly[0]).dot(d) / len2;
  const double t1 = (b.poly[1] - a.poly[0]).dot(d) / len2;
  if (std::abs(t1 - t0) * std::sqrt(len2) <= 1e-12) return {};
  const double lo = std::max(0.0, std::min(t0, t1)), hi = std::min(1.0, std::max(t0, t1));
  if (lo > hi) return {};
  std::vector<Vec2> out;
  for (double t : {lo, hi}) {
    const Vec2 pa = a.poly[0] + t * d;
    const Vec2 pb = b.poly[0] + (t - t0) / (t1 - t0) * (b.poly[1] - b.poly[0]);
    if ((pa - pb).norm() > offset) return {};
    out.push_back(0.5 * (pa + pb));
  }
  return out;
}

/// The contact region in the plane: the intersection of the two features, empty when it is a
/// single point (or when the features do not overlap numerically).
std::vector<Vec2> contactRegion(const PlanarFeature& a, const PlanarFeature& b, double delta,
                                double offset) {
  using K = PlanarFeature::Kind;
  if (a.kind == K::kPoint || b.kind == K::kPoint) return {};
  if (a.kind == K::kPlane) return b.poly;
  if (b.kind == K::kPlane) return a.poly;
  if (a.kind == K::kPolygon && b.kind == K::kPolygon) return clipPolygon(b.poly, a.poly, delta);
  if (a.kind == K::kSegment && b.kind == K::kPolygon) {
    return clipSegment(a.poly[0], a.poly[1], b.poly, delta);
  }
  if (a.kind == K::kPolygon && b.kind == K::kSegment) {
    return clipSegment(b.poly[0], b.poly[1], a.poly, delta);
  }
  return overlapSegments(a, b, std::max(delta, offset));
}

/// Keeps at most max_count contacts: the deepest, then repeatedly the one farthest from those
/// kept (the corners of the region come first).
void reduceContacts(std::vector<DetectedContact>& contacts, std::size_t max_count) {
  if (contacts.size() <= max_count) return;
  std::size_t first = 0;
  for (std::size_t k = 1; k < contacts.size(); ++k) {
    if (contacts[k].depth > contacts[first].depth + 1e-12) first = k;
  }
  std::vector<std::size_t> kept{first};
  std::vector<double> dist(contacts.size(), std::numeric_limits<double>::infinity());
  while (kept.size() < max_count) {
    const Vec3& last = contacts[kept.back()].point;
    std::size_t best = 0;
    double best_d = -1.0;
    for (std::size_t k = 0; k < contacts.size(); ++k) {
      dist[k] = std::min(dist[k], (contacts[k].point - last).norm());
      if (dist[k] > best_d + 1e-12) best_d = dist[k], best = k;
    }
    kept.push_back(best);
  }
  std::sort(kept.begin(), kept.end());
  std::vector<DetectedContact> out;
  for (std::size_t k : kept) out.push_back(contacts[k]);
  contacts = std::move(out);
}

/// Appends c unless a contact of the list is at the same point.
void addDistinctContact(std::vector<DetectedContact>& list, const DetectedContact& c,
                        double delta) {
  for (const DetectedContact& o : list) {
    if ((o.point - c.point).norm() <= delta) return;
  }
  list.push_back(c);
}

}  // namespace collision_response::detection
