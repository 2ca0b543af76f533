#pragma once

#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "collision_response/core/body_model.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/option_ranges.h"
#include "collision_response/core/scene.h"
#include "collision_response/core/solver_options.h"

namespace collision_response::core {

/// Tolerance on |q| - 1 for orientations and on |n| - 1 for contact normals, the one unit-length
/// tolerance of every request (a Scene's contacts and bodies, computeBodyResponse()'s
/// ContactPoints): within it the value is normalised, beyond it the request is rejected. Loose
/// enough for a normal or quaternion written with a few digits or sent as float32, tight enough
/// that a wrong vector (a zero component lost, a sign error) is caught.
constexpr double kUnitTolerance = 1e-3;

/// Accepted magnitudes; beyond them a request is rejected, naming the field. Physical scenes stay
/// many orders of magnitude inside (1 g against 1000 t, 1e4 m/s, 1e5 m from the origin), and every
/// product the solvers form (r^2 / I in K and its 3x3 determinant, m v^2) stays far from overflow.
struct MagnitudeLimits {
  static constexpr double kMass[2] = {1e-15, 1e15};     ///< [kg], movable bodies (0 = immovable)
  static constexpr double kInertia[2] = {1e-30, 1e30};  ///< [kg m^2], principal moments
  static constexpr double kLength = 1e7;                ///< [m], |position|, |com|, |point|
  static constexpr double kSpeed = 1e7;                 ///< [m/s] and [rad/s]
  static constexpr double kForce = 1e18;                ///< [N] and [N m]
  static constexpr double kAcceleration = 1e9;          ///< [m/s^2], a robot's gravity
  /// Largest lever arm of a contact over the smallest radius of gyration of its body, |r| / k_min
  /// with k_min^2 = I_min / m. The contact-space matrix K holds terms up to |r|^2 / I_min next to
  /// 1 / m: past (1e6)^2 its round-off exceeds 1 / m and n^T K n loses even its sign.
  static constexpr double kLeverOverGyration = 1e6;
};

/// Throws InvalidInput naming `field` unless `value` is finite and inside `range`
/// (option_ranges.h); `unit` (e.g. "m", "s") is named in the message.
void requireInRange(double value, const OptionRange& range, const std::string& field,
                    const char* unit = "");

/// Checks a contact's (or a material's) coefficients: finite, e in [0, 1], 0 <= mu_d <= mu_s.
/// Throws InvalidInput naming `field` + ".restitution", ".static_friction" or ".dynamic_friction".
void validateCoefficients(double restitution, double static_friction, double dynamic_friction,
                          const std::string& field);

/// The contacts of computeBodyResponse() (body indices into `bodies`): every index names a body
/// (not nullptr), a contact of one body with itself only between two different parts of a body
/// that is not a free rigid body (two links of a robot), and the values every contact is checked
/// for, a Scene's too (SceneValidator::checkContacts(), the same code and texts): a finite point
/// within MagnitudeLimits::kLength, a finite, non-zero normal of unit length within
/// kUnitTolerance, coefficients as validateCoefficients(). Throws InvalidInput naming
/// "contacts[i].<field>" (body_a, body_b, point, normal, restitution, static_friction,
/// dynamic_friction) for the first offending contact.
void validateContactPoints(const std::vector<BodyModel*>& bodies,
                           const std::vector<ContactPoint>& contacts);

/// Throws InvalidInput ("bodies" or "contacts") if a request of this size exceeds the limits;
/// cheap, so a server can call it before converting anything.
void checkSize(std::size_t body_count, std::size_t contact_count, const RequestLimits& limits);

/// Throws InvalidInput ("bodies") if the request's collision geometry (counted over all bodies)
/// exceeds the limits; cheap, so a server can call it before converting any shape.
void checkGeometrySize(std::size_t shapes, std::size_t mesh_vertices, std::size_t mesh_triangles,
                       const RequestLimits& limits);

/// Validation in two steps, so that each value of a request is checked once even when contacts are
/// added after the bodies were checked (contacts detected from the bodies' shapes, which needs
/// valid poses): the constructor checks the sizes, the options and every body; checkContacts()
/// checks the contacts not checked yet, in order. validate() is both steps at once.
class SceneValidator {
 public:
  /// Throws InvalidInput naming the first offending field (see validate()).
  SceneValidator(const Scene& scene, const SolverOptions& options, const RequestLimits& limits);
  /// The same for bodies that are not in a Scene (an episode's), `contact_count` contacts to come
  /// (checked against the limits only).
  SceneValidator(const std::vector<BodyState>& bodies, std::size_t contact_count,
                 const SolverOptions& options, const RequestLimits& limits);
  /// The contacts' body indices (contactBodies()) handed over when the validator is done with them
  /// (validate() returns them without a copy).
  std::vector<std::pair<int, int>> releaseContactBodies() && { return std::move(contact_bodies_); }
  /// Checks scene.contacts from the first one not checked yet to the last (the bodies must be those
  /// given to the constructor, unchanged) and records their body indices. Throws InvalidInput
  /// naming "contacts[i]..." (i: the index in scene.contacts), or "contacts" past the size limit.
  void checkContacts(const Scene& scene);
  /// The same for contacts whose bodies are known by index, not looked up by id (contacts found by
  /// detection, which knows the bodies it paired): `bodies[k]` are the indices of body_a and body_b
  /// of the k-th contact not checked yet, numbered as contactBodies() numbers them (scene.bodies,
  /// then the other body ids); the contacts' id strings are only read for the messages. Throws
  /// InvalidInput as checkContacts() does (an index naming no body: "contacts[i].body_a" / "_b"),
  /// std::invalid_argument if `bodies` does not have one pair per such contact.
  void checkContacts(const Scene& scene, const std::vector<std::pair<int, int>>& bodies);
  /// Ids that contacts may name besides scene.bodies: the parts of bodies that are not free rigid
  /// bodies (a robot's links, "<robot>/<link>", docs/robots.md). contactBodies() numbers them
  /// scene.bodies.size() + k, k their index here. They count as movable, and their lever arms are
  /// not checked (their model has its own checks). Call before checkContacts(). Throws
  /// InvalidInput naming "bodies[i].id" if a body has one of these ids.
  void addOtherBodyIds(const std::vector<std::string>& ids);
  /// Per checked contact, the indices of body_a and body_b in scene.bodies (or past it: the other
  /// body ids).
  const std::vector<std::pair<int, int>>& contactBodies() const { return contact_bodies_; }

 private:
  // Checks scene.contacts[i] (`field` its name) with body indices a and b and records them.
  void checkContact(const Scene& scene, std::size_t i, const std::string& field, int a, int b);

  // The index of `id` in contactBodies()' numbering, -1 if unknown.
  int indexOf(const std::string& id) const;
  // Adds `id` (the next index) and returns -1, or returns the index of an equal id given before.
  int addId(const std::string& id);

  // The ids contacts may name (scene.bodies, then the other ids), looked up by a scan while there
  // are at most kScannedIds (no allocation per id: most requests have a few bodies), past that
  // through index_of_.
  static constexpr std::size_t kScannedIds = 16;
  RequestLimits limits_;
  std::vector<std::string> ids_;
  std::unordered_map<std::string, int> index_of_;
  std::vector<double> smallest_moments_;
  std::size_t body_count_ = 0;
  std::vector<std::pair<int, int>> contact_bodies_;
};

/// Checks everything the solvers rely on and throws InvalidInput naming the first offending field:
/// sizes within limits; finite numbers everywhere; non-empty, unique ids; mass >= 0; for movable
/// bodies an inertia that is positive definite and satisfies the triangle inequality of principal
/// moments (an immovable body's inertia is ignored); a non-zero, unit orientation; contacts naming
/// two different known bodies, not both immovable; a non-zero, unit normal; e in [0, 1];
/// 0 <= mu_d <= mu_s; solver options in range. Returns, per contact, the indices of body_a and
/// body_b in scene.bodies.
std::vector<std::pair<int, int>> validate(const Scene& scene, const SolverOptions& options,
                                          const RequestLimits& limits);

}  // namespace collision_response::core
