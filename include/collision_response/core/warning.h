#pragma once

#include <string>

namespace collision_response::core {

/// A request that is valid and was solved as given, but that holds something users usually send by
/// mistake (a moving body with no mass, a contact whose normal points the wrong way). The answer is
/// computed as the contract says; the warning names the field so that the caller can check it.
struct Warning {
  /// Path of the value in the request, spelled as in the ROS messages and as InvalidInput::field()
  /// (e.g. "bodies[1].inertia", "contacts[0]").
  std::string field;
  std::string reason;  ///< what was found and how it was treated

  /// "field: reason", the form the ROS response's `warnings` carry.
  std::string text() const { return field + ": " + reason; }
};

}  // namespace collision_response::core
