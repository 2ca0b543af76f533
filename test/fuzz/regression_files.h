// The saved inputs a fuzz target once failed on, for the replay tests: every regular file in a
// folder of test/fuzz/regressions/ (README.md and hidden files aside), in name order.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace collision_response::fuzz {

/// `variable` from the environment if set, else `fallback` (the folder CMake names at build time).
inline std::filesystem::path regressionsDir(const char* variable, const char* fallback) {
  if (const char* dir = std::getenv(variable)) return dir;
  return fallback;
}

inline std::vector<std::filesystem::path> regressionFiles(const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  std::vector<fs::path> files;
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

inline std::vector<std::uint8_t> readBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in),
                                   std::istreambuf_iterator<char>());
}

}  // namespace collision_response::fuzz
