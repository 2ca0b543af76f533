// Replays every input saved under test/fuzz/regressions/identify/ (inputs the identify fuzzer,
// test/fuzz/fuzz_identify_inputs.cpp, once failed on) and every seed of its committed corpus
// (test/fuzz/corpus/identify/) through the same path (test/fuzz/identify_inputs_check.h: the object
// file, the CSV recording read from a file, the landings): each must give a clear error naming its
// source or finite landings, with no crash and no other exception. The seeds must give landings
// (they are recordings with a clean hop). No Ceres, no ROS.
//
// The directories are the ones CMake names at build time (IDENTIFY_REGRESSIONS_DIR,
// IDENTIFY_CORPUS_DIR); FUZZ_IDENTIFY_REGRESSIONS_DIR overrides the first.
#include <gtest/gtest.h>

#include <unistd.h>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "identify_inputs_check.h"
#include "regression_files.h"

namespace fs = std::filesystem;
namespace fuzz = collision_response::fuzz;

namespace {

fs::path regressionsDir() {
  return fuzz::regressionsDir("FUZZ_IDENTIFY_REGRESSIONS_DIR", IDENTIFY_REGRESSIONS_DIR);
}

std::string csvPath() {
  return (fs::temp_directory_path() /
          ("fuzz-identify-regressions-" + std::to_string(::getpid()) + ".csv"))
      .string();
}

}  // namespace

TEST(FuzzIdentifyRegressions, DirectoriesHoldInputs) {
  EXPECT_FALSE(fuzz::regressionFiles(regressionsDir()).empty()) << regressionsDir();
  EXPECT_FALSE(fuzz::regressionFiles(IDENTIFY_CORPUS_DIR).empty()) << IDENTIFY_CORPUS_DIR;
}

TEST(FuzzIdentifyRegressions, EveryInputGivesANamedErrorOrFiniteLandings) {
  const std::string path = csvPath();
  const std::vector<fs::path> files = fuzz::regressionFiles(regressionsDir());
  for (const fs::path& file : files) {
    SCOPED_TRACE(file.string());
    const std::vector<std::uint8_t> bytes = fuzz::readBytes(file);
    const fuzz::IdentifyInputsOutcome outcome =
        fuzz::runIdentifyInputs(bytes.data(), bytes.size(), path);
    EXPECT_TRUE(outcome.bug.empty()) << outcome.bug;
  }
  fs::remove(path);
  std::printf("replayed %zu input(s) from %s\n", files.size(), regressionsDir().c_str());
}

TEST(FuzzIdentifyRegressions, SeedsGiveLandings) {
  const std::string path = csvPath();
  for (const fs::path& file : fuzz::regressionFiles(IDENTIFY_CORPUS_DIR)) {
    SCOPED_TRACE(file.string());
    const std::vector<std::uint8_t> bytes = fuzz::readBytes(file);
    const fuzz::IdentifyInputsOutcome outcome =
        fuzz::runIdentifyInputs(bytes.data(), bytes.size(), path);
    EXPECT_TRUE(outcome.bug.empty()) << outcome.bug;
    EXPECT_TRUE(outcome.error.empty()) << outcome.error;
    EXPECT_GE(outcome.landings, 1);
    EXPECT_EQ(outcome.landings, outcome.recordings);
  }
  fs::remove(path);
}
