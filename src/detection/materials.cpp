#include "collision_response/detection/materials.h"

#include <cmath>

#include "collision_response/core/errors.h"
#include "collision_response/core/validation.h"

namespace collision_response::detection {

ContactMaterial mix(const ContactMaterial& a, const ContactMaterial& b) {
  return {std::sqrt(a.restitution * b.restitution),
          std::sqrt(a.static_friction * b.static_friction),
          std::sqrt(a.dynamic_friction * b.dynamic_friction)};
}

std::pair<std::string, std::string> MaterialTable::key(const std::string& a, const std::string& b) {
  return a < b ? std::make_pair(a, b) : std::make_pair(b, a);
}

const ContactMaterial* MaterialTable::find(const std::string& a, const std::string& b) const {
  const auto it = pairs_.find(key(a, b));
  return it == pairs_.end() ? nullptr : &it->second;
}

void MaterialTable::set(const std::string& a, const std::string& b, const ContactMaterial& material,
                        const std::string& field) {
  if (a.empty()) throw core::InvalidInput(field + ".a", "is empty");
  if (b.empty()) throw core::InvalidInput(field + ".b", "is empty");
  core::validateCoefficients(material.restitution, material.static_friction,
                             material.dynamic_friction, field);
  if (!pairs_.emplace(key(a, b), material).second) {
    throw core::InvalidInput(field, "repeats the pair (" + a + ", " + b + ")");
  }
}

bool MaterialTable::knows(const std::string& name) const {
  for (const auto& [pair, material] : pairs_) {
    if (pair.first == name || pair.second == name) return true;
  }
  return false;
}

ContactMaterial MaterialTable::lookup(const std::string& a, const std::string& b,
                                      const ContactMaterial& fallback) const {
  if (a.empty() || b.empty() || pairs_.empty()) return fallback;
  if (const ContactMaterial* pair = find(a, b)) return *pair;
  const ContactMaterial* own_a = find(a, a);
  const ContactMaterial* own_b = find(b, b);
  if (own_a != nullptr && own_b != nullptr) return mix(*own_a, *own_b);
  return fallback;
}

}  // namespace collision_response::detection
