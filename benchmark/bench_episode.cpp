// Cost of one impact episode (Google Benchmark), Release build:
//   devel/lib/collision_response/bench_episode --benchmark_repetitions=5
// core::computeEpisode() on the geometry of detection::ShapeGaps, as ~compute_episode calls it:
//  - cube_landing: the real tosses' cube (0.37 kg, side 0.1048 m, uniform) tossed onto a table
//    plane, tilted 20 degrees about x then 10 about y, its lowest corner 1 cm above the table,
//    v = (0.5, 0.2, -1.5) m/s, w = (3, -2, 1) rad/s; e = 0.3, mu_s = mu_d = 0.25. The first contact
//    is on a corner, then the cube turns onto others until it rests or flies off. Under Newton,
//    Poisson and Stronge (the law's name in the label).
//  - ball_drop: a 0.2 kg solid ball of radius 0.05 m released at rest 0.1 m above the plane, e =
//  0.5,
//    mu = 0.25: the bounces' accumulation closed, then sustained contact.
//  - arm_strikes_box: the shipped 7-DOF arm (urdf/arm7.urdf) under gravity compensation swinging
//    its fingertips (joint2 at 1.2 rad/s, as scripts/robot_demo.sh) down onto a 1 kg box resting
//    on a table (test/support/arm_box_scene.h), core::computeBodyEpisode(): the strike, the box
//    held on the table while the arm flies, to the horizon (0.1 s), sustained contact or
//    separation. The bodies are set back to their start state inside the timed loop (one
//    setState() of the arm, about 1 us).
// The shapes are prepared once (ShapeGaps' constructor) outside the timed loop; *_with_setup times
// the constructor too (what one service call pays). Counters: impacts listed per episode, impacts
// closed by an accumulation, the end time [s]; the label names the law and the episode's end.
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "../test/support/arm_box_scene.h"
#include "../test/support/shape_builders.h"
#include "collision_response/core/episode.h"
#include "collision_response/detection/shape_gaps.h"

namespace core = collision_response::core;
namespace detection = collision_response::detection;
using collision_response::testing::primitive;
using Eigen::Vector3d;

namespace {

constexpr double kSide = 0.1048, kCubeMass = 0.37;
constexpr double kRadius = 0.05, kBallMass = 0.2;

struct EpisodeScene {
  std::vector<core::BodyState> bodies;
  detection::DetectionInput input;
  core::EpisodeOptions options;
};

core::BodyState table() {
  core::BodyState t;
  t.id = "table";
  t.mass = 0.0;
  return t;
}

EpisodeScene cubeLanding(core::ImpactLaw law) {
  EpisodeScene s;
  core::BodyState cube;
  cube.id = "cube";
  cube.mass = kCubeMass;
  cube.inertia = Eigen::Matrix3d::Identity() * kCubeMass * kSide * kSide / 6.0;
  cube.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(10.0 * M_PI / 180.0, Vector3d::UnitY()) *
                                        Eigen::AngleAxisd(20.0 * M_PI / 180.0, Vector3d::UnitX()));
  // The lowest corner 1 cm above the table.
  double lowest = 0.0;
  for (int k = 0; k < 8; ++k) {
    const Vector3d corner(k & 1 ? 0.5 : -0.5, k & 2 ? 0.5 : -0.5, k & 4 ? 0.5 : -0.5);
    lowest = std::min(lowest, (cube.orientation * (kSide * corner)).z());
  }
  cube.position = Vector3d(0.0, 0.0, 0.01 - lowest);
  cube.linear_velocity = Vector3d(0.5, 0.2, -1.5);
  cube.angular_velocity = Vector3d(3.0, -2.0, 1.0);
  s.bodies = {table(), cube};
  s.input.geometry = {{{primitive(detection::Shape::Type::kPlane, {0, 0, 1, 0})}},
                      {{primitive(detection::Shape::Type::kBox, {kSide, kSide, kSide})}}};
  s.input.defaults = {0.3, 0.25, 0.25};
  s.options.solver.law = law;
  return s;
}

EpisodeScene ballDrop(core::ImpactLaw law) {
  EpisodeScene s;
  core::BodyState ball;
  ball.id = "ball";
  ball.mass = kBallMass;
  ball.inertia = Eigen::Matrix3d::Identity() * 0.4 * kBallMass * kRadius * kRadius;
  ball.position = Vector3d(0.0, 0.0, kRadius + 0.1);
  s.bodies = {table(), ball};
  s.input.geometry = {{{primitive(detection::Shape::Type::kPlane, {0, 0, 1, 0})}},
                      {{primitive(detection::Shape::Type::kSphere, {kRadius})}}};
  s.input.defaults = {0.5, 0.25, 0.25};
  s.options.solver.law = law;
  return s;
}

core::ImpactLaw lawOf(int64_t index) {
  static const core::ImpactLaw kLaws[] = {core::ImpactLaw::kNewton, core::ImpactLaw::kPoisson,
                                          core::ImpactLaw::kStronge};
  return kLaws[index];
}

void report(benchmark::State& state, const core::EpisodeResult& result, core::ImpactLaw law) {
  state.counters["impacts"] = static_cast<double>(result.impacts.size());
  state.counters["accumulated"] = static_cast<double>(result.accumulated_impacts);
  state.counters["end_time_s"] = result.end_time;
  state.SetLabel(std::string(core::toString(law)) + ", " + core::toString(result.end));
}

template <EpisodeScene (*Scene)(core::ImpactLaw)>
void BM_Episode(benchmark::State& state) {
  const core::ImpactLaw law = lawOf(state.range(0));
  const EpisodeScene s = Scene(law);
  const detection::ShapeGaps geometry(s.bodies, s.input, detection::MaterialTable{});
  core::EpisodeResult result;
  for (auto _ : state) {
    result = core::computeEpisode(s.bodies, geometry, s.options);
    benchmark::DoNotOptimize(result.bodies.data());
  }
  report(state, result, law);
}

template <EpisodeScene (*Scene)(core::ImpactLaw)>
void BM_EpisodeWithSetup(benchmark::State& state) {
  const core::ImpactLaw law = lawOf(state.range(0));
  const EpisodeScene s = Scene(law);
  const detection::MaterialTable materials;
  core::EpisodeResult result;
  for (auto _ : state) {
    const detection::ShapeGaps geometry(s.bodies, s.input, materials);
    result = core::computeEpisode(s.bodies, geometry, s.options);
    benchmark::DoNotOptimize(result.bodies.data());
  }
  report(state, result, law);
}

void BM_ArmStrikesBox(benchmark::State& state) {
  const core::ImpactLaw law = lawOf(state.range(0));
  auto s = collision_response::testing::armBoxScene(ARM7_URDF);
  s.options.solver.law = law;
  // Room for runs under callgrind (some 50 times slower): the episode's own time is far below.
  s.options.solver.time_budget = 100.0;
  std::vector<Eigen::VectorXd> start(s.bodies.size());
  for (std::size_t i = 0; i < s.bodies.size(); ++i) s.bodies[i]->saveState(start[i]);
  core::BodyEpisodeResult result;
  for (auto _ : state) {
    for (std::size_t i = 0; i < s.bodies.size(); ++i) s.bodies[i]->restoreState(start[i]);
    result = core::computeBodyEpisode(s.bodies, s.parts, *s.geometry, s.options);
    benchmark::DoNotOptimize(result.impacts.data());
  }
  state.counters["impacts"] = static_cast<double>(result.impacts.size());
  state.counters["steps"] = static_cast<double>(result.steps);
  state.counters["end_time_s"] = result.end_time;
  state.SetLabel(std::string(core::toString(law)) + ", " + core::toString(result.end));
}

// Arguments: 0 Newton, 1 Poisson, 2 Stronge.
BENCHMARK(BM_ArmStrikesBox)->Name("arm_strikes_box")->Arg(0)->Arg(2)->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(BM_Episode, cubeLanding)->Name("cube_landing")->DenseRange(0, 2);
BENCHMARK_TEMPLATE(BM_EpisodeWithSetup, cubeLanding)
    ->Name("cube_landing_with_setup")
    ->Arg(0)
    ->Arg(2);
BENCHMARK_TEMPLATE(BM_Episode, ballDrop)->Name("ball_drop")->DenseRange(0, 2);

}  // namespace

BENCHMARK_MAIN();
