// Decodes arbitrary bytes into a request of the core (Scene, SolverOptions, RequestLimits), runs
// core::computeResponse on it and checks the outcome. Shared by the libFuzzer target
// (fuzz_compute_response.cpp) and the regression test (test_fuzz_regressions.cpp), so a saved input
// replays exactly as the fuzzer saw it.
//
// The decoding is total (any byte string gives a request; missing bytes read as 0, which selects
// the "sane" branch of every choice, so short inputs give valid scenes) and mixes:
//  - sane values mapped into physical ranges (log-uniform masses and principal moments, rotated
//    inertias that are positive definite and satisfy the triangle inequality, unit quaternions and
//    normals, e in [0, 1], 0 <= mu_d <= mu_s), so that the solvers are reached;
//  - special values (0, -0, +-1, +-inf, NaN, denormals, huge, epsilon) and raw doubles straight
//    from the bytes, so that validation and extreme arithmetic are exercised;
//  - body ids from a small set (duplicates and empty ids appear) and contacts that mostly name two
//    different existing bodies, sometimes the same one or an unknown id.
// Iteration caps are kept small (max_iterations <= 200) so that no input can run for long.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <exception>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "collision_response/core/compute_response.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/scene.h"
#include "collision_response/core/solver_options.h"
#include "collision_response/core/uncertainty.h"

namespace collision_response::fuzz {

namespace core = collision_response::core;

constexpr std::size_t kMaxBodies = 6;
constexpr std::size_t kMaxContacts = 14;  // > 12: SOLVER_AUTO then takes the iterative solver
constexpr std::size_t kMaxIterations = 200;

/// Reads the input front to back; past its end every read gives zeros.
class ByteReader {
 public:
  ByteReader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  std::uint8_t byte() { return pos_ < size_ ? data_[pos_++] : 0; }
  std::uint16_t u16() {
    const std::uint16_t lo = byte();
    return static_cast<std::uint16_t>(lo | (byte() << 8));
  }
  /// Uniform in [0, 1] from 16 bits.
  double unit() { return u16() / 65535.0; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * unit(); }
  double logUniform(double lo, double hi) {
    return std::exp(std::log(lo) + (std::log(hi) - std::log(lo)) * unit());
  }
  /// Eight bytes reinterpreted as a double: NaN payloads, infinities, denormals, anything.
  double raw() {
    std::uint64_t bits = 0;
    for (int i = 0; i < 8; ++i) bits |= static_cast<std::uint64_t>(byte()) << (8 * i);
    double value;
    std::memcpy(&value, &bits, sizeof value);
    return value;
  }
  double special() {
    static const double kValues[] = {0.0,
                                     -0.0,
                                     1.0,
                                     -1.0,
                                     std::numeric_limits<double>::quiet_NaN(),
                                     std::numeric_limits<double>::infinity(),
                                     -std::numeric_limits<double>::infinity(),
                                     std::numeric_limits<double>::denorm_min(),
                                     std::numeric_limits<double>::min(),
                                     std::numeric_limits<double>::max(),
                                     -std::numeric_limits<double>::max(),
                                     std::numeric_limits<double>::epsilon(),
                                     1e-300,
                                     1e300,
                                     1e-12,
                                     1e12};
    return kValues[byte() % (sizeof kValues / sizeof kValues[0])];
  }
  /// In `wild` mode (sometimes) a special or raw value instead of a sane one.
  double value(bool wild, double lo, double hi) {
    if (wild) {
      const std::uint8_t mode = byte();
      if (mode % 8 == 1) return special();
      if (mode % 8 == 2) return raw();
    }
    return uniform(lo, hi);
  }
  Eigen::Vector3d vector(bool wild, double lo, double hi) {
    Eigen::Vector3d v;
    for (int i = 0; i < 3; ++i) v[i] = value(wild, lo, hi);
    return v;
  }
  /// A unit vector (an axis now and then, so that contacts line up and become redundant).
  Eigen::Vector3d unitVector() {
    const std::uint8_t mode = byte();
    if (mode % 4 == 3) {
      Eigen::Vector3d axis = Eigen::Vector3d::Zero();
      axis[(mode / 4) % 3] = (mode & 0x80) ? -1.0 : 1.0;
      return axis;
    }
    Eigen::Vector3d v(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
    if (v.norm() < 1e-3) return Eigen::Vector3d::UnitZ();
    return v.normalized();
  }
  Eigen::Quaterniond unitQuaternion() {
    const std::uint8_t mode = byte();
    if (mode % 4 == 3) return Eigen::Quaterniond::Identity();
    Eigen::Quaterniond q(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
    if (q.norm() < 1e-3) return Eigen::Quaterniond::Identity();
    q.normalize();
    return q;
  }

  std::size_t consumed() const { return std::min(pos_, size_); }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

struct DecodedRequest {
  core::Scene scene;
  core::SolverOptions options;
  core::RequestLimits limits;
  /// The request's outcome distribution (docs/uncertainty.md), decoded from the bytes after the
  /// contacts: none when they run out (so that inputs saved before it replay as they did).
  bool with_uncertainty = false;
  std::vector<core::ContactUncertainty> uncertainties;
  core::UncertaintyOptions uncertainty;
};

namespace detail {

inline const char* bodyId(std::size_t i) {
  static const char* const kIds[] = {"b0", "b1", "b2", "b3", "b4", "b5", "b6", "b7"};
  return kIds[i % 8];
}

inline core::SolverOptions decodeOptions(ByteReader& in) {
  core::SolverOptions options;
  const std::uint8_t selector = in.byte();
  // Byte 0 reads as Stronge / auto, the defaults.
  static const core::ImpactLaw kLaws[] = {core::ImpactLaw::kStronge, core::ImpactLaw::kPoisson,
                                          core::ImpactLaw::kNewton, core::ImpactLaw::kSeedOnePass};
  static const core::SolverMethod kMethods[] = {
      core::SolverMethod::kAuto, core::SolverMethod::kExact, core::SolverMethod::kIterative};
  options.law = kLaws[selector % 4];
  options.method = kMethods[(selector / 4) % 3];
  const bool wild = (selector & 0x80) != 0 && (selector & 0x40) != 0;

  const std::uint8_t tol = in.byte();
  static const double kTolerances[] = {1e-12, 0.0, 1e-9, 1e-6, 1e-3, 0.1, 1.0, 1e-15};
  options.tolerance = (wild && tol >= 0xf0) ? in.raw() : kTolerances[tol % 8];

  const std::uint8_t iterations = in.byte();
  // 0 is rejected by validation: only in wild mode.
  options.max_iterations = wild && iterations == 0xff ? 0 : 1 + iterations % kMaxIterations;

  const std::uint8_t itol = in.byte();
  static const double kIntegration[] = {1e-10, 1e-6, 1e-3, 1e-12, 1e-14, 0.1};
  options.integration_tolerance = (wild && itol >= 0xf0) ? in.raw() : kIntegration[itol % 6];

  const std::uint8_t rest = in.byte();
  static const double kResting[] = {1e-6, 0.0, 1e-3, 0.1, 1.0, 1e-12};
  options.resting_velocity = (wild && rest >= 0xf0) ? in.raw() : kResting[rest % 6];

  // A budget well above any input's solve time under the sanitizers (and below libFuzzer's
  // -timeout=10), so SolverTimeout does not depend on the machine; wild: any value (validation).
  const std::uint8_t budget = in.byte();
  options.time_budget = (wild && budget >= 0xf0) ? in.raw() : 5.0;
  return options;
}

inline core::RequestLimits decodeLimits(ByteReader& in) {
  core::RequestLimits limits;
  const std::uint8_t mode = in.byte();
  if (mode >= 0xf0) {  // small limits, often exceeded
    limits.max_bodies = in.byte() % 8;
    limits.max_contacts = in.byte() % 16;
  }
  return limits;
}

inline Eigen::Matrix3d saneInertia(ByteReader& in) {
  // Principal moments from the semi-axes of a solid ellipsoid, which always satisfy the triangle
  // inequality; now and then a degenerate case (a thin rod or a flat disk at the limit).
  const std::uint8_t shape = in.byte();
  const double mass = in.logUniform(1e-3, 1e3);
  Eigen::Vector3d axes(in.logUniform(1e-2, 1.0), in.logUniform(1e-2, 1.0),
                       in.logUniform(1e-2, 1.0));
  Eigen::Vector3d moments(axes[1] * axes[1] + axes[2] * axes[2],
                          axes[0] * axes[0] + axes[2] * axes[2],
                          axes[0] * axes[0] + axes[1] * axes[1]);
  moments *= mass / 5.0;
  if (shape % 8 == 7) moments = Eigen::Vector3d(1.0, 1.0, 2.0) * moments[0];  // flat disk limit
  if (shape % 8 == 6) moments = Eigen::Vector3d::Constant(moments[0]);        // sphere
  const Eigen::Matrix3d rotation = in.unitQuaternion().toRotationMatrix();
  Eigen::Matrix3d inertia = rotation * moments.asDiagonal() * rotation.transpose();
  inertia = 0.5 * (inertia + inertia.transpose()).eval();
  return inertia;
}

inline core::BodyState decodeBody(ByteReader& in, std::size_t index) {
  core::BodyState body;
  const std::uint8_t mode = in.byte();
  const bool wild = mode % 4 == 3;

  const std::uint8_t id = in.byte();
  if (id < 0xe0) {
    body.id = bodyId(index);
  } else if (id < 0xf8) {
    body.id = bodyId(id);  // may duplicate another body's id
  } else {
    body.id = "";
  }

  const std::uint8_t kind = in.byte();
  if (kind % 4 == 0) {
    body.mass = 0.0;  // immovable
  } else if (wild && kind % 4 == 3) {
    body.mass = (kind & 0x80) ? in.raw() : in.special();
  } else {
    body.mass = in.logUniform(1e-3, 1e3);
  }

  const std::uint8_t inertia_mode = in.byte();
  if (wild && inertia_mode % 4 == 1) {
    // Symmetric, arbitrary entries.
    for (int r = 0; r < 3; ++r) {
      for (int c = r; c < 3; ++c) body.inertia(r, c) = body.inertia(c, r) = in.value(true, -1, 1);
    }
  } else if (wild && inertia_mode % 4 == 2) {
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) body.inertia(r, c) = in.value(true, -1, 1);  // any matrix
    }
  } else if (body.mass != 0.0 || inertia_mode % 2 == 1) {
    body.inertia = saneInertia(in);
  }

  body.com = in.vector(wild, -0.1, 0.1);
  body.position = in.vector(wild, -1.0, 1.0);
  if (wild && (mode & 0x80)) {
    Eigen::Vector4d q;
    for (int i = 0; i < 4; ++i) q[i] = in.value(true, -1, 1);
    body.orientation = Eigen::Quaterniond(q[3], q[0], q[1], q[2]);  // not normalised
  } else {
    body.orientation = in.unitQuaternion();
  }
  body.linear_velocity = in.vector(wild, -10.0, 10.0);
  body.angular_velocity = in.vector(wild, -10.0, 10.0);
  const std::uint8_t wrench = in.byte();
  if (wrench % 2 == 1) {
    body.force = in.vector(wild, -20.0, 20.0);
    body.torque = in.vector(wild, -5.0, 5.0);
  } else if (wrench % 4 == 2) {
    body.force = Eigen::Vector3d(0.0, 0.0, -9.81) * (body.mass > 0.0 ? body.mass : 0.0);
  }
  // Now and then a body at rest, so that resting contacts (|u_n| ~ 0) appear.
  if (mode % 8 == 4) {
    body.linear_velocity.setZero();
    body.angular_velocity.setZero();
  }
  return body;
}

inline core::Contact decodeContact(ByteReader& in, const std::vector<core::BodyState>& bodies) {
  core::Contact contact;
  const std::uint8_t mode = in.byte();
  const bool wild = mode % 4 == 3;
  const std::size_t n = bodies.size();

  const std::uint8_t pick_a = in.byte();
  const std::uint8_t pick_b = in.byte();
  if (n == 0 || (wild && (mode & 0x40))) {
    static const char* const kOther[] = {"", "zz", "b0", "b7"};
    contact.body_a = kOther[pick_a % 4];
    contact.body_b = kOther[pick_b % 4];
  } else {
    const std::size_t a = pick_a % n;
    // Mostly a different body; in wild mode sometimes the same one.
    const std::size_t b = (n == 1 || (wild && pick_b >= 0xf0)) ? a : (a + 1 + pick_b % (n - 1)) % n;
    contact.body_a = bodies[a].id;
    contact.body_b = bodies[b].id;
  }

  contact.point = in.vector(wild, -1.0, 1.0);
  if (wild && (mode & 0x80)) {
    contact.normal = in.vector(true, -1.0, 1.0);
  } else {
    contact.normal = in.unitVector();
    // Within the accepted |n| - 1 tolerance, so the library normalises it.
    if (mode % 8 == 5) contact.normal *= 1.0 + in.uniform(-9e-4, 9e-4);
  }

  const std::uint8_t e = in.byte();
  static const double kRestitution[] = {0.5, 0.0, 1.0};
  contact.restitution = e % 4 == 3 ? in.value(wild, 0.0, 1.0) : kRestitution[e % 4];

  const std::uint8_t mu = in.byte();
  if (mu % 4 == 0) {
    contact.static_friction = contact.dynamic_friction = 0.0;
  } else if (wild && mu % 4 == 3) {
    contact.static_friction = in.value(true, 0.0, 2.0);
    contact.dynamic_friction = in.value(true, 0.0, 2.0);
  } else {
    contact.static_friction = in.uniform(0.0, 2.0);
    contact.dynamic_friction =
        mu % 4 == 1 ? contact.static_friction : contact.static_friction * in.unit();
  }
  return contact;
}

}  // namespace detail

/// The request encoded by `data`. Layout: options (5 bytes), limits (1 or 3), body count, contact
/// count, then each body and each contact, field by field; see the detail:: functions.
namespace detail {

// A coefficient's distribution: none, a normal or an interval of sane values, or raw doubles
// (NaN, negative spreads, min > max, means outside the range).
inline std::optional<core::CoefficientDistribution> decodeCoefficient(ByteReader& in,
                                                                      double upper) {
  const std::uint8_t kind = in.byte();
  switch (kind % 5) {
    case 0:
      return std::nullopt;
    case 1:
      return core::CoefficientDistribution::normal(in.uniform(0.0, upper),
                                                   in.uniform(0.0, 0.1 * upper));
    case 2: {
      const double a = in.uniform(0.0, upper), b = in.uniform(0.0, upper);
      return core::CoefficientDistribution::interval(std::min(a, b), std::max(a, b));
    }
    case 3:
      return core::CoefficientDistribution::normal(in.raw(), in.raw());
    default:
      return core::CoefficientDistribution::interval(in.raw(), in.raw());
  }
}

// A spread of the normal [rad] or of a point's axis [m]: mostly 0 or small, sometimes raw.
inline double decodeSpread(ByteReader& in, double scale) {
  const std::uint8_t kind = in.byte();
  switch (kind % 6) {
    case 0:
    case 1:
      return 0.0;
    case 2:
    case 3:
      return in.uniform(0.0, scale);
    case 4:
      return -in.uniform(0.0, scale);
    default:
      return in.raw();
  }
}

// An outcome distribution's request over `contacts` contacts: false (none) when the selector byte
// is a multiple of 4, as past the input's end; else the method, a sample count (now and then out of
// range), a seed, and the uncertainties (now and then naming a contact past the end).
inline bool decodeUncertainty(ByteReader& in, std::size_t contacts,
                              std::vector<core::ContactUncertainty>& uncertainties,
                              core::UncertaintyOptions& uncertainty) {
  const std::uint8_t selector = in.byte();
  if (selector % 4 == 0) return false;  // (also when the input has run out)
  uncertainty.method =
      selector % 4 == 3 ? core::UncertaintyMethod::kSampled : core::UncertaintyMethod::kLinear;
  // Few samples, and now and then a count out of range (0, over the cap).
  const std::uint8_t samples = in.byte();
  uncertainty.samples = samples == 255   ? core::kMaxUncertaintySamples + 1
                        : samples == 254 ? 0
                                         : 1 + samples % 16;
  uncertainty.seed = in.byte();
  const std::size_t count = in.byte() % (contacts + 2);
  for (std::size_t k = 0; k < count; ++k) {
    core::ContactUncertainty u;
    u.contact = in.byte() % (contacts + 1);  // now and then one past the end
    u.restitution = decodeCoefficient(in, 1.0);
    u.static_friction = decodeCoefficient(in, 1.5);
    u.dynamic_friction = decodeCoefficient(in, 1.0);
    u.normal_std_dev = decodeSpread(in, 0.2);
    for (int axis = 0; axis < 3; ++axis) u.point_std_dev[axis] = decodeSpread(in, 0.05);
    uncertainties.push_back(u);
  }
  return true;
}

}  // namespace detail

inline DecodedRequest decodeRequest(const std::uint8_t* data, std::size_t size) {
  ByteReader in(data, size);
  DecodedRequest request;
  request.options = detail::decodeOptions(in);
  request.limits = detail::decodeLimits(in);
  // Counts default to 2 bodies and 1 contact when the input runs out.
  const std::size_t body_count = (in.byte() + 2) % (kMaxBodies + 1);
  const std::size_t contact_count = (in.byte() + 1) % (kMaxContacts + 1);
  for (std::size_t i = 0; i < body_count; ++i)
    request.scene.bodies.push_back(detail::decodeBody(in, i));
  for (std::size_t i = 0; i < contact_count; ++i)
    request.scene.contacts.push_back(detail::decodeContact(in, request.scene.bodies));
  request.with_uncertainty = detail::decodeUncertainty(in, request.scene.contacts.size(),
                                                       request.uncertainties, request.uncertainty);
  return request;
}

/// What running a request gave.
struct Outcome {
  bool solved = false;  ///< computeResponse returned (otherwise InvalidInput, a timeout or a bug)
  std::string invalid;  ///< the InvalidInput message, if any
  std::string timeout;  ///< the SolverTimeout message, if any (a slow input, not a wrong one)
  std::string bug;      ///< non-empty: an unexpected exception or a broken invariant
  bool non_finite = false;  ///< the bug is a non-finite number in a successful answer
  core::CollisionResult result;
  /// With an uncertainty: whether computeOutcomeDistribution() answered (else InvalidInput or a
  /// timeout, in `invalid` / `timeout` with "uncertainty: " before it).
  bool distributed = false;
  core::OutcomeDistribution distribution;
};

/// True if some number of the scene is finite but huge (|x| > bound) or tiny (0 < |x| < 1 /
/// bound): inputs on which intermediate products can overflow. The fuzz target can be told to
/// excuse non-finite answers to such inputs (FUZZ_SKIP_EXTREME=1) so that it looks further.
inline bool extremeMagnitudes(const DecodedRequest& request, double bound = 1e20) {
  const auto extreme = [bound](double x) {
    const double m = std::abs(x);
    return std::isfinite(m) && (m > bound || (m != 0.0 && m < 1.0 / bound));
  };
  const auto any = [&](const auto& matrix) {
    for (Eigen::Index i = 0; i < matrix.size(); ++i) {
      if (extreme(matrix.data()[i])) return true;
    }
    return false;
  };
  for (const core::BodyState& b : request.scene.bodies) {
    if (extreme(b.mass) || any(b.com) || any(b.inertia) || any(b.position) ||
        any(b.orientation.coeffs()) || any(b.linear_velocity) || any(b.angular_velocity) ||
        any(b.force) || any(b.torque))
      return true;
  }
  for (const core::Contact& c : request.scene.contacts) {
    if (any(c.point) || any(c.normal) || extreme(c.restitution) || extreme(c.static_friction) ||
        extreme(c.dynamic_friction))
      return true;
  }
  return false;
}

namespace detail {

inline bool finite(const Eigen::Vector3d& v) {
  return v.allFinite();
}

/// Cheap invariants of a successful answer; returns the first one broken, or "". Structural ones
/// first; non_finite says the one returned is a non-finite number.
inline std::string checkResult(const DecodedRequest& request, const core::CollisionResult& r,
                               bool& non_finite) {
  const core::Scene& scene = request.scene;
  non_finite = false;
  std::ostringstream out;
  out.precision(17);
  if (r.bodies.size() != scene.bodies.size()) {
    out << "result.bodies.size() " << r.bodies.size() << " != " << scene.bodies.size();
    return out.str();
  }
  if (r.impulses.size() != scene.contacts.size()) {
    out << "result.impulses.size() " << r.impulses.size() << " != " << scene.contacts.size();
    return out.str();
  }
  for (std::size_t i = 0; i < r.bodies.size(); ++i) {
    const core::BodyState& before = scene.bodies[i];
    const core::BodyState& after = r.bodies[i];
    if (after.id != before.id || after.mass != before.mass) {
      out << "bodies[" << i << "]: id or mass changed";
      return out.str();
    }
    if (before.immovable() && (after.linear_velocity != before.linear_velocity ||
                               after.angular_velocity != before.angular_velocity)) {
      out << "bodies[" << i << "]: immovable body's velocity changed";
      return out.str();
    }
  }
  // Islands partition the contacts.
  std::vector<int> seen(scene.contacts.size(), 0);
  for (std::size_t k = 0; k < r.islands.size(); ++k) {
    for (const int c : r.islands[k].contacts) {
      if (c < 0 || static_cast<std::size_t>(c) >= seen.size()) {
        out << "islands[" << k << "]: contact index " << c << " out of range";
        return out.str();
      }
      ++seen[c];
    }
  }
  for (std::size_t c = 0; c < seen.size(); ++c) {
    if (seen[c] != 1) {
      out << "contacts[" << c << "] is in " << seen[c] << " islands";
      return out.str();
    }
  }

  non_finite = true;
  for (std::size_t i = 0; i < r.bodies.size(); ++i) {
    const core::BodyState& after = r.bodies[i];
    if (!finite(after.linear_velocity) || !finite(after.angular_velocity)) {
      out << "bodies[" << i << "]: non-finite velocity after: linear "
          << after.linear_velocity.transpose() << ", angular "
          << after.angular_velocity.transpose();
      return out.str();
    }
  }
  for (std::size_t c = 0; c < r.impulses.size(); ++c) {
    const core::ContactImpulse& p = r.impulses[c];
    if (!std::isfinite(p.normal_impulse) || !finite(p.friction_impulse) ||
        !std::isfinite(p.normal_velocity_before) || !std::isfinite(p.normal_velocity_after) ||
        !std::isfinite(p.normal_force) || !finite(p.friction_force)) {
      out << "impulses[" << c << "]: non-finite value (normal_impulse " << p.normal_impulse
          << ", friction_impulse " << p.friction_impulse.transpose() << ", u_n before "
          << p.normal_velocity_before << ", after " << p.normal_velocity_after << ", normal_force "
          << p.normal_force << ", friction_force " << p.friction_force.transpose() << ")";
      return out.str();
    }
  }
  if (!std::isfinite(r.kinetic_energy_before) || !std::isfinite(r.kinetic_energy_after)) {
    out << "non-finite kinetic energy (" << r.kinetic_energy_before << " -> "
        << r.kinetic_energy_after << ")";
    return out.str();
  }
  for (std::size_t k = 0; k < r.islands.size(); ++k) {
    if (!std::isfinite(r.islands[k].residual) && r.islands[k].converged) {
      out << "islands[" << k << "]: converged with a non-finite residual";
      return out.str();
    }
  }
  non_finite = false;
  return "";
}

}  // namespace detail

/// Runs computeResponse on the request. InvalidInput is an expected outcome; any other exception
/// or a broken invariant of the answer is reported in Outcome::bug.
namespace detail {

// Cheap invariants of an answered distribution: sizes as the rows of the prediction (6 per movable
// body, 4 per contact), a symmetric covariance with a non-negative diagonal, q05 <= mean <= q95
// (linear: symmetric about the mean), probabilities in [0, 1], finite numbers where the prediction
// is finite (non_finite otherwise).
// `m` the rows expected, `contacts` the contacts, `method` the method asked for.
inline std::string checkDistribution(Eigen::Index m, std::size_t contacts,
                                     core::UncertaintyMethod method,
                                     const core::OutcomeDistribution& d, bool& non_finite) {
  if (d.mean.size() != m || d.covariance.rows() != m || d.covariance.cols() != m ||
      d.q05.size() != m || d.q95.size() != m || d.labels.size() != static_cast<std::size_t>(m))
    return "uncertainty: the distribution's sizes differ from the prediction's rows";
  if (d.stick_probability.size() != contacts)
    return "uncertainty: one stick probability per contact expected";
  if (d.method != method) return "uncertainty: another method answered";
  for (const double p : d.stick_probability)
    if (!(p >= 0.0 && p <= 1.0)) return "uncertainty: a stick probability outside [0, 1]";
  for (const double p : d.limit_probability)
    if (!(p >= 0.0 && p <= 1.0)) return "uncertainty: a limit probability outside [0, 1]";
  if (!d.mean.allFinite() || !d.covariance.allFinite() || !d.q05.allFinite() ||
      !d.q95.allFinite()) {
    non_finite = true;
    return "uncertainty: non-finite mean, covariance or quantile";
  }
  if (m == 0) return "";
  const double scale = std::max(1.0, d.covariance.cwiseAbs().maxCoeff());
  if ((d.covariance - d.covariance.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale)
    return "uncertainty: covariance not symmetric";
  for (Eigen::Index i = 0; i < m; ++i) {
    const double slack =
        1e-9 * std::max({1.0, std::abs(d.mean(i)), std::abs(d.q05(i)), std::abs(d.q95(i))});
    if (d.covariance(i, i) < 0.0) return "uncertainty: negative variance";
    if (d.q05(i) > d.q95(i) + slack) return "uncertainty: q05 above q95";
    if (d.method == core::UncertaintyMethod::kLinear &&
        (d.q05(i) > d.mean(i) + slack || d.q95(i) < d.mean(i) - slack))
      return "uncertainty: linear quantiles not about the mean";
  }
  return "";
}

}  // namespace detail

inline Outcome run(const DecodedRequest& request) {
  Outcome outcome;
  try {
    outcome.result = core::computeResponse(request.scene, request.options, request.limits);
    outcome.solved = true;
  } catch (const core::InvalidInput& error) {
    outcome.invalid = error.what();
    return outcome;
  } catch (const core::SolverTimeout& error) {
    outcome.timeout = error.what();
    return outcome;
  } catch (const std::exception& error) {
    outcome.bug = std::string("unexpected exception: ") + error.what();
    return outcome;
  } catch (...) {
    outcome.bug = "unexpected exception of unknown type";
    return outcome;
  }
  outcome.bug = detail::checkResult(request, outcome.result, outcome.non_finite);
  if (!outcome.bug.empty() || !request.with_uncertainty) return outcome;
  // The outcome distribution of the same (valid, solvable) request.
  try {
    outcome.distribution =
        core::computeOutcomeDistribution(request.scene, request.uncertainties, request.options,
                                         request.uncertainty, nullptr, request.limits);
    outcome.distributed = true;
  } catch (const core::InvalidInput& error) {
    outcome.invalid = std::string("uncertainty: ") + error.what();
    return outcome;
  } catch (const core::SolverTimeout& error) {
    outcome.timeout = std::string("uncertainty: ") + error.what();
    return outcome;
  } catch (const std::exception& error) {
    outcome.bug = std::string("uncertainty: unexpected exception: ") + error.what();
    return outcome;
  } catch (...) {
    outcome.bug = "uncertainty: unexpected exception of unknown type";
    return outcome;
  }
  Eigen::Index movable = 0;
  for (const core::BodyState& body : request.scene.bodies) movable += body.immovable() ? 0 : 1;
  outcome.bug = detail::checkDistribution(
      6 * movable + 4 * static_cast<Eigen::Index>(request.scene.contacts.size()),
      request.scene.contacts.size(), request.uncertainty.method, outcome.distribution,
      outcome.non_finite);
  return outcome;
}

/// The request in readable form (17 significant digits), for bug reports.
inline std::string describe(const DecodedRequest& request) {
  std::ostringstream out;
  out.precision(17);
  const auto vec = [&](const Eigen::Vector3d& v) {
    std::ostringstream s;
    s.precision(17);
    s << "[" << v[0] << ", " << v[1] << ", " << v[2] << "]";
    return s.str();
  };
  out << "options: law " << core::toString(request.options.law) << ", solver "
      << core::toString(request.options.method) << ", tolerance " << request.options.tolerance
      << ", max_iterations " << request.options.max_iterations << ", integration_tolerance "
      << request.options.integration_tolerance << ", resting_velocity "
      << request.options.resting_velocity << "\n";
  out << "limits: max_bodies " << request.limits.max_bodies << ", max_contacts "
      << request.limits.max_contacts << "\n";
  for (std::size_t i = 0; i < request.scene.bodies.size(); ++i) {
    const core::BodyState& b = request.scene.bodies[i];
    out << "bodies[" << i << "]: id '" << b.id << "', mass " << b.mass << ", com " << vec(b.com)
        << "\n  inertia [" << b.inertia.row(0) << "; " << b.inertia.row(1) << "; "
        << b.inertia.row(2) << "]"
        << "\n  position " << vec(b.position) << ", orientation (w x y z) " << b.orientation.w()
        << " " << b.orientation.x() << " " << b.orientation.y() << " " << b.orientation.z()
        << "\n  linear " << vec(b.linear_velocity) << ", angular " << vec(b.angular_velocity)
        << "\n  force " << vec(b.force) << ", torque " << vec(b.torque) << "\n";
  }
  for (std::size_t i = 0; i < request.scene.contacts.size(); ++i) {
    const core::Contact& c = request.scene.contacts[i];
    out << "contacts[" << i << "]: '" << c.body_a << "' -> '" << c.body_b << "', point "
        << vec(c.point) << ", normal " << vec(c.normal) << ", e " << c.restitution << ", mu_s "
        << c.static_friction << ", mu_d " << c.dynamic_friction << "\n";
  }
  if (request.with_uncertainty) {
    out << "uncertainty: " << core::toString(request.uncertainty.method) << ", samples "
        << request.uncertainty.samples << ", seed " << request.uncertainty.seed << "\n";
    const auto distribution = [](const std::optional<core::CoefficientDistribution>& d) {
      std::ostringstream s;
      s.precision(17);
      if (!d)
        s << "none";
      else if (d->type == core::CoefficientDistribution::Type::kNormal)
        s << "normal(" << d->mean << ", " << d->std_dev << ")";
      else
        s << "interval(" << d->min << ", " << d->max << ")";
      return s.str();
    };
    for (std::size_t k = 0; k < request.uncertainties.size(); ++k) {
      const core::ContactUncertainty& u = request.uncertainties[k];
      out << "uncertainties[" << k << "]: contact " << u.contact << ", e "
          << distribution(u.restitution) << ", mu_s " << distribution(u.static_friction)
          << ", mu_d " << distribution(u.dynamic_friction) << ", normal_std_dev "
          << u.normal_std_dev << ", point_std_dev " << vec(u.point_std_dev) << "\n";
    }
  }
  return out.str();
}

}  // namespace collision_response::fuzz
