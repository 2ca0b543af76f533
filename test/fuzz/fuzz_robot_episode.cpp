// libFuzzer target on impact episodes with a robot (~compute_episode with `robots`) without a ROS
// master: bytes -> a URDF (generated or given as text), the robot's state and torque model, a
// world of rigid bodies with shapes, EpisodeOptions (robot_episode_decoder.h) -> ServedRobot,
// robotAtRequestState(), detection::ShapeGaps over the bodies and the links, RobotEpisodeBody,
// core::computeBodyEpisode(), toMsg(). core::InvalidInput naming a field and SolverTimeout are
// expected outcomes; any other exception, a crash, a sanitizer report, or a successful episode
// that breaks an invariant aborts. Every episode has a 0.05 s time budget, so none hangs.
//
// Environment:
//   FUZZ_PRINT=1           print each decoded input and its outcome (use with --replay).
//   FUZZ_EMIT_SEEDS=DIR    write a seed corpus into DIR and exit: the URDF files listed in
//                          FUZZ_SEED_URDFS (colon-separated) in text mode with random request
//                          bytes, and generated documents; one per kind (document, end reason,
//                          impacts: none, one, several).
#include <console_bridge/console.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "robot_episode_decoder.h"

namespace fuzz = collision_response::fuzz;
namespace core = collision_response::core;

namespace {

bool printInputs() {
  static const bool print = [] {
    const char* value = std::getenv("FUZZ_PRINT");
    return value != nullptr && std::string(value) != "0" && std::string(value) != "";
  }();
  return print;
}

void write(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
}

std::string readFile(const std::string& path) {
  std::ifstream file(path);
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

void emitSeeds(const std::string& dir) {
  std::mt19937 rng(20261126u);
  std::vector<std::string> documents;
  if (const char* list = std::getenv("FUZZ_SEED_URDFS")) {
    std::stringstream paths(list);
    std::string path;
    while (std::getline(paths, path, ':'))
      if (!path.empty()) documents.push_back(readFile(path));
  }
  std::set<std::string> kinds;
  int written = 0;
  for (std::size_t d = 0; d <= documents.size(); ++d) {
    const bool generated = d == documents.size();
    for (int attempt = 0; attempt < (generated ? 600 : 120); ++attempt) {
      std::vector<std::uint8_t> bytes;
      if (generated) {
        bytes.resize(16 + rng() % 500);
        for (auto& b : bytes) b = static_cast<std::uint8_t>(rng() % 0x7f);  // mostly sane picks
        bytes[0] = static_cast<std::uint8_t>(2 * (rng() % 100));
      } else {
        bytes.push_back(1);
        bytes.insert(bytes.end(), documents[d].begin(), documents[d].end());
        bytes.push_back(0);
        const std::size_t request = 8 + rng() % 200;
        for (std::size_t k = 0; k < request; ++k)
          bytes.push_back(static_cast<std::uint8_t>(rng() % 0x3f));  // sane options and values
      }
      const fuzz::RobotEpisodeOutcome outcome =
          fuzz::runRobotEpisodeInput(bytes.data(), bytes.size());
      if (!outcome.bug.empty()) {
        const std::string path =
            dir + "/crash-emit-" + std::to_string(d) + "-" + std::to_string(attempt);
        write(path, bytes);
        std::fprintf(stderr, "emit-seeds: %s breaks: %s\n%s", path.c_str(), outcome.bug.c_str(),
                     outcome.description.c_str());
        std::abort();
      }
      if (!outcome.solved) continue;
      const std::string kind =
          (generated ? std::string("generated/") : "text" + std::to_string(d) + "/") +
          core::toString(outcome.end) + "/" +
          (outcome.impacts == 0   ? "0"
           : outcome.impacts == 1 ? "1"
                                  : "n");
      if (!kinds.insert(kind).second) continue;
      const std::string path = dir + "/seed-" + std::to_string(written++);
      write(path, bytes);
      std::printf("emit-seeds: %s (%s)\n", path.c_str(), kind.c_str());
    }
  }
  std::printf("emit-seeds: %d seeds\n", written);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  // urdfdom's parse errors go through console_bridge: silence them (the outcome says it).
  console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_NONE);
  if (const char* dir = std::getenv("FUZZ_EMIT_SEEDS")) {
    emitSeeds(dir);
    std::exit(0);
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const fuzz::RobotEpisodeOutcome outcome = fuzz::runRobotEpisodeInput(data, size, printInputs());
  if (printInputs()) {
    std::printf("%s", outcome.description.c_str());
    std::fflush(stdout);
  }
  if (!outcome.bug.empty()) {
    std::fprintf(stderr, "BUG: %s\ninput:\n%s", outcome.bug.c_str(), outcome.description.c_str());
    std::abort();
  }
  return 0;
}
