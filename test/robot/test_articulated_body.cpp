// ArticulatedBody's model against closed forms and KDL's chain solvers (docs/robots.md): M(q) of a
// pendulum and of the textbook planar 2R arm, the 7-DOF arm's M(q) and Jacobians against
// ChainDynParam::JntToMass and ChainJntToJacSolver, joint models (locked, armature) and the
// rejection of a singular joint-space inertia.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <kdl/chain.hpp>
#include <kdl/chaindynparam.hpp>
#include <kdl/chainidsolver_recursive_newton_euler.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <kdl/jacobian.hpp>
#include <kdl/jntspaceinertiamatrix.hpp>
#include <kdl/tree.hpp>
#include <kdl_parser/kdl_parser.hpp>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "collision_response/core/errors.h"
#include "collision_response/robot/algorithms.h"
#include "collision_response/robot/articulated_body.h"
#include "collision_response/robot/articulated_body_algorithm.h"
#include "collision_response/robot/urdf_loader.h"
#include "two_link_arm.h"

namespace rb = collision_response::robot;
using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::VectorXd;

namespace {

const std::string kDir = ROBOT_TEST_DIR;
const std::string kArm7 = ARM7_URDF;  // the shipped arm, urdf/arm7.urdf

// A random state of the whole arm (9 joints): q in [-3, 3] rad (fingers 0.02 m open), qdot in
// [-1, 1] rad/s, joint torques in [-5, 5] N m.
struct ArmMotion {
  VectorXd q = VectorXd(9), qdot = VectorXd(9), tau = VectorXd(9);
};
ArmMotion randomArmMotion(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  ArmMotion out;
  for (int i = 0; i < 9; ++i) {
    out.q(i) = 3 * u(rng);
    out.qdot(i) = u(rng);
    out.tau(i) = 5 * u(rng);
  }
  out.q(7) = out.q(8) = 0.02;
  return out;
}

}  // namespace

// Pendulum: one unknown, M = I_hinge = m L^2 / 3 = 2/3 kg m^2; at q = 0 the point (d, 0, 0) of the
// rod moves at w z x (d, 0, 0) = (0, w d, 0): J = (0, d, 0).
TEST(ArticulatedBody, PendulumMassAndJacobian) {
  rb::ArticulatedBody rod = rb::robotFromUrdfFile(kDir + "/pendulum.urdf");
  ASSERT_EQ(rod.jointCount(), 1);
  ASSERT_EQ(rod.velocityCount(), 1);
  EXPECT_EQ(rod.jointNames()[0], "hinge");
  EXPECT_NEAR(rod.massMatrix()(0, 0), 2.0 / 3.0, 1e-15);
  const auto J = rod.linkPointJacobian(rod.linkIndex("rod"), Vector3d(0.7, 0, 0));
  EXPECT_TRUE(J.isApprox(Vector3d(0, 0.7, 0), 1e-15));
  // At q = 90 degrees the rod points along y: M unchanged, the point (0, d, 0) moves along -x.
  rod.setState(VectorXd::Constant(1, M_PI / 2), VectorXd::Constant(1, 2.0));
  EXPECT_NEAR(rod.massMatrix()(0, 0), 2.0 / 3.0, 1e-15);
  EXPECT_TRUE(rod.partPointVelocity(rod.linkIndex("rod"), Vector3d(0, 0.5, 0))
                  .isApprox(Vector3d(-1.0, 0, 0), 1e-15));
}

TEST(ArticulatedBody, TwoLinkMassMatchesTheTextbookAtSeveralConfigurations) {
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(kDir + "/two_link.urdf");
  ASSERT_EQ(arm.velocityCount(), 2);
  for (const double q1 : {0.0, 0.4, -1.3}) {
    for (const double q2 : {0.0, 0.9, 2.5, -2.0}) {
      arm.setState(Eigen::Vector2d(q1, q2), Eigen::Vector2d::Zero());
      EXPECT_TRUE(arm.massMatrix().isApprox(two_link::massMatrix(q2), 1e-14))
          << "q = " << q1 << ", " << q2 << "\n"
          << arm.massMatrix() << "\nwant\n"
          << two_link::massMatrix(q2);
    }
  }
}

// The 7-DOF arm against KDL's chain solvers. A KDL chain has no branches, so the comparison is on
// the chain base_link -> left_finger (7 revolute joints, the hand, one prismatic finger), rebuilt
// as a tree for ArticulatedBody: the same links, two independent algorithms (ChainDynParam is the
// chain's composite-rigid-body method in local frames; ChainJntToJacSolver the twists of the tip).
TEST(ArticulatedBody, Arm7MassAndJacobiansEqualKdlChainSolvers) {
  KDL::Tree full;
  ASSERT_TRUE(kdl_parser::treeFromFile(kArm7, full));
  KDL::Chain chain;
  ASSERT_TRUE(full.getChain("base_link", "left_finger", chain));
  ASSERT_EQ(chain.getNrOfJoints(), 8u);
  KDL::Tree tree("base_link");
  ASSERT_TRUE(tree.addChain(chain, "base_link"));
  rb::ArticulatedBody arm(tree);
  ASSERT_EQ(arm.velocityCount(), 8);

  KDL::ChainDynParam dynamics(chain, KDL::Vector(0, 0, -9.81));
  KDL::ChainJntToJacSolver jacobians(chain);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  const int finger = arm.linkIndex("left_finger");
  for (int trial = 0; trial < 20; ++trial) {
    VectorXd q(8);
    for (int i = 0; i < 7; ++i) q(i) = angle(rng);
    q(7) = 0.02 + 0.01 * angle(rng) / M_PI;
    arm.setState(q, VectorXd::Zero(8));
    KDL::JntArray kq(8);
    kq.data = q;
    KDL::JntSpaceInertiaMatrix H(8);
    ASSERT_GE(dynamics.JntToMass(kq, H), 0);
    EXPECT_LE((arm.massMatrix() - H.data).cwiseAbs().maxCoeff(), 1e-12) << "trial " << trial;

    KDL::Jacobian jac(8);
    ASSERT_GE(jacobians.JntToJac(kq, jac), 0);
    // KDL's Jacobian is the twist of the tip frame's origin, base coordinates: the velocity of a
    // point p of the tip link is v_tip + w x (p - o_tip).
    const Vector3d tip = arm.linkPose(finger).translation();
    const Vector3d p = tip + Vector3d(0.03, -0.02, 0.05);
    const MatrixXd want = jac.data.topRows(3) - [&] {
      MatrixXd lever(3, 8);
      for (int i = 0; i < 8; ++i) lever.col(i) = (p - tip).cross(Vector3d(jac.data.col(i).tail(3)));
      return lever;
    }();
    EXPECT_LE((arm.linkPointJacobian(finger, p) - want).cwiseAbs().maxCoeff(), 1e-12);
  }
}

// The whole arm (both fingers, a tree): the seven arm joints and the two finger joints. M is
// symmetric positive definite and (1/2) qdot^T M qdot equals the links' kinetic energy summed
// link by link (sum of (1/2) V_i . I_i V_i over the links' twists), an independent computation.
TEST(ArticulatedBody, Arm7TreeEnergyMatchesMassMatrix) {
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(kArm7);
  ASSERT_EQ(arm.jointCount(), 9);
  ASSERT_EQ(arm.linkCount(), 12);  // base, its inertia, 7 links, hand, 2 fingers
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 10; ++trial) {
    VectorXd q(9), qdot(9);
    for (int i = 0; i < 9; ++i) {
      q(i) = 3 * u(rng);
      qdot(i) = u(rng);
    }
    arm.setState(q, qdot);
    const MatrixXd& M = arm.massMatrix();
    EXPECT_LE((M - M.transpose()).cwiseAbs().maxCoeff(), 0.0);
    EXPECT_NEAR(0.5 * qdot.dot(M * qdot), arm.kineticEnergy(), 1e-12);
  }
}

// The shipped arm's root link base_link has no <inertial> (kdl_parser, hence robot_state_publisher,
// warns about a root inertia it cannot use on every launch): the base's 4 kg are on
// base_link_inertia, fixed to base_link at its frame. Written the other way, the inertial on the
// root link (which the loader hands to the body itself), it is the same body: for a fixed base
// (which nothing moves) and a floating one (base and inertia one rigid body), the mass matrices,
// the kinetic energies, the momenta and the links' poses are equal at random states.
TEST(ArticulatedBody, Arm7BaseInertiaOnAFixedChildIsTheSameBody) {
  std::ifstream file(kArm7);
  std::stringstream buffer;
  buffer << file.rdbuf();
  const std::string shipped = buffer.str();
  const auto block = [](const std::string& text, const std::string& open,
                        const std::string& close) {
    const std::size_t begin = text.find(open);
    const std::size_t end = text.find(close, begin);
    EXPECT_NE(begin, std::string::npos) << open;
    EXPECT_NE(end, std::string::npos) << close;
    return std::make_pair(begin, end + close.size());
  };
  const auto root = block(shipped, "<link name=\"base_link\">", "</link>");
  EXPECT_EQ(shipped.substr(root.first, root.second - root.first).find("<inertial>"),
            std::string::npos)
      << "the root link has an inertial again";
  // The same arm with the inertial on the root: base_link_inertia and its joint removed.
  std::string on_root = shipped;
  const auto child = block(on_root, "<link name=\"base_link_inertia\">", "</link>");
  const std::string link = on_root.substr(child.first, child.second - child.first);
  const auto inertial = block(link, "<inertial>", "</inertial>");
  on_root.erase(child.first, child.second - child.first);
  const auto joint = block(on_root, "<joint name=\"base_inertia_joint\"", "</joint>");
  on_root.erase(joint.first, joint.second - joint.first);
  const std::string root_open = "<link name=\"base_link\">";
  on_root.insert(on_root.find(root_open) + root_open.size(),
                 link.substr(inertial.first, inertial.second - inertial.first));

  for (const rb::BaseType base_type : {rb::BaseType::kFixed, rb::BaseType::kFloating}) {
    rb::ArticulatedBody arm = rb::robotFromUrdfString(shipped, base_type);
    rb::ArticulatedBody reference = rb::robotFromUrdfString(on_root, base_type);
    ASSERT_EQ(arm.linkCount(), reference.linkCount() + 1);
    ASSERT_EQ(arm.velocityCount(), reference.velocityCount());
    std::mt19937 rng(41);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int trial = 0; trial < 5; ++trial) {
      const ArmMotion motion = randomArmMotion(rng);
      Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
      base.translation() = Vector3d(u(rng), u(rng), u(rng));
      base.linear() = Eigen::AngleAxisd(3 * u(rng), Vector3d(u(rng), u(rng), 1).normalized())
                          .toRotationMatrix();
      const Vector3d v_b(u(rng), u(rng), u(rng)), w(u(rng), u(rng), u(rng));
      arm.setState(motion.q, motion.qdot, base, v_b, w);
      reference.setState(motion.q, motion.qdot, base, v_b, w);
      const double scale = reference.massMatrix().cwiseAbs().maxCoeff();
      EXPECT_LE((arm.massMatrix() - reference.massMatrix()).cwiseAbs().maxCoeff(), 1e-13 * scale)
          << "trial " << trial;
      EXPECT_NEAR(arm.kineticEnergy(), reference.kineticEnergy(), 1e-13 * scale);
      EXPECT_LE((arm.momentum() - reference.momentum()).cwiseAbs().maxCoeff(), 1e-13 * scale);
      for (const char* name : {"base_link", "link4", "left_finger"}) {
        EXPECT_LE((arm.linkPose(arm.linkIndex(name)).matrix() -
                   reference.linkPose(reference.linkIndex(name)).matrix())
                      .cwiseAbs()
                      .maxCoeff(),
                  1e-14)
            << name;
      }
    }
    // The fixed-base arm's total mass does not enter its mass matrix; the floating one's does.
    if (base_type == rb::BaseType::kFloating) {
      arm.setState(VectorXd::Zero(9), VectorXd::Zero(9));
      EXPECT_NEAR(arm.massMatrix()(0, 0), 4.0 + 4.0 + 3.5 + 3.0 + 2.5 + 2.0 + 1.5 + 1.0 + 0.6 + 0.2,
                  1e-12);
    }
  }
}

// The robot's dynamics for resting contacts against KDL's recursive Newton-Euler solver on the same
// chain (KDL's own algorithm, in the links' frames): h(q, qdot) = C qdot + g(q) is KDL's torque for
// zero joint accelerations, g(q) its torque at rest (also ChainDynParam::JntToGravity), and the
// free acceleration M^-1 (tau - h) under random torques is the acceleration for which KDL's inverse
// dynamics returns those torques.
TEST(ArticulatedBody, Arm7DynamicsEqualKdlNewtonEuler) {
  KDL::Tree full;
  ASSERT_TRUE(kdl_parser::treeFromFile(kArm7, full));
  KDL::Chain chain;
  ASSERT_TRUE(full.getChain("base_link", "left_finger", chain));
  KDL::Tree tree("base_link");
  ASSERT_TRUE(tree.addChain(chain, "base_link"));
  rb::ArticulatedBody arm(tree);
  const Vector3d g(0.5, -1.2, -9.81);  // not along an axis of the base
  KDL::ChainIdSolver_RNE newton_euler(chain, KDL::Vector(g.x(), g.y(), g.z()));
  KDL::ChainDynParam dynamics(chain, KDL::Vector(g.x(), g.y(), g.z()));
  const KDL::Wrenches no_wrench(chain.getNrOfSegments(), KDL::Wrench::Zero());
  const auto kdlTorques = [&](const VectorXd& q, const VectorXd& qdot, const VectorXd& qddot) {
    KDL::JntArray kq(8), kqd(8), kqdd(8), torques(8);
    kq.data = q;
    kqd.data = qdot;
    kqdd.data = qddot;
    EXPECT_GE(newton_euler.CartToJnt(kq, kqd, kqdd, no_wrench, torques), 0);
    return VectorXd(torques.data);
  };
  std::mt19937 rng(19);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    VectorXd q(8), qdot(8), tau(8);
    for (int i = 0; i < 8; ++i) {
      q(i) = M_PI * u(rng);
      qdot(i) = 2.0 * u(rng);
      tau(i) = 20.0 * u(rng);
    }
    q(7) = 0.02 + 0.01 * u(rng);
    arm.setState(q, qdot);
    arm.setLoads(tau, g);
    const VectorXd zero = VectorXd::Zero(8);
    EXPECT_LE((arm.biasForces() - kdlTorques(q, qdot, zero)).cwiseAbs().maxCoeff(), 1e-11)
        << "trial " << trial;
    EXPECT_LE((arm.gravityTorques() - kdlTorques(q, zero, zero)).cwiseAbs().maxCoeff(), 1e-11);
    KDL::JntArray kq(8), gravity(8);
    kq.data = q;
    ASSERT_GE(dynamics.JntToGravity(kq, gravity), 0);
    EXPECT_LE((arm.gravityTorques() - gravity.data).cwiseAbs().maxCoeff(), 1e-11);
    const VectorXd qddot = arm.freeAcceleration();
    EXPECT_LE((kdlTorques(q, qdot, qddot) - tau).cwiseAbs().maxCoeff(), 1e-10) << "trial " << trial;
  }
}

// The inverse dynamics reuse the world inertias the mass matrix computed at the same frames
// (RobotData::link_inertias): after forwardKinematics() alone moves the frames (no new mass
// matrix), they must be the new frames' inertias, not the kept ones. Against KDL's recursive
// Newton-Euler at the new configuration.
TEST(ArticulatedBody, InverseDynamicsAfterKinematicsAloneEqualKdlNewtonEuler) {
  KDL::Tree full;
  ASSERT_TRUE(kdl_parser::treeFromFile(kArm7, full));
  KDL::Chain chain;
  ASSERT_TRUE(full.getChain("base_link", "left_finger", chain));
  KDL::Tree tree("base_link");
  ASSERT_TRUE(tree.addChain(chain, "base_link"));
  rb::ArticulatedBody arm(tree);
  const Vector3d g(0.5, -1.2, -9.81);
  KDL::ChainIdSolver_RNE newton_euler(chain, KDL::Vector(g.x(), g.y(), g.z()));
  const KDL::Wrenches no_wrench(chain.getNrOfSegments(), KDL::Wrench::Zero());
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 10; ++trial) {
    VectorXd q(8), qdot(8), qddot(8);
    for (int i = 0; i < 8; ++i) {
      q(i) = M_PI * u(rng);
      qdot(i) = 2.0 * u(rng);
      qddot(i) = 5.0 * u(rng);
    }
    q(7) = 0.02 + 0.01 * u(rng);
    arm.setState(q, qdot);  // frames, mass matrix (and its kept inertias) at q
    arm.setLoads(VectorXd::Zero(8), g);
    rb::RobotData data = arm.data();
    for (int i = 0; i < 7; ++i) data.q(i) += 0.3 + 0.2 * u(rng);  // elsewhere, no mass matrix
    rb::forwardKinematics(arm.model(), data);
    VectorXd tau;
    Eigen::Matrix<double, 6, 1> base;
    rb::inverseDynamics(arm.model(), data, qddot, Eigen::Matrix<double, 6, 1>::Zero(), true, tau,
                        base, nullptr);
    KDL::JntArray kq(8), kqd(8), kqdd(8), expected(8);
    kq.data = data.q;
    kqd.data = qdot;
    kqdd.data = qddot;
    ASSERT_GE(newton_euler.CartToJnt(kq, kqd, kqdd, no_wrench, expected), 0);
    EXPECT_LE((tau - expected.data).cwiseAbs().maxCoeff(), 1e-10) << "trial " << trial;
  }
}

// A material point's free acceleration is the time derivative of its velocity along the motion
// the free acceleration gives: central differences of partPointVelocity() over states 1e-5 s apart
// (q +- qdot dt + qddot dt^2 / 2, qdot +- qddot dt: the point's velocity is then known to
// O(dt^2)), on the whole arm (a tree: both fingers) with a locked joint and gravity.
TEST(ArticulatedBody, Arm7PointAccelerationIsTheDerivativeOfItsVelocity) {
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(kArm7);
  arm.setJointModel(arm.jointIndex("joint3"), rb::JointModel::kLocked);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double dt = 1e-5;
  for (int trial = 0; trial < 5; ++trial) {
    const ArmMotion motion = randomArmMotion(rng);
    const VectorXd &q = motion.q, &qdot = motion.qdot, &tau = motion.tau;
    arm.setLoads(tau, Vector3d(0, 0, -9.81));
    arm.setState(q, qdot);
    VectorXd qddot = VectorXd::Zero(9);  // the locked joint's stays 0
    const VectorXd vdot = arm.freeAcceleration();
    for (int k = 0; k < arm.velocityCount(); ++k) qddot(arm.jointOfUnknown(k)) = vdot(k);
    for (const char* name : {"left_finger", "link4", "hand"}) {
      const int link = arm.linkIndex(name);
      const Eigen::Isometry3d pose = arm.linkPose(link);
      const Vector3d local(0.02, -0.03, 0.04);
      const Vector3d want = arm.partPointFreeAcceleration(link, pose * local);
      Vector3d velocity[2];
      for (int side = 0; side < 2; ++side) {
        const double h = side == 0 ? -dt : dt;
        arm.setState(q + qdot * h + 0.5 * qddot * h * h, qdot + qddot * h);
        velocity[side] = arm.partPointVelocity(link, arm.linkPose(link) * local);
      }
      arm.setState(q, qdot);
      const Vector3d difference = (velocity[1] - velocity[0]) / (2 * dt);
      EXPECT_LE((difference - want).norm(), 1e-6 * (1 + want.norm()))
          << name << ", trial " << trial << ": " << want.transpose() << " against "
          << difference.transpose();
    }
  }
}

// A floating arm moving freely (random joint rates, torques and base twist) under gravity alone:
// its joint torques are internal, so its linear momentum changes at m_total g (Newton's second law
// for the system). The rate is the central difference of momentum() over states 1e-5 s apart along
// the free acceleration (joints q +- qdot dt + qddot dt^2 / 2; base origin likewise; base rotation
// exp(+-w dt + alpha dt^2 / 2)); it checks the floating base's unknowns, h's base rows and the
// Coriolis terms of moving joints together.
TEST(ArticulatedBody, FloatingArmMomentumChangesByItsWeight) {
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(kArm7, rb::BaseType::kFloating);
  const Vector3d g(0.6, -1.1, -9.81);
  std::mt19937 rng(29);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double dt = 1e-5;
  for (int trial = 0; trial < 5; ++trial) {
    const ArmMotion motion = randomArmMotion(rng);
    const VectorXd &q = motion.q, &qdot = motion.qdot, &tau = motion.tau;
    const Vector3d v_b(u(rng), u(rng), u(rng)), w(u(rng), u(rng), u(rng));
    Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
    base.translation() = Vector3d(0.3, -0.2, 0.5);
    base.linear() = Eigen::AngleAxisd(1.0, Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    arm.setLoads(tau, g);
    arm.setState(q, qdot, base, v_b, w);
    const double mass = arm.massMatrix()(0, 0);  // the base's translation moves every link
    const VectorXd vdot = arm.freeAcceleration();
    const Vector3d a_b = vdot.head<3>(), alpha = vdot.segment<3>(3);
    VectorXd qddot = vdot.tail(9);
    Vector3d momentum[2];
    for (int side = 0; side < 2; ++side) {
      const double h = side == 0 ? -dt : dt;
      Eigen::Isometry3d pose = base;
      const Vector3d turn = w * h + 0.5 * alpha * h * h;
      pose.linear() = Eigen::AngleAxisd(turn.norm(), turn.normalized()) * base.linear();
      pose.translation() = base.translation() + v_b * h + 0.5 * a_b * h * h;
      arm.setState(q + qdot * h + 0.5 * qddot * h * h, qdot + qddot * h, pose, v_b + a_b * h,
                   w + alpha * h);
      momentum[side] = arm.momentum().head<3>();
    }
    const Vector3d rate = (momentum[1] - momentum[0]) / (2 * dt);
    EXPECT_LE((rate - mass * g).norm(), 1e-5 * mass * g.norm())
        << "trial " << trial << ": " << rate.transpose() << " against " << (mass * g).transpose();
  }
}

// Armature: a single joint's M is I_hinge + I_a; locking the joint removes the unknown.
TEST(ArticulatedBody, JointModels) {
  rb::ArticulatedBody rod = rb::robotFromUrdfFile(kDir + "/pendulum.urdf");
  rod.setJointModel(0, rb::JointModel::kArmature, 0.25);
  EXPECT_NEAR(rod.massMatrix()(0, 0), 2.0 / 3.0 + 0.25, 1e-15);
  rod.setJointModel(0, rb::JointModel::kLocked);
  EXPECT_EQ(rod.velocityCount(), 0);
  EXPECT_EQ(rod.unknownOfJoint(0), -1);
  rod.setJointModel(0, rb::JointModel::kFree);
  EXPECT_EQ(rod.velocityCount(), 1);

  // The 2R arm with the shoulder locked: one unknown, M = M22.
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(kDir + "/two_link.urdf");
  arm.setJointModel(arm.jointIndex("shoulder"), rb::JointModel::kLocked);
  ASSERT_EQ(arm.velocityCount(), 1);
  EXPECT_EQ(arm.jointOfUnknown(0), arm.jointIndex("elbow"));
  EXPECT_NEAR(arm.massMatrix()(0, 0), two_link::massMatrix(0.0)(1, 1), 1e-15);
}

// A free joint that moves only massless links makes M singular: the robot is refused (setState(),
// M^-1 J^T) naming the joint until it is locked. A document that does not parse and a missing file
// are rejected.
TEST(ArticulatedBody, SingularInertiaIsRejectedNamingTheJoint) {
  const std::string urdf = R"(<?xml version="1.0"?>
<robot name="massless_tip">
  <link name="base"/>
  <joint name="hinge" type="continuous">
    <parent link="base"/><child link="rod"/><axis xyz="0 0 1"/>
  </joint>
  <link name="rod">
    <inertial><origin xyz="0.5 0 0"/><mass value="1"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>
  </link>
  <joint name="wrist" type="continuous">
    <parent link="rod"/><child link="pointer"/><origin xyz="1 0 0"/><axis xyz="0 0 1"/>
  </joint>
  <link name="pointer"/>
</robot>)";
  rb::ArticulatedBody robot = rb::robotFromUrdfString(urdf);
  EXPECT_NE(robot.singularJoint().find("'wrist'"), std::string::npos) << robot.singularJoint();
  try {
    robot.setState(Eigen::Vector2d(0.1, 0.2), Eigen::Vector2d::Zero());
    FAIL() << "a massless link on a free joint was accepted";
  } catch (const collision_response::core::InvalidInput& error) {
    EXPECT_NE(std::string(error.what()).find("'wrist'"), std::string::npos) << error.what();
  }
  EXPECT_THROW(robot.partInverseMassJacobianTranspose(2, Vector3d(1, 0, 0)),
               collision_response::core::InvalidInput);
  robot.setJointModel(robot.jointIndex("wrist"), rb::JointModel::kLocked);
  EXPECT_TRUE(robot.singularJoint().empty());
  robot.setState(Eigen::Vector2d(0.1, 0.2), Eigen::Vector2d::Zero());
  EXPECT_EQ(robot.velocityCount(), 1);
  EXPECT_THROW(rb::robotFromUrdfString("<robot"), collision_response::core::InvalidInput);
  EXPECT_THROW(rb::robotFromUrdfFile(kDir + "/missing.urdf"),
               collision_response::core::InvalidInput);
}

// The URDF's text is checked before TinyXML reads it (urdf_text.h): UTF-8 without NUL. The robot
// fuzz target found TinyXML reading past the end of a text that ends in a cut UTF-8 sequence
// (test/fuzz/regressions/robot/); every broken form is refused naming the byte and its line, and
// real UTF-8 (a comment in three scripts) still loads.
TEST(ArticulatedBody, UrdfTextThatIsNotUtf8IsRefusedNamingTheByte) {
  const std::string head = "<?xml version=\"1.0\"?>\n<robot name=\"r\">\n<!-- ";
  const std::string tail = " -->\n<link name=\"base\"/>\n</robot>\n";
  // "Smørbrød, 機械, 🤖": two-, three- and four-byte sequences.
  const std::string fine =
      "Sm\xc3\xb8rbr\xc3\xb8"
      "d, \xe6\xa9\x9f\xe6\xa2\xb0, \xf0\x9f\xa4\x96";
  EXPECT_EQ(rb::robotFromUrdfString(head + fine + tail).jointCount(), 0);
  struct Case {
    std::string text;
    std::size_t byte;  // the offset the error must name
    std::size_t line;
  };
  const std::size_t at = head.size();  // the comment's first byte, on line 3
  const std::vector<Case> cases = {
      {head + "ok" + tail + "\xf0", head.size() + 2 + tail.size(), 6},  // cut at the end
      {head + "\xc3", at, 3},                                           // cut at the end
      {head + "\xf0\x9f\xa4", at, 3},  // cut at the end, one byte short (needs 1 more byte)
      {head + "\xe2\x28", at + 1, 3},  // at the end, and '(' inside: the '(' is named
      {head + "a" + std::string(1, '\0') + tail, at + 1, 3},  // a NUL
      {head + "\xc0\xaf" + tail, at, 3},                      // overlong '/'
      {head + "\xe0\x80\xaf" + tail, at + 1, 3},              // overlong '/'
      {head + "\xed\xa0\x80" + tail, at + 1, 3},              // a surrogate
      {head + "\xf4\x90\x80\x80" + tail, at + 1, 3},          // beyond U+10FFFF
      {head + "\xe2\x28\xa1" + tail, at + 1, 3},              // '(' inside
      {head + "x\x80" + tail, at + 1, 3},                     // a lone continuation
      {head + "\xff" + tail, at, 3}};
  for (const Case& c : cases) {
    try {
      rb::robotFromUrdfString(c.text);
      ADD_FAILURE() << "accepted a text with byte " << c.byte << " broken";
    } catch (const collision_response::core::InvalidInput& error) {
      EXPECT_EQ(error.field(), "URDF");
      const std::string expected =
          "byte " + std::to_string(c.byte) + " (line " + std::to_string(c.line) + ")";
      EXPECT_NE(error.reason().find(expected), std::string::npos)
          << error.what() << " (expected " << expected << ")";
      if (c.text == head + "\xf0\x9f\xa4")
        EXPECT_NE(error.reason().find("needs 1 more byte"), std::string::npos) << error.what();
    }
  }
}

// Model and data (docs/robots.md): copies of a body share one model and own their state; a change
// of joint model gives that one body a model of its own (copy on write) and leaves the others.
TEST(ArticulatedBody, CopiesShareTheModelAndKeepTheirOwnState) {
  const rb::ArticulatedBody arm = rb::robotFromUrdfFile(kArm7);
  rb::ArticulatedBody copy = arm;
  EXPECT_EQ(copy.sharedModel().get(), arm.sharedModel().get());
  Eigen::VectorXd q = Eigen::VectorXd::Constant(arm.jointCount(), 0.3);
  copy.setState(q, -q);
  EXPECT_EQ(arm.jointPositions(), Eigen::VectorXd::Zero(arm.jointCount()));
  EXPECT_EQ(copy.sharedModel().get(), arm.sharedModel().get());
  const int joint7 = arm.jointIndex("joint7");
  copy.setJointModel(joint7, rb::JointModel::kLocked);
  EXPECT_NE(copy.sharedModel().get(), arm.sharedModel().get());
  EXPECT_EQ(arm.jointModel(joint7), rb::JointModel::kFree);
  EXPECT_EQ(arm.velocityCount(), arm.jointCount());
  EXPECT_EQ(copy.velocityCount(), arm.jointCount() - 1);
}

// A body's own locks (setLockedJoints(), held in its data) act as the same locks in its model: the
// same unknowns and the same M, at the model's own pointer. On the gripper (finger2 mimics finger1)
// a lock on one finger locks the pair, whichever joint carries it.
TEST(ArticulatedBody, LocksInTheDataActAsLocksInTheModel) {
  const rb::ArticulatedBody gripper = rb::robotFromUrdfFile(kDir + "/gripper.urdf");
  const Eigen::Vector3d q(0.2, 0.01, 0.0), qdot(0.5, 0.03, 0.0);
  for (const std::vector<std::string>& locks : std::vector<std::vector<std::string>>{
           {"wrist"}, {"finger1_joint"}, {"finger2_joint"}, {"wrist", "finger2_joint"}}) {
    std::vector<bool> flags(gripper.jointCount(), false);
    rb::ArticulatedBody in_model = gripper;
    for (const std::string& name : locks) {
      flags[gripper.jointIndex(name)] = true;
      in_model.setJointModel(gripper.jointIndex(name), rb::JointModel::kLocked);
    }
    rb::ArticulatedBody in_data = gripper;
    in_data.setLockedJoints(flags);
    EXPECT_EQ(in_data.sharedModel().get(), gripper.sharedModel().get());
    in_data.setState(q, qdot);
    in_model.setState(q, qdot);
    ASSERT_EQ(in_data.velocityCount(), in_model.velocityCount()) << locks.back();
    for (int j = 0; j < gripper.jointCount(); ++j)
      EXPECT_EQ(in_data.unknownOfJoint(j), in_model.unknownOfJoint(j)) << locks.back();
    EXPECT_EQ(in_data.massMatrix(), in_model.massMatrix()) << locks.back();
  }
  // The fingers are one mimic group: a brake on either holds both.
  rb::ArticulatedBody one = gripper;
  std::vector<bool> flags(gripper.jointCount(), false);
  flags[gripper.jointIndex("finger2_joint")] = true;
  one.setLockedJoints(flags);
  EXPECT_TRUE(one.isLocked(gripper.jointIndex("finger1_joint")));
  EXPECT_EQ(one.velocityCount(), 1);
}

// The articulated-body algorithm (articulated_body_algorithm.h) against the mass-matrix path
// (M(q) by composite rigid bodies, its Cholesky factor, Newton-Euler for h: freeAcceleration()),
// an independent computation of the same vdot = M^-1 (tau - h): the whole arm (a tree: both
// fingers) at random states, under random torques and gravity, under gravity compensation, with a
// locked joint moving at its velocity and with armature on two joints.
TEST(ArticulatedBody, ArticulatedBodyAlgorithmEqualsTheMassMatrixPath) {
  std::mt19937 rng(2411);
  const Vector3d g(0.3, -0.8, -9.81);
  for (int variant = 0; variant < 4; ++variant) {
    rb::ArticulatedBody arm = rb::robotFromUrdfFile(kArm7);
    ASSERT_TRUE(rb::articulatedBodyApplies(arm.model()));
    if (variant == 2) {
      std::vector<bool> locked(9, false);
      locked[3] = true;
      arm.setLockedJoints(locked);
    }
    if (variant == 3) {
      arm.setJointModel(1, rb::JointModel::kArmature, 0.4);
      arm.setJointModel(5, rb::JointModel::kArmature, 0.05);
    }
    for (int trial = 0; trial < 10; ++trial) {
      const ArmMotion motion = randomArmMotion(rng);
      if (variant == 1) {
        arm.setGravityCompensation(g);
      } else {
        arm.setLoads(motion.tau, g);
      }
      arm.setState(motion.q, motion.qdot);
      const VectorXd expected = arm.freeAcceleration();
      rb::ArticulatedBody flight = arm;
      flight.setFlightState(motion.q, motion.qdot, Eigen::Isometry3d::Identity());
      const VectorXd vdot = flight.flightAcceleration();
      ASSERT_EQ(vdot.size(), expected.size());
      EXPECT_LE((vdot - expected).cwiseAbs().maxCoeff(),
                1e-10 * (1.0 + expected.cwiseAbs().maxCoeff()))
          << "variant " << variant << " trial " << trial;
    }
  }
}
