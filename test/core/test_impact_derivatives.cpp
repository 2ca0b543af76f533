// Derivatives of the impact map (impact_derivatives.h) against references computed without the
// code under test: central differences of computeResponse() itself, taken here with their own
// step, at seeded random scenes away from mode switches; one-sided differences on the reported
// side at an exact stick/slide switch; and, for a frictionless contact, the closed forms
// dv'/dv = I - (1 + e) M^-1 J^T (J M^-1 J^T)^-1 J and dv'/de = -M^-1 J^T (J M^-1 J^T)^-1 u_n with
// M and J written out here.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "collision_response/core/compute_response.h"
#include "collision_response/core/contact_space.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/impact_derivatives.h"
#include "collision_response/core/impulse_space_derivatives.h"
#include "collision_response/core/impulse_space_integrator.h"
#include "collision_response/core/problem_contact.h"
#include "collision_response/core/scene.h"
#include "collision_response/core/solver_options.h"
#include "collision_response/core/validation.h"

#include "scenes.h"

namespace cr = collision_response::core;
using namespace collision_response::testing;  // NOLINT: shared builders
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

// ---- The reference: the library's prediction as a function, differenced here ----------------

// Outputs in the layout of ImpactDerivatives: the movable bodies' twists, then per contact the
// normal impulse and the friction impulse; and each contact's mode (0 no impulse, 1 sticking, 2
// sliding) as the prediction reports it.
struct Outputs {
  VectorXd values;
  std::vector<int> modes;
};

Outputs predict(const cr::Scene& scene, const cr::SolverOptions& options) {
  const cr::CollisionResult result = cr::computeResponse(scene, options);
  std::vector<double> values;
  for (std::size_t b = 0; b < scene.bodies.size(); ++b) {
    if (scene.bodies[b].mass == 0.0) continue;
    for (int k = 0; k < 3; ++k) values.push_back(result.bodies[b].linear_velocity[k]);
    for (int k = 0; k < 3; ++k) values.push_back(result.bodies[b].angular_velocity[k]);
  }
  Outputs out;
  for (const cr::ContactImpulse& impulse : result.impulses) {
    values.push_back(impulse.normal_impulse);
    for (int k = 0; k < 3; ++k) values.push_back(impulse.friction_impulse[k]);
    const bool none = impulse.normal_impulse == 0.0 && impulse.friction_impulse.isZero(0.0);
    out.modes.push_back(none ? 0 : impulse.sticking ? 1 : 2);
  }
  // The solve's discretisation (integration steps, sweeps): the integrations' outputs jump by their
  // error where it changes, so a difference across it is not a derivative.
  for (const cr::SolveReport& island : result.islands) {
    out.modes.push_back(static_cast<int>(island.iterations));
  }
  out.values = Eigen::Map<VectorXd>(values.data(), static_cast<Eigen::Index>(values.size()));
  return out;
}

// A reference to input `column` of the scene (layout of ImpactDerivatives' columns).
double& input(cr::Scene& scene, int column) {
  int k = column;
  for (cr::BodyState& body : scene.bodies) {
    if (body.mass == 0.0) continue;
    if (k < 3) return body.linear_velocity[k];
    if (k < 6) return body.angular_velocity[k - 3];
    k -= 6;
  }
  cr::Contact& c = scene.contacts[k / 3];
  return k % 3 == 0 ? c.restitution : k % 3 == 1 ? c.static_friction : c.dynamic_friction;
}

// The step of input `column`: relative to the input's scale.
double stepOf(const cr::Scene& scene, int column, double relative) {
  cr::Scene copy = scene;
  return relative * std::max(1.0, std::abs(input(copy, column)));
}

// The scale a column that vanishes is compared at: 1e-2 of the outputs' magnitude per unit of the
// input's scale (a difference quotient cannot resolve less than the solve's round-off over the
// step: 1e-14 / 1e-6 = 1e-8 of the outputs for a pivoting solve).
double floorOf(const cr::Scene& scene, const cr::SolverOptions& options, int column) {
  cr::Scene copy = scene;
  return 1e-2 * predict(scene, options).values.cwiseAbs().maxCoeff() /
         std::max(1.0, std::abs(input(copy, column)));
}

// Central difference of the prediction along one input; false if a contact's mode changes
// within the step (the column is then near a switch and not compared).
bool centralDifference(const cr::Scene& scene, const cr::SolverOptions& options, int column,
                       double relative, VectorXd& derivative) {
  const double h = stepOf(scene, column, relative);
  const Outputs base = predict(scene, options);
  cr::Scene plus = scene, minus = scene;
  input(plus, column) += h;
  input(minus, column) -= h;
  const Outputs p = predict(plus, options), m = predict(minus, options);
  if (p.modes != base.modes || m.modes != base.modes) return false;
  derivative = (p.values - m.values) / (2.0 * h);
  // The reference holds where the map is smooth at the step's scale: the central difference with
  // twice the step agrees to 1e-7 (truncation error ~ h^2); otherwise an event inside the solve
  // lies within the steps and the column is not compared.
  input(plus, column) += h;
  input(minus, column) -= h;
  const Outputs p2 = predict(plus, options), m2 = predict(minus, options);
  if (p2.modes != base.modes || m2.modes != base.modes) return false;
  const VectorXd wide = (p2.values - m2.values) / (4.0 * h);
  const double scale = std::max(derivative.cwiseAbs().maxCoeff(), floorOf(scene, options, column));
  return (wide - derivative).cwiseAbs().maxCoeff() <= 1e-7 * scale;
}

// Each column of the Jacobian against the central differences, to `tolerance` of the column's
// largest magnitude; returns the number of columns compared.
int compareWithDifferences(const cr::Scene& scene, const cr::SolverOptions& options,
                           const cr::ImpactDerivatives& d, double relative_step, double tolerance,
                           const std::string& what) {
  int compared = 0;
  for (int col = 0; col < d.jacobian.cols(); ++col) {
    // A coefficient whose central step leaves its valid range (e = 0 or 1, mu_d = mu_s, mu = 0)
    // is not compared here.
    cr::Scene probe = scene;
    const double x = input(probe, col), h = stepOf(scene, col, relative_step);
    const int k = col - static_cast<int>(d.velocityCount());
    if (k >= 0) {
      const cr::Contact& c = scene.contacts[k / 3];
      if (k % 3 == 0 && (x - h < 0.0 || x + h > 1.0)) continue;
      if (k % 3 == 1 && (x - h < c.dynamic_friction)) continue;
      if (k % 3 == 2 && (x - h < 0.0 || x + h > c.static_friction)) continue;
    }
    VectorXd reference;
    if (!centralDifference(scene, options, col, relative_step, reference)) continue;
    const double scale = std::max(reference.cwiseAbs().maxCoeff(), floorOf(scene, options, col));
    for (int row = 0; row < d.jacobian.rows(); ++row) {
      EXPECT_NEAR(d.jacobian(row, col), reference(row), tolerance * scale)
          << what << ": d " << d.rowLabels()[row] << " / d " << d.columnLabels()[col];
    }
    ++compared;
  }
  return compared;
}

// ---- Scenes -----------------------------------------------------------------------------------

cr::BodyState randomBody(RandomSource& random, const std::string& id, const Vector3d& position) {
  cr::BodyState b;
  b.id = id;
  b.mass = random.uniform(0.5, 5.0);
  b.inertia = boxInertia(b.mass, random.boxSize());
  b.orientation = random.rotation();
  b.com = random.vec(-0.1, 0.1);
  b.position = position;
  b.linear_velocity = random.vec(-1.0, 1.0);
  b.angular_velocity = random.vec(-2.0, 2.0);
  return b;
}

// `contacts` contacts between a body "b" and either the ground or a second movable body "a"
// below it, normals near +z (from a to b), points within 0.4 m of b's centre; b moves down fast
// enough that the contacts approach.
cr::Scene randomScene(RandomSource& random, int contacts, bool two_bodies, double e_max,
                      double mu_s, double mu_d) {
  cr::Scene scene;
  scene.bodies.push_back(two_bodies ? randomBody(random, "a", Vector3d(0, 0, -0.5)) : ground());
  scene.bodies.push_back(randomBody(random, "b", Vector3d(0, 0, 0.5)));
  scene.bodies[1].linear_velocity.z() -= 3.0;
  for (int i = 0; i < contacts; ++i) {
    const Vector3d p = Vector3d(0, 0, 0.3) + random.vec(-0.4, 0.4);
    const Vector3d n = (Vector3d::UnitZ() + random.vec(-0.3, 0.3)).normalized();
    scene.contacts.push_back(
        contact(scene.bodies[0].id, "b", p, n, random.uniform(0.0, e_max), mu_s, mu_d));
  }
  return scene;
}

int countMode(const cr::ImpactDerivatives& d, cr::ImpactMode mode) {
  return static_cast<int>(std::count_if(d.contacts.begin(), d.contacts.end(),
                                        [&](const auto& c) { return c.mode == mode; }));
}

bool anySwitch(const cr::ImpactDerivatives& d) {
  return std::any_of(d.contacts.begin(), d.contacts.end(),
                     [](const auto& c) { return c.at_switch; });
}

cr::SolverOptions withLaw(cr::ImpactLaw law) {
  cr::SolverOptions options;
  options.law = law;
  options.integration_tolerance = 1e-14;
  // The physics is tested, not the speed: the time budget now bounds the whole call, prediction
  // and every finite-difference solve (several hundred under the sanitizers' slowdown).
  options.time_budget = 600.0;
  return options;
}

// ---- Newton, one contact: the closed form's derivatives --------------------------------------

TEST(ImpactDerivatives, NewtonSingleContactMatchesCentralDifferencesStickingAndSliding) {
  RandomSource random(2611);
  int sticking = 0, sliding = 0, compared = 0;
  for (int trial = 0; trial < 80 && (sticking < 10 || sliding < 10); ++trial) {
    const bool two_bodies = trial % 2 == 1;
    // Large mu_s mostly sticks; small, with mu_d < mu_s, mostly slides.
    const bool want_stick = trial % 4 < 2;
    const double mu_s = want_stick ? random.uniform(1.0, 3.0) : random.uniform(0.05, 0.3);
    const double mu_d = random.uniform(0.3, 0.9) * mu_s;
    const cr::Scene scene = randomScene(random, 1, two_bodies, 0.9, mu_s, mu_d);
    const cr::SolverOptions options = withLaw(cr::ImpactLaw::kNewton);
    const cr::ImpactDerivatives d = cr::computeImpactDerivatives(scene, options);
    ASSERT_EQ(d.method, cr::DerivativeMethod::kAnalytic);
    if (anySwitch(d) || d.contacts[0].mode == cr::ImpactMode::kNoImpulse) continue;
    sticking += d.contacts[0].mode == cr::ImpactMode::kSticking;
    sliding += d.contacts[0].mode == cr::ImpactMode::kSliding;
    compared += compareWithDifferences(scene, options, d, 1e-6, 1e-6,
                                       "single contact, trial " + std::to_string(trial));
  }
  EXPECT_GE(sticking, 10);
  EXPECT_GE(sliding, 10);
  EXPECT_GE(compared, 20 * 9);
}

// ---- Newton, several contacts: the exact solver's active set ----------------------------------

TEST(ImpactDerivatives, NewtonSeveralContactsMatchCentralDifferences) {
  RandomSource random(2612);
  int cases = 0, sticking = 0, sliding = 0, none = 0, compared = 0, columns = 0;
  for (int trial = 0; trial < 120 && cases < 30; ++trial) {
    const int contacts = 2 + trial % 3;
    const double mu_s = random.uniform(0.05, 1.5);
    const double mu_d = random.uniform(0.3, 1.0) * mu_s;
    const cr::Scene scene = randomScene(random, contacts, trial % 2 == 1, 0.9, mu_s, mu_d);
    const cr::SolverOptions options = withLaw(cr::ImpactLaw::kNewton);
    const cr::ImpactDerivatives d = cr::computeImpactDerivatives(scene, options);
    if (d.result.islands.size() != 1 || d.result.islands[0].method != cr::SolvedBy::kExact) {
      continue;
    }
    ASSERT_EQ(d.method, cr::DerivativeMethod::kAnalytic);
    if (anySwitch(d)) continue;
    sticking += countMode(d, cr::ImpactMode::kSticking);
    sliding += countMode(d, cr::ImpactMode::kSliding);
    none += countMode(d, cr::ImpactMode::kNoImpulse);
    compared += compareWithDifferences(
        scene, options, d, 1e-6, 1e-6,
        std::to_string(contacts) + " contacts, trial " + std::to_string(trial));
    columns += static_cast<int>(d.jacobian.cols());
    ++cases;
  }
  EXPECT_GE(cases, 20);
  // Columns left out: coefficients at the ends of their ranges, and steps that change a mode.
  EXPECT_GE(compared, columns * 3 / 4) << compared << " of " << columns;
  std::printf("newton, several contacts: %d of %d columns compared\n", compared, columns);
  EXPECT_GE(sticking, 5);
  EXPECT_GE(sliding, 5);
  EXPECT_GE(none, 3);
}

// ---- Poisson, Stronge: analytic for one contact and for islands integrated together ----------

// Whether the library differentiates an island solved as `island` reports: one contact integrated
// to its end, or several integrated together (SolvedBy::kSimultaneousImpulseSpace) without a
// fallback.
bool impulseSpaceAnalytic(const cr::SolveReport& island) {
  const bool integrated = island.converged &&
                          !(island.impulse_space && island.impulse_space->fallback) &&
                          (island.method == cr::SolvedBy::kImpulseSpace ||
                           island.method == cr::SolvedBy::kSimultaneousImpulseSpace);
  return integrated;
}

TEST(ImpactDerivatives, ImpulseSpaceLawsMatchTheTestsOwnDifferences) {
  RandomSource random(2613);
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    int cases = 0, compared = 0, columns = 0;
    for (int trial = 0; trial < 40 && cases < 8; ++trial) {
      const int contacts = 1 + trial % 3;
      const double mu_s = random.uniform(0.05, 1.5);
      const double mu_d = random.uniform(0.3, 1.0) * mu_s;
      const cr::Scene scene = randomScene(random, contacts, trial % 2 == 1, 0.9, mu_s, mu_d);
      const cr::SolverOptions options = withLaw(law);
      const cr::ImpactDerivatives d = cr::computeImpactDerivatives(scene, options);
      // The sensitivity of the integration, of one contact or of several together; otherwise
      // (a fallback) the library's differences.
      const cr::DerivativeMethod method =
          d.result.islands.size() == 1 && impulseSpaceAnalytic(d.result.islands[0])
              ? cr::DerivativeMethod::kAnalytic
              : cr::DerivativeMethod::kFiniteDifference;
      // Several contacts may still be differenced where the dual run refuses or its round-off takes
      // another branch than the solve's (ImpulseSpaceSeveralContactsAreAnalytic... counts how
      // often); never analytic after a fallback. Every contact reports the result's method.
      if (d.result.islands.size() == 1) {
        if (contacts == 1 || method == cr::DerivativeMethod::kFiniteDifference) {
          EXPECT_EQ(d.method, method);
        }
        for (const auto& c : d.contacts) EXPECT_EQ(c.method, d.method);
      }
      if (anySwitch(d)) continue;
      // The library differences with a step of 1e-7, this test with 4e-7.
      compared += compareWithDifferences(
          scene, options, d, 4e-7, 1e-6,
          std::string(cr::toString(law)) + ", trial " + std::to_string(trial));
      columns += static_cast<int>(d.jacobian.cols());
      ++cases;
    }
    EXPECT_GE(cases, 5) << cr::toString(law);
    // Left out besides: columns whose steps cross an event inside the integration.
    EXPECT_GE(compared, columns / 2) << cr::toString(law) << ": " << compared << " of " << columns;
    std::printf("%s: %d of %d columns compared\n", cr::toString(law), compared, columns);
  }
}

// Several contacts under Poisson and Stronge integrated together (the default for islands of up
// to 12 contacts): the dual-number run of the integration against the test's central differences
// of computeResponse(), at random scenes of 2 to 4 contacts on one body or between two (mu_s >
// mu_d; every third scene with high friction, whose contacts stop and stick during the impact),
// away from switches (the counts of contacts ending sticking and sliding are printed). Without the
// sensitivity (the library differencing these islands) the method check fails.
TEST(ImpactDerivatives, ImpulseSpaceSeveralContactsAreAnalyticAndMatchCentralDifferences) {
  RandomSource random(2626);
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    int cases = 0, eligible = 0, compared = 0, columns = 0, sticking = 0, sliding = 0;
    for (int trial = 0; trial < 120 && cases < 18; ++trial) {
      const int contacts = 2 + trial % 3;
      // Every third scene with high friction, so that contacts stop and stick.
      const double mu_s = trial % 3 == 0 ? random.uniform(1.5, 3.0) : random.uniform(0.1, 1.2);
      const double mu_d = random.uniform(0.4, 0.9) * mu_s;
      const cr::Scene scene = randomScene(random, contacts, trial % 2 == 1, 0.9, mu_s, mu_d);
      const cr::SolverOptions options = withLaw(law);
      const cr::ImpactDerivatives d = cr::computeImpactDerivatives(scene, options);
      if (d.result.islands.size() != 1 ||
          d.result.islands[0].method != cr::SolvedBy::kSimultaneousImpulseSpace ||
          !impulseSpaceAnalytic(d.result.islands[0])) {
        continue;
      }
      // The dual run reproduces the solve's impulses unless round-off takes another branch (then
      // the library differences; see the count below).
      ++eligible;
      if (d.method != cr::DerivativeMethod::kAnalytic) continue;
      if (anySwitch(d)) continue;
      sticking += countMode(d, cr::ImpactMode::kSticking);
      sliding += countMode(d, cr::ImpactMode::kSliding);
      compared +=
          compareWithDifferences(scene, options, d, 4e-7, 1e-6,
                                 std::string(cr::toString(law)) + ", " + std::to_string(contacts) +
                                     " contacts, trial " + std::to_string(trial));
      columns += static_cast<int>(d.jacobian.cols());
      ++cases;
    }
    EXPECT_GE(cases, 12) << cr::toString(law);
    EXPECT_GE(cases, eligible * 3 / 4) << cr::toString(law) << ": " << cases << " of " << eligible;
    EXPECT_GE(compared, columns / 2) << cr::toString(law) << ": " << compared << " of " << columns;
    EXPECT_GE(sliding, 4) << cr::toString(law);
    std::printf(
        "%s, several contacts: %d cases, %d of %d columns compared, %d sticking, %d "
        "sliding\n",
        cr::toString(law), cases, compared, columns, sticking, sliding);
  }
}

// A cube turning onto its edge: corner 0 touches with u_n = 0 exactly (v_z = -1 m/s, w_y = 2 rad/s
// at x = -0.5: -1 + 0.5 * 2 = 0 in binary), corner 1 approaches at 2 m/s. Integrated together;
// a perturbation makes corner 0 approach (it compresses) or separate (it stays idle): the
// derivative is one-sided there and corner 0 must say so, whichever way the library takes it.
TEST(ImpactDerivatives, ImpulseSpaceSeveralContactsTouchingContactIsFlagged) {
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    cr::Scene scene;
    scene.bodies.push_back(ground());
    cr::BodyState cube;
    cube.id = "cube";
    cube.mass = 1.5;
    cube.inertia = boxInertia(cube.mass, Vector3d(1, 1, 1));
    cube.position = Vector3d(0, 0, 0.5);
    cube.linear_velocity = Vector3d(0.3, 0.0, -1.0);
    cube.angular_velocity = Vector3d(0.0, 2.0, 0.0);
    scene.bodies.push_back(cube);
    for (const double x : {-0.5, 0.5}) {
      scene.contacts.push_back(
          contact("ground", "cube", Vector3d(x, 0.0, 0), Vector3d::UnitZ(), 0.5, 0.6, 0.4));
    }
    const cr::SolverOptions options = withLaw(law);
    const cr::ImpactDerivatives d = cr::computeImpactDerivatives(scene, options);
    ASSERT_EQ(d.result.impulses[0].normal_velocity_before, 0.0) << cr::toString(law);
    ASSERT_LT(d.result.impulses[1].normal_velocity_before, -1.9) << cr::toString(law);
    ASSERT_EQ(d.result.islands.size(), 1u);
    EXPECT_EQ(d.result.islands[0].method, cr::SolvedBy::kSimultaneousImpulseSpace);
    EXPECT_TRUE(d.contacts[0].at_switch) << cr::toString(law) << ": " << cr::toString(d.method);
    EXPECT_NE(d.contacts[0].switch_detail.find("u_n = 0"), std::string::npos)
        << cr::toString(law) << ": " << d.contacts[0].switch_detail;
  }
}

// ---- At a switch: the one-sided derivative of the reported mode -------------------------------

// M^-1 and the contact Jacobian J (3 x 6, u = J v) of one movable body against the ground, written
// out here: J = [I3, -[r]x] with r = p - c.
struct OneBody {
  MatrixXd M_inv = MatrixXd::Zero(6, 6);
  MatrixXd J = MatrixXd::Zero(3, 6);
};

OneBody oneBody(const cr::BodyState& body, const Vector3d& p) {
  OneBody out;
  const Matrix3d I_world = worldInertia(body);
  out.M_inv.topLeftCorner<3, 3>() = Matrix3d::Identity() / body.mass;
  out.M_inv.bottomRightCorner<3, 3>() = I_world.inverse();
  const Vector3d r = p - worldCom(body);
  Matrix3d r_cross;
  r_cross << 0, -r.z(), r.y(), r.z(), 0, -r.x(), -r.y(), r.x(), 0;
  out.J.leftCols<3>() = Matrix3d::Identity();
  out.J.rightCols<3>() = -r_cross;
  return out;
}

TEST(ImpactDerivatives, AtTheStickSlideSwitchTheOneSidedDerivativeMatchesItsSide) {
  RandomSource random(2614);
  int checked = 0;
  for (int trial = 0; trial < 10; ++trial) {
    cr::Scene scene = randomScene(random, 1, false, 0.8, 1.0, 0.5);
    cr::BodyState& body = scene.bodies[1];
    cr::Contact& c = scene.contacts[0];
    const Vector3d n = c.normal.normalized();
    // The sticking impulse q = K^-1 (-u - e u_n n), K = J M^-1 J^T, from the test's own M and J;
    // mu_s set to |q_t| / q_n (a hair above, so that the prediction sticks), mu_d = mu_s / 2.
    const OneBody m = oneBody(body, c.point);
    Eigen::Matrix<double, 6, 1> v;
    v << body.linear_velocity, body.angular_velocity;
    const Vector3d u = m.J * v;
    const double u_n = u.dot(n);
    ASSERT_LT(u_n, 0.0);
    const Matrix3d K = m.J * m.M_inv * m.J.transpose();
    const Vector3d q = K.inverse() * (-u - c.restitution * u_n * n);
    const double q_n = q.dot(n);
    if (!(q_n > 0.0)) continue;
    c.static_friction = (q - q_n * n).norm() / q_n * (1.0 + 1e-13);
    c.dynamic_friction = 0.5 * c.static_friction;
    const cr::SolverOptions options = withLaw(cr::ImpactLaw::kNewton);
    const cr::ImpactDerivatives d = cr::computeImpactDerivatives(scene, options);
    ASSERT_TRUE(d.contacts[0].at_switch) << trial;
    ASSERT_EQ(d.contacts[0].mode, cr::ImpactMode::kSticking) << d.contacts[0].switch_detail;
    EXPECT_NE(d.contacts[0].switch_detail.find("sticking side"), std::string::npos);
    // Each column: the second-order one-sided difference on the side that keeps sticking.
    const Outputs base = predict(scene, options);
    for (int col = 0; col < d.jacobian.cols(); ++col) {
      const double h = stepOf(scene, col, 1e-6);
      bool found = false;
      for (const double sign : {1.0, -1.0}) {
        cr::Scene near = scene, far = scene;
        input(near, col) += sign * h;
        input(far, col) += 2.0 * sign * h;
        const Outputs p1 = predict(near, options), p2 = predict(far, options);
        if (p1.modes != base.modes || p2.modes != base.modes) continue;
        const VectorXd reference =
            sign * (-3.0 * base.values + 4.0 * p1.values - p2.values) / (2.0 * h);
        const double scale =
            std::max(reference.cwiseAbs().maxCoeff(), floorOf(scene, options, col));
        for (int row = 0; row < d.jacobian.rows(); ++row) {
          EXPECT_NEAR(d.jacobian(row, col), reference(row), 1e-5 * scale)
              << "trial " << trial << ": d " << d.rowLabels()[row] << " / d "
              << d.columnLabels()[col] << " (side " << sign << ")";
        }
        found = true;
        break;
      }
      EXPECT_TRUE(found) << "no side keeps the contact sticking for " << d.columnLabels()[col];
    }
    // The other side is a different map: sliding with mu_d < mu_s jumps.
    cr::Scene slide = scene;
    slide.contacts[0].static_friction *= 1.0 - 1e-6;
    EXPECT_EQ(predict(slide, options).modes[0], 2);
    ++checked;
  }
  EXPECT_GE(checked, 5);
}

// ---- Frictionless: the closed forms ------------------------------------------------------------

TEST(ImpactDerivatives, FrictionlessSingleContactClosedFormsForEveryLaw) {
  RandomSource random(2615);
  for (const cr::ImpactLaw law :
       {cr::ImpactLaw::kNewton, cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    for (int trial = 0; trial < 5; ++trial) {
      // Two movable bodies: M = diag(m_a I, I_a, m_b I, I_b), J the normal row
      // [-n^T, -(r_a x n)^T, n^T, (r_b x n)^T] (u_n = J v).
      const cr::Scene scene = randomScene(random, 1, true, 0.9, 0.0, 0.0);
      const cr::Contact& c = scene.contacts[0];
      const Vector3d n = c.normal.normalized();
      MatrixXd M_inv = MatrixXd::Zero(12, 12);
      Eigen::RowVectorXd J(12);
      VectorXd v(12);
      for (int k = 0; k < 2; ++k) {
        const cr::BodyState& b = scene.bodies[k];
        const OneBody part = oneBody(b, c.point);
        M_inv.block<6, 6>(6 * k, 6 * k) = part.M_inv;
        const double sign = k == 1 ? 1.0 : -1.0;
        J.segment<6>(6 * k) = sign * n.transpose() * part.J;
        v.segment<3>(6 * k) = b.linear_velocity;
        v.segment<3>(6 * k + 3) = b.angular_velocity;
      }
      const double u_n = J.dot(v);
      ASSERT_LT(u_n, 0.0);
      const double e = c.restitution;
      const double effective = 1.0 / (J * M_inv * J.transpose())(0, 0);
      const MatrixXd expected_dv =
          MatrixXd::Identity(12, 12) - (1.0 + e) * effective * M_inv * J.transpose() * J;
      const VectorXd expected_de = -effective * u_n * (M_inv * J.transpose());
      const cr::ImpactDerivatives d = cr::computeImpactDerivatives(scene, withLaw(law));
      // Newton in closed form; the impulse-space laws by their sensitivity, whose phases are
      // closed forms here (frictionless: u_n linear in the impulse), to round-off.
      const double tol = 1e-10;
      EXPECT_EQ(d.method, cr::DerivativeMethod::kAnalytic) << cr::toString(law);
      const MatrixXd dv = d.velocitiesByVelocities();
      EXPECT_LT((dv - expected_dv).cwiseAbs().maxCoeff(), tol * expected_dv.cwiseAbs().maxCoeff())
          << cr::toString(law) << " trial " << trial << "\n"
          << dv << "\n\n"
          << expected_dv;
      const VectorXd de = d.velocitiesByCoefficients().col(0);
      EXPECT_LT((de - expected_de).cwiseAbs().maxCoeff(), tol * expected_de.cwiseAbs().maxCoeff())
          << cr::toString(law) << " trial " << trial;
      // The normal impulse: dP_n/dv = -(1 + e) m_eff J, dP_n/de = -m_eff u_n.
      const MatrixXd dP = d.impulsesByVelocities();
      EXPECT_LT((dP.row(0) + (1.0 + e) * effective * J).cwiseAbs().maxCoeff(),
                tol * (effective * J).cwiseAbs().maxCoeff());
      EXPECT_NEAR(d.impulsesByCoefficients()(0, 0), -effective * u_n, tol * effective * -u_n);
      EXPECT_TRUE(d.contacts[0].at_switch);  // the friction columns are one-sided
      if (law != cr::ImpactLaw::kNewton) {
        // The mu_d column, for friction raised from 0 (mu_s = mu_d raised together; mu_s alone
        // does nothing to a slip that never stops): the second-order one-sided difference of the
        // solver. Friction acts along the turning frictionless slip: the integrated sensitivity.
        const int col = static_cast<int>(d.velocityCount()) + 2;
        const double h = 1e-5;
        const auto at = [&](double mu) {
          cr::Scene s = scene;
          s.contacts[0].static_friction = mu;
          s.contacts[0].dynamic_friction = mu;
          return predict(s, withLaw(law)).values;
        };
        const VectorXd reference = (-3.0 * at(0.0) + 4.0 * at(h) - at(2.0 * h)) / (2.0 * h);
        const double scale = reference.cwiseAbs().maxCoeff();
        ASSERT_GT(scale, 0.0);
        for (int row = 0; row < d.jacobian.rows(); ++row) {
          EXPECT_NEAR(d.jacobian(row, col), reference(row), 1e-6 * scale)
              << cr::toString(law) << " trial " << trial << ": d " << d.rowLabels()[row]
              << " / d mu_d at 0";
        }
      }
    }
  }
}

// ---- Poisson, Stronge, one contact: the analytic sensitivity ----------------------------------

// Every column against plain central differences (step 1e-5 of the input's scale) with the
// contact's mode kept on both sides, the solve's step counts let change: for maps that are smooth
// where the prediction changes its path (closed form on one side, integration on the other).
void comparePlain(const cr::Scene& scene, const cr::SolverOptions& options,
                  const cr::ImpactDerivatives& d, const std::string& what) {
  const Outputs base = predict(scene, options);
  for (int col = 0; col < d.jacobian.cols(); ++col) {
    const double h = stepOf(scene, col, 1e-5);
    cr::Scene plus = scene, minus = scene;
    input(plus, col) += h;
    input(minus, col) -= h;
    const Outputs p = predict(plus, options), m = predict(minus, options);
    ASSERT_EQ(p.modes[0], base.modes[0]) << what;
    ASSERT_EQ(m.modes[0], base.modes[0]) << what;
    const VectorXd reference = (p.values - m.values) / (2.0 * h);
    const double scale = std::max(reference.cwiseAbs().maxCoeff(), floorOf(scene, options, col));
    for (int row = 0; row < d.jacobian.rows(); ++row) {
      EXPECT_NEAR(d.jacobian(row, col), reference(row), 1e-6 * scale)
          << what << " " << cr::toString(options.law) << ": d " << d.rowLabels()[row] << " / d "
          << d.columnLabels()[col];
    }
  }
}

// One body against the ground or two bodies, one contact, under each impulse-space law: sticking
// during the impact (large mu), sliding throughout (small mu), and reversing (the slip stops and
// resumes the other way: small mu off-centre), with mu_s >= mu_d. Every column against the
// test's central differences of computeResponse() (integration tolerance 1e-14, so the solve's
// own error is 1e-9 of a difference quotient), to 1e-6 of the column.
TEST(ImpactDerivatives, ImpulseSpaceSingleContactIsAnalyticAndMatchesCentralDifferences) {
  RandomSource random(2617);
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    int stuck = 0, slid = 0, reversed = 0, compared = 0, columns = 0, cases = 0;
    for (int trial = 0; trial < 200 && (stuck < 8 || slid < 8 || reversed < 3); ++trial) {
      const bool two_bodies = trial % 3 == 2;
      const double mu_s = trial % 4 == 0   ? random.uniform(0.8, 2.5)
                          : trial % 4 == 1 ? random.uniform(0.05, 0.3)
                                           : random.uniform(0.05, 1.2);
      const double mu_d = random.uniform(0.4, 1.0) * mu_s;
      const cr::Scene scene = randomScene(random, 1, two_bodies, 0.9, mu_s, mu_d);
      const cr::SolverOptions options = withLaw(law);
      const cr::ImpactDerivatives d = cr::computeImpactDerivatives(scene, options);
      ASSERT_EQ(d.result.islands.size(), 1u);
      ASSERT_EQ(d.method, cr::DerivativeMethod::kAnalytic) << "trial " << trial;
      ASSERT_EQ(d.contacts[0].method, cr::DerivativeMethod::kAnalytic);
      if (anySwitch(d) || d.contacts[0].mode == cr::ImpactMode::kNoImpulse) continue;
      // The slip after the impact against the one before (one body on the ground: u = J v).
      bool reverses = false;
      if (!two_bodies) {
        const cr::Contact& c = scene.contacts[0];
        const Vector3d n = c.normal.normalized();
        const OneBody m = oneBody(scene.bodies[1], c.point);
        Eigen::Matrix<double, 6, 1> v, v_after;
        v << scene.bodies[1].linear_velocity, scene.bodies[1].angular_velocity;
        v_after << d.result.bodies[1].linear_velocity, d.result.bodies[1].angular_velocity;
        const Vector3d u = m.J * v, u_after = m.J * v_after;
        const Vector3d slip = u - u.dot(n) * n, slip_after = u_after - u_after.dot(n) * n;
        reverses = d.contacts[0].mode == cr::ImpactMode::kSliding && slip.dot(slip_after) < 0.0;
      }
      const bool sticks = d.contacts[0].mode == cr::ImpactMode::kSticking;
      stuck += sticks;
      reversed += reverses;
      slid += !sticks && !reverses;
      compared += compareWithDifferences(
          scene, options, d, 1e-5, 1e-6,
          std::string(cr::toString(law)) + ", trial " + std::to_string(trial));
      columns += static_cast<int>(d.jacobian.cols());
      ++cases;
    }
    std::printf("%s, one contact: %d sticking, %d sliding, %d reversing; %d of %d columns\n",
                cr::toString(law), stuck, slid, reversed, compared, columns);
    EXPECT_GE(stuck, 8) << cr::toString(law);
    EXPECT_GE(slid, 8) << cr::toString(law);
    EXPECT_GE(reversed, 3) << cr::toString(law);
    EXPECT_GE(compared, columns * 3 / 4) << cr::toString(law);
  }
}

// A central contact (the normal through the centre of mass of a sphere: K_tn = 0) under each
// impulse-space law, sticking once the slip has stopped: the integrator's closed-form stop; and a
// planar slip (the slip and K_tn in one plane, the slip's direction constant) whose derivatives
// across the plane must come from the rotating slip. Both against central differences.
TEST(ImpactDerivatives, ImpulseSpaceCentralAndPlanarContactsMatchCentralDifferences) {
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    cr::Scene central;
    central.bodies = {ground(), sphere("s", 2.0, 0.1, Vector3d(0, 0, 0.1),
                                       Vector3d(0.3, -0.2, -1.5), Vector3d(1.0, 2.0, -0.5))};
    central.contacts = {contact("ground", "s", Vector3d::Zero(), Vector3d::UnitZ(), 0.6, 0.9, 0.7)};
    cr::ImpactDerivatives d = cr::computeImpactDerivatives(central, withLaw(law));
    ASSERT_EQ(d.method, cr::DerivativeMethod::kAnalytic);
    EXPECT_EQ(d.contacts[0].mode, cr::ImpactMode::kSticking);
    EXPECT_FALSE(d.contacts[0].at_switch) << d.contacts[0].switch_detail;
    EXPECT_EQ(compareWithDifferences(central, withLaw(law), d, 1e-5, 1e-6, "central"), 9);

    // A box struck off-centre in its x-z plane, moving along x: the slip stays along x.
    cr::Scene planar;
    cr::BodyState box;
    box.id = "box";
    box.mass = 1.2;
    box.inertia = Vector3d(0.02, 0.05, 0.04).asDiagonal();
    box.position = {0.15, 0.0, 0.1};
    box.linear_velocity = {0.8, 0.0, -1.2};
    box.angular_velocity = {0.0, 0.5, 0.0};
    planar.bodies = {ground(), box};
    planar.contacts = {
        contact("ground", "box", Vector3d::Zero(), Vector3d::UnitZ(), 0.5, 0.3, 0.2)};
    d = cr::computeImpactDerivatives(planar, withLaw(law));
    ASSERT_EQ(d.method, cr::DerivativeMethod::kAnalytic);
    EXPECT_EQ(d.contacts[0].mode, cr::ImpactMode::kSliding);
    EXPECT_FALSE(d.contacts[0].at_switch) << d.contacts[0].switch_detail;
    // Across the plane the prediction leaves its closed form for the integration of a turning
    // slip (its step count changes, which compareWithDifferences() avoids): the map is smooth
    // there, so plain central differences (the contact's mode kept) are the reference.
    comparePlain(planar, withLaw(law), d, "planar");

    // No slip before the impact, mu_d above the sticking rate |K_tt^-1 K_tn|: a small slip either
    // way stops at once, so the map is smooth across u_t = 0 and the derivative two-sided (not
    // flagged); the tangential columns are those of sticking from the start.
    cr::Scene at_rest = planar;
    {
      // The linear velocity adds to u directly: less the slip, u_t = 0.
      const OneBody m = oneBody(at_rest.bodies[1], at_rest.contacts[0].point);
      Eigen::Matrix<double, 6, 1> v;
      v << at_rest.bodies[1].linear_velocity, at_rest.bodies[1].angular_velocity;
      const Vector3d u = m.J * v;
      at_rest.bodies[1].linear_velocity -= u - u.z() * Vector3d::UnitZ();
    }
    at_rest.contacts[0].static_friction = 3.0;
    at_rest.contacts[0].dynamic_friction = 2.5;
    d = cr::computeImpactDerivatives(at_rest, withLaw(law));
    ASSERT_EQ(d.method, cr::DerivativeMethod::kAnalytic);
    EXPECT_EQ(d.contacts[0].mode, cr::ImpactMode::kSticking);
    EXPECT_FALSE(d.contacts[0].at_switch) << d.contacts[0].switch_detail;
    comparePlain(at_rest, withLaw(law), d, "no slip before");
  }
}

// Stronge, a box struck off-centre in its x-z plane with a small slip along x that the coupling
// K_tn slows to a stop (sigma' = s.K_tn - mu_d s^T K_tt s < 0), mu_s set 1e-12 above the sticking
// rate |K_tt^-1 K_tn| (the contact then sticks, and would slip back with mu_s a little lower),
// mu_d = mu_s / 2: the contact is flagged at the stick/slip switch, sticking side, and every
// column matches the one-sided difference taken on the side that keeps the modes.
TEST(ImpactDerivatives, ImpulseSpaceStickSlipSwitchIsFlaggedAndOneSided) {
  int checked = 0;
  for (int trial = 0; trial < 3; ++trial) {
    cr::BodyState box;
    box.id = "box";
    box.mass = 1.2;
    box.inertia = Vector3d(0.02, 0.05, 0.04).asDiagonal();
    box.position = {0.1 + 0.05 * trial, 0.0, 0.1};
    box.linear_velocity = {0.0, 0.0, -1.2};
    cr::Scene scene;
    scene.bodies = {ground(), box};
    scene.contacts = {contact("ground", "box", Vector3d::Zero(), Vector3d::UnitZ(), 0.5, 1.0, 0.5)};
    cr::Contact& c = scene.contacts[0];
    const Vector3d n = c.normal.normalized();
    const OneBody m = oneBody(scene.bodies[1], c.point);
    const Matrix3d K = m.J * m.M_inv * m.J.transpose();
    const Vector3d t1 = n.unitOrthogonal(), t2 = n.cross(t1);
    Eigen::Matrix2d A;
    A << t1.dot(K * t1), t1.dot(K * t2), t2.dot(K * t1), t2.dot(K * t2);
    const Eigen::Vector2d b(t1.dot(K * n), t2.dot(K * n));
    const double tau = (A.inverse() * b).norm();
    c.static_friction = tau * (1.0 + 1e-12);
    c.dynamic_friction = 0.5 * c.static_friction;
    // The slip along x against K_tn's x part (world x: K's (0, 2) entry), 0.1 m/s.
    scene.bodies[1].linear_velocity.x() = K(0, 2) > 0.0 ? -0.1 : 0.1;
    const cr::SolverOptions options = withLaw(cr::ImpactLaw::kStronge);
    const cr::ImpactDerivatives d = cr::computeImpactDerivatives(scene, options);
    ASSERT_EQ(d.contacts[0].method, cr::DerivativeMethod::kAnalytic);
    std::printf("trial %d: %s [%s]\n", trial, cr::toString(d.contacts[0].mode),
                d.contacts[0].switch_detail.c_str());
    if (d.contacts[0].mode != cr::ImpactMode::kSticking) continue;  // the slip did not stop
    EXPECT_TRUE(d.contacts[0].at_switch) << "trial " << trial;
    EXPECT_NE(d.contacts[0].switch_detail.find("stick/slip after the stop"), std::string::npos)
        << d.contacts[0].switch_detail;
    EXPECT_NE(d.contacts[0].switch_detail.find("sticking side"), std::string::npos);
    const Outputs base = predict(scene, options);
    int sided = 0;
    for (int col = 0; col < d.jacobian.cols(); ++col) {
      const double h = stepOf(scene, col, 1e-5);
      for (const double sign : {1.0, -1.0}) {
        cr::Scene near = scene, far = scene;
        input(near, col) += sign * h;
        input(far, col) += 2.0 * sign * h;
        const Outputs p1 = predict(near, options), p2 = predict(far, options);
        if (p1.modes != base.modes || p2.modes != base.modes) continue;
        const VectorXd reference =
            sign * (-3.0 * base.values + 4.0 * p1.values - p2.values) / (2.0 * h);
        const double scale =
            std::max(reference.cwiseAbs().maxCoeff(), floorOf(scene, options, col));
        for (int row = 0; row < d.jacobian.rows(); ++row) {
          EXPECT_NEAR(d.jacobian(row, col), reference(row), 1e-5 * scale)
              << "trial " << trial << ": d " << d.rowLabels()[row] << " / d "
              << d.columnLabels()[col] << " (side " << sign << ")";
        }
        ++sided;
        break;
      }
    }
    EXPECT_GE(sided, 6);  // across the plane both sides leave the closed form: not compared
    ++checked;
  }
  EXPECT_GE(checked, 2);
}

// e = 0 under Poisson and Stronge: the impact ends at maximum compression, the restitution column
// is flagged one-sided and matches the solver's second-order forward difference in e; the other
// columns the central differences.
TEST(ImpactDerivatives, ImpulseSpaceAtZeroRestitutionTheColumnIsForIncreasingE) {
  RandomSource random(2619);
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    int checked = 0;
    for (int trial = 0; trial < 20 && checked < 4; ++trial) {
      const double mu_s = random.uniform(0.05, 1.5), mu_d = random.uniform(0.4, 1.0) * mu_s;
      const cr::Scene scene = randomScene(random, 1, trial % 2 == 1, 0.0, mu_s, mu_d);
      ASSERT_EQ(scene.contacts[0].restitution, 0.0);
      const cr::SolverOptions options = withLaw(law);
      const cr::ImpactDerivatives d = cr::computeImpactDerivatives(scene, options);
      ASSERT_EQ(d.method, cr::DerivativeMethod::kAnalytic);
      if (d.contacts[0].mode == cr::ImpactMode::kNoImpulse) continue;
      EXPECT_NE(d.contacts[0].switch_detail.find("e = 0"), std::string::npos)
          << d.contacts[0].switch_detail;
      // Skip contacts at another switch as well.
      if (d.contacts[0].switch_detail.find(';') != std::string::npos) continue;
      compareWithDifferences(
          scene, options, d, 1e-5, 1e-6,
          std::string(cr::toString(law)) + " e = 0, trial " + std::to_string(trial));
      const int col = static_cast<int>(d.velocityCount());
      const double h = 1e-5;
      const auto at = [&](double e) {
        cr::Scene s = scene;
        s.contacts[0].restitution = e;
        return predict(s, options).values;
      };
      const VectorXd reference = (-3.0 * at(0.0) + 4.0 * at(h) - at(2.0 * h)) / (2.0 * h);
      const double scale = reference.cwiseAbs().maxCoeff();
      for (int row = 0; row < d.jacobian.rows(); ++row) {
        EXPECT_NEAR(d.jacobian(row, col), reference(row), 1e-5 * scale)
            << cr::toString(law) << " trial " << trial << ": d " << d.rowLabels()[row]
            << " / d e at 0";
      }
      ++checked;
    }
    EXPECT_EQ(checked, 4) << cr::toString(law);
  }
}

// The same in an island integrated together: a contact with e = 0 among others goes idle after its
// compression, so the integration's own column for its e would be 0 (the dual run refuses it and
// the library differences). Poisson: the column is the increasing-e side's, against the test's
// difference on that side (e = h and 2h: e > 0 adds a restitution phase and steps, so the side is a
// piece of its own). Stronge: there the outputs grow like sqrt(e) (the test's secant slopes grow
// like h^-1/2), so the one-sided derivative is unbounded and no column can match: it is flagged.
TEST(ImpactDerivatives, ImpulseSpaceSeveralContactsAtZeroRestitutionTheColumnIsForIncreasingE) {
  RandomSource random(2631);
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    int checked = 0, flagged = 0;
    for (int trial = 0; trial < 40 && checked < 4; ++trial) {
      const double mu_s = random.uniform(0.1, 1.2), mu_d = random.uniform(0.4, 1.0) * mu_s;
      cr::Scene scene = randomScene(random, 2 + trial % 3, trial % 2 == 1, 0.9, mu_s, mu_d);
      scene.contacts[0].restitution = 0.0;
      const cr::SolverOptions options = withLaw(law);
      const cr::ImpactDerivatives d = cr::computeImpactDerivatives(scene, options);
      if (d.result.islands.size() != 1 ||
          d.result.islands[0].method != cr::SolvedBy::kSimultaneousImpulseSpace) {
        continue;
      }
      const std::string what =
          std::string(cr::toString(law)) + ", trial " + std::to_string(trial) + ": ";
      const auto at = [&](double e) {
        cr::Scene s = scene;
        s.contacts[0].restitution = e;
        return predict(s, options);
      };
      // Where e changes nothing (contact 0 gets no impulse, or sticks at once) the column is 0.
      const double h = 1e-6;
      const Outputs base = at(0.0), near = at(h), far = at(2.0 * h);
      const VectorXd slope = (far.values - near.values) / h;
      const double scale = slope.cwiseAbs().maxCoeff();
      const int col = static_cast<int>(d.velocityCount());
      // (To the library's difference round-off: 1e-16 of the outputs over its step 1e-7.)
      const double outputs = base.values.cwiseAbs().maxCoeff();
      if (!(scale > 1e-6 * outputs)) {
        EXPECT_LE(d.jacobian.col(col).cwiseAbs().maxCoeff(), 1e-7 * outputs) << what;
        continue;
      }
      if (near.modes != far.modes) continue;  // another switch on the side
      EXPECT_EQ(d.method, cr::DerivativeMethod::kFiniteDifference) << what;
      const std::string& detail = d.contacts[0].switch_detail;
      if (law == cr::ImpactLaw::kStronge) {
        EXPECT_NE(detail.find("contacts[0].restitution"), std::string::npos) << what << detail;
        ++flagged;
      } else {
        for (int row = 0; row < d.jacobian.rows(); ++row) {
          EXPECT_NEAR(d.jacobian(row, col), slope(row), 1e-4 * scale)
              << what << "d " << d.rowLabels()[row] << " / d contacts[0].restitution at 0";
        }
      }
      ++checked;
    }
    EXPECT_EQ(checked, 4) << cr::toString(law);
    if (law == cr::ImpactLaw::kStronge) {
      EXPECT_EQ(flagged, 4);
    }
  }
}

// differentiateImpulseSpace() on random symmetric positive definite K (not built from rigid
// bodies: any body pair's contact), random approaching u and coefficients: the impulse it carries
// is integrateSingleContact()'s (to 1e-8 of the impulse, both at tolerance 1e-12), and dP/du
// matches central differences of integrateSingleContact() (at 1e-14) to 1e-6.
TEST(ImpactDerivatives, ImpulseSpaceSensitivityOnGeneralContactsMatchesTheIntegrator) {
  RandomSource random(2620);
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    int checked = 0;
    for (int trial = 0; trial < 40 && checked < 15; ++trial) {
      const Matrix3d R = random.rotation().toRotationMatrix();
      const Vector3d eigen = random.vec(0.1, 2.0).cwiseAbs() + Vector3d::Constant(0.05);
      cr::ProblemContact c;
      c.delassus = R * eigen.asDiagonal() * R.transpose();
      c.normal = random.vec(-1.0, 1.0).normalized();
      cr::tangentBasis(c.normal, c.tangent1, c.tangent2);
      c.restitution = random.uniform(0.1, 0.9);
      c.static_friction = random.uniform(0.05, 1.5);
      c.dynamic_friction = random.uniform(0.4, 1.0) * c.static_friction;
      const Vector3d u = random.vec(-1.0, 1.0) - 1.5 * c.normal;
      Matrix3d dP_du, dP_dc;
      cr::ContactDerivativeMode mode;
      Vector3d P;
      ASSERT_TRUE(cr::differentiateImpulseSpace(c.normal, c.delassus, u, c.restitution,
                                                c.static_friction, c.dynamic_friction, law, 1e-12,
                                                dP_du, dP_dc, mode, &P));
      if (mode.at_switch || mode.mode == cr::ImpactMode::kNoImpulse) continue;
      const auto impulse = [&](const Vector3d& v, double tolerance) {
        const cr::ContactImpulse i = cr::integrateSingleContact(c, v, law, tolerance);
        return Vector3d(i.total(c.normal));
      };
      const Vector3d want = impulse(u, 1e-12);
      EXPECT_LE((P - want).norm(), 1e-8 * want.norm()) << cr::toString(law) << " trial " << trial;
      Matrix3d reference;
      const double h = 1e-5;
      for (int k = 0; k < 3; ++k) {
        const Vector3d step = h * Vector3d::Unit(k);
        reference.col(k) = (impulse(u + step, 1e-14) - impulse(u - step, 1e-14)) / (2.0 * h);
      }
      EXPECT_LE((dP_du - reference).cwiseAbs().maxCoeff(), 1e-6 * reference.cwiseAbs().maxCoeff())
          << cr::toString(law) << " trial " << trial << " (" << cr::toString(mode.mode) << ")\n"
          << dP_du << "\n\n"
          << reference;
      ++checked;
    }
    EXPECT_GE(checked, 15) << cr::toString(law);
  }
}

// A turning slip that the prediction ends by the stick-approach series (stick_approach.h): the
// sensitivity ends it the same way (detail.series, asserted), with the series' gradient chained
// with the sensitivity up to its start. Random symmetric positive definite K with a strong
// tangential anisotropy (the slips whose exponent m >= 2 the series is used on), random
// approaching u and coefficients; every column (u, e, mu_s, mu_d) against central differences of
// integrateSingleContact() at 1e-14, each column to 1e-6 of its largest entry. The u columns of
// contacts that stick after the stop are also the columns the series' homogeneity and flow
// identities give; the mu_d column is the series' recurrence carried with its mu_d derivative.
TEST(ImpactDerivatives, ImpulseSpaceSeriesToTheStopMatchesCentralDifferences) {
  RandomSource random(2626);
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    int checked = 0, tried = 0;
    for (int trial = 0; trial < 4000 && checked < 12; ++trial) {
      const Matrix3d R = random.rotation().toRotationMatrix();
      Vector3d eigen(random.uniform(0.05, 0.3), random.uniform(1.0, 4.0), random.uniform(0.5, 2.0));
      cr::ProblemContact c;
      c.delassus = R * eigen.asDiagonal() * R.transpose();
      c.normal = random.vec(-1.0, 1.0).normalized();
      cr::tangentBasis(c.normal, c.tangent1, c.tangent2);
      c.restitution = random.uniform(0.1, 0.9);
      c.static_friction = random.uniform(0.3, 1.5);
      c.dynamic_friction = random.uniform(0.5, 1.0) * c.static_friction;
      const Vector3d u = random.vec(-1.0, 1.0) - 0.7 * c.normal;
      Matrix3d dP_du, dP_dc;
      cr::ContactDerivativeMode mode;
      cr::ImpulseSpaceSensitivityDetail detail;
      Vector3d P;
      if (!cr::differentiateImpulseSpace(c.normal, c.delassus, u, c.restitution, c.static_friction,
                                         c.dynamic_friction, law, 1e-12, dP_du, dP_dc, mode, &P,
                                         &detail)) {
        continue;
      }
      if (!detail.series || mode.at_switch || mode.mode == cr::ImpactMode::kNoImpulse) continue;
      ++tried;
      const auto impulse = [&](const Vector3d& v, const cr::ProblemContact& contact) {
        const cr::ContactImpulse i = cr::integrateSingleContact(contact, v, law, 1e-14);
        return Vector3d(i.total(contact.normal));
      };
      EXPECT_LE((P - impulse(u, c)).norm(), 1e-8 * P.norm()) << cr::toString(law) << " " << trial;
      Eigen::Matrix<double, 3, 6> got, reference;
      got << dP_du, dP_dc;
      const double h = 1e-5;
      for (int k = 0; k < 3; ++k) {
        const Vector3d step = h * Vector3d::Unit(k);
        reference.col(k) = (impulse(u + step, c) - impulse(u - step, c)) / (2.0 * h);
      }
      for (int k = 0; k < 3; ++k) {
        cr::ProblemContact up = c, down = c;
        double* coefficient_up[3] = {&up.restitution, &up.static_friction, &up.dynamic_friction};
        double* coefficient_down[3] = {&down.restitution, &down.static_friction,
                                       &down.dynamic_friction};
        *coefficient_up[k] += h;
        *coefficient_down[k] -= h;
        reference.col(3 + k) = (impulse(u, up) - impulse(u, down)) / (2.0 * h);
      }
      // Each column to 1e-6 of itself (of 1e-3 of the largest entry for columns near zero, such
      // as mu_s's away from the stick/slip switch, or mu_d's under Poisson when the contact
      // sticks before compression ends).
      const double largest = reference.cwiseAbs().maxCoeff();
      double worst = 0.0;
      for (int k = 0; k < 6; ++k) {
        const double scale = std::max(reference.col(k).cwiseAbs().maxCoeff(), 1e-3 * largest);
        worst = std::max(worst, (got.col(k) - reference.col(k)).cwiseAbs().maxCoeff() / scale);
      }
      EXPECT_LE(worst, 1e-6) << cr::toString(law) << " trial " << trial << " ("
                             << cr::toString(mode.mode) << ", series order " << detail.series_order
                             << ", " << detail.steps << " steps)\n"
                             << got << "\n\n"
                             << reference;
      ++checked;
    }
    EXPECT_GE(checked, 12) << cr::toString(law) << ": series taken on " << tried;
  }
}

// differentiateImpulseSpaceByK(): the impulse's change along a change dK of K (a robot's joint
// positions move K), against central differences of integrateSingleContact() (at 1e-14) with K
// moved by +-h dK, on random symmetric positive definite K, random symmetric dK, random approaching
// u and coefficients: the anisotropic K of the series' test (turning slips that stop, then stick
// or resume), the general ones above, central contacts (K_tn = 0, where the prediction's central
// stop is a closed form) and frictionless ones; every mode met. Each to 1e-6 of itself; dP/du as
// differentiateImpulseSpace() gives it (1e-6).
TEST(ImpactDerivatives, ImpulseSpaceDerivativeByTheMassMatrixMatchesCentralDifferences) {
  RandomSource random(2631);
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    int checked = 0, sticking = 0, sliding = 0, central = 0;
    for (int trial = 0; trial < 400 && checked < 40; ++trial) {
      const Matrix3d R = random.rotation().toRotationMatrix();
      const int kind = trial % 4;  // anisotropic, general, central, frictionless
      const Vector3d eigen =
          kind == 0 ? Vector3d(random.uniform(0.05, 0.3), random.uniform(1.0, 4.0),
                               random.uniform(0.5, 2.0))
                    : Vector3d(random.vec(0.1, 2.0).cwiseAbs() + Vector3d::Constant(0.05));
      cr::ProblemContact c;
      c.delassus = R * eigen.asDiagonal() * R.transpose();
      c.normal = random.vec(-1.0, 1.0).normalized();
      if (kind == 2) {  // K_tn = 0: n an eigenvector of K
        c.normal = R.col(2);
      }
      cr::tangentBasis(c.normal, c.tangent1, c.tangent2);
      c.restitution = random.uniform(0.1, 0.9);
      c.static_friction = kind == 3 ? 0.0 : random.uniform(0.05, 1.5);
      c.dynamic_friction = random.uniform(0.4, 1.0) * c.static_friction;
      const Vector3d u = random.vec(-1.0, 1.0) - 1.2 * c.normal;
      Matrix3d S = Matrix3d::Zero();
      for (int i = 0; i < 3; ++i) S.col(i) = random.vec(-1.0, 1.0);
      const Matrix3d dK = 0.5 * (S + S.transpose());
      Eigen::Matrix<double, 3, Eigen::Dynamic> dP_dK;
      Matrix3d dP_du, dP_du_plain, dP_dc;
      cr::ContactDerivativeMode mode, plain;
      if (!cr::differentiateImpulseSpaceByK(c.normal, c.delassus, u, c.restitution,
                                            c.static_friction, c.dynamic_friction, law, 1e-12, {dK},
                                            dP_dK, dP_du, mode)) {
        continue;
      }
      ASSERT_TRUE(cr::differentiateImpulseSpace(c.normal, c.delassus, u, c.restitution,
                                                c.static_friction, c.dynamic_friction, law, 1e-12,
                                                dP_du_plain, dP_dc, plain));
      if (mode.at_switch || mode.mode == cr::ImpactMode::kNoImpulse) continue;
      const auto impulse = [&](const Matrix3d& K) {
        cr::ProblemContact moved = c;
        moved.delassus = K;
        const cr::ContactImpulse i = cr::integrateSingleContact(moved, u, law, 1e-14);
        return Vector3d(i.total(c.normal));
      };
      const double h = 1e-6;
      const Vector3d want = (impulse(c.delassus + h * dK) - impulse(c.delassus - h * dK)) / (2 * h);
      EXPECT_LE((dP_dK.col(0) - want).norm(), 1e-6 * std::max(want.norm(), 1e-3))
          << cr::toString(law) << " trial " << trial << " (" << cr::toString(mode.mode) << ")\n"
          << dP_dK.col(0).transpose() << "\n"
          << want.transpose();
      EXPECT_LE((dP_du - dP_du_plain).cwiseAbs().maxCoeff(),
                1e-6 * dP_du_plain.cwiseAbs().maxCoeff())
          << cr::toString(law) << " trial " << trial;
      ++checked;
      sticking += mode.mode == cr::ImpactMode::kSticking;
      sliding += mode.mode == cr::ImpactMode::kSliding;
      central += kind == 2;
    }
    EXPECT_GE(checked, 40) << cr::toString(law);
    EXPECT_GE(sticking, 5) << cr::toString(law);
    EXPECT_GE(sliding, 5) << cr::toString(law);
    EXPECT_GE(central, 5) << cr::toString(law);
  }
}

// A frictionless contact whose K_tn is parallel to a shrinking slip: the slip passes through zero
// along a line, which for a frictionless contact is no stop (its tangential impulse is 0 whatever
// the slip), so the map is smooth. The sensitivity used to put the state on the sticking manifold
// there, whose gradient gave spurious tangential columns (dP/dK_t1n (-0.25, -0.55, 0) against 0,
// found by review). dP/du and dP/dK along random symmetric dK against central differences of
// integrateSingleContact() at 1e-14; the contact is not flagged for the slip's zero.
TEST(ImpactDerivatives, FrictionlessSlipThroughZeroAlongALineIsSmooth) {
  RandomSource random(2640);
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    for (int trial = 0; trial < 6; ++trial) {
      const Matrix3d R = random.rotation().toRotationMatrix();
      cr::ProblemContact c;
      const Eigen::Vector2d b(random.uniform(-0.5, 0.5), random.uniform(-0.5, 0.5));
      Matrix3d Kc;
      Kc << random.uniform(0.8, 1.5), 0.1, b.x(), 0.1, random.uniform(0.8, 1.5), b.y(), b.x(),
          b.y(), random.uniform(1.0, 2.0);
      c.normal = R.col(2);
      c.tangent1 = R.col(0);
      c.tangent2 = R.col(1);
      c.delassus = R * Kc * R.transpose();
      c.restitution = random.uniform(0.1, 0.9);
      c.static_friction = c.dynamic_friction = 0.0;
      // u_t = -k b: the slip shrinks along b (u_t = u0_t + b p) and passes zero at p = k.
      const double k = random.uniform(0.05, 0.3);
      const Vector3d u = R * Vector3d(-k * b.x(), -k * b.y(), -1.0);
      Matrix3d dP_du, dP_dc;
      cr::ContactDerivativeMode mode;
      ASSERT_TRUE(cr::differentiateImpulseSpace(c.normal, c.delassus, u, c.restitution, 0.0, 0.0,
                                                law, 1e-12, dP_du, dP_dc, mode));
      EXPECT_EQ(mode.switch_detail.find("through zero"), std::string::npos) << mode.switch_detail;
      Matrix3d S;
      for (int i = 0; i < 3; ++i) S.col(i) = random.vec(-1.0, 1.0);
      const Matrix3d dK = 0.5 * (S + S.transpose());
      Eigen::Matrix<double, 3, Eigen::Dynamic> dP_dK;
      Matrix3d dP_du12;
      cr::ContactDerivativeMode mode12;
      ASSERT_TRUE(cr::differentiateImpulseSpaceByK(c.normal, c.delassus, u, c.restitution, 0.0, 0.0,
                                                   law, 1e-12, {dK}, dP_dK, dP_du12, mode12));
      const auto impulse = [&](const Vector3d& v, const Matrix3d& K) {
        cr::ProblemContact moved = c;
        moved.delassus = K;
        return Vector3d(cr::integrateSingleContact(moved, v, law, 1e-14).total(c.normal));
      };
      const double h = 1e-6;
      Matrix3d want;
      for (int j = 0; j < 3; ++j) {
        const Vector3d step = h * Vector3d::Unit(j);
        want.col(j) = (impulse(u + step, c.delassus) - impulse(u - step, c.delassus)) / (2 * h);
      }
      const Vector3d want_K =
          (impulse(u, c.delassus + h * dK) - impulse(u, c.delassus - h * dK)) / (2 * h);
      const double scale = want.cwiseAbs().maxCoeff();
      EXPECT_LE((dP_du - want).cwiseAbs().maxCoeff(), 1e-6 * scale)
          << cr::toString(law) << " trial " << trial << "\n"
          << dP_du << "\n\n"
          << want;
      EXPECT_LE((dP_du12 - want).cwiseAbs().maxCoeff(), 1e-6 * scale);
      EXPECT_LE((dP_dK.col(0) - want_K).norm(), 1e-6 * std::max(1.0, want_K.norm()))
          << cr::toString(law) << " trial " << trial << ": " << dP_dK.col(0).transpose()
          << " against " << want_K.transpose();
    }
  }
}

// ---- Labels, bodies without impact, bad input --------------------------------------------------

TEST(ImpactDerivatives, LabelsAreTheRequestAndResponseFieldNames) {
  cr::Scene scene;
  scene.bodies.push_back(ground());
  scene.bodies.push_back(sphere("ball", 1.0, 0.1, Vector3d(0, 0, 0.1), Vector3d(0, 0, -1)));
  scene.bodies.push_back(sphere("idle", 2.0, 0.1, Vector3d(3, 0, 0.1), Vector3d(1, 0, 0)));
  scene.contacts.push_back(contact("ground", "ball", Vector3d::Zero(), Vector3d::UnitZ(), 0.5));
  const cr::ImpactDerivatives d =
      cr::computeImpactDerivatives(scene, withLaw(cr::ImpactLaw::kNewton));
  const std::vector<std::string> rows = d.rowLabels(), cols = d.columnLabels();
  ASSERT_EQ(static_cast<Eigen::Index>(rows.size()), d.jacobian.rows());
  ASSERT_EQ(static_cast<Eigen::Index>(cols.size()), d.jacobian.cols());
  ASSERT_EQ(rows.size(), 12u + 4u);
  EXPECT_EQ(rows[0], "bodies[1].twist.linear.x");
  EXPECT_EQ(rows[5], "bodies[1].twist.angular.z");
  EXPECT_EQ(rows[6], "bodies[2].twist.linear.x");
  EXPECT_EQ(rows[12], "impulses[0].normal_impulse");
  EXPECT_EQ(rows[15], "impulses[0].friction_impulse.z");
  EXPECT_EQ(cols[12], "contacts[0].restitution");
  EXPECT_EQ(cols[13], "contacts[0].static_friction");
  EXPECT_EQ(cols[14], "contacts[0].dynamic_friction");
  // A head-on ball: v_z' = -e v_z, so dv_z'/dv_z = -e and dv_z'/de = -v_z = 1; the idle body
  // keeps its velocity (identity) and nothing couples the two.
  EXPECT_NEAR(d.jacobian(2, 2), -0.5, 1e-12);
  EXPECT_NEAR(d.jacobian(2, 12), 1.0, 1e-12);
  const MatrixXd idle = d.jacobian.block(6, 6, 6, 6), cross1 = d.jacobian.block(0, 6, 6, 6),
                 cross2 = d.jacobian.block(6, 0, 6, 6);
  EXPECT_TRUE(idle.isIdentity(0.0));
  EXPECT_TRUE(cross1.isZero(0.0));
  EXPECT_TRUE(cross2.isZero(0.0));
  EXPECT_STREQ(cr::toString(d.contacts[0].mode), "sliding");  // frictionless, active
}

TEST(ImpactDerivatives, InvalidSceneIsRefusedNamingTheField) {
  cr::Scene scene;
  scene.bodies.push_back(ground());
  scene.bodies.push_back(sphere("ball", 1.0, 0.1, Vector3d(0, 0, 0.1), Vector3d(0, 0, -1)));
  scene.contacts.push_back(contact("ground", "ball", Vector3d::Zero(), Vector3d::UnitZ(), 1.5));
  try {
    cr::computeImpactDerivatives(scene);
    FAIL() << "e = 1.5 accepted";
  } catch (const cr::InvalidInput& error) {
    EXPECT_EQ(error.field(), "contacts[0].restitution");
  }
}

}  // namespace

namespace {

// The finite-difference path at a switch: the one-pass law (differenced) at its own stick/slide
// boundary, the friction pass's sticking impulse |u_t| / (t^T K t) equal to mu_s times the normal
// pass's -(1 + e) u_n / (n^T K n) (t along u_t; K from the test's M and J). The library must flag
// the contact and difference on the side that keeps it sticking; the test's own one-sided
// differences on that side are the reference.
TEST(ImpactDerivatives, FiniteDifferencesAtASwitchAreOneSidedOnTheReportedSide) {
  RandomSource random(2616);
  int checked = 0;
  for (int trial = 0; trial < 10 && checked < 5; ++trial) {
    cr::Scene scene = randomScene(random, 1, false, 0.8, 1.0, 0.5);
    cr::Contact& c = scene.contacts[0];
    const Vector3d n = c.normal.normalized();
    const OneBody m = oneBody(scene.bodies[1], c.point);
    Eigen::Matrix<double, 6, 1> v;
    v << scene.bodies[1].linear_velocity, scene.bodies[1].angular_velocity;
    const Vector3d u = m.J * v;
    const Matrix3d K = m.J * m.M_inv * m.J.transpose();
    const double u_n = u.dot(n);
    const Vector3d u_t = u - u_n * n;
    const Vector3d t = u_t.normalized();
    const double j_r = -(1.0 + c.restitution) * u_n / n.dot(K * n);
    const double j_stick = u_t.norm() / t.dot(K * t);
    c.static_friction = j_stick / j_r * (1.0 + 1e-13);
    c.dynamic_friction = 0.5 * c.static_friction;
    cr::SolverOptions options = withLaw(cr::ImpactLaw::kSeedOnePass);
    const cr::ImpactDerivatives d = cr::computeImpactDerivatives(scene, options);
    ASSERT_EQ(d.contacts[0].method, cr::DerivativeMethod::kFiniteDifference);
    ASSERT_EQ(d.contacts[0].mode, cr::ImpactMode::kSticking) << "trial " << trial;
    EXPECT_TRUE(d.contacts[0].at_switch) << "trial " << trial;
    EXPECT_NE(d.contacts[0].switch_detail.find("static_friction: increasing side"),
              std::string::npos)
        << d.contacts[0].switch_detail;
    const Outputs base = predict(scene, options);
    for (int col = 0; col < d.jacobian.cols(); ++col) {
      const double h = stepOf(scene, col, 1e-6);
      for (const double sign : {1.0, -1.0}) {
        cr::Scene near = scene, far = scene;
        input(near, col) += sign * h;
        input(far, col) += 2.0 * sign * h;
        const Outputs p1 = predict(near, options), p2 = predict(far, options);
        if (p1.modes != base.modes || p2.modes != base.modes) continue;
        const VectorXd reference =
            sign * (-3.0 * base.values + 4.0 * p1.values - p2.values) / (2.0 * h);
        const double scale =
            std::max(reference.cwiseAbs().maxCoeff(), floorOf(scene, options, col));
        for (int row = 0; row < d.jacobian.rows(); ++row) {
          EXPECT_NEAR(d.jacobian(row, col), reference(row), 1e-5 * scale)
              << "trial " << trial << ": d " << d.rowLabels()[row] << " / d "
              << d.columnLabels()[col] << " (side " << sign << ")";
        }
        break;
      }
    }
    ++checked;
  }
  EXPECT_EQ(checked, 5);
}

}  // namespace

namespace {

// A 1 m cube of random mass (0.5 to 3 kg) landing flat on the ground at 2 m/s on its 4 bottom
// corners, its horizontal velocity uniform in [-speed, speed] per axis and its spin in [-0.3, 0.3]
// rad/s per axis; each corner's e from `restitution()`, in corner order.
cr::Scene flatCubeLanding(RandomSource& random, double speed, double mu_s, double mu_d,
                          const std::function<double()>& restitution) {
  cr::Scene scene;
  scene.bodies.push_back(ground());
  cr::BodyState cube;
  cube.id = "cube";
  cube.mass = random.uniform(0.5, 3.0);
  cube.inertia = boxInertia(cube.mass, Vector3d(1, 1, 1));
  cube.position = Vector3d(0, 0, 0.5);
  cube.linear_velocity =
      Vector3d(random.uniform(-speed, speed), random.uniform(-speed, speed), -2.0);
  cube.angular_velocity = random.vec(-0.3, 0.3);
  scene.bodies.push_back(cube);
  for (const double x : {-0.5, 0.5}) {
    for (const double y : {-0.5, 0.5}) {
      scene.contacts.push_back(contact("ground", "cube", Vector3d(x, y, 0), Vector3d::UnitZ(),
                                       restitution(), mu_s, mu_d));
    }
  }
  return scene;
}

// Redundant contacts: a cube landing flat on its 4 bottom corners (12 contact equations, 6 body
// unknowns: the active set's equations are singular and the impulses not unique). Sticking (large
// mu), the solver gives the least-norm impulses, whose derivative is the least-norm change:
// analytic. Sliding (small mu), the sharing of the normal impulse is not fixed and, through
// friction, neither are the twists: the solver's choice is differenced, reported so. Both against
// central differences.
TEST(ImpactDerivatives, RedundantContactsOfAFaceLandingFlatMatchCentralDifferences) {
  RandomSource random(2617);
  int compared = 0, columns = 0, sticking = 0, sliding = 0, differenced = 0, analytic = 0;
  for (int trial = 0; trial < 12; ++trial) {
    const double mu_s = trial % 2 == 0 ? 2.0 : 0.1, mu_d = 0.7 * mu_s;
    const cr::Scene scene = flatCubeLanding(random, 1.0, mu_s, mu_d, [] { return 0.4; });
    const cr::SolverOptions options = withLaw(cr::ImpactLaw::kNewton);
    const cr::ImpactDerivatives d = cr::computeImpactDerivatives(scene, options);
    if (d.method == cr::DerivativeMethod::kFiniteDifference) {
      // Sliding on all four: the solver's choice, differenced and said so.
      EXPECT_NE(d.contacts[0].switch_detail.find("not unique"), std::string::npos)
          << d.contacts[0].switch_detail;
      ++differenced;
    } else if (anySwitch(d)) {
      continue;  // e.g. a corner left without impulse at its target (a degenerate vertex)
    } else {
      ++analytic;
    }
    sticking += countMode(d, cr::ImpactMode::kSticking);
    sliding += countMode(d, cr::ImpactMode::kSliding);
    compared += compareWithDifferences(scene, options, d, 1e-6, 1e-6,
                                       "flat landing, trial " + std::to_string(trial));
    columns += static_cast<int>(d.jacobian.cols());
  }
  EXPECT_GE(sticking, 8);
  EXPECT_GE(sliding, 8);
  EXPECT_GE(analytic, 3);
  EXPECT_GE(differenced, 3);
  EXPECT_GE(compared, columns * 3 / 4) << compared << " of " << columns;
}

// A cube landing flat on its 4 corners under Poisson and Stronge, integrated together: redundant
// contacts (the compression's rate block has rank 3 of 4: the least-norm rates, differentiated at
// constant rank). Sliding across (mu_s 0.1 > mu_d 0.07): analytic, against the test's central
// differences. With a small slip and mu_s 2 > mu_d 1.4 the corners stop during the impact and
// some steps' rates are Lemke's with a corner weakly active (r = 0, w = 0: a vertex of a set of
// answers, which can change with the inputs): those landings are differenced, flagged, and their
// twist rows (unique, unlike the corners' impulses) compared.
TEST(ImpactDerivatives, ImpulseSpaceFaceLandingFlatMatchesCentralDifferences) {
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    RandomSource random(2627);
    int compared = 0, columns = 0, sliding = 0, analytic = 0, differenced = 0, twist_compared = 0;
    for (int trial = 0; trial < 8; ++trial) {
      const bool stick = trial % 2 == 0;
      const double mu_s = stick ? 2.0 : 0.1, mu_d = 0.7 * mu_s;
      // Sticking: one restitution (unequal ones set the cube turning as it leaves).
      const cr::Scene scene = flatCubeLanding(random, stick ? 0.2 : 1.0, mu_s, mu_d, [&] {
        return stick ? 0.4 : random.uniform(0.2, 0.6);
      });
      const cr::SolverOptions options = withLaw(law);
      const cr::ImpactDerivatives d = cr::computeImpactDerivatives(scene, options);
      ASSERT_EQ(d.result.islands.size(), 1u);
      if (d.result.islands[0].method != cr::SolvedBy::kSimultaneousImpulseSpace) continue;
      if (d.method != cr::DerivativeMethod::kAnalytic) {
        ++differenced;
        EXPECT_TRUE(stick) << cr::toString(law) << ", trial " << trial;
        for (const auto& c : d.contacts)
          EXPECT_EQ(c.method, cr::DerivativeMethod::kFiniteDifference);
        // The corners' friction impulses are one vertex of a set of answers that changes with the
        // inputs (only their wrench on the cube is unique), so the library's differences (step
        // 1e-7) cross jumps in the impulse rows: every contact must say so. The cube's twist is
        // unique: its rows against the test's central differences.
        for (const auto& c : d.contacts) {
          EXPECT_TRUE(c.at_switch) << cr::toString(law) << ", trial " << trial;
        }
        const Eigen::Index twist_rows = d.velocityCount();
        for (int col = 0; col < d.jacobian.cols(); ++col) {
          VectorXd reference;
          if (!centralDifference(scene, options, col, 4e-7, reference)) continue;
          const double scale = std::max(reference.head(twist_rows).cwiseAbs().maxCoeff(),
                                        floorOf(scene, options, col));
          for (Eigen::Index row = 0; row < twist_rows; ++row) {
            EXPECT_NEAR(d.jacobian(row, col), reference(row), 1e-6 * scale)
                << cr::toString(law) << ", flat landing, trial " << trial << ": d "
                << d.rowLabels()[row] << " / d " << d.columnLabels()[col];
          }
          ++twist_compared;
        }
        continue;
      } else if (anySwitch(d)) {
        continue;
      } else {
        ++analytic;
      }
      sliding += countMode(d, cr::ImpactMode::kSliding);
      compared += compareWithDifferences(
          scene, options, d, 4e-7, 1e-6,
          std::string(cr::toString(law)) + ", flat landing, trial " + std::to_string(trial));
      columns += static_cast<int>(d.jacobian.cols());
    }
    EXPECT_GE(analytic, 4) << cr::toString(law);
    EXPECT_GE(sliding, 16) << cr::toString(law);
    EXPECT_GE(compared, columns * 3 / 4)
        << cr::toString(law) << ": " << compared << " of " << columns;
    EXPECT_GE(twist_compared, 2 * differenced) << cr::toString(law);
    std::printf(
        "%s, flat landing: %d analytic, %d differenced, %d sliding, %d of %d columns; twist rows "
        "of %d differenced columns\n",
        cr::toString(law), analytic, differenced, sliding, compared, columns, twist_compared);
  }
}

}  // namespace

namespace {

// A cube landing on one edge (two corners of its bottom face, rank 2: no redundant rows) under
// Poisson and Stronge with mu_s > mu_d, integrated together, against the test's central
// differences. Half the landings with mu_s in [1, 2.5] and a slip up to 0.4 m/s (some end
// sticking), half with mu_s in [2, 3.5] and a slip up to 0.15 m/s: the corners stop during the
// impact and slip again as the cube turns about the edge, so their |P_t| / P_n ends well below
// mu_d (a contact sliding one way throughout ends at mu_d): the branches inside the integration.
TEST(ImpactDerivatives, ImpulseSpaceEdgeLandingMatchesCentralDifferences) {
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    RandomSource random(2641);
    int analytic = 0, compared = 0, columns = 0, sticking = 0, stopped = 0;
    const int trials = 24;
    for (int trial = 0; trial < trials; ++trial) {
      const bool slow = trial >= trials / 2;
      const double mu_s = slow ? random.uniform(2.0, 3.5) : random.uniform(1.0, 2.5);
      const double mu_d = random.uniform(0.3, 0.9) * mu_s;
      const double speed = slow ? random.uniform(0.0, 0.15) : random.uniform(0.05, 0.4);
      cr::Scene scene =
          flatCubeLanding(random, speed, mu_s, mu_d, [&] { return random.uniform(0.2, 0.7); });
      scene.contacts.erase(scene.contacts.begin() + 2, scene.contacts.end());  // the edge y = -0.5
      const cr::SolverOptions options = withLaw(law);
      const cr::ImpactDerivatives d = cr::computeImpactDerivatives(scene, options);
      ASSERT_EQ(d.result.islands.size(), 1u);
      ASSERT_EQ(d.result.islands[0].method, cr::SolvedBy::kSimultaneousImpulseSpace);
      if (d.method != cr::DerivativeMethod::kAnalytic || anySwitch(d)) continue;
      ++analytic;
      for (const cr::ContactImpulse& impulse : d.result.impulses) {
        if (impulse.sticking) {
          ++sticking;
        } else if (impulse.friction_impulse.norm() < 0.9 * mu_d * impulse.normal_impulse) {
          ++stopped;
        }
      }
      compared += compareWithDifferences(
          scene, options, d, 4e-7, 1e-6,
          std::string(cr::toString(law)) + ", edge landing, trial " + std::to_string(trial));
      columns += static_cast<int>(d.jacobian.cols());
    }
    EXPECT_GE(analytic, trials * 3 / 4) << cr::toString(law);
    // (Left out: columns whose steps cross an event inside the integration, the reference's own
    // smoothness check.)
    EXPECT_GE(compared, columns * 2 / 3)
        << cr::toString(law) << ": " << compared << " of " << columns;
    EXPECT_GE(sticking, 2) << cr::toString(law);
    EXPECT_GE(stopped, 16) << cr::toString(law);
    std::printf(
        "%s, edge landing: %d of %d analytic, %d of %d columns, %d corners ending sticking, "
        "%d sliding below mu_d\n",
        cr::toString(law), analytic, trials, compared, columns, sticking, stopped);
  }
}

// computeValidatedImpactDerivatives() with a subset of the columns (the linear uncertainty's
// call): each column asked for is the full call's column (whose values the tests above check
// against central differences), every other column is 0. Scenes of every path: several contacts
// (exact solver, sticking and sliding), a face landing flat (redundant contacts: the body-space
// all-sticking solve, or finite differences when it slides), one contact (closed form).
TEST(ImpactDerivatives, ColumnSubsetsAreTheFullCallsColumns) {
  RandomSource random(2619);
  int checked = 0;
  for (int trial = 0; trial < 24; ++trial) {
    cr::Scene scene;
    if (trial % 3 == 2) {
      scene.bodies.push_back(ground());
      cr::BodyState cube;
      cube.id = "cube";
      cube.mass = random.uniform(0.5, 3.0);
      cube.inertia = boxInertia(cube.mass, Eigen::Vector3d(1, 1, 1));
      cube.position = Eigen::Vector3d(0, 0, 0.5);
      cube.linear_velocity = Eigen::Vector3d(random.uniform(-1, 1), random.uniform(-1, 1), -2.0);
      cube.angular_velocity = random.vec(-0.3, 0.3);
      scene.bodies.push_back(cube);
      const double mu_s = trial % 2 == 0 ? 2.0 : 0.1;
      for (const double x : {-0.5, 0.5}) {
        for (const double y : {-0.5, 0.5}) {
          scene.contacts.push_back(contact("ground", "cube", Eigen::Vector3d(x, y, 0),
                                           Eigen::Vector3d::UnitZ(), 0.4, mu_s, 0.7 * mu_s));
        }
      }
    } else {
      const double mu_s = random.uniform(0.05, 1.5);
      scene = randomScene(random, 1 + trial % 4, trial % 2 == 1, 0.9, mu_s,
                          random.uniform(0.3, 1.0) * mu_s);
    }
    const cr::SolverOptions options = withLaw(cr::ImpactLaw::kNewton);
    const cr::ImpactDerivatives full = cr::computeImpactDerivatives(scene, options);
    cr::DerivativeColumns columns;
    columns.velocities = trial % 2 == 0;
    for (std::size_t k = 0; k < 3 * scene.contacts.size(); ++k) {
      columns.coefficients.push_back(random.uniform(0.0, 1.0) < 0.5);
    }
    const cr::ImpactDerivatives subset = cr::computeValidatedImpactDerivatives(
        scene, cr::validate(scene, options, cr::RequestLimits{}), options, columns);
    ASSERT_EQ(subset.jacobian.rows(), full.jacobian.rows());
    ASSERT_EQ(subset.jacobian.cols(), full.jacobian.cols());
    const Eigen::Index velocities = full.velocityCount();
    for (Eigen::Index k = 0; k < full.jacobian.cols(); ++k) {
      const bool wanted =
          k < velocities ? columns.velocities
                         : bool(columns.coefficients[static_cast<std::size_t>(k - velocities)]);
      const VectorXd expected =
          wanted ? VectorXd(full.jacobian.col(k)) : VectorXd(VectorXd::Zero(full.jacobian.rows()));
      const double scale = std::max(1.0, full.jacobian.col(k).cwiseAbs().maxCoeff());
      EXPECT_LE((subset.jacobian.col(k) - expected).cwiseAbs().maxCoeff(), 1e-9 * scale)
          << "trial " << trial << ", column " << k << (wanted ? " (asked for)" : " (left out)");
    }
    for (std::size_t c = 0; c < scene.contacts.size(); ++c) {
      EXPECT_EQ(subset.contacts[c].mode, full.contacts[c].mode) << "trial " << trial;
    }
    ++checked;
  }
  EXPECT_EQ(checked, 24);
}

}  // namespace

namespace {

// A stack: body a on the ground, body b on a, one contact each (6 contact equations, 12 body
// unknowns: W regular). With large friction both stick, the exact solver's all-sticking answer,
// whose derivative is W^-1 (its own Cholesky factor, not the body-space solve of a face): against
// central differences.
TEST(ImpactDerivatives, StickingStackOfTwoBodiesMatchesCentralDifferences) {
  RandomSource random(2621);
  int compared = 0, columns = 0, analytic = 0;
  for (int trial = 0; trial < 12; ++trial) {
    cr::Scene scene;
    scene.bodies.push_back(ground());
    scene.bodies.push_back(randomBody(random, "a", Vector3d(0, 0, 0.5)));
    scene.bodies.push_back(randomBody(random, "b", Vector3d(0, 0, 1.5)));
    scene.bodies[1].linear_velocity.z() -= 1.0;
    scene.bodies[2].linear_velocity.z() -= 3.0;
    const Vector3d n0 = (Vector3d::UnitZ() + random.vec(-0.2, 0.2)).normalized();
    const Vector3d n1 = (Vector3d::UnitZ() + random.vec(-0.2, 0.2)).normalized();
    scene.contacts.push_back(contact("ground", "a", Vector3d(0, 0, 0) + random.vec(-0.1, 0.1), n0,
                                     random.uniform(0.0, 0.9), 5.0, 4.0));
    scene.contacts.push_back(contact("a", "b", Vector3d(0, 0, 1) + random.vec(-0.1, 0.1), n1,
                                     random.uniform(0.0, 0.9), 5.0, 4.0));
    const cr::SolverOptions options = withLaw(cr::ImpactLaw::kNewton);
    const cr::ImpactDerivatives d = cr::computeImpactDerivatives(scene, options);
    if (d.result.islands.size() != 1 || d.result.islands[0].method != cr::SolvedBy::kExact ||
        countMode(d, cr::ImpactMode::kSticking) != 2 || anySwitch(d)) {
      continue;
    }
    ASSERT_EQ(d.method, cr::DerivativeMethod::kAnalytic);
    ++analytic;
    compared += compareWithDifferences(scene, options, d, 1e-6, 1e-6,
                                       "stack, trial " + std::to_string(trial));
    columns += static_cast<int>(d.jacobian.cols());
  }
  EXPECT_GE(analytic, 6);
  EXPECT_GE(compared, columns * 3 / 4) << compared << " of " << columns;
}

}  // namespace
