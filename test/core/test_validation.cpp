// Unit tests of input validation: every class of bad input is rejected with core::InvalidInput
// whose field() is the exact path of the offending value.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "collision_response/core/compute_response.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/scene.h"
#include "collision_response/core/solver_options.h"
#include "collision_response/core/validation.h"

namespace cr = collision_response::core;
using Eigen::Matrix3d;
using Eigen::Quaterniond;
using Eigen::Vector3d;

namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();
const double kInf = std::numeric_limits<double>::infinity();

// A valid scene: bodies[0] the immovable ground (zero inertia), bodies[1] a ball on it,
// bodies[2] a box touching the ball. contacts[0] ground-ball, contacts[1] ball-box.
cr::Scene validScene() {
  cr::Scene s;
  cr::BodyState ground;
  ground.id = "ground";
  ground.mass = 0.0;
  cr::BodyState ball;
  ball.id = "ball";
  ball.mass = 1.0;
  ball.inertia = Matrix3d::Identity() * 0.1;
  ball.position = Vector3d(0, 0.5, 0);
  ball.linear_velocity = Vector3d(0.2, -1.0, 0.0);
  cr::BodyState box;
  box.id = "box";
  box.mass = 2.0;
  box.inertia = Vector3d(0.3, 0.4, 0.5).asDiagonal();
  box.position = Vector3d(1.0, 0.5, 0);
  box.orientation = Quaterniond(Eigen::AngleAxisd(0.3, Vector3d::UnitY()));
  box.linear_velocity = Vector3d(-1.0, 0.0, 0.0);
  s.bodies = {ground, ball, box};
  cr::Contact c0;
  c0.body_a = "ground";
  c0.body_b = "ball";
  c0.point = Vector3d::Zero();
  c0.normal = Vector3d::UnitY();
  c0.restitution = 0.5;
  c0.static_friction = 0.6;
  c0.dynamic_friction = 0.4;
  cr::Contact c1;
  c1.body_a = "ball";
  c1.body_b = "box";
  c1.point = Vector3d(0.5, 0.5, 0);
  c1.normal = Vector3d::UnitX();
  c1.restitution = 1.0;
  s.contacts = {c0, c1};
  return s;
}

// Expects computeResponse (and validate) to throw InvalidInput naming exactly `field`; returns
// the message for further checks.
std::string expectInvalid(const cr::Scene& s, const std::string& field,
                          const cr::SolverOptions& options = {},
                          const cr::RequestLimits& limits = {}) {
  std::string what;
  try {
    cr::computeResponse(s, options, limits);
    ADD_FAILURE() << "no InvalidInput thrown, expected field " << field;
  } catch (const cr::InvalidInput& e) {
    EXPECT_EQ(e.field(), field) << e.what();
    what = e.what();
    EXPECT_EQ(what.rfind(field + ": ", 0), 0u) << what;  // the message starts with the field
  }
  try {
    cr::validate(s, options, limits);
    ADD_FAILURE() << "validate did not throw, expected field " << field;
  } catch (const cr::InvalidInput& e) {
    EXPECT_EQ(e.field(), field);
  }
  return what;
}

using Mutator = std::function<void(cr::Scene&, double)>;

void expectNonFiniteRejected(const Mutator& mutate, const std::string& field) {
  for (const double bad : {kNaN, kInf, -kInf}) {
    SCOPED_TRACE(field + " = " + std::to_string(bad));
    cr::Scene s = validScene();
    mutate(s, bad);
    const std::string what = expectInvalid(s, field);
    EXPECT_NE(what.find("finite"), std::string::npos) << what;
  }
}

TEST(Validation, ValidSceneIsAcceptedAndContactsAreResolvedToIndices) {
  const cr::Scene s = validScene();
  const auto pairs = cr::validate(s, {}, {});
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[0], std::make_pair(0, 1));
  EXPECT_EQ(pairs[1], std::make_pair(1, 2));
  EXPECT_NO_THROW(cr::computeResponse(s));
}

TEST(Validation, ImmovableBodyWithZeroInertiaIsAccepted) {
  cr::Scene s = validScene();
  ASSERT_EQ(s.bodies[0].inertia, Matrix3d::Zero());
  EXPECT_NO_THROW(cr::validate(s, {}, {}));
  // An immovable body's inertia is ignored even when it is not physical.
  s.bodies[0].inertia = Vector3d(1.0, 1.0, 5.0).asDiagonal();
  EXPECT_NO_THROW(cr::validate(s, {}, {}));
}

TEST(Validation, NearlyUnitQuaternionAndNormalAreAccepted) {
  cr::Scene s = validScene();
  s.bodies[2].orientation.coeffs() *= 1.0 + 0.5 * cr::kUnitTolerance;
  s.contacts[0].normal *= 1.0 - 0.5 * cr::kUnitTolerance;
  EXPECT_NO_THROW(cr::computeResponse(s));
}

// --- Non-finite numbers, everywhere. ------------------------------------------------------------
TEST(Validation, NonFiniteMassIsRejected) {
  expectNonFiniteRejected([](cr::Scene& s, double x) { s.bodies[1].mass = x; },
                          "bodies[1].inertia.m");
  // Also for a body declared immovable elsewhere: mass is the first thing checked.
  expectNonFiniteRejected([](cr::Scene& s, double x) { s.bodies[0].mass = x; },
                          "bodies[0].inertia.m");
}

TEST(Validation, NonFiniteCentreOfMassIsRejected) {
  const char* axes[] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    expectNonFiniteRejected([i](cr::Scene& s, double x) { s.bodies[2].com[i] = x; },
                            std::string("bodies[2].inertia.com.") + axes[i]);
  }
}

TEST(Validation, NonFiniteInertiaEntriesAreRejected) {
  const char* names[3][3] = {{"ixx", "ixy", "ixz"}, {"ixy", "iyy", "iyz"}, {"ixz", "iyz", "izz"}};
  for (int r = 0; r < 3; ++r) {
    for (int c = r; c < 3; ++c) {
      expectNonFiniteRejected(
          [r, c](cr::Scene& s, double x) {
            s.bodies[1].inertia(r, c) = x;
            s.bodies[1].inertia(c, r) = x;  // symmetric, as in the message
          },
          std::string("bodies[1].inertia.") + names[r][c]);
    }
  }
  // Also on an immovable body, whose inertia is otherwise ignored.
  expectNonFiniteRejected([](cr::Scene& s, double x) { s.bodies[0].inertia(2, 2) = x; },
                          "bodies[0].inertia.izz");
}

TEST(Validation, NonFinitePoseIsRejected) {
  const char* axes[] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    expectNonFiniteRejected([i](cr::Scene& s, double x) { s.bodies[1].position[i] = x; },
                            std::string("bodies[1].pose.position.") + axes[i]);
  }
  expectNonFiniteRejected([](cr::Scene& s, double x) { s.bodies[2].orientation.x() = x; },
                          "bodies[2].pose.orientation.x");
  expectNonFiniteRejected([](cr::Scene& s, double x) { s.bodies[2].orientation.y() = x; },
                          "bodies[2].pose.orientation.y");
  expectNonFiniteRejected([](cr::Scene& s, double x) { s.bodies[2].orientation.z() = x; },
                          "bodies[2].pose.orientation.z");
  expectNonFiniteRejected([](cr::Scene& s, double x) { s.bodies[2].orientation.w() = x; },
                          "bodies[2].pose.orientation.w");
}

TEST(Validation, NonFiniteVelocitiesAreRejected) {
  const char* axes[] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    expectNonFiniteRejected([i](cr::Scene& s, double x) { s.bodies[1].linear_velocity[i] = x; },
                            std::string("bodies[1].twist.linear.") + axes[i]);
    expectNonFiniteRejected([i](cr::Scene& s, double x) { s.bodies[2].angular_velocity[i] = x; },
                            std::string("bodies[2].twist.angular.") + axes[i]);
    // An immovable body's velocity enters the relative velocity, so it must be finite too.
    expectNonFiniteRejected([i](cr::Scene& s, double x) { s.bodies[0].linear_velocity[i] = x; },
                            std::string("bodies[0].twist.linear.") + axes[i]);
  }
}

TEST(Validation, NonFiniteContactValuesAreRejected) {
  const char* axes[] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    expectNonFiniteRejected([i](cr::Scene& s, double x) { s.contacts[1].point[i] = x; },
                            std::string("contacts[1].point.") + axes[i]);
    expectNonFiniteRejected([i](cr::Scene& s, double x) { s.contacts[0].normal[i] = x; },
                            std::string("contacts[0].normal.") + axes[i]);
  }
  expectNonFiniteRejected([](cr::Scene& s, double x) { s.contacts[0].restitution = x; },
                          "contacts[0].restitution");
  expectNonFiniteRejected([](cr::Scene& s, double x) { s.contacts[1].static_friction = x; },
                          "contacts[1].static_friction");
  expectNonFiniteRejected([](cr::Scene& s, double x) { s.contacts[1].dynamic_friction = x; },
                          "contacts[1].dynamic_friction");
}

// --- Bodies. ------------------------------------------------------------------------------------
TEST(Validation, NegativeMassIsRejected) {
  cr::Scene s = validScene();
  s.bodies[1].mass = -1.0;
  const std::string what = expectInvalid(s, "bodies[1].inertia.m");
  EXPECT_NE(what.find("negative"), std::string::npos) << what;
}

TEST(Validation, NonPositiveDefiniteInertiaIsRejected) {
  const std::vector<Matrix3d> bad = {
      Matrix3d::Zero(),                                 // a movable body needs an inertia
      Matrix3d(Vector3d(1.0, 1.0, 0.0).asDiagonal()),   // singular (obeys the triangle inequality)
      Matrix3d(Vector3d(1.0, 1.0, -0.5).asDiagonal()),  // negative moment
      (Matrix3d() << 1, 2, 0, 2, 1, 0, 0, 0, 1).finished(),  // eigenvalues -1, 1, 3
  };
  for (const Matrix3d& inertia : bad) {
    cr::Scene s = validScene();
    s.bodies[2].inertia = inertia;
    const std::string what = expectInvalid(s, "bodies[2].inertia");
    EXPECT_NE(what.find("positive definite"), std::string::npos) << what;
  }
}

TEST(Validation, InertiaBreakingTriangleInequalityIsRejected) {
  // Principal moments of any real mass distribution satisfy I1 + I2 >= I3.
  cr::Scene s = validScene();
  s.bodies[1].inertia = Vector3d(1.0, 1.0, 3.0).asDiagonal();
  std::string what = expectInvalid(s, "bodies[1].inertia");
  EXPECT_NE(what.find("triangle"), std::string::npos) << what;
  // The same tensor rotated (off-diagonal entries): still rejected.
  const Matrix3d R =
      Quaterniond(Eigen::AngleAxisd(0.7, Vector3d(1, 2, 3).normalized())).toRotationMatrix();
  s.bodies[1].inertia = R * Vector3d(1.0, 1.0, 3.0).asDiagonal() * R.transpose();
  s.bodies[1].inertia = 0.5 * (s.bodies[1].inertia + s.bodies[1].inertia.transpose()).eval();
  what = expectInvalid(s, "bodies[1].inertia");
  EXPECT_NE(what.find("triangle"), std::string::npos) << what;
  // The limiting case of a flat plate, I3 = I1 + I2, is physical and accepted.
  s.bodies[1].inertia = Vector3d(1.0, 2.0, 3.0).asDiagonal();
  EXPECT_NO_THROW(cr::validate(s, {}, {}));
}

TEST(Validation, ZeroQuaternionIsRejectedAsZero) {
  cr::Scene s = validScene();
  s.bodies[2].orientation = Quaterniond(0, 0, 0, 0);
  const std::string what = expectInvalid(s, "bodies[2].pose.orientation");
  EXPECT_NE(what.find("zero"), std::string::npos) << what;
  EXPECT_EQ(what.find("unit"), std::string::npos) << what;
}

TEST(Validation, NonUnitQuaternionIsRejectedAsNotUnit) {
  for (const double scale : {2.0, 0.5, 1.0 + 2 * cr::kUnitTolerance}) {
    cr::Scene s = validScene();
    s.bodies[2].orientation.coeffs() *= scale;
    const std::string what = expectInvalid(s, "bodies[2].pose.orientation");
    EXPECT_NE(what.find("unit"), std::string::npos) << what;
    EXPECT_EQ(what.find("zero"), std::string::npos) << what;
  }
}

TEST(Validation, EmptyIdIsRejected) {
  cr::Scene s = validScene();
  s.bodies[1].id = "";
  expectInvalid(s, "bodies[1].id");
}

TEST(Validation, DuplicateIdIsRejectedAtTheSecondOccurrence) {
  cr::Scene s = validScene();
  s.bodies[2].id = "ground";
  const std::string what = expectInvalid(s, "bodies[2].id");
  EXPECT_NE(what.find("bodies[0]"), std::string::npos) << what;
}

// Ids are compared by a scan for a few bodies and through a hash table past 16: both find the same
// duplicates and resolve the same contacts, whichever side of the switch an id falls on.
TEST(Validation, IdsResolveTheSameAcrossTheScanAndTheTable) {
  for (const int count : {3, 16, 17, 18, 40}) {
    cr::Scene s;
    for (int i = 0; i < count; ++i) {
      cr::BodyState body;
      body.id = "body_number_" + std::to_string(i);  // longer than a short string
      body.mass = i == 0 ? 0.0 : 1.0;
      body.inertia = i == 0 ? Matrix3d::Zero() : Matrix3d(Vector3d(0.5, 0.3, 0.4).asDiagonal());
      body.position = Vector3d(i, 0, 0);
      s.bodies.push_back(body);
    }
    for (int k = 0; k + 1 < count; ++k) {  // from the last pair to the first
      cr::Contact c;
      c.body_a = s.bodies[count - 1 - k].id;
      c.body_b = s.bodies[count - 2 - k].id;
      c.point = Vector3d(count - 1.5 - k, 0, 0);
      c.normal = -Vector3d::UnitX();
      s.contacts.push_back(c);
    }
    const std::vector<std::pair<int, int>> pairs =
        cr::validate(s, cr::SolverOptions{}, cr::RequestLimits{});
    ASSERT_EQ(pairs.size(), s.contacts.size());
    for (int k = 0; k + 1 < count; ++k) {
      EXPECT_EQ(pairs[k], std::make_pair(count - 1 - k, count - 2 - k)) << count << " bodies";
    }
    cr::Scene unknown = s;
    unknown.contacts.back().body_b = "body_number_" + std::to_string(count);
    expectInvalid(unknown, "contacts[" + std::to_string(count - 2) + "].body_b");
    for (const int second : {1, count / 2, count - 1}) {
      cr::Scene twice = s;
      twice.bodies[second].id = s.bodies[second - 1].id;
      const std::string what = expectInvalid(twice, "bodies[" + std::to_string(second) + "].id");
      EXPECT_NE(what.find("bodies[" + std::to_string(second - 1) + "]"), std::string::npos) << what;
    }
  }
}

// An inertia given on its principal axes (diagonal) takes no eigen-solve: its moments are still
// sorted before the checks, so the triangle inequality is tested on the largest moment whichever
// diagonal entry holds it.
TEST(Validation, DiagonalInertiaIsCheckedOnItsSortedMoments) {
  for (const Vector3d& diagonal : {Vector3d(3, 1, 1), Vector3d(1, 3, 1), Vector3d(1, 1, 3)}) {
    cr::Scene s = validScene();
    s.bodies[2].inertia = diagonal.asDiagonal();
    const std::string what = expectInvalid(s, "bodies[2].inertia");
    EXPECT_NE(what.find("triangle"), std::string::npos) << what;
  }
  for (const Vector3d& diagonal : {Vector3d(0, 1, 1), Vector3d(1, -1, 1)}) {
    cr::Scene s = validScene();
    s.bodies[2].inertia = diagonal.asDiagonal();
    const std::string what = expectInvalid(s, "bodies[2].inertia");
    EXPECT_NE(what.find("positive definite"), std::string::npos) << what;
  }
  cr::Scene s = validScene();
  s.bodies[2].inertia = Vector3d(2, 1, 1.5).asDiagonal();  // 1 + 1.5 >= 2
  EXPECT_NO_THROW(cr::validate(s, cr::SolverOptions{}, cr::RequestLimits{}));
}

// --- Contacts. ----------------------------------------------------------------------------------
TEST(Validation, ZeroNormalIsRejectedAsZero) {
  cr::Scene s = validScene();
  s.contacts[1].normal = Vector3d::Zero();
  const std::string what = expectInvalid(s, "contacts[1].normal");
  EXPECT_NE(what.find("zero"), std::string::npos) << what;
  EXPECT_EQ(what.find("unit"), std::string::npos) << what;
}

TEST(Validation, NonUnitNormalIsRejectedAsNotUnit) {
  for (const Vector3d& n : {Vector3d(0, 2, 0), Vector3d(0.1, 0.1, 0), Vector3d(1, 1, 1)}) {
    cr::Scene s = validScene();
    s.contacts[0].normal = n;
    const std::string what = expectInvalid(s, "contacts[0].normal");
    EXPECT_NE(what.find("unit"), std::string::npos) << what;
    EXPECT_EQ(what.find("zero"), std::string::npos) << what;
  }
}

TEST(Validation, RestitutionOutsideUnitIntervalIsRejected) {
  for (const double e : {-0.1, -1e-12, 1.0 + 1e-12, 1.5}) {
    cr::Scene s = validScene();
    s.contacts[0].restitution = e;
    expectInvalid(s, "contacts[0].restitution");
  }
  for (const double e : {0.0, 1.0}) {  // the ends are valid
    cr::Scene s = validScene();
    s.contacts[0].restitution = e;
    EXPECT_NO_THROW(cr::validate(s, {}, {}));
  }
}

TEST(Validation, NegativeFrictionIsRejected) {
  cr::Scene s = validScene();
  s.contacts[0].static_friction = -0.1;
  s.contacts[0].dynamic_friction = -0.2;
  expectInvalid(s, "contacts[0].static_friction");
  s = validScene();
  s.contacts[0].dynamic_friction = -0.1;
  expectInvalid(s, "contacts[0].dynamic_friction");
}

TEST(Validation, DynamicFrictionAboveStaticIsRejected) {
  cr::Scene s = validScene();
  s.contacts[0].static_friction = 0.3;
  s.contacts[0].dynamic_friction = 0.31;
  const std::string what = expectInvalid(s, "contacts[0].dynamic_friction");
  EXPECT_NE(what.find("static"), std::string::npos) << what;
  s.contacts[0].dynamic_friction = 0.3;  // equal is fine
  EXPECT_NO_THROW(cr::validate(s, {}, {}));
}

TEST(Validation, UnknownBodyIdIsRejected) {
  cr::Scene s = validScene();
  s.contacts[1].body_a = "nobody";
  std::string what = expectInvalid(s, "contacts[1].body_a");
  EXPECT_NE(what.find("nobody"), std::string::npos) << what;
  s = validScene();
  s.contacts[0].body_b = "Ball";  // ids are case-sensitive
  expectInvalid(s, "contacts[0].body_b");
  s = validScene();
  s.contacts[0].body_b = "";
  expectInvalid(s, "contacts[0].body_b");
}

TEST(Validation, SelfReferencingContactIsRejected) {
  cr::Scene s = validScene();
  s.contacts[1].body_b = "ball";
  expectInvalid(s, "contacts[1].body_b");
}

TEST(Validation, ContactBetweenTwoImmovableBodiesIsRejected) {
  cr::Scene s = validScene();
  s.bodies[2].mass = 0.0;
  s.contacts[1].body_a = "ground";
  s.contacts[1].body_b = "box";
  const std::string what = expectInvalid(s, "contacts[1]");
  EXPECT_NE(what.find("immovable"), std::string::npos) << what;
}

// Contacts whose bodies are given by index (detected contacts: SceneValidator::checkContacts()
// with body pairs) are recorded as given, not looked up by id, and get the same checks as contacts
// named by id: the same field for a bad value, a body paired with itself, two immovable bodies.
TEST(Validation, ContactsWithBodyIndicesAreRecordedAndCheckedAsThoseNamedById) {
  cr::Scene s = validScene();
  const std::vector<cr::Contact> later = s.contacts;
  s.contacts.clear();
  {
    cr::SceneValidator validator(s, {}, {});
    validator.checkContacts(s);  // none yet
    s.contacts = later;
    s.contacts[1].body_a = s.contacts[1].body_b = "a name no body has";  // not read
    validator.checkContacts(s, {{0, 1}, {1, 2}});
    ASSERT_EQ(validator.contactBodies().size(), 2u);
    EXPECT_EQ(validator.contactBodies()[0], std::make_pair(0, 1));
    EXPECT_EQ(validator.contactBodies()[1], std::make_pair(1, 2));
  }
  const auto field_of = [](const cr::Scene& scene, std::vector<std::pair<int, int>> bodies) {
    cr::Scene empty = scene;
    empty.contacts.clear();
    cr::SceneValidator validator(empty, {}, {});
    try {
      validator.checkContacts(scene, bodies);
    } catch (const cr::InvalidInput& e) {
      return e.field();
    }
    return std::string("(accepted)");
  };
  s = validScene();
  EXPECT_EQ(field_of(s, {{0, 1}, {1, 3}}), "contacts[1].body_b");  // no body 3
  EXPECT_EQ(field_of(s, {{-1, 1}, {1, 2}}), "contacts[0].body_a");
  EXPECT_EQ(field_of(s, {{0, 1}, {1, 1}}), "contacts[1].body_b");  // itself
  s.contacts[0].normal = Vector3d(0, 2, 0);
  EXPECT_EQ(field_of(s, {{0, 1}, {1, 2}}), "contacts[0].normal");
  s = validScene();
  s.bodies[2].mass = 0.0;
  EXPECT_EQ(field_of(s, {{0, 1}, {0, 2}}), "contacts[1]");     // both immovable
  EXPECT_THROW(field_of(s, {{0, 1}}), std::invalid_argument);  // one pair per contact
}

// --- Limits and options. ------------------------------------------------------------------------
TEST(Validation, TooManyBodiesIsRejected) {
  const cr::Scene s = validScene();  // 3 bodies
  cr::RequestLimits limits;
  limits.max_bodies = 2;
  expectInvalid(s, "bodies", {}, limits);
  limits.max_bodies = 3;
  EXPECT_NO_THROW(cr::computeResponse(s, {}, limits));
}

TEST(Validation, TooManyContactsIsRejected) {
  const cr::Scene s = validScene();  // 2 contacts
  cr::RequestLimits limits;
  limits.max_contacts = 1;
  expectInvalid(s, "contacts", {}, limits);
  limits.max_contacts = 2;
  EXPECT_NO_THROW(cr::computeResponse(s, {}, limits));
}

TEST(Validation, LimitsAreCheckedBeforeAnyOtherField) {
  cr::Scene s = validScene();
  s.bodies[0].mass = kNaN;
  cr::RequestLimits limits;
  limits.max_bodies = 1;
  expectInvalid(s, "bodies", {}, limits);
}

TEST(Validation, BadSolverOptionsAreRejected) {
  const cr::Scene s = validScene();
  cr::SolverOptions o;
  o.tolerance = -1e-9;
  expectInvalid(s, "options.tolerance", o);
  o.tolerance = kNaN;
  expectInvalid(s, "options.tolerance", o);
  o.tolerance = kInf;
  expectInvalid(s, "options.tolerance", o);
  o = cr::SolverOptions{};
  o.max_iterations = 0;
  expectInvalid(s, "options.max_iterations", o);
  o = cr::SolverOptions{};
  o.integration_tolerance = 0.0;
  expectInvalid(s, "options.integration_tolerance", o);
  o.integration_tolerance = kNaN;
  expectInvalid(s, "options.integration_tolerance", o);
}

TEST(Validation, FirstOffendingFieldIsNamed) {
  // Two errors: the earlier body is reported.
  cr::Scene s = validScene();
  s.bodies[1].mass = -1.0;
  s.bodies[2].inertia = Matrix3d::Zero();
  expectInvalid(s, "bodies[1].inertia.m");
}

}  // namespace

namespace {

// Magnitudes beyond MagnitudeLimits are rejected, naming the field (the fuzzer's overflow inputs:
// a 1e-300 kg ball, a contact 1e80 m from the centre, a ball at 2e160 m/s; and a time budget whose
// conversion to std::chrono would overflow).
TEST(Validation, MagnitudesOutsideThePhysicalRangeAreRejected) {
  const std::vector<std::pair<std::function<void(cr::Scene&)>, std::string>> cases = {
      {[](cr::Scene& s) { s.bodies[1].mass = 1e-300; }, "bodies[1].inertia.m"},
      {[](cr::Scene& s) { s.bodies[1].mass = 1e20; }, "bodies[1].inertia.m"},
      {[](cr::Scene& s) { s.bodies[1].inertia = Matrix3d::Identity() * 1e-40; },
       "bodies[1].inertia"},
      {[](cr::Scene& s) { s.bodies[2].position.x() = 1e80; }, "bodies[2].pose.position"},
      {[](cr::Scene& s) { s.bodies[1].linear_velocity.y() = -2.2e160; }, "bodies[1].twist.linear"},
      {[](cr::Scene& s) { s.bodies[2].angular_velocity.z() = 1e9; }, "bodies[2].twist.angular"},
      {[](cr::Scene& s) { s.bodies[2].force.z() = 1e20; }, "bodies[2].wrench.force"},
      {[](cr::Scene& s) { s.contacts[1].point.x() = 1e80; }, "contacts[1].point"},
  };
  for (const auto& [mutate, field] : cases) {
    SCOPED_TRACE(field);
    cr::Scene s = validScene();
    mutate(s);
    expectInvalid(s, field);
  }
  // A lever arm beyond 1e6 radii of gyration: ball (0.5 m from contact 0) with k = 1e-7 m.
  cr::Scene lever = validScene();
  lever.bodies[1].mass = 1e12;
  lever.bodies[1].inertia = Matrix3d::Identity() * 1e-2;  // k^2 = 1e-14 m^2
  const std::string message = expectInvalid(lever, "contacts[0].point");
  EXPECT_NE(message.find("bodies[1] ('ball')"), std::string::npos) << message;
  lever.bodies[1].inertia = Matrix3d::Identity() * 1.0;  // k = 1e-6 m: lever 5e5 k, accepted
  EXPECT_NO_THROW(cr::validate(lever, {}, {}));
  // The stress suite's extremes stay inside: 1 g, 1e9 kg, 1e4 m/s, 1e5 m.
  cr::Scene s = validScene();
  s.bodies[1].mass = 1e-3;
  s.bodies[2].mass = 1e9;
  s.bodies[2].inertia *= 1e9;
  s.bodies[1].linear_velocity.y() = -1e4;
  EXPECT_NO_THROW(cr::validate(s, {}, {}));
  cr::SolverOptions huge_budget;
  huge_budget.time_budget = 1e77;
  expectInvalid(validScene(), "options.time_budget", huge_budget);
}

}  // namespace

// InvalidInput names the value by its path in the request, as segments, so that a caller can name
// it in something larger (a batch, a request with detected contacts) without editing strings.
TEST(InvalidInput, PathSegmentsPrefixAndRename) {
  const cr::InvalidInput error("bodies[1].inertia.m", "is negative (-1 kg)");
  EXPECT_EQ(error.path(), (std::vector<std::string>{"bodies[1]", "inertia", "m"}));
  EXPECT_EQ(error.field(), "bodies[1].inertia.m");
  EXPECT_EQ(error.reason(), "is negative (-1 kg)");
  EXPECT_STREQ(error.what(), "bodies[1].inertia.m: is negative (-1 kg)");
  const cr::InvalidInput in_batch = error.prefixed("scenes[3]");
  EXPECT_STREQ(in_batch.what(), "scenes[3].bodies[1].inertia.m: is negative (-1 kg)");
  EXPECT_EQ(in_batch.path().size(), 4u);
  const cr::InvalidInput renamed = cr::InvalidInput("contacts[5].normal", "is a zero vector")
                                       .withFirstSegment("detected_contacts[2]");
  EXPECT_STREQ(renamed.what(), "detected_contacts[2].normal: is a zero vector");
}
