// Impact episodes (episode.h) against references computed in this file: the bouncing ball's
// geometric series and single-contact Newton impulses in closed form, an event-driven rod
// integration (analytic flight, root finding, a closed-form frictionless impulse), the same cube
// landing at a far smaller contact tolerance, the signed distances of the corners along the
// episode's path, computeResponse() on the impact's contact, and the resting analysis' closed form
// for a cube on a floor. The geometry is a test-only GapQuery: immovable planes and bodies made of
// material points with a radius (a ball: its centre; a rod: its two ends; a cube: its corners).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "collision_response/core/compute_response.h"
#include "collision_response/core/constants.h"
#include "collision_response/core/deadline.h"
#include "collision_response/core/episode.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/free_flight.h"

namespace core = collision_response::core;
using Eigen::Vector3d;

namespace {

constexpr double kG = 9.81;
using collision_response::core::kPi;
constexpr double kInf = std::numeric_limits<double>::infinity();

struct Coefficients {
  double e = 0.5;
  double mu_s = 0.0;
  double mu_d = 0.0;
};

// Immovable planes (body i: through its position, unit normal planes[i]) and movable bodies made of
// material points (body frame) that are balls of radius `rho`.
class PointsAndPlanes : public core::GapQuery {
 public:
  // point_on_plane: whether the contacts say so (GapContact::point_on_plane, true of this
  // geometry), which lets the episode bound each point's gap instead of the pair's.
  PointsAndPlanes(std::vector<Vector3d> plane_normals, std::vector<Vector3d> points, double rho,
                  Coefficients coefficients, bool point_on_plane = true)
      : normals_(std::move(plane_normals)),
        points_(std::move(points)),
        rho_(rho),
        coefficients_(coefficients),
        point_on_plane_(point_on_plane) {}

  void gaps(const std::vector<core::BodyState>& bodies, double range,
            std::vector<core::GapContact>& out) const override {
    out.clear();
    const int planes = static_cast<int>(normals_.size());
    for (int b = planes; b < static_cast<int>(bodies.size()); ++b) {
      for (int p = 0; p < planes; ++p) {
        const Vector3d& n = normals_[p];
        for (const Vector3d& point : points_) {
          const Vector3d x = bodies[b].position + bodies[b].orientation * point;
          const double height = n.dot(x - bodies[p].position);
          if (height - rho_ > range) continue;
          core::GapContact c;
          c.body_a = p;
          c.body_b = b;
          c.point = x - height * n;
          c.normal = n;
          c.gap = height - rho_;
          c.restitution = coefficients_.e;
          c.static_friction = coefficients_.mu_s;
          c.dynamic_friction = coefficients_.mu_d;
          c.point_on_plane = point_on_plane_;
          out.push_back(c);
        }
      }
    }
  }
  double radius(int body) const override {
    if (body < static_cast<int>(normals_.size())) return kInf;
    double r = 0.0;
    for (const Vector3d& p : points_) r = std::max(r, p.norm());
    return r + rho_;
  }
  int bodyCount() const override { return static_cast<int>(normals_.size()) + 1; }

 private:
  std::vector<Vector3d> normals_;
  std::vector<Vector3d> points_;
  double rho_;
  Coefficients coefficients_;
  bool point_on_plane_;
};

core::BodyState floorBody() {
  core::BodyState floor;
  floor.id = "floor";
  return floor;
}

core::BodyState ball(double mass, double radius, double height) {
  core::BodyState b;
  b.id = "ball";
  b.mass = mass;
  b.inertia = Eigen::Matrix3d::Identity() * 0.4 * mass * radius * radius;
  b.position = {0.0, 0.0, radius + height};
  return b;
}

std::vector<Vector3d> boxCorners(const Vector3d& half) {
  std::vector<Vector3d> corners;
  for (int i = 0; i < 8; ++i) {
    corners.emplace_back((i & 1 ? 1 : -1) * half.x(), (i & 2 ? 1 : -1) * half.y(),
                         (i & 4 ? 1 : -1) * half.z());
  }
  return corners;
}

std::vector<Vector3d> cubeCorners(double half) {
  return boxCorners(Vector3d::Constant(half));
}

core::BodyState cube(double mass, double half) {
  core::BodyState c;
  c.id = "cube";
  c.mass = mass;
  c.inertia = Eigen::Matrix3d::Identity() * mass * (2 * half) * (2 * half) / 6.0;
  return c;
}

core::EpisodeOptions episodeOptions(core::ImpactLaw law, double tolerance = 1e-4) {
  core::EpisodeOptions o;
  o.gravity = {0.0, 0.0, -kG};
  o.horizon = 5.0;
  o.max_impacts = 100;
  o.contact_tolerance = tolerance;
  o.solver.law = law;
  o.solver.time_budget = 60.0;  // the physics is tested, not the speed
  return o;
}

// --- The bouncing ball ------------------------------------------------------------------------

TEST(Episode, BallBouncesAtTheGeometricSeriesAndComesToRest) {
  const double h = 1.0, e = 0.5, m = 0.5, R = 0.05;
  for (const core::ImpactLaw law :
       {core::ImpactLaw::kNewton, core::ImpactLaw::kPoisson, core::ImpactLaw::kStronge}) {
    for (const bool points : {true, false}) {
      SCOPED_TRACE(core::toString(law));
      SCOPED_TRACE(points ? "bounded per point" : "bounded per pair");
      const PointsAndPlanes geometry({Vector3d::UnitZ()}, {Vector3d::Zero()}, R, {e, 0.0, 0.0},
                                     points);
      const core::EpisodeOptions options = episodeOptions(law);
      const core::EpisodeResult result =
          core::computeEpisode({floorBody(), ball(m, R, h)}, geometry, options);

      // Closed form: first impact at sqrt(2 h / g) with speed v1, then flights 2 e^k v1 / g.
      const double v1 = std::sqrt(2 * kG * h);
      const double threshold = std::sqrt(2 * kG * options.contact_tolerance);
      int listed = 1;  // the impacts up to the first whose rebound e^k v1 is below the threshold
      while (std::pow(e, listed) * v1 > threshold) ++listed;
      ASSERT_EQ(static_cast<int>(result.impacts.size()), listed);
      double t = std::sqrt(2 * h / kG);
      for (int k = 0; k < listed; ++k) {
        EXPECT_NEAR(result.impacts[k].time, t, 1e-9) << "impact " << k;
        EXPECT_NEAR(result.impacts[k].bodies_after[1].linear_velocity.z(), std::pow(e, k + 1) * v1,
                    1e-9)
            << "impact " << k;
        t += 2 * std::pow(e, k + 1) * v1 / kG;
      }
      // Time of rest: t1 + 2 e v1 / (g (1 - e)), the whole series.
      ASSERT_EQ(result.end, core::EpisodeEnd::kSustainedContact);
      EXPECT_NEAR(result.end_time, std::sqrt(2 * h / kG) + 2 * e * v1 / (kG * (1 - e)), 1e-9);
      // The bounces summed: those whose rebound e^k v1 exceeds the solver's resting velocity.
      EXPECT_EQ(result.accumulated_impacts,
                static_cast<int>(std::ceil(
                    std::log(options.solver.resting_velocity / (std::pow(e, listed) * v1)) /
                    std::log(e))));
      EXPECT_LT(result.bodies[1].linear_velocity.norm(), 1e-9);
      ASSERT_EQ(result.resting.size(), 1u);
      EXPECT_NEAR(result.resting[0].normal_force, m * kG, 1e-9);
      EXPECT_LT(result.linear_accelerations[1].norm(), 1e-9);
      EXPECT_EQ(result.outcomes[1], core::BodyOutcome::kSticking);
    }
  }
}

// Newton's law on one ball-floor contact in closed form, the contact at depth d below the centre
// (R at the ball's surface; the test geometry puts it on the floor, R + gap): u'_n = -e u_n; the
// sticking impulse P_t = -u_t / (1/m + d^2/I) if |P_t| <= mu_s P_n, else P_t = -mu_d P_n u_t/|u_t|.
void newtonBallBounce(double m, double R, double d, double e, double mu_s, double mu_d, Vector3d& v,
                      Vector3d& w) {
  const double I = 0.4 * m * R * R;
  const Vector3d r(0, 0, -d);
  const Vector3d u = v + w.cross(r);
  const double P_n = -(1 + e) * m * u.z();
  const Vector3d u_t(u.x(), u.y(), 0.0);
  Vector3d P_t = -u_t / (1 / m + d * d / I);
  if (P_t.norm() > mu_s * P_n) P_t = -mu_d * P_n * u_t.normalized();
  const Vector3d P = P_t + Vector3d(0, 0, P_n);
  v += P / m;
  w += r.cross(P) / I;
}

TEST(Episode, SpinningBallSpinAfterEachBounceFollowsTheClosedForm) {
  const double m = 0.2, R = 0.04, e = 0.7;
  struct Case {
    double mu_s, mu_d;
    Vector3d v, w;
  };
  // Sliding through the impact (small mu), sticking (large mu), static above dynamic.
  for (const Case& c : {Case{0.1, 0.1, {1.5, -0.4, 0.0}, {3.0, 20.0, -4.0}},
                        Case{0.9, 0.9, {0.3, 0.1, 0.0}, {-5.0, 2.0, 1.0}},
                        Case{0.5, 0.2, {0.8, 0.0, 0.0}, {0.0, -30.0, 0.0}}}) {
    const PointsAndPlanes geometry({Vector3d::UnitZ()}, {Vector3d::Zero()}, R, {e, c.mu_s, c.mu_d});
    core::BodyState b = ball(m, R, 0.3);
    b.linear_velocity = c.v;
    b.angular_velocity = c.w;
    core::EpisodeOptions options = episodeOptions(core::ImpactLaw::kNewton);
    options.max_impacts = 6;
    const core::EpisodeResult result = core::computeEpisode({floorBody(), b}, geometry, options);
    ASSERT_GE(result.impacts.size(), 3u);
    // Flight in closed form (w constant for a ball) to the episode's impact time, where the gap
    // must be within [0, tolerance] (and no earlier landing skipped), then the impulse above.
    Vector3d v = c.v, w = c.w;
    double z = R + 0.3, t = 0.0;
    for (std::size_t k = 0; k < result.impacts.size(); ++k) {
      const double landing = t + (v.z() + std::sqrt(v.z() * v.z() + 2 * kG * (z - R))) / kG;
      const double dt = result.impacts[k].time - t;
      const double gap = z + v.z() * dt - 0.5 * kG * dt * dt - R;
      EXPECT_GE(gap, -1e-12) << "impact " << k;
      EXPECT_LE(gap, options.contact_tolerance) << "impact " << k;
      EXPECT_LE(result.impacts[k].time, landing + 1e-12) << "impact " << k;
      v.z() -= kG * dt;
      newtonBallBounce(m, R, R + gap, e, c.mu_s, c.mu_d, v, w);
      const core::BodyState& after = result.impacts[k].bodies_after[1];
      EXPECT_LT((after.angular_velocity - w).norm(), 1e-9 * w.norm() + 1e-12) << "impact " << k;
      EXPECT_LT((after.linear_velocity - v).norm(), 1e-9 * v.norm()) << "impact " << k;
      EXPECT_NEAR(after.position.z(), R + gap, 1e-9) << "impact " << k;
      // On from the episode's own state, so that differences of order tolerance do not add up.
      v = after.linear_velocity;
      w = after.angular_velocity;
      t = result.impacts[k].time;
      z = after.position.z();
    }
  }
}

// --- The rod ----------------------------------------------------------------------------------

constexpr double kRodLength = 1.0, kRodMass = 1.0;
const double kRodInertia = kRodMass * kRodLength * kRodLength / 12.0;

core::BodyState rod(double tilt, double height, const Vector3d& v, double spin) {
  core::BodyState r;
  r.id = "rod";
  r.mass = kRodMass;
  r.inertia = Vector3d(1e-4, kRodInertia, kRodInertia).asDiagonal();
  r.orientation = Eigen::AngleAxisd(tilt, Vector3d::UnitY());
  r.position = {0.0, 0.0, height};
  r.linear_velocity = v;
  r.angular_velocity = {0.0, spin, 0.0};
  return r;
}

// The rod in its vertical plane: centre (x, z), angle phi about y (axis (cos phi, 0, -sin phi)),
// velocities; ends s = +1, -1 at height z - s L/2 sin(phi).
struct PlanarRod {
  double x, z, phi, vx, vz, w;
  double endHeight(int s, double t) const {
    return z + vz * t - 0.5 * kG * t * t - s * 0.5 * kRodLength * std::sin(phi + w * t);
  }
  void fly(double t) {
    x += vx * t;
    z += vz * t - 0.5 * kG * t * t;
    vz -= kG * t;
    phi += w * t;
  }
  // Frictionless impulse at end s: u_n = vz - w r_x, P = -(1 + e) u_n / (1/m + r_x^2 / I).
  void impact(int s, double e) {
    const double r_x = s * 0.5 * kRodLength * std::cos(phi);
    const double u_n = vz - w * r_x;
    const double P = -(1 + e) * u_n / (1 / kRodMass + r_x * r_x / kRodInertia);
    vz += P / kRodMass;
    w -= P * r_x / kRodInertia;
  }
};

struct RodEvent {
  double time;
  int end;
  PlanarRod after;
};

// Event-driven: the first root of either end's height after each impact (scan, then bisection).
std::vector<RodEvent> rodReference(PlanarRod rod, double e, int count) {
  std::vector<RodEvent> events;
  double t = 0.0;
  for (int k = 0; k < count; ++k) {
    const double scan = 1e-4;
    double hit = -1;
    int end = 0;
    for (double s = 1e-9; s < 3.0 && hit < 0; s += scan) {
      for (const int i : {1, -1}) {
        if (rod.endHeight(i, s) > 0 && rod.endHeight(i, s + scan) <= 0) {
          double lo = s, hi = s + scan;
          for (int it = 0; it < 200; ++it) {
            const double mid = 0.5 * (lo + hi);
            (rod.endHeight(i, mid) > 0 ? lo : hi) = mid;
          }
          if (hit < 0 || lo < hit) {
            hit = lo;
            end = i;
          }
        }
      }
    }
    if (hit < 0) break;
    rod.fly(hit);
    t += hit;
    rod.impact(end, e);
    events.push_back({t, end, rod});
  }
  return events;
}

TEST(Episode, RodDroppedAtAnAngleHitsWithOneEndThenTheOther) {
  const double e = 0.6, tilt = 0.3;
  const PointsAndPlanes geometry(
      {Vector3d::UnitZ()}, {Vector3d(0.5 * kRodLength, 0, 0), Vector3d(-0.5 * kRodLength, 0, 0)},
      0.0, {e, 0.0, 0.0});
  const Vector3d v(0.2, 0.0, -1.0);
  const double spin = 1.0, height = 0.4;
  core::EpisodeOptions options = episodeOptions(core::ImpactLaw::kNewton, 1e-8);
  options.max_impacts = 3;
  const core::EpisodeResult result =
      core::computeEpisode({floorBody(), rod(tilt, height, v, spin)}, geometry, options);
  const std::vector<RodEvent> reference =
      rodReference({0.0, height, tilt, v.x(), v.z(), spin}, e, 3);
  ASSERT_EQ(reference.size(), 3u);
  ASSERT_EQ(result.impacts.size(), 3u);
  EXPECT_EQ(reference[0].end, 1);   // the lower end first ...
  EXPECT_EQ(reference[1].end, -1);  // ... then the other
  for (std::size_t k = 0; k < 3; ++k) {
    const core::EpisodeImpact& impact = result.impacts[k];
    const RodEvent& ref = reference[k];
    EXPECT_NEAR(impact.time, ref.time, 1e-6) << "impact " << k;
    ASSERT_EQ(impact.contacts.size(), 1u);
    // Which end: the contact point on the end's side of the centre.
    const double side = (impact.contacts[0].point - impact.bodies_after[1].position).x();
    EXPECT_GT(side * ref.end * std::cos(ref.after.phi), 0.0) << "impact " << k;
    const core::BodyState& after = impact.bodies_after[1];
    EXPECT_NEAR(after.linear_velocity.z(), ref.after.vz, 1e-5) << "impact " << k;
    EXPECT_NEAR(after.linear_velocity.x(), ref.after.vx, 1e-9) << "impact " << k;
    EXPECT_NEAR(after.angular_velocity.y(), ref.after.w, 1e-5) << "impact " << k;
    EXPECT_NEAR(after.position.z(), ref.after.z, 1e-6) << "impact " << k;
  }
}

TEST(Episode, RodDroppedFlatHitsWithBothEndsAtOnce) {
  const double e = 0.6;
  const PointsAndPlanes geometry(
      {Vector3d::UnitZ()}, {Vector3d(0.5 * kRodLength, 0, 0), Vector3d(-0.5 * kRodLength, 0, 0)},
      0.0, {e, 0.0, 0.0});
  // Exactly flat, and tilted by less than the tolerance over its length: one impact, two contacts.
  for (const double tilt : {0.0, 3e-5}) {
    SCOPED_TRACE(tilt);
    core::EpisodeOptions options = episodeOptions(core::ImpactLaw::kNewton);
    const core::EpisodeResult result = core::computeEpisode(
        {floorBody(), rod(tilt, 0.2, Vector3d(0, 0, -1), 0.0)}, geometry, options);
    ASSERT_GE(result.impacts.size(), 1u);
    ASSERT_EQ(result.impacts[0].contacts.size(), 2u);
    const double v1 = std::sqrt(1.0 + 2 * kG * 0.2);
    const core::BodyState& after = result.impacts[0].bodies_after[1];
    EXPECT_NEAR(after.linear_velocity.z(), e * v1, 1e-3 * v1);
    EXPECT_LT(std::abs(after.angular_velocity.y()), 1e-3 * v1);
    // Resting on both ends at the end, each carrying half the weight.
    ASSERT_EQ(result.end, core::EpisodeEnd::kSustainedContact);
    ASSERT_EQ(result.resting.size(), 2u);
    EXPECT_NEAR(result.resting[0].normal_force + result.resting[1].normal_force, kRodMass * kG,
                1e-9);
    EXPECT_NEAR(result.resting[0].normal_force, 0.5 * kRodMass * kG, 1e-3);
  }
  // The tilted rod's ends differ by 3e-5 m: a tolerance below that sees two impacts, the lower
  // end's first.
  core::EpisodeOptions options = episodeOptions(core::ImpactLaw::kNewton, 1e-6);
  const core::EpisodeResult result = core::computeEpisode(
      {floorBody(), rod(3e-5, 0.2, Vector3d(0, 0, -1), 0.0)}, geometry, options);
  ASSERT_GE(result.impacts.size(), 2u);
  ASSERT_EQ(result.impacts[0].contacts.size(), 1u);
  EXPECT_GT(result.impacts[0].contacts[0].point.x(), 0.0);
  EXPECT_LT(result.impacts[1].time - result.impacts[0].time, 1e-4);
}

// --- The cube ---------------------------------------------------------------------------------

constexpr double kHalf = 0.05, kCubeMass = 0.37;

double lowestCorner(const core::BodyState& c,
                    const std::vector<Vector3d>& corners = cubeCorners(kHalf)) {
  double z = kInf;
  for (const Vector3d& p : corners) z = std::min(z, (c.position + c.orientation * p).z());
  return z;
}

TEST(Episode, CubeCornerLandingAgreesWithAFarSmallerTolerance) {
  const PointsAndPlanes geometry({Vector3d::UnitZ()}, cubeCorners(kHalf), 0.0, {0.5, 0.4, 0.4});
  core::BodyState c = cube(kCubeMass, kHalf);
  c.orientation = Eigen::AngleAxisd(0.6, Vector3d(1, 0.5, 0).normalized()) *
                  Eigen::AngleAxisd(0.3, Vector3d::UnitZ());
  c.position = {0.0, 0.0, 0.05 - lowestCorner(c)};
  c.linear_velocity = {0.5, 0.2, -1.5};
  c.angular_velocity = {1.0, -2.0, 0.5};
  for (const core::ImpactLaw law : {core::ImpactLaw::kNewton, core::ImpactLaw::kStronge}) {
    SCOPED_TRACE(core::toString(law));
    const core::EpisodeResult coarse =
        core::computeEpisode({floorBody(), c}, geometry, episodeOptions(law, 1e-4));
    const core::EpisodeResult fine =
        core::computeEpisode({floorBody(), c}, geometry, episodeOptions(law, 1e-8));
    ASSERT_GE(coarse.impacts.size(), 2u);
    ASSERT_GE(fine.impacts.size(), 2u);
    for (std::size_t k = 0; k < 2; ++k) {
      const core::EpisodeImpact& a = coarse.impacts[k];
      const core::EpisodeImpact& b = fine.impacts[k];
      EXPECT_NEAR(a.time, b.time, 1e-4) << "impact " << k;
      ASSERT_EQ(a.contacts.size(), b.contacts.size()) << "impact " << k;
      EXPECT_LT((a.contacts[0].point - b.contacts[0].point).norm(), 1e-3) << "impact " << k;
      EXPECT_LT((a.bodies_after[1].linear_velocity - b.bodies_after[1].linear_velocity).norm(),
                5e-3)
          << "impact " << k;
      EXPECT_LT((a.bodies_after[1].angular_velocity - b.bodies_after[1].angular_velocity).norm(),
                5e-3 / kHalf)
          << "impact " << k;
    }
  }
}

// The episode's path, flight by flight from each impact's state, sampled finely: no corner ever
// deeper than the tolerance below the floor.
TEST(Episode, RandomCubeLandingsMissNoContact) {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 80; ++trial) {
    SCOPED_TRACE(trial);
    // Each half with the per-point bound (GapContact::point_on_plane) and with the per-pair one;
    // every other pair of trials a brick (unequal moments: the adaptive free flight, and the
    // per-point bound's term for a changing angular velocity).
    const bool brick = trial % 4 >= 2;
    const Vector3d half = brick ? Vector3d(0.06, 0.035, 0.02) : Vector3d::Constant(kHalf);
    const std::vector<Vector3d> corners = boxCorners(half);
    const PointsAndPlanes geometry({Vector3d::UnitZ()}, corners, 0.0, {0.4, 0.5, 0.3}, trial < 40);
    core::BodyState c = cube(kCubeMass, kHalf);
    const Vector3d sq = half.cwiseProduct(half);
    c.inertia =
        kCubeMass / 3.0 * Vector3d(sq.y() + sq.z(), sq.x() + sq.z(), sq.x() + sq.y()).asDiagonal();
    c.orientation = Eigen::Quaterniond(u(random), u(random), u(random), u(random)).normalized();
    c.position = {0.0, 0.0, 0.02 + 0.1 * (u(random) + 1.0) - lowestCorner(c, corners)};
    c.linear_velocity = Vector3d(u(random), u(random), -1.0 + u(random));
    c.angular_velocity = 8.0 * Vector3d(u(random), u(random), u(random));
    const core::ImpactLaw law = trial % 2 ? core::ImpactLaw::kNewton : core::ImpactLaw::kStronge;
    core::EpisodeOptions options = episodeOptions(law);
    options.horizon = 1.0;
    const core::EpisodeResult result = core::computeEpisode({floorBody(), c}, geometry, options);
    ASSERT_FALSE(result.impacts.empty());
    EXPECT_TRUE(result.end == core::EpisodeEnd::kSustainedContact ||
                result.end == core::EpisodeEnd::kHorizon ||
                result.end == core::EpisodeEnd::kImpactCap)
        << core::toString(result.end);
    // Segments: start -> impact 0 -> impact 1 -> ... -> end (the accumulation's closure, which
    // does not move the bodies, left out).
    std::vector<std::pair<core::BodyState, double>> segments;
    segments.push_back({c, result.impacts[0].time});
    for (std::size_t k = 0; k < result.impacts.size(); ++k) {
      const double next = k + 1 < result.impacts.size()    ? result.impacts[k + 1].time
                          : result.accumulated_impacts > 0 ? result.impacts[k].time
                                                           : result.end_time;
      segments.push_back({result.impacts[k].bodies_after[1], next - result.impacts[k].time});
      // Every impact has a contact that approached.
      bool approached = false;
      for (const core::ContactImpulse& impulse : result.impacts[k].impulses) {
        approached = approached || impulse.normal_velocity_before < 0.0;
      }
      EXPECT_TRUE(approached) << "impact " << k;
    }
    for (const auto& [start, duration] : segments) {
      const int samples = 400;
      core::BodyState s = start;
      for (int i = 0; i < samples; ++i) {
        core::advanceFreeFlight(s, duration / samples, options.gravity);
        ASSERT_GE(lowestCorner(s, corners), -options.contact_tolerance) << "sample " << i;
      }
    }
    EXPECT_GE(lowestCorner(result.bodies[1], corners), -options.contact_tolerance);
  }
}

// A cube released at rest on one of its edges, its centre of mass 5 degrees past the edge, tips
// over about the edge and lands on a face: weight on an edge is not sustained contact when the
// body turns onto its next feature (docs/physics.md, "Impact episodes"). The reference is the
// geometry of a cube lying on a face: one body axis along the vertical, four corners on the floor,
// its centre one half width up, and energy: it cannot end with more kinetic energy than its
// centre's drop gives.
TEST(Episode, CubeTippingOverAnEdgeLandsOnAFace) {
  for (const core::ImpactLaw law : {core::ImpactLaw::kNewton, core::ImpactLaw::kStronge}) {
    SCOPED_TRACE(core::toString(law));
    const std::vector<Vector3d> corners = cubeCorners(kHalf);
    const PointsAndPlanes geometry({Vector3d::UnitZ()}, corners, 0.0, {0.0, 0.8, 0.8});
    core::BodyState c = cube(kCubeMass, kHalf);
    const double tilt = (45.0 + 5.0) * kPi / 180.0;  // about x: the edge along x on the floor
    c.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(tilt, Vector3d::UnitX()));
    c.position = {0.0, 0.0, 0.0};
    c.position.z() = -lowestCorner(c, corners);
    const double height_before = c.position.z();
    core::EpisodeOptions options = episodeOptions(law);
    options.horizon = 2.0;
    options.max_impacts = 200;
    const core::EpisodeResult result = core::computeEpisode({floorBody(), c}, geometry, options);
    ASSERT_EQ(result.end, core::EpisodeEnd::kSustainedContact)
        << core::toString(result.end) << " after " << result.impacts.size() << " impacts";
    const core::BodyState& end = result.bodies[1];
    EXPECT_GT(result.end_time, 0.05);  // it fell: about 0.2 s for a 10 cm cube
    // Lying on a face: some body axis vertical to 1 degree, the centre a half width up.
    const Eigen::Matrix3d R = end.orientation.toRotationMatrix();
    const double vertical = R.row(2).cwiseAbs().maxCoeff();
    EXPECT_GT(vertical, std::cos(kPi / 180.0));
    EXPECT_NEAR(end.position.z(), kHalf, 2.0 * options.contact_tolerance);
    // On the face: its four corners carry the weight. (It is left sliding slowly: the plastic
    // touches at the pivot leave a residue of the order the tolerance allows, see physics.md.)
    EXPECT_EQ(result.resting_contacts.size(), 4u);
    double normal = 0.0;
    for (const core::ContactImpulse& f : result.resting) normal += f.normal_force;
    EXPECT_NEAR(normal, kCubeMass * kG, 1e-2 * kCubeMass * kG);
    std::printf("%s: on a face after %.3f s, %zu impacts, %s, |w| %.3g rad/s, |v| %.3g m/s\n",
                core::toString(law), result.end_time, result.impacts.size(),
                core::toString(result.outcomes[1]), end.angular_velocity.norm(),
                end.linear_velocity.norm());
  }
}

// A body given overlapping another by more than the tolerance is named in the warnings (the state
// is usually a mistake), once per pair, with the depth of its deepest point.
TEST(Episode, StartingOverlapIsNamedOnce) {
  const std::vector<Vector3d> corners = cubeCorners(kHalf);
  const PointsAndPlanes geometry({Vector3d::UnitZ()}, corners, 0.0, {0.3, 0.5, 0.5});
  core::BodyState c = cube(kCubeMass, kHalf);
  c.position = {0.0, 0.0, kHalf - 0.003};  // 3 mm into the floor, flat
  core::EpisodeOptions options = episodeOptions(core::ImpactLaw::kNewton);
  options.horizon = 0.01;
  const core::EpisodeResult result = core::computeEpisode({floorBody(), c}, geometry, options);
  int named = 0;
  for (const core::Warning& w : result.warnings) {
    if (w.field == "bodies[1]" && w.reason.find("starts overlapping bodies[0] by 0.003") == 0)
      ++named;
  }
  EXPECT_EQ(named, 1);
  c.position.z() = kHalf - 0.5 * options.contact_tolerance;  // within the tolerance: nothing said
  for (const core::Warning& w : core::computeEpisode({floorBody(), c}, geometry, options).warnings)
    EXPECT_EQ(w.reason.find("starts overlapping"), std::string::npos) << w.text();
}

// A floor given an inertia tensor but no mass (usually a forgotten mass) is immovable, and says so
// as a single prediction would (computeResponse()'s "bodies[i].inertia" warning): once for the
// episode, however many impacts it has, and the ball's bounces are the closed form's all the same.
TEST(Episode, AnImmovableBodyGivenAnInertiaIsNamedOnceForTheWholeEpisode) {
  const double h = 0.2, e = 0.5, m = 0.5, R = 0.05;
  const PointsAndPlanes geometry({Vector3d::UnitZ()}, {Vector3d::Zero()}, R, {e, 0.0, 0.0});
  core::BodyState floor = floorBody();
  floor.inertia = Eigen::Matrix3d::Identity();
  const core::EpisodeOptions options = episodeOptions(core::ImpactLaw::kNewton);
  const core::EpisodeResult result =
      core::computeEpisode({floor, ball(m, R, h)}, geometry, options);
  ASSERT_GE(result.impacts.size(), 3u);
  int named = 0;
  for (const core::Warning& w : result.warnings) {
    if (w.field == "bodies[0].inertia") {
      ++named;
      EXPECT_EQ(w.kind, core::Warning::Kind::kInput);
      EXPECT_NE(w.reason.find("treated as immovable"), std::string::npos) << w.text();
    }
  }
  EXPECT_EQ(named, 1);
  // The same words as the single prediction of the first impact.
  core::Scene first;
  first.bodies = {floor, ball(m, R, h)};
  first.bodies[1].position.z() = R;
  first.bodies[1].linear_velocity.z() = -std::sqrt(2 * kG * h);
  first.contacts.push_back({"floor", "ball", Vector3d::Zero(), Vector3d::UnitZ(), e, 0.0, 0.0});
  const core::CollisionResult single = core::computeResponse(first, options.solver);
  ASSERT_FALSE(single.warnings.empty());
  EXPECT_EQ(single.warnings[0].field, "bodies[0].inertia");
  for (const core::Warning& w : result.warnings) {
    if (w.field == "bodies[0].inertia") {
      EXPECT_EQ(w.reason, single.warnings[0].reason);
    }
  }
  // The floor did not move, and the first rebound is e times the impact speed.
  EXPECT_NEAR(result.impacts[0].bodies_after[1].linear_velocity.z(), e * std::sqrt(2 * kG * h),
              1e-9);
  EXPECT_TRUE(result.bodies[0].linear_velocity.isZero(0.0));
}

// Two cubes (the same corners, each against the floor only): one at rest on it, the other dropped
// flat from 0.3 m beside it. The episode must not end when the first one's contacts carry it:
// the second is in the air. It ends when both rest, after the drop's closed-form fall time.
class TwoBodiesOnPlanes : public PointsAndPlanes {
 public:
  using PointsAndPlanes::PointsAndPlanes;
  int bodyCount() const override { return 3; }
};

TEST(Episode, BodyRestingBesideAFallingOneDoesNotEndTheEpisode) {
  const std::vector<Vector3d> corners = cubeCorners(kHalf);
  const TwoBodiesOnPlanes geometry({Vector3d::UnitZ()}, corners, 0.0, {0.0, 0.6, 0.6});
  core::BodyState resting = cube(kCubeMass, kHalf);
  resting.id = "resting";
  resting.position = {0.0, 0.0, kHalf};
  core::BodyState falling = cube(kCubeMass, kHalf);
  falling.id = "falling";
  const double height = 0.3;
  falling.position = {1.0, 0.0, kHalf + height};
  core::EpisodeOptions options = episodeOptions(core::ImpactLaw::kNewton);
  options.horizon = 2.0;
  const core::EpisodeResult result =
      core::computeEpisode({floorBody(), resting, falling}, geometry, options);
  ASSERT_EQ(result.end, core::EpisodeEnd::kSustainedContact) << core::toString(result.end);
  const double fall = std::sqrt(2.0 * height / kG);
  // The falling cube's first impact (the resting one meanwhile gets plastic touches: gravity
  // makes it sink in each flight, as a pivot does).
  double landing = -1.0;
  for (const core::EpisodeImpact& impact : result.impacts) {
    for (const core::Contact& c : impact.contacts) {
      if (landing < 0.0 && (c.body_a == "falling" || c.body_b == "falling")) landing = impact.time;
    }
  }
  EXPECT_NEAR(landing, fall, 1e-3);  // found within the tolerance's band
  EXPECT_GE(result.end_time, landing);
  EXPECT_NEAR(result.bodies[2].position.z(), kHalf, 2.0 * options.contact_tolerance);
  EXPECT_EQ(result.outcomes[1], core::BodyOutcome::kSticking);
  EXPECT_EQ(result.outcomes[2], core::BodyOutcome::kSticking);
  double normal = 0.0;
  for (const core::ContactImpulse& f : result.resting) normal += f.normal_force;
  EXPECT_NEAR(normal, 2.0 * kCubeMass * kG, 1e-6 * kCubeMass * kG);
}

// --- One impact, and contact already sustained --------------------------------------------------

TEST(Episode, SingleImpactThatSeparatesEqualsComputeResponse) {
  const double m = 0.3, R = 0.05;
  const PointsAndPlanes geometry({Vector3d::UnitZ()}, {Vector3d::Zero()}, R, {0.7, 0.3, 0.2});
  core::BodyState b = ball(m, R, 0.2);
  b.linear_velocity = {0.5, -0.2, -2.0};
  b.angular_velocity = {4.0, 1.0, -3.0};
  for (const core::ImpactLaw law : {core::ImpactLaw::kNewton, core::ImpactLaw::kStronge}) {
    core::EpisodeOptions options = episodeOptions(law);
    options.gravity.setZero();  // nothing brings the ball back
    const core::EpisodeResult result = core::computeEpisode({floorBody(), b}, geometry, options);
    ASSERT_EQ(result.impacts.size(), 1u);
    EXPECT_EQ(result.end, core::EpisodeEnd::kSeparated);
    EXPECT_EQ(result.outcomes[1], core::BodyOutcome::kSeparated);
    // The impact where straight flight brings the gap into [0, tolerance].
    EXPECT_GE(result.impacts[0].time, (0.2 - options.contact_tolerance) / 2.0 - 1e-12);
    EXPECT_LE(result.impacts[0].time, 0.2 / 2.0 + 1e-12);
    core::Scene scene;
    scene.bodies = {floorBody(), b};
    scene.bodies[1].position = result.impacts[0].bodies_after[1].position;
    scene.contacts = {result.impacts[0].contacts[0]};
    EXPECT_LT((scene.contacts[0].point -
               (scene.bodies[1].position - Vector3d(0, 0, scene.bodies[1].position.z())))
                  .norm(),
              1e-12);
    const core::CollisionResult reference = core::computeResponse(scene, options.solver);
    EXPECT_LT(
        (result.impacts[0].bodies_after[1].linear_velocity - reference.bodies[1].linear_velocity)
            .norm(),
        1e-12);
    EXPECT_LT(
        (result.impacts[0].bodies_after[1].angular_velocity - reference.bodies[1].angular_velocity)
            .norm(),
        1e-12);
    EXPECT_NEAR(result.impacts[0].impulses[0].normal_impulse, reference.impulses[0].normal_impulse,
                1e-12);
    // Then straight flight to the end.
    EXPECT_LT((result.bodies[1].linear_velocity - reference.bodies[1].linear_velocity).norm(),
              1e-12);
  }
}

// An episode keeps its lists in storage of its thread, reused by the thread's next episode. An
// episode started on the same thread while another runs (here from inside the outer one's gap
// query, at every query) must take storage of its own: both give what each gives alone, to the
// bit.
class QueryThatRunsAnEpisode : public core::GapQuery {
 public:
  QueryThatRunsAnEpisode(const core::GapQuery& geometry, const core::GapQuery& inner_geometry,
                         std::vector<core::BodyState> inner_bodies,
                         core::EpisodeOptions inner_options)
      : geometry_(geometry),
        inner_geometry_(inner_geometry),
        inner_bodies_(std::move(inner_bodies)),
        inner_options_(std::move(inner_options)) {}
  void gaps(const std::vector<core::BodyState>& bodies, double range,
            std::vector<core::GapContact>& out) const override {
    inner_.push_back(core::computeEpisode(inner_bodies_, inner_geometry_, inner_options_));
    geometry_.gaps(bodies, range, out);
  }
  double radius(int body) const override { return geometry_.radius(body); }
  int bodyCount() const override { return geometry_.bodyCount(); }
  const std::vector<core::EpisodeResult>& inner() const { return inner_; }

 private:
  const core::GapQuery& geometry_;
  const core::GapQuery& inner_geometry_;
  std::vector<core::BodyState> inner_bodies_;
  core::EpisodeOptions inner_options_;
  mutable std::vector<core::EpisodeResult> inner_;
};

void expectSameEpisode(const core::EpisodeResult& a, const core::EpisodeResult& b) {
  EXPECT_EQ(a.end, b.end);
  EXPECT_EQ(a.end_time, b.end_time);
  ASSERT_EQ(a.impacts.size(), b.impacts.size());
  for (std::size_t k = 0; k < a.impacts.size(); ++k) {
    EXPECT_EQ(a.impacts[k].time, b.impacts[k].time) << "impact " << k;
    ASSERT_EQ(a.impacts[k].impulses.size(), b.impacts[k].impulses.size()) << "impact " << k;
    for (std::size_t c = 0; c < a.impacts[k].impulses.size(); ++c)
      EXPECT_EQ(a.impacts[k].impulses[c].normal_impulse, b.impacts[k].impulses[c].normal_impulse)
          << "impact " << k << ", contact " << c;
  }
  ASSERT_EQ(a.bodies.size(), b.bodies.size());
  for (std::size_t i = 0; i < a.bodies.size(); ++i) {
    EXPECT_EQ(a.bodies[i].position, b.bodies[i].position) << "body " << i;
    EXPECT_EQ(a.bodies[i].linear_velocity, b.bodies[i].linear_velocity) << "body " << i;
    EXPECT_EQ(a.bodies[i].angular_velocity, b.bodies[i].angular_velocity) << "body " << i;
  }
  EXPECT_EQ(a.outcomes, b.outcomes);
  EXPECT_EQ(a.resting.size(), b.resting.size());
}

TEST(Episode, AnEpisodeStartedWithinAnotherOnItsThreadLeavesBothUnchanged) {
  // Outer: a tilted cube landing on a corner (several impacts, friction, a resting analysis).
  const PointsAndPlanes cube_geometry({Vector3d::UnitZ()}, cubeCorners(0.05), 0.0, {0.3, 0.6, 0.4});
  core::BodyState c = cube(0.37, 0.05);
  c.orientation = Eigen::AngleAxisd(0.5, Vector3d(1, 0.3, 0).normalized());
  c.position = {0.0, 0.0, 0.12};
  c.linear_velocity = {0.4, 0.0, -1.0};
  c.angular_velocity = {0.0, 2.0, 1.0};
  const std::vector<core::BodyState> outer_bodies = {floorBody(), c};
  const core::EpisodeOptions outer_options = episodeOptions(core::ImpactLaw::kNewton);
  // Inner: a ball bouncing to rest, other bodies and counts.
  const PointsAndPlanes ball_geometry({Vector3d::UnitZ()}, {Vector3d::Zero()}, 0.02,
                                      {0.6, 0.0, 0.0});
  const std::vector<core::BodyState> inner_bodies = {floorBody(), ball(0.1, 0.02, 0.05)};
  const core::EpisodeOptions inner_options = episodeOptions(core::ImpactLaw::kStronge);

  const core::EpisodeResult outer_alone =
      core::computeEpisode(outer_bodies, cube_geometry, outer_options);
  const core::EpisodeResult inner_alone =
      core::computeEpisode(inner_bodies, ball_geometry, inner_options);
  ASSERT_GE(outer_alone.impacts.size(), 2u);
  ASSERT_GE(inner_alone.impacts.size(), 2u);

  const QueryThatRunsAnEpisode nesting(cube_geometry, ball_geometry, inner_bodies, inner_options);
  const core::EpisodeResult outer_nested =
      core::computeEpisode(outer_bodies, nesting, outer_options);
  expectSameEpisode(outer_nested, outer_alone);
  ASSERT_FALSE(nesting.inner().empty());
  for (const core::EpisodeResult& inner : nesting.inner()) expectSameEpisode(inner, inner_alone);
  // And the thread's storage is free again: the next episode on it gives the same.
  expectSameEpisode(core::computeEpisode(outer_bodies, cube_geometry, outer_options), outer_alone);
}

// The thread's lists hold the last episode's contacts when the next one starts: an episode out of
// time before its first query (an expired deadline) reports from none of them. (A free ball after
// a cube that rested on the floor: the cube's touching corners named body 1, which this episode
// does not have.)
TEST(Episode, AnEpisodeOutOfTimeAtOnceReportsNoContactOfTheEpisodeBefore) {
  const PointsAndPlanes floor_and_cube({Vector3d::UnitZ()}, cubeCorners(0.05), 0.0,
                                       {0.5, 0.6, 0.4});
  core::BodyState resting = cube(0.37, 0.05);
  resting.position = {0.0, 0.0, 0.05};
  const core::EpisodeResult before = core::computeEpisode({floorBody(), resting}, floor_and_cube,
                                                          episodeOptions(core::ImpactLaw::kNewton));
  ASSERT_EQ(before.end, core::EpisodeEnd::kSustainedContact);

  const PointsAndPlanes nothing_else({}, {Vector3d::Zero()}, 0.02, {0.5, 0.0, 0.0});
  core::EpisodeOptions options = episodeOptions(core::ImpactLaw::kNewton);
  options.solver.deadline = core::Deadline::in(-1.0);  // expired
  const core::EpisodeResult alone =
      core::computeEpisode({ball(0.1, 0.02, 1.0)}, nothing_else, options);
  EXPECT_EQ(alone.end, core::EpisodeEnd::kTimeBudget);
  ASSERT_EQ(alone.outcomes.size(), 1u);
  EXPECT_EQ(alone.outcomes[0], core::BodyOutcome::kSeparated);  // nothing touched it
  EXPECT_TRUE(alone.impacts.empty());
}

core::BodyState cubeOnFloor() {
  core::BodyState c = cube(kCubeMass, kHalf);
  c.position = {0.0, 0.0, kHalf};
  return c;
}

TEST(Episode, CubeRestingOnTheFloorGivesTheRestingAnalysis) {
  const double mu_s = 0.6, mu_d = 0.4;
  const PointsAndPlanes geometry({Vector3d::UnitZ()}, cubeCorners(kHalf), 0.0, {0.5, mu_s, mu_d});
  const core::EpisodeOptions options = episodeOptions(core::ImpactLaw::kStronge);
  const auto totalForce = [](const core::EpisodeResult& r) {
    Vector3d f = Vector3d::Zero();
    for (std::size_t i = 0; i < r.resting.size(); ++i) {
      f += r.resting[i].normal_force * r.resting_contacts[i].normal + r.resting[i].friction_force;
    }
    return f;
  };
  {  // At rest: held by the normal forces alone, sticking.
    const core::EpisodeResult r =
        core::computeEpisode({floorBody(), cubeOnFloor()}, geometry, options);
    EXPECT_EQ(r.end, core::EpisodeEnd::kSustainedContact);
    EXPECT_EQ(r.end_time, 0.0);
    EXPECT_TRUE(r.impacts.empty());
    EXPECT_EQ(r.resting.size(), 4u);
    EXPECT_LT((totalForce(r) - Vector3d(0, 0, kCubeMass * kG)).norm(), 1e-9);
    ASSERT_EQ(r.linear_accelerations.size(), 2u);
    EXPECT_EQ(r.outcomes[1], core::BodyOutcome::kSticking);
    EXPECT_LT(r.linear_accelerations[1].norm(), 1e-9);
    EXPECT_LT(r.angular_accelerations[1].norm(), 1e-9);
  }
  {  // Moving along the floor: sliding, dynamic friction against the motion.
    core::BodyState c = cubeOnFloor();
    c.linear_velocity = {0.3, 0.0, 0.0};
    const core::EpisodeResult r = core::computeEpisode({floorBody(), c}, geometry, options);
    ASSERT_EQ(r.end, core::EpisodeEnd::kSustainedContact);
    EXPECT_EQ(r.outcomes[1], core::BodyOutcome::kSliding);
    EXPECT_LT((totalForce(r) - Vector3d(-mu_d * kCubeMass * kG, 0, kCubeMass * kG)).norm(), 1e-9);
    EXPECT_NEAR(r.linear_accelerations[1].x(), -mu_d * kG, 1e-9);
  }
  {  // Pushed through its centre between mu_d m g and mu_s m g: static friction holds it.
    core::BodyState c = cubeOnFloor();
    c.force = {0.5 * kCubeMass * kG, 0.0, 0.0};
    const core::EpisodeResult r = core::computeEpisode({floorBody(), c}, geometry, options);
    ASSERT_EQ(r.end, core::EpisodeEnd::kSustainedContact);
    EXPECT_EQ(r.outcomes[1], core::BodyOutcome::kSticking);
    EXPECT_LT(r.linear_accelerations[1].norm(), 1e-9);
    EXPECT_NEAR(totalForce(r).x(), -0.5 * kCubeMass * kG, 1e-9);
  }
  {  // Pushed above mu_s m g: it starts to slide under dynamic friction.
    core::BodyState c = cubeOnFloor();
    c.force = {0.7 * kCubeMass * kG, 0.0, 0.0};
    const core::EpisodeResult r = core::computeEpisode({floorBody(), c}, geometry, options);
    ASSERT_EQ(r.end, core::EpisodeEnd::kSustainedContact);
    EXPECT_EQ(r.outcomes[1], core::BodyOutcome::kSliding);
    EXPECT_NEAR(r.linear_accelerations[1].x(), (0.7 - mu_d) * kG, 1e-6);
  }
}

// Slow slips (docs/physics.md, "Slow slips"): a slip below the episode's resting threshold
// (sqrt(2 g tol) = 0.044 m/s at tol = 1e-4 m) but above round-off is Coulomb's sliding. The cube
// lying on the floor sliding at 2 cm/s along x without turning (every corner slipping at 2 cm/s),
// mu_s = 0.6 > mu_d = 0.4. Closed form: each loaded corner's friction -mu_d N_i x, so the cube
// decelerates at mu_d g along x and, all four corners staying in contact, does not turn
// (alpha = 0). The corners' normal forces are not unique, but their sums are: sum N_i = m g
// (vertical), and the moments about the centre of F_i = (-mu_d N_i, 0, N_i) at r_i = (x_i, y_i,
// -h): about y, mu_d h N_i - x_i N_i, so sum x_i N_i = mu_d h m g (the front corners, x_i = +h,
// carry m g (1 + mu_d) / 2, the back ones m g (1 - mu_d) / 2); about x and z, sum y_i N_i = 0.
// Before, the slips counted as none, the all-stick answer (no friction needed) was given, and the
// cube was reported sliding at zero acceleration.
TEST(Episode, CubeSlidingSlowlyWithoutTurningBrakesUnderDynamicFriction) {
  const double mu_s = 0.6, mu_d = 0.4, m = kCubeMass, v = 0.02;
  const PointsAndPlanes geometry({Vector3d::UnitZ()}, cubeCorners(kHalf), 0.0, {0.5, mu_s, mu_d});
  const core::EpisodeOptions options = episodeOptions(core::ImpactLaw::kStronge);
  ASSERT_LT(v, std::sqrt(2.0 * kG * options.contact_tolerance));  // within the resting threshold
  core::BodyState c = cubeOnFloor();
  c.linear_velocity = {v, 0.0, 0.0};
  const core::EpisodeResult r = core::computeEpisode({floorBody(), c}, geometry, options);
  ASSERT_EQ(r.end, core::EpisodeEnd::kSustainedContact);
  EXPECT_TRUE(r.impacts.empty());
  EXPECT_EQ(r.outcomes[1], core::BodyOutcome::kSliding);
  ASSERT_EQ(r.linear_accelerations.size(), 2u);
  EXPECT_LT((r.linear_accelerations[1] - Vector3d(-mu_d * kG, 0.0, 0.0)).norm(), 1e-9 * kG);
  EXPECT_LT(r.angular_accelerations[1].norm(), 1e-9 * kG / kHalf);
  ASSERT_EQ(r.resting.size(), 4u);
  double normal = 0.0, moment_x = 0.0, moment_y = 0.0;
  for (std::size_t i = 0; i < r.resting.size(); ++i) {
    const core::ContactImpulse& f = r.resting[i];
    const Vector3d arm = r.resting_contacts[i].point - c.position;
    normal += f.normal_force;
    moment_x += arm.x() * f.normal_force;
    moment_y += arm.y() * f.normal_force;
    EXPECT_GE(f.normal_force, 0.0) << "corner " << i;
    EXPECT_FALSE(f.sticking) << "corner " << i;
    EXPECT_LT((f.friction_force - Vector3d(-mu_d * f.normal_force, 0.0, 0.0)).norm(), 1e-9 * m * kG)
        << "corner " << i;
  }
  EXPECT_NEAR(normal, m * kG, 1e-9 * m * kG);
  EXPECT_NEAR(moment_x, mu_d * kHalf * m * kG, 1e-9 * m * kG * kHalf);
  EXPECT_NEAR(moment_y, 0.0, 1e-9 * m * kG * kHalf);
}

// The other side of the line: slips of round-off size stay at rest, and the static band is kept.
// The cube pushed through its centre with 0.5 m g, between mu_d m g and mu_s m g: at exactly zero
// slip, and at a slip of 1e-9 m/s (below the solver's resting velocity, 1e-6 m/s: round-off), it
// sticks (static friction 0.5 m g against the push, no acceleration); at a slip of 2 cm/s, it is
// already sliding, so dynamic friction, and it accelerates at (0.5 - mu_d) g along the push.
TEST(Episode, CubeInTheStaticBandSticksAtRoundOffSlipAndSlidesAtARealOne) {
  const double mu_s = 0.6, mu_d = 0.4, m = kCubeMass, push = 0.5 * m * kG;
  const PointsAndPlanes geometry({Vector3d::UnitZ()}, cubeCorners(kHalf), 0.0, {0.5, mu_s, mu_d});
  const core::EpisodeOptions options = episodeOptions(core::ImpactLaw::kStronge);
  for (const double v : {0.0, 1e-9, 0.02}) {
    char trace[32];
    std::snprintf(trace, sizeof trace, "slip %g m/s", v);
    SCOPED_TRACE(trace);
    core::BodyState c = cubeOnFloor();
    c.linear_velocity = {v, 0.0, 0.0};
    c.force = {push, 0.0, 0.0};
    const core::EpisodeResult r = core::computeEpisode({floorBody(), c}, geometry, options);
    ASSERT_EQ(r.end, core::EpisodeEnd::kSustainedContact);
    ASSERT_EQ(r.resting.size(), 4u);
    Vector3d friction = Vector3d::Zero();
    for (const core::ContactImpulse& f : r.resting) friction += f.friction_force;
    if (v < 1e-6) {
      EXPECT_EQ(r.outcomes[1], core::BodyOutcome::kSticking);
      EXPECT_LT(r.linear_accelerations[1].norm(), 1e-9 * kG);
      EXPECT_LT((friction - Vector3d(-push, 0.0, 0.0)).norm(), 1e-9 * m * kG);
      for (const core::ContactImpulse& f : r.resting) EXPECT_TRUE(f.sticking);
    } else {
      EXPECT_EQ(r.outcomes[1], core::BodyOutcome::kSliding);
      EXPECT_LT((r.linear_accelerations[1] - Vector3d((0.5 - mu_d) * kG, 0.0, 0.0)).norm(),
                1e-9 * kG);
      EXPECT_LT((friction - Vector3d(-mu_d * m * kG, 0.0, 0.0)).norm(), 1e-9 * m * kG);
      for (const core::ContactImpulse& f : r.resting) EXPECT_FALSE(f.sticking);
    }
    EXPECT_LT(r.angular_accelerations[1].norm(), 1e-9 * kG / kHalf);
  }
}

// One contact: a ball (1 kg, R = 0.05 m) on the floor sliding at 2 cm/s without spin, its contact
// slipping at 2 cm/s (below the resting threshold). Closed form of a sliding ball: friction
// -mu_d m g x at the bottom, so a = -mu_d g x and alpha = R mu_d m g / I about +y,
// I = 2/5 m R^2: alpha_y = 5 mu_d g / (2 R). Before, the lone contact's closed form took the slip
// as none and, nothing pushing the ball along the floor, answered no friction and no
// acceleration.
TEST(Episode, BallSlidingSlowlyOnOneContactBrakesUnderDynamicFriction) {
  const double m = 1.0, R = 0.05, mu_s = 0.6, mu_d = 0.4, v = 0.02;
  const PointsAndPlanes geometry({Vector3d::UnitZ()}, {Vector3d::Zero()}, R, {0.5, mu_s, mu_d});
  const core::EpisodeOptions options = episodeOptions(core::ImpactLaw::kNewton);
  core::BodyState b = ball(m, R, 0.0);
  b.linear_velocity = {v, 0.0, 0.0};
  const core::EpisodeResult r = core::computeEpisode({floorBody(), b}, geometry, options);
  ASSERT_EQ(r.end, core::EpisodeEnd::kSustainedContact);
  ASSERT_EQ(r.resting.size(), 1u);
  EXPECT_EQ(r.outcomes[1], core::BodyOutcome::kSliding);
  EXPECT_FALSE(r.resting[0].sticking);
  EXPECT_NEAR(r.resting[0].normal_force, m * kG, 1e-9 * m * kG);
  EXPECT_LT((r.resting[0].friction_force - Vector3d(-mu_d * m * kG, 0.0, 0.0)).norm(),
            1e-9 * m * kG);
  EXPECT_LT((r.linear_accelerations[1] - Vector3d(-mu_d * kG, 0.0, 0.0)).norm(), 1e-9 * kG);
  EXPECT_LT((r.angular_accelerations[1] - Vector3d(0.0, 2.5 * mu_d * kG / R, 0.0)).norm(),
            1e-9 * kG / R);
}

// --- Bad input and pathological episodes -------------------------------------------------------

std::string fieldOf(const std::vector<core::BodyState>& bodies, const core::GapQuery& geometry,
                    const core::EpisodeOptions& options) {
  try {
    core::computeEpisode(bodies, geometry, options);
  } catch (const core::InvalidInput& error) {
    return error.field();
  }
  return "(accepted)";
}

TEST(Episode, BadInputNamesTheField) {
  const PointsAndPlanes geometry({Vector3d::UnitZ()}, {Vector3d::Zero()}, 0.05, {0.5, 0.0, 0.0});
  const std::vector<core::BodyState> bodies = {floorBody(), ball(1.0, 0.05, 0.1)};
  const core::EpisodeOptions good = episodeOptions(core::ImpactLaw::kStronge);
  EXPECT_EQ(fieldOf(bodies, geometry, good), "(accepted)");
  core::EpisodeOptions o = good;
  o.gravity.x() = std::nan("");
  EXPECT_EQ(fieldOf(bodies, geometry, o), "gravity");
  o = good;
  o.gravity.z() = kInf;
  EXPECT_EQ(fieldOf(bodies, geometry, o), "gravity");
  for (const double horizon : {-1.0, 0.0, kInf, std::nan("")}) {
    o = good;
    o.horizon = horizon;
    EXPECT_EQ(fieldOf(bodies, geometry, o), "horizon") << horizon;
  }
  o = good;
  o.max_impacts = 0;
  EXPECT_EQ(fieldOf(bodies, geometry, o), "max_impacts");
  for (const double tolerance : {0.0, -1e-4, std::nan("")}) {
    o = good;
    o.contact_tolerance = tolerance;
    EXPECT_EQ(fieldOf(bodies, geometry, o), "contact_tolerance") << tolerance;
  }
  o = good;
  o.solver.time_budget = 0.0;
  EXPECT_EQ(fieldOf(bodies, geometry, o), "options.time_budget");
  core::BodyState second = ball(1.0, 0.05, 0.5);
  second.id = "second";
  EXPECT_EQ(fieldOf({floorBody(), ball(1.0, 0.05, 0.1), second}, geometry, good), "geometry");
  std::vector<core::BodyState> bad = bodies;
  bad[1].mass = -1.0;
  EXPECT_EQ(fieldOf(bad, geometry, good), "bodies[1].inertia.m");  // as the messages spell it
  bad = bodies;
  bad[0].mass = 1.0;  // a movable plane: unbounded geometry
  bad[0].inertia = Eigen::Matrix3d::Identity();
  EXPECT_EQ(fieldOf(bad, geometry, good), "bodies[0]");  // the body given, not the geometry
}

// A ball squeezed between two walls closing on it (prescribed velocities): ever faster bounces,
// then both walls through it. It ends at the cap or the budget, reported.
TEST(Episode, WedgedBallEndsAtTheCapOrTheBudget) {
  const double R = 0.05;
  const PointsAndPlanes geometry({Vector3d::UnitX(), -Vector3d::UnitX()}, {Vector3d::Zero()}, R,
                                 {0.9, 0.3, 0.3});
  core::BodyState left, right;
  left.id = "left";
  left.position = {-R - 0.01, 0.0, 0.0};
  left.linear_velocity = {0.1, 0.0, 0.0};
  right.id = "right";
  right.position = {R + 0.01, 0.0, 0.0};
  right.linear_velocity = {-0.1, 0.0, 0.0};
  core::BodyState b = ball(1.0, R, 0.0);
  b.position.setZero();
  b.linear_velocity = {1.0, 0.0, 0.0};
  core::EpisodeOptions options = episodeOptions(core::ImpactLaw::kStronge);
  options.gravity.setZero();
  options.horizon = 1e6;
  {
    // Newton's law here: Stronge's integration of the jammed contacts is slow (its own budget),
    // which the second case below exercises.
    core::EpisodeOptions newton = options;
    newton.solver.law = core::ImpactLaw::kNewton;
    const core::EpisodeResult r = core::computeEpisode({left, right, b}, geometry, newton);
    EXPECT_EQ(r.end, core::EpisodeEnd::kImpactCap);
    EXPECT_EQ(static_cast<int>(r.impacts.size()), options.max_impacts);
    EXPECT_EQ(r.outcomes[2], core::BodyOutcome::kCapped);
  }
  {
    options.max_impacts = 1000000000;
    options.solver.time_budget = 0.05;
    const auto start = std::chrono::steady_clock::now();
    const core::EpisodeResult r = core::computeEpisode({left, right, b}, geometry, options);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_EQ(r.end, core::EpisodeEnd::kTimeBudget);
    EXPECT_LT(seconds, 5.0);  // ends soon after its budget (generous: a loaded machine)
  }
}

// Ends without an impact: a ball that cannot reach the floor before the horizon (it falls
// g horizon^2 / 2 = 4.9 cm of its 1 m), and one touching the floor in zero gravity (nothing
// loads the contact; it is still touching at the horizon).
TEST(Episode, EndsAtSeparationOrHorizonWithoutAnImpact) {
  const double R = 0.05;
  const PointsAndPlanes geometry({Vector3d::UnitZ()}, {Vector3d::Zero()}, R, {0.5, 0.3, 0.3});
  core::EpisodeOptions options = episodeOptions(core::ImpactLaw::kStronge);
  options.horizon = 0.1;
  core::EpisodeResult r = core::computeEpisode({floorBody(), ball(1.0, R, 1.0)}, geometry, options);
  EXPECT_EQ(r.end, core::EpisodeEnd::kSeparated);
  EXPECT_TRUE(r.impacts.empty());
  EXPECT_LT(r.end_time, options.horizon);
  EXPECT_EQ(r.outcomes[1], core::BodyOutcome::kSeparated);
  // The state at end_time is the free flight's.
  EXPECT_NEAR(r.bodies[1].position.z(), R + 1.0 - 0.5 * kG * r.end_time * r.end_time, 1e-12);

  options.gravity.setZero();
  r = core::computeEpisode({floorBody(), ball(1.0, R, 0.0)}, geometry, options);
  EXPECT_EQ(r.end, core::EpisodeEnd::kHorizon);
  EXPECT_EQ(r.end_time, options.horizon);
  EXPECT_EQ(r.outcomes[1], core::BodyOutcome::kCapped);
}

// A ball dropped 0.2 m (it lands at sqrt(2 h / g) = 0.202 s at 1.98 m/s) bounces with e = 0.5 and
// rises; the horizon comes 0.05 s after the bounce, before it can fall back (its apex is 0.1 s
// after it). The step from the bounce, where the ball still touches the floor, covers the rest of
// the horizon: the episode ends there in flight, `separated` (not `horizon`, which says a pair
// still touches), in the ballistic state the bounce's answer gives in closed form.
TEST(Episode, BallFlyingOffAfterItsBounceEndsSeparatedAtTheHorizon) {
  const double R = 0.05, e = 0.5, h = 0.2;
  const PointsAndPlanes geometry({Vector3d::UnitZ()}, {Vector3d::Zero()}, R, {e, 0.3, 0.3});
  for (const core::ImpactLaw law : {core::ImpactLaw::kNewton, core::ImpactLaw::kStronge}) {
    core::EpisodeOptions options = episodeOptions(law);
    const double landing = std::sqrt(2.0 * h / kG);
    options.horizon = landing + 0.05;
    const core::EpisodeResult r =
        core::computeEpisode({floorBody(), ball(1.0, R, h)}, geometry, options);
    ASSERT_EQ(r.impacts.size(), 1u) << core::toString(law);
    EXPECT_EQ(r.end, core::EpisodeEnd::kSeparated);
    EXPECT_EQ(r.outcomes[1], core::BodyOutcome::kSeparated);
    EXPECT_EQ(r.end_time, options.horizon);
    // The bounce within the tolerance of the closed-form landing, reversing e of the speed then.
    const double t1 = r.impacts[0].time;
    EXPECT_NEAR(t1, landing, options.contact_tolerance / (kG * landing));
    const double v1 = kG * t1;  // falling speed at the bounce [m/s]
    const core::BodyState& after = r.impacts[0].bodies_after[1];
    EXPECT_NEAR(after.linear_velocity.z(), e * v1, 1e-9);
    // Ballistic from there to the horizon.
    const double dt = options.horizon - t1;
    EXPECT_NEAR(r.bodies[1].linear_velocity.z(), e * v1 - kG * dt, 1e-9);
    EXPECT_NEAR(r.bodies[1].position.z(), after.position.z() + e * v1 * dt - 0.5 * kG * dt * dt,
                1e-9);
    EXPECT_GT(r.bodies[1].position.z() - R, 0.03);  // well clear of the floor
  }
}

TEST(Episode, ToStringNamesEveryEnumerator) {
  EXPECT_STREQ(core::toString(core::EpisodeEnd::kSeparated), "separated");
  EXPECT_STREQ(core::toString(core::EpisodeEnd::kSustainedContact), "sustained_contact");
  EXPECT_STREQ(core::toString(core::EpisodeEnd::kHorizon), "horizon");
  EXPECT_STREQ(core::toString(core::EpisodeEnd::kImpactCap), "impact_cap");
  EXPECT_STREQ(core::toString(core::EpisodeEnd::kTimeBudget), "time_budget");
  EXPECT_STREQ(core::toString(core::BodyOutcome::kSeparated), "separated");
  EXPECT_STREQ(core::toString(core::BodyOutcome::kSliding), "sliding");
  EXPECT_STREQ(core::toString(core::BodyOutcome::kRolling), "rolling");
  EXPECT_STREQ(core::toString(core::BodyOutcome::kSticking), "sticking");
  EXPECT_STREQ(core::toString(core::BodyOutcome::kCapped), "capped");
}

}  // namespace
