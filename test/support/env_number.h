// A test's size setting read from the environment (CR_PROPERTY_SCENES, CR_STRESS_MAX_CONTACTS,
// ...): scripts/sanitize.sh sets them to keep the instrumented run short.
#pragma once

#include <cstdlib>

namespace collision_response::testing {

/// The integer in environment variable `name`, or `fallback` when it is unset.
inline long envOr(const char* name, long fallback) {
  const char* value = std::getenv(name);
  return value ? std::strtol(value, nullptr, 10) : fallback;
}

}  // namespace collision_response::testing
