#include "collision_response/core/episode.h"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>

#include "collision_response/core/compute_response.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/contact_problem.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/free_flight.h"
#include "collision_response/core/islands.h"
#include "collision_response/core/option_ranges.h"
#include "collision_response/core/resting_contact.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/validation.h"

namespace collision_response::core {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// Largest s >= 0 with V s + G s^2 / 2 <= target (the gap a pair can close in s at most).
double safeStep(double speed, double gravity, double target) {
  if (!(speed < kInfinity)) return 0.0;
  if (gravity <= 0.0) return speed > 0.0 ? target / speed : kInfinity;
  return 2.0 * target / (speed + std::sqrt(speed * speed + 2.0 * gravity * target));
}

// Largest s >= 0 with -u s + A s^2 / 2 <= target: how long a gap moving at u (> 0 opening) and
// accelerating towards closing by at most A keeps within `target` of its value now.
double pointStep(double velocity, double acceleration, double target) {
  const double root = std::sqrt(velocity * velocity + 2.0 * acceleration * target);
  if (velocity >= 0.0) return acceleration > 0.0 ? (velocity + root) / acceleration : kInfinity;
  return 2.0 * target / (root - velocity);
}

// One candidate contact of the moment with what the loop needs of it.
struct Candidate {
  int index = 0;                 // into the query's contacts
  double normal_velocity = 0.0;  // u_n [m/s], < 0 approaching
  double threshold = 0.0;        // |u_n| at or below this: resting (rebound height below tolerance)
  double gravity_normal = 0.0;   // g_n [m/s^2]: gravity's relative acceleration into the contact
  double gap = 0.0;              // [m]
  double acceleration = 0.0;     // bound on a point-on-plane gap's closing acceleration [m/s^2]
  int pair = 0;                  // index into pairs_
};

// What the stepping bounds read of one body, refreshed by each query (one vector for all bodies:
// one allocation per episode).
struct BodyBounds {
  double radius = 0.0;           // GapQuery::radius() [m]
  double speed = 0.0;            // |v| + |w|max r [m/s]
  double spin = 0.0;             // |w|max over the flight (angularSpeedBound()) [rad/s]
  double smallest_moment = 0.0;  // smallest principal moment, 0 if isotropic [kg m^2]
  Eigen::Vector3d com = Eigen::Vector3d::Zero();  // world centre of mass [m]
};

// A pair of bodies seen by the query at this moment.
struct Pair {
  int a = 0;
  int b = 0;
  double gap = kInfinity;  // smallest gap of its contacts [m]
  bool points = true;      // every contact a material point on a plane (GapContact::point_on_plane)
};

// The lists an episode fills and refills, kept per thread from one episode to the next (a
// landing then allocates none of them again); every one is cleared or assigned before it is read.
struct EpisodeWorkspace {
  bool in_use = false;
  std::vector<BodyBounds> bounds;
  std::vector<GapContact> gaps;
  std::vector<Candidate> candidates;
  std::vector<Pair> pairs;
  std::vector<int> touching;
  std::vector<int> resting_set;
  Scene scene;
  std::vector<std::pair<int, int>> scene_pairs;
  std::vector<BodyState> before;
  std::vector<RigidBody> rigid;
  std::vector<BodyModel*> models;
  std::vector<ContactPoint> points;
  ContactProblem problem;
  std::vector<ContactImpulse> answer;
};

// Looked up once per episode (solve_islands.cpp says why this is a function).
[[gnu::noinline]] EpisodeWorkspace& threadEpisodeWorkspace() {
  thread_local EpisodeWorkspace workspace;
  return workspace;
}

// The thread's workspace for one episode, or a workspace of its own for an episode that starts
// while another runs on the same thread (a gap query that follows an episode itself).
class WorkspaceLease {
 public:
  WorkspaceLease() : workspace_(&threadEpisodeWorkspace()) {
    if (workspace_->in_use) {
      own_ = std::make_unique<EpisodeWorkspace>();
      workspace_ = own_.get();
    }
    workspace_->in_use = true;
  }
  ~WorkspaceLease() { workspace_->in_use = false; }
  WorkspaceLease(const WorkspaceLease&) = delete;
  WorkspaceLease& operator=(const WorkspaceLease&) = delete;
  EpisodeWorkspace& operator*() const { return *workspace_; }

 private:
  EpisodeWorkspace* workspace_;
  std::unique_ptr<EpisodeWorkspace> own_;
};

class Episode {
 public:
  Episode(const std::vector<BodyState>& bodies, const GapQuery& geometry,
          const EpisodeOptions& options)
      : geometry_(geometry),
        options_(options),
        bodies_(bodies),
        bounds_((*lease_).bounds),
        gaps_((*lease_).gaps),
        candidates_((*lease_).candidates),
        pairs_((*lease_).pairs),
        touching_((*lease_).touching),
        resting_set_((*lease_).resting_set),
        scene_((*lease_).scene),
        scene_pairs_((*lease_).scene_pairs),
        before_((*lease_).before),
        rigid_((*lease_).rigid),
        models_((*lease_).models),
        points_((*lease_).points),
        problem_((*lease_).problem),
        answer_((*lease_).answer) {
    start_ = std::chrono::steady_clock::now();
    for (BodyState& body : bodies_) body.orientation.normalize();
    const std::size_t n = bodies_.size();
    bounds_.assign(n, BodyBounds{});
    // The thread's lists still hold the last episode's moment: emptied (their storage kept), so
    // that an episode ending before its first query (out of time) reads none of it.
    gaps_.clear();
    candidates_.clear();
    pairs_.clear();
    touching_.clear();
    resting_set_.clear();
    for (std::size_t i = 0; i < n; ++i) {
      const BodyState& body = bodies_[i];
      if (!body.immovable() && !isotropicInertia(body.inertia)) {
        bounds_[i].smallest_moment =
            Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(body.inertia, Eigen::EigenvaluesOnly)
                .eigenvalues()(0);
      }
      bounds_[i].radius = geometry_.radius(static_cast<int>(i));
    }
    gravity_norm_ = options_.gravity.norm();
    tolerance_ = options_.contact_tolerance;
    resting_velocity_ = options_.solver.resting_velocity;
  }

  EpisodeResult run();

 private:
  double elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  bool outOfTime() const {
    return elapsed() >= options_.solver.time_budget || options_.solver.deadline.expired();
  }
  void query();
  double step() const;
  void advance(double dt);
  void solve(const std::vector<BodyState>& states, ContactResponse& response);
  bool impact(const std::vector<int>& contacts, bool plastic_resting);
  bool sustained(const std::vector<int>& contacts);
  bool configurationLasts(const std::vector<int>& contacts) const;
  bool othersMayTouch(const std::vector<int>& contacts) const;
  double fastestPairSpeed() const;
  std::pair<int, int> addContact(const GapContact& gap, bool plastic, Contact& contact);
  void finish(EpisodeEnd end);
  void warnOverlaps();

  WorkspaceLease lease_;  // first: the lists below live in it
  const GapQuery& geometry_;
  const EpisodeOptions& options_;
  std::chrono::steady_clock::time_point start_;
  EpisodeResult result_;
  std::vector<BodyState> bodies_;
  std::vector<BodyBounds>& bounds_;  // per body
  double gravity_norm_ = 0.0;
  double tolerance_ = 0.0;
  double resting_velocity_ = 0.0;
  double time_ = 0.0;
  double range_ = 0.0;  // of the last query [m]
  // gaps_ is the geometry's answer at the bodies' poses now, for gaps_range_ (cleared by a move).
  bool gaps_current_ = false;
  double gaps_range_ = 0.0;
  bool gaps_points_ = false;  // every contact of gaps_ a point on a plane

  // The moment's geometry, reused from query to query (and in the thread's next episode).
  std::vector<GapContact>& gaps_;
  std::vector<Candidate>& candidates_;
  std::vector<Pair>& pairs_;
  std::vector<int>& touching_;
  std::vector<int>& resting_set_;
  // Impact and resting workspaces.
  Scene& scene_;
  std::vector<std::pair<int, int>>& scene_pairs_;
  std::vector<BodyState>& before_;
  std::vector<RigidBody>& rigid_;
  std::vector<BodyModel*>& models_;
  std::vector<ContactPoint>& points_;
  ContactProblem& problem_;
  std::vector<ContactImpulse>& answer_;
};

// The contact of a touching gap: its coefficients checked, its record in `contact` (restitution
// 0 if `plastic`), its solver contact appended to points_. Returns its bodies' indices.
std::pair<int, int> Episode::addContact(const GapContact& gap, bool plastic, Contact& contact) {
  validateCoefficients(gap.restitution, gap.static_friction, gap.dynamic_friction, "geometry");
  contact.body_a = bodies_[gap.body_a].id;
  contact.body_b = bodies_[gap.body_b].id;
  contact.point = gap.point;
  contact.normal = gap.normal.normalized();
  contact.restitution = plastic ? 0.0 : gap.restitution;
  contact.static_friction = gap.static_friction;
  contact.dynamic_friction = gap.dynamic_friction;
  points_.emplace_back(gap.body_a, gap.body_b, contact.point, contact.normal, contact.restitution,
                       contact.static_friction, contact.dynamic_friction);
  return {gap.body_a, gap.body_b};
}

// The two largest speed bounds added: how fast any two bodies can close on each other [m/s].
double Episode::fastestPairSpeed() const {
  double fastest = 0.0, second = 0.0;
  for (const BodyBounds& body : bounds_) {
    const double v = body.speed;
    if (v > fastest) {
      second = fastest;
      fastest = v;
    } else if (v > second) {
      second = v;
    }
  }
  return fastest + second;
}

// The contacts of the moment, their normal velocities and thresholds, and the pairs' gaps.
void Episode::query() {
  const std::size_t n = bodies_.size();
  for (std::size_t i = 0; i < n; ++i) {
    const BodyState& body = bodies_[i];
    bounds_[i].com = body.worldCom();
    // angularSpeedBound() with the smallest moment found once.
    double spin = body.angular_velocity.norm();
    if (bounds_[i].smallest_moment > 0.0 && spin > 0.0) {
      const Eigen::Matrix3d R = body.orientation.toRotationMatrix();
      spin = std::max(spin, (R * (body.inertia * (R.transpose() * body.angular_velocity))).norm() /
                                bounds_[i].smallest_moment);
    }
    bounds_[i].spin = spin;
    bounds_[i].speed = body.linear_velocity.norm() + (spin > 0.0 ? spin * bounds_[i].radius : 0.0);
  }
  // Range: what any pair could close before the horizon (then a pair left out cannot touch
  // before it), at least 10 tolerances, at most 1 m or 1e4 tolerances (the query's cost).
  const double remaining = options_.horizon - time_;
  range_ = std::clamp(fastestPairSpeed() * remaining + gravity_norm_ * remaining * remaining,
                      10.0 * tolerance_, std::max(1.0, 1e4 * tolerance_));
  // The geometry's answer depends on the poses and the range only. After an impact (velocities
  // changed, poses not) the last answer stands for a range no larger when it is all material
  // points on planes (GapContact::point_on_plane): a query lists each such point within its range,
  // so those within the smaller range are the points a new query would list.
  const bool reuse =
      gaps_current_ && (range_ == gaps_range_ || (gaps_points_ && range_ < gaps_range_));
  if (!reuse) {
    gaps_.clear();  // (the query clears it too, as GapQuery::gaps() promises)
    geometry_.gaps(bodies_, range_, gaps_);
    gaps_current_ = true;
    gaps_range_ = range_;
    gaps_points_ = std::all_of(gaps_.begin(), gaps_.end(),
                               [](const GapContact& gap) { return gap.point_on_plane; });
  }
  const bool filter = reuse && range_ < gaps_range_;

  candidates_.clear();
  pairs_.clear();
  touching_.clear();
  int last_pair = -1;  // a query lists a pair's contacts together, mostly
  for (std::size_t c = 0; c < gaps_.size(); ++c) {
    const GapContact& gap = gaps_[c];
    if (filter && gap.gap > range_) continue;  // (checked by the query that listed it)
    if (gap.body_a < 0 || gap.body_b < 0 || gap.body_a >= static_cast<int>(n) ||
        gap.body_b >= static_cast<int>(n) || gap.body_a == gap.body_b) {
      throw InvalidInput("geometry", "a contact names bodies " + std::to_string(gap.body_a) +
                                         " and " + std::to_string(gap.body_b) + " of " +
                                         std::to_string(n));
    }
    const BodyState& a = bodies_[gap.body_a];
    const BodyState& b = bodies_[gap.body_b];
    const bool a_fixed = a.immovable(), b_fixed = b.immovable();
    if (a_fixed && b_fixed) continue;
    const double length_squared = gap.normal.squaredNorm();
    // One sum is finite exactly when its terms are (or a term is so large that it overflows:
    // then the terms are checked one by one).
    if (!std::isfinite(gap.gap + gap.point.sum() + length_squared) || !(length_squared > 0.0)) {
      if (!std::isfinite(gap.gap) || !gap.point.allFinite() || !(length_squared > 0.0) ||
          !std::isfinite(gap.normal.norm())) {
        throw InvalidInput("geometry", "a contact with a non-finite gap, point or normal");
      }
    }
    // A unit normal (what queries give) is taken as it is.
    const Eigen::Vector3d normal = length_squared == 1.0
                                       ? gap.normal
                                       : Eigen::Vector3d(gap.normal / std::sqrt(length_squared));
    // Relative velocity of b's point from a's (the cross products of non-turning bodies skipped).
    Eigen::Vector3d u = b.linear_velocity;
    if (bounds_[gap.body_b].spin > 0.0)
      u += b.angular_velocity.cross(gap.point - bounds_[gap.body_b].com);
    u -= a.linear_velocity;
    if (bounds_[gap.body_a].spin > 0.0)
      u -= a.angular_velocity.cross(gap.point - bounds_[gap.body_a].com);
    Candidate& candidate = candidates_.emplace_back();
    candidate.index = static_cast<int>(c);
    candidate.normal_velocity = normal.dot(u);
    // Gravity's relative acceleration of b from a, into the contact (> 0 pushes them together):
    // -n . (g_b - g_a), g_i = g for a movable body, 0 for an immovable one.
    const double gravity_along = normal.dot(options_.gravity);
    candidate.gravity_normal = a_fixed == b_fixed ? 0.0 : a_fixed ? -gravity_along : gravity_along;
    // A rebound at most this high stays within the tolerance: sqrt(2 g_n tol).
    candidate.threshold =
        candidate.gravity_normal > 0.0
            ? std::max(resting_velocity_, std::sqrt(2.0 * candidate.gravity_normal * tolerance_))
            : resting_velocity_;
    if (gap.gap <= tolerance_) touching_.push_back(static_cast<int>(candidates_.size() - 1));

    candidate.gap = gap.gap;
    // A point of b on a's fixed plane: its gap accelerates by n . (g + alpha x r + w x (w x r)),
    // |alpha| <= |w|max^2 for torque-free rotation (0 when isotropic), |r| <= radius(b).
    const bool point_on_plane =
        gap.point_on_plane && a_fixed && !b_fixed && a.angular_velocity.isZero(0.0);
    if (point_on_plane) {
      const double spin = bounds_[gap.body_b].spin;
      const double turning =
          bounds_[gap.body_b].smallest_moment > 0.0 ? 2.0 * spin * spin : spin * spin;
      candidate.acceleration = std::max(0.0, -gravity_along) + turning * bounds_[gap.body_b].radius;
    }
    const int lo = std::min(gap.body_a, gap.body_b), hi = std::max(gap.body_a, gap.body_b);
    if (last_pair < 0 || pairs_[last_pair].a != lo || pairs_[last_pair].b != hi) {
      const auto it = std::find_if(pairs_.begin(), pairs_.end(),
                                   [&](const Pair& p) { return p.a == lo && p.b == hi; });
      last_pair = static_cast<int>(it - pairs_.begin());
      if (it == pairs_.end()) {
        pairs_.push_back({lo, hi, gap.gap, point_on_plane});
      }
    }
    Pair& pair = pairs_[last_pair];
    pair.gap = std::min(pair.gap, gap.gap);
    pair.points = pair.points && point_on_plane;
    candidate.pair = last_pair;
  }
}

// The longest step no pair can close its gap in, to 0 (pairs apart by more than the tolerance)
// or by one tolerance (touching pairs, whose touching contacts do not approach).
double Episode::step() const {
  double s = kInfinity;
  for (const Pair& pair : pairs_) {
    const BodyState& a = bodies_[pair.a];
    const BodyState& b = bodies_[pair.b];
    const double spin_a = bounds_[pair.a].spin, spin_b = bounds_[pair.b].spin;
    const double speed = (a.linear_velocity - b.linear_velocity).norm() +
                         (spin_a > 0.0 ? spin_a * bounds_[pair.a].radius : 0.0) +
                         (spin_b > 0.0 ? spin_b * bounds_[pair.b].radius : 0.0);
    const double gravity = a.immovable() != b.immovable() ? gravity_norm_ : 0.0;
    // Points on a plane: each listed point bounded below; the pair's others are beyond the range.
    const double target = pair.points ? range_
                          : pair.gap > tolerance_
                              ? pair.gap
                              : std::max(tolerance_ + std::min(pair.gap, 0.0), 0.1 * tolerance_);
    s = std::min(s, safeStep(speed, gravity, target));
  }
  for (const Candidate& c : candidates_) {
    if (!pairs_[c.pair].points) continue;
    // A point apart by more than the tolerance may close to 0; a touching one that opens may
    // come back to where it is (not below 0: an impact found late would change its answer); a
    // touching one that neither opens nor approaches may sink by one tolerance.
    // (Down to -tolerance: by one tolerance from a gap >= 0, by less from a gap below 0; a point
    // already near -tolerance, which no step leaves there, by a tenth of one.)
    const double target = c.gap > tolerance_ ? c.gap
                          : c.normal_velocity > 0.0
                              ? std::max(c.gap, 0.0)
                              : std::max(tolerance_ + std::min(c.gap, 0.0), 0.1 * tolerance_);
    s = std::min(s, pointStep(c.normal_velocity, c.acceleration, target));
  }
  // Pairs the query left out are farther apart than the range (a single body has no pair).
  if (bodies_.size() < 2) return s;
  const double fastest_two = fastestPairSpeed();
  return std::min(s, safeStep(fastest_two, 2.0 * gravity_norm_, range_));
}

// The impact of points_ on the bodies in `states` through the island pipeline, under the time
// left: the velocities after it in rigid_ (built from `states`), the impulses and warnings in
// `response`. Throws SolverTimeout when no time is left.
void Episode::solve(const std::vector<BodyState>& states, ContactResponse& response) {
  SolverOptions solver = options_.solver;
  solver.time_budget = options_.solver.time_budget - elapsed();
  if (!(solver.time_budget > 0.0)) throw SolverTimeout("episode");
  solveRigidIslands(states, points_, solver, rigid_, models_, response);
}

void Episode::advance(double dt) {
  for (BodyState& body : bodies_) advanceFreeFlight(body, dt, options_.gravity);
  gaps_current_ = false;
  time_ += dt;
}

// The impact of the touching contacts `contacts` (indices into candidates_) at this time, under
// the contacts' coefficients. Then the contacts it leaves within their resting threshold are
// settled: their rebound (below the tolerance) summed as a geometric series, and the resting
// analysis run. Returns true if the episode ends in sustained contact.
bool Episode::impact(const std::vector<int>& contacts, bool plastic_resting) {
  const std::size_t k = result_.impacts.size();
  std::vector<Contact> listed(contacts.size());  // the record's, moved into it
  points_.clear();
  for (std::size_t i = 0; i < contacts.size(); ++i) {
    addContact(gaps_[candidates_[contacts[i]].index], plastic_resting, listed[i]);
  }
  ContactResponse response;
  solve(bodies_, response);  // the velocities after it in rigid_
  before_ = bodies_;         // the states before the impact
  for (std::size_t i = 0; i < bodies_.size(); ++i) {
    bodies_[i].linear_velocity = rigid_[i].linear_velocity;
    bodies_[i].angular_velocity = rigid_[i].angular_velocity;
  }
  // A slow touch (a pivot the body turns about, through plastic touches) would otherwise sink a
  // little more at each: its deepest point is brought back to the surface (gap 0), the pair's
  // movable bodies moved apart along the normal in inverse proportion to their masses, a move
  // within the contact tolerance.
  if (plastic_resting) {
    for (std::size_t i = 0; i < contacts.size(); ++i) {
      const GapContact& gap = gaps_[candidates_[contacts[i]].index];
      if (!(gap.gap < 0.0)) continue;
      bool deepest = true;  // the pair's first deepest point moves it
      for (std::size_t j = 0; j < contacts.size() && deepest; ++j) {
        const GapContact& other = gaps_[candidates_[contacts[j]].index];
        if (j != i && other.body_a == gap.body_a && other.body_b == gap.body_b) {
          deepest = other.gap > gap.gap || (other.gap == gap.gap && j > i);
        }
      }
      if (!deepest) continue;
      BodyState& a = bodies_[gap.body_a];
      BodyState& b = bodies_[gap.body_b];
      const double wa = a.immovable() ? 0.0 : 1.0 / a.mass, wb = b.immovable() ? 0.0 : 1.0 / b.mass;
      if (!(wa + wb > 0.0)) continue;
      const Eigen::Vector3d shift = -gap.gap * gap.normal.normalized();
      a.position -= wa / (wa + wb) * shift;
      b.position += wb / (wa + wb) * shift;
      gaps_current_ = false;
    }
  }

  // The record takes the answer's impulses and states (read below through it).
  if (result_.impacts.empty()) result_.impacts.reserve(std::min(options_.max_impacts, 8));
  EpisodeImpact& record = result_.impacts.emplace_back();
  record.time = time_;
  record.contacts = std::move(listed);
  record.impulses = std::move(response.impulses);
  record.bodies_after = bodies_;
  const std::vector<ContactImpulse>& impulses = record.impulses;
  // The bodies' own warnings (about the state given) once, with the first impact, before its
  // others; a separating neighbour the detection listed is not a mistake of the caller's.
  if (k == 0) addBodyWarnings(before_, result_.warnings);
  if (!response.warnings.empty()) {
    const std::string prefix = "impacts[" + std::to_string(k) + "].";
    for (Warning& warning : response.warnings) {
      if (warning.kind == Warning::Kind::kSeparating) continue;
      if (warning.kind == Warning::Kind::kInput) {
        if (k > 0) continue;  // about the bodies given: said once
      } else {
        warning.field = prefix + warning.field;
      }
      result_.warnings.push_back(std::move(warning));
    }
  }

  // Contacts left within their resting threshold (rebound height below the tolerance).
  resting_set_.clear();
  for (std::size_t i = 0; i < contacts.size(); ++i) {
    const Candidate& c = candidates_[contacts[i]];
    const ContactImpulse& impulse = impulses[i];
    const double after = impulse.normal_velocity_after;
    if (std::abs(after) > c.threshold) continue;
    // An elastic rebound (ratio 1) never settles: left to bounce on.
    if (after > resting_velocity_ && impulse.normal_velocity_before < 0.0 &&
        after >= (1.0 - 1e-9) * -impulse.normal_velocity_before) {
      continue;
    }
    resting_set_.push_back(static_cast<int>(i));
  }
  if (resting_set_.empty()) return false;

  // Accumulation: a contact rebounding at u (> resting velocity) at a ratio r = u / |u_before| < 1
  // under g_n > 0 bounces on, each flight 2 u r^j / g_n: in all 2 u / (g_n (1 - r)), and
  // log(resting_velocity / u) / log(r) bounces until the rebound is below the resting velocity.
  double duration = 0.0;
  int bounces = 0;
  bool rebound = false;
  for (const int i : resting_set_) {
    const ContactImpulse& impulse = impulses[i];
    const double after = impulse.normal_velocity_after;
    if (!(after > resting_velocity_) || !(impulse.normal_velocity_before < 0.0)) continue;
    rebound = true;
    const Candidate& c = candidates_[contacts[i]];
    const double ratio = after / -impulse.normal_velocity_before;
    if (c.gravity_normal > 0.0)
      duration = std::max(duration, 2.0 * after / (c.gravity_normal * (1.0 - ratio)));
    if (ratio > 0.0) {
      // More than an int holds (infinitely many when resting_velocity is 0): counted as INT_MAX.
      const double count = std::ceil(std::log(resting_velocity_ / after) / std::log(ratio));
      bounces = count < static_cast<double>(std::numeric_limits<int>::max())
                    ? std::max(bounces, static_cast<int>(count))
                    : std::numeric_limits<int>::max();
    }
  }
  const double time_before = time_;
  const int accumulated_before = result_.accumulated_impacts;
  if (rebound) {
    // The series' impulses add up to a plastic impact on these contacts (e = 0) from the state
    // before: solved again so, the other contacts keeping their restitution.
    for (const int i : resting_set_) points_[i].restitution = 0.0;
    ContactResponse settled;
    solve(before_, settled);
    for (std::size_t i = 0; i < bodies_.size(); ++i) {
      bodies_[i].linear_velocity = rigid_[i].linear_velocity;
      bodies_[i].angular_velocity = rigid_[i].angular_velocity;
    }
    result_.accumulated_impacts +=
        std::min(bounces, std::numeric_limits<int>::max() - result_.accumulated_impacts);
    // The bounces last `duration`; the bodies are not moved over it (it is short: a rebound
    // below the tolerance), their sliding along the contact left out.
    time_ += std::min(duration, options_.horizon - time_);
  }
  std::vector<int> set(resting_set_.size());
  for (std::size_t i = 0; i < set.size(); ++i) set[i] = contacts[resting_set_[i]];
  if (sustained(set)) return true;
  // Nothing held: no accumulation, the flight goes on from the impact's own answer.
  bodies_ = result_.impacts.back().bodies_after;
  time_ = time_before;
  result_.accumulated_impacts = accumulated_before;
  return false;
}

// The resting analysis of touching contacts (indices into candidates_) under gravity and the
// bodies' wrenches: true (and the result filled) if it holds some contact closed.
bool Episode::sustained(const std::vector<int>& contacts) {
  const std::size_t n = bodies_.size();
  rigid_.resize(n);
  scene_.bodies = bodies_;
  for (std::size_t i = 0; i < n; ++i) {
    BodyState& state = scene_.bodies[i];
    if (!state.immovable()) state.force += state.mass * options_.gravity;
    rigid_[i] = makeRigidBody(state);
  }
  points_.clear();
  scene_pairs_.clear();
  scene_.contacts.resize(contacts.size());
  for (std::size_t i = 0; i < contacts.size(); ++i) {
    scene_pairs_.push_back(
        addContact(gaps_[candidates_[contacts[i]].index], false, scene_.contacts[i]));
  }
  // Resting here means a normal velocity within the contacts' resting thresholds, sqrt(2 g_n tol)
  // (a rebound that small stays within the tolerance). A slip is another matter: any slip above
  // the solver's resting velocity (round-off) is Coulomb's sliding, friction -mu_d N against it,
  // however slow (a box sliding at 2 cm/s without turning brakes at mu_d g); static friction is
  // tried first only on slips within it (docs/physics.md, "Slow slips").
  double normal_threshold = resting_velocity_;
  for (const int c : contacts) {
    normal_threshold = std::max(normal_threshold, candidates_[c].threshold);
  }
  std::vector<ContactImpulse> forces(contacts.size());
  SolverOptions solver = options_.solver;
  solver.deadline = Deadline::in(std::max(options_.solver.time_budget - elapsed(), 0.0));
  for (const Island& island : findIslands(rigid_, scene_pairs_)) {
    problem_.buildResting(scene_.bodies, rigid_, points_, island.contacts, normal_threshold,
                          resting_velocity_);
    solveRestingIsland(problem_, solver, answer_);
    problem_.scatterForces(answer_, forces);
  }
  double load = 0.0;
  for (const BodyState& state : scene_.bodies) {
    if (!state.immovable()) load += state.force.norm();
  }
  bool holds = false;
  for (const ContactImpulse& f : forces) holds = holds || f.normal_force > 1e-9 * load;
  if (!holds) return false;

  // Accelerations under the resting forces.
  std::vector<Eigen::Vector3d> force(n), torque(n);
  for (std::size_t i = 0; i < n; ++i) {
    force[i] = scene_.bodies[i].force;
    torque[i] = scene_.bodies[i].torque;
  }
  for (std::size_t c = 0; c < forces.size(); ++c) {
    const Eigen::Vector3d f = forces[c].normal_force * points_[c].normal + forces[c].friction_force;
    const auto [a, b] = scene_pairs_[c];
    force[a] -= f;
    torque[a] -= (points_[c].point - rigid_[a].com).cross(f);
    force[b] += f;
    torque[b] += (points_[c].point - rigid_[b].com).cross(f);
  }
  result_.linear_accelerations.assign(n, Eigen::Vector3d::Zero());
  result_.angular_accelerations.assign(n, Eigen::Vector3d::Zero());
  for (std::size_t i = 0; i < n; ++i) {
    const BodyState& state = scene_.bodies[i];
    if (state.immovable()) continue;
    const Eigen::Matrix3d R = state.orientation.toRotationMatrix();
    const Eigen::Vector3d& w = state.angular_velocity;
    const Eigen::Vector3d Iw_w = R * (state.inertia * (R.transpose() * w));
    result_.linear_accelerations[i] = force[i] / state.mass;
    result_.angular_accelerations[i] = rigid_[i].inverse_inertia * (torque[i] - w.cross(Iw_w));
  }
  // The contact set must last: a held body turning or tipping onto another of its features (a
  // cube pivoting on a corner or an edge towards a face) is not in sustained contact but between
  // impacts. Any other listed point of a pair with a held body whose gap, at its normal velocity
  // and its normal acceleration under the resting forces, closes before the horizon, starting to
  // close faster than its resting threshold (or from rest, accelerating towards the contact): the
  // flight goes on (docs/physics.md, "Impact episodes").
  if (!configurationLasts(contacts)) return false;
  // Nor does it end while a body it does not hold may still touch something before the horizon
  // (a ball in flight beside a box at rest): the flight goes on until that body lands too.
  if (othersMayTouch(contacts)) return false;
  // Outcomes: a body with a loaded resting contact slides if one of its contacts slips (slip
  // velocity above the resting velocity, or friction that does not hold), rolls if none slips but
  // it turns (|w| r above the resting velocity), sticks otherwise.
  result_.outcomes.assign(n, BodyOutcome::kSeparated);
  std::vector<char> slips(n, 0), held(n, 0);
  for (std::size_t c = 0; c < forces.size(); ++c) {
    const auto [a, b] = scene_pairs_[c];
    const ContactPoint& p = points_[c];
    const Eigen::Vector3d u = rigid_[b].pointVelocity(p.point - rigid_[b].com) -
                              rigid_[a].pointVelocity(p.point - rigid_[a].com);
    const Eigen::Vector3d u_t = u - u.dot(p.normal) * p.normal;
    bool slipping = u_t.norm() > resting_velocity_;
    if (forces[c].normal_force > 0.0 && !p.frictionless() && !forces[c].sticking) slipping = true;
    if (p.frictionless() && forces[c].normal_force > 0.0) {
      // Nothing holds a frictionless contact: it slips if its points accelerate apart along it.
      const Eigen::Vector3d r_a = p.point - rigid_[a].com, r_b = p.point - rigid_[b].com;
      const auto pointAcceleration = [&](int i, const Eigen::Vector3d& r) {
        const Eigen::Vector3d& w = rigid_[i].angular_velocity;
        return Eigen::Vector3d(result_.linear_accelerations[i] +
                               result_.angular_accelerations[i].cross(r) + w.cross(w.cross(r)));
      };
      const Eigen::Vector3d acc = pointAcceleration(b, r_b) - pointAcceleration(a, r_a);
      const Eigen::Vector3d acc_t = acc - acc.dot(p.normal) * p.normal;
      if (acc_t.norm() > 1e-9 * std::max(gravity_norm_, 1.0)) slipping = true;
    }
    for (const int i : {a, b}) {
      if (bodies_[i].immovable()) continue;
      held[i] = 1;
      if (slipping) slips[i] = 1;
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!held[i]) continue;
    const double turning = bodies_[i].angular_velocity.norm() * bounds_[i].radius;
    result_.outcomes[i] = slips[i]                      ? BodyOutcome::kSliding
                          : turning > resting_velocity_ ? BodyOutcome::kRolling
                                                        : BodyOutcome::kSticking;
  }
  result_.resting_contacts = scene_.contacts;
  result_.resting = std::move(forces);
  return true;
}

bool Episode::othersMayTouch(const std::vector<int>& contacts) const {
  const std::size_t n = bodies_.size();
  std::vector<char> held(n, 0);
  for (const int c : contacts) {
    const GapContact& gap = gaps_[candidates_[c].index];
    held[gap.body_a] = 1;
    held[gap.body_b] = 1;
  }
  bool free_body = false;  // a movable body outside the contact set
  for (std::size_t i = 0; i < n; ++i)
    free_body = free_body || (!held[i] && !bodies_[i].immovable());
  if (!free_body) return false;
  const double remaining = options_.horizon - time_;
  // Listed pairs of which neither body is held: their closing bound, as step() takes it.
  for (const Pair& pair : pairs_) {
    if (held[pair.a] || held[pair.b]) continue;
    const BodyState& a = bodies_[pair.a];
    const BodyState& b = bodies_[pair.b];
    const double speed = (a.linear_velocity - b.linear_velocity).norm() +
                         bounds_[pair.a].spin * bounds_[pair.a].radius +
                         bounds_[pair.b].spin * bounds_[pair.b].radius;
    const double gravity = a.immovable() != b.immovable() ? gravity_norm_ : 0.0;
    if (safeStep(speed, gravity, std::max(pair.gap, 0.0)) < remaining) return true;
  }
  // Pairs the query left out are farther apart than its range.
  const double fastest_two = fastestPairSpeed();
  return safeStep(fastest_two, 2.0 * gravity_norm_, range_) < remaining;
}

bool Episode::configurationLasts(const std::vector<int>& contacts) const {
  const std::size_t n = bodies_.size();
  std::vector<char> held(n, 0);
  for (const int c : contacts) {
    const GapContact& gap = gaps_[candidates_[c].index];
    held[gap.body_a] = !bodies_[gap.body_a].immovable();
    held[gap.body_b] = !bodies_[gap.body_b].immovable();
  }
  const auto pointAcceleration = [&](int i, const Eigen::Vector3d& point) {
    if (bodies_[i].immovable()) return Eigen::Vector3d::Zero().eval();
    const Eigen::Vector3d r = point - rigid_[i].com;
    const Eigen::Vector3d& w = rigid_[i].angular_velocity;
    return Eigen::Vector3d(result_.linear_accelerations[i] +
                           result_.angular_accelerations[i].cross(r) + w.cross(w.cross(r)));
  };
  const double remaining = options_.horizon - time_;
  for (std::size_t k = 0; k < candidates_.size(); ++k) {
    if (std::find(contacts.begin(), contacts.end(), static_cast<int>(k)) != contacts.end())
      continue;
    const Candidate& c = candidates_[k];
    const GapContact& gap = gaps_[c.index];
    if (!held[gap.body_a] && !held[gap.body_b]) continue;
    const Eigen::Vector3d normal = gap.normal.normalized();
    // Its normal velocity now (the candidates' were taken before this moment's impact).
    const auto pointVelocity = [&](int i) {
      return bodies_[i].immovable()
                 ? bodies_[i].linear_velocity +
                       bodies_[i].angular_velocity.cross(gap.point - bounds_[i].com)
                 : rigid_[i].pointVelocity(gap.point - rigid_[i].com);
    };
    const double u = normal.dot(pointVelocity(gap.body_b) - pointVelocity(gap.body_a));
    const double a = normal.dot(pointAcceleration(gap.body_b, gap.point) -
                                pointAcceleration(gap.body_a, gap.point));
    // Closing: approaching faster than its threshold, or accelerating towards the contact (a
    // corner rising as the body rocks comes back down).
    const bool closing = u < -c.threshold || a < -1e-9 * std::max(gravity_norm_, 1.0);
    if (!closing) continue;
    // Time for gap + u t + a t^2 / 2 to reach 0 (the gap's local path), if it does.
    const double g = std::max(c.gap, 0.0);
    double t = kInfinity;
    if (a < 0.0) {
      t = (u + std::sqrt(u * u - 2.0 * a * g)) / -a;
    } else if (u < 0.0) {
      const double disc = u * u - 2.0 * a * g;
      if (disc >= 0.0) t = (-u - std::sqrt(disc)) / std::max(a, 1e-300);
      if (a == 0.0) t = g / -u;
    }
    if (t <= remaining) return false;
  }
  return true;
}

// Bodies that start overlapping by more than the tolerance: followed as touching (their pair
// steps by tolerances while it stays within them, which can take the whole time budget), and
// named once, since the state given is usually a mistake (a pose from another frame, a shape
// too large).
void Episode::warnOverlaps() {
  std::vector<std::pair<int, int>> named;
  for (const Candidate& c : candidates_) {
    const GapContact& gap = gaps_[c.index];
    if (!(gap.gap < -tolerance_)) continue;
    const std::pair<int, int> pair(std::min(gap.body_a, gap.body_b),
                                   std::max(gap.body_a, gap.body_b));
    if (std::find(named.begin(), named.end(), pair) != named.end()) continue;
    named.push_back(pair);
    double deepest = gap.gap;
    for (const Candidate& other : candidates_) {
      const GapContact& o = gaps_[other.index];
      if (std::min(o.body_a, o.body_b) == pair.first && std::max(o.body_a, o.body_b) == pair.second)
        deepest = std::min(deepest, o.gap);
    }
    Warning warning;
    warning.field = "bodies[" + std::to_string(pair.second) + "]";
    warning.reason = "starts overlapping bodies[" + std::to_string(pair.first) + "] by " +
                     std::to_string(-deepest) + " m, more than the contact tolerance (" +
                     std::to_string(tolerance_) +
                     " m): followed as touching, in steps of about the tolerance";
    result_.warnings.push_back(std::move(warning));
  }
}

void Episode::finish(EpisodeEnd end) {
  result_.end = end;
  result_.end_time = time_;
  result_.bodies = bodies_;
  if (end == EpisodeEnd::kSustainedContact) return;  // outcomes set by sustained()
  result_.outcomes.assign(bodies_.size(), BodyOutcome::kSeparated);
  result_.linear_accelerations.clear();
  result_.angular_accelerations.clear();
  if (end == EpisodeEnd::kSeparated) return;
  for (const int t : touching_) {
    const GapContact& gap = gaps_[candidates_[t].index];
    for (const int i : {gap.body_a, gap.body_b}) {
      if (!bodies_[i].immovable()) result_.outcomes[i] = BodyOutcome::kCapped;
    }
  }
}

EpisodeResult Episode::run() {
  bool resting_checked = false;  // a resting analysis of the touching contacts found no load
  for (int iteration = 0;; ++iteration) {
    // The clock every 8 steps (a step costs far less than a clock read; impacts read it too).
    if (iteration % 8 == 0 && outOfTime()) {
      finish(EpisodeEnd::kTimeBudget);
      break;
    }
    query();
    if (iteration == 0) warnOverlaps();
    if (touching_.empty()) resting_checked = false;
    // An impact: a touching contact approaching faster than the resting velocity.
    bool fast = false, slow = false;
    for (const int t : touching_) {
      const Candidate& c = candidates_[t];
      if (c.normal_velocity < -c.threshold) fast = true;
      if (c.normal_velocity < -resting_velocity_) slow = true;
    }
    try {
      if (fast || slow) {
        if (static_cast<int>(result_.impacts.size()) >= options_.max_impacts) {
          finish(EpisodeEnd::kImpactCap);
          break;
        }
        resting_checked = false;
        // Approaching only within the thresholds: a touch whose rebound stays within the
        // tolerance, solved plastic and then analysed at rest.
        if (impact(touching_, !fast)) {
          finish(EpisodeEnd::kSustainedContact);
          break;
        }
        resting_checked = true;
        if (time_ >= options_.horizon) {
          finish(EpisodeEnd::kHorizon);
          break;
        }
        continue;  // the same moment again: what the impact left
      }
      if (!touching_.empty() && !resting_checked) {
        resting_set_.clear();
        for (const int t : touching_) {
          if (std::abs(candidates_[t].normal_velocity) <= resting_velocity_) {
            resting_set_.push_back(t);
          }
        }
        if (!resting_set_.empty()) {
          const std::vector<int> set = resting_set_;
          if (sustained(set)) {
            finish(EpisodeEnd::kSustainedContact);
            break;
          }
        }
        resting_checked = true;
      }
    } catch (const SolverTimeout&) {
      finish(EpisodeEnd::kTimeBudget);
      break;
    }
    const double remaining = options_.horizon - time_;
    const double s = step();
    if (s >= remaining) {
      if (touching_.empty()) {
        finish(EpisodeEnd::kSeparated);  // the bound shows no contact before the horizon
      } else {
        // Touching now (a contact an impact has just left opening, or one at rest): the step
        // bounds every gap to the horizon, so nothing closes on the way. What touches there
        // decides the end: nothing (the bodies flew apart after the impact) is `separated`.
        advance(remaining);
        time_ = options_.horizon;
        query();
        finish(touching_.empty() ? EpisodeEnd::kSeparated : EpisodeEnd::kHorizon);
      }
      break;
    }
    advance(s);
  }
  return std::move(result_);
}

}  // namespace

EpisodeResult computeEpisode(const std::vector<BodyState>& bodies, const GapQuery& geometry,
                             const EpisodeOptions& options) {
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
  const SceneValidator bodies_checked(bodies, 0, options.solver, RequestLimits{});  // or throws
  if (geometry.bodyCount() != static_cast<int>(bodies.size())) {
    throw InvalidInput("geometry", "describes " + std::to_string(geometry.bodyCount()) +
                                       " bodies, " + std::to_string(bodies.size()) + " given");
  }
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    const double radius = geometry.radius(static_cast<int>(i));
    if (std::isnan(radius) || radius < 0.0) {
      throw InvalidInput("geometry", "radius of body " + std::to_string(i) + " is not >= 0");
    }
    if (!std::isfinite(radius) && !bodies[i].immovable()) {
      throw InvalidInput("bodies[" + std::to_string(i) + "]",
                         "is movable but its geometry is unbounded (a plane): only an immovable "
                         "body may have one");
    }
    if (!std::isfinite(radius) && !bodies[i].angular_velocity.isZero(0.0)) {
      throw InvalidInput("bodies[" + std::to_string(i) + "].angular_velocity",
                         "an immovable body of unbounded geometry cannot turn in an episode");
    }
  }
  return Episode(bodies, geometry, options).run();
}

const char* toString(EpisodeEnd end) {
  switch (end) {
    case EpisodeEnd::kSeparated:
      return "separated";
    case EpisodeEnd::kSustainedContact:
      return "sustained_contact";
    case EpisodeEnd::kHorizon:
      return "horizon";
    case EpisodeEnd::kImpactCap:
      return "impact_cap";
    case EpisodeEnd::kTimeBudget:
      return "time_budget";
  }
  return "unknown";
}

const char* toString(BodyOutcome outcome) {
  switch (outcome) {
    case BodyOutcome::kSeparated:
      return "separated";
    case BodyOutcome::kSliding:
      return "sliding";
    case BodyOutcome::kRolling:
      return "rolling";
    case BodyOutcome::kSticking:
      return "sticking";
    case BodyOutcome::kCapped:
      return "capped";
  }
  return "unknown";
}

}  // namespace collision_response::core
