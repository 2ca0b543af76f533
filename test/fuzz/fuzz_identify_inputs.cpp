// libFuzzer target on the identify program's inputs: bytes -> an object file and a CSV recording
// -> calibration::parseObjectModel, calibration::readCsvTracks (through a file, as identify reads
// it) and calibration::extractLandings (identify_inputs_check.h). A clear error naming its source
// (std::runtime_error) or landings whose numbers are all finite are the expected outcomes; any
// other exception, an error not naming its source, a non-finite number in an accepted object or a
// landing, a crash, a sanitizer report or a hang aborts.
//
// Environment:
//   FUZZ_PRINT=1         print each input's outcome (use with --replay).
//   FUZZ_EMIT_SEEDS=DIR  write the seed inputs (recordings with a clean landing, in both CSV
//                        layouts, for a box, a sphere and a cylinder) into DIR and exit; the same
//                        seeds are committed in test/fuzz/corpus/identify/.
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "identify_inputs_check.h"

namespace fuzz = collision_response::fuzz;

namespace {

bool flag(const char* name) {
  const char* value = std::getenv(name);
  return value != nullptr && std::string(value) != "0" && std::string(value) != "";
}

/// CSV rows of a recording at 148 Hz of an object whose lowest point lies `low` below its origin
/// (upright, turning about the vertical at 3 rad/s): a fall onto the floor z = floor, one sample
/// resting there, a hop up at 0.6 m/s, and rest on the floor. With `toss` >= 0 the rows carry that
/// toss number (the many-recordings layout).
std::string recording(double low, double floor, int toss) {
  std::ostringstream out;
  out.precision(9);
  const double g = 9.81, dt = 1.0 / 148.0, z0 = floor + low + 0.25;
  auto row = [&](int k, double x, double y, double z) {
    const double angle = 3.0 * k * dt;
    if (toss >= 0) out << toss << ",";
    out << k * dt << "," << x << "," << y << "," << z << "," << std::cos(angle / 2) << ",0,0,"
        << std::sin(angle / 2) << "\n";
  };
  int k = 0;
  // The fall: from z0 at 1 m/s down, 0.3 m/s sideways, until the lowest point reaches the floor.
  for (;; ++k) {
    const double t = k * dt, z = z0 - 1.0 * t - 0.5 * g * t * t;
    if (z - low <= floor) break;
    row(k, 0.3 * t, 0.0, z);
  }
  const double x_contact = 0.3 * k * dt;
  row(k++, x_contact, 0.0, floor + low);
  // The hop: up at 0.6 m/s from 1 mm above the floor, sideways at 0.1 m/s, until it is back.
  const int hop = k;
  for (;; ++k) {
    const double t = (k - hop) * dt, z = floor + low + 0.001 + 0.6 * t - 0.5 * g * t * t;
    if (z - low <= floor) break;
    row(k, x_contact + 0.1 * t, 0.0, z);
  }
  const double x_rest = x_contact + 0.1 * (k - hop) * dt;
  for (int rest = 0; rest < 14; ++rest, ++k) row(k, x_rest, 0.0, floor + low);
  return out.str();
}

void write(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

void emitSeeds(const std::string& dir) {
  const std::string one = "t,x,y,z,qw,qx,qy,qz\n", many = "toss,t,x,y,z,qw,qx,qy,qz\n";
  // The default object (the cube; floor from rest), one recording.
  write(dir + "/seed-cube-default", one + recording(0.0524, 0.0, -1));
  // A box on a given floor, two recordings in the tosses' layout.
  write(dir + "/seed-box-tosses",
        "shape: {type: box, size: [0.1, 0.2, 0.3]}  # a brick\nmass: 1.5\nmaterial_a: brick\n"
        "material_b: table\nfloor_height: 0.02\n%%\n" +
            many + recording(0.15, 0.02, 3) + recording(0.15, 0.02, 4));
  // A sphere with its inertia given (three numbers).
  write(dir + "/seed-sphere",
        "shape: {type: sphere, radius: 0.05}\nmass: 0.2\ninertia: [2e-4, 2e-4, 2e-4]\n"
        "material_a: ball\nmaterial_b: floor\n%%\n" +
            one + recording(0.05, 0.0, -1));
  // A cylinder (axis z), inertia row-major.
  write(dir + "/seed-cylinder",
        "shape: {type: cylinder, radius: 0.04, length: 0.12}\nmass: 0.5\n"
        "inertia: [8e-4, 0, 0, 0, 8e-4, 0, 0, 0, 4e-4]\nmaterial_a: can\nmaterial_b: floor\n"
        "floor_height: 0.0\n%%\n" +
            one + recording(0.06, 0.0, -1));
  std::printf("emit-seeds: 4 seeds in %s\n", dir.c_str());
}

std::string csvPath() {
  return (std::filesystem::temp_directory_path() /
          ("fuzz-identify-" + std::to_string(::getpid()) + ".csv"))
      .string();
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
  static const std::string path = csvPath();
  const fuzz::IdentifyInputsOutcome outcome = fuzz::runIdentifyInputs(data, size, path);
  if (print) {
    std::printf("recordings %d, landings %d%s%s\n", outcome.recordings, outcome.landings,
                outcome.error.empty() ? "" : ", error: ", outcome.error.c_str());
    std::fflush(stdout);
  }
  if (!outcome.bug.empty()) {
    std::fprintf(stderr, "BUG: %s\n", outcome.bug.c_str());
    std::abort();
  }
  return 0;
}
