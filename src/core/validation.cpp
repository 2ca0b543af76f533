#include "collision_response/core/validation.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "collision_response/core/errors.h"

namespace collision_response::core {
namespace {

// "array[i]", written into a buffer and made a string once (no temporaries: this runs for every
// body and contact of every request). The array names are short literals ("bodies", "contacts").
std::string indexed(const char* array, std::size_t i) {
  char text[64];
  const std::size_t length = std::strlen(array);
  if (length > 32) return std::string(array) + "[" + std::to_string(i) + "]";
  std::memcpy(text, array, length);
  text[length] = '[';
  char* end = std::to_chars(text + length + 1, text + sizeof text - 1, i).ptr;
  *end++ = ']';
  return std::string(text, end);
}

std::string describe(double value) {
  std::ostringstream out;
  out.precision(17);
  out << value;
  return out.str();
}

// The checks take the field's name in pieces (base + suffix + detail) and join them only to
// report a failure: a valid request builds no strings (validation runs on every call).
void requireFinite(double value, const std::string& base, const char* suffix,
                   const char* detail = "") {
  if (!std::isfinite(value)) {
    throw InvalidInput(base + suffix + detail, "is not a finite number (" + describe(value) + ")");
  }
}

void requireFinite(const Eigen::Vector3d& v, const std::string& base, const char* suffix) {
  static const char* const kAxes[] = {".x", ".y", ".z"};
  for (int i = 0; i < 3; ++i) requireFinite(v[i], base, suffix, kAxes[i]);
}

void requireAtMost(const Eigen::Vector3d& v, double limit, const char* unit,
                   const std::string& base, const char* suffix) {
  if (v.norm() > limit) {
    throw InvalidInput(base + suffix, "magnitude " + describe(v.norm()) + " " + unit +
                                          " exceeds the accepted " + describe(limit) + " " + unit);
  }
}

// Returns the smallest principal moment [kg m^2].
double validateInertia(const Eigen::Matrix3d& inertia, std::size_t body_index) {
  const auto field = [&] { return indexed("bodies", body_index) + ".inertia"; };
  if (!inertia.isApprox(inertia.transpose(), 1e-12))
    throw InvalidInput(field(), "is not symmetric");
  Eigen::Vector3d moments;  // ascending
  if (inertia(0, 1) == 0.0 && inertia(0, 2) == 0.0 && inertia(1, 2) == 0.0) {
    moments = inertia.diagonal();  // principal axes given (a box, a cylinder): no solve
    std::sort(moments.data(), moments.data() + 3);
  } else {
    moments = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(inertia, Eigen::EigenvaluesOnly)
                  .eigenvalues();
  }
  const double scale = moments.cwiseAbs().maxCoeff();
  if (!(moments[0] > 1e-12 * scale) || scale == 0.0) {
    throw InvalidInput(field(), "is not positive definite (principal moments " +
                                    describe(moments[0]) + ", " + describe(moments[1]) + ", " +
                                    describe(moments[2]) + ")");
  }
  if (moments[0] < MagnitudeLimits::kInertia[0] || moments[2] > MagnitudeLimits::kInertia[1]) {
    throw InvalidInput(field(), "principal moments " + describe(moments[0]) + " .. " +
                                    describe(moments[2]) + " kg m^2 leave the accepted range [" +
                                    describe(MagnitudeLimits::kInertia[0]) + ", " +
                                    describe(MagnitudeLimits::kInertia[1]) + "]");
  }
  if (moments[0] + moments[1] < moments[2] * (1.0 - 1e-9)) {
    throw InvalidInput(field(), "violates the triangle inequality of principal moments (" +
                                    describe(moments[0]) + " + " + describe(moments[1]) + " < " +
                                    describe(moments[2]) + ")");
  }
  return moments[0];
}

// Whether every number of `body` is finite and within the accepted magnitudes, its orientation a
// unit quaternion: the common case, decided without building a field's name (validateBody() names
// what fails).
bool plainBody(const BodyState& body) {
  const auto within = [](const Eigen::Vector3d& v, double limit) {
    return v.allFinite() && v.squaredNorm() <= limit * limit;
  };
  const double q_norm = body.orientation.coeffs().norm();
  return !body.id.empty() && std::isfinite(body.mass) && body.inertia.allFinite() &&
         (body.mass == 0.0 ||
          (body.mass >= MagnitudeLimits::kMass[0] && body.mass <= MagnitudeLimits::kMass[1])) &&
         within(body.com, MagnitudeLimits::kLength) &&
         within(body.position, MagnitudeLimits::kLength) &&
         within(body.linear_velocity, MagnitudeLimits::kSpeed) &&
         within(body.angular_velocity, MagnitudeLimits::kSpeed) &&
         within(body.force, MagnitudeLimits::kForce) &&
         within(body.torque, MagnitudeLimits::kForce) && std::isfinite(q_norm) &&
         std::abs(q_norm - 1.0) <= kUnitTolerance;
}

// Returns the smallest principal moment [kg m^2] of a movable body, 0 for an immovable one.
double validateBody(const BodyState& body, std::size_t index) {
  if (plainBody(body)) {
    if (body.immovable()) return 0.0;
    // The inertia's own checks (symmetry, principal moments) name the body only if they fail.
    return validateInertia(body.inertia, index);
  }
  const std::string field = indexed("bodies", index);
  if (body.id.empty()) throw InvalidInput(field + ".id", "is empty");
  requireFinite(body.mass, field, ".inertia.m");
  requireFinite(body.com, field, ".inertia.com");
  static const char* const kInertia[3][3] = {
      {"ixx", "ixy", "ixz"}, {"ixy", "iyy", "iyz"}, {"ixz", "iyz", "izz"}};
  for (int r = 0; r < 3; ++r) {
    for (int c = r; c < 3; ++c)
      requireFinite(body.inertia(r, c), field, ".inertia.", kInertia[r][c]);
  }
  requireFinite(body.position, field, ".pose.position");
  const Eigen::Vector4d q = body.orientation.coeffs();
  static const char* const kQuaternion[] = {".x", ".y", ".z", ".w"};
  for (int i = 0; i < 4; ++i) requireFinite(q[i], field, ".pose.orientation", kQuaternion[i]);
  requireFinite(body.linear_velocity, field, ".twist.linear");
  requireFinite(body.angular_velocity, field, ".twist.angular");
  requireFinite(body.force, field, ".wrench.force");
  requireFinite(body.torque, field, ".wrench.torque");

  if (body.mass < 0.0)
    throw InvalidInput(field + ".inertia.m", "is negative (" + describe(body.mass) + " kg)");
  if (body.mass != 0.0 &&
      (body.mass < MagnitudeLimits::kMass[0] || body.mass > MagnitudeLimits::kMass[1])) {
    throw InvalidInput(field + ".inertia.m",
                       describe(body.mass) + " kg leaves the accepted range [" +
                           describe(MagnitudeLimits::kMass[0]) + ", " +
                           describe(MagnitudeLimits::kMass[1]) + "] (0 = immovable)");
  }
  requireAtMost(body.com, MagnitudeLimits::kLength, "m", field, ".inertia.com");
  requireAtMost(body.position, MagnitudeLimits::kLength, "m", field, ".pose.position");
  requireAtMost(body.linear_velocity, MagnitudeLimits::kSpeed, "m/s", field, ".twist.linear");
  requireAtMost(body.angular_velocity, MagnitudeLimits::kSpeed, "rad/s", field, ".twist.angular");
  requireAtMost(body.force, MagnitudeLimits::kForce, "N", field, ".wrench.force");
  requireAtMost(body.torque, MagnitudeLimits::kForce, "N m", field, ".wrench.torque");
  const double q_norm = q.norm();
  if (q_norm == 0.0) throw InvalidInput(field + ".pose.orientation", "is a zero quaternion");
  if (std::abs(q_norm - 1.0) > kUnitTolerance) {
    throw InvalidInput(field + ".pose.orientation",
                       "is not a unit quaternion (norm " + describe(q_norm) + ")");
  }
  // Reached only where plainBody() and the checks above round a limit differently.
  return body.immovable() ? 0.0 : validateInertia(body.inertia, index);
}

// Rejects a contact whose lever arm on a movable body is beyond MagnitudeLimits::kLeverOverGyration
// times the body's smallest radius of gyration.
void checkLeverArm(const BodyState& body, std::size_t body_index, double smallest_moment,
                   const Eigen::Vector3d& point, const std::string& contact_field) {
  if (body.immovable()) return;
  const double lever = (point - body.worldCom()).norm();
  const double gyration = std::sqrt(smallest_moment / body.mass);
  if (lever > MagnitudeLimits::kLeverOverGyration * gyration) {
    throw InvalidInput(contact_field + ".point",
                       "lies " + describe(lever) + " m from the centre of mass of " +
                           indexed("bodies", body_index) + " ('" + body.id + "'), more than " +
                           describe(MagnitudeLimits::kLeverOverGyration) +
                           " times its smallest radius of gyration (" + describe(gyration) +
                           " m): the impact would be computed without precision");
  }
}

}  // namespace

void validateCoefficients(double restitution, double static_friction, double dynamic_friction,
                          const std::string& field) {
  requireFinite(restitution, field, ".restitution");
  requireFinite(static_friction, field, ".static_friction");
  requireFinite(dynamic_friction, field, ".dynamic_friction");
  if (restitution < 0.0 || restitution > 1.0) {
    throw InvalidInput(field + ".restitution",
                       "must lie in [0, 1] (" + describe(restitution) + ")");
  }
  if (static_friction < 0.0) {
    throw InvalidInput(field + ".static_friction",
                       "is negative (" + describe(static_friction) + ")");
  }
  if (dynamic_friction < 0.0) {
    throw InvalidInput(field + ".dynamic_friction",
                       "is negative (" + describe(dynamic_friction) + ")");
  }
  if (dynamic_friction > static_friction) {
    throw InvalidInput(field + ".dynamic_friction", "exceeds static_friction (" +
                                                        describe(dynamic_friction) + " > " +
                                                        describe(static_friction) + ")");
  }
}

namespace {

// The values every contact is checked for, whichever request it comes in (a Scene's Contact, a
// ContactPoint): finite point within the length limit, finite non-zero normal of unit length within
// kUnitTolerance, coefficients. `field()` gives "contacts[i]", built only to name an error.
template <typename Field>
void checkContactValues(const Eigen::Vector3d& point, const Eigen::Vector3d& normal,
                        double restitution, double static_friction, double dynamic_friction,
                        const Field& field) {
  if (!point.allFinite()) requireFinite(point, field(), ".point");
  if (!normal.allFinite()) requireFinite(normal, field(), ".normal");
  if (point.squaredNorm() > MagnitudeLimits::kLength * MagnitudeLimits::kLength) {
    requireAtMost(point, MagnitudeLimits::kLength, "m", field(), ".point");
  }
  const double n_norm = normal.norm();
  if (n_norm == 0.0) throw InvalidInput(field() + ".normal", "is a zero vector");
  if (std::abs(n_norm - 1.0) > kUnitTolerance) {
    throw InvalidInput(field() + ".normal", "is not a unit vector (norm " + describe(n_norm) + ")");
  }
  // The common case without building the field's name; validateCoefficients() names the error.
  if (!(restitution >= 0.0 && restitution <= 1.0 && static_friction >= 0.0 &&
        std::isfinite(static_friction) && dynamic_friction >= 0.0 &&
        dynamic_friction <= static_friction)) {
    validateCoefficients(restitution, static_friction, dynamic_friction, field());
  }
}

}  // namespace

void validateContactPoints(const std::vector<BodyModel*>& bodies,
                           const std::vector<ContactPoint>& contacts) {
  const int count = static_cast<int>(bodies.size());
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const ContactPoint& contact = contacts[c];
    const auto field = [c] { return indexed("contacts", c); };
    if (contact.body_a < 0 || contact.body_a >= count || bodies[contact.body_a] == nullptr) {
      throw InvalidInput(field() + ".body_a", "no body " + std::to_string(contact.body_a));
    }
    if (contact.body_b < 0 || contact.body_b >= count || bodies[contact.body_b] == nullptr) {
      throw InvalidInput(field() + ".body_b", "no body " + std::to_string(contact.body_b));
    }
    // Two parts of one body (two links of a robot) may touch; one part cannot touch itself.
    if (contact.body_a == contact.body_b &&
        (contact.part_a == contact.part_b || bodies[contact.body_a]->asRigidBody() != nullptr)) {
      throw InvalidInput(field() + ".body_b",
                         contact.part_a == contact.part_b && contact.part_a >= 0
                             ? "a contact of a part with itself"
                             : "a contact of a body with itself");
    }
    checkContactValues(contact.point, contact.normal, contact.restitution, contact.static_friction,
                       contact.dynamic_friction, field);
  }
}

void checkSize(std::size_t body_count, std::size_t contact_count, const RequestLimits& limits) {
  if (body_count > limits.max_bodies) {
    throw InvalidInput("bodies", std::to_string(body_count) + " bodies exceed the limit of " +
                                     std::to_string(limits.max_bodies));
  }
  if (contact_count > limits.max_contacts) {
    throw InvalidInput("contacts", std::to_string(contact_count) +
                                       " contacts exceed the limit of " +
                                       std::to_string(limits.max_contacts));
  }
}

void checkGeometrySize(std::size_t shapes, std::size_t mesh_vertices, std::size_t mesh_triangles,
                       const RequestLimits& limits) {
  const auto check = [](std::size_t count, std::size_t limit, const char* what) {
    if (count > limit) {
      throw InvalidInput("bodies", std::to_string(count) + " " + what + " exceed the limit of " +
                                       std::to_string(limit));
    }
  };
  check(shapes, limits.max_shapes, "collision shapes");
  check(mesh_vertices, limits.max_mesh_vertices, "mesh vertices");
  check(mesh_triangles, limits.max_mesh_triangles, "mesh triangles");
}

std::string OptionRange::text() const {
  return (min_exclusive ? "(" : "[") + describe(min) + ", " + describe(max) + "]";
}

namespace {

[[noreturn, gnu::cold]] void throwOutOfRange(double value, const OptionRange& range,
                                             const std::string& field, const char* unit) {
  const std::string units = *unit ? std::string(" ") + unit : std::string();
  throw InvalidInput(field, "must lie in " + range.text() + units + " (" + describe(value) + ")");
}

// requireInRange() for a literal field name, made a string only to report a failure (the option
// names are longer than a short string: each would be a heap allocation on every request).
void requireOptionInRange(double value, const OptionRange& range, const char* field,
                          const char* unit = "") {
  if (!(std::isfinite(value) && range.contains(value))) throwOutOfRange(value, range, field, unit);
}

}  // namespace

void requireInRange(double value, const OptionRange& range, const std::string& field,
                    const char* unit) {
  if (!(std::isfinite(value) && range.contains(value))) throwOutOfRange(value, range, field, unit);
}

SceneValidator::SceneValidator(const Scene& scene, const SolverOptions& options,
                               const RequestLimits& limits)
    : SceneValidator(scene.bodies, scene.contacts.size(), options, limits) {}

SceneValidator::SceneValidator(const std::vector<BodyState>& bodies, std::size_t contact_count,
                               const SolverOptions& options, const RequestLimits& limits)
    : limits_(limits), smallest_moments_(bodies.size()) {
  checkSize(bodies.size(), contact_count, limits);
  requireOptionInRange(options.tolerance, option_ranges::kTolerance, "options.tolerance");
  requireOptionInRange(options.integration_tolerance, option_ranges::kIntegrationTolerance,
                       "options.integration_tolerance");
  requireOptionInRange(options.resting_velocity, option_ranges::kRestingVelocity,
                       "options.resting_velocity", "m/s");
  requireOptionInRange(options.time_budget, option_ranges::kTimeBudget, "options.time_budget", "s");
  requireOptionInRange(static_cast<double>(options.max_iterations), option_ranges::kMaxIterations,
                       "options.max_iterations");

  body_count_ = bodies.size();
  ids_.reserve(bodies.size());
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    smallest_moments_[i] = validateBody(bodies[i], i);
    const int earlier = addId(bodies[i].id);
    if (earlier >= 0) {
      throw InvalidInput(indexed("bodies", i) + ".id", "'" + bodies[i].id + "' duplicates bodies[" +
                                                           std::to_string(earlier) + "].id");
    }
  }
}

int SceneValidator::indexOf(const std::string& id) const {
  if (ids_.size() <= kScannedIds) {
    for (std::size_t k = 0; k < ids_.size(); ++k) {
      if (ids_[k] == id) return static_cast<int>(k);
    }
    return -1;
  }
  const auto it = index_of_.find(id);
  return it == index_of_.end() ? -1 : it->second;
}

int SceneValidator::addId(const std::string& id) {
  const int earlier = indexOf(id);
  if (earlier >= 0) return earlier;
  ids_.push_back(id);
  if (ids_.size() == kScannedIds + 1) {
    // From now on looked up by hash: the table is made of every id so far.
    index_of_.reserve(2 * ids_.size());
    for (std::size_t k = 0; k < ids_.size(); ++k) index_of_.emplace(ids_[k], static_cast<int>(k));
  } else if (ids_.size() > kScannedIds + 1) {
    index_of_.emplace(id, static_cast<int>(ids_.size() - 1));
  }
  return -1;
}

void SceneValidator::addOtherBodyIds(const std::vector<std::string>& ids) {
  for (const std::string& id : ids) {
    const int earlier = addId(id);
    if (earlier >= 0) {
      if (earlier < static_cast<int>(body_count_)) {
        throw InvalidInput(indexed("bodies", static_cast<std::size_t>(earlier)) + ".id",
                           "'" + id + "' is also the name of a robot's link");
      }
      throw InvalidInput("bodies", "body id '" + id + "' given twice");
    }
  }
}

void SceneValidator::checkContacts(const Scene& scene) {
  checkSize(scene.bodies.size(), scene.contacts.size(), limits_);
  contact_bodies_.reserve(scene.contacts.size());
  for (std::size_t i = contact_bodies_.size(); i < scene.contacts.size(); ++i) {
    const Contact& contact = scene.contacts[i];
    const std::string field = indexed("contacts", i);
    const auto find = [&](const std::string& id, const char* name) {
      const int index = indexOf(id);
      if (index < 0) throw InvalidInput(field + "." + name, "names unknown body id '" + id + "'");
      return index;
    };
    const int a = find(contact.body_a, "body_a");
    const int b = find(contact.body_b, "body_b");
    checkContact(scene, i, field, a, b);
  }
}

void SceneValidator::checkContacts(const Scene& scene,
                                   const std::vector<std::pair<int, int>>& bodies) {
  checkSize(scene.bodies.size(), scene.contacts.size(), limits_);
  const std::size_t first = contact_bodies_.size();
  if (bodies.size() != scene.contacts.size() - first) {
    throw std::invalid_argument("SceneValidator::checkContacts: " + std::to_string(bodies.size()) +
                                " body pairs for " + std::to_string(scene.contacts.size() - first) +
                                " contacts");
  }
  contact_bodies_.reserve(scene.contacts.size());
  const int known = static_cast<int>(ids_.size());
  for (std::size_t i = first; i < scene.contacts.size(); ++i) {
    const std::string field = indexed("contacts", i);
    const auto [a, b] = bodies[i - first];
    if (a < 0 || a >= known)
      throw InvalidInput(field + ".body_a", "names no body (index " + std::to_string(a) + ")");
    if (b < 0 || b >= known)
      throw InvalidInput(field + ".body_b", "names no body (index " + std::to_string(b) + ")");
    checkContact(scene, i, field, a, b);
  }
}

void SceneValidator::checkContact(const Scene& scene, std::size_t i, const std::string& field,
                                  int a, int b) {
  const Contact& contact = scene.contacts[i];
  if (a == b)
    throw InvalidInput(field + ".body_b", "is the same body as body_a ('" + contact.body_a + "')");
  const int n = static_cast<int>(body_count_);
  if (a < n && b < n && scene.bodies[a].immovable() && scene.bodies[b].immovable()) {
    throw InvalidInput(
        field, "both bodies ('" + contact.body_a + "', '" + contact.body_b + "') are immovable");
  }
  checkContactValues(contact.point, contact.normal, contact.restitution, contact.static_friction,
                     contact.dynamic_friction, [&field]() -> const std::string& { return field; });
  if (a < n) checkLeverArm(scene.bodies[a], a, smallest_moments_[a], contact.point, field);
  if (b < n) checkLeverArm(scene.bodies[b], b, smallest_moments_[b], contact.point, field);
  contact_bodies_.emplace_back(a, b);
}

std::vector<std::pair<int, int>> validate(const Scene& scene, const SolverOptions& options,
                                          const RequestLimits& limits) {
  SceneValidator validator(scene, options, limits);
  validator.checkContacts(scene);
  return std::move(validator).releaseContactBodies();
}

}  // namespace collision_response::core
