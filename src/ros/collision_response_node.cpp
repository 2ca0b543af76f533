#include <ros/ros.h>

#include "collision_response/ros/collision_response_server.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "collision_response");
  try {
    const ros::NodeHandle private_node("~");
    collision_response::CollisionResponseServer server(ros::NodeHandle(), private_node);
    // Threads serving requests concurrently (the server is thread-safe).
    const int threads = private_node.param("threads", 2);
    if (threads < 1) throw std::invalid_argument("~threads must be at least 1");
    ros::MultiThreadedSpinner(static_cast<uint32_t>(threads)).spin();
  } catch (const std::exception& e) {
    ROS_FATAL("collision_response: %s", e.what());
    return 1;
  }
  return 0;
}
