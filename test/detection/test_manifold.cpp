// Contact manifolds as plane geometry (detection/manifold.h), without FCL: the support features of
// two shapes projected onto the contact plane and clipped against each other. Expected regions are
// worked out by hand from the coordinates.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "collision_response/detection/manifold.h"

namespace detection = collision_response::detection;
using detection::ContactPlaneBasis;
using detection::PlanarFeature;
using detection::Vec2;
using detection::Vec3;

namespace {

constexpr double kDelta = 1e-10;

// The corners of the axis-aligned square [x0, x1] x [y0, y1] at height z, counter-clockwise.
std::vector<Vec3> square(double x0, double x1, double y0, double y1, double z) {
  return {{x0, y0, z}, {x1, y0, z}, {x1, y1, z}, {x0, y1, z}};
}

// Signed area of a polygon (shoelace): positive when counter-clockwise.
double area(const std::vector<Vec2>& polygon) {
  double twice = 0.0;
  for (std::size_t k = 0; k < polygon.size(); ++k) {
    const Vec2& a = polygon[k];
    const Vec2& b = polygon[(k + 1) % polygon.size()];
    twice += a.x() * b.y() - a.y() * b.x();
  }
  return 0.5 * twice;
}

// True if `points` holds q, to 1e-9: clipping keeps points up to kDelta outside the clip polygon
// (a tolerance band, so that corners on an edge are not lost to round-off).
bool holds(const std::vector<Vec2>& points, const Vec2& q) {
  return std::any_of(points.begin(), points.end(),
                     [&](const Vec2& p) { return (p - q).norm() <= 1e-9; });
}

}  // namespace

TEST(ProjectFeature, ClassifiesPointSegmentAndPolygon) {
  const ContactPlaneBasis basis(Vec3::UnitZ());
  const PlanarFeature point = detection::projectFeature({{1, 2, 3}}, basis, Vec3::UnitZ(), kDelta);
  EXPECT_EQ(point.kind, PlanarFeature::Kind::kPoint);

  // Three collinear points (an edge with its midpoint) are a segment between the two ends.
  const PlanarFeature edge =
      detection::projectFeature({{0, 0, 1}, {1, 0, 1}, {2, 0, 1}}, basis, Vec3::UnitZ(), kDelta);
  ASSERT_EQ(edge.kind, PlanarFeature::Kind::kSegment);
  EXPECT_NEAR((edge.pts[0] - edge.pts[1]).norm(), 2.0, 1e-12);

  // A square face at z = 0.5 facing down: a polygon of area 1 with its outward plane n = -z,
  // -z . x = -0.5.
  const PlanarFeature face =
      detection::projectFeature(square(0, 1, 0, 1, 0.5), basis, -Vec3::UnitZ(), kDelta);
  ASSERT_EQ(face.kind, PlanarFeature::Kind::kPolygon);
  EXPECT_NEAR(std::abs(area(face.poly)), 1.0, 1e-12);
  EXPECT_GT(area(face.poly), 0.0) << "polygons are counter-clockwise";
  ASSERT_TRUE(face.has_plane);
  EXPECT_NEAR(face.plane_n.z(), -1.0, 1e-12);
  EXPECT_NEAR(face.plane_d, -0.5, 1e-12);
  // Its height anywhere in the plane is that of the face.
  EXPECT_NEAR(face.height(basis, Vec2(0.3, 0.7)), 0.5, 1e-12);
}

// Two unit squares, the second shifted by (0.5, 0.5): they overlap in [0.5, 1]^2.
TEST(ContactRegion, OverlappingFacesClipToTheirIntersection) {
  const ContactPlaneBasis basis(Vec3::UnitZ());
  const PlanarFeature a =
      detection::projectFeature(square(0, 1, 0, 1, 0.0), basis, Vec3::UnitZ(), kDelta);
  const PlanarFeature b =
      detection::projectFeature(square(0.5, 1.5, 0.5, 1.5, 0.0), basis, -Vec3::UnitZ(), kDelta);
  const std::vector<Vec2> region = detection::contactRegion(a, b, kDelta, 1e-3);
  ASSERT_EQ(region.size(), 4u);
  EXPECT_NEAR(std::abs(area(region)), 0.25, 1e-9);
  // The region's corners, in the basis' coordinates of the world points.
  for (const Vec3& corner : square(0.5, 1, 0.5, 1, 0.0))
    EXPECT_TRUE(holds(region, basis.flat(corner))) << corner.transpose();
}

// A box face resting on a plane: the whole face is the region (its 4 corners).
TEST(ContactRegion, FaceOnAPlaneIsTheWholeFace) {
  const ContactPlaneBasis basis(Vec3::UnitZ());
  const PlanarFeature floor = detection::planeFeature(Vec3::UnitZ(), 0.0);
  const PlanarFeature face =
      detection::projectFeature(square(-0.5, 0.5, -0.5, 0.5, 0.0), basis, -Vec3::UnitZ(), kDelta);
  const std::vector<Vec2> region = detection::contactRegion(floor, face, kDelta, 1e-3);
  ASSERT_EQ(region.size(), 4u);
  EXPECT_NEAR(std::abs(area(region)), 1.0, 1e-12);
  EXPECT_NEAR(floor.height(basis, Vec2(0.2, 0.1)), 0.0, 1e-12);
}

// An edge from x = -1 to x = 2 across the unit square [0, 1]^2 at y = 0.5: clipped to x in [0, 1].
TEST(ContactRegion, EdgeAcrossAFaceIsClippedToIt) {
  const std::vector<Vec2> clipped = detection::clipSegment(Vec2(-1.0, 0.5), Vec2(2.0, 0.5),
                                                           {{0, 0}, {1, 0}, {1, 1}, {0, 1}}, 0.0);
  ASSERT_EQ(clipped.size(), 2u);
  EXPECT_TRUE(holds(clipped, Vec2(0.0, 0.5)));
  EXPECT_TRUE(holds(clipped, Vec2(1.0, 0.5)));
  // Outside the square: nothing.
  EXPECT_TRUE(
      detection::clipSegment(Vec2(-1.0, 2.0), Vec2(2.0, 2.0), {{0, 0}, {1, 0}, {1, 1}, {0, 1}}, 0.0)
          .empty());
}

// Two parallel edges (a cylinder on its side on a box edge): [0, 2] and [1, 3] on the x axis
// overlap in [1, 2].
TEST(ContactRegion, CollinearEdgesOverlap) {
  const ContactPlaneBasis basis(Vec3::UnitZ());
  const PlanarFeature a =
      detection::projectFeature({{0, 0, 0}, {2, 0, 0}}, basis, Vec3::UnitZ(), kDelta);
  const PlanarFeature b =
      detection::projectFeature({{1, 0, 0}, {3, 0, 0}}, basis, -Vec3::UnitZ(), kDelta);
  const std::vector<Vec2> region = detection::contactRegion(a, b, kDelta, 1e-3);
  ASSERT_EQ(region.size(), 2u);
  EXPECT_TRUE(holds(region, basis.flat(Vec3(1, 0, 0))));
  EXPECT_TRUE(holds(region, basis.flat(Vec3(2, 0, 0))));
  // A point feature makes the region a single point, left to the caller: empty.
  const PlanarFeature tip = detection::projectFeature({{1, 0, 0}}, basis, -Vec3::UnitZ(), kDelta);
  EXPECT_TRUE(detection::contactRegion(a, tip, kDelta, 1e-3).empty());
}

// Eight points on a circle of radius 1, the one at angle 0 deepest: kept are the deepest first,
// then each time the point farthest from those kept: the opposite one (angle pi), then the two at
// +-pi/2 (equally far; either order).
TEST(ReduceContacts, KeepsTheDeepestAndTheExtremes) {
  std::vector<detection::DetectedContact> contacts;
  for (int k = 0; k < 8; ++k) {
    detection::DetectedContact c;
    const double angle = 2.0 * M_PI * k / 8;
    c.point = Vec3(std::cos(angle), std::sin(angle), 0.0);
    c.depth = k == 0 ? 0.002 : 0.001;
    contacts.push_back(c);
  }
  detection::reduceContacts(contacts, 4);
  ASSERT_EQ(contacts.size(), 4u);
  std::vector<Vec2> kept;
  for (const auto& c : contacts) kept.emplace_back(c.point.x(), c.point.y());
  for (const Vec2& q : {Vec2(1, 0), Vec2(-1, 0), Vec2(0, 1), Vec2(0, -1)})
    EXPECT_TRUE(holds(kept, q)) << q.transpose();
  // Fewer than the limit: unchanged.
  detection::reduceContacts(contacts, 8);
  EXPECT_EQ(contacts.size(), 4u);
}

TEST(AddDistinctContact, DropsRepeatedPoints) {
  std::vector<detection::DetectedContact> list;
  detection::DetectedContact c;
  c.point = Vec3(1, 2, 3);
  detection::addDistinctContact(list, c, 1e-9);
  detection::addDistinctContact(list, c, 1e-9);
  c.point.x() += 1e-3;
  detection::addDistinctContact(list, c, 1e-9);
  EXPECT_EQ(list.size(), 2u);
}
