// The service in a nodelet: the same CollisionResponseServer as collision_response_node, on the
// nodelet's multi-threaded node handles (the manager's worker threads serve requests concurrently).
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>
#include <stdexcept>

#include "collision_response/ros/collision_response_server.h"

namespace collision_response {

/// nodelet `collision_response/CollisionResponseNodelet`: ~compute, ~compute_batch, ~responses,
/// ~markers under the nodelet's name, with the node's parameters (its private namespace).
class CollisionResponseNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    try {
      server_ =
          std::make_unique<CollisionResponseServer>(getMTNodeHandle(), getMTPrivateNodeHandle());
    } catch (const std::exception& e) {
      NODELET_FATAL("collision_response: %s", e.what());
      throw;  // the manager reports the failed load
    }
  }

  std::unique_ptr<CollisionResponseServer> server_;
};

}  // namespace collision_response

PLUGINLIB_EXPORT_CLASS(collision_response::CollisionResponseNodelet, nodelet::Nodelet)
