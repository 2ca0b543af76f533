// Integration test: contacts found by the node from shapes, materials from its parameters, bodies
// in different tf frames (detection_node.test).
#include <collision_response/CollisionResponse.h>
#include <collision_response/ComputeResponse.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <Eigen/Geometry>
#include <cmath>

#include "node_test_messages.h"

namespace cr = collision_response;
using namespace collision_response::testing;

namespace {

constexpr double kTolerance = 1e-9;

shape_msgs::SolidPrimitive primitive(uint8_t type, std::vector<double> dimensions) {
  shape_msgs::SolidPrimitive p;
  p.type = type;
  p.dimensions = std::move(dimensions);
  return p;
}

void addPrimitive(cr::BodyState& body, const shape_msgs::SolidPrimitive& shape,
                  const geometry_msgs::Pose& where = pose(0, 0, 0)) {
  body.primitives.push_back(shape);
  body.primitive_poses.push_back(where);
}

cr::BodyState floorBody(const std::string& frame = "") {
  cr::BodyState body;
  body.id = "floor";  // m = 0: immovable
  body.frame_id = frame;
  body.pose.orientation.w = 1.0;
  shape_msgs::Plane plane;
  plane.coef = {0.0, 0.0, 1.0, 0.0};  // z = 0, solid below
  body.planes.push_back(plane);
  body.plane_poses.push_back(pose(0, 0, 0));
  return body;
}

/// A solid sphere carrying a sphere primitive.
cr::BodyState ball(const std::string& id, double mass, double radius,
                   const geometry_msgs::Pose& p) {
  cr::BodyState body = sphere(id, mass, radius, p);
  addPrimitive(body, primitive(shape_msgs::SolidPrimitive::SPHERE, {radius}));
  return body;
}

/// A uniform 1 kg cube of side 1 m (I = 1/6 kg m^2), as a box primitive or as its convex hull.
cr::BodyState cube(const geometry_msgs::Pose& p, bool as_mesh) {
  cr::BodyState body;
  body.id = "cube";
  body.inertia.m = 1.0;
  body.inertia.ixx = body.inertia.iyy = body.inertia.izz = 1.0 / 6.0;
  body.pose = p;
  body.twist.linear.z = -1.0;
  if (!as_mesh) {
    addPrimitive(body, primitive(shape_msgs::SolidPrimitive::BOX, {1.0, 1.0, 1.0}));
    return body;
  }
  shape_msgs::Mesh mesh;
  for (int k = 0; k < 8; ++k) {
    geometry_msgs::Point v;
    v.x = k & 1 ? 0.5 : -0.5;
    v.y = k & 2 ? 0.5 : -0.5;
    v.z = k & 4 ? 0.5 : -0.5;
    mesh.vertices.push_back(v);
  }
  const uint32_t quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    shape_msgs::MeshTriangle t1, t2;
    t1.vertex_indices = {q[0], q[1], q[2]};
    t2.vertex_indices = {q[0], q[2], q[3]};
    mesh.triangles.push_back(t1);
    mesh.triangles.push_back(t2);
  }
  body.meshes.push_back(mesh);
  body.mesh_poses.push_back(pose(0, 0, 0));
  return body;
}

cr::ComputeResponse request(std::vector<cr::BodyState> bodies, double e, double mu = 0.0) {
  cr::ComputeResponse srv;
  srv.request.header.frame_id = "map";
  srv.request.bodies = std::move(bodies);
  srv.request.detection.restitution = e;
  srv.request.detection.static_friction = mu;
  srv.request.detection.dynamic_friction = mu;
  return srv;
}

void expectVector(const geometry_msgs::Vector3& got, const Eigen::Vector3d& want, double tol) {
  EXPECT_NEAR(got.x, want.x(), tol);
  EXPECT_NEAR(got.y, want.y(), tol);
  EXPECT_NEAR(got.z, want.z(), tol);
}

using DetectionNodeTest = ServiceTest;

TEST_F(DetectionNodeTest, SphereOnAPlaneBouncesAndRolls) {
  // R = 0.1 m, 1 kg, v = (1, 0, -2), e = 0.5, mu = 1: v' = (5/7, 0, 1), w' = (0, 5/7 / R, 0).
  cr::BodyState b = ball("ball", 1.0, 0.1, pose(0, 0, 0.1));
  b.twist.linear.x = 1.0;
  b.twist.linear.z = -2.0;
  const auto response = call(request({floorBody(), b}, 0.5, 1.0));
  ASSERT_TRUE(response.success) << response.message;
  ASSERT_EQ(response.detected_contacts.size(), 1u);
  ASSERT_EQ(response.impulses.size(), 1u);
  EXPECT_EQ(response.detected_contacts[0].body_a, "floor");
  EXPECT_NEAR(response.detected_contacts[0].normal.z, 1.0, kTolerance);
  EXPECT_NEAR(response.detected_depths[0], 0.0, 1e-9);
  expectVector(response.bodies[1].twist.linear, {5.0 / 7.0, 0, 1.0}, kTolerance);
  expectVector(response.bodies[1].twist.angular, {0, 5.0 / 7.0 / 0.1, 0}, kTolerance);
}

TEST_F(DetectionNodeTest, TwoSpheresHeadOn) {
  cr::BodyState left = ball("left", 1.0, 0.1, pose(-0.1, 0, 0));
  cr::BodyState right = ball("right", 2.0, 0.1, pose(0.1, 0, 0));
  left.twist.linear.x = 2.0;
  right.twist.linear.x = -1.0;
  const auto response = call(request({left, right}, 0.5));
  ASSERT_TRUE(response.success) << response.message;
  ASSERT_EQ(response.detected_contacts.size(), 1u);
  EXPECT_NEAR(response.bodies[0].twist.linear.x, -1.0, kTolerance);
  EXPECT_NEAR(response.bodies[1].twist.linear.x, 0.5, kTolerance);
  EXPECT_NEAR(response.impulses[0].normal_impulse, 3.0, kTolerance);
}

TEST_F(DetectionNodeTest, BoxLandingFlatAsBoxAndAsMesh) {
  for (const bool as_mesh : {false, true}) {
    SCOPED_TRACE(as_mesh ? "mesh" : "box");
    const auto response = call(request({floorBody(), cube(pose(0, 0, 0.5), as_mesh)}, 0.5));
    ASSERT_TRUE(response.success) << response.message;
    EXPECT_EQ(response.detected_contacts.size(), 4u);
    EXPECT_EQ(response.impulses.size(), 4u);
    expectVector(response.bodies[1].twist.linear, {0, 0, 0.5}, kTolerance);
    expectVector(response.bodies[1].twist.angular, {0, 0, 0}, kTolerance);
  }
}

TEST_F(DetectionNodeTest, BoxLandingOnAnEdgeAsBoxAndAsMesh) {
  // Turned 30 degrees about x, landing on its lowest edge, off-centre by dy: frictionless,
  // j = (1 + e) / (1/m + dy^2 / I), v'_z = -1 + j / m, w'_x = j dy / I.
  const double theta = M_PI / 6.0, e = 0.5, I = 1.0 / 6.0;
  const double dy = -0.5 * std::cos(theta) + 0.5 * std::sin(theta);
  const double j = (1.0 + e) / (1.0 + dy * dy / I);
  const Eigen::Quaterniond q(Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitX()));
  for (const bool as_mesh : {false, true}) {
    SCOPED_TRACE(as_mesh ? "mesh" : "box");
    const double height = 0.5 * (std::sin(theta) + std::cos(theta));
    const auto response = call(request({floorBody(), cube(pose(0, 0, height, q), as_mesh)}, e));
    ASSERT_TRUE(response.success) << response.message;
    EXPECT_EQ(response.detected_contacts.size(), 2u);
    expectVector(response.bodies[1].twist.linear, {0, 0, -1.0 + j}, kTolerance);
    expectVector(response.bodies[1].twist.angular, {j * dy / I, 0, 0}, kTolerance);
  }
}

TEST_F(DetectionNodeTest, CylinderOnItsSide) {
  const double h = 1.0, r = 0.1, m = 2.0;
  cr::BodyState body;
  body.id = "cylinder";
  body.inertia.m = m;
  body.inertia.ixx = 0.5 * m * r * r;  // axis along the body's x
  body.inertia.iyy = body.inertia.izz = m * (3 * r * r + h * h) / 12.0;
  body.pose = pose(0.2, -0.3, r);
  body.twist.linear.z = -1.0;
  const Eigen::Quaterniond along_x(Eigen::AngleAxisd(M_PI / 2.0, Eigen::Vector3d::UnitY()));
  addPrimitive(body, primitive(shape_msgs::SolidPrimitive::CYLINDER, {h, r}),
               pose(0, 0, 0, along_x));
  const auto response = call(request({floorBody(), body}, 0.5));
  ASSERT_TRUE(response.success) << response.message;
  EXPECT_EQ(response.detected_contacts.size(), 2u);
  expectVector(response.bodies[1].twist.linear, {0, 0, 0.5}, kTolerance);
  expectVector(response.bodies[1].twist.angular, {0, 0, 0}, kTolerance);
}

TEST_F(DetectionNodeTest, MaterialsFromTheParameterTable) {
  // Head-on spheres: v1' = -2 e, v2' = e.
  const auto restitution = [&](const std::string& a, const std::string& b) {
    cr::BodyState left = ball("left", 1.0, 0.1, pose(-0.1, 0, 0));
    cr::BodyState right = ball("right", 2.0, 0.1, pose(0.1, 0, 0));
    left.twist.linear.x = 2.0;
    right.twist.linear.x = -1.0;
    left.material = a;
    right.material = b;
    const auto response = call(request({left, right}, 0.25));
    EXPECT_TRUE(response.success) << response.message;
    if (response.detected_contacts.size() != 1u) return -1.0;
    const double e = response.detected_contacts[0].restitution;
    EXPECT_NEAR(response.bodies[1].twist.linear.x, e, kTolerance);
    return e;
  };
  EXPECT_DOUBLE_EQ(restitution("glass", "steel"), 0.8);
  EXPECT_DOUBLE_EQ(restitution("steel", "rubber"), 0.6);   // sqrt(0.9 * 0.4)
  EXPECT_DOUBLE_EQ(restitution("glass", "rubber"), 0.25);  // no pair, no mix: the request's
  EXPECT_DOUBLE_EQ(restitution("", "steel"), 0.25);        // no material: the request's
  // A name in no entry of the table is a typo: rejected, naming the body.
  cr::BodyState left = ball("left", 1.0, 0.1, pose(-0.1, 0, 0));
  cr::BodyState right = ball("right", 2.0, 0.1, pose(0.1, 0, 0));
  left.twist.linear.x = 1.0;
  right.material = "wood";
  expectRejected(request({left, right}, 0.25), "bodies[1].material");
}

TEST_F(DetectionNodeTest, BodiesInDifferentFramesAreSolvedInTheRequestFrame) {
  // map -> odom: (1, 2, 0), yaw 90 deg (/tf_static); odom -> base_link: (0.5, 0, 0), yaw -30 deg
  // (/tf). The floor is given in odom, the ball in base_link at (0.3, 0.1, 0.1) with v = (1, 0,
  // -2) there. In map, base_link is yawed 60 deg: v = (cos 60, sin 60, -2). e = 0.5, mu = 1:
  // it bounces (v'_z = 1) and rolls (v'_t = 5/7 v_t, w' = z x v'_t / R).
  {  // The frames publisher starts with the node: wait for its transforms, as a client would.
    tf2_ros::Buffer buffer;
    const tf2_ros::TransformListener listener(buffer);
    std::string error;
    ASSERT_TRUE(buffer.canTransform("map", "base_link", ros::Time(0), ros::Duration(20.0), &error))
        << error;
  }
  cr::BodyState b = ball("ball", 1.0, 0.1, pose(0.3, 0.1, 0.1));
  b.frame_id = "base_link";
  b.twist.linear.x = 1.0;
  b.twist.linear.z = -2.0;
  cr::ComputeResponse srv = request({floorBody("odom"), b}, 0.5, 1.0);
  const auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  ASSERT_EQ(response.detected_contacts.size(), 1u);
  const double c = std::cos(M_PI / 3.0), s = std::sin(M_PI / 3.0);
  const Eigen::Vector3d v_t = 5.0 / 7.0 * Eigen::Vector3d(c, s, 0.0);
  expectVector(response.bodies[1].twist.linear, v_t + Eigen::Vector3d(0, 0, 1.0), kTolerance);
  expectVector(response.bodies[1].twist.angular, Eigen::Vector3d::UnitZ().cross(v_t) / 0.1,
               kTolerance);
  EXPECT_EQ(response.bodies[1].frame_id, "map");
  // Ball centre in map: map_T_odom * odom_T_base * (0.3, 0.1, 0.1); the contact lies below it.
  const Eigen::Isometry3d map_T_odom =
      Eigen::Translation3d(1, 2, 0) * Eigen::AngleAxisd(M_PI / 2.0, Eigen::Vector3d::UnitZ());
  const Eigen::Isometry3d odom_T_base =
      Eigen::Translation3d(0.5, 0, 0) * Eigen::AngleAxisd(-M_PI / 6.0, Eigen::Vector3d::UnitZ());
  const Eigen::Vector3d centre = map_T_odom * odom_T_base * Eigen::Vector3d(0.3, 0.1, 0.1);
  EXPECT_NEAR(response.detected_contacts[0].point.x, centre.x(), 1e-9);
  EXPECT_NEAR(response.detected_contacts[0].point.y, centre.y(), 1e-9);
  EXPECT_NEAR(response.detected_contacts[0].point.z, 0.0, 1e-9);

  srv.request.bodies[1].frame_id = "no_such_frame";
  expectRejected(srv, "bodies[1].frame_id");
}

TEST_F(DetectionNodeTest, GivenContactsAreSolvedWithoutDetection) {
  // MODE_AUTO: contacts given, so nothing is detected (the shapes would have given one).
  cr::BodyState left = ball("left", 1.0, 0.1, pose(-0.1, 0, 0));
  cr::BodyState right = ball("right", 2.0, 0.1, pose(0.1, 0, 0));
  left.twist.linear.x = 2.0;
  right.twist.linear.x = -1.0;
  cr::ComputeResponse srv = request({left, right}, 0.5);
  srv.request.contacts = {contact("left", "right", 0, 0, 0, 1, 0, 0, 1.0)};
  auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  EXPECT_TRUE(response.detected_contacts.empty());
  EXPECT_NEAR(response.bodies[0].twist.linear.x, -2.0, kTolerance);  // e = 1 of the given contact
  // MODE_ALWAYS: both, solved together (the same point twice, e = 1 and 0.5).
  srv.request.detection.mode = cr::DetectionOptions::MODE_ALWAYS;
  response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  EXPECT_EQ(response.detected_contacts.size(), 1u);
  EXPECT_EQ(response.impulses.size(), 2u);
  // MODE_NEVER with shapes only: nothing to solve, nothing changes.
  srv.request.contacts.clear();
  srv.request.detection.mode = cr::DetectionOptions::MODE_NEVER;
  response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  EXPECT_TRUE(response.impulses.empty());
  EXPECT_NEAR(response.bodies[0].twist.linear.x, 2.0, kTolerance);
}

TEST_F(DetectionNodeTest, PublishesTheDetectedContacts) {
  const ResponsesListener listener(node_);
  listener.waitForPublisher(10.0);
  const auto response = call(request({floorBody(), cube(pose(0, 0, 0.5), false)}, 0.5));
  ASSERT_TRUE(response.success);
  const cr::CollisionResponse::ConstPtr received = listener.waitForMessage(5.0);
  ASSERT_TRUE(received);
  EXPECT_EQ(received->contacts.size(), 4u);
  EXPECT_EQ(received->impulses.size(), 4u);
}

TEST_F(DetectionNodeTest, BadGeometryIsRejectedNamingTheField) {
  cr::BodyState b = ball("ball", 1.0, 0.1, pose(0, 0, 0.1));
  b.primitive_poses.clear();
  expectRejected(request({floorBody(), b}, 0.5), "bodies[1].primitive_poses");

  b = ball("ball", 1.0, 0.1, pose(0, 0, 0.1));
  b.primitives[0].type = 42;
  expectRejected(request({floorBody(), b}, 0.5), "bodies[1].primitives[0].type");

  b = ball("ball", 1.0, 0.1, pose(0, 0, 0.1));
  b.primitives[0].dimensions = {-0.1};
  expectRejected(request({floorBody(), b}, 0.5), "bodies[1].primitives[0].dimensions");

  b = ball("ball", 1.0, 0.1, pose(0, 0, 0.1));
  b.primitive_poses[0].orientation.w = 0.0;
  expectRejected(request({floorBody(), b}, 0.5), "bodies[1].primitive_poses[0].orientation");

  cr::BodyState plane_body = floorBody();
  plane_body.planes[0].coef = {0.0, 0.0, 0.0, 1.0};
  expectRejected(request({plane_body, ball("ball", 1.0, 0.1, pose(0, 0, 0.1))}, 0.5),
                 "bodies[0].planes[0]");

  cr::BodyState mesh_body = cube(pose(0, 0, 0.5), true);
  mesh_body.meshes[0].triangles[3].vertex_indices[1] = 99;
  expectRejected(request({floorBody(), mesh_body}, 0.5), "bodies[1].meshes[0].triangles[3]");

  mesh_body = cube(pose(0, 0, 0.5), true);
  mesh_body.meshes[0].vertices.resize(150);  // ~max_mesh_vertices is 100 in this test
  expectRejected(request({floorBody(), mesh_body}, 0.5), "bodies: 150 mesh vertices");

  cr::ComputeResponse srv = request({floorBody(), ball("ball", 1.0, 0.1, pose(0, 0, 0.1))}, 1.5);
  expectRejected(srv, "detection.restitution");
  srv = request({floorBody(), ball("ball", 1.0, 0.1, pose(0, 0, 0.1))}, 0.5);
  srv.request.detection.contact_tolerance = -1.0;
  expectRejected(srv, "detection.contact_tolerance");
  srv.request.detection.contact_tolerance = 0.0;
  srv.request.detection.mode = 7;
  expectRejected(srv, "detection.mode");

  // Detected contacts beyond ~max_contacts (6 in this test): two boxes flat on the floor give 8.
  cr::BodyState second = cube(pose(2, 0, 0.5), false);
  second.id = "cube2";
  expectRejected(request({floorBody(), cube(pose(0, 0, 0.5), false), second}, 0.5),
                 "bodies: the shapes touch at more than 6 contact points");

  // An error on a detected contact names it as such: a 1e12 kg ball with a radius of gyration of
  // 1e-7 m touched 0.2 m from its centre is past the lever-arm limit (1e6 radii).
  cr::BodyState heavy = ball("heavy", 1e12, 0.2, pose(0, 0, 0.2));
  heavy.inertia.ixx = heavy.inertia.iyy = heavy.inertia.izz = 1e-2;
  heavy.twist.linear.z = -1.0;
  expectRejected(request({floorBody(), heavy}, 0.5), "detected_contacts[0].point");

  // Still serving.
  EXPECT_TRUE(call(request({floorBody(), cube(pose(0, 0, 0.5), false)}, 0.5)).success);
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_detection_node");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  return RUN_ALL_TESTS();
}
