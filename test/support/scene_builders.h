// Scene builders of scenes.h plus the gtest helpers the core unit tests share.
#pragma once

#include <gtest/gtest.h>

#include "scenes.h"

namespace collision_response::testing {

inline void expectVecNear(const Vector3d& got, const Vector3d& want, double tol) {
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(got[i], want[i], tol) << "component " << i;
}

}  // namespace collision_response::testing
