// detection::ShapeGaps, the geometry of impact episodes, against closed forms written here: each
// corner's height over a plane (level and tilted boxes), a sphere's lowest point, the distance of
// two spheres and of two boxes, a convex-hull mesh against the box it encloses, a cylinder's and
// a cone's lowest points, the material of each pair, the radius and the support about the centre
// of mass from points sampled on each shape, which bodies are convex, invalid input named, and
// concurrent calls.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <random>
#include <thread>
#include <vector>

#include "collision_response/core/errors.h"
#include "collision_response/detection/shape_gaps.h"
#include "shape_builders.h"

namespace {

namespace core = collision_response::core;
namespace detection = collision_response::detection;
using collision_response::testing::boxMesh;
using collision_response::testing::primitive;
using Eigen::Quaterniond;
using Eigen::Vector3d;
using Type = detection::Shape::Type;

core::BodyState body(double mass, const Vector3d& position,
                     const Quaterniond& q = Quaterniond::Identity(),
                     const Vector3d& com = Vector3d::Zero()) {
  core::BodyState b;
  b.mass = mass;
  b.inertia = Eigen::Matrix3d::Identity() * 0.01;
  b.position = position;
  b.orientation = q;
  b.com = com;
  return b;
}

detection::Shape floorPlane() {
  return primitive(Type::kPlane, {0.0, 0.0, 1.0, 0.0});
}

detection::DetectionInput inputOf(std::vector<std::vector<detection::Shape>> shapes) {
  detection::DetectionInput input;
  for (auto& s : shapes) input.geometry.push_back({std::move(s)});
  input.defaults = {0.5, 0.4, 0.3};
  return input;
}

std::vector<core::GapContact> gapsOf(const detection::ShapeGaps& query,
                                     const std::vector<core::BodyState>& bodies, double range) {
  std::vector<core::GapContact> out;
  query.gaps(bodies, range, out);
  return out;
}

/// The 8 corners of a box of full sides `size` at a pose, world.
std::vector<Vector3d> corners(const Vector3d& size, const Vector3d& p, const Quaterniond& q) {
  std::vector<Vector3d> out;
  for (int k = 0; k < 8; ++k) {
    const Vector3d local((k & 1 ? 0.5 : -0.5) * size.x(), (k & 2 ? 0.5 : -0.5) * size.y(),
                         (k & 4 ? 0.5 : -0.5) * size.z());
    out.push_back(p + q.toRotationMatrix() * local);
  }
  return out;
}

double minGap(const std::vector<core::GapContact>& contacts) {
  double m = std::numeric_limits<double>::infinity();
  for (const auto& c : contacts) m = std::min(m, c.gap);
  return m;
}

/// Each contact of a solid over the floor z = 0 matches one corner (its gap = the corner's height,
/// its point midway between the corner and the floor); returns how many corners matched.
void expectCornersOverFloor(const std::vector<core::GapContact>& got,
                            const std::vector<Vector3d>& expected_corners, double range,
                            int floor_index, int solid_index) {
  std::vector<Vector3d> within;
  for (const Vector3d& c : expected_corners) {
    if (c.z() <= range) within.push_back(c);
  }
  ASSERT_EQ(got.size(), within.size());
  for (const Vector3d& c : within) {
    const Vector3d midway(c.x(), c.y(), 0.5 * c.z());
    const auto it = std::find_if(got.begin(), got.end(), [&](const core::GapContact& g) {
      return (g.point - midway).norm() < 1e-12;
    });
    ASSERT_NE(it, got.end()) << "no contact at the corner " << c.transpose();
    EXPECT_NEAR(it->gap, c.z(), 1e-12);
    EXPECT_EQ(it->body_a, std::min(floor_index, solid_index));
    EXPECT_EQ(it->body_b, std::max(floor_index, solid_index));
    const Vector3d up =
        floor_index < solid_index ? Vector3d::UnitZ() : Vector3d(-Vector3d::UnitZ());
    EXPECT_NEAR((it->normal - up).norm(), 0.0, 1e-12);
  }
}

TEST(ShapeGaps, LevelBoxOverAPlaneGivesEachCornerItsHeight) {
  // A box 0.2 x 0.3 x 0.4 centred at height 0.5: bottom corners at 0.3, top corners at 0.7.
  const Vector3d size(0.2, 0.3, 0.4), p(0.1, -0.2, 0.5);
  const auto box = primitive(Type::kBox, {size.x(), size.y(), size.z()});
  const std::vector<core::BodyState> bodies{body(0.0, Vector3d::Zero()), body(1.0, p)};
  const detection::ShapeGaps query(bodies, inputOf({{floorPlane()}, {box}}),
                                   detection::MaterialTable{});
  // Range 0.5: the 4 bottom corners; range 1: all 8.
  expectCornersOverFloor(gapsOf(query, bodies, 0.5), corners(size, p, Quaterniond::Identity()), 0.5,
                         0, 1);
  expectCornersOverFloor(gapsOf(query, bodies, 1.0), corners(size, p, Quaterniond::Identity()), 1.0,
                         0, 1);
  // Nothing within 0.29 m.
  EXPECT_TRUE(gapsOf(query, bodies, 0.29).empty());
  // The plane as the later body: the normal points from the box down to the plane.
  const std::vector<core::BodyState> swapped{body(1.0, p), body(0.0, Vector3d::Zero())};
  const detection::ShapeGaps query2(swapped, inputOf({{box}, {floorPlane()}}),
                                    detection::MaterialTable{});
  expectCornersOverFloor(gapsOf(query2, swapped, 0.5), corners(size, p, Quaterniond::Identity()),
                         0.5, 1, 0);
}

TEST(ShapeGaps, TiltedBoxOverAPlaneGivesEachCornerItsHeight) {
  const Vector3d size(0.2, 0.3, 0.4), p(-0.3, 0.2, 0.45);
  const Quaterniond q(Eigen::AngleAxisd(0.7, Vector3d(1.0, 2.0, 0.5).normalized()));
  const auto box = primitive(Type::kBox, {size.x(), size.y(), size.z()});
  const std::vector<core::BodyState> bodies{body(0.0, Vector3d::Zero()), body(1.0, p, q)};
  const detection::ShapeGaps query(bodies, inputOf({{floorPlane()}, {box}}),
                                   detection::MaterialTable{});
  const std::vector<Vector3d> c = corners(size, p, q);
  expectCornersOverFloor(gapsOf(query, bodies, 1.0), c, 1.0, 0, 1);
  // Only the lowest corner just above its height.
  double lowest = 1e9;
  for (const Vector3d& x : c) lowest = std::min(lowest, x.z());
  expectCornersOverFloor(gapsOf(query, bodies, lowest + 1e-9), c, lowest + 1e-9, 0, 1);
  // Penetrating by 1 cm: the lowest corner's gap is -0.01.
  std::vector<core::BodyState> sunk = bodies;
  sunk[1].position.z() -= lowest + 0.01;
  EXPECT_NEAR(minGap(gapsOf(query, sunk, 0.0)), -0.01, 1e-12);
}

TEST(ShapeGaps, SphereOverATiltedPlaneGivesItsLowestPoint) {
  // Plane 2 n . x - 0.4 = 0 with n = (0, sin a, cos a), given unnormalised: n . x = 0.2; a sphere
  // of radius 0.1 centred at c: gap = n . c - 0.2 - 0.1, point midway along n.
  const double a = 0.4, r = 0.1;
  const Vector3d n(0.0, std::sin(a), std::cos(a)), c(0.3, -0.1, 0.8);
  const auto plane = primitive(Type::kPlane, {0.0, 2.0 * n.y(), 2.0 * n.z(), -0.4});
  const std::vector<core::BodyState> bodies{body(0.0, Vector3d::Zero()), body(1.0, c)};
  const detection::ShapeGaps query(bodies, inputOf({{plane}, {primitive(Type::kSphere, {r})}}),
                                   detection::MaterialTable{});
  const auto got = gapsOf(query, bodies, 1.0);
  ASSERT_EQ(got.size(), 1u);
  const double gap = n.dot(c) - 0.2 - r;
  EXPECT_NEAR(got[0].gap, gap, 1e-12);
  EXPECT_NEAR((got[0].normal - n).norm(), 0.0, 1e-12);
  EXPECT_NEAR((got[0].point - (c - r * n - 0.5 * gap * n)).norm(), 0.0, 1e-12);
  EXPECT_TRUE(gapsOf(query, bodies, gap - 1e-9).empty());
}

TEST(ShapeGaps, TwoSpheresGiveTheirCentreDistanceLessTheRadii) {
  const double r1 = 0.1, r2 = 0.25;
  const Vector3d c1(0.0, 0.0, 0.0), c2(0.3, -0.2, 0.4);
  const std::vector<core::BodyState> bodies{body(1.0, c1), body(2.0, c2)};
  const detection::ShapeGaps query(
      bodies, inputOf({{primitive(Type::kSphere, {r1})}, {primitive(Type::kSphere, {r2})}}),
      detection::MaterialTable{});
  const double distance = (c2 - c1).norm() - r1 - r2;  // 0.1885
  const auto got = gapsOf(query, bodies, 1.0);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_NEAR(got[0].gap, distance, 1e-6);
  EXPECT_NEAR((got[0].normal - (c2 - c1).normalized()).norm(), 0.0, 1e-6);
  EXPECT_EQ(got[0].body_a, 0);
  EXPECT_EQ(got[0].body_b, 1);
  // Beyond the range: nothing.
  EXPECT_TRUE(gapsOf(query, bodies, distance - 1e-3).empty());
  // Overlapping by 2 cm.
  std::vector<core::BodyState> close = bodies;
  close[1].position = c1 + (c2 - c1).normalized() * (r1 + r2 - 0.02);
  const auto pen = gapsOf(query, close, 0.0);
  ASSERT_EQ(pen.size(), 1u);
  EXPECT_NEAR(pen[0].gap, -0.02, 1e-6);
}

TEST(ShapeGaps, SphereAgainstATurnedBoxGivesTheClampedDistance) {
  // The distance from a sphere to a box is the distance from its centre to the nearest point of
  // the box (the centre clamped to the box in the box's frame), less its radius; the normal points
  // from that nearest point to the centre. Random poses, apart and overlapping.
  const Vector3d half(0.3, 0.2, 0.1);
  const double r = 0.07;
  const std::vector<core::BodyState> start{body(1.0, Vector3d::Zero()),
                                           body(1.0, Vector3d(1, 0, 0))};
  const detection::ShapeGaps query(
      start,
      inputOf({{primitive(Type::kBox, {2 * half.x(), 2 * half.y(), 2 * half.z()})},
               {primitive(Type::kSphere, {r})}}),
      detection::MaterialTable{});
  std::srand(7);
  auto uniform = [] { return 2.0 * std::rand() / RAND_MAX - 1.0; };
  int checked = 0;
  double worst = 0.0;
  for (int k = 0; k < 200; ++k) {
    std::vector<core::BodyState> bodies = start;
    bodies[0].position = Vector3d(uniform(), uniform(), uniform());
    bodies[0].orientation =
        Quaterniond(Eigen::Vector4d(uniform(), uniform(), uniform(), uniform()));
    bodies[1].position = bodies[0].position + 0.5 * Vector3d(uniform(), uniform(), uniform());
    const Eigen::Matrix3d rot = bodies[0].orientation.normalized().toRotationMatrix();
    const Vector3d local = rot.transpose() * (bodies[1].position - bodies[0].position);
    const Vector3d nearest = local.cwiseMax(-half).cwiseMin(half);
    if ((local - nearest).norm() < 1e-3) continue;  // centre inside the box: no simple closed form
    const double gap = (local - nearest).norm() - r;
    const Vector3d normal = rot * (local - nearest).normalized();
    const auto got = gapsOf(query, bodies, 0.5);
    if (gap > 0.5) {
      EXPECT_TRUE(got.empty()) << "case " << k;
      continue;
    }
    ASSERT_EQ(got.size(), 1u) << "case " << k << ", gap " << gap;
    EXPECT_NEAR(got[0].gap, gap, 1e-6) << "case " << k;
    // The direction between the nearest points, or a face's normal within 0.05 rad of it (the
    // detector snaps the normal to a nearly aligned face whose corners all lie within its feature
    // band; the gap along it is the same to second order in the angle).
    bool normal_ok = (got[0].normal - normal).norm() <= 1e-6;
    for (int axis = 0; axis < 3; ++axis) {
      for (const double sign : {-1.0, 1.0}) {
        const Vector3d face = sign * rot.col(axis);
        normal_ok = normal_ok ||
                    (face.dot(normal) >= std::cos(0.05) && (got[0].normal - face).norm() <= 1e-9);
      }
    }
    EXPECT_TRUE(normal_ok) << "case " << k << ": normal " << got[0].normal.transpose()
                           << ", nearest points' direction " << normal.transpose();
    worst = std::max(worst, std::abs(got[0].gap - gap));
    ++checked;
  }
  EXPECT_GT(checked, 100);
  RecordProperty("worst_gap_error_m", std::to_string(worst));
}

TEST(ShapeGaps, BoxesSeparatedAlongAnAxisGiveTheFaceCornersAndTheDistance) {
  // A 0.5 m cube 0.3 m above a 1 m cube: the upper cube's bottom face over the lower's top face.
  const auto big = primitive(Type::kBox, {1.0, 1.0, 1.0});
  const auto small = primitive(Type::kBox, {0.5, 0.5, 0.5});
  const Vector3d p(0.1, 0.05, 0.5 + 0.3 + 0.25);
  const std::vector<core::BodyState> bodies{body(0.0, Vector3d::Zero()), body(1.0, p)};
  const detection::ShapeGaps query(bodies, inputOf({{big}, {small}}), detection::MaterialTable{});
  for (const double range : {0.31, 1.0}) {
    const auto got = gapsOf(query, bodies, range);
    ASSERT_EQ(got.size(), 4u) << "range " << range;
    for (const auto& g : got) {
      EXPECT_NEAR(g.gap, 0.3, 1e-6);
      EXPECT_NEAR((g.normal - Vector3d::UnitZ()).norm(), 0.0, 1e-6);
      EXPECT_NEAR(std::abs(g.point.x() - p.x()), 0.25, 1e-6);
      EXPECT_NEAR(std::abs(g.point.y() - p.y()), 0.25, 1e-6);
    }
  }
  EXPECT_TRUE(gapsOf(query, bodies, 0.29).empty());

  // The upper cube turned 0.3 rad about x: its lowest edge (two corners) at the distance, the
  // other corners higher. Its lowest corners, by hand: z = p.z - 0.25 (cos 0.3 + sin 0.3).
  std::vector<core::BodyState> tilted = bodies;
  tilted[1].orientation = Quaterniond(Eigen::AngleAxisd(0.3, Vector3d::UnitX()));
  const double lowest = p.z() - 0.25 * (std::cos(0.3) + std::sin(0.3));
  const auto got = gapsOf(query, tilted, 1.0);
  ASSERT_FALSE(got.empty());
  EXPECT_NEAR(minGap(got), lowest - 0.5, 1e-6);
  for (const auto& g : got) {
    EXPECT_GE(g.gap, lowest - 0.5 - 1e-6);
    EXPECT_NEAR((g.normal - Vector3d::UnitZ()).norm(), 0.0, 1e-6);
  }
}

TEST(ShapeGaps, ConvexMeshCubeGivesTheGapsOfTheBox) {
  const Vector3d size(0.2, 0.3, 0.4), p(0.2, 0.1, 0.35);
  const Quaterniond q(Eigen::AngleAxisd(0.5, Vector3d(0.3, -1.0, 0.2).normalized()));
  const std::vector<core::BodyState> bodies{body(0.0, Vector3d::Zero()), body(1.0, p, q),
                                            body(1.0, Vector3d(2.0, 0.0, 2.0))};
  const auto as_box = primitive(Type::kBox, {size.x(), size.y(), size.z()});
  const auto as_mesh = boxMesh(size.x(), size.y(), size.z());
  const auto other = primitive(Type::kBox, {1.0, 1.0, 1.0});
  const detection::ShapeGaps box_query(bodies, inputOf({{floorPlane()}, {as_box}, {other}}),
                                       detection::MaterialTable{});
  const detection::ShapeGaps mesh_query(bodies, inputOf({{floorPlane()}, {as_mesh}, {other}}),
                                        detection::MaterialTable{});
  // Over the plane: the closed form of the corners, for both.
  expectCornersOverFloor(gapsOf(mesh_query, bodies, 1.0), corners(size, p, q), 1.0, 0, 1);
  // Against a 1 m cube beside it, through FCL: the same distance.
  std::vector<core::BodyState> beside = bodies;
  beside[0].position.z() = -5.0;  // the plane out of range
  beside[2].position = p + Vector3d(0.8, 0.0, 0.0);
  const auto from_box = gapsOf(box_query, beside, 1.0);
  const auto from_mesh = gapsOf(mesh_query, beside, 1.0);
  ASSERT_FALSE(from_box.empty());
  ASSERT_FALSE(from_mesh.empty());
  EXPECT_NEAR(minGap(from_mesh), minGap(from_box), 1e-6);
  // By hand: the rightmost corner of the tilted box against the cube's left face (which spans
  // +-0.5 m around the box's centre, beyond the box's half diagonal).
  double rightmost = -1e9;
  for (const Vector3d& c : corners(size, p, q)) rightmost = std::max(rightmost, c.x());
  EXPECT_NEAR(minGap(from_box), beside[2].position.x() - 0.5 - rightmost, 1e-6);
}

TEST(ShapeGaps, CylinderAndConeOverAPlaneGiveTheirLowestPoints) {
  const double h = 0.4, r = 0.1;
  const auto cylinder = primitive(Type::kCylinder, {h, r});
  const auto cone = primitive(Type::kCone, {h, r});
  // Every pose below is first spun about the shape's own axis by 0.1 rad, which changes no
  // lowest point but keeps the rim's sample points off it.
  const Quaterniond spin(Eigen::AngleAxisd(0.1, Vector3d::UnitZ()));
  // Lying on its side (axis along x) at height 0.3: the contact line's two ends, each at 0.2.
  {
    const Quaterniond side = Quaterniond(Eigen::AngleAxisd(M_PI / 2, Vector3d::UnitY())) * spin;
    const std::vector<core::BodyState> bodies{body(0.0, Vector3d::Zero()),
                                              body(1.0, Vector3d(0, 0, 0.3), side)};
    const detection::ShapeGaps query(bodies, inputOf({{floorPlane()}, {cylinder}}),
                                     detection::MaterialTable{});
    const auto got = gapsOf(query, bodies, 0.2 + 1e-9);
    ASSERT_EQ(got.size(), 2u);
    for (const auto& g : got) {
      EXPECT_NEAR(g.gap, 0.2, 1e-12);
      EXPECT_NEAR(std::abs(g.point.x()), h / 2, 1e-12);
      EXPECT_NEAR(g.point.y(), 0.0, 1e-12);
    }
  }
  // Tilted by b about x: the lowest point of the lower rim at z - (h/2) cos b - r sin b.
  {
    const double b = 0.35, z = 0.5;
    const Quaterniond tilt = Quaterniond(Eigen::AngleAxisd(b, Vector3d::UnitX())) * spin;
    const std::vector<core::BodyState> bodies{body(0.0, Vector3d::Zero()),
                                              body(1.0, Vector3d(0, 0, z), tilt)};
    const detection::ShapeGaps cyl_query(bodies, inputOf({{floorPlane()}, {cylinder}}),
                                         detection::MaterialTable{});
    EXPECT_NEAR(minGap(gapsOf(cyl_query, bodies, 1.0)), z - h / 2 * std::cos(b) - r * std::sin(b),
                1e-12);
    // The cone's base is its lower end: the same lowest point.
    const detection::ShapeGaps cone_query(bodies, inputOf({{floorPlane()}, {cone}}),
                                          detection::MaterialTable{});
    EXPECT_NEAR(minGap(gapsOf(cone_query, bodies, 1.0)), z - h / 2 * std::cos(b) - r * std::sin(b),
                1e-12);
    // Upside down (apex first): the apex at z - (h/2) cos b.
    std::vector<core::BodyState> flipped = bodies;
    flipped[1].orientation = Quaterniond(Eigen::AngleAxisd(M_PI - b, Vector3d::UnitX())) * spin;
    const auto apex = gapsOf(cone_query, flipped, z - h / 2 * std::cos(b) + 1e-9);
    ASSERT_EQ(apex.size(), 1u);
    EXPECT_NEAR(apex[0].gap, z - h / 2 * std::cos(b), 1e-12);
  }
  // Standing on its cap: rim points spanning the cap (at most max_contacts_per_pair), each at the
  // cap's height, spread around the axis.
  {
    const std::vector<core::BodyState> bodies{body(0.0, Vector3d::Zero()),
                                              body(1.0, Vector3d(0, 0, 0.25))};
    const detection::ShapeGaps query(bodies, inputOf({{floorPlane()}, {cylinder}}),
                                     detection::MaterialTable{});
    const auto got = gapsOf(query, bodies, 0.1);
    ASSERT_EQ(got.size(), 8u);
    Vector3d mean = Vector3d::Zero();
    for (const auto& g : got) {
      EXPECT_NEAR(g.gap, 0.05, 1e-12);
      EXPECT_NEAR(std::hypot(g.point.x(), g.point.y()), r, 1e-12);
      mean += g.point / 8.0;
    }
    EXPECT_LT(std::hypot(mean.x(), mean.y()), 0.3 * r);
  }
}

TEST(ShapeGaps, EachPairTakesItsMaterials) {
  detection::MaterialTable table;
  table.set("wood", "rubber", {0.8, 0.9, 0.7});
  table.set("wood", "wood", {0.5, 0.4, 0.3});
  table.set("steel", "steel", {0.2, 0.1, 0.1});
  // Floor (wood), ball (rubber), box (steel), a second ball (no material).
  const std::vector<core::BodyState> bodies{
      body(0.0, Vector3d::Zero()), body(1.0, Vector3d(0, 0, 0.15)),
      body(1.0, Vector3d(0.35, 0, 0.15)), body(1.0, Vector3d(-0.35, 0, 0.15))};
  detection::DetectionInput input = inputOf({{floorPlane()},
                                             {primitive(Type::kSphere, {0.1})},
                                             {primitive(Type::kBox, {0.3, 0.3, 0.3})},
                                             {primitive(Type::kSphere, {0.1})}});
  input.materials = {"wood", "rubber", "steel", ""};
  const detection::ShapeGaps query(bodies, input, table);
  const auto got = gapsOf(query, bodies, 0.2);
  auto expectPair = [&](int a, int b, double e, double mus, double mud) {
    int seen = 0;
    for (const auto& g : got) {
      if (g.body_a != a || g.body_b != b) continue;
      ++seen;
      EXPECT_DOUBLE_EQ(g.restitution, e) << a << "-" << b;
      EXPECT_DOUBLE_EQ(g.static_friction, mus) << a << "-" << b;
      EXPECT_DOUBLE_EQ(g.dynamic_friction, mud) << a << "-" << b;
    }
    EXPECT_GT(seen, 0) << "no contact between " << a << " and " << b;
  };
  expectPair(0, 1, 0.8, 0.9, 0.7);  // wood-rubber: its entry
  // wood-steel: no entry, both have their own: the geometric mean of each coefficient.
  expectPair(0, 2, std::sqrt(0.5 * 0.2), std::sqrt(0.4 * 0.1), std::sqrt(0.3 * 0.1));
  expectPair(0, 3, 0.5, 0.4, 0.3);  // no material: the defaults
  expectPair(1, 2, 0.5, 0.4, 0.3);  // rubber has no entry of its own: the defaults (via FCL)
}

TEST(ShapeGaps, ManyMaterialsAreLookedUpPerPair) {
  // 70 spheres of 70 materials (more than are tabulated at construction), each material with its
  // own entry e_k = k / 100: two neighbours k, k + 1 touching get the geometric mean.
  detection::MaterialTable table;
  std::vector<core::BodyState> bodies;
  detection::DetectionInput input;
  input.defaults = {0.5, 0.4, 0.3};
  for (int k = 0; k < 70; ++k) {
    const std::string name = "m" + std::to_string(k);
    table.set(name, name, {k / 100.0, k / 50.0, k / 100.0});
    bodies.push_back(body(1.0, Vector3d(0.25 * k, 0.0, 0.0)));
    input.geometry.push_back({{primitive(Type::kSphere, {0.12})}});
    input.materials.push_back(name);
  }
  const detection::ShapeGaps query(bodies, input, table);
  const auto got = gapsOf(query, bodies, 0.011);  // neighbours are 1 cm apart
  ASSERT_EQ(got.size(), 69u);
  for (const auto& g : got) {
    ASSERT_EQ(g.body_b, g.body_a + 1);
    const double a = g.body_a, b = g.body_b;
    EXPECT_NEAR(g.restitution, std::sqrt(a * b) / 100.0, 1e-15);
    EXPECT_NEAR(g.static_friction, std::sqrt(a * b) / 50.0, 1e-15);
  }
}

TEST(ShapeGaps, RadiusBoundsEveryPointAboutTheCentreOfMass) {
  // One body of five shapes, each at its own pose, with its centre of mass off the origin.
  Eigen::Isometry3d box_pose = Eigen::Isometry3d::Identity();
  box_pose.translate(Vector3d(0.3, -0.1, 0.2));
  box_pose.rotate(Eigen::AngleAxisd(0.6, Vector3d(1, 1, 0).normalized()));
  Eigen::Isometry3d cyl_pose = Eigen::Isometry3d::Identity();
  cyl_pose.translate(Vector3d(-0.4, 0.2, 0.0));
  cyl_pose.rotate(Eigen::AngleAxisd(1.1, Vector3d(0, 1, 0.3).normalized()));
  Eigen::Isometry3d cone_pose = Eigen::Isometry3d::Identity();
  cone_pose.translate(Vector3d(0.1, 0.5, -0.3));
  cone_pose.rotate(Eigen::AngleAxisd(-0.8, Vector3d(1, 0, 0)));
  Eigen::Isometry3d sphere_pose = Eigen::Isometry3d::Identity();
  sphere_pose.translate(Vector3d(0.0, -0.6, 0.1));
  auto mesh = boxMesh(0.1, 0.2, 0.3);
  mesh.pose.translate(Vector3d(0.2, 0.2, 0.6));
  const std::vector<detection::Shape> shapes{primitive(Type::kBox, {0.2, 0.3, 0.1}, box_pose),
                                             primitive(Type::kCylinder, {0.5, 0.08}, cyl_pose),
                                             primitive(Type::kCone, {0.3, 0.12}, cone_pose),
                                             primitive(Type::kSphere, {0.15}, sphere_pose), mesh};
  const Vector3d com(0.05, -0.02, 0.1);
  const std::vector<core::BodyState> bodies{
      body(0.0, Vector3d::Zero()), body(1.0, Vector3d(0, 0, 2), Quaterniond::Identity(), com),
      body(1.0, Vector3d(5, 0, 0))};
  const detection::ShapeGaps query(bodies, inputOf({{floorPlane()}, shapes, {}}),
                                   detection::MaterialTable{});
  EXPECT_TRUE(std::isinf(query.radius(0)));
  EXPECT_EQ(query.radius(2), 0.0);
  EXPECT_EQ(query.bodyCount(), 3);
  EXPECT_THROW(query.radius(3), std::out_of_range);

  // Points on every surface, body frame: corners; rims and the apex finely sampled; the sphere in
  // many directions.
  std::vector<Vector3d> points;
  for (const Vector3d& c :
       corners(Vector3d(0.2, 0.3, 0.1), box_pose.translation(), Quaterniond(box_pose.linear()))) {
    points.push_back(c);
  }
  for (const Vector3d& c :
       corners(Vector3d(0.1, 0.2, 0.3), mesh.pose.translation(), Quaterniond::Identity())) {
    points.push_back(c);
  }
  const int n = 3600;
  for (int k = 0; k < n; ++k) {
    const double a = 2.0 * M_PI * k / n;
    const Vector3d ring(std::cos(a), std::sin(a), 0.0);
    for (double z : {-0.25, 0.25}) points.push_back(cyl_pose * (0.08 * ring + Vector3d(0, 0, z)));
    points.push_back(cone_pose * (0.12 * ring + Vector3d(0, 0, -0.15)));
    for (int m = 0; m <= 60; ++m) {
      const double polar = M_PI * m / 60;
      if (k % 10 != 0) break;
      points.push_back(sphere_pose *
                       (0.15 * Vector3d(std::sin(polar) * std::cos(a),
                                        std::sin(polar) * std::sin(a), std::cos(polar))));
    }
  }
  points.push_back(cone_pose * Vector3d(0, 0, 0.15));
  double farthest = 0.0;
  for (const Vector3d& x : points) {
    EXPECT_LE((x - com).norm(), query.radius(1) + 1e-12);
    farthest = std::max(farthest, (x - com).norm());
  }
  // And tight: the sampled farthest point is within the sampling error of the bound.
  EXPECT_NEAR(query.radius(1), farthest, 1e-4);

  // The support about the centre of mass, in directions of several lengths: at least every
  // sampled point's d . (x - com), and within the sampling error of the largest.
  std::mt19937 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int trial = 0; trial < 40; ++trial) {
    const Vector3d d = Vector3d(normal(rng), normal(rng), normal(rng)) * (0.5 + trial % 3);
    double largest = -std::numeric_limits<double>::infinity();
    for (const Vector3d& x : points) largest = std::max(largest, d.dot(x - com));
    const double h = query.support(1, d);
    EXPECT_GE(h, largest - 1e-12 * d.norm());
    EXPECT_NEAR(h, largest, 1e-4 * d.norm());
  }
  EXPECT_TRUE(std::isinf(query.support(0, Vector3d::UnitZ())));
  EXPECT_EQ(query.support(2, Vector3d::UnitZ()), 0.0);
  EXPECT_THROW(query.support(3, Vector3d::UnitZ()), std::out_of_range);
  // Five shapes, a plane, nothing: none is one convex solid.
  EXPECT_FALSE(query.convex(0));
  EXPECT_FALSE(query.convex(1));
  EXPECT_FALSE(query.convex(2));
}

// One box, sphere, cylinder or cone is convex; a mesh (convex or not) is not assumed to be.
TEST(ShapeGaps, ConvexOnlyForOnePrimitive) {
  std::vector<core::BodyState> bodies;
  for (int i = 0; i < 5; ++i) bodies.push_back(body(1.0, Vector3d(3.0 * i, 0, 0)));
  const detection::ShapeGaps query(bodies,
                                   inputOf({{primitive(Type::kBox, {0.1, 0.2, 0.3})},
                                            {primitive(Type::kSphere, {0.1})},
                                            {primitive(Type::kCylinder, {0.2, 0.1})},
                                            {primitive(Type::kCone, {0.2, 0.1})},
                                            {boxMesh(0.1, 0.1, 0.1)}}),
                                   detection::MaterialTable{});
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(query.convex(i)) << i;
  EXPECT_FALSE(query.convex(4));
  EXPECT_THROW(query.convex(5), std::out_of_range);
}

TEST(ShapeGaps, ImmovablePairsAndCollisionGroupsNeverAppear) {
  // Two immovable bodies touching (a plane and a box), and two movable boxes of one group.
  const std::vector<core::BodyState> bodies{
      body(0.0, Vector3d::Zero()), body(0.0, Vector3d(3, 0, 0.5)), body(1.0, Vector3d(0, 0, 0.5)),
      body(1.0, Vector3d(0, 0, 1.5))};
  const auto box = primitive(Type::kBox, {1, 1, 1});
  detection::DetectionInput input = inputOf({{floorPlane()}, {box}, {box}, {box}});
  input.collision_groups = {-1, -1, 7, 7};
  const detection::ShapeGaps query(bodies, input, detection::MaterialTable{});
  const auto got = gapsOf(query, bodies, 0.01);
  ASSERT_EQ(got.size(), 4u);  // the floor and box 2's bottom face only
  for (const auto& g : got) {
    EXPECT_EQ(g.body_a, 0);
    EXPECT_EQ(g.body_b, 2);
  }
}

template <typename F>
void expectInvalid(F&& f, const std::string& field) {
  try {
    f();
    ADD_FAILURE() << "no error for " << field;
  } catch (const core::InvalidInput& e) {
    EXPECT_EQ(e.field(), field) << e.what();
  }
}

TEST(ShapeGaps, InvalidInputIsNamed) {
  const std::vector<core::BodyState> bodies{body(0.0, Vector3d::Zero()),
                                            body(1.0, Vector3d(0, 0, 1))};
  const detection::MaterialTable none;
  const auto ball = primitive(Type::kSphere, {0.1});
  expectInvalid(
      [&] {
        detection::ShapeGaps q(bodies, inputOf({{floorPlane()}, {primitive(Type::kBox, {1, 1})}}),
                               none);
      },
      "bodies[1].primitives[0].dimensions");
  expectInvalid(
      [&] {
        detection::ShapeGaps q(bodies,
                               inputOf({{floorPlane()}, {primitive(Type::kSphere, {-0.1})}}), none);
      },
      "bodies[1].primitives[0].dimensions");
  expectInvalid(
      [&] {
        detection::ShapeGaps q(bodies, inputOf({{primitive(Type::kPlane, {0, 0, 0, 1})}, {ball}}),
                               none);
      },
      "bodies[0].planes[0]");
  expectInvalid(
      [&] {
        auto input = inputOf({{floorPlane()}, {ball}});
        input.materials = {"", "unobtainium"};
        detection::ShapeGaps q(bodies, input, none);
      },
      "bodies[1].material");
  expectInvalid(
      [&] {
        auto input = inputOf({{floorPlane()}, {ball}});
        input.defaults.restitution = 1.5;
        detection::ShapeGaps q(bodies, input, none);
      },
      "detection.restitution");
  expectInvalid(
      [&] {
        detection::ShapeGaps q(bodies, inputOf({{floorPlane()}, {ball}, {ball}}), none);
      },
      "bodies");
  expectInvalid(
      [&] {
        auto bad = bodies;
        bad[1].com.x() = std::nan("");
        detection::ShapeGaps q(bad, inputOf({{floorPlane()}, {ball}}), none);
      },
      "bodies[1].com");
  expectInvalid(
      [&] {
        auto bad = bodies;
        bad[1].mass = -1.0;
        detection::ShapeGaps q(bad, inputOf({{floorPlane()}, {ball}}), none);
      },
      "bodies[1].mass");

  const detection::ShapeGaps query(bodies, inputOf({{floorPlane()}, {ball}}), none);
  std::vector<core::GapContact> out;
  expectInvalid([&] { query.gaps(bodies, -1e-3, out); }, "range");
  expectInvalid([&] { query.gaps(bodies, std::nan(""), out); }, "range");
  expectInvalid([&] { query.gaps(bodies, std::numeric_limits<double>::infinity(), out); }, "range");
  expectInvalid([&] { query.gaps({bodies[0]}, 0.1, out); }, "bodies");
  auto bad = bodies;
  bad[1].position.z() = std::nan("");
  expectInvalid([&] { query.gaps(bad, 0.1, out); }, "bodies[1].position");
  bad = bodies;
  bad[1].orientation.coeffs().setZero();
  expectInvalid([&] { query.gaps(bad, 0.1, out); }, "bodies[1].orientation");
}

TEST(ShapeGaps, ConcurrentCallsGiveTheAnswersOfSequentialOnes) {
  // A floor, two boxes, a sphere and a cylinder: plane pairs and FCL pairs.
  const std::vector<detection::Shape> shapes[] = {{floorPlane()},
                                                  {primitive(Type::kBox, {0.3, 0.3, 0.3})},
                                                  {primitive(Type::kBox, {0.2, 0.4, 0.2})},
                                                  {primitive(Type::kSphere, {0.12})},
                                                  {primitive(Type::kCylinder, {0.3, 0.1})}};
  detection::DetectionInput input;
  for (const auto& s : shapes) input.geometry.push_back({s});
  std::vector<core::BodyState> base{body(0.0, Vector3d::Zero())};
  for (int i = 0; i < 4; ++i) base.push_back(body(1.0, Vector3d::Zero()));
  const detection::ShapeGaps query(base, input, detection::MaterialTable{});
  // Poses of each case: bodies clustered near the floor, turning with the case number.
  auto scene = [&](int k) {
    std::vector<core::BodyState> b = base;
    for (int i = 1; i < 5; ++i) {
      const double s = 0.37 * k + i;
      b[i].position = Vector3d(0.25 * std::cos(s + i), 0.25 * std::sin(1.3 * s), 0.2 + 0.1 * i);
      b[i].orientation = Quaterniond(
          Eigen::AngleAxisd(0.3 * s, Vector3d(std::sin(s), 1.0, std::cos(2 * s)).normalized()));
    }
    return b;
  };
  const int cases = 60;
  std::vector<std::vector<core::GapContact>> expected(cases);
  std::size_t total = 0;
  for (int k = 0; k < cases; ++k) {
    query.gaps(scene(k), 0.3, expected[k]);
    total += expected[k].size();
  }
  ASSERT_GT(total, 5u * cases);
  std::vector<int> mismatches(4, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      std::vector<core::GapContact> out;
      for (int round = 0; round < 10; ++round) {
        for (int k = 0; k < cases; ++k) {
          const int c = (k * (t + 1) + round) % cases;
          query.gaps(scene(c), 0.3, out);
          bool same = out.size() == expected[c].size();
          for (std::size_t i = 0; same && i < out.size(); ++i) {
            same = out[i].body_a == expected[c][i].body_a &&
                   out[i].body_b == expected[c][i].body_b && out[i].gap == expected[c][i].gap &&
                   out[i].point == expected[c][i].point && out[i].normal == expected[c][i].normal;
          }
          if (!same) ++mismatches[t];
        }
      }
    });
  }
  for (auto& th : threads) th.join();
  for (int t = 0; t < 4; ++t) EXPECT_EQ(mismatches[t], 0) << "thread " << t;
}

}  // namespace
