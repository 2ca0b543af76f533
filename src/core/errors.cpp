#include "collision_response/core/errors.h"

#include <utility>

namespace collision_response::core {
namespace {

std::vector<std::string> split(const std::string& field) {
  std::vector<std::string> path;
  std::size_t start = 0;
  for (;;) {
    const std::size_t dot = field.find('.', start);
    path.push_back(field.substr(start, dot - start));
    if (dot == std::string::npos) return path;
    start = dot + 1;
  }
}

std::string join(const std::vector<std::string>& path) {
  std::string field;
  for (const std::string& segment : path) {
    if (!field.empty()) field += '.';
    field += segment;
  }
  return field;
}

}  // namespace

InvalidInput::InvalidInput(const std::string& field, const std::string& reason)
    : InvalidInput(split(field), reason) {}

InvalidInput::InvalidInput(std::vector<std::string> path, const std::string& reason)
    : CollisionResponseError(join(path) + ": " + reason), path_(std::move(path)), reason_(reason) {}

std::string InvalidInput::field() const {
  return join(path_);
}

InvalidInput InvalidInput::prefixed(const std::string& segment) const {
  std::vector<std::string> path{segment};
  path.insert(path.end(), path_.begin(), path_.end());
  return InvalidInput(std::move(path), reason_);
}

InvalidInput InvalidInput::withFirstSegment(const std::string& segment) const {
  std::vector<std::string> path = path_;
  path.front() = segment;
  return InvalidInput(std::move(path), reason_);
}

}  // namespace collision_response::core
