// identify: coefficients from recorded landings (docs/calibration.md, "Command line").
#include <cstdio>
#include <exception>

#include "collision_response/calibration/identify_program.h"

int main(int argc, char** argv) {
  using namespace collision_response::calibration;
  try {
    const IdentifyArguments arguments = parseIdentifyArguments(argc, argv);
    // Rosbags: the ros library's reader is wired in here (readBagPoseTrack); until then --bag
    // is refused with a message naming the bag.
    runIdentify(arguments, BagReader(), [](const std::string& line) {
      std::printf("identify: %s\n", line.c_str());
      std::fflush(stdout);
    });
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "identify: %s\n", e.what());
    return 2;
  }
}
