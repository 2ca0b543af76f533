#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace collision_response::core {

/// Base of every error the core library throws.
class CollisionResponseError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A request that cannot be solved as given. The offending value is named by its path in the
/// request, as segments spelled as in the ROS messages: {"bodies[1]", "inertia", "ixx"}, written
/// "bodies[1].inertia.ixx". A caller that embeds the request in something larger names it there
/// with prefixed() ("scenes[3]") or renames its first segment (a detected contact) without
/// editing strings.
class InvalidInput : public CollisionResponseError {
 public:
  /// `field` in its written form ("contacts[0].normal"), split at the dots.
  InvalidInput(const std::string& field, const std::string& reason);
  InvalidInput(std::vector<std::string> path, const std::string& reason);

  /// The written form of path(): "bodies[1].inertia.ixx".
  std::string field() const;
  const std::vector<std::string>& path() const { return path_; }
  const std::string& reason() const { return reason_; }

  /// The same error with `segment` in front of its path: "scenes[3]" names it in a batch.
  InvalidInput prefixed(const std::string& segment) const;
  /// The same error with the first segment of its path replaced by `segment`.
  InvalidInput withFirstSegment(const std::string& segment) const;

 private:
  std::vector<std::string> path_;
  std::string reason_;
};

/// A solve that ran past its time budget (SolverOptions::time_budget); nothing is returned.
class SolverTimeout : public CollisionResponseError {
 public:
  using CollisionResponseError::CollisionResponseError;
};

}  // namespace collision_response::core
