// identify: coefficients from recorded landings (docs/calibration.md, "Command line").
#include <cstdio>
#include <exception>

#include "collision_response/calibration/identify_program.h"
#include "collision_response/ros/bag_recording.h"

int main(int argc, char** argv) {
  using namespace collision_response::calibration;
  try {
    const IdentifyArguments arguments = parseIdentifyArguments(argc, argv);
    // Rosbags: the ros library's reader (tf or PoseStamped).
    const BagReader read_bag = [](const std::string& bag, const IdentifyInput& input) {
      return collision_response::readBagPoseTrack(
          {bag, input.topic, input.world_frame, input.frame});
    };
    runIdentify(arguments, read_bag, [](const std::string& line) {
      std::printf("identify: %s\n", line.c_str());
      std::fflush(stdout);
    });
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "identify: %s\n", e.what());
    return 2;
  }
}
