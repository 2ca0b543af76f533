// Cost of the outcome distributions of uncertain coefficients (uncertainty.h) against the
// prediction's own (Google Benchmark), Newton law: a unit cube landing flat on 4 corner contacts
// (exact solver), each contact with e ~ N(0.5, 0.05), mu_s ~ U[0.4, 0.6], mu_d ~ N(0.4, 0.03).
//   devel/lib/collision_response/bench_uncertainty          (Release build)
// BM_Predict: computeResponse(); BM_Linear: the linear distribution; BM_Sampled/N/threads: N
// samples on a worker pool of that many threads (wall time: --benchmark_min_time=2).
// Instruction counts of one call each, for the ratio linear / prediction:
//   valgrind --tool=callgrind --toggle-collect='*predictOnce*' bench_uncertainty --callgrind
//   valgrind --tool=callgrind --toggle-collect='*linearOnce*' bench_uncertainty --callgrind
// (and '*sampledOnce*': 1,000 samples on the calling thread).
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <cstring>
#include <vector>

#include "collision_response/core/compute_response.h"
#include "collision_response/core/uncertainty.h"
#include "collision_response/core/worker_pool.h"

namespace core = collision_response::core;

namespace {

// The cube4 scene of bench_derivatives: tilted velocity and spin, 4 corner contacts, one island.
core::Scene cube4() {
  core::BodyState ground;
  ground.id = "ground";
  core::BodyState cube;
  cube.id = "cube";
  cube.mass = 1.0;
  cube.inertia = Eigen::Matrix3d::Identity() / 6.0;
  cube.position = {0.0, 0.0, 0.5};
  cube.linear_velocity = {0.3, 0.1, -1.0};
  cube.angular_velocity = {0.2, -0.1, 0.3};
  core::Scene scene;
  scene.bodies = {ground, cube};
  for (const double x : {-0.5, 0.5}) {
    for (const double y : {-0.5, 0.5}) {
      core::Contact contact;
      contact.body_a = "ground";
      contact.body_b = "cube";
      contact.point = {x, y, 0.0};
      contact.normal = {0.0, 0.0, 1.0};
      contact.restitution = 0.5;
      contact.static_friction = 0.5;
      contact.dynamic_friction = 0.4;
      scene.contacts.push_back(contact);
    }
  }
  return scene;
}

std::vector<core::ContactUncertainty> uncertainties() {
  std::vector<core::ContactUncertainty> all;
  for (std::size_t c = 0; c < 4; ++c) {
    core::ContactUncertainty u;
    u.contact = c;
    u.restitution = core::CoefficientDistribution::normal(0.5, 0.05);
    u.static_friction = core::CoefficientDistribution::interval(0.4, 0.6);
    u.dynamic_friction = core::CoefficientDistribution::normal(0.4, 0.03);
    all.push_back(u);
  }
  return all;
}

core::SolverOptions newton() {
  core::SolverOptions options;
  options.law = core::ImpactLaw::kNewton;
  return options;
}

[[gnu::noinline]] core::CollisionResult predictOnce(const core::Scene& scene,
                                                    const core::SolverOptions& options) {
  return core::computeResponse(scene, options);
}

[[gnu::noinline]] core::OutcomeDistribution linearOnce(
    const core::Scene& scene, const std::vector<core::ContactUncertainty>& u,
    const core::SolverOptions& options) {
  return core::computeOutcomeDistribution(scene, u, options, core::UncertaintyOptions{});
}

[[gnu::noinline]] core::OutcomeDistribution sampledOnce(
    const core::Scene& scene, const std::vector<core::ContactUncertainty>& u,
    const core::SolverOptions& options, std::size_t samples) {
  core::UncertaintyOptions sampled;
  sampled.method = core::UncertaintyMethod::kSampled;
  sampled.samples = samples;
  return core::computeOutcomeDistribution(scene, u, options, sampled);
}

void BM_Predict(benchmark::State& state) {
  const core::Scene scene = cube4();
  const core::SolverOptions options = newton();
  for (auto _ : state) benchmark::DoNotOptimize(predictOnce(scene, options));
}

void BM_Linear(benchmark::State& state) {
  const core::Scene scene = cube4();
  const auto u = uncertainties();
  const core::SolverOptions options = newton();
  for (auto _ : state) benchmark::DoNotOptimize(linearOnce(scene, u, options));
}

void BM_Sampled(benchmark::State& state) {
  const core::Scene scene = cube4();
  const auto u = uncertainties();
  core::SolverOptions options = newton();
  options.time_budget = 60.0;
  core::UncertaintyOptions sampled;
  sampled.method = core::UncertaintyMethod::kSampled;
  sampled.samples = static_cast<std::size_t>(state.range(0));
  core::WorkerPool pool(static_cast<int>(state.range(1)));
  for (auto _ : state)
    benchmark::DoNotOptimize(core::computeOutcomeDistribution(scene, u, options, sampled, &pool));
}

}  // namespace

BENCHMARK(BM_Predict);
BENCHMARK(BM_Linear);
BENCHMARK(BM_Sampled)
    ->Args({10000, 1})
    ->Args({10000, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// `--callgrind`: one counted call of each function, no timing (for the instruction counts above).
int main(int argc, char** argv) {
  if (argc > 1 && std::strcmp(argv[1], "--callgrind") == 0) {
    const core::Scene scene = cube4();
    const auto u = uncertainties();
    const core::SolverOptions options = newton();
    // A first call of each outside the counted ones (thread-local workspaces, lazy tables).
    benchmark::DoNotOptimize(linearOnce(scene, u, options));
    benchmark::DoNotOptimize(predictOnce(scene, options));
    benchmark::DoNotOptimize(linearOnce(scene, u, options));
    benchmark::DoNotOptimize(sampledOnce(scene, u, options, 1000));
    return 0;
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
