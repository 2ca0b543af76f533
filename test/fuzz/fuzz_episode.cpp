// libFuzzer target on impact episodes: bytes -> bodies, their shapes (boxes, spheres, cylinders,
// cones, small meshes, planes), materials and EpisodeOptions (episode_decoder.h) -> the path of
// ~compute_episode without a ROS master: core::SceneValidator, detection::ShapeGaps,
// core::computeEpisode. core::InvalidInput and core::SolverTimeout are expected outcomes; any other
// exception, a crash, a sanitizer report, or a successful episode that breaks an invariant
// (non-finite numbers, end_time past the horizon, impacts out of order or past the cap, a moved
// immovable body, a body that started above a plane ending `separated` more than 4 contact
// tolerances below it) aborts. Every episode has a 0.05 s time budget, so none hangs.
//
// Environment:
//   FUZZ_PRINT=1           print each decoded episode and its outcome (use with --replay).
//   FUZZ_SKIP_EXTREME=1    excuse non-finite answers to bodies holding finite but extreme
//                          magnitudes (scene_decoder.h's extremeMagnitudes()).
//   FUZZ_EMIT_SEEDS=DIR    write a seed corpus of solved episodes (one per law, end reason and
//                          count of impacts: none, one, several) into DIR and exit.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "episode_decoder.h"

namespace fuzz = collision_response::fuzz;
namespace core = collision_response::core;

namespace {

bool flag(const char* name) {
  const char* value = std::getenv(name);
  return value != nullptr && std::string(value) != "0" && std::string(value) != "";
}

void write(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
}

// Random byte strings, kept if they decode into an episode that is solved, one per combination of
// law, end reason and number of impacts (none, one, several).
void emitSeeds(const std::string& dir) {
  std::mt19937 rng(20261126u);
  std::set<std::string> kinds;
  int written = 0;
  for (int attempt = 0; attempt < 3000 && written < 32; ++attempt) {
    std::vector<std::uint8_t> bytes(24 + rng() % 200);
    for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
    bytes[0] &= 0x3f;  // sane solver options
    bytes[6] &= 0x3f;  // sane episode options
    const fuzz::DecodedEpisode episode = fuzz::decodeEpisode(bytes.data(), bytes.size());
    const fuzz::EpisodeOutcome outcome = fuzz::runEpisode(episode);
    if (!outcome.bug.empty()) {
      const std::string path = dir + "/crash-emit-" + std::to_string(attempt);
      write(path, bytes);
      std::fprintf(stderr, "emit-seeds: candidate %d (%s) breaks: %s\nepisode:\n%s", attempt,
                   path.c_str(), outcome.bug.c_str(), fuzz::describe(episode).c_str());
      std::abort();
    }
    if (!outcome.solved) continue;
    const std::size_t impacts = outcome.result.impacts.size();
    const std::string kind = std::string(core::toString(episode.options.solver.law)) + "/" +
                             core::toString(outcome.result.end) + "/" +
                             (impacts == 0   ? "0"
                              : impacts == 1 ? "1"
                                             : "n");
    if (!kinds.insert(kind).second) continue;
    const std::string path = dir + "/seed-" + std::to_string(written++);
    write(path, bytes);
    std::printf("emit-seeds: %s (%s)\n", path.c_str(), kind.c_str());
  }
  std::printf("emit-seeds: %d seeds\n", written);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  if (const char* dir = std::getenv("FUZZ_EMIT_SEEDS")) {
    emitSeeds(dir);
    std::exit(0);
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool print = flag("FUZZ_PRINT");
  static const bool skip_extreme = flag("FUZZ_SKIP_EXTREME");
  const fuzz::DecodedEpisode episode = fuzz::decodeEpisode(data, size);
  const fuzz::EpisodeOutcome outcome = fuzz::runEpisode(episode);
  if (print) {
    std::printf("%s%s", fuzz::describe(episode).c_str(), fuzz::describe(outcome).c_str());
    std::fflush(stdout);
  }
  if (!outcome.bug.empty() && outcome.non_finite && skip_extreme &&
      fuzz::extremeMagnitudes(episode)) {
    return 0;
  }
  if (!outcome.bug.empty()) {
    std::fprintf(stderr, "BUG: %s\nepisode:\n%s", outcome.bug.c_str(),
                 fuzz::describe(episode).c_str());
    std::abort();
  }
  return 0;
}
