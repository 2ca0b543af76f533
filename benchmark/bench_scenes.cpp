// Benchmark scenes and their reference answers (see bench_scenes.h).
#include "bench_scenes.h"
#include "sliding_cube_landing.h"

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <stdexcept>

#include "collision_response/core/contact_point.h"
#include "collision_response/core/contact_space.h"
#include "collision_response/core/impulse_space_integrator.h"
#include "collision_response/core/island_solver.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/single_contact.h"
#include "scenes.h"

namespace collision_response::bench {
namespace {

using Eigen::Matrix3d;
using Eigen::Quaterniond;
using Eigen::Vector3d;

constexpr core::ImpactLaw kNewton = core::ImpactLaw::kNewton;
constexpr core::ImpactLaw kPoisson = core::ImpactLaw::kPoisson;
constexpr core::ImpactLaw kStronge = core::ImpactLaw::kStronge;

using collision_response::testing::contact;
using collision_response::testing::ground;
using collision_response::testing::sphere;

/// Closed form for one central contact between spheres (or a sphere and the immovable ground),
/// computed here independently of the library. K = k_n n n^T + k_t (I - n n^T) with
/// k_n = sum 1/m_i and k_t = sum (1/m_i + r_i^2 / I_i). Normal impulse P_n = -(1 + e) u_n / k_n
/// (every law agrees: K_tn = 0). Friction: the sticking impulse |u_t| / k_t if it is within
/// mu_d P_n (the contact stops slipping during the impact and stays stuck), mu_d P_n against the
/// slip if the sticking impulse exceeds mu_s P_n; scenes in between are not built (there Newton's
/// static-cone test and Routh's integration disagree).
Velocities centralSpheres(const core::Scene& scene) {
  const core::Contact& c = scene.contacts.at(0);
  Velocities out = velocitiesBefore(scene);
  int ia = -1, ib = -1;
  for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
    if (scene.bodies[i].id == c.body_a) ia = static_cast<int>(i);
    if (scene.bodies[i].id == c.body_b) ib = static_cast<int>(i);
  }
  const auto& a = scene.bodies[ia];
  const auto& b = scene.bodies[ib];
  const Vector3d ra = c.point - a.position, rb = c.point - b.position;
  const Vector3d u = b.linear_velocity + b.angular_velocity.cross(rb) - a.linear_velocity -
                     a.angular_velocity.cross(ra);
  const double un = u.dot(c.normal);
  const Vector3d ut = u - un * c.normal;
  double kn = 0.0, kt = 0.0;
  for (const auto* body : {&a, &b}) {
    if (body->mass == 0.0) continue;
    const Vector3d r = c.point - body->position;
    kn += 1.0 / body->mass;
    kt += 1.0 / body->mass + r.squaredNorm() / body->inertia(0, 0);
  }
  const double pn = -(1.0 + c.restitution) * un / kn;
  Vector3d p = pn * c.normal;
  if (ut.norm() > 0.0) {
    const double stick = ut.norm() / kt;
    double pt;
    if (stick <= c.dynamic_friction * pn) {
      pt = stick;
    } else if (stick > c.static_friction * pn) {
      pt = c.dynamic_friction * pn;
    } else {
      throw std::logic_error("centralSpheres: ambiguous scene (between mu_d and mu_s)");
    }
    p -= pt * ut.normalized();
  }
  for (const auto& [index, sign, r] : {std::tuple<int, double, Vector3d>{ia, -1.0, ra},
                                       std::tuple<int, double, Vector3d>{ib, 1.0, rb}}) {
    const auto& body = scene.bodies[index];
    if (body.mass == 0.0) continue;
    out.linear[index] += sign * p / body.mass;
    out.angular[index] += sign * r.cross(p) / body.inertia(0, 0);
  }
  return out;
}

/// The library's own answer at the finest setting, for scenes without a closed form: one contact
/// by the closed form (Newton) or the impulse-space integration at 1e-14 (Poisson, Stronge);
/// several contacts by the exact (Lemke) solver, two-phase for Poisson and Stronge. `lcp`: Newton's
/// law with friction opposing the final slip, by the iterative solver to round-off (a frictionless
/// island: the exact solver).
Velocities fineSolve(const core::Scene& scene, core::ImpactLaw law, bool lcp) {
  std::vector<core::RigidBody> bodies;
  for (const auto& b : scene.bodies) bodies.push_back(core::makeRigidBody(b));
  std::vector<core::ContactPoint> rows;
  auto index = [&](const std::string& id) {
    for (std::size_t i = 0; i < scene.bodies.size(); ++i)
      if (scene.bodies[i].id == id) return static_cast<int>(i);
    throw std::logic_error("unknown body " + id);
  };
  for (const auto& c : scene.contacts) {
    const int a = index(c.body_a), b = index(c.body_b);
    rows.emplace_back(a, b, c.point, c.normal, c.restitution, c.static_friction,
                      c.dynamic_friction);
  }
  if (rows.size() == 1 && !lcp) {
    const auto& row = rows[0];
    const core::ContactImpulse impulse =
        law == kNewton
            ? core::solveSingleContact(bodies[row.body_a], bodies[row.body_b], row, law)
            : core::integrateSingleContact(bodies[row.body_a], bodies[row.body_b], row, law, 1e-14);
    core::ContactSpace(bodies[row.body_a], bodies[row.body_b], row.point)
        .applyImpulse(bodies[row.body_a], bodies[row.body_b], impulse.total(row.normal));
  } else {
    core::SolverOptions options;
    options.law = law;
    // "newton_lcp": projected Gauss-Seidel on the friction cone itself, converged to round-off.
    options.method = lcp ? core::SolverMethod::kIterative : core::SolverMethod::kExact;
    options.tolerance = 1e-15;
    options.max_iterations = 1000000;
    options.time_budget = 600.0;
    std::vector<int> island(rows.size());
    for (std::size_t i = 0; i < rows.size(); ++i) island[i] = static_cast<int>(i);
    std::vector<core::ContactImpulse> impulses(rows.size());
    core::solveIsland(bodies, rows, island, options, impulses);
  }
  Velocities out;
  for (const auto& b : bodies) {
    out.linear.push_back(b.linear_velocity);
    out.angular.push_back(b.angular_velocity);
  }
  return out;
}

BenchScene closedFormScene(const std::string& name, const std::string& family,
                           std::vector<core::Scene> instances,
                           Velocities (*closed_form)(const core::Scene&),
                           Velocities (*poisson)(const core::Scene&) = nullptr,
                           Velocities (*stronge)(const core::Scene&) = nullptr) {
  BenchScene s;
  s.name = name;
  s.family = family;
  s.reference = "closed form (every law)";
  s.instances = std::move(instances);
  for (const auto& scene : s.instances) {
    for (const auto& c : scene.contacts)
      s.friction_split |= c.static_friction != c.dynamic_friction;
    s.reference_by_law["newton"].push_back(closed_form(scene));
  }
  for (const char* law : {"newton_lcp", "poisson", "stronge"})
    s.reference_by_law[law] = s.reference_by_law["newton"];
  // Laws whose answer differs from Newton's here have their own closed form.
  for (const auto& [law, form] : {std::pair<const char*, decltype(poisson)>{"poisson", poisson},
                                  std::pair<const char*, decltype(stronge)>{"stronge", stronge}}) {
    if (form == nullptr) continue;
    s.reference = "closed form (per law)";
    s.reference_by_law[law].clear();
    for (const auto& scene : s.instances) s.reference_by_law[law].push_back(form(scene));
  }
  return s;
}

BenchScene fineScene(const std::string& name, const std::string& family,
                     const std::string& reference, std::vector<core::Scene> instances) {
  BenchScene s;
  s.name = name;
  s.family = family;
  s.reference = reference;
  s.instances = std::move(instances);
  for (const auto& scene : s.instances) {
    for (const auto& c : scene.contacts)
      s.friction_split |= c.static_friction != c.dynamic_friction;
    bool frictionless = true;
    for (const auto& c : scene.contacts) frictionless &= c.frictionless();
    s.reference_by_law["newton"].push_back(fineSolve(scene, kNewton, false));
    s.reference_by_law["newton_lcp"].push_back(fineSolve(scene, kNewton, !frictionless));
    s.reference_by_law["poisson"].push_back(fineSolve(scene, kPoisson, false));
    s.reference_by_law["stronge"].push_back(fineSolve(scene, kStronge, false));
  }
  return s;
}

/// Two spheres head on (README's example): 1 kg at 2 m/s meets 2 kg at -1 m/s, e = 0.5.
core::Scene headOn() {
  core::Scene s;
  s.bodies = {sphere("left", 1.0, 0.1, {-0.1, 0, 0}, {2, 0, 0}),
              sphere("right", 2.0, 0.1, {0.1, 0, 0}, {-1, 0, 0})};
  s.contacts = {contact("left", "right", Vector3d::Zero(), Vector3d::UnitX(), 0.5, 0.0, 0.0)};
  return s;
}

/// A 1 kg sphere (r 0.1 m) strikes a resting sphere `ratio` times heavier (r 1 m), head on with
/// a tangential component: central, frictional (mu 0.4), e = 0.8; it sticks.
core::Scene massRatio(double ratio) {
  core::Scene s;
  s.bodies = {sphere("light", 1.0, 0.1, {-0.1, 0, 0}, {1.0, 0.2, 0.0}, {0, 0, 3.0}),
              sphere("heavy", ratio, 1.0, {1.0, 0, 0}, Vector3d::Zero())};
  s.contacts = {contact("light", "heavy", Vector3d::Zero(), Vector3d::UnitX(), 0.8, 0.4, 0.4)};
  return s;
}

/// A ball (1 kg, r 0.1 m) lands on the ground at 1 m/s down, e = 0.5; `slide`: 3 m/s along x,
/// mu_s 0.3 mu_d 0.2 (it slides throughout); otherwise 1 m/s along x with back spin 2 rad/s,
/// mu_s 0.6 mu_d 0.5 (it stops slipping and sticks).
core::Scene sphereOnGround(bool slide) {
  core::Scene s;
  const Vector3d v = slide ? Vector3d(3.0, 0.0, -1.0) : Vector3d(1.0, 0.0, -1.0);
  const Vector3d w = slide ? Vector3d::Zero() : Vector3d(0.0, -2.0, 0.0);
  s.bodies = {ground(), sphere("ball", 1.0, 0.1, {0, 0, 0.1}, v, w)};
  s.contacts = {contact("ground", "ball", Vector3d::Zero(), Vector3d::UnitZ(), 0.5,
                        slide ? 0.3 : 0.6, slide ? 0.2 : 0.5)};
  return s;
}

/// A unit cube (1 kg, I = 1/6 kg m^2) lands flat on the ground at v = (0.3, -1, 0) m/s: 4 corner
/// contacts, e = 0.5, mu_s 0.6, mu_d 0.5. Newton: the sticking impulse (0.3 N s) is inside the cone
/// (0.6 x 1.5), so v' = (0, 0.5, 0), w' = 0: every corner ends at u'_n = -e u_n, stuck. Poisson and
/// Stronge: see cubeFlatPoisson() and cubeFlatStronge().
core::Scene cubeFlat() {
  core::Scene s;
  core::BodyState cube;
  cube.id = "cube";
  cube.mass = 1.0;
  cube.inertia = Matrix3d::Identity() / 6.0;
  cube.position = {0.0, 0.5, 0.0};
  cube.linear_velocity = {0.3, -1.0, 0.0};
  s.bodies = {ground(), cube};
  for (const double x : {-0.5, 0.5})
    for (const double z : {-0.5, 0.5})
      s.contacts.push_back(contact("ground", "cube", {x, 0, z}, Vector3d::UnitY(), 0.5, 0.6, 0.5));
  return s;
}

Velocities cubeFlatClosedForm(const core::Scene& scene) {
  Velocities out = velocitiesBefore(scene);
  out.linear[1] = Vector3d(0.0, 0.5, 0.0);
  out.angular[1] = Vector3d::Zero();
  return out;
}

/// Poisson (by hand, as in test_multi_contact's SlidingCubeLandingFlatKeepsItsCornersStuck, here
/// with y up): compression ends stuck at v = w = 0, the leading corners (x = +1/2) carrying m v_x
/// more normal impulse than the trailing ones to balance the friction's torque; restitution (e p_c
/// per corner) releases that torque times e, the corners kept stuck by friction (0.18 per unit
/// normal impulse, inside mu_s): v' = (-0.6 e v_x, e, 0), w' = (0, 0, 1.2 e v_x) = (-0.09, 0.5, 0)
/// m/s and (0, 0, 0.18) rad/s: it tips backwards.
Velocities cubeFlatPoisson(const core::Scene& scene) {
  Velocities out = velocitiesBefore(scene);
  out.linear[1] = Vector3d(-0.09, 0.5, 0.0);
  out.angular[1] = Vector3d(0.0, 0.0, 0.18);
  return out;
}

/// Stronge, each corner pair ending on its own work condition (the simultaneous integration, by
/// hand in test_simultaneous_impact's SlidingCubeLandingFlatByHandUnderTheConsistentRule): the
/// leading pair's restitution ends at t1 of the Poisson path, the trailing pair goes on alone,
/// stuck, by a normal impulse n until its work reaches e^2 of its compression work.
Velocities cubeFlatStronge(const core::Scene& scene) {
  // The hand derivation's answer, with z up there (sliding_cube_landing.h): here y is up, so the
  // rotation about (n x slip) is about -z.
  const testing::CubeMotion stronge = testing::slidingCubeLandingUnderStronge();
  Velocities out = velocitiesBefore(scene);
  out.linear[1] = Vector3d(stronge.linear.x(), stronge.linear.z(), 0.0);
  out.angular[1] = Vector3d(0.0, 0.0, -stronge.angular.y());
  return out;
}

/// `boxes` unit cubes (1 kg) stacked on the ground, all moving at v = (0.3, -1, 0.1) m/s: 4 corner
/// contacts per face, e = 0.5, mu = 0.5. The closed form (Newton, simultaneous) is the stack
/// moving as one: v' = (0, 0.5, 0), w' = 0 for every box; the ground corners end at u'_n = -e u_n,
/// the faces between boxes at u'_n = 0, every contact stuck (the friction the ground needs, 0.32
/// N s per box, is inside the cone, and the normal impulses can balance its torques).
core::Scene stack(int boxes) {
  core::Scene s;
  s.bodies = {ground()};
  for (int i = 0; i < boxes; ++i) {
    core::BodyState box;
    box.id = "box" + std::to_string(i);
    box.mass = 1.0;
    box.inertia = Matrix3d::Identity() / 6.0;
    box.position = {0.0, 0.5 + i, 0.0};
    box.linear_velocity = {0.3, -1.0, 0.1};
    s.bodies.push_back(box);
    const std::string below = i == 0 ? "ground" : "box" + std::to_string(i - 1);
    for (const double x : {-0.5, 0.5})
      for (const double z : {-0.5, 0.5})
        s.contacts.push_back(contact(below, box.id, {x, static_cast<double>(i), z},
                                     Vector3d::UnitY(), 0.5, 0.5, 0.5));
  }
  return s;
}

Velocities stackClosedForm(const core::Scene& scene) {
  Velocities out = velocitiesBefore(scene);
  for (std::size_t i = 1; i < scene.bodies.size(); ++i) {
    out.linear[i] = Vector3d(0.0, 0.5, 0.0);
    out.angular[i] = Vector3d::Zero();
  }
  return out;
}

/// The rod of docs/physics.md, "Worked examples" (test/scenes.h): e = 0.9, mu_s = 0.8 and mu_d =
/// `mu_d`.
core::Scene rodTip(double mu_d) {
  return collision_response::testing::rodScene(0.9, 0.8, mu_d);
}

/// Random box-like body (mass 0.5..2 kg, diagonal body inertia obeying the triangle inequality).
core::BodyState randomBody(std::mt19937& rng, const std::string& id, double mass_scale) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0), positive(0.5, 2.0);
  core::BodyState body;
  body.id = id;
  body.mass = positive(rng) * mass_scale;
  // z inside [|x - y|, x + y] (share 0.1..1): all three triangle inequalities of a rigid body's
  // principal moments.
  const double x = positive(rng), y = positive(rng), share = 0.1 + 0.6 * (positive(rng) - 0.5);
  const double z = std::abs(x - y) + share * (x + y - std::abs(x - y));
  body.inertia = Vector3d(x, y, z).asDiagonal() * (0.1 * mass_scale);
  body.orientation = Quaterniond(unit(rng), unit(rng), unit(rng), unit(rng)).normalized();
  body.position = Vector3d(unit(rng), unit(rng), unit(rng));
  body.linear_velocity = Vector3d(unit(rng), unit(rng), unit(rng));
  body.angular_velocity = Vector3d(unit(rng), unit(rng), unit(rng));
  return body;
}

/// `count` random off-centre frictional impacts (e = 0.5, mu 0.6), approaching only: a body
/// against the immovable ground, or (heavy > 0) against a movable body `heavy` times heavier.
std::vector<core::Scene> randomImpacts(int count, double heavy, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<core::Scene> out;
  while (static_cast<int>(out.size()) < count) {
    core::Scene s;
    core::BodyState a = heavy > 0.0 ? randomBody(rng, "heavy", heavy) : ground();
    if (heavy == 0.0) a.position = Vector3d(unit(rng), unit(rng), unit(rng));
    core::BodyState b = randomBody(rng, "body", 1.0);
    const Vector3d normal = Vector3d(unit(rng), unit(rng), unit(rng)).normalized();
    const Vector3d point(unit(rng), unit(rng), unit(rng));
    s.bodies = {a, b};
    s.contacts = {contact(a.id, b.id, point, normal, 0.5, 0.6, 0.6)};
    const core::RigidBody ra = core::makeRigidBody(a), rb = core::makeRigidBody(b);
    const core::ContactSpace space(ra, rb, point);
    if (normal.dot(space.relativeVelocity(ra, rb)) >= -1e-3) continue;  // approaching only
    out.push_back(s);
  }
  return out;
}

/// `spheres` spheres in a row along x, touching, the first at 1 m/s: 15 frictionless contacts, e =
/// 0.5.
core::Scene chain(int spheres) {
  core::Scene s;
  for (int i = 0; i < spheres; ++i) {
    s.bodies.push_back(sphere("ball" + std::to_string(i), 1.0, 0.1, {0.2 * i, 0, 0},
                              i == 0 ? Vector3d(1, 0, 0) : Vector3d::Zero()));
    if (i > 0)
      s.contacts.push_back(contact(s.bodies[i - 1].id, s.bodies[i].id, {0.2 * i - 0.1, 0, 0},
                                   Vector3d::UnitX(), 0.5, 0.0, 0.0));
  }
  return s;
}

/// The same scene with its contacts replaced by one contact at `point` (their common restitution
/// and friction): what a symmetric contact set is equivalent to.
core::Scene withOneContact(const core::Scene& scene, const Vector3d& point) {
  core::Scene one = scene;
  one.contacts = {scene.contacts.front()};
  one.contacts.front().point = point;
  return one;
}

/// A scene whose contacts act, by symmetry, as one contact at `point`: the reference of every law
/// is our single-contact answer there at the finest setting (fineSolve on the one contact).
BenchScene equivalentContactScene(const std::string& name, const std::string& reference,
                                  const core::Scene& scene, const Vector3d& point) {
  BenchScene s = fineScene(name, "many_contacts", reference, {withOneContact(scene, point)});
  s.instances = {scene};
  return s;
}

/// A box (1.5 kg, 0.6 x 0.4 x 0.3 m, tilted 30 degrees about y) lands on its lowest edge, which
/// lies along y on the ground (z up), while sliding across it: v = (1.2, 0, -1) m/s, w = (0, -2, 0)
/// rad/s; e = 0.5, mu_s 0.6, mu_d 0.4; 2 contacts, the ends of the edge. The centre of mass is
/// above the edge's midpoint plane y = 0 and v, w are symmetric about it (no y velocity, spin about
/// y only, y a principal axis of the box), so the two contacts carry equal impulses and the
/// contact velocities stay equal: the scene is one contact at the edge midpoint, for every law.
core::Scene edgeLanding() {
  const Vector3d half(0.3, 0.2, 0.15);  // [m] box half sizes, body axes
  core::BodyState box;
  box.id = "box";
  box.mass = 1.5;
  box.inertia = collision_response::testing::boxInertia(box.mass, 2.0 * half);
  box.orientation =
      Quaterniond(Eigen::AngleAxisd(30.0 * std::acos(-1.0) / 180.0, Vector3d::UnitY()));
  const Matrix3d R = box.orientation.toRotationMatrix();
  // The lowest edge of the tilted box: body (+x, -z) edge, along body y (= world y).
  const Vector3d edge_mid_body(half.x(), 0.0, -half.z());
  box.position = -(R * edge_mid_body);  // edge midpoint at the origin
  for (const double sx : {-1.0, 1.0})
    for (const double sz : {-1.0, 1.0})
      if ((R * Vector3d(sx * half.x(), 0.0, sz * half.z()) + box.position).z() < -1e-12)
        throw std::logic_error("edgeLanding: the box is below the ground");
  box.linear_velocity = {1.2, 0.0, -1.0};
  box.angular_velocity = {0.0, -2.0, 0.0};
  core::Scene s;
  s.bodies = {ground(), box};
  for (const double y : {-half.y(), half.y()})
    s.contacts.push_back(contact("ground", "box", {0.0, y, 0.0}, Vector3d::UnitZ(), 0.5, 0.6, 0.4));
  const Vector3d r = -box.position;  // edge midpoint from the centre of mass
  if ((box.linear_velocity + box.angular_velocity.cross(r)).z() >= 0.0)
    throw std::logic_error("edgeLanding: the edge does not approach the ground");
  return s;
}

/// A thin plate (2 kg, 0.8 x 0.5 m, its centre of mass in the plane of its corners) lands flat on
/// its 4 corners (ground z up) while sliding: v = (1.5, 0.8, -1) m/s, no spin; e = 0.6, mu_s 0.5,
/// mu_d 0.3. The corners are symmetric about the centre of mass in the contact plane and the
/// contact velocities are all v: the scene is one contact at the centre, for every law (it slides
/// throughout: mu_d (1 + e) 1 m/s x 2 kg = 0.96 N s of friction against 3.4 N s to stop it).
core::Scene plateFlat() {
  core::BodyState plate;
  plate.id = "plate";
  plate.mass = 2.0;
  plate.inertia = collision_response::testing::boxInertia(plate.mass, Vector3d(0.8, 0.5, 0.01));
  plate.linear_velocity = {1.5, 0.8, -1.0};
  core::Scene s;
  s.bodies = {ground(), plate};
  for (const double x : {-0.4, 0.4})
    for (const double y : {-0.25, 0.25})
      s.contacts.push_back(
          contact("ground", "plate", {x, y, 0.0}, Vector3d::UnitZ(), 0.6, 0.5, 0.3));
  return s;
}

/// Independent check of a symmetric scene's references (every law): the impulse of the equivalent
/// contact passes through `point`, so the angular momentum about it is unchanged (all components),
/// and the linear momentum along each of `fixed_axes` (no impulse there) is unchanged.
void checkMomenta(const BenchScene& s, const Vector3d& point,
                  const std::vector<Vector3d>& fixed_axes) {
  using collision_response::testing::angularMomentum;
  using collision_response::testing::linearMomentum;
  const core::Scene& scene = s.instances.front();
  const Vector3d p0 = linearMomentum(scene.bodies), h0 = angularMomentum(scene.bodies, point);
  for (const auto& [law, refs] : s.reference_by_law) {
    std::vector<core::BodyState> after = scene.bodies;
    for (std::size_t i = 0; i < after.size(); ++i) {
      after[i].linear_velocity = refs.front().linear[i];
      after[i].angular_velocity = refs.front().angular[i];
    }
    bool ok = (angularMomentum(after, point) - h0).norm() <= 1e-12;
    for (const Vector3d& axis : fixed_axes)
      ok &= std::abs((linearMomentum(after) - p0).dot(axis)) <= 1e-12;
    if (!ok) throw std::logic_error(s.name + ": reference (" + law + ") fails the momentum check");
  }
}

/// The plate slides throughout, so every law gives the same closed form: v'_n = -e v_n, the
/// tangential velocity reduced by mu_d (1 + e) |v_n| against the slip, no spin.
void checkPlate(const BenchScene& s) {
  const core::Scene& scene = s.instances.front();
  const core::Contact& c = scene.contacts.front();
  const Vector3d v = scene.bodies[1].linear_velocity;
  const double vn = v.dot(c.normal);
  const Vector3d vt = v - vn * c.normal;
  const Vector3d expected = -c.restitution * vn * c.normal + vt -
                            c.dynamic_friction * (1.0 + c.restitution) * -vn * vt.normalized();
  for (const auto& [law, refs] : s.reference_by_law)
    if ((refs.front().linear[1] - expected).norm() > 1e-12 ||
        refs.front().angular[1].norm() > 1e-12)
      throw std::logic_error("plate_flat: reference (" + law + ") differs from the closed form");
}

}  // namespace

Velocities velocitiesBefore(const core::Scene& scene) {
  Velocities v;
  for (const auto& b : scene.bodies) {
    v.linear.push_back(b.linear_velocity);
    v.angular.push_back(b.angular_velocity);
  }
  return v;
}

std::vector<BenchScene> makeScenes() {
  std::vector<BenchScene> scenes;
  scenes.push_back(closedFormScene("head_on", "closed_form", {headOn()}, centralSpheres));
  scenes.push_back(
      closedFormScene("sphere_slide", "closed_form", {sphereOnGround(true)}, centralSpheres));
  scenes.push_back(
      closedFormScene("sphere_stick", "closed_form", {sphereOnGround(false)}, centralSpheres));
  scenes.push_back(closedFormScene("cube_flat", "closed_form", {cubeFlat()}, cubeFlatClosedForm,
                                   cubeFlatPoisson, cubeFlatStronge));
  scenes.push_back(
      closedFormScene("mass_ratio_1e3", "mass_ratio", {massRatio(1e3)}, centralSpheres));
  scenes.push_back(
      closedFormScene("mass_ratio_1e6", "mass_ratio", {massRatio(1e6)}, centralSpheres));
  const std::string fine = "same law, finest setting: closed form (Newton), integrator at 1e-14";
  scenes.push_back(fineScene("rod_tip", "closed_form", fine, {rodTip(0.8)}));
  scenes.push_back(fineScene("rod_tip_split", "closed_form", fine, {rodTip(0.5)}));
  scenes.push_back(fineScene("random_offcentre", "random", fine, randomImpacts(32, 0.0, 7)));
  scenes.push_back(fineScene("random_ratio_1e6", "mass_ratio", fine, randomImpacts(32, 1e6, 11)));
  scenes.push_back(fineScene("chain_16", "many_contacts",
                             "exact (Lemke) solver of the same law (frictionless: unique)",
                             {chain(16)}));
  scenes.push_back(closedFormScene("stack_4", "many_contacts", {stack(4)}, stackClosedForm));
  const std::string by_symmetry =
      "one contact at the centre of the contacts (symmetry), same law, finest setting: closed "
      "form (Newton), integrator at 1e-14";
  scenes.push_back(
      equivalentContactScene("edge_landing", by_symmetry, edgeLanding(), Vector3d::Zero()));
  checkMomenta(scenes.back(), Vector3d::Zero(), {Vector3d::UnitY()});
  scenes.push_back(
      equivalentContactScene("plate_flat", by_symmetry, plateFlat(), Vector3d::Zero()));
  checkMomenta(scenes.back(), Vector3d::Zero(), {});
  checkPlate(scenes.back());
  return scenes;
}

}  // namespace collision_response::bench
