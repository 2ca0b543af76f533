// Replays every input saved under test/fuzz/regressions/robot_episode/ (inputs the robot-episode
// fuzzer, test/fuzz/fuzz_robot_episode.cpp, once failed on) and the committed seed corpus
// test/fuzz/corpus/robot_episode/ through the same decoding and the same path
// (test/fuzz/robot_episode_decoder.h): each must give InvalidInput naming a field or a successful
// episode that keeps the invariants (finite, within its horizon, impacts in order), with no crash
// and no other exception. The seeds must, besides, be solved, as they were when written. No ROS
// master.
//
// The directories are those CMake names at build time (ROBOT_EPISODE_REGRESSIONS_DIR,
// ROBOT_EPISODE_CORPUS_DIR); FUZZ_ROBOT_EPISODE_REGRESSIONS_DIR and FUZZ_ROBOT_EPISODE_CORPUS_DIR
// override them. package:// mesh URLs resolve to this package (ROS_PACKAGE_PATH is set to
// PACKAGE_DIR).
#include <console_bridge/console.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "regression_files.h"
#include "robot_episode_decoder.h"

namespace fs = std::filesystem;
namespace fuzz = collision_response::fuzz;

namespace {

fs::path regressionsDir() {
  return fuzz::regressionsDir("FUZZ_ROBOT_EPISODE_REGRESSIONS_DIR", ROBOT_EPISODE_REGRESSIONS_DIR);
}
fs::path corpusDir() {
  return fuzz::regressionsDir("FUZZ_ROBOT_EPISODE_CORPUS_DIR", ROBOT_EPISODE_CORPUS_DIR);
}

class FuzzRobotEpisodeRegressions : public ::testing::Test {
 protected:
  void SetUp() override {
    setenv("ROS_PACKAGE_PATH", PACKAGE_DIR, 1);
    console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_NONE);
  }
  /// Replays every file of `dir`; returns how many were solved.
  static std::size_t replay(const fs::path& dir) {
    std::size_t solved = 0;
    const std::vector<fs::path> files = fuzz::regressionFiles(dir);
    for (const fs::path& file : files) {
      SCOPED_TRACE(file.string());
      const std::vector<std::uint8_t> bytes = fuzz::readBytes(file);
      const fuzz::RobotEpisodeOutcome outcome =
          fuzz::runRobotEpisodeInput(bytes.data(), bytes.size());
      EXPECT_TRUE(outcome.bug.empty()) << outcome.bug << "\ninput:\n" << outcome.description;
      EXPECT_FALSE(outcome.skipped);
      EXPECT_TRUE(outcome.solved || !outcome.invalid.empty() || !outcome.timeout.empty())
          << outcome.description;
      solved += outcome.solved ? 1 : 0;
    }
    std::printf("replayed %zu input(s) from %s, %zu solved\n", files.size(), dir.c_str(), solved);
    return solved;
  }
};

}  // namespace

TEST_F(FuzzRobotEpisodeRegressions, FindingsGiveInvalidInputOrAnEpisodeThatKeepsTheInvariants) {
  replay(regressionsDir());
}

TEST_F(FuzzRobotEpisodeRegressions, SeedsAreSolvedEpisodesThatKeepTheInvariants) {
  const std::size_t files = fuzz::regressionFiles(corpusDir()).size();
  ASSERT_GT(files, 0u) << corpusDir();
  // Each seed was written because it was solved; a seed that now times out (a slow machine, the
  // sanitizers) is tolerated, one that is refused or breaks an invariant is not.
  EXPECT_GE(replay(corpusDir()) + 1, files);
}
