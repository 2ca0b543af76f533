// Links' collision geometry from URDF (robot_geometry.h), no ROS master: each primitive's placement
// in the link frame against hand-computed points, the shipped arm's finger pads placed by its
// kinematics landing flat on a table (hand-computed corners), and its convex palm mesh against a
// box compared with FCL called directly on the mesh read here from the STL file.

#include <fcl/fcl.h>
#include <gtest/gtest.h>
#include <urdf/model.h>

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "collision_response/detection/detect_contacts.h"
#include "collision_response/robot/urdf_loader.h"
#include "collision_response/ros/robot_geometry.h"

namespace cr = collision_response::core;
namespace detection = collision_response::detection;
namespace rb = collision_response::robot;
using collision_response::linkCollisionGeometry;
using collision_response::linkCollisionGeometryFromUrdf;
using Eigen::Isometry3d;
using Eigen::Vector3d;

namespace {

const std::string kPackageDir = PACKAGE_DIR;
const std::string kArm7 = kPackageDir + "/urdf/arm7.urdf";

/// package://collision_response/... resolves through ROS_PACKAGE_PATH, which the devel space's
/// setup points at the source; put this package's source first (there may be other checkouts).
void findThisPackageFirst() {
  const char* old = std::getenv("ROS_PACKAGE_PATH");
  const std::string path = kPackageDir + (old && *old ? ":" + std::string(old) : "");
  setenv("ROS_PACKAGE_PATH", path.c_str(), 1);
}

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

Isometry3d translation(const Vector3d& t) {
  Isometry3d p = Isometry3d::Identity();
  p.translation() = t;
  return p;
}

Isometry3d rotation(double angle, const Vector3d& axis) {
  Isometry3d p = Isometry3d::Identity();
  p.linear() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  return p;
}

cr::BodyState bodyAt(const std::string& id, double mass, const Isometry3d& pose) {
  cr::BodyState b;
  b.id = id;
  b.mass = mass;
  if (mass > 0.0) b.inertia = Eigen::Matrix3d::Identity() * 0.01 * mass;
  b.position = pose.translation();
  b.orientation = Eigen::Quaterniond(pose.linear());
  return b;
}

void expectNear(const Vector3d& actual, const Vector3d& expected, double tol) {
  EXPECT_LE((actual - expected).norm(), tol)
      << "actual " << actual.transpose() << ", expected " << expected.transpose();
}

/// The world frame of `link` by composing the URDF's joints from the root: each joint's <origin>
/// then its motion (a rotation by q about the axis, or a translation by q along it). Independent
/// of KDL (ArticulatedBody) and of robot_geometry.cpp.
Isometry3d urdfLinkFrame(const urdf::Model& model, const std::string& link,
                         const std::map<std::string, double>& q) {
  const urdf::JointConstSharedPtr joint = model.getLink(link)->parent_joint;
  if (!joint) return Isometry3d::Identity();
  const urdf::Pose& o = joint->parent_to_joint_origin_transform;
  Isometry3d origin = translation(Vector3d(o.position.x, o.position.y, o.position.z));
  origin.rotate(Eigen::Quaterniond(o.rotation.w, o.rotation.x, o.rotation.y, o.rotation.z));
  const Vector3d axis(joint->axis.x, joint->axis.y, joint->axis.z);
  Isometry3d motion = Isometry3d::Identity();
  if (joint->type == urdf::Joint::REVOLUTE || joint->type == urdf::Joint::CONTINUOUS) {
    motion = rotation(q.at(joint->name), axis);
  } else if (joint->type == urdf::Joint::PRISMATIC) {
    motion = translation(q.at(joint->name) * axis);
  }
  return urdfLinkFrame(model, joint->parent_link_name, q) * origin * motion;
}

/// Vertices and triangles of an ASCII STL file, vertices repeated per facet merged (exact
/// matches), coordinates multiplied by scale.
struct StlMesh {
  std::vector<Vector3d> vertices;
  std::vector<std::array<int, 3>> triangles;
};

StlMesh readAsciiStl(const std::string& path, double scale) {
  std::istringstream in(readFile(path));
  StlMesh mesh;
  std::string word;
  std::array<int, 3> triangle{};
  int corner = 0;
  while (in >> word) {
    if (word != "vertex") continue;
    Vector3d v;
    in >> v.x() >> v.y() >> v.z();
    v *= scale;
    int index = 0;
    while (index < static_cast<int>(mesh.vertices.size()) && mesh.vertices[index] != v) ++index;
    if (index == static_cast<int>(mesh.vertices.size())) mesh.vertices.push_back(v);
    triangle[corner++] = index;
    if (corner == 3) {
      mesh.triangles.push_back(triangle);
      corner = 0;
    }
  }
  return mesh;
}

}  // namespace

// Each primitive's shape frame in the link frame, checked at points computed by hand. URDF's rpy
// is roll about x, then pitch about y, then yaw about z, all about the fixed (link) axes.
TEST(RobotGeometry, PrimitivesLandInTheLinkFrame) {
  const std::string xml = R"(<robot name="probe">
    <link name="base"/>
    <joint name="j" type="fixed"><parent link="base"/><child link="probe"/></joint>
    <link name="probe">
      <collision>
        <origin xyz="1 2 3" rpy="1.5707963267948966 0 1.5707963267948966"/>
        <geometry><box size="0.1 0.2 0.3"/></geometry>
      </collision>
      <collision>
        <origin xyz="0.1 0 0" rpy="0 1.5707963267948966 0"/>
        <geometry><cylinder radius="0.05" length="0.4"/></geometry>
      </collision>
      <collision>
        <origin xyz="0 0 0.5"/>
        <geometry><sphere radius="0.07"/></geometry>
      </collision>
    </link>
  </robot>)";
  const auto geometry = linkCollisionGeometryFromUrdf(xml);
  ASSERT_EQ(geometry.size(), 2u);
  EXPECT_TRUE(geometry.at("base").shapes.empty());  // a link without <collision>
  const std::vector<detection::Shape>& shapes = geometry.at("probe").shapes;
  ASSERT_EQ(shapes.size(), 3u);

  // Box: roll 90 deg takes (x, y, z) to (x, -z, y), yaw 90 deg then (x, y, z) to (-y, x, z): in
  // all (x, y, z) -> (z, x, y). The corner (0.05, 0.1, 0.15) lands at (0.15, 0.05, 0.1) + origin.
  EXPECT_EQ(shapes[0].type, detection::Shape::Type::kBox);
  EXPECT_EQ(shapes[0].dimensions, (std::vector<double>{0.1, 0.2, 0.3}));
  expectNear(shapes[0].pose * Vector3d(0.05, 0.1, 0.15), Vector3d(1.15, 2.05, 3.1), 1e-12);

  // Cylinder [length, radius], axis along the shape's z; pitch 90 deg takes z to +x and x to -z:
  // the top cap's centre (0, 0, 0.2) lands at (0.3, 0, 0), its rim point (0.05, 0, 0.2) at
  // (0.3, 0, -0.05).
  EXPECT_EQ(shapes[1].type, detection::Shape::Type::kCylinder);
  EXPECT_EQ(shapes[1].dimensions, (std::vector<double>{0.4, 0.05}));
  expectNear(shapes[1].pose * Vector3d(0, 0, 0.2), Vector3d(0.3, 0, 0), 1e-12);
  expectNear(shapes[1].pose * Vector3d(0.05, 0, 0.2), Vector3d(0.3, 0, -0.05), 1e-12);

  EXPECT_EQ(shapes[2].type, detection::Shape::Type::kSphere);
  EXPECT_EQ(shapes[2].dimensions, (std::vector<double>{0.07}));
  expectNear(shapes[2].pose * Vector3d(0.07, 0, 0), Vector3d(0.07, 0, 0.5), 1e-12);
  EXPECT_NO_THROW(detection::validateGeometry({geometry.at("probe")}, 1));
}

// The palm's STL (millimetres) through file:// with a scale per axis: its 12 corners (repeated
// per facet in the file) are one vertex each, its 20 triangles kept, each axis scaled by its own
// factor.
TEST(RobotGeometry, MeshIsScaledPerAxisAndMerged) {
  const std::string xml = R"(<robot name="palm"><link name="palm"><collision>
      <origin xyz="0 0 1"/>
      <geometry><mesh filename="file://)" +
                          kPackageDir + R"(/meshes/hand.stl" scale="0.001 0.002 0.0005"/></geometry>
    </collision></link></robot>)";
  const auto geometry = linkCollisionGeometryFromUrdf(xml);
  const detection::Shape& mesh = geometry.at("palm").shapes.at(0);
  EXPECT_EQ(mesh.type, detection::Shape::Type::kMesh);
  EXPECT_EQ(mesh.vertices.size(), 12u);
  EXPECT_EQ(mesh.triangles.size(), 20u);
  // hand.stl spans x -40..40, y -70..70, z -30..30 mm.
  Vector3d low = Vector3d::Constant(1e9), high = -low;
  for (const Vector3d& v : mesh.vertices) {
    low = low.cwiseMin(v);
    high = high.cwiseMax(v);
  }
  expectNear(low, Vector3d(-0.04, -0.14, -0.015), 1e-12);
  expectNear(high, Vector3d(0.04, 0.14, 0.015), 1e-12);
  expectNear(mesh.pose.translation(), Vector3d(0, 0, 1), 0.0);
}

TEST(RobotGeometry, ErrorsNameTheLinkAndTheCollision) {
  const auto messageOf = [](const std::string& collisions) {
    try {
      linkCollisionGeometryFromUrdf("<robot name=\"r\"><link name=\"palm\">" + collisions +
                                    "</link></robot>");
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  const std::string box = "<collision><geometry><box size=\"1 1 1\"/></geometry></collision>";
  const std::string missing =
      "<collision><geometry><mesh filename=\"file:///nonexistent/palm.stl\"/></geometry>"
      "</collision>";
  EXPECT_EQ(
      messageOf(box + missing)
          .rfind("link 'palm' collision[1]: cannot load mesh 'file:///nonexistent/palm.stl': ", 0),
      0u)
      << messageOf(box + missing);
  findThisPackageFirst();
  const std::string unknown_file =
      "<collision><geometry><mesh filename=\"package://collision_response/meshes/nothing.stl\"/>"
      "</geometry></collision>";
  EXPECT_EQ(messageOf(unknown_file)
                .rfind("link 'palm' collision[0]: cannot load mesh "
                       "'package://collision_response/meshes/nothing.stl': ",
                       0),
            0u)
      << messageOf(unknown_file);
  const std::string not_a_mesh =
      "<collision><geometry><mesh filename=\"package://collision_response/package.xml\"/>"
      "</geometry></collision>";
  EXPECT_EQ(messageOf(not_a_mesh).rfind("link 'palm' collision[0]: cannot load mesh", 0), 0u)
      << messageOf(not_a_mesh);
  const std::string flat =
      "<collision><geometry><mesh filename=\"package://collision_response/meshes/hand.stl\" "
      "scale=\"1 0 1\"/></geometry></collision>";
  EXPECT_EQ(messageOf(flat).rfind("link 'palm' collision[0]: mesh "
                                  "'package://collision_response/meshes/hand.stl': scale",
                                  0),
            0u)
      << messageOf(flat);
  EXPECT_THROW(linkCollisionGeometryFromUrdf("<robot>"), std::invalid_argument);
  // A text ending in a cut UTF-8 sequence (TinyXML would read past its end): refused by its byte.
  const std::string cut = "<robot name=\"r\"><link name=\"a\"/></robot>\xf0";
  std::string message = "(accepted)";
  try {
    linkCollisionGeometryFromUrdf(cut);
  } catch (const std::invalid_argument& e) {
    message = e.what();
  }
  EXPECT_EQ(message.rfind("URDF: byte " + std::to_string(cut.size() - 1) + " (line 1)", 0), 0u)
      << message;
}

// Every link of the shipped arm has collision geometry, valid for detection, and the hand's is
// the convex mesh the package ships (package:// resolved through ROS_PACKAGE_PATH); all but
// base_link_inertia, which only carries the base's inertia (the root link has none, for KDL).
TEST(RobotGeometry, ShippedArmHasGeometryOnEveryLink) {
  findThisPackageFirst();
  urdf::Model model;
  ASSERT_TRUE(model.initFile(kArm7));
  const auto geometry = linkCollisionGeometry(model);
  ASSERT_EQ(geometry.size(), 12u);
  std::vector<detection::BodyGeometry> bodies;
  for (const auto& [name, body] : geometry) {
    if (name == "base_link_inertia") {
      EXPECT_TRUE(body.shapes.empty());
      continue;
    }
    EXPECT_EQ(body.shapes.size(), 1u) << name;
    bodies.push_back(body);
  }
  EXPECT_EQ(bodies.size(), 11u);
  EXPECT_NO_THROW(detection::validateGeometry(bodies, bodies.size()));
  for (const char* link : {"base_link", "link1", "link4", "link7"}) {
    EXPECT_EQ(geometry.at(link).shapes.at(0).type, detection::Shape::Type::kCylinder) << link;
  }
  for (const char* link : {"left_finger", "right_finger"}) {
    EXPECT_EQ(geometry.at(link).shapes.at(0).type, detection::Shape::Type::kBox) << link;
  }
  const detection::Shape& palm = geometry.at("hand").shapes.at(0);
  EXPECT_EQ(palm.type, detection::Shape::Type::kMesh);
  EXPECT_EQ(palm.vertices.size(), 12u);
}

// (a) The arm, in a bent configuration, placed so that its left finger points straight down with
// its pad's tip face in the plane z = 0, 0.1 mm below the top of a table. Each link is one body at
// linkPose(link), all links in one collision group. Expected, by hand: the left finger frame is
// the desired one (x along world x, y and z reversed: a half turn about x, origin at
// (0.4, -0.1, 0.05)); its box (0.02 x 0.01 x 0.05 at (0, 0.005, 0.025)) has its tip face at
// finger z = 0.05, corners x = +-0.01, y = 0 .. 0.01: world x 0.39 / 0.41, y -0.1 / -0.11. The
// right finger is the left one moved along the hand's y (world -y) by -(0.02 + qL + qR) =
// -0.055: its frame at world y = -0.045, its box at finger y = -0.01 .. 0, world y -0.045 /
// -0.035. Each point midway between the surfaces (z = 0.05 mm), depth 0.1 mm, normal +z (table
// towards finger).
TEST(RobotGeometry, FingerPadsLandFlatOnATable) {
  findThisPackageFirst();
  urdf::Model model;
  ASSERT_TRUE(model.initFile(kArm7));
  const auto geometry = linkCollisionGeometry(model);
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(kArm7);

  const std::map<std::string, double> q_by_name = {{"joint1", 0.3},
                                                   {"joint2", 0.2},
                                                   {"joint3", -0.4},
                                                   {"joint4", 0.3},
                                                   {"joint5", 0.5},
                                                   {"joint6", -0.3},
                                                   {"joint7", 0.7},
                                                   {"left_finger_joint", 0.015},
                                                   {"right_finger_joint", 0.02}};
  Eigen::VectorXd q(arm.jointCount());
  for (int j = 0; j < arm.jointCount(); ++j) q[j] = q_by_name.at(arm.jointNames()[j]);
  const Isometry3d finger_wanted =
      translation(Vector3d(0.4, -0.1, 0.05)) * rotation(M_PI, Vector3d::UnitX());
  const Isometry3d base_pose =
      finger_wanted * urdfLinkFrame(model, "left_finger", q_by_name).inverse();
  arm.setState(q, Eigen::VectorXd::Zero(arm.jointCount()), base_pose);
  // KDL's segment tip frame is the URDF link frame.
  for (int link = 0; link < arm.linkCount(); ++link) {
    const Isometry3d urdf_frame = base_pose * urdfLinkFrame(model, arm.linkName(link), q_by_name);
    EXPECT_LE((arm.linkPose(link).matrix() - urdf_frame.matrix()).norm(), 1e-12)
        << arm.linkName(link);
  }

  std::vector<cr::BodyState> bodies = {
      bodyAt("table", 0.0, translation(Vector3d(0.4, -0.1, -0.05 + 1e-4)))};
  detection::DetectionInput input;
  input.geometry = {detection::BodyGeometry{{detection::Shape()}}};
  input.geometry[0].shapes[0].dimensions = {1.0, 1.0, 0.1};  // a box (the default type)
  input.collision_groups = {-1};
  for (int link = 0; link < arm.linkCount(); ++link) {
    bodies.push_back(bodyAt(arm.linkName(link), 1.0, arm.linkPose(link)));
    input.geometry.push_back(geometry.at(arm.linkName(link)));
    input.collision_groups.push_back(0);
  }
  input.defaults = {0.5, 0.0, 0.0};
  detection::ContactDetector detector;
  const detection::DetectedContacts found = detection::detectContacts(detector, bodies, input, {});

  const std::map<std::string, std::vector<Vector3d>> corners = {
      {"left_finger",
       {{0.39, -0.1, 5e-5}, {0.41, -0.1, 5e-5}, {0.39, -0.11, 5e-5}, {0.41, -0.11, 5e-5}}},
      {"right_finger",
       {{0.39, -0.045, 5e-5}, {0.41, -0.045, 5e-5}, {0.39, -0.035, 5e-5}, {0.41, -0.035, 5e-5}}}};
  ASSERT_EQ(found.contacts.size(), 8u);
  std::map<std::string, int> matched;
  for (std::size_t k = 0; k < found.contacts.size(); ++k) {
    const cr::Contact& c = found.contacts[k];
    EXPECT_EQ(c.body_a, "table");
    ASSERT_EQ(corners.count(c.body_b), 1u) << c.body_b;
    expectNear(c.normal, Vector3d::UnitZ(), 1e-9);
    EXPECT_NEAR(found.depths[k], 1e-4, 1e-9);
    for (const Vector3d& corner : corners.at(c.body_b)) {
      if ((c.point - corner).norm() <= 1e-9) ++matched[c.body_b];
    }
  }
  EXPECT_EQ(matched["left_finger"], 4);
  EXPECT_EQ(matched["right_finger"], 4);

  // Without the group the links meet each other where they are joined (the fingers stand on the
  // palm, each link's cylinder on its parent's).
  input.collision_groups.clear();
  const detection::DetectedContacts ungrouped =
      detection::detectContacts(detector, bodies, input, {});
  bool finger_on_palm = false;
  for (const cr::Contact& c : ungrouped.contacts) {
    finger_on_palm = finger_on_palm || (c.body_a == "hand" && c.body_b == "left_finger") ||
                     (c.body_a == "left_finger" && c.body_b == "hand");
  }
  EXPECT_TRUE(finger_on_palm);
  EXPECT_GT(ungrouped.contacts.size(), 8u);
}

// (b) The palm (a convex mesh, from package://) against a box lying on its 45-degree chamfer,
// 0.4 mm apart and then 0.4 mm into it, against FCL called directly on the same solids: the mesh
// read here from the STL file as an fcl::Convex, the box as an fcl::Box.
TEST(RobotGeometry, PalmMeshAgainstABoxMatchesFcl) {
  findThisPackageFirst();
  urdf::Model model;
  ASSERT_TRUE(model.initFile(kArm7));
  const detection::BodyGeometry palm = linkCollisionGeometry(model).at("hand");

  // The chamfer, in the mesh's frame [m]: the face from (0.025, y, -0.03) to (0.04, y, -0.015),
  // y = -0.07 .. 0.07; outward normal n = (1, 0, -1) / sqrt(2), centre (0.0325, 0, -0.0225), its
  // in-plane axes y and e = (1, 0, 1) / sqrt(2) (half-length 0.0075 sqrt(2)).
  const Vector3d n = Vector3d(1, 0, -1).normalized(), e = Vector3d(1, 0, 1).normalized();
  const Vector3d face_centre(0.0325, 0, -0.0225);
  const Isometry3d hand_pose =
      translation(Vector3d(0.2, -0.1, 0.5)) * rotation(0.4, Vector3d(1, 2, 3));
  const Isometry3d mesh_in_hand = translation(Vector3d(0, 0, 0.03));  // the <collision> origin
  const Isometry3d mesh_world = hand_pose * mesh_in_hand;
  const Vector3d box_size(0.02, 0.05, 0.01);  // along n, y, e

  const StlMesh stl = readAsciiStl(kPackageDir + "/meshes/hand.stl", 0.001);
  auto fcl_vertices = std::make_shared<const std::vector<Vector3d>>(stl.vertices);
  auto fcl_faces = std::make_shared<std::vector<int>>();
  for (const auto& t : stl.triangles) fcl_faces->insert(fcl_faces->end(), {3, t[0], t[1], t[2]});
  auto fcl_palm = std::make_shared<fcl::Convexd>(fcl_vertices,
                                                 static_cast<int>(stl.triangles.size()), fcl_faces);
  auto fcl_box = std::make_shared<fcl::Boxd>(box_size.x(), box_size.y(), box_size.z());

  for (const double gap : {4e-4, -4e-4}) {
    SCOPED_TRACE("gap " + std::to_string(gap));
    Isometry3d box_in_mesh = Isometry3d::Identity();
    box_in_mesh.linear().col(0) = n;
    box_in_mesh.linear().col(1) = Vector3d::UnitY();
    box_in_mesh.linear().col(2) = e;  // n x y = e: right-handed
    box_in_mesh.translation() = face_centre + (0.5 * box_size.x() + gap) * n;
    const Isometry3d box_world = mesh_world * box_in_mesh;

    detection::DetectionInput input;
    input.geometry = {palm, detection::BodyGeometry{{detection::Shape()}}};
    input.geometry[1].shapes[0].dimensions = {box_size.x(), box_size.y(), box_size.z()};
    input.defaults = {0.5, 0.0, 0.0};
    detection::ContactDetector detector;
    const detection::DetectedContacts found = detection::detectContacts(
        detector, {bodyAt("hand", 0.6, hand_pose), bodyAt("box", 1.0, box_world)}, input, {});

    // FCL directly: the signed distance and the normal from the palm towards the box.
    fcl::CollisionObjectd palm_object(fcl_palm, mesh_world);
    fcl::CollisionObjectd box_object(fcl_box, box_world);
    Vector3d fcl_normal;
    double fcl_depth = 0.0;
    std::vector<Vector3d> fcl_points;
    if (gap > 0.0) {
      fcl::DistanceRequestd request(true);
      fcl::DistanceResultd result;
      fcl::distance(&palm_object, &box_object, request, result);
      fcl_depth = -result.min_distance;
      fcl_normal = (result.nearest_points[1] - result.nearest_points[0]).normalized();
      fcl_points = {result.nearest_points[0], result.nearest_points[1]};
    } else {
      fcl::CollisionRequestd request(1, true);
      fcl::CollisionResultd result;
      fcl::collide(&palm_object, &box_object, request, result);
      ASSERT_EQ(result.numContacts(), 1u);
      fcl_depth = result.getContact(0).penetration_depth;
      fcl_normal = result.getContact(0).normal;
      fcl_points = {result.getContact(0).pos};
    }
    const Vector3d n_world = mesh_world.linear() * n;
    expectNear(fcl_normal, n_world, 1e-9);  // FCL agrees with the hand-computed face
    EXPECT_NEAR(fcl_depth, -gap, 1e-9);

    // The box's face on the chamfer is inside it: its 4 corners.
    ASSERT_EQ(found.contacts.size(), 4u);
    const Vector3d centre_world = mesh_world * face_centre;
    for (std::size_t k = 0; k < 4; ++k) {
      const cr::Contact& c = found.contacts[k];
      EXPECT_EQ(c.body_a, "hand");
      expectNear(c.normal, fcl_normal, 1e-9);
      EXPECT_NEAR(found.depths[k], fcl_depth, 1e-9);
      // On the chamfer face: midway between the surfaces along n, within its extent.
      const Vector3d r = mesh_world.linear().transpose() * (c.point - centre_world);
      EXPECT_NEAR(r.dot(n), 0.5 * gap, 1e-9);
      EXPECT_NEAR(std::abs(r.y()), 0.5 * box_size.y(), 1e-9);
      EXPECT_NEAR(std::abs(r.dot(e)), 0.5 * box_size.z(), 1e-9);
    }
    for (const Vector3d& p : fcl_points) {  // FCL's points are on the same face
      const Vector3d r = mesh_world.linear().transpose() * (p - centre_world);
      EXPECT_LE(std::abs(r.dot(n)), std::abs(gap) + 1e-9);
      EXPECT_LE(std::abs(r.y()), 0.5 * box_size.y() + 1e-9);
      EXPECT_LE(std::abs(r.dot(e)), 0.5 * box_size.z() + 1e-9);
    }
  }
}
