#include "collision_response/core/contact_safety.h"

#include <limits>

namespace collision_response::core {

double reflectedMass(const BodyModel& body, int part, const Eigen::Vector3d& point,
                     const Eigen::Vector3d& normal) {
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  if (body.velocityCount() == 0) return kInfinity;
  // W = J M^-1 J^T, the point's velocity change per unit impulse; n^T W n along n. Below round-off
  // of W's size (1e-12 of its trace) nothing of the body moves the point along n: infinity, not
  // the 1e30 kg that the round-off of J n = 0 would give.
  const Eigen::Matrix3d W =
      body.partPointJacobian(part, point) * body.partInverseMassJacobianTranspose(part, point);
  const double w = normal.dot(W * normal);
  return w > 1e-12 * W.trace() ? 1.0 / w : kInfinity;
}

std::vector<ContactSafety> contactSafety(const std::vector<BodyModel*>& bodies,
                                         const std::vector<ContactPoint>& contacts,
                                         const std::vector<ContactImpulse>& impulses) {
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  std::vector<ContactSafety> out(contacts.size());
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const ContactPoint& contact = contacts[c];
    ContactSafety& s = out[c];
    s.reflected_mass_a =
        reflectedMass(*bodies[contact.body_a], contact.part_a, contact.point, contact.normal);
    s.reflected_mass_b =
        reflectedMass(*bodies[contact.body_b], contact.part_b, contact.point, contact.normal);
    const double u_n = impulses[c].normal_velocity_before;
    s.approach_speed = u_n < 0.0 ? -u_n : 0.0;
    const double inverse = 1.0 / s.reflected_mass_a + 1.0 / s.reflected_mass_b;  // 1/inf = 0
    s.reduced_mass = inverse > 0.0 ? 1.0 / inverse : kInfinity;
    if (s.approach_speed == 0.0) {
      s.transferred_energy = 0.0;
    } else {
      s.transferred_energy = 0.5 * s.reduced_mass * s.approach_speed * s.approach_speed;
    }
  }
  return out;
}

}  // namespace collision_response::core
