#pragma once

namespace collision_response::core {

/// pi, to double precision (std::numbers::pi is C++20).
inline constexpr double kPi = 3.14159265358979323846;

}  // namespace collision_response::core
