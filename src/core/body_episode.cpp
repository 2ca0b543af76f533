#include "collision_response/core/body_episode.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <tuple>

#include "collision_response/core/body_response.h"
#include "collision_response/core/contact_problem.h"
#include "collision_response/core/contact_space.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/islands.h"
#include "collision_response/core/option_ranges.h"
#include "collision_response/core/resting_contact.h"
#include "collision_response/core/validation.h"

namespace collision_response::core {
namespace {

// The largest and the second largest of x (0 where x has fewer entries), x >= 0.
void twoLargest(const std::vector<double>& x, double& first, double& second) {
  first = second = 0.0;
  for (const double value : x) {
    if (value > first) {
      second = first;
      first = value;
    } else if (value > second) {
      second = value;
    }
  }
}

constexpr double kInfinity = std::numeric_limits<double>::infinity();
// Halvings of a step undone because a pair overlapped after it, before the step is taken anyway
// (a robot pressing into a contact, which a plastic touch does not move back out).
constexpr int kMaxHalvings = 40;

// Largest s >= 0 with V s + A s^2 / 2 <= target.
double safeStep(double speed, double acceleration, double target) {
  if (!(speed < kInfinity) || !(acceleration < kInfinity)) return 0.0;
  if (acceleration <= 0.0) return speed > 0.0 ? target / speed : kInfinity;
  return 2.0 * target / (speed + std::sqrt(speed * speed + 2.0 * acceleration * target));
}

// Largest s >= 0 with -u s + A s^2 / 2 <= target: how long a gap opening at u (< 0 closing) whose
// opening rate falls by at most A per second keeps within `target` of its value now.
double pointStep(double velocity, double acceleration, double target) {
  if (!std::isfinite(velocity) || !(acceleration < kInfinity)) return 0.0;
  const double root = std::sqrt(velocity * velocity + 2.0 * acceleration * target);
  if (velocity >= 0.0) return acceleration > 0.0 ? (velocity + root) / acceleration : kInfinity;
  return 2.0 * target / (root - velocity);
}

struct Touch {
  int gap = 0;                   // index into gaps_
  double normal_velocity = 0.0;  // u_n [m/s], < 0 approaching
  double threshold = 0.0;        // resting threshold [m/s]
};

struct PairGap {
  int a = 0, b = 0;  // geometry bodies, a < b
  double gap = kInfinity;
  // Both convex (GapQuery::convex()): the unit normal of the smallest gap's contact, from a to b.
  bool convex = false;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
};

class BodyEpisode {
 public:
  BodyEpisode(const std::vector<EpisodeBody*>& bodies, const std::vector<EpisodePart>& parts,
              const GapQuery& geometry, const EpisodeOptions& options)
      : bodies_(bodies), parts_(parts), geometry_(geometry), options_(options) {
    start_ = std::chrono::steady_clock::now();
    tolerance_ = options.contact_tolerance;
    resting_velocity_ = options.solver.resting_velocity;
    for (EpisodeBody* body : bodies_) body->setGravity(options.gravity);
    states_.resize(parts_.size());
    radius_.resize(parts_.size());
    for (std::size_t g = 0; g < parts_.size(); ++g) {
      states_[g] = bodies_[parts_[g].body]->partGeometry(parts_[g].part);
      radius_[g] = geometry_.radius(static_cast<int>(g));
    }
    frozen_.assign(bodies_.size(), 0);
    held_.assign(bodies_.size(), 0);
    speed_.resize(parts_.size());
    acceleration_.resize(parts_.size());
    turning_.resize(parts_.size());
    angular_.resize(parts_.size());
    angular_known_.resize(parts_.size());
    reference_velocity_.resize(parts_.size());
    convex_.resize(parts_.size());
    for (std::size_t g = 0; g < parts_.size(); ++g) {
      convex_[g] = geometry_.convex(static_cast<int>(g)) ? 1 : 0;
    }
    models_.resize(bodies_.size());
  }

  BodyEpisodeResult run();

 private:
  double elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  bool outOfTime() const {
    return elapsed() >= options_.solver.time_budget || options_.solver.deadline.expired();
  }
  bool moving(int body) const { return bodies_[body]->movable() && !frozen_[body]; }
  // Kept in its resting contacts: held at rest, held sliding, or immovable and still.
  bool kept(int part) const {
    const int body = parts_[part].body;
    return frozen_[body] || held_[body] || (!bodies_[body]->movable() && speed_[part] == 0.0);
  }
  void releaseHeld();
  void refreshModels();
  void query();
  void bounds();
  double turningAlong(int g, const Eigen::Vector3d& direction) const;
  double pairStep(const PairGap& pair) const;
  double step() const;
  bool advanceChecked(double s);
  ContactPoint contactOf(const GapContact& gap) const;
  void impact(bool plastic);
  bool sustained();
  bool othersMayTouch(const std::vector<char>& held) const;
  void finish(EpisodeEnd end);
  void warnOverlaps();

  const std::vector<EpisodeBody*>& bodies_;
  const std::vector<EpisodePart>& parts_;
  const GapQuery& geometry_;
  const EpisodeOptions& options_;
  std::chrono::steady_clock::time_point start_;
  BodyEpisodeResult result_;
  double tolerance_ = 0.0;
  double resting_velocity_ = 0.0;
  double time_ = 0.0;
  double range_ = 0.0;

  std::vector<BodyState> states_;  // the geometry's bodies (parts), posed now
  std::vector<double> radius_;
  std::vector<double> speed_, acceleration_;  // per part: bounds now
  // Per part: the speed bound's share from turning, V(radius) - V(0) [m/s], and the velocity of
  // its reference point [m/s], world (0 for a body held at rest).
  std::vector<double> turning_;
  std::vector<Eigen::Vector3d> reference_velocity_;
  // Per part: its angular velocity now [rad/s], world, where EpisodeBody::partAngularVelocity()
  // gives it (then its turning along a normal from the geometry's support, not turning_).
  std::vector<Eigen::Vector3d> angular_;
  std::vector<char> angular_known_;
  std::vector<char> convex_;       // per part: GapQuery::convex()
  std::vector<char> frozen_;       // per body: held at rest while others fly
  std::vector<char> held_;         // per body: held sliding (EpisodeBody::hold())
  double held_until_ = kInfinity;  // when the first held body's slip stops [s]
  std::vector<BodyModel*> models_;
  std::vector<GapContact> gaps_;
  std::vector<PairGap> pairs_;
  std::vector<Touch> touching_;
  std::vector<Eigen::VectorXd> saved_;
  ContactProblem problem_;
  std::vector<ContactImpulse> answer_;
};

void BodyEpisode::releaseHeld() {
  held_until_ = kInfinity;
  for (std::size_t i = 0; i < bodies_.size(); ++i) {
    if (held_[i]) bodies_[i]->release();
    held_[i] = 0;
  }
}

void BodyEpisode::refreshModels() {
  for (std::size_t i = 0; i < bodies_.size(); ++i) models_[i] = &bodies_[i]->model();
}

ContactPoint BodyEpisode::contactOf(const GapContact& gap) const {
  const EpisodePart& a = parts_[gap.body_a];
  const EpisodePart& b = parts_[gap.body_b];
  ContactPoint c(a.body, b.body, gap.point, gap.normal.normalized(), gap.restitution,
                 gap.static_friction, gap.dynamic_friction);
  c.part_a = bodies_[a.body]->partCount() > 1 ? a.part : -1;
  c.part_b = bodies_[b.body]->partCount() > 1 ? b.part : -1;
  return c;
}

// Each part's speed and acceleration bounds now (0 for a body held at rest), and its reference
// point's velocity (the parts posed now).
void BodyEpisode::bounds() {
  for (std::size_t g = 0; g < parts_.size(); ++g) {
    const EpisodePart& p = parts_[g];
    const EpisodeBody& body = *bodies_[p.body];
    const double r = std::isfinite(radius_[g]) ? radius_[g] : 0.0;
    speed_[g] = frozen_[p.body] ? 0.0 : body.partSpeedBound(p.part, r);
    acceleration_[g] = frozen_[p.body] ? 0.0 : body.partAccelerationBound(p.part, r);
    turning_[g] = 0.0;
    reference_velocity_[g].setZero();
    angular_[g].setZero();
    angular_known_[g] = 1;
    if (frozen_[p.body] || !convex_[g]) continue;
    angular_known_[g] = body.partAngularVelocity(p.part, angular_[g]) ? 1 : 0;
    turning_[g] = std::max(speed_[g] - body.partSpeedBound(p.part, 0.0), 0.0);
    const BodyState& s = states_[g];
    const int part = body.partCount() > 1 ? p.part : -1;
    reference_velocity_[g] =
        models_[p.body]->partPointVelocity(part, s.position + s.orientation * s.com);
  }
}

// The parts posed now, their gaps within the range, the pairs' smallest gaps and the touching
// contacts with their normal velocities and resting thresholds.
void BodyEpisode::query() {
  refreshModels();
  for (std::size_t g = 0; g < parts_.size(); ++g) {
    bodies_[parts_[g].body]->partPose(parts_[g].part, states_[g]);
  }
  bounds();
  double v1, v2, a1, a2;
  twoLargest(speed_, v1, v2);
  twoLargest(acceleration_, a1, a2);
  const double remaining = options_.horizon - time_;
  range_ = std::clamp((v1 + v2) * remaining + 0.5 * (a1 + a2) * remaining * remaining,
                      10.0 * tolerance_, std::max(1.0, 1e4 * tolerance_));
  geometry_.gaps(states_, range_, gaps_);
  pairs_.clear();
  touching_.clear();
  const int n = static_cast<int>(parts_.size());
  for (std::size_t c = 0; c < gaps_.size(); ++c) {
    const GapContact& gap = gaps_[c];
    if (gap.body_a < 0 || gap.body_b < 0 || gap.body_a >= n || gap.body_b >= n ||
        gap.body_a == gap.body_b) {
      throw InvalidInput("geometry", "a contact names bodies " + std::to_string(gap.body_a) +
                                         " and " + std::to_string(gap.body_b) + " of " +
                                         std::to_string(n));
    }
    const int body_a = parts_[gap.body_a].body, body_b = parts_[gap.body_b].body;
    if (body_a == body_b) continue;  // a body's parts against each other: not followed
    if (!bodies_[body_a]->movable() && !bodies_[body_b]->movable()) continue;
    const double length = gap.normal.norm();
    if (!std::isfinite(gap.gap) || !gap.point.allFinite() || !(length > 0.0) ||
        !std::isfinite(length)) {
      throw InvalidInput("geometry", "a contact with a non-finite gap, point or normal");
    }
    const int lo = std::min(gap.body_a, gap.body_b), hi = std::max(gap.body_a, gap.body_b);
    auto it = std::find_if(pairs_.begin(), pairs_.end(),
                           [&](const PairGap& p) { return p.a == lo && p.b == hi; });
    const Eigen::Vector3d unit = (gap.body_a == lo ? 1.0 : -1.0) * gap.normal / length;
    if (it == pairs_.end()) {
      pairs_.push_back({lo, hi, gap.gap, convex_[lo] && convex_[hi], unit});
    } else if (gap.gap < it->gap) {
      it->gap = gap.gap;
      it->normal = unit;
    }
    if (gap.gap > tolerance_) continue;
    const EpisodePart& pa = parts_[gap.body_a];
    const EpisodePart& pb = parts_[gap.body_b];
    const Eigen::Vector3d normal = gap.normal / length;
    Touch& touch = touching_.emplace_back();
    touch.gap = static_cast<int>(c);
    const int part_a = bodies_[body_a]->partCount() > 1 ? pa.part : -1;
    const int part_b = bodies_[body_b]->partCount() > 1 ? pb.part : -1;
    touch.normal_velocity = normal.dot(models_[body_b]->partPointVelocity(part_b, gap.point) -
                                       models_[body_a]->partPointVelocity(part_a, gap.point));
    // The relative free acceleration into the contact (gravity, a robot's loads): a rebound at
    // most sqrt(2 g_n tol) stays within the tolerance.
    const double g_n = -normal.dot(models_[body_b]->partPointFreeAcceleration(part_b, gap.point) -
                                   models_[body_a]->partPointFreeAcceleration(part_a, gap.point));
    touch.threshold = std::max(resting_velocity_, std::sqrt(2.0 * std::max(g_n, 0.0) * tolerance_));
  }
}

// The longest step a pair cannot close in: to 0 from apart, by about a tolerance when touching.
// A convex pair also by its gap's rate along the normal: the plane normal to n through the closest
// points separates the two by the gap, and over a span s each point of b moves along n by at least
// (n . v_ref,b - W_b) s - A_b s^2 / 2 (v_ref its part's reference point's velocity now, W its
// turning share of the speed bound, A its acceleration bound), each point of a by at most the
// like; so the gap stays above gap + (u - W_a - W_b) s - (A_a + A_b) s^2 / 2, u the reference
// points' relative velocity along n. Whichever bound allows the longer step holds.
// How fast turning can move part g's points along `direction` (unit, world) relative to its
// reference point now: the largest (w x rho) . direction = rho . (direction x w) over its points
// rho (GapQuery::support()), or the turning share of its speed bound.
double BodyEpisode::turningAlong(int g, const Eigen::Vector3d& direction) const {
  if (!angular_known_[g]) return turning_[g];
  const Eigen::Vector3d m = direction.cross(angular_[g]);
  if (m.isZero(0.0)) return 0.0;
  const double h = geometry_.support(g, states_[g].orientation.conjugate() * m);
  return std::isfinite(h) ? h : turning_[g];
}

double BodyEpisode::pairStep(const PairGap& pair) const {
  const double speed = speed_[pair.a] + speed_[pair.b];
  const double acceleration = acceleration_[pair.a] + acceleration_[pair.b];
  if (speed == 0.0 && acceleration == 0.0) return kInfinity;
  const double target = pair.gap > tolerance_
                            ? pair.gap
                            : std::max(tolerance_ + std::min(pair.gap, 0.0), 0.1 * tolerance_);
  const double s = safeStep(speed, acceleration, target);
  // Only for a pair apart that opens: one that closes is stepped as before (where its impacts are
  // found), and so is a touching one (steps of about a tolerance: where a pair opening between two
  // bounces is stepped decides where within the tolerance the next bounce is found).
  if (!pair.convex || !(pair.gap > tolerance_)) return s;
  const double opening =
      pair.normal.dot(reference_velocity_[pair.b] - reference_velocity_[pair.a]) -
      turningAlong(pair.a, pair.normal) - turningAlong(pair.b, -pair.normal);
  if (!(opening > 0.0)) return s;
  return std::max(s, pointStep(opening, acceleration, pair.gap));
}

double BodyEpisode::step() const {
  double s = kInfinity;
  for (const PairGap& pair : pairs_) {
    // Two sides kept in their resting contacts: the resting forces keep the contacts between them
    // closed.
    if (kept(pair.a) && kept(pair.b)) continue;
    s = std::min(s, pairStep(pair));
  }
  // Pairs the query left out are farther apart than the range: the two fastest parts.
  double v1, v2, a1, a2;
  twoLargest(speed_, v1, v2);
  twoLargest(acceleration_, a1, a2);
  if (parts_.size() >= 2) s = std::min(s, safeStep(v1 + v2, a1 + a2, range_));
  for (std::size_t i = 0; i < bodies_.size(); ++i) {
    if (moving(static_cast<int>(i))) s = std::min(s, bodies_[i]->stepLimit());
  }
  return s;
}

// Advances the moving bodies by s, halving it (from the saved states) while a pair that was apart
// overlaps after it, or a touching pair sinks below -tolerance. Leaves the moment queried.
bool BodyEpisode::advanceChecked(double s) {
  const std::vector<PairGap> before = pairs_;
  saved_.resize(bodies_.size());
  for (std::size_t i = 0; i < bodies_.size(); ++i) bodies_[i]->saveState(saved_[i]);
  for (int halving = 0;; ++halving) {
    for (std::size_t i = 0; i < bodies_.size(); ++i) {
      if (moving(static_cast<int>(i)) || (!bodies_[i]->movable())) bodies_[i]->advance(s);
    }
    ++result_.steps;
    query();
    bool overlap = false;
    for (const PairGap& pair : pairs_) {
      double prior = kInfinity;
      for (const PairGap& p : before) {
        if (p.a == pair.a && p.b == pair.b) prior = p.gap;
      }
      if ((prior > tolerance_ && pair.gap < 0.0) ||
          (prior >= -tolerance_ && pair.gap < -tolerance_)) {
        overlap = true;
        break;
      }
    }
    if (!overlap || halving >= kMaxHalvings) {
      time_ += s;
      return true;
    }
    for (std::size_t i = 0; i < bodies_.size(); ++i) bodies_[i]->restoreState(saved_[i]);
    s *= 0.5;
  }
}

void BodyEpisode::impact(bool plastic) {
  const std::size_t k = result_.impacts.size();
  std::vector<ContactPoint> contacts;
  contacts.reserve(touching_.size());
  for (const Touch& t : touching_) {
    const GapContact& gap = gaps_[t.gap];
    validateCoefficients(gap.restitution, gap.static_friction, gap.dynamic_friction, "geometry");
    ContactPoint c = contactOf(gap);
    // A touch approaching within its resting threshold rebounds within the tolerance: plastic.
    if (plastic || t.normal_velocity >= -t.threshold) c.restitution = 0.0;
    contacts.push_back(c);
  }
  SolverOptions solver = options_.solver;
  solver.time_budget = options_.solver.time_budget - elapsed();
  if (!(solver.time_budget > 0.0)) throw SolverTimeout("episode");
  BodyResponse response = computeBodyResponse(models_, contacts, solver);
  std::fill(frozen_.begin(), frozen_.end(), 0);
  releaseHeld();
  for (EpisodeBody* body : bodies_) body->syncFromModel();
  // A plastic touch's depth taken back out: the deepest point of each pair brought to the
  // surface, the pair's rigid body moved along the normal (a robot is not moved).
  if (plastic) {
    for (std::size_t i = 0; i < touching_.size(); ++i) {
      const GapContact& gap = gaps_[touching_[i].gap];
      if (!(gap.gap < 0.0)) continue;
      bool deepest = true;
      for (std::size_t j = 0; j < touching_.size() && deepest; ++j) {
        const GapContact& o = gaps_[touching_[j].gap];
        if (j != i && o.body_a == gap.body_a && o.body_b == gap.body_b)
          deepest = o.gap > gap.gap || (o.gap == gap.gap && j > i);
      }
      if (!deepest) continue;
      const Eigen::Vector3d shift = -gap.gap * gap.normal.normalized();
      if (!bodies_[parts_[gap.body_b].body]->translate(shift))
        bodies_[parts_[gap.body_a].body]->translate(-shift);
    }
  }
  BodyEpisodeImpact& record = result_.impacts.emplace_back();
  record.time = time_;
  record.contacts = std::move(contacts);
  record.impulses = response.impulses;
  record.velocities_after.reserve(bodies_.size());
  for (BodyModel* model : models_) record.velocities_after.push_back(model->velocity());
  record.states_after.resize(bodies_.size());
  for (std::size_t i = 0; i < bodies_.size(); ++i) bodies_[i]->saveState(record.states_after[i]);
  const std::string prefix = "impacts[" + std::to_string(k) + "].";
  for (Warning& warning : response.warnings) {
    if (warning.kind == Warning::Kind::kSeparating) continue;
    if (warning.kind == Warning::Kind::kInput) {
      if (k > 0) continue;
    } else {
      warning.field = prefix + warning.field;
    }
    result_.warnings.push_back(std::move(warning));
  }
}

bool BodyEpisode::othersMayTouch(const std::vector<char>& held) const {
  const double remaining = options_.horizon - time_;
  bool free_body = false;
  double v1 = 0.0, v2 = 0.0, a1 = 0.0;
  for (std::size_t g = 0; g < parts_.size(); ++g) {
    const int body = parts_[g].body;
    if (held[body] || !bodies_[body]->movable()) continue;
    free_body = true;
    if (speed_[g] > v1) {
      v2 = v1;
      v1 = speed_[g];
    } else if (speed_[g] > v2) {
      v2 = speed_[g];
    }
    a1 = std::max(a1, acceleration_[g]);
  }
  if (!free_body) return false;
  // The bounds hold within each free body's step limit only.
  for (std::size_t i = 0; i < bodies_.size(); ++i) {
    if (!held[i] && moving(static_cast<int>(i)) && bodies_[i]->stepLimit() < remaining) return true;
  }
  for (const PairGap& pair : pairs_) {
    const int a = parts_[pair.a].body, b = parts_[pair.b].body;
    const bool free_a = !held[a] && bodies_[a]->movable();
    const bool free_b = !held[b] && bodies_[b]->movable();
    if (!free_a && !free_b) continue;
    PairGap apart = pair;
    apart.gap = std::max(pair.gap, tolerance_ * (1.0 + 1e-9));
    // A free part touching already (gap within the tolerance) may touch at once.
    if (pair.gap <= tolerance_) return true;
    if (pairStep(apart) < remaining) return true;
  }
  // Pairs left out: a free part and any other, together at most this fast.
  double fastest = 0.0, fastest_acceleration = 0.0;
  for (std::size_t g = 0; g < parts_.size(); ++g) {
    fastest = std::max(fastest, speed_[g]);
    fastest_acceleration = std::max(fastest_acceleration, acceleration_[g]);
  }
  return safeStep(v1 + fastest, a1 + fastest_acceleration, range_) < remaining;
}

// The resting analysis of the touching contacts: true if it holds them closed and nothing else
// can reach a body before the horizon (then the result is filled). Bodies held at rest are kept
// still while the others fly.
bool BodyEpisode::sustained() {
  releaseHeld();
  std::vector<ContactPoint> contacts;
  std::vector<std::pair<int, int>> pairs;
  for (const Touch& t : touching_) {
    const GapContact& gap = gaps_[t.gap];
    validateCoefficients(gap.restitution, gap.static_friction, gap.dynamic_friction, "geometry");
    contacts.push_back(contactOf(gap));
    pairs.emplace_back(contacts.back().body_a, contacts.back().body_b);
  }
  // Normal velocities within the thresholds count as resting (a rebound that small stays within
  // the tolerance), and so does a body whose every point moves within them. A slip above the
  // solver's resting velocity (round-off) is Coulomb's sliding, friction -mu_d N against it,
  // however slow (docs/physics.md, "Slow slips").
  double resting_threshold = resting_velocity_;
  for (const Touch& t : touching_) resting_threshold = std::max(resting_threshold, t.threshold);
  SolverOptions solver = options_.solver;
  solver.resting_velocity = resting_threshold;
  solver.time_budget = options_.solver.time_budget - elapsed();
  if (!(solver.time_budget > 0.0)) throw SolverTimeout("episode");
  // The resting problem of each island (no impulse: the models are not changed).
  BodyResponse response;
  response.impulses.assign(contacts.size(), ContactImpulse());
  std::vector<const BodyModel*> models(models_.begin(), models_.end());
  solver.deadline = Deadline::in(solver.time_budget);
  for (const Island& island : findIslands(models_, pairs)) {
    problem_.buildResting(models, contacts, island.contacts, resting_threshold, resting_velocity_);
    solveRestingIsland(problem_, solver, answer_);
    problem_.scatterForces(answer_, response.impulses);
  }
  double total = 0.0;
  for (const ContactImpulse& f : response.impulses) total += std::max(f.normal_force, 0.0);
  if (!(total > 0.0)) return false;
  const std::size_t n = bodies_.size();
  std::vector<char> held(n, 0), slips(n, 0);
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const ContactImpulse& f = response.impulses[c];
    if (!(f.normal_force > 1e-9 * total)) continue;
    const ContactPoint& p = contacts[c];
    const Eigen::Vector3d u = models_[p.body_b]->partPointVelocity(p.part_b, p.point) -
                              models_[p.body_a]->partPointVelocity(p.part_a, p.point);
    const bool slipping = (u - u.dot(p.normal) * p.normal).norm() > resting_velocity_ ||
                          (!p.frictionless() && !f.sticking) || p.frictionless();
    for (const int i : {p.body_a, p.body_b}) {
      if (!bodies_[i]->movable()) continue;
      held[i] = 1;
      if (slipping) slips[i] = 1;
    }
  }
  const auto atRest = [&](int i) {
    for (std::size_t g = 0; g < parts_.size(); ++g) {
      if (parts_[g].body != i) continue;
      const double r = std::isfinite(radius_[g]) ? radius_[g] : 0.0;
      if (bodies_[i]->partSpeedBound(parts_[g].part, r) > resting_threshold) return false;
    }
    return true;
  };
  if (othersMayTouch(held)) {
    // Held, not slipping and at rest: kept still while the others fly. Held and moving, not tilting
    // beyond the thresholds: moved on under the contact forces' wrench (EpisodeBody::hold()), the
    // analysis redone where its slip or spin would stop (or it has turned too far to keep the
    // forces), at the next impact, or when nothing touches.
    // Each body's contact force and its moment about the world origin (EpisodeBody::hold()).
    std::vector<Eigen::Vector3d> force(n, Eigen::Vector3d::Zero());
    std::vector<Eigen::Vector3d> torque(n, Eigen::Vector3d::Zero());
    for (std::size_t c = 0; c < contacts.size(); ++c) {
      const ContactImpulse& f = response.impulses[c];
      const Eigen::Vector3d F = f.normal_force * contacts[c].normal + f.friction_force;
      const Eigen::Vector3d moment = contacts[c].point.cross(F);
      force[contacts[c].body_a] -= F;
      force[contacts[c].body_b] += F;
      torque[contacts[c].body_a] -= moment;
      torque[contacts[c].body_b] += moment;
    }
    // Per body: how fast its turning moves its points within its radius along its loaded contacts'
    // normals (|w x n| r for a rigid body: its spin about axes across a normal). A body turning so
    // tilts or rolls off its contact set, which a hold does not follow; one spinning about the
    // normals only (a box turning flat on a table) keeps its contacts and is held.
    std::vector<double> tilting(n, 0.0);
    for (std::size_t c = 0; c < contacts.size(); ++c) {
      if (!(response.impulses[c].normal_force > 1e-9 * total)) continue;
      const ContactPoint& p = contacts[c];
      const GapContact& gap = gaps_[touching_[c].gap];
      Eigen::Vector3d t1, t2;
      tangentBasis(p.normal, t1, t2);
      for (const auto& [i, part, g] : {std::tuple(p.body_a, p.part_a, gap.body_a),
                                       std::tuple(p.body_b, p.part_b, gap.body_b)}) {
        if (!bodies_[i]->movable()) continue;
        const double r = std::isfinite(radius_[g]) ? radius_[g] : 0.0;
        const BodyModel& model = *models_[i];
        const Eigen::Vector3d u = model.partPointVelocity(part, p.point);
        const double along1 = p.normal.dot(model.partPointVelocity(part, p.point + r * t1) - u);
        const double along2 = p.normal.dot(model.partPointVelocity(part, p.point + r * t2) - u);
        tilting[i] = std::max(tilting[i], std::hypot(along1, along2));
      }
    }
    for (std::size_t i = 0; i < n; ++i) {
      if (!held[i]) continue;
      if (!slips[i] && atRest(static_cast<int>(i))) {
        BodyModel& model = *models_[i];
        if (model.velocityCount() > 0) model.addVelocityChange(-model.velocity());
        bodies_[i]->syncFromModel();
        frozen_[i] = 1;
        continue;
      }
      if (tilting[i] <= resting_threshold && bodies_[i]->hold(force[i], torque[i])) {
        held_[i] = 1;
        held_until_ = std::min(held_until_, time_ + bodies_[i]->stepLimit());
      }
    }
    return false;
  }
  result_.outcomes.assign(n, BodyOutcome::kSeparated);
  for (std::size_t i = 0; i < n; ++i) {
    if (!held[i]) continue;
    result_.outcomes[i] = slips[i]                       ? BodyOutcome::kSliding
                          : !atRest(static_cast<int>(i)) ? BodyOutcome::kRolling
                                                         : BodyOutcome::kSticking;
  }
  result_.resting_contacts = std::move(contacts);
  result_.resting = response.impulses;
  return true;
}

void BodyEpisode::warnOverlaps() {
  std::vector<std::pair<int, int>> named;
  for (const Touch& t : touching_) {
    const GapContact& gap = gaps_[t.gap];
    if (!(gap.gap < -tolerance_)) continue;
    const std::pair<int, int> pair(std::min(gap.body_a, gap.body_b),
                                   std::max(gap.body_a, gap.body_b));
    if (std::find(named.begin(), named.end(), pair) != named.end()) continue;
    named.push_back(pair);
    Warning warning;
    const EpisodePart& a = parts_[pair.first];
    const EpisodePart& b = parts_[pair.second];
    warning.field = "bodies[" + std::to_string(b.body) + "]";
    warning.reason = "(part " + std::to_string(b.part) + ") starts overlapping bodies[" +
                     std::to_string(a.body) + "] (part " + std::to_string(a.part) + ") by " +
                     std::to_string(-gap.gap) + " m or more, beyond the contact tolerance (" +
                     std::to_string(tolerance_) + " m): followed as touching";
    result_.warnings.push_back(std::move(warning));
  }
}

void BodyEpisode::finish(EpisodeEnd end) {
  releaseHeld();  // the bodies leave the episode under their own loads
  result_.end = end;
  result_.end_time = time_;
  if (end == EpisodeEnd::kSustainedContact) return;
  result_.outcomes.assign(bodies_.size(), BodyOutcome::kSeparated);
  if (end == EpisodeEnd::kSeparated) return;
  for (const Touch& t : touching_) {
    const GapContact& gap = gaps_[t.gap];
    for (const int g : {gap.body_a, gap.body_b}) {
      const int i = parts_[g].body;
      if (bodies_[i]->movable()) result_.outcomes[i] = BodyOutcome::kCapped;
    }
  }
}

BodyEpisodeResult BodyEpisode::run() {
  bool resting_checked = false;
  bool queried = false;
  for (int iteration = 0;; ++iteration) {
    if (iteration % 8 == 0 && outOfTime()) {
      finish(EpisodeEnd::kTimeBudget);
      break;
    }
    if (!queried) query();
    queried = false;
    if (iteration == 0) warnOverlaps();
    if (touching_.empty()) {
      resting_checked = false;
      releaseHeld();
      std::fill(frozen_.begin(), frozen_.end(), 0);
    }
    bool fast = false, slow = false;
    for (const Touch& t : touching_) {
      if (t.normal_velocity < -t.threshold) fast = true;
      if (t.normal_velocity < -resting_velocity_) slow = true;
    }
    try {
      if (fast || slow) {
        if (static_cast<int>(result_.impacts.size()) >= options_.max_impacts) {
          finish(EpisodeEnd::kImpactCap);
          break;
        }
        impact(!fast);
        resting_checked = false;
        continue;  // the same moment again: what the impact left
      }
      if (!touching_.empty() && !resting_checked) {
        resting_checked = true;
        if (sustained()) {
          finish(EpisodeEnd::kSustainedContact);
          break;
        }
        bounds();  // bodies held at rest no longer move
      }
    } catch (const SolverTimeout&) {
      finish(EpisodeEnd::kTimeBudget);
      break;
    }
    const double remaining = options_.horizon - time_;
    const double s = step();
    if (s >= remaining) {
      if (touching_.empty()) {
        finish(EpisodeEnd::kSeparated);
      } else {
        for (std::size_t i = 0; i < bodies_.size(); ++i) {
          if (moving(static_cast<int>(i)) || !bodies_[i]->movable()) bodies_[i]->advance(remaining);
        }
        time_ = options_.horizon;
        query();
        // Nothing touching there: the bodies flew apart over the last step (as the rigid
        // episode's end, docs/physics.md "Ends").
        finish(touching_.empty() ? EpisodeEnd::kSeparated : EpisodeEnd::kHorizon);
      }
      break;
    }
    advanceChecked(s);
    queried = true;
    // Bodies held sliding: their resting analysis redone when one's slip would stop (the step
    // limit it set), where the friction it feels changes.
    // (Within rounding: the last step ends where the slip stops, up to an ulp or so.)
    if (time_ >= held_until_ - 1e-12 * std::max(1.0, held_until_)) resting_checked = false;
  }
  return std::move(result_);
}

}  // namespace

BodyEpisodeResult computeBodyEpisode(const std::vector<EpisodeBody*>& bodies,
                                     const std::vector<EpisodePart>& parts,
                                     const GapQuery& geometry, const EpisodeOptions& options) {
  if (!options.gravity.allFinite() || options.gravity.norm() > MagnitudeLimits::kAcceleration) {
    throw InvalidInput("gravity", "must be finite and at most 1e9 m/s^2");
  }
  if (!std::isfinite(options.horizon) || !(options.horizon > 0.0)) {
    throw InvalidInput("horizon", "must be finite and > 0 s");
  }
  if (options.max_impacts < 1) throw InvalidInput("max_impacts", "must be >= 1");
  if (!std::isfinite(options.contact_tolerance) || !(options.contact_tolerance > 0.0) ||
      options.contact_tolerance > option_ranges::kContactTolerance.max) {
    throw InvalidInput("contact_tolerance", "must be finite, > 0 and at most 1 m (" +
                                                std::to_string(options.contact_tolerance) + ")");
  }
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    if (bodies[i] == nullptr) throw InvalidInput("bodies[" + std::to_string(i) + "]", "is null");
  }
  if (geometry.bodyCount() != static_cast<int>(parts.size())) {
    throw InvalidInput("geometry", "describes " + std::to_string(geometry.bodyCount()) +
                                       " bodies, " + std::to_string(parts.size()) + " parts given");
  }
  for (std::size_t g = 0; g < parts.size(); ++g) {
    const EpisodePart& p = parts[g];
    if (p.body < 0 || p.body >= static_cast<int>(bodies.size()) || p.part < 0 ||
        p.part >= bodies[p.body]->partCount()) {
      throw InvalidInput("parts[" + std::to_string(g) + "]",
                         "names body " + std::to_string(p.body) + " part " +
                             std::to_string(p.part) + ", which does not exist");
    }
    const double radius = geometry.radius(static_cast<int>(g));
    if (std::isnan(radius) || radius < 0.0) {
      throw InvalidInput("geometry", "radius of body " + std::to_string(g) + " is not >= 0");
    }
    if (!std::isfinite(radius) && bodies[p.body]->movable()) {
      throw InvalidInput("bodies[" + std::to_string(p.body) + "]",
                         "moves but the geometry of its part " + std::to_string(p.part) +
                             " is unbounded (a plane): only an immovable body may have one");
    }
  }
  return BodyEpisode(bodies, parts, geometry, options).run();
}

}  // namespace collision_response::core
