// Replays every input saved under test/fuzz/regressions/ (inputs the fuzzer,
// test/fuzz/fuzz_compute_response.cpp, once failed on) through the same decoding
// (test/fuzz/scene_decoder.h): each must give InvalidInput or a successful answer that is finite
// and keeps the cheap invariants, with no crash and no other exception. No ROS.
//
// The directory is the one CMake names at build time (REGRESSIONS_DIR); FUZZ_REGRESSIONS_DIR
// overrides it.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "regression_files.h"
#include "scene_decoder.h"

namespace fs = std::filesystem;
namespace fuzz = collision_response::fuzz;

namespace {

fs::path regressionsDir() {
  return fuzz::regressionsDir("FUZZ_REGRESSIONS_DIR", REGRESSIONS_DIR);
}
std::vector<fs::path> regressionFiles() {
  return fuzz::regressionFiles(regressionsDir());
}
using fuzz::readBytes;

}  // namespace

TEST(FuzzRegressions, DirectoryExists) {
  EXPECT_TRUE(fs::is_directory(regressionsDir())) << regressionsDir();
}

TEST(FuzzRegressions, EveryInputGivesInvalidInputOrAFiniteAnswer) {
  const std::vector<fs::path> files = regressionFiles();
  for (const fs::path& file : files) {
    SCOPED_TRACE(file.string());
    const std::vector<std::uint8_t> bytes = readBytes(file);
    const fuzz::DecodedRequest request = fuzz::decodeRequest(bytes.data(), bytes.size());
    const fuzz::Outcome outcome = fuzz::run(request);
    EXPECT_TRUE(outcome.bug.empty()) << outcome.bug << "\nrequest:\n" << fuzz::describe(request);
    EXPECT_TRUE(outcome.timeout.empty()) << outcome.timeout;
    EXPECT_TRUE(outcome.solved || !outcome.invalid.empty());
  }
  std::printf("replayed %zu input(s) from %s\n", files.size(), regressionsDir().c_str());
}
