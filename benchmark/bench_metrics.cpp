// Error measures of the accuracy sweep (see bench_metrics.h).
#include "bench_metrics.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

namespace collision_response::bench {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

Matrix3d worldInertia(const core::BodyState& b) {
  const Matrix3d R = b.orientation.normalized().toRotationMatrix();
  return R * b.inertia * R.transpose();
}

double gyrationRadius(const core::BodyState& b) {
  return std::sqrt(b.inertia.trace() / (3.0 * b.mass));
}

int bodyIndex(const core::Scene& scene, const std::string& id) {
  for (std::size_t i = 0; i < scene.bodies.size(); ++i)
    if (scene.bodies[i].id == id) return static_cast<int>(i);
  return -1;
}

/// u_n = (v_b(p) - v_a(p)) . n for contact `c` [m/s].
double normalVelocity(const core::Scene& scene, const Velocities& v, const core::Contact& c) {
  const int a = bodyIndex(scene, c.body_a), b = bodyIndex(scene, c.body_b);
  const Vector3d ra = c.point - scene.bodies[a].worldCom();
  const Vector3d rb = c.point - scene.bodies[b].worldCom();
  const Vector3d u = v.linear[b] + v.angular[b].cross(rb) - v.linear[a] - v.angular[a].cross(ra);
  return u.dot(c.normal);
}

}  // namespace

double kineticEnergy(const core::Scene& scene, const Velocities& v) {
  double e = 0.0;
  for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
    const auto& b = scene.bodies[i];
    if (b.mass == 0.0) continue;
    e += 0.5 * b.mass * v.linear[i].squaredNorm() +
         0.5 * v.angular[i].dot(worldInertia(b) * v.angular[i]);
  }
  return e;
}

Errors measure(const core::Scene& scene, const Velocities& after,
               const std::vector<Vector3d>& impulses, const Velocities& reference) {
  const Velocities before = velocitiesBefore(scene);
  Errors err;
  double speed = 0.0;
  for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
    const auto& b = scene.bodies[i];
    if (b.mass == 0.0) continue;
    const double rho = gyrationRadius(b);
    speed = std::max(speed, before.linear[i].norm() + rho * before.angular[i].norm());
    err.velocity =
        std::max(err.velocity, (after.linear[i] - reference.linear[i]).norm() +
                                   rho * (after.angular[i] - reference.angular[i]).norm());
  }
  err.velocity /= speed;
  const double ke = kineticEnergy(scene, before), ke_after = kineticEnergy(scene, after);
  err.energy = std::abs(ke_after - kineticEnergy(scene, reference)) / ke;
  err.energy_gain = std::max(0.0, ke_after - ke) / ke;
  err.energy_ratio = ke_after / ke;
  double un_scale = 0.0;
  for (const auto& c : scene.contacts)
    un_scale = std::max(un_scale, std::abs(normalVelocity(scene, before, c)));
  for (std::size_t k = 0; k < scene.contacts.size(); ++k) {
    const auto& c = scene.contacts[k];
    const double un = normalVelocity(scene, after, c);
    err.restitution =
        std::max(err.restitution, std::abs(un - normalVelocity(scene, reference, c)) / un_scale);
    err.approach = std::max(err.approach, std::max(0.0, -un) / un_scale);
    if (impulses.empty()) continue;
    const Vector3d& p = impulses[k];
    const double pn = p.dot(c.normal);
    const double pt = (p - pn * c.normal).norm();
    if (p.norm() > 0.0)
      err.cone = std::max(err.cone, std::max(0.0, pt - c.static_friction * pn) / p.norm());
  }
  if (impulses.empty()) err.cone = std::numeric_limits<double>::quiet_NaN();
  return err;
}

void accumulate(Errors& total, const Errors& one) {
  total.velocity = std::max(total.velocity, one.velocity);
  total.energy = std::max(total.energy, one.energy);
  total.energy_gain = std::max(total.energy_gain, one.energy_gain);
  total.restitution = std::max(total.restitution, one.restitution);
  total.approach = std::max(total.approach, one.approach);
  total.cone = std::isnan(one.cone) ? one.cone : std::max(total.cone, one.cone);
  total.energy_ratio = std::max(total.energy_ratio, one.energy_ratio);
}

}  // namespace collision_response::bench
