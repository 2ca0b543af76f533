// Mimic joints (URDF <mimic>, docs/robots.md, "Mimic joints") against references that do not use
// the mimic code: the same mechanism without the couplings (every joint free: its M and J are
// tested against KDL in test_articulated_body.cpp) reduced by hand here, q_all = T v + c, with
// M_red = T^T M T and J_red = J T solved by a BodyModel written in this file; momentum
// conservation; the exact coupling of the fingers after a strike; a symmetric squeeze, which the
// uncoupled gripper answers with the coupling already satisfied; equivalent descriptions of one
// mechanism (multiplier -1 on a flipped axis, offsets on a shifted origin, a chain against its
// resolved mimic); locks, armature and the errors that name the joint.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "collision_response/core/body_response.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/robot/articulated_body.h"
#include "collision_response/robot/urdf_loader.h"

namespace cr = collision_response::core;
namespace rb = collision_response::robot;
using Eigen::Matrix3d;
using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::VectorXd;

namespace {

const std::string kDir = ROBOT_TEST_DIR;
const std::string kArm7 = ARM7_URDF;  // the shipped arm, urdf/arm7.urdf (no mimic joints)

std::string readFile(const std::string& path) {
  std::ifstream file(path);
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

// `urdf` with `xml` added as the last element of joint `joint`.
std::string withElement(std::string urdf, const std::string& joint, const std::string& xml) {
  const std::size_t start = urdf.find("<joint name=\"" + joint + "\"");
  EXPECT_NE(start, std::string::npos) << joint;
  const std::size_t end = urdf.find("</joint>", start);
  urdf.insert(end, xml + "\n  ");
  return urdf;
}
std::string withoutMimics(const std::string& urdf) {
  return std::regex_replace(urdf, std::regex("<mimic[^>]*/>"), "");
}
std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

// A free solid sphere of mass ms and radius R, centre c, velocity v: I = 2/5 ms R^2.
cr::RigidBody sphere(double ms, double R, const Vector3d& c, const Vector3d& v) {
  cr::RigidBody out;
  out.inverse_mass = 1.0 / ms;
  out.inverse_inertia = Matrix3d::Identity() / (0.4 * ms * R * R);
  out.com = c;
  out.linear_velocity = v;
  return out;
}

// The coupling written by hand: joint -> (its independent joint, multiplier, offset), so that
// q_joint = multiplier q_root + offset. Joints not listed are independent.
struct Coupling {
  std::string root;
  double multiplier, offset;
};
using Couplings = std::map<std::string, Coupling>;

// The reference: the uncoupled robot `all` (every joint free, no <mimic>) restricted by hand to
// the reduced velocities v (base twist if floating, then the independent joints in joint order):
// v_all = T v, q_all = positions derived by the hand-written couplings. M_red = T^T M_all T and
// J_red = J_all T; M_red^-1 by Eigen's LDLT (not the robot's Cholesky).
class HandReducedRobot final : public cr::BodyModel {
 public:
  HandReducedRobot(rb::ArticulatedBody all, const Couplings& couplings)
      : all_(std::move(all)), couplings_(couplings) {
    const int base = all_.baseType() == rb::BaseType::kFloating ? 6 : 0;
    std::vector<int> column(all_.jointCount(), -1);
    int n = base;
    for (int j = 0; j < all_.jointCount(); ++j) {
      if (couplings_.count(all_.jointNames()[j]) == 0) column[j] = n++;
    }
    T_ = MatrixXd::Zero(base + all_.jointCount(), n);
    for (int b = 0; b < base; ++b) T_(b, b) = 1.0;
    for (int j = 0; j < all_.jointCount(); ++j) {
      const auto it = couplings_.find(all_.jointNames()[j]);
      if (it == couplings_.end()) {
        T_(base + j, column[j]) = 1.0;
      } else {
        T_(base + j, column[all_.jointIndex(it->second.root)]) = it->second.multiplier;
      }
    }
    v_ = VectorXd::Zero(n);
  }
  // The state: independent joints' q and qdot from `q`, `qdot` (jointCount() entries; the coupled
  // ones are derived here), base pose and twist.
  void setState(const VectorXd& q, const VectorXd& qdot, const Eigen::Isometry3d& pose,
                const Vector3d& base_v = Vector3d::Zero(),
                const Vector3d& base_w = Vector3d::Zero()) {
    q_ = q;
    for (int j = 0; j < all_.jointCount(); ++j) {
      const auto it = couplings_.find(all_.jointNames()[j]);
      if (it != couplings_.end())
        q_(j) = it->second.multiplier * q(all_.jointIndex(it->second.root)) + it->second.offset;
    }
    pose_ = pose;
    const int base = T_.rows() - all_.jointCount();
    if (base == 6) v_ << base_v, base_w;
    for (int k = base; k < T_.cols(); ++k) {
      for (int j = 0; j < all_.jointCount(); ++j) {
        if (T_(base + j, k) == 1.0 && couplings_.count(all_.jointNames()[j]) == 0) v_(k) = qdot(j);
      }
    }
    sync();
  }
  const rb::ArticulatedBody& all() const { return all_; }
  const MatrixXd& T() const { return T_; }
  MatrixXd reducedMass() const { return T_.transpose() * all_.massMatrix() * T_; }

  int velocityCount() const override { return static_cast<int>(v_.size()); }
  VectorXd velocity() const override { return v_; }
  Vector3d materialPointVelocity(const Vector3d& p) const override {
    return partPointVelocity(-1, p);
  }
  Eigen::Matrix<double, 3, Eigen::Dynamic> pointJacobian(const Vector3d& p) const override {
    return partPointJacobian(-1, p);
  }
  Eigen::Matrix<double, Eigen::Dynamic, 3> inverseMassJacobianTranspose(
      const Vector3d& p) const override {
    return partInverseMassJacobianTranspose(-1, p);
  }
  void addVelocityChange(const Eigen::Ref<const VectorXd>& change) override {
    v_ += change;
    sync();
  }
  Vector3d partPointVelocity(int part, const Vector3d& p) const override {
    return all_.partPointVelocity(part, p);
  }
  Eigen::Matrix<double, 3, Eigen::Dynamic> partPointJacobian(int part,
                                                             const Vector3d& p) const override {
    return all_.partPointJacobian(part, p) * T_;
  }
  Eigen::Matrix<double, Eigen::Dynamic, 3> partInverseMassJacobianTranspose(
      int part, const Vector3d& p) const override {
    return reducedMass().ldlt().solve(partPointJacobian(part, p).transpose());
  }

 private:
  void sync() {
    const VectorXd v_all = T_ * v_;
    const int base = T_.rows() - all_.jointCount();
    Vector3d base_v = Vector3d::Zero(), base_w = Vector3d::Zero();
    if (base == 6) {
      base_v = v_all.head<3>();
      base_w = v_all.segment<3>(3);
    }
    all_.setState(q_, v_all.tail(all_.jointCount()), pose_, base_v, base_w);
  }
  rb::ArticulatedBody all_;
  Couplings couplings_;
  MatrixXd T_;
  VectorXd q_, v_;
  Eigen::Isometry3d pose_ = Eigen::Isometry3d::Identity();
};

// The arm with its gripper coupled: right_finger_joint follows left_finger_joint (multiplier
// -1.5, offset 0.01 m), and in `chain` joint7 follows right_finger_joint in turn (4 rad/m, offset
// 0.2 rad): joint7 = 4 (-1.5 q_left + 0.01) + 0.2 = -6 q_left + 0.24 (by hand). joint7 is an
// ancestor of both fingers: one unknown moves links on one path twice.
std::string coupledArm(bool chain) {
  std::string urdf =
      withElement(readFile(kArm7), "right_finger_joint",
                  R"(<mimic joint="left_finger_joint" multiplier="-1.5" offset="0.01"/>)");
  if (chain) {
    urdf = withElement(urdf, "joint7",
                       R"(<mimic joint="right_finger_joint" multiplier="4" offset="0.2"/>)");
  }
  return urdf;
}
Couplings coupledArmByHand(bool chain) {
  Couplings out = {{"right_finger_joint", {"left_finger_joint", -1.5, 0.01}}};
  if (chain) out["joint7"] = {"left_finger_joint", -6.0, 0.24};
  return out;
}

double maxAbs(const MatrixXd& m) {
  return m.size() == 0 ? 0.0 : m.cwiseAbs().maxCoeff();
}

}  // namespace

// M, J, h and the free acceleration of the coupled arm equal the hand-reduced ones, and a
// frictional strike on the follower finger (Stronge; Newton with link3 too) gives the same joint
// velocities as the hand-reduced robot; the coupled joints' velocities are their roots' times the
// multiplier to round-off. Fixed and floating base, one coupling and a chain.
TEST(MimicJoints, CoupledArmEqualsTheHandReducedMechanism) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (const bool chain : {false, true}) {
    for (const rb::BaseType base : {rb::BaseType::kFixed, rb::BaseType::kFloating}) {
      const std::string urdf = coupledArm(chain);
      rb::ArticulatedBody arm = rb::robotFromUrdfString(urdf, base);
      HandReducedRobot reference(rb::robotFromUrdfString(withoutMimics(urdf), base),
                                 coupledArmByHand(chain));
      ASSERT_FALSE(reference.all().hasMimicJoints());
      ASSERT_TRUE(arm.hasMimicJoints());
      const int follower = arm.jointIndex("right_finger_joint");
      const int leader = arm.jointIndex("left_finger_joint");
      ASSERT_EQ(arm.velocityCount(), reference.velocityCount());
      for (int trial = 0; trial < 6; ++trial) {
        VectorXd q(9), qdot(9);
        for (int i = 0; i < 9; ++i) {
          q(i) = 2 * u(rng);
          qdot(i) = u(rng);
        }
        q(leader) = 0.02 + 0.01 * u(rng);
        qdot(follower) = 7.0;  // not used: derived from the leader
        Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
        pose.linear() =
            Eigen::AngleAxisd(u(rng), Vector3d(u(rng), 1, u(rng)).normalized()).matrix();
        pose.translation() = Vector3d(u(rng), u(rng), u(rng));
        const Vector3d bv(u(rng), u(rng), u(rng)), bw(u(rng), u(rng), u(rng));
        arm.setState(q, qdot, pose, bv, bw);
        reference.setState(q, qdot, pose, bv, bw);
        const std::string at = std::string(chain ? "chain" : "one") + " base " +
                               std::to_string(static_cast<int>(base)) + " trial " +
                               std::to_string(trial);
        // The derived state.
        EXPECT_NEAR(arm.jointPositions()(follower), -1.5 * q(leader) + 0.01, 1e-15) << at;
        EXPECT_EQ(arm.jointVelocities()(follower), -1.5 * qdot(leader)) << at;
        EXPECT_LE(maxAbs(arm.jointPositions() - reference.all().jointPositions()), 1e-15) << at;
        EXPECT_LE(maxAbs(arm.jointVelocities() - reference.all().jointVelocities()), 1e-15) << at;
        // M, J, kinetic energy.
        const MatrixXd M = reference.reducedMass();
        EXPECT_LE(maxAbs(arm.massMatrix() - M), 1e-13 * maxAbs(M)) << at << "\n"
                                                                   << arm.massMatrix() << "\n"
                                                                   << M;
        for (const char* link : {"right_finger", "left_finger", "link7", "hand", "link3"}) {
          const Vector3d p = arm.linkPose(arm.linkIndex(link)) * Vector3d(0.01, -0.02, 0.03);
          const MatrixXd J = arm.linkPointJacobian(arm.linkIndex(link), p);
          const MatrixXd J_ref = reference.partPointJacobian(arm.linkIndex(link), p);
          EXPECT_LE(maxAbs(J - J_ref), 1e-14) << at << " " << link;
        }
        EXPECT_NEAR(arm.kineticEnergy(), 0.5 * arm.velocity().dot(M * arm.velocity()),
                    1e-12 * arm.kineticEnergy())
            << at;
        // Loads: h_red = T^T h_all, vdot = M_red^-1 T^T (tau - h_all) with the full robot's h.
        VectorXd tau(9);
        for (int i = 0; i < 9; ++i) tau(i) = 3 * u(rng);
        const Vector3d g(0.5, -1.0, -9.81);
        arm.setLoads(tau, g);
        rb::ArticulatedBody all = reference.all();
        all.setLoads(tau, g);
        const int b = base == rb::BaseType::kFloating ? 6 : 0;
        VectorXd tau_all = VectorXd::Zero(b + 9);
        tau_all.tail(9) = tau;
        const MatrixXd& T = reference.T();
        EXPECT_LE(maxAbs(arm.biasForces() - T.transpose() * all.biasForces()),
                  1e-12 * (1 + maxAbs(all.biasForces())))
            << at;
        const VectorXd vdot = M.ldlt().solve(T.transpose() * (tau_all - all.biasForces()));
        EXPECT_LE(maxAbs(arm.freeAcceleration() - vdot), 1e-9 * (1 + maxAbs(vdot))) << at;

        // A 0.3 kg sphere strikes the follower finger (and link3, Newton), friction, e = 0.5.
        const Vector3d finger =
            arm.linkPose(arm.linkIndex("right_finger")) * Vector3d(0, -0.01, 0.03);
        const Vector3d elbow = arm.linkPose(arm.linkIndex("link3")) * Vector3d(0.05, 0, 0.1);
        const Vector3d n = Vector3d(u(rng), u(rng), 1).normalized();
        for (const cr::ImpactLaw law : {cr::ImpactLaw::kNewton, cr::ImpactLaw::kStronge}) {
          rb::ArticulatedBody struck = arm;
          HandReducedRobot struck_ref = reference;
          cr::RigidBody ball =
              sphere(0.3, 0.05, finger + 0.05 * n,
                     arm.partPointVelocity(arm.linkIndex("right_finger"), finger) - 4.0 * n);
          cr::RigidBody ball_ref = ball;
          std::vector<cr::ContactPoint> contacts = {
              cr::ContactPoint(0, 1, finger, n, 0.5, 0.6, 0.4),
              cr::ContactPoint(0, 1, elbow, n, 0.5, 0.6, 0.4)};
          contacts[0].part_a = arm.linkIndex("right_finger");
          contacts[1].part_a = arm.linkIndex("link3");
          // Stronge on the finger alone: two contacts go through the simultaneous integration,
          // whose default rule resolves equal problems only to ~1e-3 here (its chatter where
          // friction makes the compression problem infeasible; W is not ill-conditioned). Two
          // contacts: TwoContactsEqualTheHandReducedMechanism, below.
          if (law == cr::ImpactLaw::kStronge) contacts.pop_back();
          cr::SolverOptions options;
          options.law = law;
          options.integration_tolerance = 1e-12;
          const cr::BodyResponse out = cr::computeBodyResponse({&struck, &ball}, contacts, options);
          const cr::BodyResponse ref =
              cr::computeBodyResponse({&struck_ref, &ball_ref}, contacts, options);
          ASSERT_GT(out.impulses[0].normal_impulse + out.impulses.back().normal_impulse, 0.0) << at;
          const VectorXd& v_ref = struck_ref.all().jointVelocities();
          EXPECT_LE(maxAbs(struck.jointVelocities() - v_ref), 1e-8 * (1 + maxAbs(v_ref)))
              << at << " law " << static_cast<int>(law) << "\n"
              << struck.jointVelocities().transpose() << "\n"
              << v_ref.transpose();
          EXPECT_LE((ball.linear_velocity - ball_ref.linear_velocity).norm(), 1e-8) << at;
          EXPECT_EQ(struck.jointVelocities()(follower), -1.5 * struck.jointVelocities()(leader));
          if (chain) {
            EXPECT_EQ(struck.jointVelocities()(struck.jointIndex("joint7")),
                      -6.0 * struck.jointVelocities()(leader));
          }
        }
      }
    }
  }
}

// Two contacts, the follower finger and the hand or link3 (one sphere against both, friction,
// e = 0.5), in the states of the test above: the coupled arm and the hand-reduced one give the same
// joint and sphere velocities under Newton (exact solver), the two-phase scheme (Stronge, Poisson)
// and the simultaneous integration's spring rule. Not under its velocity-consistent rule, the
// default: where friction makes its compression problem infeasible it chatters between that
// problem and its frictionless fallback, step by step, and equal problems then differ by up to
// ~1e-3 (docs/physics.md, "Simultaneous impulse-space integration", "Resolution").
TEST(MimicJoints, TwoContactsEqualTheHandReducedMechanism) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  struct Scheme {
    const char* name;
    cr::ImpactLaw law;
    bool simultaneous;
    cr::SimultaneousSharing sharing;
  };
  const Scheme schemes[] = {
      {"newton", cr::ImpactLaw::kNewton, true, cr::SimultaneousSharing::kVelocityConsistent},
      {"stronge two-phase", cr::ImpactLaw::kStronge, false,
       cr::SimultaneousSharing::kVelocityConsistent},
      {"poisson two-phase", cr::ImpactLaw::kPoisson, false,
       cr::SimultaneousSharing::kVelocityConsistent},
      {"stronge spring", cr::ImpactLaw::kStronge, true, cr::SimultaneousSharing::kSpring}};
  for (const bool chain : {false, true}) {
    for (const rb::BaseType base : {rb::BaseType::kFixed, rb::BaseType::kFloating}) {
      const std::string urdf = coupledArm(chain);
      rb::ArticulatedBody arm = rb::robotFromUrdfString(urdf, base);
      HandReducedRobot reference(rb::robotFromUrdfString(withoutMimics(urdf), base),
                                 coupledArmByHand(chain));
      const int follower = arm.jointIndex("right_finger_joint");
      const int leader = arm.jointIndex("left_finger_joint");
      for (int trial = 0; trial < 6; ++trial) {
        // The draws of the test above, in its order (its loads included).
        VectorXd q(9), qdot(9);
        for (int i = 0; i < 9; ++i) {
          q(i) = 2 * u(rng);
          qdot(i) = u(rng);
        }
        q(leader) = 0.02 + 0.01 * u(rng);
        qdot(follower) = 7.0;
        Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
        pose.linear() =
            Eigen::AngleAxisd(u(rng), Vector3d(u(rng), 1, u(rng)).normalized()).matrix();
        pose.translation() = Vector3d(u(rng), u(rng), u(rng));
        const Vector3d bv(u(rng), u(rng), u(rng)), bw(u(rng), u(rng), u(rng));
        arm.setState(q, qdot, pose, bv, bw);
        reference.setState(q, qdot, pose, bv, bw);
        for (int i = 0; i < 9; ++i) u(rng);  // the loads
        const int finger_link = arm.linkIndex("right_finger");
        const Vector3d finger = arm.linkPose(finger_link) * Vector3d(0, -0.01, 0.03);
        const Vector3d elbow = arm.linkPose(arm.linkIndex("link3")) * Vector3d(0.05, 0, 0.1);
        const Vector3d hand = arm.linkPose(arm.linkIndex("hand")) * Vector3d(0.02, 0.01, 0.0);
        const Vector3d n = Vector3d(u(rng), u(rng), 1).normalized();
        for (const char* second : {"link3", "hand"}) {
          for (const Scheme& scheme : schemes) {
            const std::string at = std::string(chain ? "chain" : "one") + " base " +
                                   std::to_string(static_cast<int>(base)) + " trial " +
                                   std::to_string(trial) + " " + second + " " + scheme.name;
            rb::ArticulatedBody struck = arm;
            HandReducedRobot struck_ref = reference;
            cr::RigidBody ball = sphere(0.3, 0.05, finger + 0.05 * n,
                                        arm.partPointVelocity(finger_link, finger) - 4.0 * n);
            cr::RigidBody ball_ref = ball;
            std::vector<cr::ContactPoint> contacts = {
                cr::ContactPoint(0, 1, finger, n, 0.5, 0.6, 0.4),
                cr::ContactPoint(0, 1, std::string(second) == "hand" ? hand : elbow, n, 0.5, 0.6,
                                 0.4)};
            contacts[0].part_a = finger_link;
            contacts[1].part_a = arm.linkIndex(second);
            cr::SolverOptions options;
            options.law = scheme.law;
            options.simultaneous_impulse_space = scheme.simultaneous;
            options.simultaneous_sharing = scheme.sharing;
            const cr::BodyResponse out =
                cr::computeBodyResponse({&struck, &ball}, contacts, options);
            const cr::BodyResponse ref =
                cr::computeBodyResponse({&struck_ref, &ball_ref}, contacts, options);
            ASSERT_EQ(out.islands.size(), 1u) << at;
            EXPECT_EQ(out.islands[0].methodName(), ref.islands[0].methodName()) << at;
            const VectorXd& v_ref = struck_ref.all().jointVelocities();
            EXPECT_LE(maxAbs(struck.jointVelocities() - v_ref), 1e-8 * (1 + maxAbs(v_ref)))
                << at << "\n"
                << struck.jointVelocities().transpose() << "\n"
                << v_ref.transpose();
            EXPECT_LE((ball.linear_velocity - ball_ref.linear_velocity).norm(), 1e-8) << at;
            for (int c = 0; c < 2; ++c) {
              EXPECT_NEAR(out.impulses[c].normal_impulse, ref.impulses[c].normal_impulse, 1e-8)
                  << at << " contact " << c;
            }
          }
        }
      }
    }
  }
}

// A chain resolves to its root with the multipliers multiplied and the offsets composed: the arm
// whose joint7 follows right_finger_joint, which follows left_finger_joint, is the arm whose joint7
// follows left_finger_joint directly with -6 and 0.24 (by hand above).
TEST(MimicJoints, AChainIsItsResolvedMimic) {
  rb::ArticulatedBody chain = rb::robotFromUrdfString(coupledArm(true));
  const std::string direct_urdf = withElement(
      withElement(readFile(kArm7), "right_finger_joint",
                  R"(<mimic joint="left_finger_joint" multiplier="-1.5" offset="0.01"/>)"),
      "joint7", R"(<mimic joint="left_finger_joint" multiplier="-6" offset="0.24"/>)");
  rb::ArticulatedBody direct = rb::robotFromUrdfString(direct_urdf);
  const int j7 = chain.jointIndex("joint7");
  EXPECT_EQ(chain.mimicRoot(j7), chain.jointIndex("left_finger_joint"));
  EXPECT_DOUBLE_EQ(chain.mimicMultiplier(j7), -6.0);
  EXPECT_DOUBLE_EQ(chain.mimicOffset(j7), 0.24);
  EXPECT_EQ(chain.velocityCount(), 7);
  VectorXd q(9), qdot(9);
  q << 0.3, -0.7, 0.5, 1.1, -0.4, 0.8, 0.0, 0.025, 0.0;
  qdot << 0.2, -0.1, 0.4, 0.3, -0.6, 0.5, 0.0, -0.05, 0.0;
  chain.setState(q, qdot);
  direct.setState(q, qdot);
  EXPECT_NEAR(chain.jointPositions()(j7), -6.0 * 0.025 + 0.24, 1e-15);
  EXPECT_LE(maxAbs(chain.massMatrix() - direct.massMatrix()), 1e-14);
  EXPECT_LE(maxAbs(chain.jointVelocities() - direct.jointVelocities()), 1e-15);
}

// The gripper of gripper.urdf on a floating base, in random states, struck by a sphere on one
// finger (the leader or the follower) with friction: linear and angular momentum of the robot and
// the sphere are conserved, energy does not grow, and the fingers' velocities stay equal (the
// follower's is the leader's times 1, exactly).
TEST(MimicJoints, FloatingGripperConservesMomentumAndKeepsTheFingersCoupled) {
  rb::ArticulatedBody gripper =
      rb::robotFromUrdfFile(kDir + "/gripper.urdf", rb::BaseType::kFloating);
  ASSERT_EQ(gripper.jointCount(), 3);
  ASSERT_EQ(gripper.velocityCount(), 8);  // base 6, wrist, the fingers' one
  const int f1 = gripper.jointIndex("finger1_joint"), f2 = gripper.jointIndex("finger2_joint");
  EXPECT_EQ(gripper.unknownOfJoint(f1), gripper.unknownOfJoint(f2));
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 10; ++trial) {
    const char* finger = trial % 2 == 0 ? "finger1" : "finger2";
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() =
        Eigen::AngleAxisd(2 * u(rng), Vector3d(u(rng), u(rng), 1).normalized()).matrix();
    pose.translation() = Vector3d(u(rng), u(rng), u(rng));
    gripper.setState(Eigen::Vector3d(u(rng), 0.02 + 0.01 * u(rng), 0.0),
                     Eigen::Vector3d(u(rng), 0.1 * u(rng), 0.0), pose,
                     Vector3d(u(rng), u(rng), u(rng)), Vector3d(u(rng), u(rng), u(rng)));
    const Eigen::Isometry3d pad = gripper.linkPose(gripper.linkIndex(finger));
    const double side = trial % 2 == 0 ? 1.0 : -1.0;  // the pad's outer face
    const Vector3d p = pad * Vector3d(0.0, side * 0.01, 0.03);
    const Vector3d n = (pad.linear() * Vector3d(u(rng), side, u(rng))).normalized();
    const double ms = 0.2;
    cr::RigidBody ball = sphere(ms, 0.03, p + 0.03 * n, -3.0 * n);
    const auto momentum = [&] {
      Eigen::Matrix<double, 6, 1> total = gripper.momentum();
      total.head<3>() += ms * ball.linear_velocity;
      total.tail<3>() += ball.com.cross(ms * ball.linear_velocity) +
                         ball.inverse_inertia.inverse() * ball.angular_velocity;
      return total;
    };
    const double energy_before =
        gripper.kineticEnergy() + 0.5 * ms * ball.linear_velocity.squaredNorm();
    const Eigen::Matrix<double, 6, 1> before = momentum();
    cr::ContactPoint contact(0, 1, p, n, 0.6, 0.8, 0.5);
    contact.part_a = gripper.linkIndex(finger);
    cr::SolverOptions options;
    options.law = cr::ImpactLaw::kStronge;
    const cr::BodyResponse out = cr::computeBodyResponse({&gripper, &ball}, {contact}, options);
    ASSERT_GT(out.impulses[0].normal_impulse, 0.0) << trial;
    EXPECT_LE(maxAbs(momentum() - before), 1e-12 * (1 + maxAbs(before))) << trial;
    EXPECT_LE(gripper.kineticEnergy() + 0.5 * ms * ball.linear_velocity.squaredNorm(),
              energy_before * (1 + 1e-12))
        << trial;
    EXPECT_EQ(gripper.jointVelocities()(f2), gripper.jointVelocities()(f1)) << trial;
    EXPECT_EQ(gripper.jointPositions()(f2), gripper.jointPositions()(f1)) << trial;
    EXPECT_GE(out.impulses[0].normal_velocity_after, -1e-9) << trial;
  }
}

// A squeeze that is its own mirror image (gripper.urdf, fixed base, the wrist at rest, the fingers
// closing at 0.1 m/s; two equal spheres approach the pads' outer faces as mirror images in the
// hand's xz plane, friction): the uncoupled gripper (no <mimic>) answers it with both fingers at
// one velocity already, by symmetry, so the coupling carries no impulse and the coupled gripper's
// answer is the same. Its two contacts' impulses are mirror images.
TEST(MimicJoints, SymmetricSqueezeEqualsTheUncoupledGripper) {
  const std::string urdf = readFile(kDir + "/gripper.urdf");
  rb::ArticulatedBody coupled = rb::robotFromUrdfString(urdf);
  rb::ArticulatedBody free_fingers = rb::robotFromUrdfString(withoutMimics(urdf));
  ASSERT_EQ(free_fingers.velocityCount(), 3);
  ASSERT_EQ(coupled.velocityCount(), 2);
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kNewton, cr::ImpactLaw::kStronge}) {
    std::vector<cr::RigidBody> balls;
    std::vector<cr::BodyResponse> outs;
    std::vector<VectorXd> velocities;
    for (rb::ArticulatedBody* robot : {&coupled, &free_fingers}) {
      robot->setState(Vector3d(0.4, 0.015, 0.015), Vector3d(0.0, -0.1, -0.1));
      std::vector<cr::RigidBody> pair;
      std::vector<cr::ContactPoint> contacts;
      for (const double side : {1.0, -1.0}) {
        const char* link = side > 0 ? "finger1" : "finger2";
        const Eigen::Isometry3d pad = robot->linkPose(robot->linkIndex(link));
        const Vector3d p = pad * Vector3d(0.003, side * 0.01, 0.03);
        // Mirror images in the hand's xz plane: y components flip.
        const Vector3d n = pad.linear() * Vector3d(0.2, side, 0.3).normalized();
        pair.push_back(sphere(0.25, 0.02, p + 0.02 * n, -2.0 * n));
        contacts.emplace_back(0, side > 0 ? 1 : 2, p, n, 0.5, 0.7, 0.5);
        contacts.back().part_a = robot->linkIndex(link);
      }
      cr::SolverOptions options;
      options.law = law;
      outs.push_back(cr::computeBodyResponse({robot, &pair[0], &pair[1]}, contacts, options));
      velocities.push_back(robot->jointVelocities());
      balls.insert(balls.end(), pair.begin(), pair.end());
    }
    const VectorXd& coupled_v = velocities[0];
    const VectorXd& free_v = velocities[1];
    // The uncoupled answer keeps the fingers together by symmetry (not forced by any code).
    EXPECT_NEAR(free_v(1), free_v(2), 1e-12);
    EXPECT_NEAR(free_v(0), 0.0, 1e-12);  // and the wrist at rest
    EXPECT_LE(maxAbs(coupled_v - free_v), 1e-10) << coupled_v.transpose() << "\n"
                                                 << free_v.transpose();
    for (int c = 0; c < 2; ++c) {
      EXPECT_NEAR(outs[0].impulses[c].normal_impulse, outs[1].impulses[c].normal_impulse, 1e-10);
      EXPECT_LE((balls[c].linear_velocity - balls[2 + c].linear_velocity).norm(), 1e-10);
    }
    EXPECT_NEAR(outs[0].impulses[0].normal_impulse, outs[0].impulses[1].normal_impulse, 1e-10);
    EXPECT_GT(outs[0].impulses[0].normal_impulse, 0.0);
  }
}

// One mechanism described four ways: finger2 along -y with multiplier 1 (gripper.urdf); along +y
// with multiplier -1; along -y from an origin 5 mm further in with offset 5 mm; along +y from there
// with multiplier -1 and offset -5 mm. Every link is where it was and moves as it did, so an
// off-centre frictional strike on finger2 gives every description the same link velocities; only
// finger2's own coordinate reads differently (q2 = m q1 + o, qdot2 = m qdot1).
TEST(MimicJoints, NegativeMultiplierAndOffsetDescribeTheSameMechanism) {
  const std::string base = readFile(kDir + "/gripper.urdf");
  const std::string origin = R"(<origin xyz="0 -0.01 0.06" rpy="0 0 0"/>
    <axis xyz="0 -1 0"/>)";
  const std::string mimic = R"(<mimic joint="finger1_joint" multiplier="1" offset="0"/>)";
  struct Variant {
    std::string origin_axis, mimic;
    double multiplier, offset;
  };
  const std::vector<Variant> variants = {
      {origin, mimic, 1.0, 0.0},
      {R"(<origin xyz="0 -0.01 0.06" rpy="0 0 0"/>
    <axis xyz="0 1 0"/>)",
       R"(<mimic joint="finger1_joint" multiplier="-1"/>)", -1.0, 0.0},
      {R"(<origin xyz="0 -0.005 0.06" rpy="0 0 0"/>
    <axis xyz="0 -1 0"/>)",
       R"(<mimic joint="finger1_joint" multiplier="1" offset="0.005"/>)", 1.0, 0.005},
      {R"(<origin xyz="0 -0.005 0.06" rpy="0 0 0"/>
    <axis xyz="0 1 0"/>)",
       R"(<mimic joint="finger1_joint" multiplier="-1" offset="-0.005"/>)", -1.0, -0.005}};
  std::vector<rb::ArticulatedBody> robots;
  std::vector<Eigen::Matrix<double, 6, 1>> momenta;
  for (const Variant& variant : variants) {
    rb::ArticulatedBody robot = rb::robotFromUrdfString(
        replaced(replaced(base, origin, variant.origin_axis), mimic, variant.mimic));
    const int f1 = robot.jointIndex("finger1_joint"), f2 = robot.jointIndex("finger2_joint");
    EXPECT_EQ(robot.mimicMultiplier(f2), variant.multiplier);
    EXPECT_EQ(robot.mimicOffset(f2), variant.offset);
    robot.setState(Vector3d(-0.3, 0.012, 0.0), Vector3d(0.8, 0.05, 0.0));
    EXPECT_NEAR(robot.jointPositions()(f2), variant.multiplier * 0.012 + variant.offset, 1e-15);
    const Eigen::Isometry3d pad = robot.linkPose(robot.linkIndex("finger2"));
    const Vector3d p = pad * Vector3d(0.006, -0.01, 0.04);
    const Vector3d n = pad.linear() * Vector3d(0.3, -1.0, -0.2).normalized();
    cr::RigidBody ball = sphere(0.4, 0.02, p + 0.02 * n, -2.5 * n);
    cr::ContactPoint contact(0, 1, p, n, 0.4, 0.6, 0.3);
    contact.part_a = robot.linkIndex("finger2");
    cr::SolverOptions options;
    options.law = cr::ImpactLaw::kStronge;
    cr::computeBodyResponse({&robot, &ball}, {contact}, options);
    EXPECT_EQ(robot.jointVelocities()(f2), variant.multiplier * robot.jointVelocities()(f1));
    momenta.push_back(robot.momentum());
    robots.push_back(std::move(robot));
  }
  for (std::size_t k = 1; k < robots.size(); ++k) {
    EXPECT_LE(maxAbs(momenta[k] - momenta[0]), 1e-10) << k;
    for (int link = 0; link < robots[0].linkCount(); ++link) {
      const Vector3d p = robots[0].linkPose(link) * Vector3d(0.01, 0.02, 0.03);
      EXPECT_LE((robots[k].linkPose(link).matrix() - robots[0].linkPose(link).matrix())
                    .cwiseAbs()
                    .maxCoeff(),
                1e-15)
          << k << " link " << link;
      EXPECT_LE(
          (robots[k].partPointVelocity(link, p) - robots[0].partPointVelocity(link, p)).norm(),
          1e-10)
          << k << " link " << link;
    }
    // The leader's and wrist's velocities are the same numbers in every description.
    EXPECT_NEAR(robots[k].jointVelocities()(0), robots[0].jointVelocities()(0), 1e-10);
    EXPECT_NEAR(robots[k].jointVelocities()(1), robots[0].jointVelocities()(1), 1e-10);
  }
}

// Locks: locking the leader locks its mimic (no unknown for either; a strike on the follower's pad
// leaves both fingers as they were); locking the follower (multiplier 1) locks the leader too.
// Armature on a follower adds multiplier^2 I_a to its root's diagonal.
TEST(MimicJoints, LocksAndArmature) {
  rb::ArticulatedBody gripper = rb::robotFromUrdfFile(kDir + "/gripper.urdf");
  const int f1 = gripper.jointIndex("finger1_joint"), f2 = gripper.jointIndex("finger2_joint");
  for (const int lock : {f1, f2}) {
    rb::ArticulatedBody robot = gripper;
    robot.setJointModel(lock, rb::JointModel::kLocked);
    EXPECT_EQ(robot.velocityCount(), 1);
    EXPECT_TRUE(robot.isLocked(f1));
    EXPECT_TRUE(robot.isLocked(f2));
    robot.setState(Vector3d(0.2, 0.01, 0.0), Vector3d(0.5, 0.03, 0.0));
    const Eigen::Isometry3d pad = robot.linkPose(robot.linkIndex("finger2"));
    const Vector3d p = pad * Vector3d(0.008, -0.01, 0.03);  // off the wrist's axis
    const Vector3d n = -pad.linear().col(1);                // the pad's outer normal
    cr::RigidBody ball = sphere(0.3, 0.02, p + 0.02 * n, -3.0 * n);
    cr::ContactPoint contact(0, 1, p, n, 0.5, 0.0, 0.0);
    contact.part_a = robot.linkIndex("finger2");
    cr::computeBodyResponse({&robot, &ball}, {contact});
    EXPECT_EQ(robot.jointVelocities()(f1), 0.03);
    EXPECT_EQ(robot.jointVelocities()(f2), 0.03);
    EXPECT_NE(robot.jointVelocities()(0), 0.5);  // the wrist took the impulse
  }
  rb::ArticulatedBody arm = rb::robotFromUrdfString(coupledArm(false));
  rb::ArticulatedBody with_armature = arm;
  with_armature.setJointModel(arm.jointIndex("right_finger_joint"), rb::JointModel::kArmature, 0.2);
  const int u = arm.unknownOfJoint(arm.jointIndex("left_finger_joint"));
  MatrixXd added = with_armature.massMatrix() - arm.massMatrix();
  EXPECT_NEAR(added(u, u), 1.5 * 1.5 * 0.2, 1e-15);
  added(u, u) = 0.0;
  EXPECT_EQ(maxAbs(added), 0.0);
}

// Errors name the joint: a leader that does not exist (or has no coordinate), a cycle, a <mimic> on
// a joint without a coordinate, a joint with two leaders, a non-finite multiplier.
TEST(MimicJoints, BadMimicsAreRefusedNamingTheJoint) {
  const std::string base = readFile(kDir + "/gripper.urdf");
  const auto expectThrow = [](const std::function<void()>& f, const std::string& text) {
    try {
      f();
      ADD_FAILURE() << "accepted: " << text;
    } catch (const cr::InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
    }
  };
  expectThrow(
      [&] {
        rb::robotFromUrdfString(
            replaced(base, R"(joint="finger1_joint")", R"(joint="thumb_joint")"));
      },
      "URDF: mimic joint 'finger2_joint': its leader 'thumb_joint' is not a joint");
  expectThrow(
      [&] {
        rb::robotFromUrdfString(
            withElement(base, "finger1_joint", R"(<mimic joint="finger2_joint"/>)"));
      },
      "its leaders form a cycle ('finger");
  expectThrow(
      [&] {
        rb::robotFromUrdfString(
            withElement(base, "wrist", R"(<mimic joint="wrist" multiplier="2"/>)"));
      },
      "mimic joint 'wrist': its leaders form a cycle ('wrist' -> 'wrist')");
  // The loader's bounds: a multiplier past 1e6 (the group's inertia would overflow), an offset
  // past 1e7 rad or m, a moving joint's zero axis (KDL would divide by its length).
  expectThrow(
      [&] {
        rb::robotFromUrdfString(
            replaced(base, R"(multiplier="1" offset="0")", R"(multiplier="1e7" offset="0")"));
      },
      "joint 'finger2_joint': <mimic> multiplier must be finite and within 1e6");
  expectThrow(
      [&] {
        rb::robotFromUrdfString(
            replaced(base, R"(multiplier="1" offset="0")", R"(multiplier="1" offset="1e8")"));
      },
      "joint 'finger2_joint': <mimic> multiplier must be finite and within 1e6 in magnitude, "
      "offset finite");
  expectThrow(
      [&] {
        rb::robotFromUrdfString(
            replaced(base, R"(<axis xyz="0 -1 0"/>)", R"(<axis xyz="0 0 0"/>)"));
      },
      "<axis> must not be zero");
  rb::ArticulatedBody gripper = rb::robotFromUrdfString(withoutMimics(base));
  expectThrow(
      [&] {
        gripper.setMimicJoints({{"finger2_joint", "finger1_joint"}, {"finger2_joint", "wrist"}});
      },
      "mimic joint 'finger2_joint': given two leaders");
  expectThrow(
      [&] {
        gripper.setMimicJoints({{"palm_joint", "wrist"}});
      },
      "mimic joint 'palm_joint': the robot has no such joint");
  expectThrow(
      [&] {
        gripper.setMimicJoints({{"finger2_joint", "finger1_joint", std::nan(""), 0.0}});
      },
      "mimic joint 'finger2_joint': its multiplier or offset is not finite");
  // The refused calls left the robot as it was; an empty list removes the couplings.
  EXPECT_FALSE(gripper.hasMimicJoints());
  gripper.setMimicJoints({{"finger2_joint", "finger1_joint", 1.0, 0.0}});
  EXPECT_EQ(gripper.velocityCount(), 2);
  gripper.setMimicJoints({});
  EXPECT_EQ(gripper.velocityCount(), 3);
  EXPECT_FALSE(gripper.hasMimicJoints());
}
