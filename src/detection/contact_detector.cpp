// Contact detection with FCL 0.7. The only translation unit that includes FCL.
//
// Conventions verified against Debian's libfcl 0.7.0 (see test_contact_detection.cpp):
//  - fcl::Contact::normal points from o1 towards o2 (sphere-sphere, halfspace-sphere, box-box);
//    penetration_depth > 0; fcl::DistanceResult::nearest_points are in the world frame.
//  - fcl::collide of two boxes already returns up to 4 contacts, but halfspace-box, halfspace-
//    cylinder and the libccd (GJK/EPA) pairs return one deepest point: manifolds are built here.
//  - fcl::distance with a fcl::Halfspace segfaults (no libccd support function for halfspaces), and
//    a halfspace's AABB is infinite: planes are kept out of FCL entirely. Every other shape is
//    tested against each plane directly (box against plane for the broadphase, support function
//    for the narrowphase), which is exact.

#include "collision_response/detection/contact_detector.h"

#include <fcl/fcl.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <sstream>
#include <string>
#include <tuple>
#include <utility>

#include "collision_response/core/errors.h"
#include "collision_response/detection/manifold.h"

namespace collision_response::detection {

// ------------------------------------------------------------------------------------------------
// Validation
// ------------------------------------------------------------------------------------------------

namespace {

/// Number of points sampled on a circular rim lying flat against the other shape.
constexpr int kRimSamples = 16;
/// A support face within this angle of the normal found by FCL replaces it (EPA normals of
/// face contacts are only approximate).
const double kSnapCos = std::cos(0.05);

/// An FCL collision object whose broadphase box can be inflated by the contact tolerance.
class InflatableObject : public fcl::CollisionObjectd {
 public:
  using fcl::CollisionObjectd::CollisionObjectd;
  void place(const Eigen::Isometry3d& world, double margin) {
    setTransform(world);
    computeAABB();
    aabb.min_ -= Vec3::Constant(margin);
    aabb.max_ += Vec3::Constant(margin);
  }
};

enum class Kind { kSphere, kPolytope, kCylinder, kCone, kHalfspace, kTriangleSoup };

/// One shape of one body, with its FCL object (none for planes) and, each call, its world pose.
struct ShapeData {
  int body = 0;
  int index = 0;  ///< in the body's shapes
  Kind kind = Kind::kSphere;
  double radius = 0.0;
  double half_height = 0.0;
  std::vector<Vec3> local_vertices;   ///< polytope (box corners, convex mesh), triangle soup
  Vec3 plane_normal = Vec3::UnitZ();  ///< halfspace, shape frame: solid where normal . x <= offset
  double plane_offset = 0.0;
  std::shared_ptr<fcl::CollisionGeometryd> geometry;
  std::unique_ptr<InflatableObject> object;
  // Per call:
  Eigen::Isometry3d world = Eigen::Isometry3d::Identity();
  std::vector<Vec3> world_vertices;
  Vec3 world_normal = Vec3::UnitZ();
  double world_offset = 0.0;
};

struct BodyCache {
  bool valid = false;
  std::size_t hash = 0;
  std::vector<Shape> shapes;
  std::vector<std::unique_ptr<ShapeData>> items;
};

void hashCombine(std::size_t& seed, std::size_t v) {
  seed ^= v + 0x9e3779b97f4a7c15ULL + (seed << 6) + (seed >> 2);
}

std::size_t hashShapes(const std::vector<Shape>& shapes) {
  std::size_t seed = shapes.size();
  const std::hash<double> hd;
  for (const Shape& s : shapes) {
    hashCombine(seed, static_cast<std::size_t>(s.type));
    for (double d : s.dimensions) hashCombine(seed, hd(d));
    for (const Vec3& v : s.vertices) {
      for (int k = 0; k < 3; ++k) hashCombine(seed, hd(v[k]));
    }
    for (const auto& t : s.triangles) {
      for (int k = 0; k < 3; ++k) hashCombine(seed, std::hash<int>()(t[k]));
    }
    for (int k = 0; k < 16; ++k) hashCombine(seed, hd(s.pose.matrix().data()[k]));
  }
  return seed;
}

bool sameShapes(const std::vector<Shape>& a, const std::vector<Shape>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].type != b[i].type || a[i].dimensions != b[i].dimensions ||
        a[i].vertices != b[i].vertices || a[i].triangles != b[i].triangles ||
        !(a[i].pose.matrix().array() == b[i].pose.matrix().array()).all()) {
      return false;
    }
  }
  return true;
}

/// True if every vertex lies on one side of every (non-degenerate) triangle's plane and the
/// vertices span a volume: the mesh bounds a convex polyhedron.
bool isConvexMesh(const Shape& s) {
  double scale = 0.0;
  for (const Vec3& v : s.vertices) scale = std::max(scale, v.cwiseAbs().maxCoeff());
  const double tol = 1e-9 * std::max(scale, 1e-9);
  bool has_volume = false;
  for (const auto& t : s.triangles) {
    const Vec3& p0 = s.vertices[t[0]];
    Vec3 m = (s.vertices[t[1]] - p0).cross(s.vertices[t[2]] - p0);
    const double len = m.norm();
    if (len <= tol * tol) continue;
    m /= len;
    bool pos = false, neg = false;
    for (const auto& u : s.triangles) {
      for (int k : u) {
        const double side = m.dot(s.vertices[k] - p0);
        if (side > tol) pos = true;
        if (side < -tol) neg = true;
      }
    }
    if (pos && neg) return false;
    if (pos || neg) has_volume = true;
  }
  return has_volume;
}

std::unique_ptr<ShapeData> buildShape(const Shape& s, int body, int index) {
  auto data = std::make_unique<ShapeData>();
  data->body = body;
  data->index = index;
  const auto& d = s.dimensions;
  switch (s.type) {
    case Shape::Type::kBox: {
      data->kind = Kind::kPolytope;
      for (int k = 0; k < 8; ++k) {
        data->local_vertices.emplace_back((k & 1 ? 0.5 : -0.5) * d[0], (k & 2 ? 0.5 : -0.5) * d[1],
                                          (k & 4 ? 0.5 : -0.5) * d[2]);
      }
      data->geometry = std::make_shared<fcl::Boxd>(d[0], d[1], d[2]);
      break;
    }
    case Shape::Type::kSphere:
      data->kind = Kind::kSphere;
      data->radius = d[0];
      data->geometry = std::make_shared<fcl::Sphered>(d[0]);
      break;
    case Shape::Type::kCylinder:
      data->kind = Kind::kCylinder;
      data->half_height = 0.5 * d[0];
      data->radius = d[1];
      data->geometry = std::make_shared<fcl::Cylinderd>(d[1], d[0]);
      break;
    case Shape::Type::kCone:
      // Both shape_msgs and FCL centre the cone on its bounding box, apex towards +z.
      data->kind = Kind::kCone;
      data->half_height = 0.5 * d[0];
      data->radius = d[1];
      data->geometry = std::make_shared<fcl::Coned>(d[1], d[0]);
      break;
    case Shape::Type::kMesh: {
      // Only the referenced vertices take part.
      std::vector<int> remap(s.vertices.size(), -1);
      std::vector<std::array<int, 3>> tris;
      for (const auto& t : s.triangles) {
        std::array<int, 3> nt{};
        for (int k = 0; k < 3; ++k) {
          if (remap[t[k]] < 0) {
            remap[t[k]] = static_cast<int>(data->local_vertices.size());
            data->local_vertices.push_back(s.vertices[t[k]]);
          }
          nt[k] = remap[t[k]];
        }
        tris.push_back(nt);
      }
      if (isConvexMesh(s)) {
        data->kind = Kind::kPolytope;
        // fcl::Convex wants faces wound counter-clockwise seen from outside.
        Vec3 centre = Vec3::Zero();
        for (const Vec3& v : data->local_vertices) centre += v;
        centre /= static_cast<double>(data->local_vertices.size());
        auto faces = std::make_shared<std::vector<int>>();
        for (auto t : tris) {
          const Vec3& p0 = data->local_vertices[t[0]];
          const Vec3 m = (data->local_vertices[t[1]] - p0).cross(data->local_vertices[t[2]] - p0);
          if (m.dot(p0 - centre) < 0.0) std::swap(t[1], t[2]);
          faces->insert(faces->end(), {3, t[0], t[1], t[2]});
        }
        auto vertices = std::make_shared<const std::vector<Vec3>>(data->local_vertices);
        data->geometry =
            std::make_shared<fcl::Convexd>(vertices, static_cast<int>(tris.size()), faces);
      } else {
        data->kind = Kind::kTriangleSoup;
        auto model = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>();
        std::vector<fcl::Triangle> ft;
        ft.reserve(tris.size());
        for (const auto& t : tris) ft.emplace_back(t[0], t[1], t[2]);
        model->beginModel(static_cast<int>(tris.size()),
                          static_cast<int>(data->local_vertices.size()));
        model->addSubModel(data->local_vertices, ft);
        model->endModel();
        data->geometry = model;
      }
      break;
    }
    case Shape::Type::kPlane: {
      data->kind = Kind::kHalfspace;
      const Vec3 abc(d[0], d[1], d[2]);
      const double norm = abc.norm();
      // a x + b y + c z + d <= 0 is the solid: n . x <= -d / |abc| with n = abc / |abc|.
      data->plane_normal = abc / norm;
      data->plane_offset = -d[3] / norm;
      break;
    }
  }
  if (data->geometry) {
    data->geometry->computeLocalAABB();
    data->object = std::make_unique<InflatableObject>(data->geometry);
    data->object->setUserData(data.get());
  }
  return data;
}

void placeShape(ShapeData& s, const Eigen::Isometry3d& world, double margin) {
  s.world = world;
  if (s.kind == Kind::kHalfspace) {
    s.world_normal = world.linear() * s.plane_normal;
    s.world_offset = s.plane_offset + s.world_normal.dot(world.translation());
    return;
  }
  s.world_vertices.resize(s.local_vertices.size());
  for (std::size_t k = 0; k < s.local_vertices.size(); ++k) {
    s.world_vertices[k] = world * s.local_vertices[k];
  }
  s.object->place(world, margin);
}

/// Points of a convex shape (not a halfspace) within eps of its support plane along dir (unit):
/// a vertex, an edge, a face or a sampled rim. Returns the support height max_x dir . x.
double supportFeature(const ShapeData& s, const Vec3& dir, double eps, std::vector<Vec3>& out) {
  std::vector<Vec3> cand;
  const Vec3 c = s.world.translation();
  switch (s.kind) {
    case Kind::kSphere:
      out.assign(1, c + s.radius * dir);
      return dir.dot(out[0]);
    case Kind::kPolytope:
    case Kind::kTriangleSoup:
      cand = s.world_vertices;
      break;
    case Kind::kCylinder:
    case Kind::kCone: {
      const Vec3 axis = s.world.linear().col(2);
      const Vec3 e1 = s.world.linear().col(0), e2 = s.world.linear().col(1);
      const Vec3 w = dir - dir.dot(axis) * axis;
      const double wn = w.norm();
      auto rim = [&](const Vec3& centre) {
        if (s.radius * wn <= eps) {  // the whole rim lies within the band: sample it
          for (int k = 0; k < kRimSamples; ++k) {
            const double a = 2.0 * M_PI * k / kRimSamples;
            cand.push_back(centre + s.radius * (std::cos(a) * e1 + std::sin(a) * e2));
          }
        }
        if (wn > 1e-12) cand.push_back(centre + s.radius * w / wn);
      };
      rim(c - s.half_height * axis);
      if (s.kind == Kind::kCylinder) {
        rim(c + s.half_height * axis);
      } else {
        cand.push_back(c + s.half_height * axis);  // apex
      }
      break;
    }
    case Kind::kHalfspace:
      break;
  }
  double top = -std::numeric_limits<double>::infinity();
  for (const Vec3& p : cand) top = std::max(top, dir.dot(p));
  out.clear();
  for (const Vec3& p : cand) {
    if (dir.dot(p) >= top - eps) out.push_back(p);
  }
  return top;
}

PlanarFeature planeFlat(const ShapeData& s) {
  return planeFeature(s.world_normal, s.world_offset);
}

struct PairContext {
  double tol = 1e-3;   ///< pairs apart by more give nothing
  double band = 1e-3;  ///< height band of a support feature (<= tol)
  double delta = 1e-10;
  std::size_t max_contacts = 8;
};

/// Manifold between two convex shapes (either may be a halfspace, not both) along the normal n0
/// (unit, a towards b). reference: a point of the contact region (FCL's), used when the region is a
/// single point.
std::vector<DetectedContact> convexManifold(const ShapeData& a, const ShapeData& b, Vec3 n,
                                            const Vec3& reference, const PairContext& ctx) {
  std::vector<Vec3> fa, fb;
  double top_a = 0.0, bottom_b = 0.0;
  PlanarFeature flat_a, flat_b;
  for (int pass = 0; pass < 2; ++pass) {
    const ContactPlaneBasis basis(n);
    if (a.kind == Kind::kHalfspace) {
      flat_a = planeFlat(a);
      top_a = a.world_offset;  // n is the plane's normal
    } else {
      top_a = supportFeature(a, n, ctx.band, fa);
      flat_a = projectFeature(fa, basis, n, ctx.delta);
    }
    if (b.kind == Kind::kHalfspace) {
      flat_b = planeFlat(b);
      bottom_b = -b.world_offset;  // n is minus the plane's normal
    } else {
      bottom_b = -supportFeature(b, -n, ctx.band, fb);
      flat_b = projectFeature(fb, basis, -n, ctx.delta);
    }
    if (pass == 1 || a.kind == Kind::kHalfspace || b.kind == Kind::kHalfspace) break;
    // Snap the normal to a support face nearly aligned with it, then redo the features.
    const double ca = flat_a.has_plane ? flat_a.plane_n.dot(n) : -1.0;
    const double cb = flat_b.has_plane ? -flat_b.plane_n.dot(n) : -1.0;
    Vec3 snapped = n;
    if (ca >= kSnapCos && ca >= cb) snapped = flat_a.plane_n;
    if (cb >= kSnapCos && cb > ca) snapped = -flat_b.plane_n;
    if ((snapped - n).norm() <= 1e-12) break;
    n = snapped;
  }
  const double depth = top_a - bottom_b;
  std::vector<DetectedContact> out;
  if (depth < -ctx.tol) return out;
  const ContactPlaneBasis basis(n);
  DetectedContact c;
  c.body_a = a.body;
  c.body_b = b.body;
  c.normal = n;
  for (const Vec2& q : contactRegion(flat_a, flat_b, ctx.delta, ctx.band)) {
    const double ha = flat_a.height(basis, q), hb = flat_b.height(basis, q);
    c.depth = ha - hb;
    if (c.depth < -ctx.tol) continue;
    c.point = basis.lift(q, 0.5 * (ha + hb));
    addDistinctContact(out, c, std::max(ctx.delta, 1e-9));
  }
  if (out.empty()) {
    // A single point: on the point feature if there is one, else at FCL's point.
    Vec3 r = reference;
    if (flat_a.kind == PlanarFeature::Kind::kPoint) r = flat_a.pts[0];
    if (flat_b.kind == PlanarFeature::Kind::kPoint) r = flat_b.pts[0];
    c.depth = depth;
    c.point = basis.lift(basis.flat(r), 0.5 * (top_a + bottom_b));
    out.push_back(c);
  }
  reduceContacts(out, ctx.max_contacts);
  return out;
}

/// Vertices of a triangle soup against a halfspace: every vertex within the tolerance is a point.
std::vector<DetectedContact> soupHalfspace(const ShapeData& a, const ShapeData& b,
                                           const PairContext& ctx) {
  const bool plane_is_a = a.kind == Kind::kHalfspace;
  const ShapeData& plane = plane_is_a ? a : b;
  const ShapeData& soup = plane_is_a ? b : a;
  std::vector<DetectedContact> out;
  DetectedContact c;
  c.body_a = a.body;
  c.body_b = b.body;
  c.normal = plane_is_a ? plane.world_normal : Vec3(-plane.world_normal);
  for (const Vec3& v : soup.world_vertices) {
    const double s = plane.world_normal.dot(v) - plane.world_offset;
    if (s > ctx.tol) continue;
    c.depth = -s;
    c.point = v - 0.5 * s * plane.world_normal;
    addDistinctContact(out, c, std::max(ctx.delta, 1e-9));
  }
  reduceContacts(out, ctx.max_contacts);
  return out;
}

Vec3 centreOf(const ShapeData& s) {
  const fcl::AABBd& box = s.object->getAABB();
  return 0.5 * (box.min_ + box.max_);
}

/// FCL 0.7's contacts with a BVH mesh do not follow the o1 -> o2 convention (box-mesh and mesh-box
/// both give the same normal, sphere-mesh a negative depth): orients n (at point p) from a towards
/// b. With a convex partner C the sign is the one for which p lies on C's support plane (C's
/// outward normal at p is +n if C is a, -n if C is b); between two meshes, the centres decide.
Vec3 orientSoupNormal(Vec3 n, const Vec3& p, const ShapeData& a, const ShapeData& b) {
  const bool a_convex = a.kind != Kind::kTriangleSoup, b_convex = b.kind != Kind::kTriangleSoup;
  if (a_convex || b_convex) {
    const ShapeData& c = a_convex ? a : b;
    const Vec3 m = a_convex ? n : Vec3(-n);
    std::vector<Vec3> unused;
    const double keep = std::abs(supportFeature(c, m, 0.0, unused) - m.dot(p));
    const double flip = std::abs(supportFeature(c, -m, 0.0, unused) + m.dot(p));
    return flip < keep ? Vec3(-n) : n;
  }
  return n.dot(centreOf(b) - centreOf(a)) < 0.0 ? Vec3(-n) : n;
}

/// Narrowphase of one pair of shapes of bodies a < b.
std::vector<DetectedContact> narrowphase(const ShapeData& a, const ShapeData& b,
                                         const PairContext& ctx) {
  const bool plane_a = a.kind == Kind::kHalfspace, plane_b = b.kind == Kind::kHalfspace;
  if (plane_a && plane_b) return {};
  const bool soup = a.kind == Kind::kTriangleSoup || b.kind == Kind::kTriangleSoup;
  if (plane_a || plane_b) {
    if (soup) return soupHalfspace(a, b, ctx);
    const Vec3 n = plane_a ? a.world_normal : Vec3(-b.world_normal);
    return convexManifold(a, b, n, Vec3::Zero(), ctx);
  }

  fcl::CollisionRequestd request(soup ? std::max<std::size_t>(64, ctx.max_contacts) : 8, true);
  fcl::CollisionResultd result;
  fcl::collide(a.object.get(), b.object.get(), request, result);
  Vec3 n = Vec3::Zero(), reference = Vec3::Zero();
  std::vector<DetectedContact> out;
  if (result.isCollision() && result.numContacts() > 0) {
    if (soup) {  // FCL's per-triangle contacts, as they are.
      for (std::size_t k = 0; k < result.numContacts(); ++k) {
        const auto& fc = result.getContact(k);
        if (!fc.normal.allFinite() || fc.normal.norm() < 0.5) continue;
        DetectedContact c;
        c.body_a = a.body;
        c.body_b = b.body;
        c.point = fc.pos;
        c.normal = orientSoupNormal(fc.normal.normalized(), fc.pos, a, b);
        c.depth = std::abs(fc.penetration_depth);
        addDistinctContact(out, c, std::max(ctx.delta, 1e-9));
      }
      reduceContacts(out, ctx.max_contacts);
      if (!out.empty()) return out;
    }
    std::size_t deepest = 0;
    for (std::size_t k = 1; k < result.numContacts(); ++k) {
      if (result.getContact(k).penetration_depth > result.getContact(deepest).penetration_depth) {
        deepest = k;
      }
    }
    n = result.getContact(deepest).normal;
    reference = result.getContact(deepest).pos;
  } else if (!result.isCollision()) {
    fcl::DistanceRequestd drequest(true);
    fcl::DistanceResultd dresult;
    fcl::distance(a.object.get(), b.object.get(), drequest, dresult);
    if (dresult.min_distance > ctx.tol) return {};
    const Vec3 p1 = dresult.nearest_points[0], p2 = dresult.nearest_points[1];
    reference = 0.5 * (p1 + p2);
    if (dresult.min_distance > 0.0 && (p2 - p1).norm() > 1e-12) n = (p2 - p1).normalized();
    if (soup && n.norm() > 0.5) {
      DetectedContact c;
      c.body_a = a.body;
      c.body_b = b.body;
      c.point = reference;
      c.normal = orientSoupNormal(n, reference, a, b);
      c.depth = -dresult.min_distance;
      return {c};
    }
  }
  if (!n.allFinite() || n.norm() < 0.5) {
    // Touching without a usable normal: push b into a by a little and ask again.
    Vec3 towards = centreOf(b) - centreOf(a);
    towards = towards.norm() > 1e-12 ? towards.normalized() : Vec3::UnitZ();
    Eigen::Isometry3d moved = b.world;
    moved.translation() -= std::max(2.0 * ctx.band, 1e-6) * towards;
    fcl::CollisionObjectd probe(b.geometry, moved);
    fcl::CollisionResultd again;
    fcl::collide(a.object.get(), &probe, request, again);
    n = again.numContacts() > 0 ? again.getContact(0).normal : towards;
    if (again.numContacts() > 0 && reference.isZero()) reference = again.getContact(0).pos;
    if (!n.allFinite() || n.norm() < 0.5) n = towards;
  }
  n.normalize();
  if (soup) {  // no support features for a soup: one point
    DetectedContact c;
    c.body_a = a.body;
    c.body_b = b.body;
    c.point = reference;
    c.normal = orientSoupNormal(n, reference, a, b);
    c.depth = result.isCollision() && result.numContacts() > 0
                  ? std::abs(result.getContact(0).penetration_depth)
                  : 0.0;
    return {c};
  }
  return convexManifold(a, b, n, reference, ctx);
}

bool collectPair(fcl::CollisionObjectd* o1, fcl::CollisionObjectd* o2, void* data) {
  auto* pairs = static_cast<std::vector<std::pair<ShapeData*, ShapeData*>>*>(data);
  pairs->emplace_back(static_cast<ShapeData*>(o1->getUserData()),
                      static_cast<ShapeData*>(o2->getUserData()));
  return false;  // never stop
}

}  // namespace

// ------------------------------------------------------------------------------------------------
// ContactDetector
// ------------------------------------------------------------------------------------------------

using ShapePair = std::pair<ShapeData*, ShapeData*>;

/// The detector's state between calls, and its phases: place the shapes (cached), broadphase,
/// the pairs to test, the narrowphase.
struct ContactDetector::Impl {
  std::vector<BodyCache> bodies;
  fcl::DynamicAABBTreeCollisionManagerd manager;
  std::vector<fcl::CollisionObjectd*> registered;
  Stats stats;

  /// Places every body's shapes in the world, rebuilding a body's FCL objects only when its
  /// shapes changed; boxes inflated by `margin`.
  void placeShapes(const std::vector<core::BodyState>& states,
                   const std::vector<BodyGeometry>& geometry, double margin);
  /// Shape pairs whose inflated boxes overlap (FCL's dynamic AABB tree; planes tested against
  /// every other shape's box).
  std::vector<ShapePair> broadphase();
  /// The candidates between two different bodies, not both immovable and not of one collision
  /// group (>= 0; `groups` empty or one per body), ordered by body pair and shape index
  /// (body_a < body_b).
  std::vector<ShapePair> pairsToTest(const std::vector<ShapePair>& candidates,
                                     const std::vector<core::BodyState>& states,
                                     const std::vector<int>& groups);
  /// The contacts of every pair, within options.max_contacts and options.deadline.
  static std::vector<DetectedContact> narrowphasePairs(const std::vector<ShapePair>& pairs,
                                                       const PairContext& ctx,
                                                       const DetectionOptions& options);
};

ContactDetector::ContactDetector() : impl_(std::make_unique<Impl>()) {}
ContactDetector::~ContactDetector() = default;
ContactDetector::ContactDetector(ContactDetector&&) noexcept = default;
ContactDetector& ContactDetector::operator=(ContactDetector&&) noexcept = default;

const ContactDetector::Stats& ContactDetector::lastStats() const {
  return impl_->stats;
}

void ContactDetector::Impl::placeShapes(const std::vector<core::BodyState>& states,
                                        const std::vector<BodyGeometry>& geometry, double margin) {
  const std::size_t count = geometry.empty() ? 0 : states.size();
  bodies.resize(count);
  for (std::size_t i = 0; i < count; ++i) {
    BodyCache& cache = bodies[i];
    const std::vector<Shape>& shapes = geometry[i].shapes;
    const std::size_t hash = hashShapes(shapes);
    if (cache.valid && cache.hash == hash && sameShapes(cache.shapes, shapes)) {
      stats.cached_objects_reused += cache.items.size();
    } else {
      cache.items.clear();
      for (std::size_t k = 0; k < shapes.size(); ++k) {
        cache.items.push_back(buildShape(shapes[k], static_cast<int>(i), static_cast<int>(k)));
      }
      cache.shapes = shapes;
      cache.hash = hash;
      cache.valid = true;
      stats.objects_built += cache.items.size();
    }
    Eigen::Isometry3d body_pose = Eigen::Isometry3d::Identity();
    body_pose.translate(states[i].position);
    body_pose.rotate(states[i].orientation.normalized().toRotationMatrix());
    for (std::size_t k = 0; k < shapes.size(); ++k) {
      placeShape(*cache.items[k], body_pose * shapes[k].pose, margin);
    }
  }
}

std::vector<ShapePair> ContactDetector::Impl::broadphase() {
  std::vector<ShapeData*> planes, solids;
  for (BodyCache& cache : bodies) {
    for (auto& item : cache.items) {
      (item->kind == Kind::kHalfspace ? planes : solids).push_back(item.get());
    }
  }
  // The tree is built anew each call (a balanced top-down build over the moved boxes): FCL's
  // update(), which re-inserts every moved leaf, measured slower for scenes where everything moves
  // (benchmark/bench_detection.cpp). The FCL geometry objects themselves stay cached.
  manager.clear();
  registered.clear();
  for (ShapeData* s : solids) registered.push_back(s->object.get());
  manager.registerObjects(registered);
  manager.setup();
  std::vector<ShapePair> candidates;
  if (!registered.empty()) manager.collide(&candidates, collectPair);
  // Planes against every shape's inflated box.
  for (ShapeData* p : planes) {
    for (ShapeData* s : solids) {
      const fcl::AABBd& box = s->object->getAABB();
      const Vec3 centre = 0.5 * (box.min_ + box.max_), half = 0.5 * (box.max_ - box.min_);
      const double lowest = p->world_normal.dot(centre) - p->world_normal.cwiseAbs().dot(half);
      if (lowest <= p->world_offset) candidates.emplace_back(p, s);
    }
  }
  stats.broadphase_pairs = candidates.size();
  return candidates;
}

std::vector<ShapePair> ContactDetector::Impl::pairsToTest(
    const std::vector<ShapePair>& candidates, const std::vector<core::BodyState>& states,
    const std::vector<int>& groups) {
  std::vector<ShapePair> pairs;
  for (auto [s1, s2] : candidates) {
    if (s1->body == s2->body) continue;
    if (states[s1->body].immovable() && states[s2->body].immovable()) continue;
    if (!groups.empty() && groups[s1->body] >= 0 && groups[s1->body] == groups[s2->body]) continue;
    if (s1->body > s2->body) std::swap(s1, s2);
    pairs.emplace_back(s1, s2);
  }
  std::sort(pairs.begin(), pairs.end(), [](const auto& x, const auto& y) {
    return std::make_tuple(x.first->body, x.second->body, x.first->index, x.second->index) <
           std::make_tuple(y.first->body, y.second->body, y.first->index, y.second->index);
  });
  stats.narrowphase_pairs = pairs.size();
  return pairs;
}

std::vector<DetectedContact> ContactDetector::Impl::narrowphasePairs(
    const std::vector<ShapePair>& pairs, const PairContext& ctx, const DetectionOptions& options) {
  std::vector<DetectedContact> contacts;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    if (k % 64 == 63) options.deadline.check("contact detection");
    for (const DetectedContact& c : narrowphase(*pairs[k].first, *pairs[k].second, ctx)) {
      contacts.push_back(c);
    }
    if (contacts.size() > options.max_contacts) {
      throw core::InvalidInput("bodies", "the shapes touch at more than " +
                                             std::to_string(options.max_contacts) +
                                             " contact points (the contact limit); " +
                                             std::to_string(pairs.size() - k - 1) +
                                             " pairs of shapes were left untested");
    }
  }
  return contacts;
}

std::vector<DetectedContact> ContactDetector::detect(const std::vector<core::BodyState>& bodies,
                                                     const std::vector<BodyGeometry>& geometry,
                                                     const DetectionOptions& options,
                                                     const std::vector<int>& collision_groups) {
  if (!std::isfinite(options.contact_tolerance) || options.contact_tolerance < 0.0) {
    throw core::InvalidInput("options.contact_tolerance", "must be finite and >= 0");
  }
  if (options.max_contacts_per_pair < 1) {
    throw core::InvalidInput("options.max_contacts_per_pair", "must be >= 1");
  }
  validateGeometry(geometry, bodies.size());
  if (!collision_groups.empty() && collision_groups.size() != bodies.size()) {
    throw core::InvalidInput("bodies", "collision groups given for " +
                                           std::to_string(collision_groups.size()) +
                                           " bodies, expected " + std::to_string(bodies.size()));
  }
  if (std::isnan(options.feature_band) || options.feature_band == HUGE_VAL) {
    throw core::InvalidInput("options.feature_band", "must be finite (or negative: the tolerance)");
  }
  PairContext ctx;
  ctx.tol = options.contact_tolerance;
  ctx.band = options.feature_band >= 0.0 ? std::min(options.feature_band, ctx.tol) : ctx.tol;
  ctx.delta = std::max(1e-4 * ctx.band, 1e-10);
  ctx.max_contacts = options.max_contacts_per_pair;

  Impl& im = *impl_;
  im.stats = Stats{};
  im.placeShapes(bodies, geometry, ctx.tol);
  const std::vector<ShapePair> pairs = im.pairsToTest(im.broadphase(), bodies, collision_groups);
  return Impl::narrowphasePairs(pairs, ctx, options);
}

}  // namespace collision_response::detection
