// Replays every input saved under test/fuzz/regressions/robot/ (inputs the robot fuzzer,
// test/fuzz/fuzz_robot_request.cpp, once failed on) through the same decoding and the same path
// (test/fuzz/robot_decoder.h): each must give InvalidInput (naming a field) or a successful answer
// that is finite, with no crash and no other exception. No ROS master.
//
// The directory is the one CMake names at build time (ROBOT_REGRESSIONS_DIR);
// FUZZ_ROBOT_REGRESSIONS_DIR overrides it. package:// mesh URLs resolve to this package
// (ROS_PACKAGE_PATH is set to PACKAGE_DIR).
#include <console_bridge/console.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "regression_files.h"
#include "robot_decoder.h"

namespace fs = std::filesystem;
namespace fuzz = collision_response::fuzz;

namespace {

fs::path regressionsDir() {
  return fuzz::regressionsDir("FUZZ_ROBOT_REGRESSIONS_DIR", ROBOT_REGRESSIONS_DIR);
}
std::vector<fs::path> regressionFiles() {
  return fuzz::regressionFiles(regressionsDir());
}
using fuzz::readBytes;

}  // namespace

TEST(FuzzRobotRegressions, DirectoryHoldsInputs) {
  EXPECT_FALSE(regressionFiles().empty()) << regressionsDir();
}

TEST(FuzzRobotRegressions, EveryInputGivesInvalidInputOrAFiniteAnswer) {
  setenv("ROS_PACKAGE_PATH", PACKAGE_DIR, 1);
  console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_NONE);
  const std::vector<fs::path> files = regressionFiles();
  for (const fs::path& file : files) {
    SCOPED_TRACE(file.string());
    const std::vector<std::uint8_t> bytes = readBytes(file);
    const fuzz::RobotOutcome outcome = fuzz::runRobotInput(bytes.data(), bytes.size());
    EXPECT_TRUE(outcome.bug.empty()) << outcome.bug << "\ninput:\n" << outcome.description;
    EXPECT_TRUE(outcome.timeout.empty()) << outcome.timeout;
    EXPECT_FALSE(outcome.skipped);
    EXPECT_TRUE(outcome.solved || !outcome.invalid.empty()) << outcome.description;
  }
  std::printf("replayed %zu input(s) from %s\n", files.size(), regressionsDir().c_str());
}
