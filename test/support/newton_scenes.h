// Helpers shared by the Newton-law multi-contact and iterative-solver tests: an immovable body,
// a body by id, the relative velocity at a contact, random bodies, and the Newton law's options
// with a chosen method.
#pragma once

#include <Eigen/Core>
#include <stdexcept>
#include <string>
#include <vector>

#include "collision_response/core/body_state.h"
#include "collision_response/core/contact.h"
#include "collision_response/core/solver_options.h"
#include "scene_builders.h"

namespace collision_response::testing {

namespace cr = collision_response::core;

inline cr::BodyState fixed(const std::string& id) {
  cr::BodyState b;
  b.id = id;
  b.mass = 0.0;
  return b;
}

inline const cr::BodyState& byId(const std::vector<cr::BodyState>& bodies, const std::string& id) {
  for (const auto& b : bodies) {
    if (b.id == id) return b;
  }
  throw std::runtime_error("no body " + id);
}
inline Vector3d relVel(const std::vector<cr::BodyState>& bodies, const cr::Contact& c) {
  return pointVelocity(byId(bodies, c.body_b), c.point) -
         pointVelocity(byId(bodies, c.body_a), c.point);
}
struct Random : RandomSource {
  using RandomSource::RandomSource;
  cr::BodyState body(const std::string& id) {
    cr::BodyState b;
    b.id = id;
    b.mass = uniform(0.2, 5.0);
    b.inertia = boxInertia(b.mass, boxSize());
    b.com = vec(-0.3, 0.3);
    b.position = vec(-2.0, 2.0);
    b.orientation = rotation();
    b.linear_velocity = vec(-2.0, 2.0);
    b.angular_velocity = vec(-3.0, 3.0);
    return b;
  }
};

// Every test here is about the Newton law (u'_n = -e u_n with Coulomb friction), chosen explicitly.
inline cr::SolverOptions newton(cr::SolverMethod method = cr::SolverMethod::kAuto) {
  cr::SolverOptions o;
  o.law = cr::ImpactLaw::kNewton;
  o.method = method;
  return o;
}

}  // namespace collision_response::testing
