// core::WorkerPool: every index runs exactly once, on several threads, for concurrent callers;
// failures come back to the caller; and the solver gives the same answers, bit for bit, whether
// a batch is solved on the pool or one scene after the other (its per-thread workspaces share
// nothing).
#include <gtest/gtest.h>

#include <atomic>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include "collision_response/core/compute_response.h"
#include "collision_response/core/worker_pool.h"
#include "scenes.h"

namespace core = collision_response::core;
using namespace collision_response::testing;

namespace {

TEST(WorkerPool, EveryIndexRunsExactlyOnce) {
  for (const int threads : {1, 2, 3, 8}) {
    core::WorkerPool pool(threads);
    EXPECT_EQ(pool.threads(), threads);
    for (const std::size_t count : {0u, 1u, 2u, 7u, 1000u}) {
      std::vector<std::atomic<int>> runs(count);
      for (auto& r : runs) r = 0;
      pool.parallelFor(count, [&](std::size_t i) { ++runs[i]; });
      for (std::size_t i = 0; i < count; ++i)
        EXPECT_EQ(runs[i].load(), 1) << "threads " << threads << " count " << count << " i " << i;
    }
  }
}

TEST(WorkerPool, JobsRunOnSeveralThreads) {
  core::WorkerPool pool(2);
  std::mutex mutex;
  std::set<std::thread::id> seen;
  // Tasks long enough that the worker joins in before the caller has claimed every index.
  pool.parallelFor(64, [&](std::size_t) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
    const std::lock_guard<std::mutex> lock(mutex);
    seen.insert(std::this_thread::get_id());
  });
  EXPECT_EQ(seen.size(), 2u);
}

TEST(WorkerPool, ConcurrentCallersEachGetTheirWholeJob) {
  core::WorkerPool pool(3);
  constexpr int kCallers = 4;
  constexpr std::size_t kCount = 500;
  std::vector<std::vector<std::atomic<int>>> runs(kCallers);
  for (auto& job : runs) {
    job = std::vector<std::atomic<int>>(kCount);
    for (auto& r : job) r = 0;
  }
  std::vector<std::thread> callers;
  for (int c = 0; c < kCallers; ++c) {
    callers.emplace_back([&, c] {
      for (int round = 0; round < 20; ++round)
        pool.parallelFor(kCount, [&](std::size_t i) { ++runs[c][i]; });
    });
  }
  for (std::thread& caller : callers) caller.join();
  for (int c = 0; c < kCallers; ++c)
    for (std::size_t i = 0; i < kCount; ++i) EXPECT_EQ(runs[c][i].load(), 20) << c << " " << i;
}

TEST(WorkerPool, FirstFailureIsRethrownAndThePoolKeepsWorking) {
  core::WorkerPool pool(2);
  std::atomic<int> ran{0};
  EXPECT_THROW(pool.parallelFor(100,
                                [&](std::size_t i) {
                                  ++ran;
                                  if (i == 17) throw std::runtime_error("scene 17");
                                }),
               std::runtime_error);
  EXPECT_LE(ran.load(), 100);
  std::atomic<int> after{0};
  pool.parallelFor(50, [&](std::size_t) { ++after; });
  EXPECT_EQ(after.load(), 50);
}

TEST(WorkerPool, RejectsAThreadCountOutOfRange) {
  EXPECT_THROW(core::WorkerPool(0), std::invalid_argument);
  EXPECT_THROW(core::WorkerPool(257), std::invalid_argument);
}

// Random multi-contact scenes under every law: the pool's answers equal the serial ones exactly.
TEST(WorkerPool, BatchOnThePoolEqualsSolvingOneAfterTheOther) {
  RandomSource random(4242);
  std::vector<core::Scene> scenes;
  std::vector<core::SolverOptions> options;
  const core::ImpactLaw laws[] = {core::ImpactLaw::kNewton, core::ImpactLaw::kPoisson,
                                  core::ImpactLaw::kStronge, core::ImpactLaw::kSeedOnePass};
  for (int k = 0; k < 200; ++k) {
    core::Scene scene;
    const core::BodyState box = randomFallingBox(random, false);
    scene.bodies = {ground(), box};
    for (int c = 0; c < 1 + k % 4; ++c) {
      scene.contacts.push_back(
          contact("ground", "box",
                  Eigen::Vector3d(random.uniform(-0.5, 0.5), random.uniform(-0.5, 0.5), -0.3),
                  Eigen::Vector3d::UnitZ(), random.uniform(0.0, 1.0), 0.6, 0.4));
    }
    scenes.push_back(scene);
    core::SolverOptions o;
    o.law = laws[k % 4];
    options.push_back(o);
  }
  std::vector<core::CollisionResult> serial;
  for (std::size_t k = 0; k < scenes.size(); ++k)
    serial.push_back(core::computeResponse(scenes[k], options[k]));
  std::vector<core::CollisionResult> pooled(scenes.size());
  core::WorkerPool pool(4);
  pool.parallelFor(scenes.size(), [&](std::size_t k) {
    pooled[k] = core::computeResponse(scenes[k], options[k]);
  });
  for (std::size_t k = 0; k < scenes.size(); ++k) {
    ASSERT_EQ(pooled[k].impulses.size(), serial[k].impulses.size());
    for (std::size_t c = 0; c < serial[k].impulses.size(); ++c) {
      EXPECT_EQ(pooled[k].impulses[c].normal_impulse, serial[k].impulses[c].normal_impulse) << k;
      EXPECT_EQ(pooled[k].impulses[c].friction_impulse, serial[k].impulses[c].friction_impulse)
          << k;
    }
    EXPECT_EQ(pooled[k].bodies[1].linear_velocity, serial[k].bodies[1].linear_velocity) << k;
    EXPECT_EQ(pooled[k].bodies[1].angular_velocity, serial[k].bodies[1].angular_velocity) << k;
  }
}

}  // namespace
