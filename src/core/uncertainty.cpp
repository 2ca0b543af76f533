#include "collision_response/core/uncertainty.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <initializer_list>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <tuple>
#include <utility>

#include "collision_response/core/body_impact_derivatives.h"
#include "collision_response/core/body_response.h"
#include "collision_response/core/compute_response.h"
#include "collision_response/core/constants.h"
#include "collision_response/core/contact_derivatives.h"
#include "collision_response/core/contact_space.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/exact_solver.h"
#include "collision_response/core/halton_sequence.h"
#include "collision_response/core/impact_derivatives.h"
#include "collision_response/core/percent_text.h"
#include "collision_response/core/standard_normal.h"
#include "collision_response/core/validation.h"

namespace collision_response::core {

const char* toString(UncertaintyMethod method) {
  switch (method) {
    case UncertaintyMethod::kNone:
      return "none";
    case UncertaintyMethod::kLinear:
      return "linear";
    case UncertaintyMethod::kSampled:
      return "sampled";
  }
  return "unknown";
}

namespace {

constexpr double kZ95 = 1.6448536269514722;              // Phi^-1(0.95)
constexpr double kMaxNormalStdDev = 1.5707963267948966;  // pi/2 [rad]
// A linear stick probability in [this, 1 - this] is reported: the spread reaches a switch.
constexpr double kSwitchReachWarning = 1e-3;
constexpr std::array<const char*, 3> kCoefficientNames = {"restitution", "static_friction",
                                                          "dynamic_friction"};
enum Coefficient { kRestitution = 0, kStaticFriction = 1, kDynamicFriction = 2 };

// The coefficients of one contact named by the request's uncertainties: each with its
// distribution (a fixed one, min = max, for those without), and its sampling dimension (-1: fixed).
struct UncertainContact {
  std::size_t contact = 0;
  std::size_t entry = 0;  // k of uncertainties[k]
  std::array<CheckedDistribution, 3> distributions;
  std::array<int, 3> dimension = {-1, -1, -1};
  // The uncertain geometry (ContactUncertainty): the mean normal n with its tangent basis, the
  // mean point, their spreads, and their sampling dimensions counted from the first one after
  // the coefficients' (Prepared::dimensions.size()); -1: exact.
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d tangent1 = Eigen::Vector3d::UnitX();
  Eigen::Vector3d tangent2 = Eigen::Vector3d::UnitY();
  double normal_std_dev = 0.0;
  int normal_dimension = -1;  // a's; b's is the next one
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d point_std_dev = Eigen::Vector3d::Zero();
  std::array<int, 3> point_dimension = {-1, -1, -1};
};

// A sample's normal and point of one uncertain contact.
struct DrawnGeometry {
  Eigen::Vector3d normal;
  Eigen::Vector3d point;
};

// One dimension of an uncertain normal or point: the contact (index in Prepared::contacts) and
// what it moves: the normal's tilt along tangent1 (kTilt1) or tangent2 (kTilt2), or the point
// along the request frame's x, y or z (kPointX + axis).
struct GeometryDimension {
  enum Kind { kTilt1 = 0, kTilt2 = 1, kPointX = 2 };
  std::size_t index = 0;
  int kind = kTilt1;
  double std_dev = 0.0;  // [rad] or [m]
};

// Prepared's two lists in storage kept per thread: a Prepared takes the thread's lists (by swap)
// and gives them back, cleared with their capacity kept, when it is destroyed, so that a request
// prepares its uncertainties without allocating them when the thread's last request had as many.
// Any number of Prepared may be alive at once: one made while another holds the lists takes the
// empty ones left in their place, and the swaps back keep every list whole.
class LentLists {
 public:
  using Contacts = std::vector<UncertainContact>;
  using Dimensions = std::vector<std::pair<std::size_t, int>>;
  LentLists() : slot_(&threadLists()) {
    contacts.swap(slot_->first);
    dimensions.swap(slot_->second);
  }
  LentLists(LentLists&& other) noexcept
      : contacts(std::move(other.contacts)),
        dimensions(std::move(other.dimensions)),
        slot_(std::exchange(other.slot_, nullptr)) {}
  LentLists(const LentLists&) = delete;
  LentLists& operator=(const LentLists&) = delete;
  LentLists& operator=(LentLists&&) = delete;
  ~LentLists() {
    if (slot_ == nullptr) return;  // moved from
    contacts.clear();
    dimensions.clear();
    contacts.swap(slot_->first);
    dimensions.swap(slot_->second);
  }
  Contacts contacts;
  Dimensions dimensions;

 private:
  using Lists = std::pair<Contacts, Dimensions>;
  static Lists& threadLists() {
    thread_local Lists lists;
    return lists;
  }
  Lists* slot_ = nullptr;
};

struct Prepared : LentLists {
  // The scene with the coefficients at their means: the request's own scene while every mean
  // equals the request's value (as when the request's values are the means), a copy once one
  // differs (prepare() makes it; the request's scene outlives the Prepared).
  const Scene& meanScene() const { return owned_mean ? *owned_mean : *request_scene; }
  const Scene* request_scene = nullptr;
  std::optional<Scene> owned_mean;
  // (LentLists: contacts, the uncertain contacts; dimensions, (index in contacts, coefficient).)
  // Sampling dimensions of the normals and points, after the coefficients' ones (their count is
  // geometry.size()).
  std::size_t geometry_dimensions = 0;
  std::vector<GeometryDimension> geometry;
  std::vector<Warning> warnings;
  std::vector<std::pair<int, int>> contact_bodies;  // kSampled: validate()'s
};

// Contact or ContactPoint, const or not (then the reference is const).
template <class AnyContact>
auto& coefficient(AnyContact& contact, int which) {
  return which == kRestitution      ? contact.restitution
         : which == kStaticFriction ? contact.static_friction
                                    : contact.dynamic_friction;
}

// The distributions checked and the mean scene (not validated: the methods validate it).
Prepared prepare(const Scene& scene, const std::vector<ContactUncertainty>& uncertainties) {
  Prepared prepared;
  prepared.request_scene = &scene;
  // The contacts named by earlier entries, one bit each (on the stack up to 1024 contacts).
  std::array<std::uint64_t, 16> named_small{};
  std::vector<std::uint64_t> named_large;
  std::uint64_t* named = named_small.data();
  if (scene.contacts.size() > 64 * named_small.size()) {
    named_large.assign((scene.contacts.size() + 63) / 64, 0);
    named = named_large.data();
  }
  prepared.contacts.reserve(uncertainties.size());
  prepared.dimensions.reserve(3 * uncertainties.size());
  for (std::size_t k = 0; k < uncertainties.size(); ++k) {
    const ContactUncertainty& entry = uncertainties[k];
    // Field names are built only for an error or a warning (the linear method's cost is a few
    // dozen allocations).
    auto field = [k] { return "uncertainties[" + std::to_string(k) + "]"; };
    if (entry.contact >= scene.contacts.size())
      throw InvalidInput(field() + ".contact", "no contact " + std::to_string(entry.contact) +
                                                   " (the request has " +
                                                   std::to_string(scene.contacts.size()) + ")");
    const std::uint64_t bit = std::uint64_t{1} << (entry.contact % 64);
    if (named[entry.contact / 64] & bit)
      throw InvalidInput(field() + ".contact", "contact " + std::to_string(entry.contact) +
                                                   " is named by an earlier entry");
    named[entry.contact / 64] |= bit;
    const std::array<const std::optional<CoefficientDistribution>*, 3> given = {
        &entry.restitution, &entry.static_friction, &entry.dynamic_friction};
    // (A normal spread beyond pi/2 spreads the direction over the whole half-sphere; a point
    // spread beyond the length limit leaves the request's world.)
    if (!(entry.normal_std_dev >= 0.0 && entry.normal_std_dev <= kMaxNormalStdDev))
      throw InvalidInput(field() + ".normal_std_dev",
                         "must be a number in [0, pi/2] [rad] (0: the normal exactly)");
    for (int axis = 0; axis < 3; ++axis)
      if (!(entry.point_std_dev[axis] >= 0.0 &&
            entry.point_std_dev[axis] <= MagnitudeLimits::kLength))
        throw InvalidInput(field() + ".point_std_dev." + "xyz"[axis],
                           "must be a number in [0, 1e7] [m] (0: exact along that axis)");
    const bool geometric = entry.normal_std_dev > 0.0 || (entry.point_std_dev.array() > 0.0).any();
    if (!*given[0] && !*given[1] && !*given[2] && !geometric) continue;
    const Contact* contact_at_mean = &scene.contacts[entry.contact];
    const std::array<double, 3> uppers = {1.0, std::numeric_limits<double>::infinity(),
                                          std::numeric_limits<double>::infinity()};
    auto checked = [&](int which) {
      if (!*given[which]) {
        const double value = coefficient(*contact_at_mean, which);
        if (!std::isfinite(value))  // as validate() names it
          throw InvalidInput(
              "contacts[" + std::to_string(entry.contact) + "]." + kCoefficientNames[which],
              "must be a finite number");
        return CheckedDistribution(CoefficientDistribution::interval(value, value), -1e300, 1e300,
                                   field);
      }
      std::optional<Warning> warning;
      CheckedDistribution distribution(
          **given[which], 0.0, uppers[which],
          [&] { return field() + "." + kCoefficientNames[which]; }, &warning);
      if (warning) prepared.warnings.push_back(*warning);
      return distribution;
    };
    // (The dimensions spelled out: an empty {} would value-initialise them to 0, dimension 0.)
    UncertainContact uncertain{
        entry.contact, k, {checked(0), checked(1), checked(2)}, {-1, -1, -1}};
    for (int which = 0; which < 3; ++which) {
      const double mean = uncertain.distributions[which].mean();
      // (Compared exactly: any other mean, however close, is written into the copy.)
      if (coefficient(*contact_at_mean, which) != mean) {
        if (!prepared.owned_mean) prepared.owned_mean = scene;
        Contact& owned = prepared.owned_mean->contacts[entry.contact];
        coefficient(owned, which) = mean;
        contact_at_mean = &owned;
      }
      if (uncertain.distributions[which].variance() > 0.0) {
        uncertain.dimension[which] = static_cast<int>(prepared.dimensions.size());
        prepared.dimensions.emplace_back(prepared.contacts.size(), which);
      }
    }
    const Contact& contact = *contact_at_mean;
    if (geometric) {
      uncertain.normal = contact.normal;
      uncertain.point = contact.point;
      uncertain.normal_std_dev = entry.normal_std_dev;
      uncertain.point_std_dev = entry.point_std_dev;
      if (entry.normal_std_dev > 0.0) {
        const double length = contact.normal.norm();
        if (!(std::isfinite(length) && length > 0.0))  // as validate() names it
          throw InvalidInput("contacts[" + std::to_string(entry.contact) + "].normal",
                             "must be a finite, nonzero vector");
        tangentBasis(contact.normal / length, uncertain.tangent1, uncertain.tangent2);
        uncertain.normal_dimension = static_cast<int>(prepared.geometry_dimensions);
        prepared.geometry_dimensions += 2;
        for (const int kind : {GeometryDimension::kTilt1, GeometryDimension::kTilt2})
          prepared.geometry.push_back({prepared.contacts.size(), kind, entry.normal_std_dev});
      }
      for (int axis = 0; axis < 3; ++axis) {
        if (!(entry.point_std_dev[axis] > 0.0)) continue;
        uncertain.point_dimension[axis] = static_cast<int>(prepared.geometry_dimensions);
        prepared.geometry_dimensions += 1;
        prepared.geometry.push_back({prepared.contacts.size(), GeometryDimension::kPointX + axis,
                                     entry.point_std_dev[axis]});
      }
    }
    // (Friction given as it is, an invalid pair is the contact's: validate() names it.)
    if ((*given[kStaticFriction] || *given[kDynamicFriction]) &&
        contact.dynamic_friction > contact.static_friction) {
      const int which = *given[kDynamicFriction] ? kDynamicFriction : kStaticFriction;
      std::ostringstream reason;
      reason << "the mean of dynamic_friction (" << contact.dynamic_friction
             << ") exceeds that of static_friction (" << contact.static_friction
             << "): Coulomb's law needs mu_d <= mu_s";
      throw InvalidInput(field() + "." + kCoefficientNames[which], reason.str());
    }
    prepared.contacts.push_back(std::move(uncertain));
  }
  return prepared;
}

// Pieces joined with one allocation (the linear method builds a few messages per call).
std::string joined(std::initializer_list<std::string_view> parts) {
  std::size_t size = 0;
  for (const std::string_view part : parts) size += part.size();
  // Sized at once, the parts copied in (cheaper than append()'s checks per part).
  std::string out(size, '\0');
  char* at = out.data();
  for (const std::string_view part : parts) {
    std::memcpy(at, part.data(), part.size());
    at += part.size();
  }
  return out;
}

// A number's decimal digits (std::to_chars, no allocation), or "12.3 %" for a fraction (percent()).
class NumberText {
 public:
  explicit NumberText(std::size_t value) {
    size_ = static_cast<std::size_t>(std::to_chars(text_, text_ + sizeof text_, value).ptr - text_);
  }
  // Three significant digits, as printf's %.3g (writePercent()).
  static NumberText percent(double fraction) {
    NumberText out;
    out.size_ = writePercent(fraction, out.text_);
    return out;
  }
  operator std::string_view() const { return {text_, size_}; }

 private:
  NumberText() = default;
  char text_[kPercentTextSize];
  std::size_t size_ = 0;
};

// The field a mu_d > mu_s draw is reported under: dynamic_friction when it has a spread (it is
// the one capped), else static_friction (only mu_s varies: its low draws fall below mu_d).
std::string overlapField(const UncertainContact& contact) {
  return joined({"uncertainties[", NumberText(contact.entry), "].",
                 contact.dimension[kDynamicFriction] >= 0 ? kCoefficientNames[kDynamicFriction]
                                                          : kCoefficientNames[kStaticFriction]});
}

// P(mu_d > mu_s) from the normal approximation of mu_s - mu_d (same means and variances): cheap
// enough for the linear method, whose warning it feeds.
double approximateOverlapProbability(const UncertainContact& contact) {
  const CheckedDistribution& mu_s = contact.distributions[kStaticFriction];
  const CheckedDistribution& mu_d = contact.distributions[kDynamicFriction];
  if (mu_d.quantile(1.0) <= mu_s.quantile(0.0)) return 0.0;
  const double variance = mu_s.variance() + mu_d.variance();
  if (variance == 0.0) return mu_d.mean() > mu_s.mean() ? 1.0 : 0.0;
  return standardNormalCdf((mu_d.mean() - mu_s.mean()) / std::sqrt(variance));
}

// The variance of sampling dimension j (the coefficients', then the geometry's).
double dimensionVariance(const Prepared& prepared, std::size_t j) {
  if (j >= prepared.dimensions.size()) {
    const double sd = prepared.geometry[j - prepared.dimensions.size()].std_dev;
    return sd * sd;
  }
  const auto& [index, which] = prepared.dimensions[j];
  return prepared.contacts[index].distributions[static_cast<std::size_t>(which)].variance();
}

Eigen::Index movableCount(const Scene& scene) {
  Eigen::Index count = 0;
  for (const BodyState& body : scene.bodies) count += body.immovable() ? 0 : 1;
  return count;
}

std::vector<int> movableBodies(const Scene& scene) {
  std::vector<int> movable;
  for (std::size_t b = 0; b < scene.bodies.size(); ++b)
    if (!scene.bodies[b].immovable()) movable.push_back(static_cast<int>(b));
  return movable;
}

// The quantities of a prediction, in the order of OutcomeDistribution.
template <typename Row>
void fillOutcome(const CollisionResult& result, const std::vector<int>& movable, Row&& row) {
  Eigen::Index r = 0;
  for (const int b : movable) {
    row(r++) = result.bodies[b].linear_velocity.x();
    row(r++) = result.bodies[b].linear_velocity.y();
    row(r++) = result.bodies[b].linear_velocity.z();
    row(r++) = result.bodies[b].angular_velocity.x();
    row(r++) = result.bodies[b].angular_velocity.y();
    row(r++) = result.bodies[b].angular_velocity.z();
  }
  for (const ContactImpulse& impulse : result.impulses) {
    row(r++) = impulse.normal_impulse;
    row(r++) = impulse.friction_impulse.x();
    row(r++) = impulse.friction_impulse.y();
    row(r++) = impulse.friction_impulse.z();
  }
}

std::vector<std::string> outcomeLabels(const std::vector<int>& movable, std::size_t contacts) {
  ImpactDerivatives layout;
  layout.movable_bodies = movable;
  layout.contact_count = contacts;
  layout.jacobian.resize(layout.velocityCount() + layout.impulseCount(), 0);
  return layout.rowLabels();
}

// "12.3 %": three significant digits, as printf's %.3g.
std::string percentText(double fraction) {
  return std::string(NumberText::percent(fraction));
}

// Under Newton's law a sliding contact sticks where its sticking impulse, the answer with that
// contact held (its friction raised to kHeldFriction, which no impulse reaches), lies in its static
// cone: the linear method's margin of such a contact is mu_s P_n - |P_t| of that held answer
// (docs/uncertainty.md, "Linear"), with its gradient along every dimension (the coefficients' from
// the held answer's derivatives, the geometry's by differences of held solves). Per contact: its
// row, or -1 (a held answer that does not stick: the contact cannot stick); `row` is empty where
// no contact slides or the law is another.
struct HeldMargins {
  std::vector<int> row;      // per contact
  Eigen::VectorXd margin;    // [N s]
  Eigen::MatrixXd gradient;  // rows x dimensions (the coefficients', then the geometry's)
  // The geometry dimensions whose held differences changed a mode or took the secant
  // (differenceGeometry()'s warnings), for the fields the outcome's own differences did not name.
  std::vector<Warning> warnings;
};

// Friction a held contact cannot exceed (|P_t| <= 1000 P_n): any impulse that a solve with it
// does not hold is not a sticking impulse the static cone could hold either.
constexpr double kHeldFriction = 1e3;

// Holds a contact (Contact or ContactPoint): its friction raised to kHeldFriction.
template <class AnyContact>
void hold(AnyContact& contact) {
  contact.static_friction = kHeldFriction;
  contact.dynamic_friction = kHeldFriction;
}

// A held solve's scratch change of `contacts` (Contact or ContactPoint): contact c held and, if
// `moved` is given, that contact moved to `normal` and `point`; undone by the destructor.
template <class AnyContact>
class HeldChange {
 public:
  HeldChange(std::vector<AnyContact>& contacts, std::size_t c, AnyContact* moved,
             const Eigen::Vector3d& normal, const Eigen::Vector3d& point)
      : held_(contacts[c]),
        static_friction_(held_.static_friction),
        dynamic_friction_(held_.dynamic_friction),
        moved_(moved) {
    if (moved_) {
      normal_ = moved_->normal;
      point_ = moved_->point;
      moved_->normal = normal;
      moved_->point = point;
    }
    hold(held_);
  }
  ~HeldChange() {
    held_.static_friction = static_friction_;
    held_.dynamic_friction = dynamic_friction_;
    if (moved_) {
      moved_->normal = normal_;
      moved_->point = point_;
    }
  }
  HeldChange(const HeldChange&) = delete;
  HeldChange& operator=(const HeldChange&) = delete;

 private:
  AnyContact& held_;
  double static_friction_, dynamic_friction_;
  AnyContact* moved_;
  Eigen::Vector3d normal_, point_;
};

// The sampling dimension of contact c's mu_s, -1 if it is not uncertain.
int staticFrictionDimension(const Prepared& prepared, std::size_t c) {
  for (const UncertainContact& uncertain : prepared.contacts)
    if (uncertain.contact == c) return uncertain.dimension[kStaticFriction];
  return -1;
}

// Where a solve decides whether a contact sticks, its static friction bounds the sticking
// impulse by the static cone |P_t| <= mu_s P_n, except in an island Newton's exact solver pivots
// on (Lemke or its modes: SolveReport::iterations > 0), which decides on the static pyramid of
// its LCP (pyramidFacetNormal(): facet . P_t <= cos(pi / D) mu_s P_n for the facet around P_t),
// up to 7.6 % inside the cone; its all-sticking answer (no pivot), the closed forms and the
// iterative solver decide on the cone (docs/uncertainty.md, "Linear").
struct StaticBound {
  bool pyramid = false;
  Eigen::Vector3d facet = Eigen::Vector3d::Zero();  // unit, the pyramid's facet around P_t
};

// cos(pi / D): a pyramid facet's distance from the axis per unit of mu P_n.
const double kFacetDistance = std::cos(kPi / kPyramidDirections);

// The bound of contact c, of normal `normal`, with `impulse` its answer in a solve whose islands
// are `islands`; `u_before()` gives its relative velocity v_b - v_a before the impact [m/s, world]
// (called for a pyramid only).
template <class VelocityBefore>
StaticBound staticBound(const std::vector<SolveReport>& islands, std::size_t c,
                        const Eigen::Vector3d& normal, VelocityBefore&& u_before,
                        const ContactImpulse& impulse) {
  StaticBound bound;
  for (const SolveReport& island : islands) {
    if (std::find(island.contacts.begin(), island.contacts.end(), static_cast<int>(c)) ==
        island.contacts.end())
      continue;
    bound.pyramid = island.method == SolvedBy::kExact && island.iterations > 0;
    break;
  }
  if (bound.pyramid)
    bound.facet = pyramidFacetNormal(normal.normalized(), u_before(), impulse.friction_impulse);
  return bound;
}

// The static margin [N s] of a contact's impulse: mu_s P_n - |P_t| on the cone, cos(pi / D)
// mu_s P_n - facet . P_t on the pyramid (>= 0: inside).
double staticMargin(double mu_s, const ContactImpulse& impulse, const StaticBound& bound) {
  if (!bound.pyramid) return mu_s * impulse.normal_impulse - impulse.friction_impulse.norm();
  return kFacetDistance * mu_s * impulse.normal_impulse - bound.facet.dot(impulse.friction_impulse);
}

// staticMargin()'s slope into gradient[j] for each j < count with column(j) >= 0: by `jacobian`'s
// column column(j), its rows from `impulse_row` the contact's P_n then P_t; plus P_n's share
// along `mu_s_dimension` (the contact's own mu_s, if uncertain: -1 otherwise). The pyramid's
// facet is held where it is (it turns with the normal and the pre-impact slip, not with the
// coefficients).
template <class Column>
void staticMarginSlope(double mu_s, const ContactImpulse& impulse, const StaticBound& bound,
                       const Eigen::MatrixXd& jacobian, Eigen::Index impulse_row,
                       Eigen::Index count, Column&& column, int mu_s_dimension, double* gradient) {
  const double share = bound.pyramid ? kFacetDistance : 1.0;
  Eigen::Vector3d direction = bound.facet;
  if (!bound.pyramid) {
    const double tangential = impulse.friction_impulse.norm();
    direction = tangential > 0.0 ? Eigen::Vector3d(impulse.friction_impulse / tangential)
                                 : Eigen::Vector3d::Zero();
  }
  for (Eigen::Index j = 0; j < count; ++j) {
    const Eigen::Index k = column(j);
    if (k < 0) continue;
    gradient[j] = share * mu_s * jacobian(impulse_row, k) -
                  direction.dot(jacobian.block<3, 1>(impulse_row + 1, k));
  }
  if (mu_s_dimension >= 0) gradient[mu_s_dimension] += share * impulse.normal_impulse;
}

// The probability that contact c sticks, from the linearised margin of its mode at the means
// (docs/uncertainty.md, "Linear"): sticking, mu_s P_n - |P_t|; sliding, under Newton's law the
// held answer's mu_s P_n - |P_t| (`held`); under Poisson's and Stronge's whether the slip stops
// within the impact, s / s_mu (= mu_d - mu*), linearised in s; under the one-pass law mu_s - mu*;
// s the slip speed after the impact, s_mu = ds/dmu_d (< 0), mu* = mu_d - s / s_mu the mu_d at
// which the slip, linearised in mu_d, would vanish.
// `jacobian`: the derivatives at the means, rows as OutcomeDistribution's (velocity_count velocity
// rows, then 4 per contact), columns velocity_count, then e, mu_s, mu_d per contact (then any
// others). `slip_of(c, slip, slip_rate)` adds the relative velocity of b against a at the contact's
// point after the impact [m/s, world] to `slip` and its derivative by each Jacobian column to
// `slip_rate` (3 x columns), both given zero; it is called for a sliding contact only.
// `column_used[j]`: whether the Jacobian's column of dimension j has a nonzero entry; `variance[j]`
// the dimension's variance (dimensionVariance()). `gradient`: a workspace of one entry per
// dimension. The geometry's dimensions (after the coefficients') have their columns after the
// coefficients' and `geometry_speed` (contacts x their count; null without them): the derivatives
// of each contact's slip speed after the impact, which also moves with the contact's own point and
// normal, not only with the bodies' velocities that slip_of() reads. `held`: Newton's held margins
// (null: none). `law`: the solve's (which margin a sliding contact takes).
template <class SlipOf>
double linearStickProbability(const Eigen::MatrixXd& jacobian, Eigen::Index velocity_count,
                              const ContactImpulse& impulse, ImpactMode mode,
                              const Prepared& prepared, std::size_t c,
                              const int* column_of_dimension, const unsigned char* column_used,
                              const double* variance, double* gradient, SlipOf& slip_of,
                              const Eigen::MatrixXd* geometry_speed, const HeldMargins* held,
                              const StaticBound& bound, ImpactLaw law) {
  const Contact& contact = prepared.meanScene().contacts[c];
  if (impulse.resting) return impulse.sticking ? 1.0 : 0.0;
  if (mode == ImpactMode::kNoImpulse || contact.frictionless()) return 0.0;
  const Eigen::Index coefficient_dims = static_cast<Eigen::Index>(prepared.dimensions.size());
  const Eigen::Index dims = coefficient_dims + static_cast<Eigen::Index>(prepared.geometry.size());
  const int mu_s_dimension = staticFrictionDimension(prepared, c);
  std::fill(gradient, gradient + dims, 0.0);
  double margin = 0.0;
  const Eigen::Index row = velocity_count + 4 * static_cast<Eigen::Index>(c);
  if (mode == ImpactMode::kSticking) {
    margin = staticMargin(contact.static_friction, impulse, bound);
    // (A zero column: its gradient entry stays 0.)
    staticMarginSlope(
        contact.static_friction, impulse, bound, jacobian, row, dims,
        [&](Eigen::Index j) { return column_used[j] ? Eigen::Index{column_of_dimension[j]} : -1; },
        mu_s_dimension, gradient);
  } else if (law == ImpactLaw::kNewton) {
    // No held answer that sticks: no sticking impulse within friction kHeldFriction, so none that
    // a static cone holds.
    if (!held || c >= held->row.size() || held->row[c] < 0) return 0.0;
    const Eigen::Index r = held->row[c];
    margin = held->margin(r);
    for (Eigen::Index j = 0; j < dims; ++j) gradient[j] = held->gradient(r, j);
  } else {
    // Slip velocity of b relative to a at the point, tangential part, and its derivatives.
    const Eigen::Vector3d n = contact.normal.normalized();  // (unit within 1e-3)
    Eigen::Vector3d slip = Eigen::Vector3d::Zero();
    Eigen::MatrixXd slip_rate = Eigen::MatrixXd::Zero(3, jacobian.cols());
    slip_of(c, slip, slip_rate);
    const Eigen::Matrix3d tangent_projection = Eigen::Matrix3d::Identity() - n * n.transpose();
    slip = tangent_projection * slip;
    const double speed = slip.norm();
    if (speed == 0.0) return 0.0;
    const Eigen::RowVectorXd speed_rate =
        (slip / speed).transpose() * tangent_projection * slip_rate;
    const Eigen::Index mu_d_column =
        velocity_count + 3 * static_cast<Eigen::Index>(c) + kDynamicFriction;
    const double by_mu_d = speed_rate(mu_d_column);
    if (!(by_mu_d < 0.0)) return 0.0;  // more friction does not slow the slip: it never sticks
    // Poisson and Stronge slide with mu_d until the slip stops, then hold: the contact ends
    // sticking iff its slip stops within the impact, s <= 0 for the slip speed s extended past its
    // zero, margin s / s_mu (= mu_d - mu*, in units of mu), its gradient (ds/dx) / s_mu with s_mu
    // held at the means: linear in s (which the bodies' velocities make nearly affine in the
    // coefficients), not in mu* (s_mu moves too: linearising mu* was further from the samples,
    // docs/uncertainty.md). mu_s does not enter (holding the stopped slip is taken as given). The
    // one-pass law: mu_s - mu*, the static coefficient at which it would stick, its own mu_d left
    // out (it decides how the contact slides, not whether it sticks).
    const bool stops = law == ImpactLaw::kPoisson || law == ImpactLaw::kStronge;
    margin = speed / by_mu_d;
    if (!stops) margin += contact.static_friction - contact.dynamic_friction;
    for (Eigen::Index j = 0; j < coefficient_dims; ++j) {
      const Eigen::Index k = column_of_dimension[j];
      if (!stops && k == mu_d_column) continue;
      gradient[j] = speed_rate(k) / by_mu_d;  // (its own mu_d: 1)
    }
    for (Eigen::Index j = coefficient_dims; j < dims; ++j)
      gradient[j] = (*geometry_speed)(static_cast<Eigen::Index>(c), j - coefficient_dims) / by_mu_d;
    if (!stops && mu_s_dimension >= 0) gradient[mu_s_dimension] += 1.0;
  }
  double margin_variance = 0.0;
  for (Eigen::Index j = 0; j < dims; ++j) {
    if (gradient[j] == 0.0) continue;  // adds +0 (the variances are finite)
    margin_variance += gradient[j] * gradient[j] * variance[j];
  }
  if (margin_variance == 0.0) return margin >= 0.0 ? 1.0 : 0.0;
  const double z = margin / std::sqrt(margin_variance);
  // (A slip rate in mu_d next to 0 can overflow the margin and its slope: their ratio is then
  // no number, and the probability that of the margin's sign.)
  if (!std::isfinite(z)) return margin >= 0.0 ? 1.0 : 0.0;
  return standardNormalCdf(z);
}

// S S^T into `out` (m x m, column-major), S = `s` (m x used, column-major). Rows x a few columns:
// column c is a sum of S's columns weighted by their entries in row c, taken four at a time so
// that each output is stored once per four (plain loops the compiler vectorises; cheaper than a
// product kernel's set-up at this size), two output columns per pass (each load of S serves
// both). Entries (r, c) and (c, r) sum the same products in the same order: the result is exactly
// symmetric.
[[gnu::always_inline]] inline void outerProduct(const double* s, Eigen::Index m, Eigen::Index used,
                                                double* out) {
  Eigen::Index c = 0;
  for (; c + 2 <= m; c += 2) {
    double* __restrict first = out + c * m;
    double* __restrict second = first + m;
    Eigen::Index j = 0;
    if (used < 4) {
      for (Eigen::Index r = 0; r < m; ++r) first[r] = second[r] = 0.0;
    }
    for (; j + 4 <= used; j += 4) {
      const double* __restrict s0 = s + j * m;
      const double* __restrict s1 = s0 + m;
      const double* __restrict s2 = s1 + m;
      const double* __restrict s3 = s2 + m;
      const double a0 = s0[c], a1 = s1[c], a2 = s2[c], a3 = s3[c];
      const double b0 = s0[c + 1], b1 = s1[c + 1], b2 = s2[c + 1], b3 = s3[c + 1];
      if (j == 0) {
        for (Eigen::Index r = 0; r < m; ++r) {
          first[r] = a0 * s0[r] + a1 * s1[r] + a2 * s2[r] + a3 * s3[r];
          second[r] = b0 * s0[r] + b1 * s1[r] + b2 * s2[r] + b3 * s3[r];
        }
      } else {
        for (Eigen::Index r = 0; r < m; ++r) {
          first[r] += a0 * s0[r] + a1 * s1[r] + a2 * s2[r] + a3 * s3[r];
          second[r] += b0 * s0[r] + b1 * s1[r] + b2 * s2[r] + b3 * s3[r];
        }
      }
    }
    for (; j < used; ++j) {
      const double* __restrict s0 = s + j * m;
      const double a0 = s0[c], b0 = s0[c + 1];
      for (Eigen::Index r = 0; r < m; ++r) {
        first[r] += a0 * s0[r];
        second[r] += b0 * s0[r];
      }
    }
  }
  for (; c < m; ++c) {  // an odd last column
    double* __restrict column = out + c * m;
    Eigen::Index j = 0;
    if (used < 4) {
      for (Eigen::Index r = 0; r < m; ++r) column[r] = 0.0;
    }
    for (; j + 4 <= used; j += 4) {
      const double* __restrict s0 = s + j * m;
      const double* __restrict s1 = s0 + m;
      const double* __restrict s2 = s1 + m;
      const double* __restrict s3 = s2 + m;
      const double a0 = s0[c], a1 = s1[c], a2 = s2[c], a3 = s3[c];
      if (j == 0) {
        for (Eigen::Index r = 0; r < m; ++r)
          column[r] = a0 * s0[r] + a1 * s1[r] + a2 * s2[r] + a3 * s3[r];
      } else {
        for (Eigen::Index r = 0; r < m; ++r)
          column[r] += a0 * s0[r] + a1 * s1[r] + a2 * s2[r] + a3 * s3[r];
      }
    }
    for (; j < used; ++j) {
      const double* __restrict s0 = s + j * m;
      const double a0 = s0[c];
      for (Eigen::Index r = 0; r < m; ++r) column[r] += a0 * s0[r];
    }
  }
}

// The linear method's spread (docs/uncertainty.md), shared by the rigid-body and the general-body
// paths: with outcome.mean set to the prediction, covariance = J S J^T over the uncertain
// coefficients' columns (S their variances), q05 / q95 = mean -/+ 1.645 sigma, the linearised stick
// probabilities (linearStickProbability(), `slip_of` as it takes it) and the warnings (truncations,
// mu_d > mu_s overlap, a spread reaching a stick/slip switch, a linearisation at a mode switch).
// `jacobian` and `velocity_count` as linearStickProbability() takes them; `impulses` and `modes`:
// the prediction's, one per contact.
// With an uncertain normal or point, `jacobian` has the geometry's columns last and
// `geometry_speed` is as linearStickProbability() takes it (differenceGeometry()); else null.
// `held` and `law`: as linearStickProbability() takes them; `bound_of(c)`: the static bound
// (staticBound()) of sticking contact c in the prediction.
template <class SlipOf, class BoundOf>
void linearSpread(const Eigen::MatrixXd& jacobian, Eigen::Index velocity_count,
                  const std::vector<ContactImpulse>& impulses,
                  const std::vector<ContactDerivativeMode>& modes, const Prepared& prepared,
                  SlipOf&& slip_of, BoundOf&& bound_of, const Eigen::MatrixXd* geometry_speed,
                  const HeldMargins* held, ImpactLaw law, OutcomeDistribution& outcome) {
  outcome.method = UncertaintyMethod::kLinear;
  const Eigen::Index m = jacobian.rows();
  const Eigen::Index coefficient_dims = static_cast<Eigen::Index>(prepared.dimensions.size());
  const Eigen::Index geometry_dims = static_cast<Eigen::Index>(prepared.geometry.size());
  const Eigen::Index dims = coefficient_dims + geometry_dims;
  // Per dimension: its Jacobian column, whether that column has a nonzero entry, its variance,
  // and the stick probabilities' gradient entry (on the stack up to 96 dimensions: 32 uncertain
  // contacts' coefficients).
  constexpr std::size_t kSmallDimensions = 96;
  std::array<int, kSmallDimensions> small_columns;
  std::array<unsigned char, kSmallDimensions> small_used;
  std::array<double, kSmallDimensions> small_variance;
  std::array<double, kSmallDimensions> small_gradient;
  std::vector<int> large_columns;
  std::vector<unsigned char> large_used;
  std::vector<double> large_variance;
  std::vector<double> large_gradient;
  int* column_of_dimension = small_columns.data();
  unsigned char* column_used = small_used.data();
  double* variance = small_variance.data();
  double* gradient = small_gradient.data();
  if (static_cast<std::size_t>(dims) > kSmallDimensions) {
    large_columns.resize(static_cast<std::size_t>(dims));
    large_used.resize(static_cast<std::size_t>(dims));
    large_variance.resize(static_cast<std::size_t>(dims));
    large_gradient.resize(static_cast<std::size_t>(dims));
    column_of_dimension = large_columns.data();
    column_used = large_used.data();
    variance = large_variance.data();
    gradient = large_gradient.data();
  }
  // J columns times the standard deviations; a coefficient the outcome does not depend on (a
  // sticking contact's friction: a zero column) adds nothing to the covariance and is left out
  // (and takes no room: `scaled` is allocated for the columns used only). One pass finds them
  // (a plain scan: cheaper than isZero()).
  Eigen::Index used = 0;
  for (Eigen::Index j = 0; j < dims; ++j) {
    if (j < coefficient_dims) {
      const auto& [index, which] = prepared.dimensions[j];
      column_of_dimension[j] = static_cast<int>(
          velocity_count + 3 * static_cast<Eigen::Index>(prepared.contacts[index].contact) + which);
    } else {
      column_of_dimension[j] =
          static_cast<int>(jacobian.cols() - geometry_dims + j - coefficient_dims);
    }
    variance[j] = dimensionVariance(prepared, static_cast<std::size_t>(j));
    const double* column = jacobian.col(column_of_dimension[j]).data();
    column_used[j] = std::any_of(column, column + m, [](double x) { return x != 0.0; });
    used += column_used[j];
  }
  Eigen::MatrixXd scaled(m, used);
  used = 0;
  for (Eigen::Index j = 0; j < dims; ++j) {
    if (column_used[j])
      scaled.col(used++) = jacobian.col(column_of_dimension[j]) * std::sqrt(variance[j]);
  }
  outcome.covariance.resize(m, m);
  outerProduct(scaled.data(), m, used, outcome.covariance.data());
  outcome.q05.resize(m);
  outcome.q95.resize(m);
  for (Eigen::Index r = 0; r < m; ++r) {
    const double spread = std::sqrt(outcome.covariance(r, r));
    outcome.q05(r) = outcome.mean(r) - kZ95 * spread;
    outcome.q95(r) = outcome.mean(r) + kZ95 * spread;
  }
  const std::size_t contacts = prepared.meanScene().contacts.size();
  outcome.stick_probability.resize(contacts);
  for (std::size_t c = 0; c < contacts; ++c)
    outcome.stick_probability[c] = linearStickProbability(
        jacobian, velocity_count, impulses[c], modes[c].mode, prepared, c, column_of_dimension,
        column_used, variance, gradient, slip_of, geometry_speed, held,
        modes[c].mode == ImpactMode::kSticking ? bound_of(c) : StaticBound{}, law);
  outcome.warnings.reserve(prepared.warnings.size() + prepared.contacts.size() + 2 * contacts);
  outcome.warnings = prepared.warnings;
  for (const UncertainContact& uncertain : prepared.contacts) {
    const double overlap = approximateOverlapProbability(uncertain);
    if (overlap > kTruncationWarningMass) {
      outcome.warnings.push_back(
          {overlapField(uncertain),
           joined({"dynamic_friction exceeds static_friction with probability about ",
                   NumberText::percent(overlap),
                   " (normal approximation of mu_s - mu_d;"
                   " such draws are solved with mu_d = mu_s by the sampled method; the linear "
                   "method does not see the cap)"}),
           Warning::Kind::kInput});
    }
  }
  auto contactField = [](std::size_t c) { return joined({"contacts[", NumberText(c), "]"}); };
  for (std::size_t c = 0; c < contacts; ++c) {
    const double p = outcome.stick_probability[c];
    if (p < kSwitchReachWarning || p > 1.0 - kSwitchReachWarning) continue;
    outcome.warnings.push_back(
        {contactField(c),
         joined({"the spread reaches its stick/slip switch (stick probability ",
                 NumberText::percent(p),
                 "): the linear distribution covers one mode only; use the sampled method"}),
         Warning::Kind::kInput});
  }
  for (std::size_t c = 0; c < contacts; ++c) {
    const ContactDerivativeMode& mode = modes[c];
    if (!mode.at_switch) continue;
    outcome.warnings.push_back(
        {contactField(c),
         joined({"linearised at a mode switch (", mode.switch_detail,
                 "): the linear distribution holds on one side only; use the sampled method"}),
         Warning::Kind::kInput});
  }
}

// One solve's options: what is left of the call's time budget (options.time_budget from `start`),
// so that the whole call (the samples, or the linear method's differences) is bounded by it, not
// each solve; SolverTimeout when nothing is left.
SolverOptions remainingBudget(const SolverOptions& options,
                              std::chrono::steady_clock::time_point start) {
  SolverOptions sample = options;
  sample.time_budget =
      options.time_budget -
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!(sample.time_budget > 0.0))
    throw SolverTimeout("the uncertainty's solves ran past options.time_budget");
  return sample;
}

// Per contact: 0 no impulse, 1 sliding, 2 sticking (what differenceGeometry() keeps its
// differences within).
int modeCode(const ContactImpulse& impulse) {
  return impulse.normal_impulse > 0.0 ? (impulse.sticking ? 2 : 1) : 0;
}

// The tangential part of a slip velocity against `normal` (any length: validated normals are unit
// within 1e-3), its length [m/s].
double tangentialSpeed(const Eigen::Vector3d& slip, const Eigen::Vector3d& normal) {
  const Eigen::Vector3d n = normal.normalized();
  return (slip - n * n.dot(slip)).norm();
}

// The linear method's columns of an uncertain normal or point (docs/uncertainty.md, "Uncertain
// normal and point"): per dimension of prepared.geometry, the central difference of the outcome's
// m rows and of each contact's slip speed after the impact, the contact's normal tilted by +-h,
// normalize(n +- h t), or its point moved by +-h along the axis, with h = min(base, sd / 100) but
// at least base / 1000, base = kGeometryStep [rad] for a tilt and kGeometryStep max(1, |p|_inf) [m]
// for a point. `evaluate(u, normal, point, values, modes)` solves with prepared.contacts[u]'s
// contact at that normal and point (every other contact as it is; every normal taken unit),
// writes the m rows, then the `contacts` slip speeds into `values`, and each contact's modeCode()
// into `modes`; evaluate(npos, ...) solves at the mean geometry. The
// difference is kept within the modes of the mean solve: where one side changes a contact's mode,
// it is one-sided on the other side; where both do, or where the two one-sided differences disagree
// (the outcome jumps with no contact changing its mode: a split of the impulse that is not unique),
// the column is the secant over +-1 standard deviation. Each such dimension is named by a warning
// (once per field).
struct GeometryColumns {
  Eigen::MatrixXd outcome;     // m x geometry dimensions
  Eigen::MatrixXd slip_speed;  // contacts x geometry dimensions [m/s per rad, or per m]
};

constexpr double kGeometryStep = 1e-6;

// Whether two one-sided differences of the same values disagree beyond a smooth map's curvature
// and round-off: by more than 1 % of their size plus `floor` (per row).
bool onesidedDisagree(const Eigen::VectorXd& forward, const Eigen::VectorXd& backward,
                      const Eigen::VectorXd& floor) {
  for (Eigen::Index i = 0; i < forward.size(); ++i)
    if (std::abs(forward(i) - backward(i)) >
        0.01 * (std::abs(forward(i)) + std::abs(backward(i))) + floor(i))
      return true;
  return false;
}

template <class Evaluate>
GeometryColumns differenceGeometry(const Prepared& prepared, Eigen::Index m, std::size_t contacts,
                                   Evaluate&& evaluate, std::vector<Warning>& warnings) {
  const auto count = static_cast<Eigen::Index>(prepared.geometry.size());
  const auto c_rows = static_cast<Eigen::Index>(contacts);
  const Eigen::Index rows = m + c_rows;
  GeometryColumns columns{Eigen::MatrixXd(m, count), Eigen::MatrixXd(c_rows, count)};
  Eigen::VectorXd plus(rows), minus(rows), mean(rows);
  std::vector<int> plus_modes(contacts), minus_modes(contacts), mean_modes(contacts);
  evaluate(static_cast<std::size_t>(-1), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), mean,
           mean_modes);
  std::vector<std::string> warned;
  for (Eigen::Index g = 0; g < count; ++g) {
    const GeometryDimension& dimension = prepared.geometry[static_cast<std::size_t>(g)];
    const UncertainContact& uncertain = prepared.contacts[dimension.index];
    const bool tilt = dimension.kind < GeometryDimension::kPointX;
    const double base =
        tilt ? kGeometryStep : kGeometryStep * std::max(1.0, uncertain.point.cwiseAbs().maxCoeff());
    const double h = std::max(std::min(base, 0.01 * dimension.std_dev), 0.001 * base);
    auto at = [&](double step, Eigen::VectorXd& values, std::vector<int>& found) {
      Eigen::Vector3d normal = uncertain.normal.normalized();
      Eigen::Vector3d point = uncertain.point;
      if (tilt) {
        const Eigen::Vector3d& t =
            dimension.kind == GeometryDimension::kTilt1 ? uncertain.tangent1 : uncertain.tangent2;
        normal = (normal + step * t).normalized();
      } else {
        point[dimension.kind - GeometryDimension::kPointX] += step;
      }
      evaluate(dimension.index, normal, point, values, found);
    };
    at(h, plus, plus_modes);
    at(-h, minus, minus_modes);
    const bool plus_kept = plus_modes == mean_modes;
    const bool minus_kept = minus_modes == mean_modes;
    bool secant = !plus_kept && !minus_kept;
    Eigen::VectorXd column;
    if (plus_kept && minus_kept) {
      // Per outcome row (not the slip speeds, whose kink at zero slip is no jump): the solves'
      // round-off, 1e-12 of the row's values or of the largest of all rows (a row that is zero
      // up to round-off), over h, and 0.1 of the row's values per unit of the dimension (a smooth
      // map's one-sided differences differ by h f'', far below that; a jump J makes them differ
      // by J / h, above it once J > 1e-7 of the values).
      const auto values = [m](const Eigen::VectorXd& v) { return v.head(m); };
      const Eigen::VectorXd size = values(mean)
                                       .cwiseAbs()
                                       .cwiseMax(values(plus).cwiseAbs())
                                       .cwiseMax(values(minus).cwiseAbs());
      const double largest = m > 0 ? size.maxCoeff() : 0.0;
      const Eigen::VectorXd floor =
          (1e-12 / h) * size.cwiseMax(largest).array() + 0.1 * size.array() + 1e-300;
      secant = onesidedDisagree((values(plus) - values(mean)) / h,
                                (values(mean) - values(minus)) / h, floor);
      if (!secant) column = (plus - minus) / (2.0 * h);
    } else if (!secant) {
      column = plus_kept ? Eigen::VectorXd((plus - mean) / h) : Eigen::VectorXd((mean - minus) / h);
    }
    if (secant) {
      // No derivative exists at the mean, and a difference across the jump over h would be as
      // large as the jump over h: the secant over +-1 standard deviation instead.
      at(dimension.std_dev, plus, plus_modes);
      at(-dimension.std_dev, minus, minus_modes);
      column = (plus - minus) / (2.0 * dimension.std_dev);
    }
    columns.outcome.col(g) = column.head(m);
    columns.slip_speed.col(g) = column.segment(m, c_rows);
    if (plus_kept && minus_kept && !secant) continue;
    static constexpr std::array<std::string_view, 5> kFields = {
        ".normal_std_dev", ".normal_std_dev", ".point_std_dev.x", ".point_std_dev.y",
        ".point_std_dev.z"};
    std::string field = joined({"uncertainties[", NumberText(uncertain.entry), "]",
                                kFields[static_cast<std::size_t>(dimension.kind)]});
    if (std::find(warned.begin(), warned.end(), field) != warned.end()) continue;
    warned.push_back(field);
    warnings.push_back(
        {std::move(field),
         secant ? std::string("the outcome has no derivative at the mean geometry (a contact "
                              "changes its mode on both sides within the difference step, or the "
                              "outcome jumps there): this dimension's column is the secant over "
                              "+-1 standard deviation, and the linear distribution is rough; use "
                              "the sampled method")
                : std::string("a contact changes its mode (no impulse, sliding, sticking) on one "
                              "side of the mean geometry within the difference step: linearised "
                              "on the other side, the linear distribution holds on that side only; "
                              "use the sampled method"),
         Warning::Kind::kInput});
  }
  return columns;
}

// The Jacobian with the geometry's columns after the coefficients' (differenceGeometry()), the
// rows of the slip speeds, and the warnings, for the linear method on a
// scene with an uncertain normal or point; `start`: the call's, for its time budget. (Out of line:
// the coefficients-only path, whose cost is measured against the prediction's, does not carry it.)
struct GeometryJacobian {
  Eigen::MatrixXd jacobian;
  Eigen::MatrixXd slip_speed;
  std::vector<Warning> warnings;
};

// Whether a frictional contact slides at the mean (under Newton's law its stick margin then needs
// its held answer: HeldMargins; a frictionless one, reported sliding, never sticks). `contacts`:
// anything with frictionless(), one per mode.
template <class Contacts>
bool anySliding(const std::vector<ContactDerivativeMode>& modes, const Contacts& contacts) {
  for (std::size_t c = 0; c < modes.size(); ++c)
    if (modes[c].mode == ImpactMode::kSliding && !contacts[c].frictionless()) return true;
  return false;
}

// Appends each of `from` whose field no warning in `to` names yet.
void addNewWarnings(const std::vector<Warning>& from, std::vector<Warning>& to) {
  for (const Warning& warning : from)
    if (std::none_of(to.begin(), to.end(),
                     [&](const Warning& had) { return had.field == warning.field; }))
      to.push_back(warning);
}

// HeldMargins (Newton's law): for each contact that slides with friction
// at the means, `differentiate(c, impulse, jacobian, bound)` solves with contact c held and
// differentiates by the uncertain coefficients (jacobian: rows velocity_count + 4 per contact,
// columns velocity_count + 3 per contact, as ImpactDerivatives' and BodyImpactDerivatives'); a
// held answer that sticks there gives the contact its row, its margin on the bound (staticBound())
// of the held solve. The geometry's columns are differences (differenceGeometry(), its warnings
// kept in HeldMargins::warnings) of held solves: `solve_moved(u, normal, point, c, impulses,
// bound)` solves with contact c held and prepared.contacts[u]'s contact at that normal and point
// (u = npos: the mean geometry), writes every contact's impulse and contact c's bound there.
template <class Contacts, class Differentiate, class SolveMoved>
HeldMargins heldMargins(const Prepared& prepared, const std::vector<ContactDerivativeMode>& modes,
                        const Contacts& contacts, Eigen::Index velocity_count,
                        Differentiate&& differentiate, SolveMoved&& solve_moved) {
  HeldMargins out;
  const std::size_t n = contacts.size();
  out.row.assign(n, -1);
  std::vector<std::size_t> kept;
  const auto coefficient_dims = static_cast<Eigen::Index>(prepared.dimensions.size());
  const Eigen::Index dims = coefficient_dims + static_cast<Eigen::Index>(prepared.geometry.size());
  Eigen::MatrixXd jacobian;
  ContactImpulse impulse;
  StaticBound bound;
  std::vector<double> slope(static_cast<std::size_t>(dims));
  for (std::size_t c = 0; c < n; ++c) {
    if (modes[c].mode != ImpactMode::kSliding || contacts[c].frictionless()) continue;
    differentiate(c, impulse, jacobian, bound);
    if (!impulse.sticking) continue;
    const auto r = static_cast<Eigen::Index>(kept.size());
    kept.push_back(c);
    out.row[c] = static_cast<int>(r);
    out.margin.conservativeResize(r + 1);
    out.gradient.conservativeResize(r + 1, dims);
    out.margin(r) = staticMargin(contacts[c].static_friction, impulse, bound);
    std::fill(slope.begin(), slope.end(), 0.0);
    staticMarginSlope(
        contacts[c].static_friction, impulse, bound, jacobian,
        velocity_count + 4 * static_cast<Eigen::Index>(c), coefficient_dims,
        [&](Eigen::Index j) {
          const auto& [index, which] = prepared.dimensions[static_cast<std::size_t>(j)];
          return velocity_count + 3 * static_cast<Eigen::Index>(prepared.contacts[index].contact) +
                 which;
        },
        staticFrictionDimension(prepared, c), slope.data());
    // (Element by element: row() of a matrix of 0 columns offsets a null pointer.)
    for (Eigen::Index j = 0; j < dims; ++j) out.gradient(r, j) = slope[static_cast<std::size_t>(j)];
  }
  const auto rows = static_cast<Eigen::Index>(kept.size());
  if (rows == 0 || prepared.geometry.empty()) return out;
  std::vector<ContactImpulse> impulses;
  auto evaluate = [&](std::size_t u, const Eigen::Vector3d& normal, const Eigen::Vector3d& point,
                      Eigen::VectorXd& values, std::vector<int>& found) {
    values.setZero();
    for (Eigen::Index r = 0; r < rows; ++r) {
      const std::size_t c = kept[static_cast<std::size_t>(r)];
      solve_moved(u, normal, point, c, impulses, bound);
      values(r) = staticMargin(contacts[c].static_friction, impulses[c], bound);
      for (std::size_t other = 0; other < n; ++other)
        found[static_cast<std::size_t>(r) * n + other] = modeCode(impulses[other]);
    }
  };
  out.gradient.rightCols(static_cast<Eigen::Index>(prepared.geometry.size())) =
      differenceGeometry(prepared, rows, kept.size() * n, evaluate, out.warnings).outcome;
  return out;
}

// `out.jacobian` = [coefficients | the geometry's columns], `out.slip_speed` the geometry's rows of
// the slip speeds: the end of rigidGeometryJacobian() and bodyGeometryJacobian().
void joinGeometryColumns(const Eigen::MatrixXd& coefficients, GeometryColumns&& columns,
                         GeometryJacobian& out) {
  out.jacobian.resize(coefficients.rows(), coefficients.cols() + columns.outcome.cols());
  out.jacobian << coefficients, columns.outcome;
  out.slip_speed = std::move(columns.slip_speed);
}

// The relative velocity u = v_b - v_a [m/s, world] at `point` of bodies `bodies` = {a, b} (indices
// of `states`) in the states' twists.
Eigen::Vector3d rigidRelativeVelocity(const std::vector<BodyState>& states,
                                      const std::pair<int, int>& bodies,
                                      const Eigen::Vector3d& point) {
  Eigen::Vector3d u = Eigen::Vector3d::Zero();
  for (const auto& [body, sign] : {std::pair{bodies.second, 1.0}, std::pair{bodies.first, -1.0}}) {
    const BodyState& state = states[static_cast<std::size_t>(body)];
    u += sign * (state.linear_velocity + state.angular_velocity.cross(point - state.worldCom()));
  }
  return u;
}

// The same of a contact between general bodies at their current velocities.
Eigen::Vector3d bodyRelativeVelocity(const std::vector<BodyModel*>& bodies,
                                     const ContactPoint& contact) {
  Eigen::Vector3d u = Eigen::Vector3d::Zero();
  for (const auto& [body, part, sign] : {std::tuple{contact.body_b, contact.part_b, 1.0},
                                         std::tuple{contact.body_a, contact.part_a, -1.0}})
    u += sign * bodies[static_cast<std::size_t>(body)]->partPointVelocity(part, contact.point);
  return u;
}

// staticBound() of contact c in `result`, a solve of rigid-body `scene` (the bodies' twists before
// the impact: the scene's; `contact_bodies` as validate() gives them).
StaticBound rigidStaticBound(const Scene& scene,
                             const std::vector<std::pair<int, int>>& contact_bodies,
                             const CollisionResult& result, std::size_t c) {
  const Contact& contact = scene.contacts[c];
  return staticBound(
      result.islands, c, contact.normal,
      [&] { return rigidRelativeVelocity(scene.bodies, contact_bodies[c], contact.point); },
      result.impulses[c]);
}

// Adds the velocity of body b against body a (`bodies` = {a, b}, scene indices) at `point` after
// the impact to `slip` [m/s, world] and, if `slip_rate` (3 x columns) is given, its derivative by
// `jacobian`'s columns from `first` on to each of its columns. Rigid bodies: `jacobian`'s rows
// are 6 per body of `movable_bodies`, in order; an immovable body has none (its motion is
// prescribed: the inputs do not move it).
void addRigidSlip(const CollisionResult& after, const std::vector<int>& movable_bodies,
                  const std::pair<int, int>& bodies, const Eigen::Vector3d& point,
                  const Eigen::MatrixXd& jacobian, Eigen::Index first, Eigen::Vector3d& slip,
                  Eigen::MatrixXd* slip_rate) {
  slip += rigidRelativeVelocity(after.bodies, bodies, point);
  if (!slip_rate) return;
  for (const auto& [body, sign] : {std::pair{bodies.second, 1.0}, std::pair{bodies.first, -1.0}}) {
    const BodyState& state = after.bodies[static_cast<std::size_t>(body)];
    if (state.immovable()) continue;
    const Eigen::Vector3d arm = point - state.worldCom();
    const auto at = std::find(movable_bodies.begin(), movable_bodies.end(), body);
    const Eigen::Index rows = 6 * (at - movable_bodies.begin());
    for (Eigen::Index k = 0; k < slip_rate->cols(); ++k) {
      const Eigen::Vector3d dv = jacobian.block<3, 1>(rows, first + k);
      const Eigen::Vector3d dw = jacobian.block<3, 1>(rows + 3, first + k);
      slip_rate->col(k) += sign * (dv + dw.cross(arm));
    }
  }
}

// The same for general bodies (computeBodyImpactDerivatives()'s layout: body b's velocity
// unknowns from `velocity_offset[b]`, none where it is -1), at the contact's point, from the
// bodies' current velocities and their point Jacobians.
void addBodySlip(const std::vector<BodyModel*>& bodies, const std::vector<int>& velocity_offset,
                 const ContactPoint& contact, const Eigen::MatrixXd& jacobian, Eigen::Index first,
                 Eigen::Vector3d& slip, Eigen::MatrixXd* slip_rate) {
  slip += bodyRelativeVelocity(bodies, contact);
  if (!slip_rate) return;
  for (const auto& [body, part, sign] : {std::tuple{contact.body_b, contact.part_b, 1.0},
                                         std::tuple{contact.body_a, contact.part_a, -1.0}}) {
    const BodyModel& model = *bodies[static_cast<std::size_t>(body)];
    const int offset = velocity_offset[static_cast<std::size_t>(body)];
    if (offset < 0) continue;
    slip_rate->noalias() += sign * model.partPointJacobian(part, contact.point) *
                            jacobian.block(offset, first, model.velocityCount(), slip_rate->cols());
  }
}

// The general-body outcome's rows (computeBodyOutcomeDistribution()) into `values`: the bodies'
// current velocity unknowns at their offsets, then per contact the normal and friction impulses.
void fillBodyOutcome(const std::vector<BodyModel*>& bodies, const std::vector<int>& velocity_offset,
                     Eigen::Index velocity_count, const std::vector<ContactImpulse>& impulses,
                     Eigen::VectorXd& values) {
  for (std::size_t b = 0; b < bodies.size(); ++b)
    if (velocity_offset[b] >= 0)
      values.segment(velocity_offset[b], bodies[b]->velocityCount()) = bodies[b]->velocity();
  Eigen::Index row = velocity_count;
  for (const ContactImpulse& impulse : impulses) {
    values(row++) = impulse.normal_impulse;
    values.segment<3>(row) = impulse.friction_impulse;
    row += 3;
  }
}

// Per contact of a solve: its tangential slip speed at its point and normal [m/s] into `speeds`
// and its modeCode() into `modes`. `add_slip(c, slip)` adds contact c's slip after the solve:
// addRigidSlip() or addBodySlip().
template <class Contacts, class AddSlip>
void slipSpeeds(const Contacts& contacts, const std::vector<ContactImpulse>& impulses,
                double* speeds, int* modes, AddSlip&& add_slip) {
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    Eigen::Vector3d slip = Eigen::Vector3d::Zero();
    add_slip(c, slip);
    speeds[c] = tangentialSpeed(slip, contacts[c].normal);
    modes[c] = modeCode(impulses[c]);
  }
}

[[gnu::noinline]] GeometryJacobian rigidGeometryJacobian(
    const Prepared& prepared, const ImpactDerivatives& derivatives,
    const std::vector<std::pair<int, int>>& contact_bodies, const SolverOptions& options,
    std::chrono::steady_clock::time_point start) {
  GeometryJacobian out;
  const Eigen::Index m = derivatives.jacobian.rows();
  const std::size_t contacts = prepared.meanScene().contacts.size();
  Scene moved = prepared.meanScene();
  for (Contact& contact : moved.contacts) contact.normal.normalize();  // (validated: nonzero)
  auto evaluate = [&](std::size_t u, const Eigen::Vector3d& normal, const Eigen::Vector3d& point,
                      Eigen::VectorXd& values, std::vector<int>& modes) {
    Contact* changed =
        u < prepared.contacts.size() ? &moved.contacts[prepared.contacts[u].contact] : nullptr;
    const Eigen::Vector3d kept_normal = changed ? changed->normal : Eigen::Vector3d::Zero();
    const Eigen::Vector3d kept_point = changed ? changed->point : Eigen::Vector3d::Zero();
    if (changed) {
      changed->normal = normal;
      changed->point = point;
    }
    const CollisionResult after =
        computeValidatedResponse(moved, contact_bodies, remainingBudget(options, start));
    fillOutcome(after, derivatives.movable_bodies,
                [&](Eigen::Index r) -> double& { return values(r); });
    slipSpeeds(moved.contacts, after.impulses, values.data() + m, modes.data(),
               [&](std::size_t c, Eigen::Vector3d& slip) {
                 addRigidSlip(after, derivatives.movable_bodies, contact_bodies[c],
                              moved.contacts[c].point, derivatives.jacobian, 0, slip, nullptr);
               });
    if (changed) {
      changed->normal = kept_normal;
      changed->point = kept_point;
    }
  };
  joinGeometryColumns(derivatives.jacobian,
                      differenceGeometry(prepared, m, contacts, evaluate, out.warnings), out);
  return out;
}

// heldMargins() for rigid bodies under Newton's law (else none):
// computeValidatedImpactDerivatives() of the held scene by `columns` (the mean's: the uncertain
// coefficients'). `start`: the call's, for its time budget.
[[gnu::noinline]] HeldMargins rigidHeldMargins(
    const Prepared& prepared, const ImpactDerivatives& derivatives,
    const std::vector<std::pair<int, int>>& contact_bodies, const DerivativeColumns& columns,
    const SolverOptions& options, std::chrono::steady_clock::time_point start) {
  if (options.law != ImpactLaw::kNewton ||
      !anySliding(derivatives.contacts, prepared.meanScene().contacts))
    return {};
  Scene held = prepared.meanScene();   // at the mean geometry, as the mean's derivatives
  Scene moved = prepared.meanScene();  // every normal unit, as differenceGeometry() takes them
  for (Contact& contact : moved.contacts) contact.normal.normalize();  // (validated: nonzero)
  auto differentiate = [&](std::size_t c, ContactImpulse& impulse, Eigen::MatrixXd& jacobian,
                           StaticBound& bound) {
    const HeldChange<Contact> change(held.contacts, c, nullptr, {}, {});
    ImpactDerivatives at = computeValidatedImpactDerivatives(
        held, contact_bodies, remainingBudget(options, start), columns);
    impulse = at.result.impulses[c];
    bound = rigidStaticBound(held, contact_bodies, at.result, c);
    jacobian = std::move(at.jacobian);
  };
  auto solve_moved = [&](std::size_t u, const Eigen::Vector3d& normal, const Eigen::Vector3d& point,
                         std::size_t c, std::vector<ContactImpulse>& impulses, StaticBound& bound) {
    const HeldChange<Contact> change(
        moved.contacts, c,
        u < prepared.contacts.size() ? &moved.contacts[prepared.contacts[u].contact] : nullptr,
        normal, point);
    CollisionResult result =
        computeValidatedResponse(moved, contact_bodies, remainingBudget(options, start));
    bound = rigidStaticBound(moved, contact_bodies, result, c);
    impulses = std::move(result.impulses);
  };
  return heldMargins(prepared, derivatives.contacts, prepared.meanScene().contacts,
                     derivatives.velocityCount(), differentiate, solve_moved);
}

// linearDistribution()'s derivatives in storage kept per thread (as DerivativeScratch in
// impact_derivatives.cpp): linearDistribution() does not call itself, nor does anything it calls.
[[gnu::noinline]] ImpactDerivatives& threadLinearDerivatives() {
  thread_local ImpactDerivatives derivatives;
  return derivatives;
}

OutcomeDistribution linearDistribution(const Prepared& prepared, const SolverOptions& options,
                                       const RequestLimits& limits) {
  // The call's start: every solve after the mean's (the geometry's differences, the sliding
  // contacts' margins) shares what is left of options.time_budget.
  const auto start = std::chrono::steady_clock::now();
  // Only the columns of the uncertain coefficients, and each contact's mu_d (the linearised stick
  // probability of a sliding contact reads it, but for Newton's law: its held margins), are
  // computed.
  const std::vector<std::pair<int, int>> contact_bodies =
      validate(prepared.meanScene(), options, limits);
  DerivativeColumns columns;
  columns.velocities = false;
  columns.coefficients.assign(3 * prepared.meanScene().contacts.size(), false);
  if (options.law != ImpactLaw::kNewton)
    for (std::size_t c = 0; c < prepared.meanScene().contacts.size(); ++c)
      columns.coefficients[3 * c + kDynamicFriction] = true;
  for (const auto& [index, which] : prepared.dimensions)
    columns.coefficients[3 * prepared.contacts[index].contact + static_cast<std::size_t>(which)] =
        true;
  // The derivatives in storage kept per thread (a request's Jacobian and lists are the size of
  // the last one's: no allocation for them).
  ImpactDerivatives& derivatives = threadLinearDerivatives();
  computeValidatedImpactDerivatives(prepared.meanScene(), contact_bodies, options, columns,
                                    derivatives);
  OutcomeDistribution outcome;
  const Eigen::Index m = derivatives.velocityCount() + derivatives.impulseCount();
  outcome.labels = derivatives.rowLabels();
  outcome.mean.resize(m);
  fillOutcome(derivatives.result, derivatives.movable_bodies,
              [&](Eigen::Index r) -> double& { return outcome.mean(r); });
  const CollisionResult& result = derivatives.result;
  // An uncertain normal or point: its columns by differences of the solver, after the
  // coefficients'.
  std::optional<GeometryJacobian> geometry;
  if (!prepared.geometry.empty())
    geometry = rigidGeometryJacobian(prepared, derivatives, contact_bodies, options, start);
  const Eigen::MatrixXd* jacobian = geometry ? &geometry->jacobian : &derivatives.jacobian;
  // The slip of a sliding contact from the bodies' twists after the impact and their rows.
  auto slip_of = [&](std::size_t c, Eigen::Vector3d& slip, Eigen::MatrixXd& slip_rate) {
    addRigidSlip(result, derivatives.movable_bodies, contact_bodies[c],
                 prepared.meanScene().contacts[c].point, *jacobian, 0, slip, &slip_rate);
  };
  // Newton's law: a sliding contact's margin from its held (sticking) answer.
  const HeldMargins held =
      rigidHeldMargins(prepared, derivatives, contact_bodies, columns, options, start);
  auto bound_of = [&](std::size_t c) {
    return rigidStaticBound(prepared.meanScene(), contact_bodies, result, c);
  };
  linearSpread(*jacobian, derivatives.velocityCount(), result.impulses, derivatives.contacts,
               prepared, slip_of, bound_of, geometry ? &geometry->slip_speed : nullptr, &held,
               options.law, outcome);
  if (geometry)
    for (Warning& warning : geometry->warnings) outcome.warnings.push_back(std::move(warning));
  addNewWarnings(held.warnings, outcome.warnings);
  return outcome;
}

double quantile(std::vector<double>& sorted, double p) {
  const double h = p * static_cast<double>(sorted.size() - 1);
  const auto low = static_cast<std::size_t>(std::floor(h));
  const std::size_t high = std::min(low + 1, sorted.size() - 1);
  return sorted[low] + (h - static_cast<double>(low)) * (sorted[high] - sorted[low]);
}

// The coefficients of sample i: per uncertain contact (prepared.contacts order) e, mu_s, mu_d; a
// mu_d over mu_s is capped there and flagged in `capped` (one entry per uncertain contact).
std::array<double, 3> drawCoefficients(const UncertainContact& uncertain,
                                       const HaltonSequence& sequence, std::size_t i,
                                       unsigned char& capped) {
  std::array<double, 3> drawn;
  for (int which = 0; which < 3; ++which) {
    const int dimension = uncertain.dimension[which];
    drawn[which] = dimension < 0
                       ? uncertain.distributions[which].mean()
                       : uncertain.distributions[which].quantile(sequence.coordinate(i, dimension));
  }
  if (drawn[kDynamicFriction] > drawn[kStaticFriction]) {
    drawn[kDynamicFriction] = drawn[kStaticFriction];
    capped = 1;
  }
  return drawn;
}

// The normal and point of sample i of an uncertain contact (UncertainContact): the scrambled
// Halton coordinates of its dimensions (after the `offset` coefficient dimensions) through the
// standard normal's quantile, scaled by the spreads; normal = normalize(n + a t1 + b t2).
DrawnGeometry drawGeometry(const UncertainContact& uncertain, const HaltonSequence& sequence,
                           std::size_t i, std::size_t offset) {
  DrawnGeometry drawn{uncertain.normal, uncertain.point};
  auto normal = [&](int dimension) {
    return standardNormalQuantile(
        sequence.coordinate(i, offset + static_cast<std::size_t>(dimension)));
  };
  if (uncertain.normal_dimension >= 0) {
    const double a = uncertain.normal_std_dev * normal(uncertain.normal_dimension);
    const double b = uncertain.normal_std_dev * normal(uncertain.normal_dimension + 1);
    drawn.normal =
        (uncertain.normal + a * uncertain.tangent1 + b * uncertain.tangent2).normalized();
  }
  for (int axis = 0; axis < 3; ++axis)
    if (uncertain.point_dimension[axis] >= 0)
      drawn.point[axis] += uncertain.point_std_dev[axis] * normal(uncertain.point_dimension[axis]);
  return drawn;
}

// Mean, covariance (N - 1), quantiles of `values` (one column per sample), the stick fractions
// (`sticking`: sample-major, one entry per contact) and the capping warnings, into `outcome`.
void summariseSamples(const Eigen::MatrixXd& values, const std::vector<unsigned char>& sticking,
                      std::size_t contacts, const std::vector<unsigned char>& capped,
                      const Prepared& prepared, OutcomeDistribution& outcome) {
  const Eigen::Index m = values.rows();
  const Eigen::Index n = values.cols();
  const auto samples = static_cast<std::size_t>(n);
  outcome.method = UncertaintyMethod::kSampled;
  outcome.samples = samples;
  outcome.mean = values.rowwise().mean();
  const Eigen::MatrixXd centred = values.colwise() - outcome.mean;
  outcome.covariance = n > 1 ? Eigen::MatrixXd(centred * centred.transpose() / double(n - 1))
                             : Eigen::MatrixXd::Zero(m, m);
  outcome.q05.resize(m);
  outcome.q95.resize(m);
  std::vector<double> row(samples);
  for (Eigen::Index r = 0; r < m; ++r) {
    for (Eigen::Index i = 0; i < n; ++i) row[static_cast<std::size_t>(i)] = values(r, i);
    std::sort(row.begin(), row.end());
    outcome.q05(r) = quantile(row, 0.05);
    outcome.q95(r) = quantile(row, 0.95);
  }
  outcome.stick_probability.assign(contacts, 0.0);
  for (std::size_t i = 0; i < samples; ++i)
    for (std::size_t c = 0; c < contacts; ++c)
      outcome.stick_probability[c] += sticking[i * contacts + c];
  for (double& p : outcome.stick_probability) p /= static_cast<double>(samples);
  outcome.warnings = prepared.warnings;
  for (std::size_t u = 0; u < prepared.contacts.size(); ++u) {
    std::size_t count = 0;
    for (std::size_t i = 0; i < samples; ++i) count += capped[i * prepared.contacts.size() + u];
    if (count == 0) continue;
    outcome.warnings.push_back({overlapField(prepared.contacts[u]),
                                "dynamic_friction exceeded static_friction in " +
                                    std::to_string(count) + " of " + std::to_string(samples) +
                                    " samples (" +
                                    percentText(static_cast<double>(count) / samples) +
                                    "): those were solved with mu_d = mu_s",
                                Warning::Kind::kInput});
  }
}

// The outcome's rows (6 per movable body or its velocity unknowns, 4 per contact) and the sampled
// values (rows x samples) an answer may hold: a request over them is refused before anything is
// allocated (the covariance alone is rows^2 doubles).
void checkOutcomeSize(Eigen::Index rows, std::size_t samples) {
  if (rows > kMaxOutcomeRows)
    throw InvalidInput("uncertainties",
                       "the outcome would have " + std::to_string(rows) +
                           " rows (its bodies' velocity unknowns and 4 per contact), over the "
                           "cap of " +
                           std::to_string(kMaxOutcomeRows) +
                           ": ask for the distribution of a smaller scene");
  if (static_cast<double>(rows) * static_cast<double>(samples) >
      static_cast<double>(kMaxSampledValues))
    throw InvalidInput("options.uncertainty_samples",
                       std::to_string(samples) + " samples of " + std::to_string(rows) +
                           " outcome rows exceed the cap of " + std::to_string(kMaxSampledValues) +
                           " sampled values: ask for fewer samples");
}

// The samples of a sampled distribution, as they are solved.
struct SampleStore {
  Eigen::MatrixXd values;               // one column per sample
  std::vector<unsigned char> sticking;  // sample-major, one entry per contact
  std::vector<unsigned char> capped;    // sample-major, one entry per uncertain contact
};

// The one sampling loop of the rigid-body and the general-body paths: the checks of the sample
// count and size, the scrambled Halton points through the coefficients' quantile functions (mu_d
// capped at mu_s and flagged), the time budget, the samples spread over `tasks` tasks on `pool`
// (task t: a contiguous range of them). make_solver(t) gives task
// t's solver (its own copy of the problem), called once per sample as solve(i, drawn, geometry,
// options, store): drawn[u] = (e, mu_s, mu_d) of prepared.contacts[u] and, when any contact's
// normal or point is uncertain, geometry[u] its normal and point (else `geometry` is empty), set on
// its copy, solved with `options` (what is left of the budget), written into column i of
// store.values and the sample's entries of store.sticking.
template <class MakeSolver>
SampleStore sampleAll(const Prepared& prepared, const SolverOptions& options,
                      const UncertaintyOptions& uncertainty, Eigen::Index rows,
                      std::size_t contacts, std::size_t tasks, WorkerPool* pool,
                      MakeSolver&& make_solver) {
  const auto start = std::chrono::steady_clock::now();
  const std::size_t dims = prepared.dimensions.size() + prepared.geometry_dimensions;
  if (dims > HaltonSequence::kMaxDimensions)
    throw InvalidInput("uncertainties",
                       "the sampled method takes at most " +
                           std::to_string(HaltonSequence::kMaxDimensions) +
                           " uncertain quantities (with a spread) per request: coefficients, 2 "
                           "per uncertain normal and 1 per uncertain axis of a point; got " +
                           std::to_string(dims));
  const HaltonSequence sequence(dims, uncertainty.seed);
  const std::size_t samples = uncertainty.samples;
  checkOutcomeSize(rows, samples);
  const std::size_t uncertain = prepared.contacts.size();
  SampleStore store;
  store.values.resize(rows, static_cast<Eigen::Index>(samples));
  store.sticking.assign(samples * contacts, 0);
  store.capped.assign(samples * uncertain, 0);
  tasks = std::max<std::size_t>(1, std::min(tasks, samples));
  auto run = [&](std::size_t task) {
    auto solve = make_solver(task);
    std::vector<std::array<double, 3>> drawn(uncertain);
    // Empty unless a normal or a point is uncertain (the coefficients-only loop stays as it was).
    std::vector<DrawnGeometry> geometry(prepared.geometry_dimensions > 0 ? uncertain : 0);
    const std::size_t end = (task + 1) * samples / tasks;
    for (std::size_t i = task * samples / tasks; i < end; ++i) {
      const SolverOptions sample_options = remainingBudget(options, start);
      for (std::size_t u = 0; u < uncertain; ++u)
        drawn[u] =
            drawCoefficients(prepared.contacts[u], sequence, i, store.capped[i * uncertain + u]);
      for (std::size_t u = 0; u < geometry.size(); ++u)
        geometry[u] = drawGeometry(prepared.contacts[u], sequence, i, prepared.dimensions.size());
      solve(i, drawn, geometry, sample_options, store);
    }
  };
  if (pool != nullptr) {
    pool->parallelFor(tasks, run);
  } else {
    for (std::size_t task = 0; task < tasks; ++task) run(task);
  }
  return store;
}

OutcomeDistribution sampledDistribution(const Prepared& prepared, const SolverOptions& options,
                                        const UncertaintyOptions& uncertainty, WorkerPool* pool) {
  const Scene& scene = prepared.meanScene();
  const std::vector<int> movable = movableBodies(scene);
  const std::size_t contacts = scene.contacts.size();
  const Eigen::Index m =
      6 * static_cast<Eigen::Index>(movable.size()) + 4 * static_cast<Eigen::Index>(contacts);
  // A few tasks per thread (the samples' costs differ: some pivot, some do not), each with one
  // copy of the scene whose coefficients it changes in place.
  const std::size_t tasks = 4 * static_cast<std::size_t>(pool != nullptr ? pool->threads() : 1);
  const SampleStore store =
      sampleAll(prepared, options, uncertainty, m, contacts, tasks, pool, [&](std::size_t) {
        return [&, sample = scene](std::size_t i, const std::vector<std::array<double, 3>>& drawn,
                                   const std::vector<DrawnGeometry>& geometry,
                                   const SolverOptions& sample_options, SampleStore& out) mutable {
          for (std::size_t u = 0; u < drawn.size(); ++u) {
            Contact& contact = sample.contacts[prepared.contacts[u].contact];
            for (int which = 0; which < 3; ++which) coefficient(contact, which) = drawn[u][which];
          }
          for (std::size_t u = 0; u < geometry.size(); ++u) {
            Contact& contact = sample.contacts[prepared.contacts[u].contact];
            contact.normal = geometry[u].normal;
            contact.point = geometry[u].point;
          }
          const CollisionResult result =
              computeValidatedResponse(sample, prepared.contact_bodies, sample_options);
          const auto column = static_cast<Eigen::Index>(i);
          fillOutcome(result, movable,
                      [&](Eigen::Index r) -> double& { return out.values(r, column); });
          for (std::size_t c = 0; c < contacts; ++c)
            out.sticking[i * contacts + c] = result.impulses[c].sticking ? 1 : 0;
        };
      });
  OutcomeDistribution outcome;
  summariseSamples(store.values, store.sticking, contacts, store.capped, prepared, outcome);
  outcome.labels = outcomeLabels(movable, contacts);
  return outcome;
}

// A method asked for, and (kSampled) a sample count within the cap.
void checkMethod(const UncertaintyOptions& uncertainty) {
  if (uncertainty.method == UncertaintyMethod::kNone)
    throw InvalidInput("options.uncertainty", "no method: ask for linear or sampled");
  if (uncertainty.method == UncertaintyMethod::kSampled &&
      (uncertainty.samples == 0 || uncertainty.samples > kMaxUncertaintySamples))
    throw InvalidInput("options.uncertainty_samples",
                       "must be in [1, " + std::to_string(kMaxUncertaintySamples) + "], got " +
                           std::to_string(uncertainty.samples));
}

// The labels of computeBodyOutcomeDistribution(): "velocities[r]", then 4 per contact.
std::vector<std::string> bodyOutcomeLabels(Eigen::Index velocity_count, std::size_t contacts) {
  std::vector<std::string> labels;
  labels.reserve(static_cast<std::size_t>(velocity_count) + 4 * contacts);
  for (Eigen::Index r = 0; r < velocity_count; ++r)
    labels.push_back("velocities[" + std::to_string(r) + "]");
  for (std::size_t c = 0; c < contacts; ++c) {
    const std::string impulse = "impulses[" + std::to_string(c) + "].";
    labels.push_back(impulse + "normal_impulse");
    for (const char* axis : {"x", "y", "z"}) labels.push_back(impulse + "friction_impulse." + axis);
  }
  return labels;
}

// The robot path's counterpart of rigidGeometryJacobian(): each difference solves
// computeBodyResponse() from the pre-impact velocities (`restore`) with the contact moved, and
// reads the bodies' velocities after it; the bodies are left at the last solve's velocities.
template <class Restore>
[[gnu::noinline]] GeometryJacobian bodyGeometryJacobian(
    const std::vector<BodyModel*>& bodies, const std::vector<ContactPoint>& mean_contacts,
    const Prepared& prepared, const BodyImpactDerivatives& derivatives, Restore&& restore,
    const SolverOptions& options, std::chrono::steady_clock::time_point start) {
  GeometryJacobian out;
  const Eigen::Index m = derivatives.jacobian.rows();
  const Eigen::Index velocity_count = derivatives.velocity_count;
  const std::size_t count = mean_contacts.size();
  std::vector<ContactPoint> moved = mean_contacts;
  for (ContactPoint& contact : moved) contact.normal.normalize();  // (validated: nonzero)
  auto evaluate = [&](std::size_t u, const Eigen::Vector3d& normal, const Eigen::Vector3d& point,
                      Eigen::VectorXd& values, std::vector<int>& modes) {
    ContactPoint* changed =
        u < prepared.contacts.size() ? &moved[prepared.contacts[u].contact] : nullptr;
    const ContactPoint kept = changed ? *changed : ContactPoint();
    if (changed) {
      changed->normal = normal;
      changed->point = point;
    }
    restore();
    const BodyResponse after = computeBodyResponse(bodies, moved, remainingBudget(options, start));
    fillBodyOutcome(bodies, derivatives.velocity_offset, velocity_count, after.impulses, values);
    slipSpeeds(moved, after.impulses, values.data() + m, modes.data(),
               [&](std::size_t c, Eigen::Vector3d& slip) {
                 addBodySlip(bodies, derivatives.velocity_offset, moved[c], derivatives.jacobian, 0,
                             slip, nullptr);
               });
    if (changed) *changed = kept;
  };
  joinGeometryColumns(derivatives.jacobian,
                      differenceGeometry(prepared, m, count, evaluate, out.warnings), out);
  return out;
}

// heldMargins() for general bodies (computeBodyImpactDerivatives() of the held contacts, every
// column), each solve from the pre-impact velocities (`restore`); the bodies are left at the last
// solve's velocities.
template <class Restore>
[[gnu::noinline]] HeldMargins bodyHeldMargins(const std::vector<BodyModel*>& bodies,
                                              const std::vector<ContactPoint>& mean_contacts,
                                              const Prepared& prepared,
                                              const BodyImpactDerivatives& derivatives,
                                              Restore&& restore, const SolverOptions& options,
                                              std::chrono::steady_clock::time_point start) {
  std::vector<ContactPoint> held = mean_contacts;                  // at the mean geometry
  std::vector<ContactPoint> moved = mean_contacts;                 // every normal unit
  for (ContactPoint& contact : moved) contact.normal.normalize();  // (validated: nonzero)
  auto differentiate = [&](std::size_t c, ContactImpulse& impulse, Eigen::MatrixXd& jacobian,
                           StaticBound& bound) {
    const HeldChange<ContactPoint> change(held, c, nullptr, {}, {});
    restore();
    const Eigen::Vector3d u_before = bodyRelativeVelocity(bodies, held[c]);
    BodyImpactDerivatives at =
        computeBodyImpactDerivatives(bodies, held, remainingBudget(options, start));
    impulse = at.result.impulses[c];
    bound = staticBound(
        at.result.islands, c, held[c].normal, [&] { return u_before; }, impulse);
    jacobian = std::move(at.jacobian);
  };
  auto solve_moved = [&](std::size_t u, const Eigen::Vector3d& normal, const Eigen::Vector3d& point,
                         std::size_t c, std::vector<ContactImpulse>& impulses, StaticBound& bound) {
    const HeldChange<ContactPoint> change(
        moved, c, u < prepared.contacts.size() ? &moved[prepared.contacts[u].contact] : nullptr,
        normal, point);
    restore();
    const Eigen::Vector3d u_before = bodyRelativeVelocity(bodies, moved[c]);
    BodyResponse result = computeBodyResponse(bodies, moved, remainingBudget(options, start));
    bound = staticBound(
        result.islands, c, moved[c].normal, [&] { return u_before; }, result.impulses[c]);
    impulses = std::move(result.impulses);
  };
  return heldMargins(prepared, derivatives.contacts, mean_contacts, derivatives.velocity_count,
                     differentiate, solve_moved);
}

// The linear method for general bodies (docs/uncertainty.md, "Robots"):
// computeBodyImpactDerivatives() at the coefficients' means (prepared.meanScene()'s), mean = its
// prediction, the spread as the rigid-body path's (linearSpread()), the slip of a sliding contact
// from the bodies' point Jacobians at the point (partPointJacobian() times the velocity rows).
// P(|v_r| > limit_r) under the normal approximation N(mean_r, covariance_rr): Phi((-limit - mean) /
// sigma) + Phi((mean - limit) / sigma) (the second is 1 - Phi((limit - mean) / sigma) without its
// cancellation); sigma = 0: 1 when |mean| > limit, else 0. The bodies end at their pre-impact
// velocities (v' + (v - v'), as the sampled path's), also when the call throws.
OutcomeDistribution linearBodyDistribution(const std::vector<BodyModel*>& bodies,
                                           const std::vector<ContactPoint>& contacts,
                                           const Prepared& prepared,
                                           const Eigen::VectorXd& velocity_limits,
                                           const SolverOptions& options) {
  // The call's start: every solve after the mean's (the geometry's differences, the sliding
  // contacts' margins) shares what is left of options.time_budget.
  const auto start = std::chrono::steady_clock::now();
  std::vector<ContactPoint> mean_contacts = contacts;
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const Contact& mean = prepared.meanScene().contacts[c];
    mean_contacts[c].restitution = mean.restitution;
    mean_contacts[c].static_friction = mean.static_friction;
    mean_contacts[c].dynamic_friction = mean.dynamic_friction;
  }
  std::vector<Eigen::VectorXd> before;
  before.reserve(bodies.size());
  for (const BodyModel* body : bodies) before.push_back(body->velocity());
  auto restore = [&] {
    for (std::size_t b = 0; b < bodies.size(); ++b)
      if (bodies[b]->velocityCount() > 0)
        bodies[b]->addVelocityChange(before[b] - bodies[b]->velocity());
  };
  OutcomeDistribution outcome;
  Eigen::Index velocity_count = 0;
  // The contacts' relative velocities before the impact, for their static pyramids (an island the
  // exact solver pivots on: also one contact under SolverMethod::kExact).
  std::vector<Eigen::Vector3d> u_before(contacts.size());
  for (std::size_t c = 0; c < contacts.size(); ++c)
    u_before[c] = bodyRelativeVelocity(bodies, mean_contacts[c]);
  try {
    const BodyImpactDerivatives derivatives =
        computeBodyImpactDerivatives(bodies, mean_contacts, options);
    velocity_count = derivatives.velocity_count;
    const Eigen::Index m = derivatives.jacobian.rows();
    outcome.mean.resize(m);
    // The bodies are at their post-impact velocities: the prediction's, and the slips' base.
    fillBodyOutcome(bodies, derivatives.velocity_offset, velocity_count,
                    derivatives.result.impulses, outcome.mean);
    // An uncertain normal or point: its columns by differences of the solver, after the
    // coefficients'; the bodies then go back to the prediction's velocities (slip_of() reads them).
    auto toPrediction = [&] {
      for (std::size_t b = 0; b < bodies.size(); ++b)
        if (derivatives.velocity_offset[b] >= 0)
          bodies[b]->addVelocityChange(
              outcome.mean.segment(derivatives.velocity_offset[b], bodies[b]->velocityCount()) -
              bodies[b]->velocity());
    };
    std::optional<GeometryJacobian> geometry;
    if (!prepared.geometry.empty()) {
      geometry = bodyGeometryJacobian(bodies, mean_contacts, prepared, derivatives, restore,
                                      options, start);
      toPrediction();
    }
    const Eigen::MatrixXd* jacobian = geometry ? &geometry->jacobian : &derivatives.jacobian;
    auto slip_of = [&](std::size_t c, Eigen::Vector3d& slip, Eigen::MatrixXd& slip_rate) {
      addBodySlip(bodies, derivatives.velocity_offset, mean_contacts[c], *jacobian, 0, slip,
                  &slip_rate);
    };
    // Newton's law: a sliding contact's margin from its held (sticking) answer; the bodies then
    // go back to the prediction's velocities too.
    std::optional<HeldMargins> held;
    if (options.law == ImpactLaw::kNewton && anySliding(derivatives.contacts, mean_contacts)) {
      held = bodyHeldMargins(bodies, mean_contacts, prepared, derivatives, restore, options, start);
      toPrediction();
    }
    auto bound_of = [&](std::size_t c) {
      return staticBound(
          derivatives.result.islands, c, mean_contacts[c].normal, [&] { return u_before[c]; },
          derivatives.result.impulses[c]);
    };
    linearSpread(*jacobian, velocity_count, derivatives.result.impulses, derivatives.contacts,
                 prepared, slip_of, bound_of, geometry ? &geometry->slip_speed : nullptr,
                 held ? &*held : nullptr, options.law, outcome);
    if (geometry)
      for (Warning& warning : geometry->warnings) outcome.warnings.push_back(std::move(warning));
    if (held) addNewWarnings(held->warnings, outcome.warnings);
  } catch (...) {
    restore();
    throw;
  }
  restore();
  outcome.labels = bodyOutcomeLabels(velocity_count, contacts.size());
  outcome.limit_probability.assign(static_cast<std::size_t>(velocity_count), 0.0);
  for (Eigen::Index r = 0; r < velocity_count; ++r) {
    const double limit = velocity_limits(r);
    if (std::isinf(limit)) continue;  // no limit: never exceeded
    const double mu = outcome.mean(r);
    const double sigma = std::sqrt(outcome.covariance(r, r));
    outcome.limit_probability[static_cast<std::size_t>(r)] =
        sigma == 0.0
            ? (std::abs(mu) > limit ? 1.0 : 0.0)
            : standardNormalCdf((-limit - mu) / sigma) + standardNormalCdf((mu - limit) / sigma);
  }
  return outcome;
}

}  // namespace

OutcomeDistribution computeOutcomeDistribution(const Scene& scene,
                                               const std::vector<ContactUncertainty>& uncertainties,
                                               const SolverOptions& options,
                                               const UncertaintyOptions& uncertainty,
                                               WorkerPool* pool, const RequestLimits& limits) {
  checkMethod(uncertainty);
  Prepared prepared = prepare(scene, uncertainties);
  if (uncertainty.method == UncertaintyMethod::kLinear) {
    checkOutcomeSize(6 * movableCount(prepared.meanScene()) +
                         4 * static_cast<Eigen::Index>(prepared.meanScene().contacts.size()),
                     1);
    return linearDistribution(prepared, options, limits);
  }
  prepared.contact_bodies = validate(prepared.meanScene(), options, limits);
  return sampledDistribution(prepared, options, uncertainty, pool);
}

OutcomeDistribution computeBodyOutcomeDistribution(
    const std::vector<std::vector<BodyModel*>>& copies, const std::vector<ContactPoint>& contacts,
    const std::vector<ContactUncertainty>& uncertainties, const Eigen::VectorXd& velocity_limits,
    const SolverOptions& options, const UncertaintyOptions& uncertainty, WorkerPool* pool) {
  checkMethod(uncertainty);
  if (copies.empty()) throw std::invalid_argument("computeBodyOutcomeDistribution: no copies");
  const std::size_t body_count = copies.front().size();
  std::vector<int> offset(body_count, -1);
  Eigen::Index velocity_count = 0;
  for (std::size_t b = 0; b < body_count; ++b) {
    const int count = copies.front()[b]->velocityCount();
    if (count > 0) {
      offset[b] = static_cast<int>(velocity_count);
      velocity_count += count;
    }
  }
  for (const std::vector<BodyModel*>& set : copies)
    if (set.size() != body_count)
      throw std::invalid_argument("computeBodyOutcomeDistribution: copies differ in size");
  if (velocity_limits.size() != velocity_count)
    throw std::invalid_argument("computeBodyOutcomeDistribution: one velocity limit per unknown");

  // The coefficients through the rigid-body path's checks (only the contacts matter to them).
  Scene coefficients;
  coefficients.contacts.resize(contacts.size());
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    coefficients.contacts[c].restitution = contacts[c].restitution;
    coefficients.contacts[c].static_friction = contacts[c].static_friction;
    coefficients.contacts[c].dynamic_friction = contacts[c].dynamic_friction;
    coefficients.contacts[c].normal = contacts[c].normal;
    coefficients.contacts[c].point = contacts[c].point;
  }
  const Prepared prepared = prepare(coefficients, uncertainties);
  const std::size_t contact_count = contacts.size();
  const Eigen::Index m = velocity_count + 4 * static_cast<Eigen::Index>(contact_count);
  if (uncertainty.method == UncertaintyMethod::kLinear) {
    checkOutcomeSize(m, 1);
    return linearBodyDistribution(copies.front(), contacts, prepared, velocity_limits, options);
  }
  // One task per set of copies (each set is used by one task at a time).
  const SampleStore store = sampleAll(
      prepared, options, uncertainty, m, contact_count, copies.size(), pool, [&](std::size_t part) {
        const std::vector<BodyModel*>& bodies = copies[part];
        std::vector<Eigen::VectorXd> before;
        before.reserve(body_count);
        for (const BodyModel* body : bodies) before.push_back(body->velocity());
        return [&, before, sample = contacts](
                   std::size_t i, const std::vector<std::array<double, 3>>& drawn,
                   const std::vector<DrawnGeometry>& geometry, const SolverOptions& sample_options,
                   SampleStore& out) mutable {
          auto restore = [&] {
            for (std::size_t b = 0; b < body_count; ++b)
              if (offset[b] >= 0) bodies[b]->addVelocityChange(before[b] - bodies[b]->velocity());
          };
          for (std::size_t u = 0; u < drawn.size(); ++u) {
            ContactPoint& contact = sample[prepared.contacts[u].contact];
            contact.restitution = drawn[u][kRestitution];
            contact.static_friction = drawn[u][kStaticFriction];
            contact.dynamic_friction = drawn[u][kDynamicFriction];
          }
          for (std::size_t u = 0; u < geometry.size(); ++u) {
            ContactPoint& contact = sample[prepared.contacts[u].contact];
            contact.normal = geometry[u].normal;
            contact.point = geometry[u].point;
          }
          BodyResponse result;
          try {
            result = computeBodyResponse(bodies, sample, sample_options);
          } catch (...) {
            restore();
            throw;
          }
          const auto column = static_cast<Eigen::Index>(i);
          for (std::size_t b = 0; b < body_count; ++b)
            if (offset[b] >= 0)
              out.values.block(offset[b], column, bodies[b]->velocityCount(), 1) =
                  bodies[b]->velocity();
          Eigen::Index r = velocity_count;
          for (std::size_t c = 0; c < contact_count; ++c) {
            const ContactImpulse& impulse = result.impulses[c];
            out.values(r++, column) = impulse.normal_impulse;
            out.values(r++, column) = impulse.friction_impulse.x();
            out.values(r++, column) = impulse.friction_impulse.y();
            out.values(r++, column) = impulse.friction_impulse.z();
            out.sticking[i * contact_count + c] = impulse.sticking ? 1 : 0;
          }
          restore();
        };
      });
  const Eigen::MatrixXd& values = store.values;
  const auto n = static_cast<Eigen::Index>(uncertainty.samples);

  OutcomeDistribution outcome;
  summariseSamples(values, store.sticking, contact_count, store.capped, prepared, outcome);
  outcome.labels = bodyOutcomeLabels(velocity_count, contact_count);
  outcome.limit_probability.assign(static_cast<std::size_t>(velocity_count), 0.0);
  for (Eigen::Index r = 0; r < velocity_count; ++r) {
    std::size_t over = 0;
    for (Eigen::Index i = 0; i < n; ++i) over += std::abs(values(r, i)) > velocity_limits(r);
    outcome.limit_probability[static_cast<std::size_t>(r)] =
        static_cast<double>(over) / static_cast<double>(uncertainty.samples);
  }
  return outcome;
}

}  // namespace collision_response::core
