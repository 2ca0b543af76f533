// Gaps between the bodies' shapes for impact episodes: pairs with a plane in closed form, every
// other pair through ContactDetector (FCL). No FCL header here: contact_detector.cpp stays the only
// translation unit that includes FCL.

#include "collision_response/detection/shape_gaps.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>

#include "collision_response/core/errors.h"
#include "collision_response/core/validation.h"
#include "collision_response/detection/contact_detector.h"
#include "collision_response/detection/manifold.h"

namespace collision_response::detection {

namespace {

/// Points sampled around a circular rim (a cylinder's caps, a cone's base) against a plane, besides
/// the rim's exact lowest point.
constexpr int kRimSamples = 16;
/// Detectors kept per query for concurrent calls; a call finding all busy uses a fresh one.
constexpr std::size_t kPoolSize = 8;
/// Distinct material names up to which the coefficients of every pair are tabulated at
/// construction (beyond: looked up per reported pair).
constexpr std::size_t kMaxTabulatedMaterials = 64;

std::string indexed(const std::string& prefix, std::size_t i) {
  return prefix + "[" + std::to_string(i) + "]";
}

/// A plane of a body in the body frame: the solid is normal . x <= offset (normal unit, outward).
struct LocalPlane {
  Vec3 normal = Vec3::UnitZ();
  double offset = 0.0;
};

/// A bounded shape of a body in the body frame, in the form the plane closed forms need.
struct LocalSolid {
  enum class Kind { kSphere, kPoints, kCylinder, kCone } kind = Kind::kSphere;
  Vec3 centre = Vec3::Zero();                   ///< the shape frame's origin
  Vec3 axis = Vec3::UnitZ();                    ///< cylinder / cone: the shape frame's z
  Vec3 e1 = Vec3::UnitX(), e2 = Vec3::UnitY();  ///< rim plane
  double radius = 0.0;
  double half_height = 0.0;
  std::vector<Vec3> points;  ///< box corners, mesh vertices (each once)
};

struct BodyData {
  bool immovable = false;
  Vec3 com = Vec3::Zero();
  int group = -1;
  int material = 0;  ///< index into Impl::material_names
  std::vector<LocalPlane> planes;
  std::vector<LocalSolid> solids;
  double radius = 0.0;
  bool convex = false;  ///< one box, sphere, cylinder or cone (core::GapQuery::convex())
};

/// Farthest point of a circle (centre c, unit axis a, radius r) from the point o.
double farthestOnCircle(const Vec3& c, const Vec3& a, double r, const Vec3& o) {
  const Vec3 d = c - o;
  const double along = d.dot(a);
  const double across = (d - along * a).norm() + r;
  return std::sqrt(along * along + across * across);
}

double solidRadius(const LocalSolid& s, const Vec3& com) {
  switch (s.kind) {
    case LocalSolid::Kind::kSphere:
      return (s.centre - com).norm() + s.radius;
    case LocalSolid::Kind::kPoints: {
      double r = 0.0;
      for (const Vec3& p : s.points) r = std::max(r, (p - com).norm());
      return r;
    }
    case LocalSolid::Kind::kCylinder:
      return std::max(farthestOnCircle(s.centre + s.half_height * s.axis, s.axis, s.radius, com),
                      farthestOnCircle(s.centre - s.half_height * s.axis, s.axis, s.radius, com));
    case LocalSolid::Kind::kCone:
      return std::max((s.centre + s.half_height * s.axis - com).norm(),
                      farthestOnCircle(s.centre - s.half_height * s.axis, s.axis, s.radius, com));
  }
  return 0.0;
}

/// The largest d . (x - com) over the solid's points x (body frame).
double solidSupport(const LocalSolid& s, const Vec3& com, const Vec3& d) {
  // A disc (centre c, unit axis a, radius r): d . (c - com) + r |d across a|.
  const auto disc = [&](const Vec3& c, double r) {
    return d.dot(c - com) + r * (d - d.dot(s.axis) * s.axis).norm();
  };
  switch (s.kind) {
    case LocalSolid::Kind::kSphere:
      return d.dot(s.centre - com) + s.radius * d.norm();
    case LocalSolid::Kind::kPoints: {
      double h = -std::numeric_limits<double>::infinity();
      for (const Vec3& p : s.points) h = std::max(h, d.dot(p - com));
      return h;
    }
    case LocalSolid::Kind::kCylinder:
      return std::max(disc(s.centre + s.half_height * s.axis, s.radius),
                      disc(s.centre - s.half_height * s.axis, s.radius));
    case LocalSolid::Kind::kCone:
      return std::max(d.dot(s.centre + s.half_height * s.axis - com),
                      disc(s.centre - s.half_height * s.axis, s.radius));
  }
  return 0.0;
}

LocalSolid localSolid(const Shape& shape) {
  LocalSolid s;
  const Eigen::Matrix3d r = shape.pose.linear();
  s.centre = shape.pose.translation();
  s.axis = r.col(2);
  s.e1 = r.col(0);
  s.e2 = r.col(1);
  const auto& d = shape.dimensions;
  switch (shape.type) {
    case Shape::Type::kSphere:
      s.kind = LocalSolid::Kind::kSphere;
      s.radius = d[0];
      break;
    case Shape::Type::kBox:
      s.kind = LocalSolid::Kind::kPoints;
      for (int k = 0; k < 8; ++k) {
        s.points.push_back(shape.pose * Vec3((k & 1 ? 0.5 : -0.5) * d[0],
                                             (k & 2 ? 0.5 : -0.5) * d[1],
                                             (k & 4 ? 0.5 : -0.5) * d[2]));
      }
      break;
    case Shape::Type::kCylinder:
    case Shape::Type::kCone:
      s.kind = shape.type == Shape::Type::kCylinder ? LocalSolid::Kind::kCylinder
                                                    : LocalSolid::Kind::kCone;
      s.half_height = 0.5 * d[0];
      s.radius = d[1];
      break;
    case Shape::Type::kMesh: {
      // The vertices the triangles use, each once: the lowest point of the mesh against a plane is
      // one of them, convex or not.
      std::vector<char> used(shape.vertices.size(), 0);
      for (const auto& t : shape.triangles) {
        for (int k : t) used[k] = 1;
      }
      s.kind = LocalSolid::Kind::kPoints;
      for (std::size_t k = 0; k < shape.vertices.size(); ++k) {
        if (!used[k]) continue;
        const Vec3 p = shape.pose * shape.vertices[k];
        if (std::find(s.points.begin(), s.points.end(), p) == s.points.end()) s.points.push_back(p);
      }
      break;
    }
    case Shape::Type::kPlane:
      break;
  }
  return s;
}

/// A body's pose this call.
struct Pose {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Vec3 translation = Vec3::Zero();
};

/// Appends the contacts of one solid (body frame, placed by `pose`) against the plane
/// world_normal . x = world_offset (world, outward normal) whose gap is at most range, as
/// DetectedContacts (depth = -gap) with the normal `normal` (the plane's normal or its opposite:
/// from body_a towards body_b) and the point midway between the solid's point and the plane.
void solidAgainstPlane(const LocalSolid& s, const Pose& pose, const Vec3& world_normal,
                       double world_offset, double range, DetectedContact prototype,
                       std::vector<DetectedContact>& out) {
  // gap(x) = n_local . x + c0 for a point x of the body frame.
  const Vec3 n_local = pose.rotation.transpose() * world_normal;
  const double c0 = world_normal.dot(pose.translation) - world_offset;
  auto add = [&](const Vec3& x, double gap) {
    if (!(gap <= range)) return;
    prototype.depth = -gap;
    prototype.point = pose.rotation * x + pose.translation - 0.5 * gap * world_normal;
    out.push_back(prototype);
  };
  switch (s.kind) {
    case LocalSolid::Kind::kSphere: {
      add(s.centre - s.radius * n_local, n_local.dot(s.centre) + c0 - s.radius);
      return;
    }
    case LocalSolid::Kind::kPoints:
      for (const Vec3& p : s.points) add(p, n_local.dot(p) + c0);
      return;
    case LocalSolid::Kind::kCylinder:
    case LocalSolid::Kind::kCone: {
      // The lowest rim point of a cap lies along -w, w the part of the plane normal across the
      // axis; when w vanishes (a cap flat on the plane), the samples span the rim.
      const std::size_t first = out.size();
      const Vec3 w = n_local - n_local.dot(s.axis) * s.axis;
      const double wn = w.norm();
      auto rim = [&](const Vec3& centre) {
        const double h = n_local.dot(centre) + c0;
        if (wn > 1e-12) add(centre - s.radius / wn * w, h - s.radius * wn);
        for (int k = 0; k < kRimSamples; ++k) {
          const double angle = 2.0 * M_PI * k / kRimSamples;
          const Vec3 p = centre + s.radius * (std::cos(angle) * s.e1 + std::sin(angle) * s.e2);
          const double gap = n_local.dot(p) + c0;
          if (!(gap <= range)) continue;
          prototype.depth = -gap;
          prototype.point = pose.rotation * p + pose.translation - 0.5 * gap * world_normal;
          // A sample at the lowest point is that point again.
          bool repeated = false;
          for (std::size_t i = first; i < out.size(); ++i) {
            repeated = repeated || (out[i].point - prototype.point).norm() <= 1e-12;
          }
          if (!repeated) out.push_back(prototype);
        }
      };
      rim(s.centre - s.half_height * s.axis);
      if (s.kind == LocalSolid::Kind::kCylinder) {
        rim(s.centre + s.half_height * s.axis);
      } else {
        const Vec3 apex = s.centre + s.half_height * s.axis;
        add(apex, n_local.dot(apex) + c0);
      }
      return;
    }
  }
}

}  // namespace

struct ShapeGaps::Impl {
  std::vector<BodyData> bodies;
  /// The bodies' shapes without their planes (which never go to FCL), for the detector.
  std::vector<BodyGeometry> fcl_geometry;
  std::vector<int> groups;  ///< empty or one per body
  bool fcl_pairs = false;   ///< some pair of bodies has bounded shapes on both sides
  std::size_t max_contacts_per_pair = 8;

  std::vector<std::string> material_names;  ///< index 0: "" (no material)
  std::vector<ContactMaterial> tabulated;   ///< K x K, or empty
  MaterialTable table;
  ContactMaterial defaults;

  struct Slot {
    std::atomic<bool> busy{false};
    std::unique_ptr<ContactDetector> detector;
    std::vector<core::BodyState> states;  ///< poses of the call, masses from the constructor
  };
  mutable std::array<Slot, kPoolSize> pool;

  bool pairable(int i, int j) const {
    if (i == j) return false;
    if (bodies[i].immovable && bodies[j].immovable) return false;
    return groups.empty() || groups[i] < 0 || groups[i] != groups[j];
  }

  ContactMaterial material(int i, int j) const {
    const int a = bodies[i].material, b = bodies[j].material;
    if (!tabulated.empty()) return tabulated[a * material_names.size() + b];
    return table.lookup(material_names[a], material_names[b], defaults);
  }

  void detectWithFcl(const std::vector<Pose>& poses, const std::vector<core::BodyState>& given,
                     double range, std::vector<DetectedContact>& found) const;
};

ShapeGaps::ShapeGaps(const std::vector<core::BodyState>& bodies, const DetectionInput& input,
                     const MaterialTable& materials, const core::RequestLimits& limits)
    : impl_(std::make_unique<Impl>()) {
  Impl& im = *impl_;
  const std::size_t n = bodies.size();
  core::validateCoefficients(input.defaults.restitution, input.defaults.static_friction,
                             input.defaults.dynamic_friction, "detection");
  if (input.options.max_contacts_per_pair < 1) {
    throw core::InvalidInput("options.max_contacts_per_pair", "must be >= 1");
  }
  if (!input.materials.empty() && input.materials.size() != n) {
    throw core::InvalidInput("bodies", "materials given for " +
                                           std::to_string(input.materials.size()) +
                                           " bodies, expected " + std::to_string(n));
  }
  if (!input.collision_groups.empty() && input.collision_groups.size() != n) {
    throw core::InvalidInput("bodies", "collision groups given for " +
                                           std::to_string(input.collision_groups.size()) +
                                           " bodies, expected " + std::to_string(n));
  }
  std::size_t shapes = 0, vertices = 0, triangles = 0;
  for (const BodyGeometry& body : input.geometry) {
    shapes += body.shapes.size();
    for (const Shape& shape : body.shapes) {
      vertices += shape.vertices.size();
      triangles += shape.triangles.size();
    }
  }
  core::checkGeometrySize(shapes, vertices, triangles, limits);
  validateGeometry(input.geometry, n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::string field = indexed("bodies", i);
    if (!std::isfinite(bodies[i].mass) || bodies[i].mass < 0.0) {
      throw core::InvalidInput(field + ".mass", "must be finite and >= 0 (0: immovable)");
    }
    if (!bodies[i].com.allFinite()) throw core::InvalidInput(field + ".com", "is not finite");
  }

  // Materials: names interned, index 0 for none.
  im.table = materials;
  im.defaults = input.defaults;
  im.material_names.push_back("");
  std::map<std::string, int> ids{{"", 0}};
  im.bodies.resize(n);
  for (std::size_t i = 0; i < input.materials.size(); ++i) {
    const std::string& name = input.materials[i];
    if (!name.empty() && !materials.knows(name)) {
      throw core::InvalidInput(indexed("bodies", i) + ".material",
                               "'" + name + "' is in no entry of the material table");
    }
    auto [it, added] = ids.emplace(name, static_cast<int>(im.material_names.size()));
    if (added) im.material_names.push_back(name);
    im.bodies[i].material = it->second;
  }
  const std::size_t k = im.material_names.size();
  if (k <= kMaxTabulatedMaterials) {
    im.tabulated.resize(k * k);
    for (std::size_t a = 0; a < k; ++a) {
      for (std::size_t b = 0; b < k; ++b) {
        im.tabulated[a * k + b] =
            materials.lookup(im.material_names[a], im.material_names[b], input.defaults);
      }
    }
  }

  im.groups = input.collision_groups;
  im.max_contacts_per_pair = input.options.max_contacts_per_pair;
  im.fcl_geometry.resize(input.geometry.empty() ? 0 : n);
  for (std::size_t i = 0; i < n; ++i) {
    BodyData& body = im.bodies[i];
    body.immovable = bodies[i].immovable();
    body.com = bodies[i].com;
    body.group = im.groups.empty() ? -1 : im.groups[i];
    if (input.geometry.empty()) continue;
    for (const Shape& shape : input.geometry[i].shapes) {
      if (shape.type == Shape::Type::kPlane) {
        const auto& d = shape.dimensions;
        const Vec3 abc(d[0], d[1], d[2]);
        const double norm = abc.norm();
        LocalPlane p;
        p.normal = shape.pose.linear() * (abc / norm);
        p.offset = -d[3] / norm + p.normal.dot(shape.pose.translation());
        body.planes.push_back(p);
        continue;
      }
      body.solids.push_back(localSolid(shape));
      im.fcl_geometry[i].shapes.push_back(shape);
    }
    body.radius = body.planes.empty() ? 0.0 : std::numeric_limits<double>::infinity();
    const auto& shapes = input.geometry[i].shapes;
    body.convex = shapes.size() == 1 && shapes[0].type != Shape::Type::kPlane &&
                  shapes[0].type != Shape::Type::kMesh;
    for (const LocalSolid& s : body.solids) {
      body.radius = std::max(body.radius, solidRadius(s, body.com));
    }
  }
  for (std::size_t i = 0; i < n && !im.fcl_pairs; ++i) {
    for (std::size_t j = i + 1; j < n && !im.fcl_pairs; ++j) {
      im.fcl_pairs = !im.bodies[i].solids.empty() && !im.bodies[j].solids.empty() &&
                     im.pairable(static_cast<int>(i), static_cast<int>(j));
    }
  }
  if (!im.fcl_pairs) im.fcl_geometry.clear();
  for (Impl::Slot& slot : im.pool) {
    slot.states.resize(n);
    for (std::size_t i = 0; i < n; ++i) slot.states[i].mass = bodies[i].immovable() ? 0.0 : 1.0;
  }
}

ShapeGaps::~ShapeGaps() = default;

int ShapeGaps::bodyCount() const {
  return static_cast<int>(impl_->bodies.size());
}

double ShapeGaps::radius(int body) const {
  if (body < 0 || body >= bodyCount()) {
    throw std::out_of_range("ShapeGaps::radius: body " + std::to_string(body) + " of " +
                            std::to_string(bodyCount()));
  }
  return impl_->bodies[body].radius;
}

bool ShapeGaps::convex(int body) const {
  if (body < 0 || body >= bodyCount()) {
    throw std::out_of_range("ShapeGaps::convex: body " + std::to_string(body) + " of " +
                            std::to_string(bodyCount()));
  }
  return impl_->bodies[body].convex;
}

double ShapeGaps::support(int body, const Eigen::Vector3d& direction) const {
  if (body < 0 || body >= bodyCount()) {
    throw std::out_of_range("ShapeGaps::support: body " + std::to_string(body) + " of " +
                            std::to_string(bodyCount()));
  }
  const BodyData& b = impl_->bodies[body];
  if (!b.planes.empty()) return std::numeric_limits<double>::infinity();
  if (b.solids.empty()) return 0.0;
  double h = -std::numeric_limits<double>::infinity();
  for (const LocalSolid& s : b.solids) h = std::max(h, solidSupport(s, b.com, direction));
  return h;
}

void ShapeGaps::Impl::detectWithFcl(const std::vector<Pose>& poses,
                                    const std::vector<core::BodyState>& given, double range,
                                    std::vector<DetectedContact>& found) const {
  DetectionOptions options;
  options.contact_tolerance = range;
  options.feature_band = std::min(range, kFeatureBand);
  options.max_contacts_per_pair = max_contacts_per_pair;
  // Borrow a free detector of the pool (its FCL objects stay built from call to call); when all
  // are busy, this call uses a fresh one rather than wait.
  Slot* slot = nullptr;
  for (Slot& s : pool) {
    bool expected = false;
    if (s.busy.compare_exchange_strong(expected, true, std::memory_order_acquire)) {
      slot = &s;
      break;
    }
  }
  std::vector<core::BodyState> own_states;
  std::unique_ptr<ContactDetector> own_detector;
  ContactDetector* detector = nullptr;
  std::vector<core::BodyState>* states = &own_states;
  if (slot != nullptr) {
    if (!slot->detector) slot->detector = std::make_unique<ContactDetector>();
    detector = slot->detector.get();
    states = &slot->states;
  } else {
    own_detector = std::make_unique<ContactDetector>();
    detector = own_detector.get();
    own_states.resize(bodies.size());
    for (std::size_t i = 0; i < bodies.size(); ++i) {
      own_states[i].mass = bodies[i].immovable ? 0.0 : 1.0;
    }
  }
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    (*states)[i].position = poses[i].translation;
    (*states)[i].orientation = given[i].orientation;
  }
  try {
    found = detector->detect(*states, fcl_geometry, options, groups);
  } catch (...) {
    if (slot != nullptr) slot->busy.store(false, std::memory_order_release);
    throw;
  }
  if (slot != nullptr) slot->busy.store(false, std::memory_order_release);
}

void ShapeGaps::gaps(const std::vector<core::BodyState>& bodies, double range,
                     std::vector<core::GapContact>& out) const {
  const Impl& im = *impl_;
  out.clear();
  const std::size_t n = im.bodies.size();
  if (bodies.size() != n) {
    throw core::InvalidInput("bodies", "gaps asked for " + std::to_string(bodies.size()) +
                                           " bodies, the geometry describes " + std::to_string(n));
  }
  if (!std::isfinite(range) || range < 0.0 || range > kMaxRange) {
    throw core::InvalidInput("range", "must be finite and in [0, 1e12] m");
  }
  // Scratch space reused from call to call by each thread (one thread-local lookup).
  struct Scratch {
    std::vector<Pose> poses;
    std::vector<DetectedContact> pair_points, found;
  };
  thread_local Scratch scratch;
  std::vector<Pose>& poses = scratch.poses;
  std::vector<DetectedContact>& pair_points = scratch.pair_points;
  std::vector<DetectedContact>& found = scratch.found;
  poses.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double q = bodies[i].orientation.norm();
    if (!bodies[i].orientation.coeffs().allFinite() || !(q > 0.0)) {
      throw core::InvalidInput(indexed("bodies", i) + ".orientation", "is not a finite rotation");
    }
    if (!bodies[i].position.allFinite()) {
      throw core::InvalidInput(indexed("bodies", i) + ".position", "is not finite");
    }
    poses[i].rotation = Eigen::Quaterniond(bodies[i].orientation.coeffs() / q).toRotationMatrix();
    poses[i].translation = bodies[i].position;
  }

  auto emit = [&](const DetectedContact& d, bool point_on_plane = false) {
    core::GapContact g;
    g.point_on_plane = point_on_plane;
    g.body_a = d.body_a;
    g.body_b = d.body_b;
    g.point = d.point;
    g.normal = d.normal;
    g.gap = -d.depth;
    const ContactMaterial m = im.material(d.body_a, d.body_b);
    g.restitution = m.restitution;
    g.static_friction = m.static_friction;
    g.dynamic_friction = m.dynamic_friction;
    out.push_back(g);
  };

  // Closed forms: every plane against every bounded shape of another body.
  for (std::size_t i = 0; i < n; ++i) {
    if (im.bodies[i].planes.empty()) continue;
    for (std::size_t j = 0; j < n; ++j) {
      if (im.bodies[j].solids.empty() || !im.pairable(static_cast<int>(i), static_cast<int>(j))) {
        continue;
      }
      DetectedContact prototype;
      prototype.body_a = static_cast<int>(std::min(i, j));
      prototype.body_b = static_cast<int>(std::max(i, j));
      for (const LocalPlane& plane : im.bodies[i].planes) {
        const Vec3 normal = poses[i].rotation * plane.normal;
        const double offset = plane.offset + normal.dot(poses[i].translation);
        prototype.normal = i < j ? normal : Vec3(-normal);
        for (const LocalSolid& solid : im.bodies[j].solids) {
          pair_points.clear();
          solidAgainstPlane(solid, poses[j], normal, offset, range, prototype, pair_points);
          // Every vertex of a box or a mesh within the range, listed, each a material point of
          // body b on the plane of body a (the plane's body first): GapContact::point_on_plane,
          // which lets the episode bound each point's gap on its own. Not after a reduction (a
          // vertex left out), nor for rims and spheres (their lowest point moves on the body).
          const bool vertices = solid.kind == LocalSolid::Kind::kPoints && i < j &&
                                pair_points.size() <= im.max_contacts_per_pair;
          if (pair_points.size() > im.max_contacts_per_pair) {
            reduceContacts(pair_points, im.max_contacts_per_pair);
          }
          for (const DetectedContact& d : pair_points) emit(d, vertices);
        }
      }
    }
  }

  // Every other pair through FCL.
  if (im.fcl_pairs) {
    found.clear();
    im.detectWithFcl(poses, bodies, range, found);
    for (const DetectedContact& d : found) emit(d);
  }
  // By body pair (the plane pairs come first, in the order of their planes' bodies): sorted only
  // when that order differs, since stable_sort allocates.
  const auto by_pair = [](const core::GapContact& x, const core::GapContact& y) {
    return x.body_a < y.body_a || (x.body_a == y.body_a && x.body_b < y.body_b);
  };
  if (!std::is_sorted(out.begin(), out.end(), by_pair)) {
    std::stable_sort(out.begin(), out.end(), by_pair);
  }
}

}  // namespace collision_response::detection
