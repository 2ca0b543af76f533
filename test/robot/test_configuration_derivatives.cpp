// The robot's configuration derivatives (robot/configuration_derivatives.h) against central
// differences of the robot's own maps (J(p) x, the point's velocity, J(p)^T F, M(q) x) with the
// coordinate's joint moved by setState(): fixed and floating bases, a locked joint, prismatic
// joints and a mimic joint with a multiplier other than 1.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "collision_response/robot/articulated_body.h"
#include "collision_response/robot/configuration_derivatives.h"
#include "collision_response/robot/urdf_loader.h"

namespace rb = collision_response::robot;
using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::VectorXd;

namespace {

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

struct Case {
  rb::ArticulatedBody body;
  VectorXd q, qdot;
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  Vector3d base_v = Vector3d::Zero(), base_w = Vector3d::Zero();
  void set(const VectorXd& at) { body.setState(at, qdot, base, base_v, base_w); }
};

// Every map of the header against central differences (step 1e-6 rad | m) at a link and point;
// returns the largest derivative of the point's velocity and of M x (to show they are not all 0).
double checkAgainstDifferences(Case& c, int link, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  c.set(c.q);
  const int n = c.body.velocityCount();
  VectorXd x(n);
  for (int i = 0; i < n; ++i) x(i) = u(rng);
  const Vector3d p = c.body.linkPose(link) * Vector3d(u(rng) * 0.05, u(rng) * 0.05, u(rng) * 0.05);
  const Vector3d F(u(rng), u(rng), u(rng));
  const std::vector<int> joints = rb::configurationJoints(c.body.model());
  const auto& model = c.body.model();
  const auto& data = c.body.data();
  const Eigen::Matrix<double, 3, Eigen::Dynamic> dJx =
      rb::jacobianProductByConfiguration(model, data, link, p, x);
  const Eigen::Matrix<double, 3, Eigen::Dynamic> dv =
      rb::pointVelocityByConfiguration(model, data, link, p);
  const MatrixXd dJtF = rb::jacobianTransposeProductByConfiguration(model, data, link, p, F);
  const MatrixXd dMx = rb::massMatrixProductByConfiguration(model, data, x);
  EXPECT_EQ(dJx.cols(), static_cast<Eigen::Index>(joints.size()));
  EXPECT_EQ(dMx.rows(), n);
  if (dJx.cols() != static_cast<Eigen::Index>(joints.size()) || dMx.rows() != n) return 0.0;
  double largest = 0.0;
  for (std::size_t k = 0; k < joints.size(); ++k) {
    const double h = 1e-6;
    VectorXd plus = c.q, minus = c.q;
    plus(joints[k]) += h;
    minus(joints[k]) -= h;
    struct Maps {
      Vector3d Jx, v;
      VectorXd JtF, Mx;
    };
    const auto maps = [&](const VectorXd& at) {
      c.set(at);
      const Eigen::Matrix<double, 3, Eigen::Dynamic> J = c.body.linkPointJacobian(link, p);
      return Maps{J * x, c.body.partPointVelocity(link, p), J.transpose() * F,
                  c.body.massMatrix() * x};
    };
    const Maps a = maps(plus), b = maps(minus);
    const auto col = static_cast<Eigen::Index>(k);
    const Vector3d want_Jx = (a.Jx - b.Jx) / (2 * h), want_v = (a.v - b.v) / (2 * h);
    const VectorXd want_JtF = (a.JtF - b.JtF) / (2 * h), want_Mx = (a.Mx - b.Mx) / (2 * h);
    largest = std::max({largest, want_Jx.norm(), want_v.norm(), want_Mx.norm()});
    const double tol = 1e-7;
    EXPECT_LE((dJx.col(col) - want_Jx).norm(), tol * std::max(1.0, want_Jx.norm())) << "k " << k;
    EXPECT_LE((dv.col(col) - want_v).norm(), tol * std::max(1.0, want_v.norm())) << "k " << k;
    EXPECT_LE((dJtF.col(col) - want_JtF).norm(), tol * std::max(1.0, want_JtF.norm()))
        << "k " << k << "\n"
        << dJtF.col(col).transpose() << "\n"
        << want_JtF.transpose();
    EXPECT_LE((dMx.col(col) - want_Mx).norm(), tol * std::max(1.0, want_Mx.norm()))
        << "k " << k << "\n"
        << dMx.col(col).transpose() << "\n"
        << want_Mx.transpose();
  }
  c.set(c.q);
  return largest;
}

VectorXd random(int n, double scale, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-scale, scale);
  VectorXd v(n);
  for (int i = 0; i < n; ++i) v(i) = u(rng);
  return v;
}

}  // namespace

TEST(ConfigurationDerivatives, ArmOnAFixedBaseWithALockedJoint) {
  std::mt19937 rng(7);
  Case c{rb::robotFromUrdfFile(ARM7_URDF), {}, {}};
  const int joints = c.body.jointCount();
  std::vector<bool> locked(joints, false);
  locked[2] = true;  // a locked joint still moves the links below it when its position changes
  c.body.setLockedJoints(locked);
  for (int trial = 0; trial < 5; ++trial) {
    c.q = random(joints, 1.5, rng);
    c.qdot = random(joints, 1.0, rng);
    c.base = Eigen::Translation3d(0.1, -0.2, 0.3) * Eigen::AngleAxisd(0.4, Vector3d::UnitZ());
    double largest = checkAgainstDifferences(c, c.body.linkCount() - 1, rng);
    for (int link = 1; link < c.body.linkCount(); link += 3)
      largest = std::max(largest, checkAgainstDifferences(c, link, rng));
    EXPECT_GT(largest, 0.1);  // the configuration matters here
  }
}

TEST(ConfigurationDerivatives, ArmOnAFloatingBase) {
  std::mt19937 rng(11);
  Case c{rb::robotFromUrdfFile(ARM7_URDF, rb::BaseType::kFloating), {}, {}};
  const int joints = c.body.jointCount();
  for (int trial = 0; trial < 5; ++trial) {
    c.q = random(joints, 1.5, rng);
    c.qdot = random(joints, 1.0, rng);
    c.base = Eigen::Translation3d(0.3, 0.1, -0.2) *
             Eigen::AngleAxisd(1.1, Vector3d(1, 2, 3).normalized());
    c.base_v = Vector3d(0.2, -0.1, 0.4);
    c.base_w = Vector3d(-0.3, 0.5, 0.2);
    EXPECT_GT(checkAgainstDifferences(c, c.body.linkCount() - 1, rng), 0.1);
    checkAgainstDifferences(c, 2, rng);
  }
}

// gripper.urdf with finger2_joint mimicking finger1_joint at multiplier -0.7 and offset 0.01
// (prismatic fingers on a revolute wrist): a coordinate moves its follower by its multiplier.
TEST(ConfigurationDerivatives, MimicGripperWithAMultiplier) {
  std::string xml = readFile(std::string(ROBOT_TEST_DIR) + "/gripper.urdf");
  const std::string mimic = "multiplier=\"1\" offset=\"0\"";
  const std::size_t at = xml.find(mimic);
  ASSERT_NE(at, std::string::npos);
  xml.replace(at, mimic.size(), "multiplier=\"-0.7\" offset=\"0.01\"");
  for (const rb::BaseType base : {rb::BaseType::kFixed, rb::BaseType::kFloating}) {
    std::mt19937 rng(3);
    Case c{rb::robotFromUrdfString(xml, base), {}, {}};
    ASSERT_TRUE(c.body.hasMimicJoints());
    ASSERT_EQ(rb::configurationJoints(c.body.model()).size(), 2u);
    for (int trial = 0; trial < 5; ++trial) {
      c.q = random(c.body.jointCount(), 0.5, rng);
      c.qdot = random(c.body.jointCount(), 1.0, rng);
      c.base_w = base == rb::BaseType::kFloating ? Vector3d(0.2, 0.1, -0.3) : Vector3d::Zero();
      double largest = 0.0;
      for (int link = 1; link < c.body.linkCount(); ++link)
        largest = std::max(largest, checkAgainstDifferences(c, link, rng));
      EXPECT_GT(largest, 1e-3);  // a small gripper: centimetres, grams
    }
  }
}

// The arm with joint5 following joint2 (multiplier -0.7, offset 0.1: root and follower on one
// path, so that a derivative carries both multipliers), its group free or locked, fixed and
// floating bases.
TEST(ConfigurationDerivatives, ArmWithAMimicOnTheSamePath) {
  std::mt19937 rng(13);
  for (const rb::BaseType base : {rb::BaseType::kFixed, rb::BaseType::kFloating}) {
    for (const bool lock_root : {false, true}) {
      Case c{rb::robotFromUrdfFile(ARM7_URDF, base), {}, {}};
      c.body.setMimicJoints({{"joint5", "joint2", -0.7, 0.1}});
      const int joints = c.body.jointCount();
      ASSERT_EQ(rb::configurationJoints(c.body.model()).size(),
                static_cast<std::size_t>(joints - 1));
      if (lock_root) {
        std::vector<bool> locked(joints, false);
        locked[c.body.jointIndex("joint2")] = true;
        c.body.setLockedJoints(locked);
      }
      for (int trial = 0; trial < 3; ++trial) {
        c.q = random(joints, 1.5, rng);
        c.qdot = random(joints, 1.0, rng);
        c.base_w = base == rb::BaseType::kFloating ? Vector3d(0.1, -0.2, 0.3) : Vector3d::Zero();
        double largest = checkAgainstDifferences(c, c.body.linkCount() - 1, rng);
        largest = std::max(largest, checkAgainstDifferences(c, c.body.linkIndex("link6"), rng));
        EXPECT_GT(largest, 0.1);
      }
    }
  }
}
