// Decodes arbitrary bytes into an impact episode (bodies, their shapes and materials,
// EpisodeOptions), runs it the way ~compute_episode does (core::SceneValidator, then
// detection::ShapeGaps, then core::computeEpisode; src/ros/episode_service.cpp) and checks the
// outcome. Shared by the libFuzzer target (fuzz_episode.cpp) and the regression test
// (test_fuzz_episode_regressions.cpp), so a saved input replays exactly as the fuzzer saw it.
//
// The decoding is total (any byte string gives an episode; missing bytes read as 0, which selects
// the sane branch of every choice: a floor plane and a box falling onto it under Stronge) and mixes
//  - sane values: log-uniform masses and positive definite inertias (scene_decoder.h), bodies
//    above a floor plane (or a tilted plane) with velocities of a few m/s, boxes, spheres,
//    cylinders, cones, small meshes (a box's hull, a tetrahedron, a soup of random triangles),
//    shapes offset and turned in their body, coefficients in range, gravity, horizon, impact cap,
//    contact tolerance, the four laws and three solvers;
//  - hostile values (wild mode): NaN, infinities, zero, denormals, huge and raw doubles in masses,
//    inertias, poses, twists, dimensions, plane coefficients, mesh vertices and indices,
//    coefficients, gravity, horizon, max_impacts, contact tolerance; planes on movable bodies,
//    unknown material names, zero points per pair.
// Every episode has a time budget of 0.05 s (wild mode: any value), so no input runs for long.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "collision_response/core/episode.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/validation.h"
#include "collision_response/detection/shape_gaps.h"
#include "scene_decoder.h"

namespace collision_response::fuzz {

namespace detection = collision_response::detection;

constexpr std::size_t kMaxEpisodeBodies = 4;
constexpr std::size_t kMaxShapesPerBody = 3;
constexpr double kEpisodeBudget = 0.05;  // [s]

struct DecodedEpisode {
  std::vector<core::BodyState> bodies;
  detection::DetectionInput input;
  detection::MaterialTable materials;
  core::EpisodeOptions options;
};

namespace episode_detail {

inline double pick(ByteReader& in, bool wild, const std::vector<double>& table) {
  const std::uint8_t b = in.byte();
  if (wild && b >= 0xf8) return in.raw();
  if (wild && b >= 0xf0) return in.special();
  return table[b % table.size()];
}

inline Eigen::Isometry3d decodePose(ByteReader& in, bool wild) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  const std::uint8_t mode = in.byte();
  if (mode % 4 == 1 || mode % 4 == 2) {
    pose.translation() = in.vector(false, -0.1, 0.1);
    if (mode % 4 == 2) pose.linear() = in.unitQuaternion().toRotationMatrix();
  } else if (mode % 4 == 3 && wild) {
    pose.translation() = in.vector(true, -0.1, 0.1);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) pose.matrix()(r, c) = in.value(true, -1.0, 1.0);
    }
  }
  return pose;
}

inline detection::Shape decodeMesh(ByteReader& in, bool wild) {
  detection::Shape s;
  s.type = detection::Shape::Type::kMesh;
  const std::uint8_t kind = in.byte();
  const double scale = in.logUniform(0.01, 0.5);
  if (kind % 3 == 0) {  // a box's hull
    for (int k = 0; k < 8; ++k) {
      s.vertices.emplace_back((k & 1 ? 0.5 : -0.5) * scale, (k & 2 ? 0.5 : -0.5) * scale,
                              (k & 4 ? 0.5 : -0.5) * scale);
    }
    const int quads[6][4] = {{0, 1, 3, 2}, {4, 5, 7, 6}, {0, 1, 5, 4},
                             {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 3, 7, 5}};
    for (const auto& q : quads) {
      s.triangles.push_back({q[0], q[1], q[2]});
      s.triangles.push_back({q[0], q[2], q[3]});
    }
  } else if (kind % 3 == 1) {  // a tetrahedron
    s.vertices = {Eigen::Vector3d(1, 1, 1) * scale, Eigen::Vector3d(1, -1, -1) * scale,
                  Eigen::Vector3d(-1, 1, -1) * scale, Eigen::Vector3d(-1, -1, 1) * scale};
    s.triangles = {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}};
  } else {  // a soup: 3-8 random vertices, 1-8 random triangles (repeated indices in wild mode)
    const std::size_t vertices = 3 + in.byte() % 6;
    for (std::size_t k = 0; k < vertices; ++k) s.vertices.push_back(in.vector(wild, -scale, scale));
    const std::size_t triangles = 1 + in.byte() % 8;
    for (std::size_t k = 0; k < triangles; ++k) {
      std::array<int, 3> t{};
      for (int& index : t) {
        const std::uint8_t b = in.byte();
        index = (wild && b >= 0xf8) ? static_cast<int>(b) - 0xfc : static_cast<int>(b % vertices);
      }
      if (!wild && (t[0] == t[1] || t[1] == t[2] || t[0] == t[2])) {
        t = {0, 1, 2};  // valid: distinct indices
      }
      s.triangles.push_back(t);
    }
    if (wild && in.byte() == 0xff) s.triangles.clear();
  }
  return s;
}

inline detection::Shape decodeShape(ByteReader& in, bool wild, bool immovable) {
  detection::Shape s;
  const std::uint8_t type = in.byte();
  // Planes on immovable bodies; on a movable one only in wild mode (refused: unbounded).
  const int kinds = (immovable || wild) ? 6 : 5;
  const auto dimension = [&] {
    return wild && in.byte() >= 0xf0 ? in.special() : in.logUniform(0.005, 0.5);
  };
  switch (type % kinds) {
    case 0:
      s.type = detection::Shape::Type::kBox;
      s.dimensions = {dimension(), dimension(), dimension()};
      break;
    case 1:
      s.type = detection::Shape::Type::kSphere;
      s.dimensions = {dimension()};
      break;
    case 2:
      s.type = detection::Shape::Type::kCylinder;
      s.dimensions = {dimension(), dimension()};
      break;
    case 3:
      s.type = detection::Shape::Type::kCone;
      s.dimensions = {dimension(), dimension()};
      break;
    case 4:
      s = decodeMesh(in, wild);
      break;
    default: {
      s.type = detection::Shape::Type::kPlane;
      const std::uint8_t mode = in.byte();
      if (mode % 4 == 0) {
        s.dimensions = {0.0, 0.0, 1.0, 0.0};  // the floor z = 0
      } else if (wild && mode % 4 == 3) {
        s.dimensions = {in.value(true, -1, 1), in.value(true, -1, 1), in.value(true, -1, 1),
                        in.value(true, -1, 1)};
        if (mode & 0x80) s.dimensions.pop_back();  // 3 coefficients
      } else {
        // A tilted plane through (0, 0, d): a unit normal with an upward component.
        Eigen::Vector3d n = in.unitVector();
        if (n.z() < 0.2) n = Eigen::Vector3d(n.x(), n.y(), 1.0).normalized();
        const double d = in.uniform(-0.1, 0.1);
        s.dimensions = {n.x(), n.y(), n.z(), -n.z() * d};
      }
      return s;  // a plane's pose: the body's
    }
  }
  s.pose = decodePose(in, wild);
  return s;
}

inline core::BodyState decodeBody(ByteReader& in, std::size_t index, bool& wild) {
  core::BodyState body;
  const std::uint8_t mode = in.byte();
  wild = mode % 8 == 7;
  body.id = detail::bodyId(index);
  // Body 0 is the floor unless the input says otherwise: immovable, at the origin.
  const std::uint8_t kind = in.byte();
  const bool floor = index == 0 ? kind % 4 != 3 : kind % 8 == 0;
  if (floor) {
    body.mass = 0.0;
    if (wild && (kind & 0x80)) body.angular_velocity = in.vector(true, -1.0, 1.0);
    return body;
  }
  if (wild && kind % 4 == 2) {
    body.mass = (kind & 0x80) ? in.raw() : in.special();
  } else {
    body.mass = in.logUniform(1e-2, 1e2);
  }
  const std::uint8_t inertia_mode = in.byte();
  if (wild && inertia_mode % 4 == 1) {
    for (int r = 0; r < 3; ++r) {
      for (int c = r; c < 3; ++c) body.inertia(r, c) = body.inertia(c, r) = in.value(true, -1, 1);
    }
  } else {
    body.inertia = detail::saneInertia(in);
    // The inertia of a body of the decoded mass (saneInertia draws its own).
    const double scale = body.mass > 0.0 && std::isfinite(body.mass) ? body.mass : 1.0;
    body.inertia *= scale / std::max(body.inertia.trace(), 1e-300) * in.logUniform(1e-3, 1.0);
  }
  body.com = (inertia_mode & 0x80) ? in.vector(wild, -0.02, 0.02) : Eigen::Vector3d::Zero();
  // Above the floor: x, y in [-0.3, 0.3], z in [0.02, 1] m.
  body.position = Eigen::Vector3d(in.value(wild, -0.3, 0.3), in.value(wild, -0.3, 0.3),
                                  in.value(wild, 0.02, 1.0));
  if (wild && (mode & 0x80)) {
    Eigen::Vector4d q;
    for (int i = 0; i < 4; ++i) q[i] = in.value(true, -1, 1);
    body.orientation = Eigen::Quaterniond(q[3], q[0], q[1], q[2]);  // not normalised
  } else {
    body.orientation = in.unitQuaternion();
  }
  const std::uint8_t motion = in.byte();
  if (motion % 4 != 0) {  // 0: released at rest
    body.linear_velocity = in.vector(wild, -3.0, 3.0);
    body.angular_velocity = in.vector(wild, -10.0, 10.0);
  }
  if (motion % 8 == 5) {
    body.force = in.vector(wild, -5.0, 5.0);
    body.torque = in.vector(wild, -1.0, 1.0);
  }
  return body;
}

inline core::EpisodeOptions decodeOptions(ByteReader& in) {
  core::EpisodeOptions options;
  options.solver = detail::decodeOptions(in);  // law, solver, tolerances (6 bytes)
  const std::uint8_t selector = in.byte();
  const bool wild = (selector & 0xc0) == 0xc0;
  options.solver.time_budget = (wild && selector % 8 == 7) ? in.special() : kEpisodeBudget;
  const std::uint8_t g = in.byte();
  if (g % 4 == 1) {
    options.gravity = in.vector(false, -20.0, 20.0);
  } else if (g % 4 == 2) {
    options.gravity.setZero();
  } else if (g % 4 == 3 && wild) {
    options.gravity = in.vector(true, -20.0, 20.0);
  }
  options.horizon = pick(in, wild, {1.0, 0.1, 0.01, 5.0, 1e-6, 0.5});
  const std::uint8_t cap = in.byte();
  static const int kCaps[] = {100, 1, 3, 10, 1000, 2};
  options.max_impacts = (wild && cap >= 0xf8) ? static_cast<int>(cap) - 0xfc : kCaps[cap % 6];
  options.contact_tolerance = pick(in, wild, {1e-4, 1e-6, 1e-3, 1e-2, 1e-8, 3e-5});
  return options;
}

inline void decodeMaterials(ByteReader& in, DecodedEpisode& episode, bool wild) {
  const std::uint8_t mode = in.byte();
  detection::ContactMaterial& m = episode.input.defaults;
  static const double kRestitution[] = {0.3, 0.0, 1.0, 0.5, 0.9};
  m.restitution = kRestitution[mode % 5];
  const std::uint8_t mu = in.byte();
  if (mu % 4 == 1) {
    m.static_friction = m.dynamic_friction = 0.25;
  } else if (mu % 4 == 2) {
    m.static_friction = in.uniform(0.0, 2.0);
    m.dynamic_friction = m.static_friction * in.unit();
  } else if (mu % 4 == 3) {
    m.static_friction = m.dynamic_friction = in.uniform(0.0, 1.0);
  }
  if (wild && (mode & 0x80)) {
    m.restitution = in.value(true, 0.0, 1.0);
    m.static_friction = in.value(true, 0.0, 2.0);
    m.dynamic_friction = in.value(true, 0.0, 2.0);
  }
  // A small table; bodies name a material now and then.
  episode.materials.set("rubber", "rubber", {0.8, 1.0, 0.9});
  episode.materials.set("steel", "steel", {0.6, 0.3, 0.2});
  episode.materials.set("rubber", "steel", {0.5, 0.6, 0.5});
  const std::uint8_t named = in.byte();
  if (named % 4 == 1) {
    static const char* const kNames[] = {"", "rubber", "steel", "wood"};  // wood: in no entry
    for (std::size_t i = 0; i < episode.bodies.size(); ++i) {
      episode.input.materials.push_back(kNames[in.byte() % (wild ? 4 : 3)]);
    }
  }
  if (named % 8 == 6) {
    for (std::size_t i = 0; i < episode.bodies.size(); ++i) {
      episode.input.collision_groups.push_back(static_cast<int>(in.byte() % 3) - 1);
    }
  }
  const std::uint8_t points = in.byte();
  static const std::size_t kPoints[] = {8, 4, 1, 16};
  episode.input.options.max_contacts_per_pair = (wild && points == 0xff) ? 0 : kPoints[points % 4];
}

/// `count` bodies (decodeBody(): body 0 the floor unless the bytes say otherwise) with their
/// shapes (the floor a plane, or what the bytes say; other bodies 1 shape, or 0 to 3), then the
/// materials, appended to `episode`.
inline void decodeWorld(ByteReader& in, std::size_t count, DecodedEpisode& episode) {
  bool any_wild = false;
  for (std::size_t i = 0; i < count; ++i) {
    bool wild = false;
    episode.bodies.push_back(decodeBody(in, i, wild));
    any_wild = any_wild || wild;
    const bool immovable = episode.bodies.back().mass == 0.0;
    detection::BodyGeometry geometry;
    const std::uint8_t shapes = in.byte();
    const std::size_t n = shapes < 0xc0 ? 1 : shapes % (kMaxShapesPerBody + 1);
    for (std::size_t k = 0; k < n; ++k) {
      if (i == 0 && k == 0 && immovable && shapes < 0x80) {
        detection::Shape plane;
        plane.type = detection::Shape::Type::kPlane;
        plane.dimensions = {0.0, 0.0, 1.0, 0.0};
        geometry.shapes.push_back(plane);
        continue;
      }
      geometry.shapes.push_back(decodeShape(in, wild, immovable));
    }
    episode.input.geometry.push_back(std::move(geometry));
  }
  decodeMaterials(in, episode, any_wild);
}

}  // namespace episode_detail

/// The episode encoded by `data`. Layout: options (6 + 1-3 + 4-6 bytes), body count, each body and
/// its shapes, then materials; see the episode_detail:: functions.
inline DecodedEpisode decodeEpisode(const std::uint8_t* data, std::size_t size) {
  ByteReader in(data, size);
  DecodedEpisode episode;
  episode.options = episode_detail::decodeOptions(in);
  // 2 bodies when the input runs out; 1 to kMaxEpisodeBodies.
  const std::size_t count = 1 + (in.byte() + 1) % kMaxEpisodeBodies;
  episode_detail::decodeWorld(in, count, episode);
  return episode;
}

/// What running an episode gave.
struct EpisodeOutcome {
  bool solved = false;      ///< computeEpisode returned
  std::string invalid;      ///< the InvalidInput message, if any
  std::string timeout;      ///< the SolverTimeout message, if any
  std::string bug;          ///< non-empty: an unexpected exception or a broken invariant
  bool non_finite = false;  ///< the bug is a non-finite number in a successful answer
  core::EpisodeResult result;
};

/// True if some number of the bodies is finite but huge or tiny (scene_decoder.h's
/// extremeMagnitudes()): FUZZ_SKIP_EXTREME=1 excuses non-finite answers to those.
inline bool extremeMagnitudes(const DecodedEpisode& episode) {
  DecodedRequest request;
  request.scene.bodies = episode.bodies;
  return extremeMagnitudes(request);
}

namespace episode_detail {

inline bool finiteState(const core::BodyState& b) {
  return b.position.allFinite() && b.orientation.coeffs().allFinite() &&
         b.linear_velocity.allFinite() && b.angular_velocity.allFinite();
}

/// The deepest gap of each (plane body, other body) pair at the bodies' poses, +infinity where
/// there is none within `range`. Index: plane body * n + other body.
inline std::vector<double> planeGaps(const DecodedEpisode& episode,
                                     const detection::ShapeGaps& geometry,
                                     const std::vector<core::BodyState>& bodies, double range) {
  const std::size_t n = bodies.size();
  std::vector<double> deepest(n * n, std::numeric_limits<double>::infinity());
  std::vector<bool> has_plane(n, false);
  for (std::size_t i = 0; i < n; ++i) {
    for (const detection::Shape& s : episode.input.geometry[i].shapes) {
      if (s.type == detection::Shape::Type::kPlane) has_plane[i] = true;
    }
  }
  std::vector<core::GapContact> gaps;
  geometry.gaps(bodies, range, gaps);
  for (const core::GapContact& g : gaps) {
    // Only pairs of a plane body with a body that has no plane: their gaps are in closed form.
    int plane = -1, other = -1;
    if (has_plane[g.body_a] && !has_plane[g.body_b]) plane = g.body_a, other = g.body_b;
    if (has_plane[g.body_b] && !has_plane[g.body_a]) plane = g.body_b, other = g.body_a;
    if (plane < 0) continue;
    double& d = deepest[static_cast<std::size_t>(plane) * n + static_cast<std::size_t>(other)];
    d = std::min(d, g.gap);
  }
  return deepest;
}

/// Invariants of a successful episode; the first one broken, or "".
inline std::string checkEpisode(const DecodedEpisode& episode, const detection::ShapeGaps& geometry,
                                const std::vector<double>& gaps_before,
                                const core::EpisodeResult& r, bool& non_finite) {
  const std::size_t n = episode.bodies.size();
  const core::EpisodeOptions& o = episode.options;
  std::ostringstream out;
  out.precision(17);
  non_finite = false;
  if (r.bodies.size() != n || r.outcomes.size() != n) {
    out << "result has " << r.bodies.size() << " bodies and " << r.outcomes.size()
        << " outcomes for " << n << " bodies";
    return out.str();
  }
  if (r.accumulated_impacts < 0) {
    out << "accumulated_impacts " << r.accumulated_impacts << " < 0";
    return out.str();
  }
  if (static_cast<int>(r.impacts.size()) > o.max_impacts) {
    out << r.impacts.size() << " impacts listed, max_impacts " << o.max_impacts;
    return out.str();
  }
  if (r.end == core::EpisodeEnd::kSustainedContact &&
      (r.resting.size() != r.resting_contacts.size() || r.linear_accelerations.size() != n ||
       r.angular_accelerations.size() != n)) {
    out << "sustained contact: " << r.resting_contacts.size() << " contacts, " << r.resting.size()
        << " forces, " << r.linear_accelerations.size() << " / " << r.angular_accelerations.size()
        << " accelerations";
    return out.str();
  }
  non_finite = true;
  if (!std::isfinite(r.end_time)) {
    out << "non-finite end_time " << r.end_time;
    return out.str();
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!finiteState(r.bodies[i])) {
      out << "bodies[" << i << "]: non-finite state at the end";
      return out.str();
    }
  }
  for (std::size_t k = 0; k < r.impacts.size(); ++k) {
    const core::EpisodeImpact& impact = r.impacts[k];
    if (!std::isfinite(impact.time)) {
      out << "impacts[" << k << "]: non-finite time";
      return out.str();
    }
    for (std::size_t c = 0; c < impact.impulses.size(); ++c) {
      const core::ContactImpulse& p = impact.impulses[c];
      if (!std::isfinite(p.normal_impulse) || !p.friction_impulse.allFinite() ||
          !std::isfinite(p.normal_velocity_before) || !std::isfinite(p.normal_velocity_after)) {
        out << "impacts[" << k << "].impulses[" << c << "]: non-finite";
        return out.str();
      }
    }
    for (std::size_t i = 0; i < impact.bodies_after.size(); ++i) {
      if (!finiteState(impact.bodies_after[i])) {
        out << "impacts[" << k << "].bodies_after[" << i << "]: non-finite";
        return out.str();
      }
    }
  }
  for (std::size_t c = 0; c < r.resting.size(); ++c) {
    if (!std::isfinite(r.resting[c].normal_force) || !r.resting[c].friction_force.allFinite()) {
      out << "resting[" << c << "]: non-finite force";
      return out.str();
    }
  }
  for (std::size_t i = 0; i < r.linear_accelerations.size(); ++i) {
    if (!r.linear_accelerations[i].allFinite() || !r.angular_accelerations[i].allFinite()) {
      out << "accelerations of bodies[" << i << "]: non-finite";
      return out.str();
    }
  }
  non_finite = false;
  // Times: within [0, horizon], impacts in order and not after the end.
  const double slack = 1e-12 * std::max(1.0, o.horizon);
  if (r.end_time < 0.0 || r.end_time > o.horizon + slack) {
    out << "end_time " << r.end_time << " outside [0, horizon " << o.horizon << "]";
    return out.str();
  }
  double previous = 0.0;
  for (std::size_t k = 0; k < r.impacts.size(); ++k) {
    const double t = r.impacts[k].time;
    if (t < previous - slack || t > r.end_time + slack) {
      out << "impacts[" << k << "].time " << t << " out of order (previous " << previous
          << ", end_time " << r.end_time << ")";
      return out.str();
    }
    previous = t;
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (episode.bodies[i].immovable() &&
        (r.bodies[i].linear_velocity != episode.bodies[i].linear_velocity ||
         r.bodies[i].angular_velocity != episode.bodies[i].angular_velocity)) {
      out << "bodies[" << i << "]: an immovable body's velocity changed";
      return out.str();
    }
  }
  // An episode that ended separated leaves no body that started above a plane sunk into it.
  if (r.end == core::EpisodeEnd::kSeparated) {
    const double tolerance = o.contact_tolerance;
    const std::vector<double> after = planeGaps(episode, geometry, r.bodies, 4.0 * tolerance);
    for (std::size_t k = 0; k < after.size(); ++k) {
      if (gaps_before[k] >= -tolerance && after[k] < -4.0 * tolerance) {
        out << "ended separated with body " << k % n << " " << -after[k]
            << " m below the plane of body " << k / n << " (contact_tolerance " << tolerance
            << ", its gap at the start " << gaps_before[k] << ")";
        return out.str();
      }
    }
  }
  return "";
}

}  // namespace episode_detail

/// Runs the episode as ~compute_episode does. InvalidInput and SolverTimeout are expected outcomes;
/// any other exception or a broken invariant is reported in EpisodeOutcome::bug.
inline EpisodeOutcome runEpisode(const DecodedEpisode& episode) {
  EpisodeOutcome outcome;
  try {
    core::Scene scene;
    scene.bodies = episode.bodies;
    const core::SceneValidator validator(scene, episode.options.solver, core::RequestLimits{});
    const detection::ShapeGaps geometry(episode.bodies, episode.input, episode.materials);
    // The deepest gap of each plane pair at the start (sinking is only a bug for a body that
    // started above its plane).
    const std::vector<double> before =
        episode_detail::planeGaps(episode, geometry, episode.bodies,
                                  std::isfinite(episode.options.contact_tolerance)
                                      ? std::abs(episode.options.contact_tolerance)
                                      : 0.0);
    outcome.result = core::computeEpisode(episode.bodies, geometry, episode.options);
    outcome.solved = true;
    outcome.bug =
        episode_detail::checkEpisode(episode, geometry, before, outcome.result, outcome.non_finite);
  } catch (const core::InvalidInput& error) {
    outcome.invalid = error.what();
  } catch (const core::SolverTimeout& error) {
    outcome.timeout = error.what();
  } catch (const std::exception& error) {
    outcome.bug = std::string("unexpected exception: ") + error.what();
  } catch (...) {
    outcome.bug = "unexpected exception of unknown type";
  }
  return outcome;
}

/// The episode in readable form (17 significant digits), for bug reports.
inline std::string describe(const DecodedEpisode& episode) {
  std::ostringstream out;
  out.precision(17);
  const auto vec = [](const Eigen::Vector3d& v) {
    std::ostringstream s;
    s.precision(17);
    s << "[" << v[0] << ", " << v[1] << ", " << v[2] << "]";
    return s.str();
  };
  const core::EpisodeOptions& o = episode.options;
  out << "options: law " << core::toString(o.solver.law) << ", solver "
      << core::toString(o.solver.method) << ", tolerance " << o.solver.tolerance
      << ", max_iterations " << o.solver.max_iterations << ", integration_tolerance "
      << o.solver.integration_tolerance << ", resting_velocity " << o.solver.resting_velocity
      << ", time_budget " << o.solver.time_budget << "\n  gravity " << vec(o.gravity)
      << ", horizon " << o.horizon << ", max_impacts " << o.max_impacts << ", contact_tolerance "
      << o.contact_tolerance << "\n";
  const detection::ContactMaterial& m = episode.input.defaults;
  out << "defaults: e " << m.restitution << ", mu_s " << m.static_friction << ", mu_d "
      << m.dynamic_friction << "; max_contacts_per_pair "
      << episode.input.options.max_contacts_per_pair << "\n";
  static const char* const kTypes[] = {"box", "sphere", "cylinder", "cone", "mesh", "plane"};
  for (std::size_t i = 0; i < episode.bodies.size(); ++i) {
    const core::BodyState& b = episode.bodies[i];
    out << "bodies[" << i << "]: mass " << b.mass << ", com " << vec(b.com) << "\n  inertia ["
        << b.inertia.row(0) << "; " << b.inertia.row(1) << "; " << b.inertia.row(2) << "]"
        << "\n  position " << vec(b.position) << ", orientation (w x y z) " << b.orientation.w()
        << " " << b.orientation.x() << " " << b.orientation.y() << " " << b.orientation.z()
        << "\n  linear " << vec(b.linear_velocity) << ", angular " << vec(b.angular_velocity)
        << "\n  force " << vec(b.force) << ", torque " << vec(b.torque);
    if (i < episode.input.materials.size())
      out << ", material '" << episode.input.materials[i] << "'";
    if (i < episode.input.collision_groups.size())
      out << ", group " << episode.input.collision_groups[i];
    out << "\n";
    for (const detection::Shape& s : episode.input.geometry[i].shapes) {
      out << "  " << kTypes[static_cast<int>(s.type)] << " [";
      for (std::size_t k = 0; k < s.dimensions.size(); ++k)
        out << (k ? ", " : "") << s.dimensions[k];
      out << "]";
      if (s.type == detection::Shape::Type::kMesh) {
        out << " " << s.vertices.size() << " vertices {";
        for (const auto& v : s.vertices) out << vec(v) << " ";
        out << "} triangles {";
        for (const auto& t : s.triangles) out << t[0] << " " << t[1] << " " << t[2] << "; ";
        out << "}";
      }
      out << " at " << vec(s.pose.translation()) << "\n";
    }
  }
  return out.str();
}

/// The outcome in readable form.
inline std::string describe(const EpisodeOutcome& outcome) {
  std::ostringstream out;
  out.precision(17);
  if (!outcome.bug.empty()) out << "BUG: " << outcome.bug << "\n";
  if (!outcome.invalid.empty()) out << "outcome: InvalidInput: " << outcome.invalid << "\n";
  if (!outcome.timeout.empty()) out << "outcome: SolverTimeout: " << outcome.timeout << "\n";
  if (!outcome.solved) return out.str();
  const core::EpisodeResult& r = outcome.result;
  out << "outcome: " << core::toString(r.end) << " at " << r.end_time << " s after "
      << r.impacts.size() << " impacts (+" << r.accumulated_impacts << " accumulated)\n";
  for (const core::EpisodeImpact& impact : r.impacts) {
    out << "  impact at " << impact.time << " s, " << impact.contacts.size() << " contacts\n";
  }
  for (std::size_t i = 0; i < r.bodies.size(); ++i) {
    out << "  bodies[" << i << "] " << core::toString(r.outcomes[i]) << ": position "
        << r.bodies[i].position.transpose() << ", linear "
        << r.bodies[i].linear_velocity.transpose() << "\n";
  }
  return out.str();
}

}  // namespace collision_response::fuzz
