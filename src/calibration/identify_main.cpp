// identify: coefficients from recorded landings or a robot's recorded impacts
// (docs/calibration.md, "Command line" and "Robot recordings").
#include <cstdio>
#include <exception>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>

#include "collision_response/calibration/identify_program.h"
#include "collision_response/robot/urdf_loader.h"
#include "collision_response/ros/bag_recording.h"
#include "collision_response/ros/robot_geometry.h"

int main(int argc, char** argv) {
  using namespace collision_response::calibration;
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--help" || std::string(argv[i]) == "-h") {
      std::printf("%s", identifyUsage().c_str());
      return 0;
    }
  IdentifyArguments parsed;
  try {
    parsed = parseIdentifyArguments(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "identify: %s\n%s", e.what(), identifyUsage().c_str());
    return 2;
  }
  try {
    const IdentifyArguments& arguments = parsed;
    IdentifyReaders readers;
    // Rosbags: the ros library's readers (tf or PoseStamped; JointState).
    readers.poses = [](const std::string& bag, const IdentifyInput& input) {
      return collision_response::readBagPoseTrack(
          {bag, input.topic, input.world_frame, input.frame});
    };
    readers.joints = [](const std::string& bag, const std::string& topic) {
      return collision_response::readBagJointTrack(bag, topic);
    };
    // A URDF file: the robot library's model, the ros library's links' collision geometry.
    readers.robot = [](const std::string& path) {
      std::ifstream in(path);
      if (!in) throw std::runtime_error(path + ": cannot read");
      std::stringstream text;
      text << in.rdbuf();
      RobotDescription robot;
      robot.source = path;
      try {
        robot.robot = std::make_shared<const collision_response::robot::ArticulatedBody>(
            collision_response::robot::robotFromUrdfString(text.str()));
        robot.links = collision_response::linkCollisionGeometryFromUrdf(text.str());
      } catch (const std::exception& e) {
        throw std::runtime_error(path + ": " + e.what());
      }
      return robot;
    };
    runIdentify(arguments, readers, [](const std::string& line) {
      std::printf("identify: %s\n", line.c_str());
      std::fflush(stdout);
    });
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "identify: %s\n", e.what());
    return 2;
  }
}
