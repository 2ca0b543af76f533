// Batch throughput against threads (Google Benchmark): the scenes of a batch solved across a
// core::WorkerPool, as ~compute_batch does, at 1, 2 and 4 threads.
//   devel/lib/collision_response/bench_batch            (Release build)
// Scenes per second is items_per_second (wall time: UseRealTime). Each scene is a cube landing on
// 4 corners, slightly tilted and spinning at random, under Newton's law (the exact solver): the
// scenes differ from each other but cost about the same, so that the figure measures the pool.
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <random>
#include <vector>

#include "collision_response/core/compute_response.h"
#include "collision_response/core/worker_pool.h"

namespace core = collision_response::core;

namespace {

std::vector<core::Scene> landings(std::size_t count) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<core::Scene> scenes;
  for (std::size_t k = 0; k < count; ++k) {
    core::Scene scene;
    core::BodyState ground;
    ground.id = "ground";
    core::BodyState cube;
    cube.id = "cube";
    cube.mass = 1.0;
    cube.inertia = Eigen::Matrix3d::Identity() / 6.0;
    cube.linear_velocity = {0.5 * unit(rng), 0.5 * unit(rng), -1.0 + 0.3 * unit(rng)};
    cube.angular_velocity = {0.5 * unit(rng), 0.5 * unit(rng), 0.5 * unit(rng)};
    scene.bodies = {ground, cube};
    for (const double x : {-0.5, 0.5}) {
      for (const double y : {-0.5, 0.5}) {
        core::Contact contact;
        contact.body_a = "ground";
        contact.body_b = "cube";
        contact.point = {x, y, -0.5 + 0.01 * unit(rng)};
        contact.normal = {0.0, 0.0, 1.0};
        contact.restitution = 0.4;
        contact.static_friction = 0.6;
        contact.dynamic_friction = 0.5;
        scene.contacts.push_back(contact);
      }
    }
    scenes.push_back(std::move(scene));
  }
  return scenes;
}

void BM_Batch(benchmark::State& state) {
  const std::vector<core::Scene> scenes = landings(512);
  std::vector<core::CollisionResult> results(scenes.size());
  core::WorkerPool pool(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    pool.parallelFor(scenes.size(), [&](std::size_t i) {
      core::SolverOptions options;
      options.law = core::ImpactLaw::kNewton;
      results[i] = core::computeResponse(scenes[i], options);
    });
    benchmark::DoNotOptimize(results.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(scenes.size()));
}

}  // namespace

BENCHMARK(BM_Batch)->Arg(1)->Arg(2)->Arg(4)->UseRealTime()->Unit(benchmark::kMicrosecond);
BENCHMARK_MAIN();
