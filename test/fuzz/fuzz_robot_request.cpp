// libFuzzer target on the node's robot path without a ROS master: bytes -> a URDF (generated or
// given as text), a ~robots entry, joint-state messages, a RobotState, rigid bodies and contacts on
// the links (robot_decoder.h) -> ServedRobot, robotAtRequestState(), core::computeBodyResponse(),
// toMsg(). core::InvalidInput (and SolverTimeout) are expected outcomes; any other exception, a
// crash, a sanitizer report, or a successful answer holding a non-finite number aborts.
//
// Environment:
//   FUZZ_PRINT=1           print each decoded input and its outcome (use with --replay).
//   FUZZ_EMIT_SEEDS=DIR    write a seed corpus into DIR and exit: the URDF files listed in
//                          FUZZ_SEED_URDFS (colon-separated; each also with a <mimic> tag added
//                          to its last joint with a coordinate) in text mode, with request bytes
//                          that reach the solver, and generated documents; one per kind (text or
//                          generated, fixed or floating, impact or resting contact).
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

#include "robot_decoder.h"

namespace fuzz = collision_response::fuzz;

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

// The document with a <mimic> tag in its last non-fixed joint, following the one before it (the
// shipped arm: the right finger follows the left one, as grippers do), if it has two.
std::string withMimic(const std::string& urdf) {
  std::vector<std::pair<std::size_t, std::string>> joints;  // (end of the opening tag, name)
  std::size_t at = 0;
  while ((at = urdf.find("<joint name=\"", at)) != std::string::npos) {
    const std::size_t name_begin = at + 13;
    const std::size_t name_end = urdf.find('"', name_begin);
    const std::size_t tag_end = urdf.find('>', name_end);
    if (name_end == std::string::npos || tag_end == std::string::npos) break;
    if (urdf.substr(name_end, tag_end - name_end).find("fixed") == std::string::npos)
      joints.emplace_back(tag_end + 1, urdf.substr(name_begin, name_end - name_begin));
    at = tag_end;
  }
  if (joints.size() < 2) return "";
  const auto& follower = joints.back();
  const auto& leader = joints[joints.size() - 2];
  std::string out = urdf;
  out.insert(follower.first,
             "<mimic joint=\"" + leader.second + "\" multiplier=\"1\" offset=\"0\"/>");
  return out;
}

void emitSeeds(const std::string& dir) {
  std::mt19937 rng(20240602u);
  std::vector<std::string> documents;
  if (const char* list = std::getenv("FUZZ_SEED_URDFS")) {
    std::stringstream paths(list);
    std::string path;
    while (std::getline(paths, path, ':')) {
      if (path.empty()) continue;
      documents.push_back(readFile(path));
      const std::string mimic = withMimic(documents.back());
      if (!mimic.empty()) documents.push_back(mimic);
    }
  }
  std::set<std::string> kinds;
  int written = 0;
  // Text mode: each document with random request bytes; then generated documents.
  for (std::size_t d = 0; d <= documents.size(); ++d) {
    const bool generated = d == documents.size();
    for (int attempt = 0; attempt < (generated ? 3000 : 400); ++attempt) {
      std::vector<std::uint8_t> bytes;
      if (generated) {
        bytes.resize(16 + rng() % 700);
        for (auto& b : bytes) b = static_cast<std::uint8_t>(rng() % 0x7f);  // mostly sane picks
        bytes[0] = static_cast<std::uint8_t>(2 * (rng() % 100));
      } else {
        bytes.push_back(1);
        bytes.insert(bytes.end(), documents[d].begin(), documents[d].end());
        bytes.push_back(0);
        const std::size_t request = 8 + rng() % 300;
        for (std::size_t k = 0; k < request; ++k)
          bytes.push_back(static_cast<std::uint8_t>(rng() % 0x7f));
      }
      const fuzz::RobotOutcome outcome = fuzz::runRobotInput(bytes.data(), bytes.size());
      if (!outcome.bug.empty()) {
        const std::string path =
            dir + "/crash-emit-" + std::to_string(written) + "-" + std::to_string(attempt);
        write(path, bytes);
        std::fprintf(stderr, "emit-seeds: %s breaks: %s\n%s", path.c_str(), outcome.bug.c_str(),
                     outcome.description.c_str());
        std::abort();
      }
      if (!outcome.solved || outcome.contacts == 0) continue;
      const std::string kind = (generated ? "generated/" : "text" + std::to_string(d) + "/") +
                               (outcome.approaching ? "impact" : "rest") +
                               (outcome.resting ? "/force" : "") + "/" +
                               std::to_string(bytes[generated ? 1 : bytes.size() - 1] % 4 == 1);
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
  const fuzz::RobotOutcome outcome = fuzz::runRobotInput(data, size, printInputs());
  if (printInputs()) {
    std::printf("%s", outcome.description.c_str());
    if (outcome.solved) std::printf("outcome: solved\n");
    if (!outcome.timeout.empty())
      std::printf("outcome: SolverTimeout: %s\n", outcome.timeout.c_str());
    std::fflush(stdout);
  }
  if (!outcome.timeout.empty()) std::fprintf(stderr, "slow input: %s\n", outcome.timeout.c_str());
  if (!outcome.bug.empty()) {
    std::fprintf(stderr, "BUG: %s\ninput:\n%s", outcome.bug.c_str(), outcome.description.c_str());
    std::abort();
  }
  return 0;
}
