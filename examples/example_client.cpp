// Example C++ client of collision_response: two spheres meet head on (~compute), then the same
// impact at three speeds in one call (~compute_batch).
// Usage: example_client [SERVER_NAMESPACE]   (default /collision_response)
// Exits 1 if a call fails or the answer disagrees with the closed form.
#include <collision_response/ComputeBatch.h>
#include <collision_response/ComputeResponse.h>
#include <ros/ros.h>

#include <cmath>
#include <cstdio>
#include <string>

namespace cr = collision_response;

cr::BodyState sphere(const std::string& id, double mass, double x, double vx) {
  cr::BodyState body;
  body.id = id;
  body.inertia.m = mass;
  body.inertia.ixx = body.inertia.iyy = body.inertia.izz = 0.4 * mass * 0.1 * 0.1;  // R = 0.1 m
  body.pose.position.x = x;
  body.pose.orientation.w = 1.0;
  body.twist.linear.x = vx;
  return body;
}

// x for printing: rounded to 6 decimals, without a negative zero.
double shown(double x) {
  return std::round(x * 1e6) / 1e6 + 0.0;
}

// 1 kg at v1 against 2 kg at -1 m/s, e = 0.5, contact at the origin, normal +x.
cr::Scene headOn(double v1) {
  cr::Scene scene;
  scene.bodies = {sphere("left", 1.0, -0.1, v1), sphere("right", 2.0, 0.1, -1.0)};
  cr::Contact contact;
  contact.body_a = "left";
  contact.body_b = "right";
  contact.normal.x = 1.0;
  contact.restitution = 0.5;
  scene.contacts = {contact};
  return scene;
}

int main(int argc, char** argv) {
  ros::init(argc, argv, "collision_response_example_client", ros::init_options::AnonymousName);
  const std::string server = argc > 1 ? argv[1] : "/collision_response";
  if (!ros::service::waitForService(server + "/compute", ros::Duration(30.0))) return 1;

  cr::ComputeResponse single;
  single.request.header.frame_id = "world";
  const cr::Scene scene = headOn(2.0);
  single.request.bodies = scene.bodies;
  single.request.contacts = scene.contacts;
  if (!ros::service::call(server + "/compute", single) || !single.response.success) {
    std::printf("compute failed: %s\n", single.response.message.c_str());
    return 1;
  }
  const double left = single.response.bodies[0].twist.linear.x;
  const double right = single.response.bodies[1].twist.linear.x;
  std::printf("single: left %.6f m/s, right %.6f m/s, impulse %.6f N s\n", shown(left),
              shown(right), shown(single.response.impulses[0].normal_impulse));
  bool ok = std::abs(left + 1.0) < 1e-9 && std::abs(right - 0.5) < 1e-9;  // closed form

  cr::ComputeBatch batch;
  batch.request.header.frame_id = "world";  // scenes with an empty frame take it
  const double speeds[] = {1.0, 2.0, 3.0};
  for (const double v1 : speeds) batch.request.scenes.push_back(headOn(v1));
  if (!ros::service::call(server + "/compute_batch", batch) || !batch.response.success) {
    std::printf("compute_batch failed: %s\n", batch.response.message.c_str());
    return 1;
  }
  for (std::size_t i = 0; i < 3; ++i) {
    const cr::SceneResult& result = batch.response.results[i];
    if (!result.success) return 1;
    const double v1 = speeds[i];
    const double expected = ((v1 - 2.0) - (v1 + 1.0)) / 3.0;  // momentum and restitution
    std::printf("batch v1=%.1f: left %.6f m/s, right %.6f m/s\n", v1,
                shown(result.bodies[0].twist.linear.x), shown(result.bodies[1].twist.linear.x));
    ok = ok && std::abs(result.bodies[0].twist.linear.x - expected) < 1e-9;
  }
  std::printf("closed form: %s\n", ok ? "OK" : "MISMATCH");
  return ok ? 0 : 1;
}
