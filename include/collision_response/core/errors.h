#pragma once

#include <stdexcept>
#include <string>

namespace collision_response::core {

/// Base of every error the core library throws.
class CollisionResponseError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A request that cannot be solved as given. field() is the path of the offending value in the
/// request, spelled as in the ROS messages (e.g. "bodies[1].inertia.ixx", "contacts[0].normal").
class InvalidInput : public CollisionResponseError {
 public:
  InvalidInput(std::string field, const std::string& reason)
      : CollisionResponseError(field + ": " + reason), field_(std::move(field)) {}
  const std::string& field() const { return field_; }

 private:
  std::string field_;
};

/// A solve that ran past its time budget (SolverOptions::time_budget); nothing is returned.
class SolverTimeout : public CollisionResponseError {
 public:
  using CollisionResponseError::CollisionResponseError;
};

}  // namespace collision_response::core
