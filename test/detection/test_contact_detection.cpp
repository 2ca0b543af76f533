// Contact detection from shapes (FCL): closed-form cases, manifolds, tolerance, broadphase,
// cache, conventions, validation.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "collision_response/core/errors.h"
#include "collision_response/detection/contact_detector.h"
#include "shape_builders.h"

namespace cr = collision_response::core;
namespace detection = collision_response::detection;
using collision_response::testing::boxMesh;
using collision_response::testing::primitive;
using Eigen::Vector3d;

namespace {

constexpr double kEps = 1e-6;

cr::BodyState body(const char* id, double mass, const Vector3d& position,
                   const Eigen::Quaterniond& q = Eigen::Quaterniond::Identity()) {
  cr::BodyState b;
  b.id = id;
  b.mass = mass;
  if (mass > 0.0) b.inertia = Eigen::Matrix3d::Identity() * 0.01 * mass;
  b.position = position;
  b.orientation = q;
  return b;
}

detection::Shape box(double x, double y, double z) {
  return primitive(detection::Shape::Type::kBox, {x, y, z});
}
detection::Shape sphere(double r) {
  return primitive(detection::Shape::Type::kSphere, {r});
}
detection::Shape cylinder(double h, double r) {
  return primitive(detection::Shape::Type::kCylinder, {h, r});
}
detection::Shape cone(double h, double r) {
  return primitive(detection::Shape::Type::kCone, {h, r});
}
detection::Shape plane(double a, double b, double c, double d,
                       const Eigen::Isometry3d& pose = Eigen::Isometry3d::Identity()) {
  return primitive(detection::Shape::Type::kPlane, {a, b, c, d}, pose);
}

/// Two disjoint tetrahedra in one mesh: not convex, handled as a triangle soup.
detection::Shape twoTetrahedra() {
  detection::Shape s;
  s.type = detection::Shape::Type::kMesh;
  for (double x0 : {-0.3, 0.3}) {
    const int base = static_cast<int>(s.vertices.size());
    s.vertices.emplace_back(x0, 0.0, 0.0);  // bottom tip
    s.vertices.emplace_back(x0 - 0.1, -0.1, 0.2);
    s.vertices.emplace_back(x0 + 0.1, -0.1, 0.2);
    s.vertices.emplace_back(x0, 0.1, 0.2);
    s.triangles.push_back({base, base + 1, base + 2});
    s.triangles.push_back({base, base + 2, base + 3});
    s.triangles.push_back({base, base + 3, base + 1});
    s.triangles.push_back({base + 1, base + 2, base + 3});
  }
  return s;
}

Eigen::Quaterniond rotation(double angle, const Vector3d& axis) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis.normalized()));
}

Eigen::Isometry3d translation(const Vector3d& t) {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.translation() = t;
  return p;
}

/// True if every expected point has a contact within tol (and the counts match).
bool samePoints(const std::vector<detection::DetectedContact>& contacts,
                const std::vector<Vector3d>& expected, double tol) {
  if (contacts.size() != expected.size()) return false;
  for (const Vector3d& e : expected) {
    bool found = false;
    for (const auto& c : contacts) found = found || (c.point - e).norm() <= tol;
    if (!found) return false;
  }
  return true;
}

std::vector<Vector3d> points(const std::vector<detection::DetectedContact>& contacts) {
  std::vector<Vector3d> p;
  for (const auto& c : contacts) p.push_back(c.point);
  return p;
}

void expectAll(const std::vector<detection::DetectedContact>& contacts, const Vector3d& normal,
               double depth, double tol = kEps) {
  for (const auto& c : contacts) {
    EXPECT_EQ(c.body_a, 0);
    EXPECT_EQ(c.body_b, 1);
    EXPECT_NEAR((c.normal - normal).norm(), 0.0, tol) << c.normal.transpose();
    EXPECT_NEAR(c.depth, depth, tol);
  }
}

std::vector<detection::DetectedContact> detectPair(
    const cr::BodyState& a, const detection::Shape& sa, const cr::BodyState& b,
    const detection::Shape& sb, const detection::DetectionOptions& options = {}) {
  detection::ContactDetector detector;
  return detector.detect({a, b}, {detection::BodyGeometry{{sa}}, detection::BodyGeometry{{sb}}},
                         options);
}

const cr::BodyState kGround = body("ground", 0.0, Vector3d::Zero());
const detection::Shape kFloor = plane(0, 0, 1, 0);

}  // namespace

TEST(ContactDetection, SphereOnPlane) {
  const auto contacts =
      detectPair(kGround, kFloor, body("ball", 1.0, Vector3d(0.3, -0.2, 0.099)), sphere(0.1));
  ASSERT_EQ(contacts.size(), 1u);
  expectAll(contacts, Vector3d::UnitZ(), 0.001);
  // Midway between the sphere's lowest point (z = -0.001) and the plane.
  EXPECT_NEAR((contacts[0].point - Vector3d(0.3, -0.2, -0.0005)).norm(), 0.0, kEps);
}

TEST(ContactDetection, TwoSpheres) {
  const auto contacts = detectPair(body("a", 1.0, Vector3d(0, 0, 0)), sphere(0.1),
                                   body("b", 1.0, Vector3d(0.29, 0, 0)), sphere(0.2));
  ASSERT_EQ(contacts.size(), 1u);
  expectAll(contacts, Vector3d::UnitX(), 0.01);
  EXPECT_NEAR((contacts[0].point - Vector3d(0.095, 0, 0)).norm(), 0.0, kEps);

  // Off-axis: normal along the centre line.
  const Vector3d cb(0.1, 0.2, -0.15);
  const auto oblique =
      detectPair(body("a", 1.0, Vector3d(0, 0, 0)), sphere(0.1), body("b", 1.0, cb), sphere(0.2));
  ASSERT_EQ(oblique.size(), 1u);
  expectAll(oblique, cb.normalized(), 0.3 - cb.norm());
}

TEST(ContactDetection, BoxFlatOnPlaneGivesFourCorners) {
  const auto q = rotation(0.5, Vector3d::UnitZ());
  const Vector3d c(0.1, 0.2, 0.0495);
  const auto contacts = detectPair(kGround, kFloor, body("box", 1.0, c, q), box(0.2, 0.4, 0.1));
  std::vector<Vector3d> corners;
  for (double sx : {-0.1, 0.1}) {
    for (double sy : {-0.2, 0.2}) {
      corners.push_back(c + q * Vector3d(sx, sy, -0.05) + Vector3d(0, 0, 0.00025));
    }
  }
  EXPECT_TRUE(samePoints(contacts, corners, kEps));
  expectAll(contacts, Vector3d::UnitZ(), 0.0005);
}

TEST(ContactDetection, BoxOnBiggerBoxGivesFourCorners) {
  const auto q = rotation(0.35, Vector3d::UnitZ());
  const Vector3d c(0.1, 0.2, 0.0999);
  const auto contacts = detectPair(body("table", 0.0, Vector3d(0, 0, -0.1)), box(1, 1, 0.2),
                                   body("box", 1.0, c, q), box(0.2, 0.2, 0.2));
  std::vector<Vector3d> corners;
  for (double sx : {-0.1, 0.1}) {
    for (double sy : {-0.1, 0.1}) {
      corners.push_back(c + q * Vector3d(sx, sy, -0.1) + Vector3d(0, 0, 0.00005));
    }
  }
  EXPECT_TRUE(samePoints(contacts, corners, kEps));
  expectAll(contacts, Vector3d::UnitZ(), 0.0001);
}

TEST(ContactDetection, BoxPartlyOverTheEdgeOfABoxIsClipped) {
  // A 0.2 box whose centre is 0.05 beyond the table's edge (x = 0.5): clipped at x = 0.5.
  const auto contacts = detectPair(body("table", 0.0, Vector3d(0, 0, -0.1)), box(1, 1, 0.2),
                                   body("box", 1.0, Vector3d(0.55, 0, 0.0999)), box(0.2, 0.2, 0.2));
  const double z = -0.00005;
  EXPECT_TRUE(samePoints(contacts,
                         {Vector3d(0.45, -0.1, z), Vector3d(0.45, 0.1, z), Vector3d(0.5, -0.1, z),
                          Vector3d(0.5, 0.1, z)},
                         kEps))
      << contacts.size();
  expectAll(contacts, Vector3d::UnitZ(), 0.0001);
}

TEST(ContactDetection, BoxOnAnEdgeGivesTheEdgesEnds) {
  // Rotated 45 degrees about x: the lowest edge runs along x at y = 0.
  const double half_diagonal = 0.1 * std::sqrt(2.0);
  const Vector3d c(0, 0, half_diagonal - 0.0005);
  const auto contacts =
      detectPair(kGround, kFloor, body("box", 1.0, c, rotation(M_PI / 4, Vector3d::UnitX())),
                 box(0.3, 0.2, 0.2));
  EXPECT_TRUE(
      samePoints(contacts, {Vector3d(-0.15, 0, -0.00025), Vector3d(0.15, 0, -0.00025)}, kEps))
      << contacts.size();
  expectAll(contacts, Vector3d::UnitZ(), 0.0005);
}

TEST(ContactDetection, CylinderOnItsSideGivesTheLinesEnds) {
  // Axis along x (height 0.4, radius 0.1).
  const auto contacts =
      detectPair(kGround, kFloor,
                 body("can", 1.0, Vector3d(0, 0.1, 0.0995), rotation(M_PI / 2, Vector3d::UnitY())),
                 cylinder(0.4, 0.1));
  EXPECT_TRUE(
      samePoints(contacts, {Vector3d(-0.2, 0.1, -0.00025), Vector3d(0.2, 0.1, -0.00025)}, kEps))
      << contacts.size();
  expectAll(contacts, Vector3d::UnitZ(), 0.0005);
}

void expectRim(const std::vector<detection::DetectedContact>& contacts, const Vector3d& axis_point,
               double radius, double z) {
  ASSERT_GE(contacts.size(), 3u);
  EXPECT_LE(contacts.size(), 8u);
  Vector3d mean = Vector3d::Zero();
  for (const auto& c : contacts) {
    const Vector3d r = c.point - axis_point;
    EXPECT_NEAR(std::hypot(r.x(), r.y()), radius, kEps);
    EXPECT_NEAR(c.point.z(), z, kEps);
    mean += c.point;
  }
  mean /= static_cast<double>(contacts.size());
  EXPECT_NEAR(mean.x(), axis_point.x(), kEps);  // symmetric about the axis
  EXPECT_NEAR(mean.y(), axis_point.y(), kEps);
}

TEST(ContactDetection, CylinderStandingGivesRimPoints) {
  const Vector3d c(0.2, 0.1, 0.1995);
  const auto contacts = detectPair(kGround, kFloor, body("can", 1.0, c), cylinder(0.4, 0.1));
  expectRim(contacts, c, 0.1, -0.00025);
  expectAll(contacts, Vector3d::UnitZ(), 0.0005);
}

TEST(ContactDetection, CylinderStandingOnABoxGivesRimPoints) {
  // Cylinder-box goes through FCL's GJK/EPA: the normal is snapped to the faces.
  const Vector3d c(0.2, 0.1, 0.1995);
  const auto contacts = detectPair(body("table", 0.0, Vector3d(0, 0, -0.1)), box(1, 1, 0.2),
                                   body("can", 1.0, c), cylinder(0.4, 0.1));
  expectRim(contacts, c, 0.1, -0.00025);
  expectAll(contacts, Vector3d::UnitZ(), 0.0005);
}

TEST(ContactDetection, CylinderOnItsSideOnABox) {
  const auto contacts =
      detectPair(body("table", 0.0, Vector3d(0, 0, -0.1)), box(1, 1, 0.2),
                 body("can", 1.0, Vector3d(0, 0.1, 0.0995), rotation(M_PI / 2, Vector3d::UnitY())),
                 cylinder(0.4, 0.1));
  EXPECT_TRUE(
      samePoints(contacts, {Vector3d(-0.2, 0.1, -0.00025), Vector3d(0.2, 0.1, -0.00025)}, 1e-5))
      << contacts.size();
  expectAll(contacts, Vector3d::UnitZ(), 0.0005, 1e-5);
}

TEST(ContactDetection, ConeOnItsBaseGivesRimPoints) {
  // Height 0.3, centred on its bounding box: the base is at z = c.z - 0.15.
  const Vector3d c(-0.1, 0.3, 0.1495);
  const auto contacts = detectPair(kGround, kFloor, body("cone", 1.0, c), cone(0.3, 0.1));
  expectRim(contacts, c, 0.1, -0.00025);
  expectAll(contacts, Vector3d::UnitZ(), 0.0005);
}

TEST(ContactDetection, ConeOnItsTipGivesOnePoint) {
  const auto contacts = detectPair(
      kGround, kFloor, body("cone", 1.0, Vector3d(0, 0, 0.1495), rotation(M_PI, Vector3d::UnitX())),
      cone(0.3, 0.1));
  ASSERT_EQ(contacts.size(), 1u);
  EXPECT_NEAR((contacts[0].point - Vector3d(0, 0, -0.00025)).norm(), 0.0, kEps);
  expectAll(contacts, Vector3d::UnitZ(), 0.0005);
}

TEST(ContactDetection, ConeOnItsSideGivesTheSlantsEnds) {
  // Tilted so that a slant line (apex to base rim, length sqrt(0.1^2 + 0.3^2)) lies on the floor;
  // the centre is 0.15 sin(atan(1/3)) = 0.04743 from that line.
  const double h = 0.15 * std::sin(std::atan(1.0 / 3.0));
  const auto contacts =
      detectPair(kGround, kFloor,
                 body("cone", 1.0, Vector3d(0, 0, h - 0.0005),
                      rotation(M_PI / 2 + std::atan(1.0 / 3.0), Vector3d::UnitX())),
                 cone(0.3, 0.1));
  ASSERT_EQ(contacts.size(), 2u);
  EXPECT_NEAR((contacts[0].point - contacts[1].point).norm(), std::sqrt(0.1), kEps);
  expectAll(contacts, Vector3d::UnitZ(), 0.0005);
}

TEST(ContactDetection, ParallelCylindersGiveTheOverlapsEnds) {
  // Both axes along x, the upper one shifted by 0.1 along x: overlap from x = -0.1 to 0.2.
  const auto contacts =
      detectPair(body("lower", 1.0, Vector3d::Zero(), rotation(M_PI / 2, Vector3d::UnitY())),
                 cylinder(0.4, 0.1),
                 body("upper", 1.0, Vector3d(0.1, 0, 0.199), rotation(M_PI / 2, Vector3d::UnitY())),
                 cylinder(0.4, 0.1));
  // GJK/EPA's normal is only good to a few milliradians here.
  EXPECT_TRUE(samePoints(contacts, {Vector3d(-0.1, 0, 0.0995), Vector3d(0.2, 0, 0.0995)}, 1e-4))
      << contacts.size();
  expectAll(contacts, Vector3d::UnitZ(), 0.001, 1e-2);
}

TEST(ContactDetection, ConvexHullOfABoxBehavesLikeTheBox) {
  const auto q = rotation(0.5, Vector3d::UnitZ());
  const Vector3d c(0.1, 0.2, 0.0495);
  const auto as_box = detectPair(kGround, kFloor, body("box", 1.0, c, q), box(0.2, 0.4, 0.1));
  const auto as_mesh = detectPair(kGround, kFloor, body("box", 1.0, c, q), boxMesh(0.2, 0.4, 0.1));
  ASSERT_EQ(as_box.size(), 4u);
  EXPECT_TRUE(samePoints(as_mesh, points(as_box), kEps));
  expectAll(as_mesh, Vector3d::UnitZ(), 0.0005);

  // And on a box (FCL's GJK/EPA for convex-box).
  const Vector3d c2(0.1, 0.2, 0.0499);
  const auto on_box = detectPair(body("table", 0.0, Vector3d(0, 0, -0.1)), box(1, 1, 0.2),
                                 body("box", 1.0, c2, q), box(0.2, 0.4, 0.1));
  const auto mesh_on_box = detectPair(body("table", 0.0, Vector3d(0, 0, -0.1)), box(1, 1, 0.2),
                                      body("box", 1.0, c2, q), boxMesh(0.2, 0.4, 0.1));
  ASSERT_EQ(on_box.size(), 4u);
  EXPECT_TRUE(samePoints(mesh_on_box, points(on_box), 1e-5));
  expectAll(mesh_on_box, Vector3d::UnitZ(), 0.0001, 1e-5);
}

TEST(ContactDetection, NonConvexMeshOnAPlaneGivesItsLowVertices) {
  const auto contacts =
      detectPair(kGround, kFloor, body("two", 1.0, Vector3d(0, 0, -0.0005)), twoTetrahedra());
  EXPECT_TRUE(samePoints(contacts, {Vector3d(-0.3, 0, -0.00025), Vector3d(0.3, 0, -0.00025)}, kEps))
      << contacts.size();
  expectAll(contacts, Vector3d::UnitZ(), 0.0005);
}

TEST(ContactDetection, NonConvexMeshOnABoxUsesFclContacts) {
  const auto contacts = detectPair(body("table", 0.0, Vector3d(0, 0, -0.1)), box(1, 1, 0.2),
                                   body("two", 1.0, Vector3d(0, 0, -0.001)), twoTetrahedra());
  ASSERT_GE(contacts.size(), 2u);
  for (const auto& c : contacts) {
    EXPECT_GT(c.normal.z(), 0.0) << c.normal.transpose();  // from the table towards the mesh
    EXPECT_NEAR(c.normal.norm(), 1.0, kEps);
    EXPECT_GE(c.depth, 0.0);
    EXPECT_NEAR(std::abs(c.point.x()), 0.3, 0.01);
  }
}

TEST(ContactDetection, ToleranceSeparatesContactsFromNone) {
  // Beyond the tolerance: nothing.
  EXPECT_TRUE(
      detectPair(kGround, kFloor, body("ball", 1.0, Vector3d(0, 0, 0.102)), sphere(0.1)).empty());
  EXPECT_TRUE(detectPair(body("a", 1.0, Vector3d::Zero()), sphere(0.1),
                         body("b", 1.0, Vector3d(0.202, 0, 0)), sphere(0.1))
                  .empty());
  // Within: contacts with negative depth.
  const auto near_plane =
      detectPair(kGround, kFloor, body("ball", 1.0, Vector3d(0, 0, 0.1005)), sphere(0.1));
  ASSERT_EQ(near_plane.size(), 1u);
  expectAll(near_plane, Vector3d::UnitZ(), -0.0005);
  EXPECT_NEAR((near_plane[0].point - Vector3d(0, 0, 0.00025)).norm(), 0.0, kEps);

  const auto near_spheres = detectPair(body("a", 1.0, Vector3d::Zero()), sphere(0.1),
                                       body("b", 1.0, Vector3d(0.2005, 0, 0)), sphere(0.1));
  ASSERT_EQ(near_spheres.size(), 1u);
  expectAll(near_spheres, Vector3d::UnitX(), -0.0005);

  // Boxes 0.5 mm apart (fcl::distance path): still the 4 corners.
  const auto near_boxes = detectPair(body("table", 0.0, Vector3d(0, 0, -0.1)), box(1, 1, 0.2),
                                     body("box", 1.0, Vector3d(0, 0, 0.1005)), box(0.2, 0.2, 0.2));
  EXPECT_EQ(near_boxes.size(), 4u);
  expectAll(near_boxes, Vector3d::UnitZ(), -0.0005);

  // Exactly touching.
  const auto touching = detectPair(body("table", 0.0, Vector3d(0, 0, -0.1)), box(1, 1, 0.2),
                                   body("box", 1.0, Vector3d(0, 0, 0.1)), box(0.2, 0.2, 0.2));
  EXPECT_EQ(touching.size(), 4u);
  expectAll(touching, Vector3d::UnitZ(), 0.0);

  // A larger tolerance takes in the farther ball.
  detection::DetectionOptions wide;
  wide.contact_tolerance = 0.01;
  EXPECT_EQ(detectPair(kGround, kFloor, body("ball", 1.0, Vector3d(0, 0, 0.102)), sphere(0.1), wide)
                .size(),
            1u);
}

TEST(ContactDetection, MaxContactsPerPairKeepsTheCorners) {
  detection::DetectionOptions one;
  one.max_contacts_per_pair = 1;
  EXPECT_EQ(
      detectPair(kGround, kFloor, body("box", 1.0, Vector3d(0, 0, 0.0495)), box(0.2, 0.4, 0.1), one)
          .size(),
      1u);
  detection::DetectionOptions four;
  four.max_contacts_per_pair = 4;
  const Vector3d c(0, 0, 0.1995);
  const auto rim = detectPair(kGround, kFloor, body("can", 1.0, c), cylinder(0.4, 0.1), four);
  ASSERT_EQ(rim.size(), 4u);
  expectRim(rim, c, 0.1, -0.00025);
}

TEST(ContactDetection, BroadphasePrunesFarPairs) {
  detection::ContactDetector detector;
  std::vector<cr::BodyState> bodies;
  std::vector<detection::BodyGeometry> geometry;
  for (int k = 0; k < 10; ++k) {
    bodies.push_back(body("b", 1.0, Vector3d(3.0 * k, 0, 1)));
    geometry.push_back({{k % 2 ? box(0.2, 0.2, 0.2) : sphere(0.1)}});
  }
  EXPECT_TRUE(detector.detect(bodies, geometry).empty());
  EXPECT_EQ(detector.lastStats().narrowphase_pairs, 0u);
  EXPECT_EQ(detector.lastStats().broadphase_pairs, 0u);

  // Bring two together: exactly one pair gets the narrowphase.
  bodies[3].position = Vector3d(6.25, 0, 1);                // body 2 is a sphere at x = 6
  EXPECT_EQ(detector.detect(bodies, geometry).size(), 0u);  // 0.05 apart
  EXPECT_EQ(detector.lastStats().narrowphase_pairs, 0u);
  bodies[3].position = Vector3d(6.1995, 0, 1);
  EXPECT_EQ(detector.detect(bodies, geometry).size(), 1u);
  EXPECT_EQ(detector.lastStats().narrowphase_pairs, 1u);

  // Boxes whose boxes are apart by less than the tolerance still reach the narrowphase.
  bodies[3].position = Vector3d(6.2005, 0, 1);
  const auto near = detector.detect(bodies, geometry);
  EXPECT_EQ(detector.lastStats().narrowphase_pairs, 1u);
  ASSERT_EQ(near.size(), 1u);
  EXPECT_NEAR(near[0].depth, -0.0005, kEps);
}

TEST(ContactDetection, TwoImmovableBodiesNeverTouch) {
  detection::ContactDetector detector;
  const auto contacts = detector.detect(
      {kGround, body("table", 0.0, Vector3d(0, 0, 0.09))},
      {detection::BodyGeometry{{kFloor}}, detection::BodyGeometry{{box(1, 1, 0.2)}}});
  EXPECT_TRUE(contacts.empty());
  EXPECT_EQ(detector.lastStats().narrowphase_pairs, 0u);
}

TEST(ContactDetection, ObjectsAreCachedWhileShapesAreUnchanged) {
  detection::ContactDetector detector;
  std::vector<cr::BodyState> bodies = {kGround, body("box", 1.0, Vector3d(0, 0, 0.0495)),
                                       body("ball", 1.0, Vector3d(1, 0, 0.099))};
  std::vector<detection::BodyGeometry> geometry = {
      {{kFloor}}, {{box(0.2, 0.4, 0.1)}}, {{sphere(0.1), sphere(0.05)}}};
  EXPECT_EQ(detector.detect(bodies, geometry).size(), 5u);
  EXPECT_EQ(detector.lastStats().objects_built, 4u);
  EXPECT_EQ(detector.lastStats().cached_objects_reused, 0u);

  // Poses change, shapes do not: everything reused, transforms updated.
  bodies[1].position.z() = 0.2;
  const auto moved = detector.detect(bodies, geometry);
  EXPECT_EQ(moved.size(), 1u);
  EXPECT_EQ(detector.lastStats().objects_built, 0u);
  EXPECT_EQ(detector.lastStats().cached_objects_reused, 4u);

  // One body's shapes change: only it is rebuilt.
  bodies[1].position.z() = 0.0495;
  geometry[1].shapes[0].dimensions[2] = 0.2;  // now 0.05 into the floor
  const auto changed = detector.detect(bodies, geometry);
  EXPECT_EQ(detector.lastStats().objects_built, 1u);
  EXPECT_EQ(detector.lastStats().cached_objects_reused, 3u);
  ASSERT_EQ(changed.size(), 5u);
  EXPECT_NEAR(changed[0].depth, 0.0505, kEps);
}

TEST(ContactDetection, NonUnitPlaneIsNormalised) {
  // 2 z - 0.2 = 0: the plane z = 0.1.
  const auto contacts = detectPair(kGround, plane(0, 0, 2, -0.2),
                                   body("ball", 1.0, Vector3d(0, 0, 0.199)), sphere(0.1));
  ASSERT_EQ(contacts.size(), 1u);
  expectAll(contacts, Vector3d::UnitZ(), 0.001);
  EXPECT_NEAR((contacts[0].point - Vector3d(0, 0, 0.0995)).norm(), 0.0, kEps);
}

TEST(ContactDetection, PlanePoseMakesAWall) {
  // A wall at x = 1 facing -x: plane x = 0 with normal (-1, 0, 0), placed at x = 1 in the body.
  const auto contacts = detectPair(kGround, plane(-1, 0, 0, 0, translation(Vector3d(1, 0, 0))),
                                   body("ball", 1.0, Vector3d(0.9005, 0.2, 0.3)), sphere(0.1));
  ASSERT_EQ(contacts.size(), 1u);
  expectAll(contacts, -Vector3d::UnitX(), 0.0005);
  EXPECT_NEAR((contacts[0].point - Vector3d(1.00025, 0.2, 0.3)).norm(), 0.0, kEps);
}

TEST(ContactDetection, ShapePosesPlaceShapesInTheBody) {
  // The body's box sits 0.3 to the side of the body's origin, itself rotated about z.
  detection::Shape offset_box = box(0.2, 0.2, 0.2);
  offset_box.pose = translation(Vector3d(0.3, 0, 0));
  const auto contacts = detectPair(
      kGround, kFloor,
      body("box", 1.0, Vector3d(0, 0, 0.0995), rotation(M_PI / 2, Vector3d::UnitZ())), offset_box);
  ASSERT_EQ(contacts.size(), 4u);
  Vector3d mean = Vector3d::Zero();
  for (const auto& c : contacts) mean += c.point / 4.0;
  EXPECT_NEAR((mean - Vector3d(0, 0.3, -0.00025)).norm(), 0.0, kEps);
}

TEST(ContactDetection, NormalPointsFromAToB) {
  const cr::BodyState lower = body("lower", 1.0, Vector3d(0, 0, 0));
  const cr::BodyState upper = body("upper", 1.0, Vector3d(0.02, 0, 0.1995));
  const auto ab = detectPair(lower, box(0.2, 0.2, 0.2), upper, box(0.2, 0.2, 0.2));
  const auto ba = detectPair(upper, box(0.2, 0.2, 0.2), lower, box(0.2, 0.2, 0.2));
  ASSERT_EQ(ab.size(), 4u);
  ASSERT_EQ(ba.size(), 4u);
  expectAll(ab, Vector3d::UnitZ(), 0.0005);
  expectAll(ba, -Vector3d::UnitZ(), 0.0005);
  EXPECT_TRUE(samePoints(ba, points(ab), kEps));

  // The same with a plane as body b.
  const auto ball_plane =
      detectPair(body("ball", 1.0, Vector3d(0, 0, 0.099)), sphere(0.1), kGround, kFloor);
  ASSERT_EQ(ball_plane.size(), 1u);
  expectAll(ball_plane, -Vector3d::UnitZ(), 0.001);
}

TEST(ContactDetection, CompoundBodies) {
  // A table top on four legs (one body) standing on the floor: 4 feet x 4 corners.
  detection::BodyGeometry table;
  table.shapes.push_back(box(1.0, 0.6, 0.04));
  table.shapes[0].pose = translation(Vector3d(0, 0, 0.72));
  for (double x : {-0.45, 0.45}) {
    for (double y : {-0.25, 0.25}) {
      detection::Shape leg = box(0.04, 0.04, 0.7);
      leg.pose = translation(Vector3d(x, y, 0.35));
      table.shapes.push_back(leg);
    }
  }
  detection::ContactDetector detector;
  const auto contacts = detector.detect({kGround, body("table", 10.0, Vector3d(0, 0, -0.0002))},
                                        {detection::BodyGeometry{{kFloor}}, table});
  EXPECT_EQ(contacts.size(), 16u);
  expectAll(contacts, Vector3d::UnitZ(), 0.0002);
  EXPECT_EQ(detector.lastStats().narrowphase_pairs, 4u);  // the top is 0.7 m up
}

TEST(ContactDetection, BodiesOfOneCollisionGroupAreNeverPaired) {
  // Three boxes 0.2 m wide resting 0.2 mm deep on the floor, the middle one overlapping both of
  // its neighbours by 1 cm (centres 0.19 m apart): the links of one robot at their joints.
  const std::vector<cr::BodyState> bodies = {
      kGround, body("link_a", 1.0, Vector3d(-0.19, 0, 0.0998)),
      body("link_b", 1.0, Vector3d(0, 0, 0.0998)), body("other", 1.0, Vector3d(0.19, 0, 0.0998))};
  const std::vector<detection::BodyGeometry> geometry = {
      {{kFloor}}, {{box(0.2, 0.2, 0.2)}}, {{box(0.2, 0.2, 0.2)}}, {{box(0.2, 0.2, 0.2)}}};
  const auto pairsOf = [](const std::vector<detection::DetectedContact>& contacts) {
    std::vector<std::pair<int, int>> pairs;
    for (const auto& c : contacts) pairs.emplace_back(c.body_a, c.body_b);
    pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
    return pairs;
  };
  using Pairs = std::vector<std::pair<int, int>>;
  detection::ContactDetector detector;
  // No groups: every overlapping pair.
  EXPECT_EQ(pairsOf(detector.detect(bodies, geometry)),
            (Pairs{{0, 1}, {0, 2}, {0, 3}, {1, 2}, {2, 3}}));
  // Bodies 1 and 2 in group 0: their overlap is skipped, body 3 (group 1) still meets body 2.
  const auto grouped = detector.detect(bodies, geometry, {}, {-1, 0, 0, 1});
  EXPECT_EQ(pairsOf(grouped), (Pairs{{0, 1}, {0, 2}, {0, 3}, {2, 3}}));
  // Each box's 4 bottom corners on the floor; boxes 2 and 3, 1 cm into each other along x, the 4
  // corners of their 0.2 m square faces.
  EXPECT_EQ(grouped.size(), 3u * 4u + 4u);
  // All of them in group 0 except the floor (-1: pairs with everything).
  EXPECT_EQ(pairsOf(detector.detect(bodies, geometry, {}, {-1, 0, 0, 0})),
            (Pairs{{0, 1}, {0, 2}, {0, 3}}));
  // Negative groups are no group: everything paired.
  EXPECT_EQ(pairsOf(detector.detect(bodies, geometry, {}, {-1, -1, -1, -1})).size(), 5u);
  try {
    detector.detect(bodies, geometry, {}, {0, 0});
    ADD_FAILURE() << "collision groups for 2 of 4 bodies were accepted";
  } catch (const cr::InvalidInput& e) {
    EXPECT_EQ(e.field(), "bodies");
  }
}

TEST(ContactDetection, BodiesWithoutGeometry) {
  detection::ContactDetector detector;
  EXPECT_TRUE(detector.detect({kGround, body("b", 1.0, Vector3d::Zero())}, {}).empty());
  EXPECT_TRUE(
      detector.detect({kGround, body("b", 1.0, Vector3d::Zero())}, {{{kFloor}}, {}}).empty());
}

namespace {
std::string errorField(const std::vector<detection::BodyGeometry>& geometry, std::size_t bodies) {
  try {
    detection::validateGeometry(geometry, bodies);
  } catch (const cr::InvalidInput& e) {
    return e.field();
  }
  return "";
}
}  // namespace

TEST(ContactDetection, GeometryValidation) {
  EXPECT_EQ(errorField({{{sphere(0.1)}}}, 1), "");
  EXPECT_EQ(errorField({{{sphere(0.1)}}}, 2), "bodies");
  EXPECT_EQ(
      errorField({{}, {}, {{sphere(0.1), primitive(detection::Shape::Type::kBox, {1, 1})}}}, 3),
      "bodies[2].primitives[1].dimensions");
  EXPECT_EQ(errorField({{{cylinder(0.2, -0.1)}}}, 1), "bodies[0].primitives[0].dimensions");
  EXPECT_EQ(errorField({{{sphere(std::nan(""))}}}, 1), "bodies[0].primitives[0].dimensions");
  detection::Shape bad_mesh = boxMesh(1, 1, 1);
  bad_mesh.triangles[3][1] = 8;
  EXPECT_EQ(errorField({{{boxMesh(1, 1, 1), bad_mesh}}}, 1), "bodies[0].meshes[1].triangles[3]");
  EXPECT_EQ(errorField({{}, {{kFloor, plane(0, 0, 0, 1)}}}, 2), "bodies[1].planes[1]");
  EXPECT_EQ(errorField({{{plane(0, 0, 1, INFINITY)}}}, 1), "bodies[0].planes[0]");
  detection::Shape skewed = sphere(0.1);
  skewed.pose.linear() *= 2.0;
  EXPECT_EQ(errorField({{{kFloor, skewed}}}, 1), "bodies[0].primitive_poses[0]");

  detection::ContactDetector detector;
  EXPECT_THROW(detector.detect({kGround}, {{{cylinder(0.2, 0.0)}}}), cr::InvalidInput);
  detection::DetectionOptions bad;
  bad.max_contacts_per_pair = 0;
  EXPECT_THROW(detector.detect({kGround}, {{{kFloor}}}, bad), cr::InvalidInput);
}
