// Replays every input saved under test/fuzz/regressions/episode/ (inputs the episode fuzzer,
// test/fuzz/fuzz_episode.cpp, once failed on) through the same decoding and the same path
// (test/fuzz/episode_decoder.h: SceneValidator, detection::ShapeGaps, core::computeEpisode): each
// must give InvalidInput, SolverTimeout (the 0.05 s budget) or a successful episode that keeps the
// invariants the fuzzer checks (finite, within the horizon, impacts in order and within the cap, no
// body sunk into a plane at a separated end), with no crash and no other exception. No ROS.
//
// The first finding's semantics are checked on a closed form too: a ball dropped on a floor with
// resting_velocity 0 bounces infinitely often (no rebound is ever below 0), in the finite time of
// the geometric series, and the episode says so with accumulated_impacts = INT_MAX.
//
// The directory is the one CMake names at build time (EPISODE_REGRESSIONS_DIR);
// FUZZ_EPISODE_REGRESSIONS_DIR overrides it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "episode_decoder.h"
#include "regression_files.h"

namespace fs = std::filesystem;
namespace fuzz = collision_response::fuzz;

namespace {

fs::path regressionsDir() {
  return fuzz::regressionsDir("FUZZ_EPISODE_REGRESSIONS_DIR", EPISODE_REGRESSIONS_DIR);
}

}  // namespace

TEST(FuzzEpisodeRegressions, DirectoryHoldsInputs) {
  EXPECT_FALSE(fuzz::regressionFiles(regressionsDir()).empty()) << regressionsDir();
}

TEST(FuzzEpisodeRegressions, EveryInputGivesAnErrorOrAnEpisodeKeepingTheInvariants) {
  const std::vector<fs::path> files = fuzz::regressionFiles(regressionsDir());
  for (const fs::path& file : files) {
    SCOPED_TRACE(file.string());
    const std::vector<std::uint8_t> bytes = fuzz::readBytes(file);
    const fuzz::DecodedEpisode episode = fuzz::decodeEpisode(bytes.data(), bytes.size());
    const fuzz::EpisodeOutcome outcome = fuzz::runEpisode(episode);
    EXPECT_TRUE(outcome.bug.empty()) << outcome.bug << "\nepisode:\n" << fuzz::describe(episode);
    EXPECT_TRUE(outcome.solved || !outcome.invalid.empty() || !outcome.timeout.empty());
  }
  std::printf("replayed %zu input(s) from %s\n", files.size(), regressionsDir().c_str());
}

// A ball dropped from rest at height h onto a floor, e = 0.5, frictionless: it lands at
// t1 = sqrt(2 h / g), and each rebound lasts e times the one before, 2 t1 e^k: it comes to rest at
// t1 (1 + 2 e / (1 - e)) after infinitely many bounces. With resting_velocity 0 no rebound falls
// below it: the accumulation closes them all, counted as INT_MAX (the count does not fit an int).
TEST(FuzzEpisodeRegressions, ZeroRestingVelocityClosesInfinitelyManyBouncesInTheSeriesTime) {
  namespace core = collision_response::core;
  namespace detection = collision_response::detection;
  constexpr double kRadius = 0.05, kHeight = 0.1, kE = 0.5, kG = 9.81;
  core::BodyState floor;
  floor.id = "floor";
  core::BodyState ball;
  ball.id = "ball";
  ball.mass = 0.2;
  ball.inertia = Eigen::Matrix3d::Identity() * 0.4 * ball.mass * kRadius * kRadius;
  ball.position = Eigen::Vector3d(0.0, 0.0, kRadius + kHeight);
  detection::DetectionInput input;
  detection::Shape plane, sphere;
  plane.type = detection::Shape::Type::kPlane;
  plane.dimensions = {0.0, 0.0, 1.0, 0.0};
  sphere.type = detection::Shape::Type::kSphere;
  sphere.dimensions = {kRadius};
  input.geometry = {{{plane}}, {{sphere}}};
  input.defaults = {kE, 0.0, 0.0};
  const std::vector<core::BodyState> bodies = {floor, ball};
  const detection::ShapeGaps geometry(bodies, input, detection::MaterialTable{});
  core::EpisodeOptions options;
  options.gravity = Eigen::Vector3d(0.0, 0.0, -kG);
  options.solver.law = core::ImpactLaw::kNewton;
  options.solver.resting_velocity = 0.0;
  const core::EpisodeResult result = core::computeEpisode(bodies, geometry, options);

  const double t1 = std::sqrt(2.0 * kHeight / kG);
  EXPECT_EQ(result.end, core::EpisodeEnd::kSustainedContact);
  // The first contact is found within contact_tolerance (1e-4 m) at ~1.4 m/s: ~1e-4 s.
  EXPECT_NEAR(result.end_time, t1 * (1.0 + 2.0 * kE / (1.0 - kE)), 2e-4);
  EXPECT_EQ(result.accumulated_impacts, std::numeric_limits<int>::max());
  EXPECT_GE(result.impacts.size(), 2u);
}

// A contact tolerance of 1e200 m is finite and > 0, so computeEpisode() took it, and ShapeGaps
// inflated FCL's bounding boxes by it: FCL's broadphase tree overflowed and dereferenced a null
// child (a segmentation fault; `segv-fcl-broadphase-huge-range.bin` reached it through gaps()).
// Now the tolerance is refused beyond 1 m (option_ranges::kContactTolerance, as detection's) and
// the range beyond
// ShapeGaps::kMaxRange, each naming its field.
TEST(FuzzEpisodeRegressions, HugeContactToleranceAndRangeAreRefusedNamingTheField) {
  namespace core = collision_response::core;
  namespace detection = collision_response::detection;
  core::BodyState table;
  table.id = "table";
  core::BodyState box;
  box.id = "box";
  box.mass = 1.0;
  box.inertia = Eigen::Matrix3d::Identity() * 0.01;
  box.position = Eigen::Vector3d(0.0, 0.0, 0.2);
  detection::Shape shape;
  shape.type = detection::Shape::Type::kBox;
  shape.dimensions = {0.1, 0.1, 0.1};
  detection::DetectionInput input;
  input.geometry = {{{shape}}, {{shape}}};  // a box on an immovable box: an FCL pair
  const std::vector<core::BodyState> bodies = {table, box};
  const detection::ShapeGaps geometry(bodies, input, detection::MaterialTable{});
  for (const double tolerance : {1.5, 1e200}) {
    core::EpisodeOptions options;
    options.contact_tolerance = tolerance;
    try {
      core::computeEpisode(bodies, geometry, options);
      ADD_FAILURE() << "contact_tolerance " << tolerance << " accepted";
    } catch (const core::InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find("contact_tolerance"), std::string::npos) << e.what();
    }
  }
  std::vector<core::GapContact> gaps;
  EXPECT_THROW(geometry.gaps(bodies, 1e200, gaps), core::InvalidInput);
  // The largest tolerance taken still answers (a range of up to 1e4 tolerances).
  core::EpisodeOptions options;
  options.contact_tolerance = 1.0;
  EXPECT_NO_THROW(core::computeEpisode(bodies, geometry, options));
}
