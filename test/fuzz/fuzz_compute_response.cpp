// libFuzzer target on the request path of the core: bytes -> (Scene, SolverOptions, RequestLimits)
// (scene_decoder.h) -> core::computeResponse. InvalidInput is an expected outcome; any other
// exception, a crash, a sanitizer report, or a successful answer that breaks a cheap invariant
// (non-finite velocities, impulses or energies, wrong sizes, a moved immovable body, islands that
// do not partition the contacts) aborts.
//
// Environment:
//   FUZZ_PRINT=1           print each decoded request and its outcome (use with --replay).
//   FUZZ_SKIP_EXTREME=1    excuse non-finite answers to requests holding finite but extreme
//                          magnitudes (|x| > 1e20 or < 1e-20, see extremeMagnitudes()): a known
//                          overflow class, so that the fuzzer can look past it.
//   FUZZ_EMIT_SEEDS=DIR    write a seed corpus of valid, solvable requests (one per combination of
//                          law, solver and island methods met) into DIR and exit.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "scene_decoder.h"

namespace fuzz = collision_response::fuzz;

namespace {

bool flag(const char* name) {
  const char* value = std::getenv(name);
  return value != nullptr && std::string(value) != "0" && std::string(value) != "";
}

bool printRequests() {
  static const bool print = flag("FUZZ_PRINT");
  return print;
}

bool skipExtreme() {
  static const bool skip = flag("FUZZ_SKIP_EXTREME");
  return skip;
}

bool approaching(const fuzz::Outcome& outcome) {
  for (const auto& impulse : outcome.result.impulses) {
    if (impulse.normal_velocity_before < 0.0) return true;
  }
  return false;
}

// Random byte strings, kept if they decode into a request that is solved (and that approaches or
// rests), one per combination of law, solver option and island methods.
void emitSeeds(const std::string& dir) {
  std::mt19937 rng(20240601u);
  std::set<std::string> kinds;
  int written = 0;
  for (int attempt = 0; attempt < 200000 && written < 48; ++attempt) {
    std::vector<std::uint8_t> bytes(32 + rng() % 600);
    for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
    // Keep the options sane (bit 7 and 6 both set would make them "wild").
    bytes[0] &= 0x7f;
    const fuzz::DecodedRequest request = fuzz::decodeRequest(bytes.data(), bytes.size());
    if (fuzz::extremeMagnitudes(request)) continue;  // seeds hold physical values only
    const fuzz::Outcome outcome = fuzz::run(request);
    if (!outcome.bug.empty()) {
      // A bug found while looking for seeds: save the input, then abort like the fuzzer would.
      const std::string path = dir + "/crash-emit-" + std::to_string(attempt);
      std::ofstream(path, std::ios::binary)
          .write(reinterpret_cast<const char*>(bytes.data()),
                 static_cast<std::streamsize>(bytes.size()));
      std::fprintf(stderr, "emit-seeds: candidate %d (%s) breaks: %s\nrequest:\n%s", attempt,
                   path.c_str(), outcome.bug.c_str(), fuzz::describe(request).c_str());
      std::abort();
    }
    if (!outcome.solved || outcome.result.islands.empty()) continue;
    std::string kind = std::string(collision_response::core::toString(request.options.law)) + "/" +
                       collision_response::core::toString(request.options.method);
    for (const auto& island : outcome.result.islands) kind += "/" + island.methodName();
    kind += approaching(outcome) ? "/impact" : "/rest";
    if (!kinds.insert(kind).second) continue;
    const std::string path = dir + "/seed-" + std::to_string(written++);
    std::ofstream(path, std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()),
               static_cast<std::streamsize>(bytes.size()));
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
  const fuzz::DecodedRequest request = fuzz::decodeRequest(data, size);
  const fuzz::Outcome outcome = fuzz::run(request);
  if (printRequests()) {
    std::printf("%s", fuzz::describe(request).c_str());
    if (outcome.solved) {
      std::printf("outcome: solved");
      for (const auto& island : outcome.result.islands) {
        std::printf(" [%s, %zu iterations, residual %g%s]", island.methodName().c_str(),
                    island.iterations, island.residual, island.converged ? "" : ", NOT converged");
      }
      std::printf("\n");
      for (std::size_t i = 0; i < outcome.result.bodies.size(); ++i) {
        const auto& b = outcome.result.bodies[i];
        std::printf(
            "  bodies[%zu] after: linear [%.17g, %.17g, %.17g], angular [%.17g, %.17g, %.17g]\n", i,
            b.linear_velocity[0], b.linear_velocity[1], b.linear_velocity[2], b.angular_velocity[0],
            b.angular_velocity[1], b.angular_velocity[2]);
      }
      std::printf("  kinetic energy %.17g -> %.17g\n", outcome.result.kinetic_energy_before,
                  outcome.result.kinetic_energy_after);
    } else if (!outcome.timeout.empty()) {
      std::printf("outcome: SolverTimeout: %s\n", outcome.timeout.c_str());
    } else if (outcome.bug.empty()) {
      std::printf("outcome: InvalidInput: %s\n", outcome.invalid.c_str());
    }
    std::fflush(stdout);
  }
  if (!outcome.timeout.empty()) {
    // Documented behaviour, but an input that needs more than 5 s is worth a look.
    std::fprintf(stderr, "slow input: %s\n", outcome.timeout.c_str());
  }
  if (!outcome.bug.empty() && outcome.non_finite && skipExtreme() &&
      fuzz::extremeMagnitudes(request)) {
    return 0;
  }
  if (!outcome.bug.empty()) {
    std::fprintf(stderr, "BUG: %s\nrequest:\n%s", outcome.bug.c_str(),
                 fuzz::describe(request).c_str());
    std::abort();
  }
  return 0;
}
