#pragma once

#include <vector>

#include "collision_response/core/body_state.h"
#include "collision_response/core/contact.h"

namespace collision_response::core {

/// Bodies and the contacts between them, all in one common frame.
struct Scene {
  std::vector<BodyState> bodies;
  std::vector<Contact> contacts;
};

}  // namespace collision_response::core
