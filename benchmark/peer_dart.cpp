// DART peer for the robot benchmark (see peer_dart.h).
#include "peer_dart.h"

#include <dart/collision/CollisionDetector.hpp>
#include <dart/collision/CollisionGroup.hpp>
#include <dart/collision/CollisionObject.hpp>
#include <dart/collision/CollisionResult.hpp>
#include <dart/constraint/BoxedLcpConstraintSolver.hpp>
#include <dart/constraint/ContactConstraint.hpp>
#include <dart/constraint/DantzigBoxedLcpSolver.hpp>
#include <dart/constraint/PgsBoxedLcpSolver.hpp>
#include <dart/dynamics/BodyNode.hpp>
#include <dart/dynamics/BoxShape.hpp>
#include <dart/dynamics/FreeJoint.hpp>
#include <dart/dynamics/ShapeNode.hpp>
#include <dart/dynamics/Skeleton.hpp>
#include <dart/dynamics/SphereShape.hpp>
#include <dart/simulation/World.hpp>
#include <dart/utils/urdf/DartLoader.hpp>

#include <algorithm>
#include <chrono>
#include <memory>
#include <stdexcept>

namespace collision_response::bench {
namespace {

namespace dd = dart::dynamics;

// A collision object that only names its shape frame: ContactConstraint reads the body nodes and
// the coefficients through it; no collision engine is behind it.
class NamedShape : public dart::collision::CollisionObject {
 public:
  NamedShape(dart::collision::CollisionDetector* detector, const dd::ShapeFrame* frame)
      : CollisionObject(detector, frame) {}

 protected:
  void updateEngineData() override {}
};

// A shape node carrying only the contact coefficients (no collision, no visual).
dd::ShapeNode* coefficientNode(dd::BodyNode* body, double friction, double restitution) {
  auto* node = body->createShapeNodeWith<dd::DynamicsAspect>(
      std::make_shared<dd::SphereShape>(0.01), body->getName() + "_contact_coefficients");
  node->getDynamicsAspect()->setFrictionCoeff(friction);
  node->getDynamicsAspect()->setRestitutionCoeff(restitution);
  return node;
}

}  // namespace

DartArmBoxRun runDartArmBox(const std::string& urdf_file, const std::string& package_dir,
                            const std::vector<std::string>& joint_names, const ArmBoxScene& scene,
                            const DartArmBoxConfig& config, int repetitions) {
  dart::utils::DartLoader::Options options;
  options.mDefaultRootJointType = dart::utils::DartLoader::RootJointType::FIXED;
  dart::utils::DartLoader loader(options);
  loader.addPackageDirectory("collision_response", package_dir);
  dd::SkeletonPtr arm = loader.parseSkeleton(dart::common::Uri::createFromPath(urdf_file));
  if (!arm) throw std::runtime_error("DART could not load " + urdf_file);
  for (std::size_t j = 0; j < arm->getNumJoints(); ++j) {
    arm->getJoint(j)->setLimitEnforcement(false);
  }
  // Our joint order -> DART's DOF indices.
  if (static_cast<int>(arm->getNumDofs()) != static_cast<int>(joint_names.size()))
    throw std::runtime_error("DART's arm has " + std::to_string(arm->getNumDofs()) + " DOFs");
  std::vector<std::size_t> dof(joint_names.size());
  for (std::size_t j = 0; j < joint_names.size(); ++j) {
    dd::Joint* joint = arm->getJoint(joint_names[j]);
    if (!joint || joint->getNumDofs() != 1)
      throw std::runtime_error("DART's arm has no 1-DOF joint " + joint_names[j]);
    dof[j] = joint->getIndexInSkeleton(0);
  }
  Eigen::VectorXd q(dof.size()), qdot(dof.size());
  for (std::size_t j = 0; j < dof.size(); ++j) {
    q[dof[j]] = scene.q[j];
    qdot[dof[j]] = scene.qdot[j];
  }
  dd::BodyNode* hand = arm->getBodyNode("hand");
  if (!hand) throw std::runtime_error("DART's arm has no link 'hand'");

  dd::SkeletonPtr box = dd::Skeleton::create("box");
  auto pair = box->createJointAndBodyNodePair<dd::FreeJoint>();
  dd::FreeJoint* box_joint = pair.first;
  dd::BodyNode* box_body = pair.second;
  auto box_shape = std::make_shared<dd::BoxShape>(scene.box_size);
  box_body->setInertia(dd::Inertia(scene.box_mass, Eigen::Vector3d::Zero(),
                                   box_shape->computeInertia(scene.box_mass)));

  // Coefficients: DART multiplies the sides' restitution and takes the smaller friction.
  dd::ShapeNode* hand_node = coefficientNode(hand, scene.dynamic_friction, 1.0);
  dd::ShapeNode* box_node = coefficientNode(box_body, scene.dynamic_friction, scene.restitution);

  auto world = dart::simulation::World::create();
  world->setGravity(Eigen::Vector3d::Zero());
  world->setTimeStep(config.time_step);
  if (config.pgs) {
    world->setConstraintSolver(std::make_unique<dart::constraint::BoxedLcpConstraintSolver>(
        std::make_shared<dart::constraint::PgsBoxedLcpSolver>(), nullptr));
  } else {
    world->setConstraintSolver(std::make_unique<dart::constraint::BoxedLcpConstraintSolver>(
        std::make_shared<dart::constraint::DantzigBoxedLcpSolver>(),
        std::make_shared<dart::constraint::PgsBoxedLcpSolver>()));
  }
  world->addSkeleton(arm);
  world->addSkeleton(box);
  dart::constraint::ConstraintSolver* solver = world->getConstraintSolver();
  // Our contact only: the world's collision group leaves the skeletons.
  solver->getCollisionGroup()->unsubscribeFrom(arm.get(), box.get());
  dart::constraint::ContactConstraint::setConstraintForceMixing(config.cfm);

  NamedShape box_object(solver->getCollisionDetector().get(), box_node);
  NamedShape hand_object(solver->getCollisionDetector().get(), hand_node);

  DartArmBoxRun run;
  auto reset = [&] {
    arm->setPositions(q);
    arm->setVelocities(qdot);
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = hand->getWorldTransform().translation() + scene.box_offset * scene.normal;
    box_joint->setTransform(pose);
    box_joint->setLinearVelocity(scene.box_velocity);
    box_joint->setAngularVelocity(Eigen::Vector3d::Zero());
  };
  auto velocities = [&](Eigen::VectorXd& joints, Eigen::Vector3d& box_v) {
    const Eigen::VectorXd v = arm->getVelocities();
    joints.resize(dof.size());
    for (std::size_t j = 0; j < dof.size(); ++j) joints[j] = v[dof[j]];
    box_v = box_body->getLinearVelocity();  // of the body origin, its centre
  };
  auto normalVelocity = [&](const Eigen::Vector3d& point) {
    const Eigen::Vector3d on_box =
        box_body->getLinearVelocity(box_body->getWorldTransform().inverse() * point);
    const Eigen::Vector3d on_hand =
        hand->getLinearVelocity(hand->getWorldTransform().inverse() * point);
    return scene.normal.dot(on_box - on_hand);
  };
  // The step without the contact: the smooth part of the velocity change over one step.
  reset();
  run.normal_velocity_before = normalVelocity(hand->getWorldTransform().translation());
  world->step();
  Eigen::VectorXd free_joints;
  Eigen::Vector3d free_box;
  velocities(free_joints, free_box);
  if (world->getLastCollisionResult().getNumContacts() != 0) run.note = "detection made contacts";

  // The contact: object 1 the box, object 2 the hand; DART's normal points from 2 to 1, its
  // impulse on 1 is +normal.
  dart::collision::Contact contact;
  contact.collisionObject1 = &box_object;
  contact.collisionObject2 = &hand_object;
  contact.normal = scene.normal;
  contact.penetrationDepth = 0.0;
  std::vector<double> ns;
  ns.reserve(repetitions);
  for (int r = 0; r < repetitions; ++r) {
    reset();
    run.hand_origin = hand->getWorldTransform().translation();
    contact.point = run.hand_origin;
    // Built after the state is set: the constraint takes the bodies' poses when constructed.
    auto constraint =
        std::make_shared<dart::constraint::ContactConstraint>(contact, config.time_step);
    solver->addConstraint(constraint);
    const auto t0 = std::chrono::steady_clock::now();
    world->step();
    const auto t1 = std::chrono::steady_clock::now();
    solver->removeConstraint(constraint);
    ns.push_back(std::chrono::duration<double, std::nano>(t1 - t0).count());
  }
  Eigen::VectorXd joints;
  Eigen::Vector3d box_v;
  velocities(joints, box_v);
  run.normal_velocity_after = normalVelocity(run.hand_origin);
  run.joint_velocity_change = joints - free_joints;
  run.box_velocity_change = box_v - free_box;
  std::nth_element(ns.begin(), ns.begin() + ns.size() / 2, ns.end());
  run.ns_per_step = ns[ns.size() / 2];
  return run;
}

}  // namespace collision_response::bench
