// Contacts found from shapes, then solved: the closed-form cases of a scene given only shapes
// (sphere on a plane, two spheres, a box landing flat, a box landing on an edge off-centre, a
// cylinder on its side, a box given as its convex-hull mesh), and the material table.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "collision_response/core/compute_response.h"
#include "collision_response/core/errors.h"
#include "collision_response/detection/detect_contacts.h"
#include "scene_builders.h"
#include "shape_builders.h"

namespace {

using namespace collision_response::testing;
namespace detection = collision_response::detection;

constexpr double kTol = 1e-9;

detection::Shape floorPlane() {
  return primitive(detection::Shape::Type::kPlane, {0.0, 0.0, 1.0, 0.0});
}

/// A uniform cube of side 1 m and mass 1 kg: I = m s^2 / 6.
cr::BodyState cube(const Vector3d& position, const Quaterniond& q, const Vector3d& v) {
  cr::BodyState b;
  b.id = "cube";
  b.mass = 1.0;
  b.inertia = Matrix3d::Identity() / 6.0;
  b.position = position;
  b.orientation = q;
  b.linear_velocity = v;
  return b;
}

struct Solved {
  detection::DetectedContacts detected;
  cr::CollisionResult result;
};

Solved detectAndSolve(const std::vector<cr::BodyState>& bodies, detection::DetectionInput input,
                      const detection::MaterialTable& table = {},
                      cr::ImpactLaw law = cr::ImpactLaw::kStronge) {
  detection::ContactDetector detector;
  Solved out;
  out.detected = detection::detectContacts(detector, bodies, input, table);
  cr::Scene scene;
  scene.bodies = bodies;
  scene.contacts = out.detected.contacts;
  cr::SolverOptions options;
  options.law = law;
  out.result = cr::computeResponse(scene, options);
  return out;
}

detection::DetectionInput shapesOf(std::vector<std::vector<detection::Shape>> shapes, double e,
                                   double mu = 0.0) {
  detection::DetectionInput input;
  for (auto& s : shapes) input.geometry.push_back({std::move(s)});
  input.defaults = {e, mu, mu};
  return input;
}

TEST(DetectedContacts, SphereDroppedOnAPlaneBouncesAndRolls) {
  // R = 0.1 m, 1 kg, v = (1, 0, -2), e = 0.5, mu = 1 (enough to stick: |P_t| / P_n = (2/7) / 3).
  // Central impact: v'_z = -e v_z = 1; rolling without slip: v'_x = 5/7 v_x, w'_y = v'_x / R.
  const double R = 0.1;
  const auto ball = sphere("ball", 1.0, R, {0, 0, R}, {1.0, 0, -2.0});
  for (const cr::ImpactLaw law :
       {cr::ImpactLaw::kNewton, cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    const Solved s = detectAndSolve(
        {ground(), ball},
        shapesOf({{floorPlane()}, {primitive(detection::Shape::Type::kSphere, {R})}}, 0.5, 1.0), {},
        law);
    ASSERT_EQ(s.detected.contacts.size(), 1u);
    expectVecNear(s.detected.contacts[0].normal, Vector3d::UnitZ(), kTol);
    expectVecNear(s.detected.contacts[0].point, Vector3d::Zero(), 1e-9);
    expectVecNear(s.result.bodies[1].linear_velocity, {5.0 / 7.0, 0, 1.0}, kTol);
    expectVecNear(s.result.bodies[1].angular_velocity, {0, 5.0 / 7.0 / R, 0}, kTol);
  }
}

TEST(DetectedContacts, TwoSpheresHeadOn) {
  // m1 = 1 kg at 2 m/s, m2 = 2 kg at -1 m/s, e = 0.5: v1' = -1, v2' = 0.5 (momentum 0).
  const auto left = sphere("left", 1.0, 0.1, {-0.1, 0, 0}, {2.0, 0, 0});
  const auto right = sphere("right", 2.0, 0.1, {0.1, 0, 0}, {-1.0, 0, 0});
  const detection::Shape ball = primitive(detection::Shape::Type::kSphere, {0.1});
  const Solved s = detectAndSolve({left, right}, shapesOf({{ball}, {ball}}, 0.5));
  ASSERT_EQ(s.detected.contacts.size(), 1u);
  EXPECT_EQ(s.detected.contacts[0].body_a, "left");
  expectVecNear(s.detected.contacts[0].normal, Vector3d::UnitX(), kTol);
  expectVecNear(s.result.bodies[0].linear_velocity, {-1.0, 0, 0}, kTol);
  expectVecNear(s.result.bodies[1].linear_velocity, {0.5, 0, 0}, kTol);

  // The same two in one collision group (two links of one robot): never paired.
  detection::DetectionInput grouped = shapesOf({{ball}, {ball}}, 0.5);
  grouped.collision_groups = {3, 3};
  detection::ContactDetector detector;
  EXPECT_TRUE(detection::detectContacts(detector, {left, right}, grouped, {}).contacts.empty());
}

// Each detected contact carries the indices of its two bodies in the bodies given (what a caller
// keeps instead of looking the ids up): three balls in a row touch their neighbours only, so the
// pairs are (0, 1) and (1, 2), and each index names the body whose id the contact names.
TEST(DetectedContacts, ContactsCarryTheirBodiesIndices) {
  const detection::Shape ball = primitive(detection::Shape::Type::kSphere, {0.1});
  const std::vector<cr::BodyState> bodies = {
      sphere("west", 1.0, 0.1, {-0.2, 0, 0}, {1.0, 0, 0}),
      sphere("middle", 1.0, 0.1, {0, 0, 0}, Vector3d::Zero()),
      sphere("east", 1.0, 0.1, {0.2, 0, 0}, {-1.0, 0, 0})};
  detection::ContactDetector detector;
  const detection::DetectedContacts found =
      detection::detectContacts(detector, bodies, shapesOf({{ball}, {ball}, {ball}}, 0.5), {});
  ASSERT_EQ(found.contacts.size(), 2u);
  ASSERT_EQ(found.bodies.size(), 2u);
  std::vector<std::pair<int, int>> pairs = found.bodies;
  std::sort(pairs.begin(), pairs.end());
  EXPECT_EQ(pairs, (std::vector<std::pair<int, int>>{{0, 1}, {1, 2}}));
  for (std::size_t k = 0; k < found.contacts.size(); ++k) {
    EXPECT_EQ(bodies[found.bodies[k].first].id, found.contacts[k].body_a);
    EXPECT_EQ(bodies[found.bodies[k].second].id, found.contacts[k].body_b);
  }
}

TEST(DetectedContacts, BoxLandingFlatKeepsNoSpin) {
  // Four corner contacts, e = 0.5, frictionless: v' = (0, 0, 0.5), w' = 0.
  const detection::Shape box = primitive(detection::Shape::Type::kBox, {1, 1, 1});
  for (const bool as_mesh : {false, true}) {
    SCOPED_TRACE(as_mesh ? "convex-hull mesh" : "box primitive");
    const Solved s =
        detectAndSolve({ground(), cube({0, 0, 0.5}, Quaterniond::Identity(), {0, 0, -1})},
                       shapesOf({{floorPlane()}, {as_mesh ? boxMesh() : box}}, 0.5));
    EXPECT_EQ(s.detected.contacts.size(), 4u);
    expectVecNear(s.result.bodies[1].linear_velocity, {0, 0, 0.5}, kTol);
    expectVecNear(s.result.bodies[1].angular_velocity, Vector3d::Zero(), kTol);
  }
}

TEST(DetectedContacts, BoxLandingOnAnEdgeOffCentre) {
  // The cube turned 30 degrees about x lands on its lowest edge (parallel to x), whose midpoint
  // is off the vertical through the centre of mass by dy. The two end contacts act like one at
  // the midpoint (torques about y cancel): frictionless, j = (1 + e) / (1/m + dy^2 / I),
  // v'_z = -1 + j / m, w'_x = j dy / I.
  const double theta = M_PI / 6.0, e = 0.5, m = 1.0, I = 1.0 / 6.0;
  const double dy = -0.5 * std::cos(theta) + 0.5 * std::sin(theta);
  const double height = 0.5 * (std::sin(theta) + std::cos(theta));
  const double j = (1.0 + e) / (1.0 / m + dy * dy / I);
  const Quaterniond q(Eigen::AngleAxisd(theta, Vector3d::UnitX()));
  for (const bool as_mesh : {false, true}) {
    SCOPED_TRACE(as_mesh ? "convex-hull mesh" : "box primitive");
    const detection::Shape box =
        as_mesh ? boxMesh() : primitive(detection::Shape::Type::kBox, {1, 1, 1});
    const Solved s = detectAndSolve({ground(), cube({0, 0, height}, q, {0, 0, -1})},
                                    shapesOf({{floorPlane()}, {box}}, e));
    ASSERT_EQ(s.detected.contacts.size(), 2u);
    for (const cr::Contact& c : s.detected.contacts) {
      EXPECT_NEAR(std::abs(c.point.x()), 0.5, 1e-9);
      EXPECT_NEAR(c.point.y(), dy, 1e-9);
    }
    expectVecNear(s.result.bodies[1].linear_velocity, {0, 0, -1.0 + j / m}, kTol);
    expectVecNear(s.result.bodies[1].angular_velocity, {j * dy / I, 0, 0}, kTol);
    EXPECT_LE(s.result.kinetic_energy_after, s.result.kinetic_energy_before);
  }
}

TEST(DetectedContacts, CylinderOnItsSideLandsWithoutSpin) {
  // h = 1 m, r = 0.1 m, axis along x (shape turned about y), falling flat on its side: the two
  // ends of the contact line share the impulse, e = 0.5: v' = (0, 0, 0.5), w' = 0.
  const double h = 1.0, r = 0.1, m = 2.0;
  cr::BodyState body;
  body.id = "cylinder";
  body.mass = m;
  body.inertia = Eigen::Vector3d(0.5 * m * r * r, m * (3 * r * r + h * h) / 12.0,
                                 m * (3 * r * r + h * h) / 12.0)
                     .asDiagonal();
  body.position = {0.2, -0.3, r};
  body.linear_velocity = {0, 0, -1};
  Eigen::Isometry3d along_x = Eigen::Isometry3d::Identity();
  along_x.rotate(Eigen::AngleAxisd(M_PI / 2.0, Vector3d::UnitY()));
  const Solved s = detectAndSolve(
      {ground(), body},
      shapesOf({{floorPlane()}, {primitive(detection::Shape::Type::kCylinder, {h, r}, along_x)}},
               0.5));
  EXPECT_EQ(s.detected.contacts.size(), 2u);
  expectVecNear(s.result.bodies[1].linear_velocity, {0, 0, 0.5}, kTol);
  expectVecNear(s.result.bodies[1].angular_velocity, Vector3d::Zero(), kTol);
}

TEST(DetectedContacts, SeparatedPairsBeyondTheToleranceGetNothing) {
  const auto ball = sphere("ball", 1.0, 0.1, {0, 0, 0.1 + 2e-3}, {0, 0, -1});
  detection::DetectionInput input =
      shapesOf({{floorPlane()}, {primitive(detection::Shape::Type::kSphere, {0.1})}}, 0.5);
  input.options.contact_tolerance = 1e-3;
  detection::ContactDetector detector;
  EXPECT_TRUE(detection::detectContacts(detector, {ground(), ball}, input, {}).contacts.empty());
  input.options.contact_tolerance = 3e-3;
  const detection::DetectedContacts near =
      detection::detectContacts(detector, {ground(), ball}, input, {});
  ASSERT_EQ(near.contacts.size(), 1u);
  EXPECT_NEAR(near.depths[0], -2e-3, 1e-9);
}

TEST(DetectedContacts, MaterialsSetTheCoefficients) {
  // Head-on spheres (m1 = 1 at 2 m/s, m2 = 2 at -1 m/s): v1' = -2 e, v2' = e.
  const detection::Shape ball = primitive(detection::Shape::Type::kSphere, {0.1});
  const auto left = sphere("left", 1.0, 0.1, {-0.1, 0, 0}, {2.0, 0, 0});
  const auto right = sphere("right", 2.0, 0.1, {0.1, 0, 0}, {-1.0, 0, 0});
  detection::MaterialTable table;
  table.set("steel", "steel", {0.9, 0.5, 0.4});
  table.set("rubber", "rubber", {0.4, 1.0, 0.8});
  table.set("glass", "steel", {0.8, 0.2, 0.1});
  const auto restitutionBetween = [&](const char* a, const char* b) {
    detection::DetectionInput input = shapesOf({{ball}, {ball}}, 0.25);
    input.materials = {a, b};
    const Solved s = detectAndSolve({left, right}, input, table);
    EXPECT_NEAR(s.result.bodies[1].linear_velocity.x(), s.detected.contacts[0].restitution, kTol);
    EXPECT_NEAR(s.result.bodies[0].linear_velocity.x(), -2.0 * s.detected.contacts[0].restitution,
                kTol);
    return s.detected.contacts[0].restitution;
  };
  EXPECT_DOUBLE_EQ(restitutionBetween("steel", "glass"), 0.8);    // the pair, either order
  EXPECT_DOUBLE_EQ(restitutionBetween("steel", "steel"), 0.9);    // its own entry
  EXPECT_DOUBLE_EQ(restitutionBetween("steel", "rubber"), 0.6);   // mix: sqrt(0.9 * 0.4)
  EXPECT_DOUBLE_EQ(restitutionBetween("glass", "rubber"), 0.25);  // glass has no own entry
  EXPECT_DOUBLE_EQ(restitutionBetween("", "steel"), 0.25);        // no material: the request's
  const detection::ContactMaterial mixed = table.lookup("rubber", "steel", {});
  EXPECT_DOUBLE_EQ(mixed.static_friction, std::sqrt(0.5));
  EXPECT_DOUBLE_EQ(mixed.dynamic_friction, std::sqrt(0.32));
  EXPECT_LE(mixed.dynamic_friction, mixed.static_friction);
}

TEST(DetectedContacts, BadInputNamesTheField) {
  const detection::Shape ball = primitive(detection::Shape::Type::kSphere, {0.1});
  const std::vector<cr::BodyState> bodies = {sphere("a", 1, 0.1, {-0.1, 0, 0}, {1, 0, 0}),
                                             sphere("b", 1, 0.1, {0.1, 0, 0}, {0, 0, 0})};
  detection::ContactDetector detector;
  const auto fieldOf = [&](const detection::DetectionInput& input,
                           const cr::RequestLimits& limits) {
    try {
      detection::detectContacts(detector, bodies, input, {}, limits);
    } catch (const cr::InvalidInput& e) {
      return e.field();
    }
    return std::string("(accepted)");
  };
  detection::DetectionInput input = shapesOf({{ball}, {ball}}, 0.5);
  input.defaults.restitution = 1.5;
  EXPECT_EQ(fieldOf(input, {}), "detection.restitution");
  input = shapesOf({{ball}, {ball}}, 0.5, 0.3);
  input.defaults.dynamic_friction = 0.4;
  EXPECT_EQ(fieldOf(input, {}), "detection.dynamic_friction");
  input = shapesOf({{ball}, {ball}}, 0.5);
  input.options.contact_tolerance = std::nan("");
  EXPECT_EQ(fieldOf(input, {}), "detection.contact_tolerance");
  input = shapesOf({{ball}, {primitive(detection::Shape::Type::kSphere, {2e7})}}, 0.5);
  EXPECT_EQ(fieldOf(input, {}), "bodies[1].primitives[0].dimensions");
  input = shapesOf({{ball, ball}, {ball}}, 0.5);
  cr::RequestLimits limits;
  limits.max_shapes = 2;
  EXPECT_EQ(fieldOf(input, limits), "bodies");
  input = shapesOf({{ball}, {ball}}, 0.5);
  input.materials = {"steel"};
  EXPECT_EQ(fieldOf(input, {}), "bodies");
  input = shapesOf({{ball}, {ball}}, 0.5);
  input.collision_groups = {0, 0, 0};
  EXPECT_EQ(fieldOf(input, {}), "bodies");
  detection::MaterialTable table;
  EXPECT_THROW(table.set("steel", "", {0.5, 0.1, 0.1}), cr::InvalidInput);
  EXPECT_THROW(table.set("steel", "steel", {0.5, 0.1, 0.2}), cr::InvalidInput);
  table.set("steel", "glass", {0.5, 0.1, 0.1});
  EXPECT_THROW(table.set("glass", "steel", {0.6, 0.1, 0.1}), cr::InvalidInput);  // repeated pair
  // A material name in no entry of the table is a typo, not a silent fallback.
  input = shapesOf({{ball}, {ball}}, 0.5);
  input.materials = {"glass", "stel"};
  try {
    detection::detectContacts(detector, bodies, input, table);
    ADD_FAILURE() << "an unknown material was accepted";
  } catch (const cr::InvalidInput& e) {
    EXPECT_EQ(e.field(), "bodies[1].material");
  }
  input.materials = {"glass", ""};  // no material: the request's coefficients
  EXPECT_NO_THROW(detection::detectContacts(detector, bodies, input, table));
  // More contact points than the solver would take: refused before the rest is tested.
  const std::vector<cr::BodyState> boxes = {ground(),
                                            cube({0, 0, 0.5}, Quaterniond::Identity(), {0, 0, -1})};
  input = shapesOf({{floorPlane()}, {primitive(detection::Shape::Type::kBox, {1, 1, 1})}}, 0.5);
  input.options.max_contacts = 3;
  EXPECT_EQ(fieldOf(input, {}), "bodies");
  EXPECT_THROW(detection::detectContacts(detector, boxes, input, {}), cr::InvalidInput);
  input.options.max_contacts = 4;
  EXPECT_EQ(detection::detectContacts(detector, boxes, input, {}).contacts.size(), 4u);
}

}  // namespace
