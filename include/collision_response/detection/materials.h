#pragma once

#include <map>
#include <string>
#include <utility>

namespace collision_response::detection {

/// Restitution and Coulomb coefficients of a contact between two materials.
struct ContactMaterial {
  double restitution = 0.0;       ///< e in [0, 1]
  double static_friction = 0.0;   ///< mu_s >= 0
  double dynamic_friction = 0.0;  ///< 0 <= mu_d <= mu_s
};

/// Mixing rule for a pair of materials the table does not name: the geometric mean of each
/// coefficient of the two materials' own entries (a against a, b against b). It keeps e in [0, 1]
/// and mu_d <= mu_s, is symmetric, gives a material against itself its own entry, and makes a
/// frictionless (or perfectly plastic) material frictionless (plastic) against everything.
ContactMaterial mix(const ContactMaterial& a, const ContactMaterial& b);

/// Contact coefficients per pair of material names (core::BodyState material strings).
class MaterialTable {
 public:
  /// Sets the coefficients of the pair (a, b), in either order; a == b is the material against
  /// itself. Throws core::InvalidInput naming `field` if a name is empty or a coefficient is out of
  /// range.
  void set(const std::string& a, const std::string& b, const ContactMaterial& material,
           const std::string& field = "materials");

  /// The coefficients of a contact between materials a and b: the pair's entry if there is one;
  /// else, if both materials have their own entries, mix() of them; else `fallback` (also for an
  /// empty material name).
  ContactMaterial lookup(const std::string& a, const std::string& b,
                         const ContactMaterial& fallback) const;

  /// True if `name` appears in some entry (as a or b).
  bool knows(const std::string& name) const;

  bool empty() const { return pairs_.empty(); }
  std::size_t size() const { return pairs_.size(); }

 private:
  static std::pair<std::string, std::string> key(const std::string& a, const std::string& b);
  const ContactMaterial* find(const std::string& a, const std::string& b) const;

  std::map<std::pair<std::string, std::string>, ContactMaterial> pairs_;
};

}  // namespace collision_response::detection
