#pragma once
// The shipped 7-DOF arm (urdf/arm7.urdf) swinging its fingertips down onto a 1 kg box (0.1 m
// cube) resting on a table, as scripts/robot_demo.sh sets the scene, for an impact episode of
// general bodies (core::computeBodyEpisode()): shared by test_robot_episode and bench_episode.
// The arm's geometry is its two fingers' collision boxes as arm7.urdf gives them (0.02 x 0.01 x
// 0.05 m at (0, +-0.005, 0.025) in each finger's frame): the parts that strike; the rest of the
// arm has no geometry here (it stays far above the box). Table: an immovable 0.6 x 0.6 x 0.1 m
// box, its top at z = 0.1615 m. Gravity (0, 0, -9.81) m/s^2; the arm under gravity compensation,
// joints at the demo's pose (config/arm7_positions.yaml) less `lift` [rad] on joint2, joint2
// turning at 1.2 rad/s (the demo's velocities). Coefficients e = 0.3, mu_s = 0.5, mu_d = 0.4.
#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <vector>

#include "collision_response/core/body_episode.h"
#include "collision_response/core/rigid_episode_body.h"
#include "collision_response/detection/shape_gaps.h"
#include "collision_response/robot/robot_episode_body.h"
#include "collision_response/robot/urdf_loader.h"
#include "shape_builders.h"

namespace collision_response::testing {

struct ArmBoxScene {
  std::unique_ptr<robot::RobotEpisodeBody> arm;
  std::unique_ptr<core::RigidEpisodeBody> table, box;
  std::vector<core::EpisodeBody*> bodies;  // table, box, arm
  std::vector<core::EpisodePart> parts;    // table, box, left finger, right finger
  std::vector<core::BodyState> part_states;
  std::unique_ptr<detection::ShapeGaps> geometry;
  core::EpisodeOptions options;
};

inline ArmBoxScene armBoxScene(const std::string& urdf_path, double lift = 0.03,
                               double joint2_velocity = 1.2) {
  ArmBoxScene s;
  robot::ArticulatedBody arm = robot::robotFromUrdfFile(urdf_path);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(arm.jointCount());
  Eigen::VectorXd qdot = Eigen::VectorXd::Zero(arm.jointCount());
  const char* names[] = {"joint2", "joint4", "joint6", "left_finger_joint", "right_finger_joint"};
  const double values[] = {0.3 - lift, -2.3, 0.5, 0.02, 0.02};
  for (int k = 0; k < 5; ++k) q(arm.jointIndex(names[k])) = values[k];
  qdot(arm.jointIndex("joint2")) = joint2_velocity;
  arm.setState(q, qdot);
  const Eigen::Vector3d gravity(0.0, 0.0, -9.81);
  arm.setGravityCompensation(gravity);
  s.arm = std::make_unique<robot::RobotEpisodeBody>(std::move(arm));

  core::BodyState table;
  table.id = "table";
  table.position = Eigen::Vector3d(0.45, 0.1, 0.1115);
  core::BodyState box;
  box.id = "box";
  box.mass = 1.0;
  box.inertia = Eigen::Matrix3d::Identity() * (1.0 * 0.01 / 6.0);
  box.position = Eigen::Vector3d(0.43278, 0.09252, 0.1615 + 0.05);
  s.table = std::make_unique<core::RigidEpisodeBody>(table);
  s.box = std::make_unique<core::RigidEpisodeBody>(box);
  s.bodies = {s.table.get(), s.box.get(), s.arm.get()};

  const robot::ArticulatedBody& model = s.arm->robot();
  const int left = model.linkIndex("left_finger"), right = model.linkIndex("right_finger");
  s.parts = {{0, 0}, {1, 0}, {2, left}, {2, right}};
  detection::DetectionInput input;
  using Type = detection::Shape::Type;
  detection::BodyGeometry table_shape, box_shape, left_shape, right_shape;
  table_shape.shapes.push_back(primitive(Type::kBox, {0.6, 0.6, 0.1}));
  box_shape.shapes.push_back(primitive(Type::kBox, {0.1, 0.1, 0.1}));
  left_shape.shapes.push_back(primitive(Type::kBox, {0.02, 0.01, 0.05},
                                        Eigen::Isometry3d(Eigen::Translation3d(0, 0.005, 0.025))));
  right_shape.shapes.push_back(primitive(
      Type::kBox, {0.02, 0.01, 0.05}, Eigen::Isometry3d(Eigen::Translation3d(0, -0.005, 0.025))));
  input.geometry = {table_shape, box_shape, left_shape, right_shape};
  input.collision_groups = {-1, -1, 0, 0};  // the fingers (one robot) are never paired
  input.defaults.restitution = 0.3;
  input.defaults.static_friction = 0.5;
  input.defaults.dynamic_friction = 0.4;
  input.options.max_contacts_per_pair = 4;
  for (const core::EpisodePart& p : s.parts)
    s.part_states.push_back(s.bodies[p.body]->partGeometry(p.part));
  s.geometry =
      std::make_unique<detection::ShapeGaps>(s.part_states, input, detection::MaterialTable{});
  s.options.gravity = gravity;
  s.options.horizon = 0.1;
  s.options.max_impacts = 50;
  s.options.contact_tolerance = 1e-4;
  s.options.solver.law = core::ImpactLaw::kStronge;
  return s;
}

}  // namespace collision_response::testing
