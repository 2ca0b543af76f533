#include "collision_response/core/contact_space.h"

#include <cmath>

namespace collision_response::core {
namespace {

// Adds the contribution I3 / m - [r]x Iw^-1 [r]x of one movable body to K.
void addBody(const RigidBody& body, const Eigen::Vector3d& r, Eigen::Matrix3d& K) {
  if (!body.movable()) return;
  const Eigen::Matrix3d rx = skew(r);
  K.diagonal().array() += body.inverse_mass;
  K.noalias() -= rx * body.inverse_inertia * rx;
}

}  // namespace

ContactSpace::ContactSpace(const RigidBody& a, const RigidBody& b, const Eigen::Vector3d& point)
    : r_a(point - a.com), r_b(point - b.com), K(Eigen::Matrix3d::Zero()) {
  addBody(a, r_a, K);
  addBody(b, r_b, K);
}

Eigen::Matrix3d rigidContactBlock(const RigidBody& body, const Eigen::Vector3d& r) {
  Eigen::Matrix3d K = Eigen::Matrix3d::Zero();
  addBody(body, r, K);
  return K;
}

void tangentBasis(const Eigen::Vector3d& n, Eigen::Vector3d& t1, Eigen::Vector3d& t2) {
  // Cross n with the world axis least aligned with it.
  const Eigen::Vector3d axis = std::abs(n.x()) < 0.57735   ? Eigen::Vector3d::UnitX()
                               : std::abs(n.y()) < 0.57735 ? Eigen::Vector3d::UnitY()
                                                           : Eigen::Vector3d::UnitZ();
  t1 = n.cross(axis).normalized();
  t2 = n.cross(t1);
}

}  // namespace collision_response::core
