// Replays every input saved under test/fuzz/regressions/ (inputs the fuzzer,
// test/fuzz/fuzz_compute_response.cpp, once failed on) through the same decoding
// (test/fuzz/scene_decoder.h): each must give InvalidInput or a successful answer that is finite
// and keeps the cheap invariants, with no crash and no other exception. No ROS.
//
// The directory is found next to this source file; FUZZ_REGRESSIONS_DIR overrides it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "scene_decoder.h"

namespace fs = std::filesystem;
namespace fuzz = collision_response::fuzz;

namespace {

fs::path regressionsDir() {
  if (const char* dir = std::getenv("FUZZ_REGRESSIONS_DIR")) return dir;
  return fs::path(__FILE__).parent_path() / "regressions";
}

std::vector<fs::path> regressionFiles() {
  std::vector<fs::path> files;
  const fs::path dir = regressionsDir();
  if (!fs::is_directory(dir)) return files;
  for (const fs::directory_entry& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (!entry.is_regular_file() || name.empty() || name[0] == '.' ||
        entry.path().extension() == ".md")
      continue;
    files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

std::vector<std::uint8_t> readBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in),
                                   std::istreambuf_iterator<char>());
}

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
