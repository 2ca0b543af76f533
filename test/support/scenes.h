// Scene builders and reference quantities shared by the core unit tests and the benchmarks,
// computed independently of the library (world inertia, momenta, point velocities). No gtest: the
// benchmarks include it too.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "collision_response/core/body_state.h"
#include "collision_response/core/contact.h"
#include "collision_response/core/scene.h"

namespace collision_response::testing {

using Eigen::Matrix3d;
using Eigen::Quaterniond;
using Eigen::Vector3d;
namespace cr = collision_response::core;

/// The immovable ground (mass 0), id "ground".
inline cr::BodyState ground() {
  cr::BodyState g;
  g.id = "ground";
  return g;
}

/// A 1.5 kg box (principal inertia (0.05, 0.08, 0.1) kg m^2, turned 0.4 rad about (1, 2, 3)) at
/// (0.1, -0.05, 0.2) m with linear velocity v [m/s] and angular velocity w [rad/s], struck by the
/// ground ("ground", body a) through one contact at `point` with normal `normal` (from the ground
/// to the box), restitution e and friction mu_s, mu_d: the off-centre box of the uncertainty tests
/// and benchmarks.
inline cr::Scene struckBox(const Vector3d& v, const Vector3d& w, const Vector3d& point,
                           const Vector3d& normal, double e, double mu_s, double mu_d) {
  cr::BodyState box;
  box.id = "box";
  box.mass = 1.5;
  box.inertia = Vector3d(0.05, 0.08, 0.1).asDiagonal();
  box.orientation = Quaterniond(Eigen::AngleAxisd(0.4, Vector3d(1, 2, 3).normalized()));
  box.position = {0.1, -0.05, 0.2};
  box.linear_velocity = v;
  box.angular_velocity = w;
  cr::Contact contact;
  contact.body_a = "ground";
  contact.body_b = "box";
  contact.point = point;
  contact.normal = normal;
  contact.restitution = e;
  contact.static_friction = mu_s;
  contact.dynamic_friction = mu_d;
  cr::Scene scene;
  scene.bodies = {ground(), box};
  scene.contacts = {contact};
  return scene;
}

/// Solid sphere: I = 2/5 m r^2.
inline cr::BodyState sphere(const std::string& id, double m, double radius,
                            const Vector3d& position, const Vector3d& v,
                            const Vector3d& w = Vector3d::Zero()) {
  cr::BodyState b;
  b.id = id;
  b.mass = m;
  b.inertia = Matrix3d::Identity() * (0.4 * m * radius * radius);
  b.position = position;
  b.linear_velocity = v;
  b.angular_velocity = w;
  return b;
}

inline cr::Contact contact(const std::string& a, const std::string& b, const Vector3d& p,
                           const Vector3d& n, double e, double mu_s = 0.0, double mu_d = 0.0) {
  cr::Contact c;
  c.body_a = a;
  c.body_b = b;
  c.point = p;
  c.normal = n;
  c.restitution = e;
  c.static_friction = mu_s;
  c.dynamic_friction = mu_d;
  return c;
}

inline Matrix3d worldInertia(const cr::BodyState& b) {
  const Matrix3d R = b.orientation.normalized().toRotationMatrix();
  return R * b.inertia * R.transpose();
}

inline Vector3d worldCom(const cr::BodyState& b) {
  return b.position + b.orientation.normalized().toRotationMatrix() * b.com;
}

inline Vector3d pointVelocity(const cr::BodyState& b, const Vector3d& p) {
  return b.linear_velocity + b.angular_velocity.cross(p - worldCom(b));
}

inline Vector3d linearMomentum(const std::vector<cr::BodyState>& bodies) {
  Vector3d p = Vector3d::Zero();
  for (const auto& b : bodies) p += b.mass * b.linear_velocity;
  return p;
}

/// About the point o: sum of m (c - o) x v + I_world w over movable bodies.
inline Vector3d angularMomentum(const std::vector<cr::BodyState>& bodies, const Vector3d& o) {
  Vector3d h = Vector3d::Zero();
  for (const auto& b : bodies) {
    if (b.mass == 0.0) continue;
    h += b.mass * (worldCom(b) - o).cross(b.linear_velocity) + worldInertia(b) * b.angular_velocity;
  }
  return h;
}

/// Inertia tensor of a solid box of the given full sizes, about its centre (always satisfies the
/// triangle inequality).
inline Matrix3d boxInertia(double mass, const Vector3d& size) {
  const Vector3d s2 = size.cwiseProduct(size);
  return (mass / 12.0 * Vector3d(s2.y() + s2.z(), s2.x() + s2.z(), s2.x() + s2.y())).asDiagonal();
}

/// Seeded random numbers, vectors and rotations; test files add the bodies they need.
struct RandomSource {
  std::mt19937 gen;
  explicit RandomSource(unsigned seed) : gen(seed) {}
  double uniform(double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(gen);
  }
  Vector3d vec(double lo, double hi) {
    return Vector3d(uniform(lo, hi), uniform(lo, hi), uniform(lo, hi));
  }
  Vector3d unit() {
    std::normal_distribution<double> g;
    return Vector3d(g(gen), g(gen), g(gen)).normalized();
  }
  /// Box sizes for boxInertia(), each in [0.1, 2] m.
  Vector3d boxSize() {
    const double x = uniform(0.1, 2.0), y = uniform(0.1, 2.0), z = uniform(0.1, 2.0);
    return Vector3d(x, y, z);
  }
  Quaterniond rotation() {
    std::normal_distribution<double> g;
    return Quaterniond(g(gen), g(gen), g(gen), g(gen)).normalized();
  }
};

/// A box falling on the ground at about 1.5 m/s, tumbling: mass [0.2, 5] kg, sizes from
/// boxSize(), a random orientation, velocity (-1..1, -1..1, -2.5..-0.5) m/s, spin within 2 rad/s
/// per axis; `placed`: its centre drawn within 0.2 m of the origin (else at the origin). id "box".
inline cr::BodyState randomFallingBox(RandomSource& random, bool placed) {
  cr::BodyState box;
  box.id = "box";
  box.mass = random.uniform(0.2, 5.0);
  box.inertia = boxInertia(box.mass, random.boxSize());
  box.orientation = random.rotation();
  if (placed) box.position = random.vec(-0.2, 0.2);
  box.linear_velocity = random.vec(-1.0, 1.0) - Vector3d(0, 0, 1.5);
  box.angular_velocity = random.vec(-2.0, 2.0);
  return box;
}

/// The rod of docs/physics.md, "Worked examples": uniform, 1 kg, 1 m, 50 degrees to the floor (z
/// up), lower tip striking at the origin, centre of mass velocity 1 m/s at 20 degrees off
/// vertical, no spin; restitution e, friction mu_s and mu_d.
inline cr::Scene rodScene(double e, double mu_s, double mu_d) {
  const double pi = std::acos(-1.0);
  const double tilt = 50.0 * pi / 180.0, off_vertical = 20.0 * pi / 180.0;
  cr::BodyState rod;
  rod.id = "rod";
  rod.mass = 1.0;
  const double radius = 0.01;  // thin cylinder along body x
  const double across = (3.0 * radius * radius + 1.0) / 12.0, along = 0.5 * radius * radius;
  rod.inertia = Vector3d(along, across, across).asDiagonal();
  // Rod axis in the x-z plane at 50 degrees to the floor, lower tip at the origin.
  rod.orientation = Quaterniond(Eigen::AngleAxisd(-tilt, Vector3d::UnitY()));
  rod.position = 0.5 * Vector3d(std::cos(tilt), 0.0, std::sin(tilt));
  // Moving down and away from the tip side (towards +x), 20 degrees off vertical.
  rod.linear_velocity = Vector3d(std::sin(off_vertical), 0.0, -std::cos(off_vertical));
  cr::Scene scene;
  scene.bodies = {ground(), rod};
  scene.contacts = {contact("ground", "rod", Vector3d::Zero(), Vector3d::UnitZ(), e, mu_s, mu_d)};
  return scene;
}

}  // namespace collision_response::testing
