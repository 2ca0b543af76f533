#pragma once

#include <string>

namespace collision_response::core {

/// A request that is valid and was solved as given, but that holds something users usually send by
/// mistake (a moving body with no mass, a contact whose normal points the wrong way). The answer is
/// computed as the contract says; the warning names the field so that the caller can check it.
struct Warning {
  /// What was found, for callers that treat kinds differently (the node drops kSeparating for the
  /// contacts it detected itself: neighbours moving apart are ordinary there).
  enum class Kind {
    kInput,            ///< a value of the request (a body with no mass, ...)
    kSeparating,       ///< a contact separating with no impulse (its normal may be flipped)
    kLeftApproaching,  ///< the answer leaves a contact approaching (approach_warnings.h)
    kJointLimit,       ///< the answer leaves a robot joint beyond its velocity limit
  };

  /// Path of the value in the request, spelled as in the ROS messages and as InvalidInput::field()
  /// (e.g. "bodies[1].inertia", "contacts[0]").
  std::string field;
  std::string reason;  ///< what was found and how it was treated
  Kind kind = Kind::kInput;

  /// "field: reason", the form the ROS response's `warnings` carry.
  std::string text() const { return field + ": " + reason; }
};

}  // namespace collision_response::core
