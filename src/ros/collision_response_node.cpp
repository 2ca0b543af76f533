#include <ros/ros.h>

#include "collision_response/ros/collision_response_server.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "collision_response");
  try {
    collision_response::CollisionResponseServer server(ros::NodeHandle(), ros::NodeHandle("~"));
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("collision_response: %s", e.what());
    return 1;
  }
  return 0;
}
