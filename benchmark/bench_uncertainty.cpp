// Cost of the outcome distributions of uncertain coefficients (uncertainty.h) against the
// prediction's own (Google Benchmark), Newton law: a unit cube landing flat on 4 corner contacts
// (exact solver), each contact with e ~ N(0.5, 0.05), mu_s ~ U[0.4, 0.6], mu_d ~ N(0.4, 0.03).
//   devel/lib/collision_response/bench_uncertainty          (Release build)
// BM_Predict: computeResponse(); BM_Linear: the linear distribution; BM_LinearGeometry: the same
// with each corner's normal (0.01 rad) and point (5 mm in x and y) uncertain too, whose columns are
// differences of the solver (16 dimensions, 49 solves: the flat face's tilts take secants);
// BM_Sampled/N/threads: N samples on a worker pool of that many threads (wall time:
// --benchmark_min_time=2). BM_LinearOverPredict: the prediction and the linear distribution
// alternately in one loop, the ratio of their medians. Instruction counts of one call each, for the
// ratio linear / prediction:
//   valgrind --tool=callgrind --toggle-collect='*predictOnce*' bench_uncertainty --callgrind
//   valgrind --tool=callgrind --toggle-collect='*linearOnce*' bench_uncertainty --callgrind
// (and '*sampledOnce*': 1,000 samples on the calling thread; '*linearGeometryOnce*').
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
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

// uncertainties() with each corner's normal and point (x, y) uncertain too.
std::vector<core::ContactUncertainty> geometryUncertainties() {
  std::vector<core::ContactUncertainty> all = uncertainties();
  for (core::ContactUncertainty& u : all) {
    u.normal_std_dev = 0.01;
    u.point_std_dev = {0.005, 0.005, 0.0};
  }
  return all;
}

[[gnu::noinline]] core::OutcomeDistribution linearGeometryOnce(
    const core::Scene& scene, const std::vector<core::ContactUncertainty>& u,
    const core::SolverOptions& options) {
  core::UncertaintyOptions linear;  // (spelled out: identical code would be folded with linearOnce)
  linear.method = core::UncertaintyMethod::kLinear;
  return core::computeOutcomeDistribution(scene, u, options, linear);
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

// The prediction and the linear distribution alternately, each call timed on its own
// (steady_clock): the ratio of their medians in one run, immune to the shared machine's speed
// drifting between two benchmarks run one after the other. Counters: predict_ns, linear_ns (the
// medians over the iterations) and ratio.
void BM_LinearOverPredict(benchmark::State& state) {
  const core::Scene scene = cube4();
  const auto u = uncertainties();
  const core::SolverOptions options = newton();
  using Clock = std::chrono::steady_clock;
  std::vector<double> predict, linear;
  for (auto _ : state) {
    const Clock::time_point t0 = Clock::now();
    benchmark::DoNotOptimize(predictOnce(scene, options));
    const Clock::time_point t1 = Clock::now();
    benchmark::DoNotOptimize(linearOnce(scene, u, options));
    const Clock::time_point t2 = Clock::now();
    predict.push_back(std::chrono::duration<double, std::nano>(t1 - t0).count());
    linear.push_back(std::chrono::duration<double, std::nano>(t2 - t1).count());
  }
  auto median = [](std::vector<double>& v) {
    if (v.empty()) return 0.0;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  const double p = median(predict), l = median(linear);
  state.counters["predict_ns"] = p;
  state.counters["linear_ns"] = l;
  state.counters["ratio"] = p > 0.0 ? l / p : 0.0;
}

void BM_LinearGeometry(benchmark::State& state) {
  const core::Scene scene = cube4();
  const auto u = geometryUncertainties();
  const core::SolverOptions options = newton();
  for (auto _ : state) benchmark::DoNotOptimize(linearGeometryOnce(scene, u, options));
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
BENCHMARK(BM_LinearOverPredict);
BENCHMARK(BM_LinearGeometry);
BENCHMARK(BM_Sampled)
    ->Args({10000, 1})
    ->Args({10000, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// A box struck off-centre on the ground, one contact that slides far from sticking (the sliding
// scene of bench_derivatives).
core::Scene slidingBox() {
  core::Scene scene = cube4();
  core::BodyState& box = scene.bodies[1];
  box.mass = 1.5;
  box.inertia = Eigen::Vector3d(0.05, 0.08, 0.1).asDiagonal();
  box.orientation =
      Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()));
  box.position = {0.1, -0.05, 0.2};
  box.linear_velocity = {1.0, 0.3, -2.0};
  box.angular_velocity = {0.5, -1.0, 0.2};
  scene.contacts.resize(1);
  scene.contacts[0].point = {0.0, 0.0, 0.0};
  scene.contacts[0].static_friction = 0.2;
  scene.contacts[0].dynamic_friction = 0.16;
  return scene;
}

// `--accuracy`: how far the linear distribution is from the sampled one (16,384 samples) as the
// spreads grow (docs/uncertainty.md): per relative spread k, every contact with
// e ~ N(e0, e0 k), mu_s ~ N(mu_s0, mu_s0 k), mu_d ~ N(mu_d0, mu_d0 k) around the scene's own
// coefficients; printed: the largest |mean difference| / sampled std dev and the relative
// Frobenius error of the covariance, both over the twists, and the largest stick probability
// difference.
void accuracy(const char* name, const core::Scene& scene) {
  core::SolverOptions options = newton();
  options.time_budget = 600.0;
  core::WorkerPool pool(2);
  std::printf("%s\nspread  mean_err/sd  cov_rel_err  stick_p_err\n", name);
  for (const double k : {0.01, 0.02, 0.05, 0.1, 0.2, 0.3}) {
    std::vector<core::ContactUncertainty> all;
    for (std::size_t c = 0; c < scene.contacts.size(); ++c) {
      const core::Contact& contact = scene.contacts[c];
      core::ContactUncertainty u;
      u.contact = c;
      u.restitution =
          core::CoefficientDistribution::normal(contact.restitution, contact.restitution * k);
      u.static_friction = core::CoefficientDistribution::normal(contact.static_friction,
                                                                contact.static_friction * k);
      u.dynamic_friction = core::CoefficientDistribution::normal(contact.dynamic_friction,
                                                                 contact.dynamic_friction * k);
      all.push_back(u);
    }
    core::UncertaintyOptions sampled;
    sampled.method = core::UncertaintyMethod::kSampled;
    sampled.samples = 16384;
    const auto lin = core::computeOutcomeDistribution(scene, all, options, {});
    const auto smp = core::computeOutcomeDistribution(scene, all, options, sampled, &pool);
    const Eigen::Index twists = 6 * static_cast<Eigen::Index>(scene.bodies.size() - 1);
    double mean_error = 0.0, stick_error = 0.0;
    for (Eigen::Index r = 0; r < twists; ++r) {
      const double sd = std::sqrt(smp.covariance(r, r));
      if (sd > 1e-9) mean_error = std::max(mean_error, std::abs(lin.mean(r) - smp.mean(r)) / sd);
    }
    for (std::size_t c = 0; c < scene.contacts.size(); ++c)
      stick_error =
          std::max(stick_error, std::abs(lin.stick_probability[c] - smp.stick_probability[c]));
    const Eigen::MatrixXd lin_twists = lin.covariance.topLeftCorner(twists, twists);
    const Eigen::MatrixXd smp_twists = smp.covariance.topLeftCorner(twists, twists);
    std::printf("%5.2f  %11.3f  %11.3f  %11.3f\n", k, mean_error,
                (lin_twists - smp_twists).norm() / smp_twists.norm(), stick_error);
  }
}

// `--callgrind`: one counted call of each function, no timing (for the instruction counts above).
int main(int argc, char** argv) {
  if (argc > 1 && std::strcmp(argv[1], "--callgrind") == 0) {
    const core::Scene scene = cube4();
    const auto u = uncertainties();
    const core::SolverOptions options = newton();
    // A first call of each outside the counted ones (thread-local workspaces, lazy tables): not
    // through the counted functions, whose every call callgrind counts.
    benchmark::DoNotOptimize(core::computeOutcomeDistribution(scene, u, options, {}));
    benchmark::DoNotOptimize(core::computeResponse(scene, options));
    benchmark::DoNotOptimize(predictOnce(scene, options));
    benchmark::DoNotOptimize(linearOnce(scene, u, options));
    benchmark::DoNotOptimize(linearGeometryOnce(scene, geometryUncertainties(), options));
    // Under valgrind, 1,000 samples take longer than the default budget of 1 s.
    core::SolverOptions unhurried = options;
    unhurried.time_budget = 3600.0;
    benchmark::DoNotOptimize(sampledOnce(scene, u, unhurried, 1000));
    return 0;
  }
  if (argc > 1 && std::strcmp(argv[1], "--accuracy") == 0) {
    accuracy("sliding box (1 contact)", slidingBox());
    accuracy("cube landing flat (4 contacts)", cube4());
    return 0;
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
