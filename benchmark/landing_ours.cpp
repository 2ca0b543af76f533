#include "landing_ours.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <utility>

#include "collision_response/core/compute_response.h"
#include "collision_response/core/episode.h"
#include "collision_response/core/gap_query.h"
#include "cube_flight.h"

namespace collision_response::bench {
namespace {

using core::ImpactLaw;

/// Corners within this of the lowest one are one simultaneous impact [m] (EpisodeOptions'
/// default contact tolerance).
constexpr double kSimultaneous = 1e-4;
/// The first contact from the flight is found to this [m].
constexpr double kContactTolerance = 1e-6;
/// The episode's max_impacts. A cube that tumbles over a corner or an edge is followed as plastic
/// touches of that corner every 0.08 ms or so (docs/benchmarks.md, "Real tosses"), so a landing
/// that pivots for 100 ms takes some 1,700 impacts: the library's default of 100 would cut it
/// after 8 ms of pivoting, and the harness would then fly the cube on through the table.
constexpr int kEpisodeImpactCap = 5000;

/// Restitution and friction from the fitted values: (e, mu) or (e, mu_d, mu_s - mu_d).
struct Coefficients {
  double e, mu_s, mu_d;
};
Coefficients coefficients(const std::vector<double>& values, bool split) {
  if (split) return {values[0], values[1] + values[2], values[1]};
  return {values[0], values[1], values[1]};
}
std::vector<LandingParameter> lawParameters(bool split) {
  if (split)
    return {{"e", 0.0, 1.0, 0.3, false},
            {"mu_d", 0.0, 1.5, 0.3, false},
            {"mu_s-mu_d", 0.0, 1.0, 0.1, false}};
  return {{"e", 0.0, 1.0, 0.3, false}, {"mu", 0.0, 1.5, 0.3, false}};
}
std::string lawName(const char* kind, ImpactLaw law, bool split) {
  return std::string(kind) + ", " + core::toString(law) + (split ? ", mu_s/mu_d" : ", mu");
}

core::BodyState tableBody() {
  core::BodyState table;
  table.id = "table";
  return table;
}
core::BodyState cubeBody(const CubeState& state, const TossedCube& cube) {
  core::BodyState body;
  body.id = "cube";
  body.mass = cube.mass;
  body.inertia = cube.inertia * Eigen::Matrix3d::Identity();
  body.position = state.position;
  body.orientation = state.orientation;
  body.linear_velocity = state.linear_velocity;
  body.angular_velocity = state.angular_velocity;
  return body;
}

/// One computeResponse() at the corners within kSimultaneous of the lowest; the cube's velocities
/// after it.
CubeState impact(const CubeState& state, const TossedCube& cube, const Coefficients& c,
                 const core::SolverOptions& options) {
  const auto corners = cubeCorners(state, cube.half_width);
  double lowest = std::numeric_limits<double>::infinity();
  for (const auto& p : corners) lowest = std::min(lowest, p.z());
  core::Scene scene;
  scene.bodies = {tableBody(), cubeBody(state, cube)};
  for (const auto& p : corners) {
    if (p.z() > lowest + kSimultaneous) continue;
    core::Contact contact;
    contact.body_a = "table";
    contact.body_b = "cube";
    contact.point = p;
    contact.normal = Eigen::Vector3d::UnitZ();
    contact.restitution = c.e;
    contact.static_friction = c.mu_s;
    contact.dynamic_friction = c.mu_d;
    scene.contacts.push_back(contact);
  }
  const core::CollisionResult result = core::computeResponse(scene, options);
  CubeState after = state;
  after.linear_velocity = result.bodies[1].linear_velocity;
  after.angular_velocity = result.bodies[1].angular_velocity;
  return after;
}

class LawLanding : public LandingModel {
 public:
  LawLanding(const TossedCube& cube, ImpactLaw law, bool split) : cube_(cube), split_(split) {
    options_.law = law;
  }
  std::vector<LandingParameter> parameters() const override { return lawParameters(split_); }
  /// How the landings simulated since the last call ended, counted by kind.
  std::map<std::string, int> takeEnds() { return std::exchange(ends_, {}); }

 protected:
  std::map<std::string, int> ends_;
  TossedCube cube_;
  bool split_;
  core::SolverOptions options_;
};

class OneImpact final : public LawLanding {
 public:
  using LawLanding::LawLanding;
  std::string name() const override { return lawName("one impact", options_.law, split_); }
  CubeState simulate(const CubeState& before, const std::vector<double>& values,
                     double duration) override {
    const double t = firstTableContact(before, cube_.half_width, duration, kContactTolerance);
    if (t >= duration) return flyBallistic(before, duration);
    const CubeState after =
        impact(flyBallistic(before, t), cube_, coefficients(values, split_), options_);
    return flyBallistic(after, duration - t);
  }
};

/// Event-driven repetition of impacts (see the header). A corner is struck when it is at or
/// below the table and moving into it faster than kApproach; corners are checked every kScan
/// seconds and a newly crossing corner's crossing time bisected to 1e-7 s. Past kMaxImpacts the
/// cube flies on ballistically (a sustained contact chatters: it is no part of the kept tosses'
/// landings, which end in free flight).
class RepeatedImpacts final : public LawLanding {
 public:
  using LawLanding::LawLanding;
  static constexpr double kScan = 2.5e-4;    // [s]
  static constexpr double kApproach = 1e-3;  // [m/s]
  static constexpr int kMaxImpacts = 500;
  std::string name() const override { return lawName("repeated impacts", options_.law, split_); }
  CubeState simulate(const CubeState& before, const std::vector<double>& values,
                     double duration) override {
    const Coefficients c = coefficients(values, split_);
    double t = firstTableContact(before, cube_.half_width, duration, kContactTolerance);
    if (t >= duration) return flyBallistic(before, duration);
    CubeState state = impact(flyBallistic(before, t), cube_, c, options_);
    int impacts = 1;
    for (; impacts < kMaxImpacts; ++impacts) {
      double step = 0.0;
      if (!nextImpact(state, duration - t, step)) break;
      state = impact(flyBallistic(state, step), cube_, c, options_);
      t += step;
    }
    ++ends_[impacts == kMaxImpacts ? "capped"
            : impacts < 5          ? "1-4 impacts"
            : impacts < 20         ? "5-19 impacts"
                                   : "20+ impacts"];
    return flyBallistic(state, duration - t);
  }

 private:
  /// Whether some corner is struck at `state` (at or below the table, approaching).
  bool struck(const CubeState& state) const {
    const auto corners = cubeCorners(state, cube_.half_width);
    for (const auto& p : corners) {
      const double vz =
          (state.linear_velocity + state.angular_velocity.cross(p - state.position)).z();
      if (p.z() <= 0.0 && vz < -kApproach) return true;
    }
    return false;
  }
  /// The time [s] after `state` of the next strike within `limit`.
  bool nextImpact(const CubeState& state, double limit, double& when) const {
    double previous = 0.0;
    for (double t = std::min(kScan, limit); t <= limit; t = std::min(t + kScan, limit)) {
      if (struck(flyBallistic(state, t))) {
        double lo = previous, hi = t;  // struck at hi, not at lo
        while (hi - lo > 1e-7) {
          const double mid = 0.5 * (lo + hi);
          (struck(flyBallistic(state, mid)) ? hi : lo) = mid;
        }
        when = hi;
        return true;
      }
      previous = t;
      if (t >= limit) break;
    }
    return false;
  }
};

/// The cube (body 1) against the table plane z = 0 (body 0, immovable): the 8 corners, each with
/// its height as gap, normal +z (from the table to the cube), the fitted coefficients.
class CubeTableGaps final : public core::GapQuery {
 public:
  CubeTableGaps(double half_width, const Coefficients& c) : half_width_(half_width), c_(c) {}
  void gaps(const std::vector<core::BodyState>& bodies, double range,
            std::vector<core::GapContact>& out) const override {
    out.clear();
    CubeState state;
    state.position = bodies[1].position;
    state.orientation = bodies[1].orientation;
    for (const auto& p : cubeCorners(state, half_width_)) {
      if (p.z() > range) continue;
      core::GapContact contact;
      contact.body_a = 0;
      contact.body_b = 1;
      contact.point = Eigen::Vector3d(p.x(), p.y(), p.z());
      contact.normal = Eigen::Vector3d::UnitZ();
      contact.gap = p.z();
      // A corner is a material point of the cube on the table's plane, and every corner within
      // the range is listed: what detection::ShapeGaps promises for a box on a plane, so the
      // episode bounds each corner's gap as it does for the users' boxes.
      contact.point_on_plane = true;
      contact.restitution = c_.e;
      contact.static_friction = c_.mu_s;
      contact.dynamic_friction = c_.mu_d;
      out.push_back(contact);
    }
  }
  double radius(int body) const override {
    return body == 0 ? std::numeric_limits<double>::infinity() : half_width_ * std::sqrt(3.0);
  }
  int bodyCount() const override { return 2; }

 private:
  double half_width_;
  Coefficients c_;
};

/// core::computeEpisode() from the pre-impact flight for `duration`; an episode that ends earlier
/// (separated) is continued in free flight, one that ends in sustained contact, on its cap or its
/// horizon is continued in free flight from its end state (the kept tosses end their landing in
/// flight).
class Episode final : public LawLanding {
 public:
  using LawLanding::LawLanding;
  std::string name() const override { return lawName("episode", options_.law, split_); }
  CubeState simulate(const CubeState& before, const std::vector<double>& values,
                     double duration) override {
    const CubeTableGaps gaps(cube_.half_width, coefficients(values, split_));
    core::EpisodeOptions options;
    options.gravity = Eigen::Vector3d(0.0, 0.0, kTossGravityZ);
    options.horizon = duration;
    options.max_impacts = kEpisodeImpactCap;
    options.contact_tolerance = kSimultaneous;
    options.solver = options_;
    const core::EpisodeResult result =
        core::computeEpisode({tableBody(), cubeBody(before, cube_)}, gaps, options);
    CubeState end;
    end.position = result.bodies[1].position;
    end.orientation = result.bodies[1].orientation;
    end.linear_velocity = result.bodies[1].linear_velocity;
    end.angular_velocity = result.bodies[1].angular_velocity;
    ++ends_[core::toString(result.end)];
    return flyBallistic(end, std::max(0.0, duration - result.end_time));
  }
};

}  // namespace

std::string landingEnds(LandingModel& model) {
  auto* law = dynamic_cast<LawLanding*>(&model);
  if (law == nullptr) return "";
  std::string text;
  for (const auto& [kind, count] : law->takeEnds())
    text += (text.empty() ? "" : ", ") + std::to_string(count) + " " + kind;
  return text;
}

std::unique_ptr<LandingModel> makeOneImpactLanding(const TossedCube& cube, ImpactLaw law,
                                                   bool split_friction) {
  return std::make_unique<OneImpact>(cube, law, split_friction);
}
std::unique_ptr<LandingModel> makeRepeatedImpactsLanding(const TossedCube& cube, ImpactLaw law,
                                                         bool split_friction) {
  return std::make_unique<RepeatedImpacts>(cube, law, split_friction);
}
std::unique_ptr<LandingModel> makeEpisodeLanding(const TossedCube& cube, ImpactLaw law,
                                                 bool split_friction) {
  return std::make_unique<Episode>(cube, law, split_friction);
}

}  // namespace collision_response::bench
