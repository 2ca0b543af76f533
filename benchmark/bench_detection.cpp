// Cost of contact detection from shapes (Google Benchmark), Release build:
//   devel/lib/collision_response/bench_detection
// Per pair of shapes (one touching pair per scene, FCL objects cached across calls as in the node),
// and a scene of 200 bodies (boxes, spheres, cylinders on a floor, neighbours touching), both with
// the cache warm (poses change, shapes do not) and cold (every object rebuilt), and detect + solve.
// ShapeGaps::gaps(), what an impact episode asks many times per landing: a cube over a plane
// (closed form) and a box over a box (FCL), each touching (range 0.1 mm) and apart (range 1 m).
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "../test/support/shape_builders.h"
#include "collision_response/core/compute_response.h"
#include "collision_response/detection/detect_contacts.h"
#include "collision_response/detection/shape_gaps.h"

namespace core = collision_response::core;
namespace detection = collision_response::detection;
using collision_response::testing::boxMesh;
using collision_response::testing::primitive;

namespace {

core::BodyState body(const char* id, double mass, const Eigen::Vector3d& position,
                     const Eigen::Quaterniond& q = Eigen::Quaterniond::Identity()) {
  core::BodyState b;
  b.id = id;
  b.mass = mass;
  if (mass > 0.0) b.inertia = Eigen::Matrix3d::Identity() * mass / 6.0;
  b.position = position;
  b.orientation = q;
  b.linear_velocity = {0.0, 0.0, -1.0};
  return b;
}

struct PairScene {
  std::vector<core::BodyState> bodies;
  detection::DetectionInput input;
};

// One touching pair of shapes; `kind` picks the pair.
PairScene pairScene(int kind) {
  const detection::Shape floor = primitive(detection::Shape::Type::kPlane, {0, 0, 1, 0});
  const detection::Shape box = primitive(detection::Shape::Type::kBox, {1, 1, 1});
  PairScene s;
  s.input.defaults = {0.5, 0.3, 0.3};
  switch (kind) {
    case 0:  // sphere on a plane: one point
      s.bodies = {body("floor", 0, {0, 0, 0}), body("ball", 1, {0, 0, 0.1})};
      s.input.geometry = {{{floor}}, {{primitive(detection::Shape::Type::kSphere, {0.1})}}};
      break;
    case 1:  // box flat on a plane: 4 corners
      s.bodies = {body("floor", 0, {0, 0, 0}), body("box", 1, {0, 0, 0.5})};
      s.input.geometry = {{{floor}}, {{box}}};
      break;
    case 2:  // box on a box, turned 30 degrees about z: clipped manifold
      s.bodies = {body("below", 1, {0, 0, 0}),
                  body("above", 1, {0.1, 0.2, 1.0},
                       Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ())))};
      s.input.geometry = {{{box}}, {{box}}};
      break;
    case 3:  // convex mesh (a box's hull) flat on a plane
      s.bodies = {body("floor", 0, {0, 0, 0}), body("hull", 1, {0, 0, 0.5})};
      s.input.geometry = {{{floor}}, {{boxMesh()}}};
      break;
    default: {  // cylinder on its side on a box: the contact line's ends
      detection::Shape cylinder = primitive(detection::Shape::Type::kCylinder, {1.0, 0.1});
      cylinder.pose.rotate(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()));
      s.bodies = {body("table", 0, {0, 0, -0.5}), body("cylinder", 1, {0, 0, 0.1})};
      s.input.geometry = {{{box}}, {{cylinder}}};
    }
  }
  return s;
}

void BM_DetectPair(benchmark::State& state) {
  PairScene s = pairScene(static_cast<int>(state.range(0)));
  detection::ContactDetector detector;
  const detection::MaterialTable materials;
  std::size_t contacts = 0;
  for (auto _ : state) {
    const detection::DetectedContacts found =
        detection::detectContacts(detector, s.bodies, s.input, materials);
    contacts = found.contacts.size();
    benchmark::DoNotOptimize(found.contacts.data());
  }
  static const char* const kNames[] = {"sphere_plane", "box_plane", "box_box_turned", "hull_plane",
                                       "cylinder_side_box"};
  state.SetLabel(std::string(kNames[state.range(0)]) + ", " + std::to_string(contacts) + " points");
}
BENCHMARK(BM_DetectPair)->DenseRange(0, 4);

// 200 bodies on a floor in a 20 x 10 grid of 1.0 m cells: boxes (side 1), spheres (radius 0.5)
// and upright cylinders (radius 0.5, height 1), alternating, each touching the floor and its
// neighbours along x; 3 of every 4 falling at 1 m/s.
struct BigScene {
  std::vector<core::BodyState> bodies;
  detection::DetectionInput input;
};

BigScene bigScene() {
  BigScene s;
  s.input.defaults = {0.5, 0.3, 0.3};
  s.bodies.push_back(body("floor", 0, {0, 0, 0}));
  s.input.geometry.push_back({{primitive(detection::Shape::Type::kPlane, {0, 0, 1, 0})}});
  static std::vector<std::string> ids;
  ids.clear();
  for (int i = 0; i < 200; ++i) ids.push_back("b" + std::to_string(i));
  for (int i = 0; i < 200; ++i) {
    const int kind = i % 3;
    core::BodyState b = body("", 1.0, {1.0 * (i % 20), 1.5 * (i / 20), 0.5});
    b.id = ids[i];
    if (i % 4 == 3) b.linear_velocity.setZero();
    s.bodies.push_back(b);
    s.input.geometry.push_back(
        {{kind == 0   ? primitive(detection::Shape::Type::kBox, {1, 1, 1})
          : kind == 1 ? primitive(detection::Shape::Type::kSphere, {0.5})
                      : primitive(detection::Shape::Type::kCylinder, {1.0, 0.5})}});
  }
  return s;
}

void BM_Detect200Bodies(benchmark::State& state) {
  BigScene s = bigScene();
  const bool cold = state.range(0) != 0;
  const detection::MaterialTable materials;
  detection::ContactDetector warm_detector;
  std::size_t contacts = 0, narrowphase = 0;
  for (auto _ : state) {
    detection::ContactDetector cold_detector;
    detection::ContactDetector& detector = cold ? cold_detector : warm_detector;
    // Poses change every call (shapes do not): the warm cache updates transforms only.
    for (std::size_t i = 1; i < s.bodies.size(); ++i) s.bodies[i].position.z() += 1e-12;
    const detection::DetectedContacts found =
        detection::detectContacts(detector, s.bodies, s.input, materials);
    contacts = found.contacts.size();
    narrowphase = detector.lastStats().narrowphase_pairs;
    benchmark::DoNotOptimize(found.contacts.data());
  }
  state.counters["contacts"] = static_cast<double>(contacts);
  state.counters["narrowphase_pairs"] = static_cast<double>(narrowphase);
  state.SetLabel(cold ? "cold: objects rebuilt each call" : "warm: cached objects");
}
BENCHMARK(BM_Detect200Bodies)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

void BM_DetectAndSolve200Bodies(benchmark::State& state) {
  BigScene s = bigScene();
  const detection::MaterialTable materials;
  detection::ContactDetector detector;
  std::size_t contacts = 0;
  for (auto _ : state) {
    core::Scene scene;
    scene.bodies = s.bodies;
    scene.contacts = detection::detectContacts(detector, s.bodies, s.input, materials).contacts;
    contacts = scene.contacts.size();
    const core::CollisionResult result = core::computeResponse(scene);
    benchmark::DoNotOptimize(result.bodies.data());
  }
  state.counters["contacts"] = static_cast<double>(contacts);
}
BENCHMARK(BM_DetectAndSolve200Bodies)->Unit(benchmark::kMillisecond);

// The gaps an episode asks for: a tilted cube (side 0.1 m, its lowest corner first) over a plane,
// closed form; a tilted box (0.1 m) over a box (1 m), through FCL. range(0): 0 plane, 1 box;
// range(1): 0 touching (lowest corner 50 um up, range 0.1 mm: one point), 1 apart (2 cm up, range
// 1 m: every point of the pair, the distance). Poses change a little every call.
void BM_ShapeGaps(benchmark::State& state) {
  const bool over_box = state.range(0) != 0, apart = state.range(1) != 0;
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.4, Eigen::Vector3d(1.0, 0.7, 0.2).normalized()));
  const Eigen::Matrix3d r = q.toRotationMatrix();
  double lowest = 0.0;  // of the cube's corners, relative to its centre
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d c((k & 1 ? 0.05 : -0.05), (k & 2 ? 0.05 : -0.05), (k & 4 ? 0.05 : -0.05));
    lowest = std::min(lowest, (r * c).z());
  }
  const double height = apart ? 0.02 : 5e-5;
  std::vector<core::BodyState> bodies{body("table", 0, {0, 0, over_box ? -0.5 : 0.0}),
                                      body("cube", 0.37, {0.1, 0.05, height - lowest}, q)};
  detection::DetectionInput input;
  input.defaults = {0.5, 0.3, 0.3};
  input.geometry = {{{over_box ? primitive(detection::Shape::Type::kBox, {1, 1, 1})
                               : primitive(detection::Shape::Type::kPlane, {0, 0, 1, 0})}},
                    {{primitive(detection::Shape::Type::kBox, {0.1, 0.1, 0.1})}}};
  const detection::ShapeGaps query(bodies, input, detection::MaterialTable{});
  const double range = apart ? 1.0 : 1e-4;
  std::vector<core::GapContact> out;
  double step = 1e-9;
  for (auto _ : state) {
    bodies[1].position.x() += step;
    step = -step;
    query.gaps(bodies, range, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetLabel(std::string(over_box ? "cube over box (FCL)" : "cube over plane (closed form)") +
                 (apart ? ", apart, range 1 m: " : ", touching, range 0.1 mm: ") +
                 std::to_string(out.size()) + " points");
}
BENCHMARK(BM_ShapeGaps)->ArgsProduct({{0, 1}, {0, 1}});

}  // namespace

BENCHMARK_MAIN();
