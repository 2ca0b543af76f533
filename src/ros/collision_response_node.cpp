#include <ros/ros.h>

#include "collision_response/ros/collision_response_server.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "collision_response");
  try {
    const ros::NodeHandle private_node("~");
    collision_response::CollisionResponseServer server(ros::NodeHandle(), private_node);
    // ~threads serve requests concurrently (the server is thread-safe).
    ros::MultiThreadedSpinner(static_cast<uint32_t>(server.parameters().threads)).spin();
  } catch (const std::exception& e) {
    ROS_FATAL("collision_response: %s", e.what());
    return 1;
  }
  return 0;
}
