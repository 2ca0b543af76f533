// Safety outputs of robot impacts (docs/robots.md, "Safety outputs"): each side's reflected mass
// along the normal, the approach speed, the transferred energy (core/contact_safety.h), the joints'
// impulses and velocity limits (robot/joint_safety.h), against references computed here: a single
// revolute link in closed form (I / r^2 along the tangent), the shipped arm against KDL's own
// joint-space inertia (ChainDynParam) and a contact Jacobian from finite differences of KDL's
// forward kinematics, two spheres head on, the energy a perfectly inelastic impact dissipates, and
// the URDF's limits read by urdf::Model.
#include <gtest/gtest.h>
#include <urdf/model.h>

#include <cmath>
#include <fstream>
#include <kdl/chain.hpp>
#include <kdl/chaindynparam.hpp>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/jntspaceinertiamatrix.hpp>
#include <kdl/tree.hpp>
#include <kdl_parser/kdl_parser.hpp>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "collision_response/core/body_response.h"
#include "collision_response/core/contact_safety.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/robot/articulated_body.h"
#include "collision_response/robot/joint_safety.h"
#include "collision_response/robot/urdf_loader.h"

namespace cr = collision_response::core;
namespace rb = collision_response::robot;
using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::VectorXd;

namespace {

const std::string kArm7 = ARM7_URDF;  // the shipped arm, urdf/arm7.urdf
constexpr double kInf = std::numeric_limits<double>::infinity();

// One link on a revolute joint about z at the origin: mass m, centre of mass (c, 0, 0), I_zz about
// the centre of mass izz; velocity limit 2 rad/s. About the joint axis I = izz + m c^2.
constexpr double kMass = 3.0, kCom = 0.4, kIzz = 0.05, kLimit = 2.0;
std::string singleLinkUrdf() {
  std::ostringstream xml;
  xml << R"(<robot name="link"><link name="base"/>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity=")"
      << kLimit << R"("/></joint>
  <link name="arm"><inertial><origin xyz=")"
      << kCom << R"( 0 0"/><mass value=")" << kMass
      << R"("/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.05" iyz="0" izz=")" << kIzz
      << R"("/></inertial></link></robot>)";
  return xml.str();
}

cr::RigidBody sphere(double mass, double radius, const Vector3d& centre, const Vector3d& velocity) {
  cr::RigidBody out;
  out.inverse_mass = 1.0 / mass;
  out.inverse_inertia = Eigen::Matrix3d::Identity() / (0.4 * mass * radius * radius);
  out.com = centre;
  out.linear_velocity = velocity;
  return out;
}

double relative(double value, double reference) {
  return std::abs(value - reference) / std::abs(reference);
}

// The arm's chain base_link -> left_finger (7 revolute joints, the hand, one prismatic finger) as
// KDL sees it, with KDL's own solvers for the references: a KDL chain has no branches, so the
// robot under test is the same chain rebuilt as a tree.
struct Arm7Chain {
  KDL::Chain chain;
  std::vector<std::string> joints;  // the chain's joints in its order
  Arm7Chain() {
    KDL::Tree full;
    EXPECT_TRUE(kdl_parser::treeFromFile(kArm7, full));
    EXPECT_TRUE(full.getChain("base_link", "left_finger", chain));
    for (const KDL::Segment& segment : chain.segments)
      if (segment.getJoint().getType() != KDL::Joint::Fixed)
        joints.push_back(segment.getJoint().getName());
  }
  rb::ArticulatedBody robot() const {
    KDL::Tree tree("base_link");
    EXPECT_TRUE(tree.addChain(chain, "base_link"));
    return rb::ArticulatedBody(tree);
  }
  // World position of the point fixed at `local` in segment `name`'s frame, at chain positions q.
  Vector3d point(const VectorXd& q, const std::string& name, const Vector3d& local) const {
    KDL::ChainFkSolverPos_recursive fk(chain);
    KDL::JntArray kq(q.size());
    kq.data = q;
    int segment = -1;
    for (unsigned i = 0; i < chain.getNrOfSegments(); ++i)
      if (chain.getSegment(i).getName() == name) segment = static_cast<int>(i);
    KDL::Frame frame;
    EXPECT_GE(fk.JntToCart(kq, frame, segment + 1), 0);
    const KDL::Vector p = frame * KDL::Vector(local.x(), local.y(), local.z());
    return Vector3d(p.x(), p.y(), p.z());
  }
  // d point / dq by central differences of KDL's forward kinematics (3 x joints, chain order).
  MatrixXd jacobian(const VectorXd& q, const std::string& name, const Vector3d& local) const {
    const double h = 1e-6;
    MatrixXd J(3, q.size());
    for (int k = 0; k < q.size(); ++k) {
      VectorXd plus = q, minus = q;
      plus(k) += h;
      minus(k) -= h;
      J.col(k) = (point(plus, name, local) - point(minus, name, local)) / (2 * h);
    }
    return J;
  }
  // KDL's joint-space inertia (ChainDynParam: its composite-rigid-body method in local frames).
  MatrixXd mass(const VectorXd& q) const {
    KDL::ChainDynParam dynamics(chain, KDL::Vector(0, 0, -9.81));
    KDL::JntArray kq(q.size());
    kq.data = q;
    KDL::JntSpaceInertiaMatrix H(q.size());
    EXPECT_GE(dynamics.JntToMass(kq, H), 0);
    return H.data;
  }
};

}  // namespace

// The single link at angle q: the material point at distance r along it moves along the tangent t
// = (-sin q, cos q, 0) at r qdot, so J n = r (t . n) and n^T J M^-1 J^T n = r^2 (t . n)^2 / I with
// I = izz + m c^2 + I_a about the joint (armature included): I / r^2 along the tangent, I / (r^2
// cos^2 a) at an angle a to it, infinite along the link (radial) or along the axis.
TEST(RobotSafety, RevoluteLinkReflectedMassIsInertiaOverRadiusSquared) {
  const double armature = 0.02;
  const double I = kIzz + kMass * kCom * kCom + armature;
  std::shared_ptr<rb::RobotModel> model = rb::robotModelFromUrdfString(singleLinkUrdf());
  model->setJointModel(0, rb::JointModel::kArmature, armature);
  rb::ArticulatedBody link{std::shared_ptr<const rb::RobotModel>(model)};
  const int part = link.linkIndex("arm");
  for (const double q : {0.0, 0.7, -2.1}) {
    link.setState(VectorXd::Constant(1, q), VectorXd::Zero(1));
    const Vector3d radial(std::cos(q), std::sin(q), 0), tangent(-std::sin(q), std::cos(q), 0);
    for (const double r : {0.3, 0.7, 1.2}) {
      SCOPED_TRACE("q = " + std::to_string(q) + ", r = " + std::to_string(r));
      const Vector3d p = r * radial;
      EXPECT_LE(relative(cr::reflectedMass(link, part, p, tangent), I / (r * r)), 1e-12);
      EXPECT_LE(relative(cr::reflectedMass(link, part, p, -tangent), I / (r * r)), 1e-12);
      const double a = 0.6;
      const Vector3d tilted = std::cos(a) * tangent + std::sin(a) * Vector3d::UnitZ();
      EXPECT_LE(relative(cr::reflectedMass(link, part, p, tilted),
                         I / (r * r * std::cos(a) * std::cos(a))),
                1e-12);
      EXPECT_EQ(cr::reflectedMass(link, part, p, radial), kInf);
      EXPECT_EQ(cr::reflectedMass(link, part, p, Vector3d::UnitZ()), kInf);
    }
  }
}

// The link turning at qdot strikes an immovable wall along the tangent at distance r: the wall's
// mass is infinite, so the reduced mass is the link's reflected mass I / r^2 and the approach speed
// r qdot: the transferred energy is 0.5 (I / r^2) (r qdot)^2 = 0.5 I qdot^2, all the link's kinetic
// energy (rotor included).
TEST(RobotSafety, RevoluteLinkAgainstAWallTransfersItsKineticEnergy) {
  const double armature = 0.02, qdot = 1.5, r = 0.8, q = 0.4;
  const double I = kIzz + kMass * kCom * kCom + armature;
  std::shared_ptr<rb::RobotModel> model = rb::robotModelFromUrdfString(singleLinkUrdf());
  model->setJointModel(0, rb::JointModel::kArmature, armature);
  rb::ArticulatedBody link{std::shared_ptr<const rb::RobotModel>(model)};
  link.setState(VectorXd::Constant(1, q), VectorXd::Constant(1, qdot));
  cr::RigidBody wall;  // immovable: no inverse mass
  const Vector3d tangent(-std::sin(q), std::cos(q), 0);
  cr::ContactPoint contact(0, 1, r * Vector3d(std::cos(q), std::sin(q), 0), tangent, 0.0, 0.0, 0.0);
  contact.part_a = link.linkIndex("arm");
  std::vector<cr::BodyModel*> bodies{&link, &wall};
  const cr::BodyResponse out = cr::computeBodyResponse(bodies, {contact});
  const std::vector<cr::ContactSafety> safety = cr::contactSafety(bodies, {contact}, out.impulses);
  ASSERT_EQ(safety.size(), 1u);
  EXPECT_LE(relative(safety[0].reflected_mass_a, I / (r * r)), 1e-12);
  EXPECT_EQ(safety[0].reflected_mass_b, kInf);
  EXPECT_LE(relative(safety[0].reduced_mass, I / (r * r)), 1e-12);
  EXPECT_LE(relative(safety[0].approach_speed, r * qdot), 1e-12);
  EXPECT_LE(relative(safety[0].transferred_energy, 0.5 * I * qdot * qdot), 1e-12);
}

// Two free spheres head on along x (contact on the line of centres, no lever arm): each side's
// reflected mass is its own mass, and the energy 0.5 m1 m2 / (m1 + m2) (v1 - v2)^2; a sphere
// against an immovable body: 0.5 m v^2. A separating contact transfers nothing.
TEST(RobotSafety, TwoSpheresHeadOnTransferTheReducedMassEnergy) {
  const double m1 = 2.0, m2 = 3.0, v1 = 4.0, v2 = -1.0;
  cr::RigidBody a = sphere(m1, 0.1, Vector3d(-0.1, 0, 0), Vector3d(v1, 0, 0));
  cr::RigidBody b = sphere(m2, 0.1, Vector3d(0.1, 0, 0), Vector3d(v2, 0, 0));
  cr::RigidBody wall;
  const cr::ContactPoint ab(0, 1, Vector3d::Zero(), Vector3d::UnitX(), 0.5, 0.0, 0.0);
  const cr::ContactPoint a_wall(0, 2, Vector3d::Zero(), Vector3d::UnitX(), 0.5, 0.0, 0.0);
  const cr::ContactPoint b_wall(1, 2, Vector3d::Zero(), Vector3d::UnitX(), 0.5, 0.0, 0.0);
  std::vector<cr::ContactImpulse> before(3);
  before[0].normal_velocity_before = v2 - v1;  // n . (v_b - v_a)
  before[1].normal_velocity_before = -v1;
  before[2].normal_velocity_before = -v2;  // n . (0 - v_b): b moves towards -x, away from the wall
  const std::vector<cr::ContactSafety> s =
      cr::contactSafety({&a, &b, &wall}, {ab, a_wall, b_wall}, before);
  EXPECT_NEAR(s[0].reflected_mass_a, m1, 1e-12);
  EXPECT_NEAR(s[0].reflected_mass_b, m2, 1e-12);
  EXPECT_NEAR(s[0].reduced_mass, m1 * m2 / (m1 + m2), 1e-12);
  EXPECT_NEAR(s[0].approach_speed, v1 - v2, 1e-12);
  EXPECT_NEAR(s[0].transferred_energy, 0.5 * m1 * m2 / (m1 + m2) * (v1 - v2) * (v1 - v2), 1e-12);
  EXPECT_EQ(s[1].reflected_mass_b, kInf);
  EXPECT_NEAR(s[1].transferred_energy, 0.5 * m1 * v1 * v1, 1e-12);
  EXPECT_EQ(s[2].approach_speed, 0.0);
  EXPECT_EQ(s[2].transferred_energy, 0.0);
}

// The shipped arm's chain with armature on joint4: at random configurations, a random point of a
// random link and a random normal, the reflected mass against 1 / (n^T J M^-1 J^T n) with M from
// KDL's ChainDynParam plus the armature and J from central differences of KDL's forward
// kinematics of the point (to 1e-6 relative: the differences' error is ~1e-10).
TEST(RobotSafety, Arm7ReflectedMassEqualsKdlInertiaAndFiniteDifferenceJacobian) {
  const Arm7Chain kdl;
  ASSERT_EQ(kdl.joints.size(), 8u);
  rb::ArticulatedBody arm = kdl.robot();
  const double armature = 0.05;
  arm.setJointModel(arm.jointIndex("joint4"), rb::JointModel::kArmature, armature);
  ASSERT_EQ(arm.jointNames(), kdl.joints);  // one joint order for q, M and J
  std::mt19937 rng(26);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI), unit(-1.0, 1.0);
  const std::vector<std::string> links{"link3", "link5", "link7", "hand", "left_finger"};
  for (int trial = 0; trial < 20; ++trial) {
    VectorXd q(8);
    for (int i = 0; i < 7; ++i) q(i) = angle(rng);
    q(7) = 0.02 + 0.01 * unit(rng);
    arm.setState(q, VectorXd::Zero(8));
    const std::string& name = links[trial % links.size()];
    const Vector3d local(0.05 * unit(rng), 0.05 * unit(rng), 0.1 * unit(rng));
    const Vector3d n = Vector3d(unit(rng), unit(rng), unit(rng)).normalized();
    MatrixXd M = kdl.mass(q);
    M(3, 3) += armature;
    const MatrixXd J = kdl.jacobian(q, name, local);
    const VectorXd Jn = J.transpose() * n;
    const double want = 1.0 / Jn.dot(M.ldlt().solve(Jn));
    const Vector3d p = kdl.point(q, name, local);
    EXPECT_LE(relative(cr::reflectedMass(arm, arm.linkIndex(name), p, n), want), 1e-6)
        << "trial " << trial << " link " << name;
  }
}

// The whole shipped arm (both fingers) struck by a free sphere through its centre, frictionless,
// e = 0, at random states: the two sides' reduced mass is the two-body effective mass the contact
// problem assembles (its Delassus operator: W = W_robot + W_sphere for two bodies), the sphere's
// reflected mass its own, and the transferred energy 0.5 m_red v^2 is exactly the kinetic energy
// the perfectly inelastic impact dissipates (robot's and sphere's, before minus after).
TEST(RobotSafety, Arm7InelasticStrikeDissipatesTheTransferredEnergy) {
  std::mt19937 rng(15066);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI), unit(-1.0, 1.0);
  const double ms = 1.5, R = 0.05;
  for (int trial = 0; trial < 10; ++trial) {
    rb::ArticulatedBody arm = rb::robotFromUrdfFile(kArm7);
    const int joints = arm.jointCount();
    VectorXd q(joints), qdot(joints);
    for (int i = 0; i < joints; ++i) {
      q(i) = i < 7 ? angle(rng) : 0.02;
      qdot(i) = i < 7 ? unit(rng) : 0.0;
    }
    arm.setState(q, qdot);
    const int link = arm.linkIndex(trial % 2 ? "link7" : "link4");
    const Vector3d p = arm.linkPose(link) * Vector3d(0.03, 0.0, 0.05);
    const Vector3d n = Vector3d(unit(rng), unit(rng), unit(rng)).normalized();  // arm -> sphere
    // The sphere on the far side of the point along n, coming back at 2 m/s plus the arm's speed.
    const double arm_speed = n.dot(arm.partPointVelocity(link, p));
    cr::RigidBody ball = sphere(ms, R, p + R * n, (arm_speed - 2.0) * n);
    cr::ContactPoint contact(0, 1, p, n, 0.0, 0.0, 0.0);
    contact.part_a = link;
    std::vector<cr::BodyModel*> bodies{&arm, &ball};
    const double energy_before =
        arm.kineticEnergy() + 0.5 * ms * ball.linear_velocity.squaredNorm();
    const cr::BodyResponse out = cr::computeBodyResponse(bodies, {contact});
    const double energy_after = arm.kineticEnergy() + 0.5 * ms * ball.linear_velocity.squaredNorm();
    const cr::ContactSafety s = cr::contactSafety(bodies, {contact}, out.impulses)[0];
    SCOPED_TRACE("trial " + std::to_string(trial));
    EXPECT_NEAR(s.approach_speed, 2.0, 1e-12);
    EXPECT_LE(relative(s.reflected_mass_b, ms), 1e-12);
    EXPECT_LT(s.reflected_mass_a, kInf);
    EXPECT_LE(relative(s.reduced_mass, out.effective_masses[0]), 1e-10);
    EXPECT_LE(relative(s.transferred_energy, energy_before - energy_after), 1e-9);
  }
}

// The joints' generalized impulse J(p)^T P over the contacts, locked joints included, against J
// from central differences of KDL's forward kinematics (the chain arm, joint3 locked): on the
// free joints it also equals M dv, the velocity jump times KDL's inertia.
TEST(RobotSafety, Arm7JointImpulsesAreTheContactJacobianTransposeImpulse) {
  const Arm7Chain kdl;
  rb::ArticulatedBody arm = kdl.robot();
  std::vector<bool> locked(8, false);
  locked[2] = true;
  arm.setLockedJoints(locked);
  VectorXd q(8);
  q << 0.3, -0.8, 1.1, 1.4, -0.4, 0.9, 0.2, 0.02;
  arm.setState(q, VectorXd::Zero(8));
  const VectorXd qdot_before = arm.jointVelocities();
  const int link = arm.linkIndex("link7");
  const Vector3d local(0.02, -0.03, 0.05);
  const Vector3d p = kdl.point(q, "link7", local);
  const Vector3d n = Vector3d(0.2, -0.9, 0.3).normalized();  // sphere (a) -> arm (b)
  cr::RigidBody ball = sphere(2.0, 0.05, p - 0.05 * n, 3.0 * n);
  cr::ContactPoint contact(0, 1, p, n, 0.4, 0.5, 0.4);
  contact.part_b = link;
  ball.angular_velocity = Vector3d(0, 0, 20);  // a tangential slip: friction takes part
  const cr::BodyResponse out = cr::computeBodyResponse({&ball, &arm}, {contact});
  const Vector3d P = out.impulses[0].total(n);  // on b, the arm
  ASSERT_GT(out.impulses[0].friction_impulse.norm(), 1e-3);
  const VectorXd want = kdl.jacobian(q, "link7", local).transpose() * P;
  const VectorXd got = rb::impactJointImpulses(arm, 1, {contact}, out.impulses);
  ASSERT_EQ(got.size(), 8);
  EXPECT_LE((got - want).cwiseAbs().maxCoeff(), 1e-6 * want.cwiseAbs().maxCoeff());
  EXPECT_GT(std::abs(got(2)), 1e-3);  // the locked joint's brake takes its share
  // On the free joints M dv = J_f^T P (dv_f = M_ff^-1 J_f^T P, the locked joint's dv is 0).
  const VectorXd jump = kdl.mass(q) * (arm.jointVelocities() - qdot_before);
  for (int j : {0, 1, 3, 4, 5, 6, 7})
    EXPECT_NEAR(got(j), jump(j), 1e-9 * want.cwiseAbs().maxCoeff()) << "joint " << j;
}

// The shipped arm's URDF limits (read here by urdf::Model) on the loaded model, and a heavy fast
// strike that throws some joints beyond theirs: exactly the joints whose |velocity| after the
// impact exceeds the URDF's limit are named, "robots[0].joint_state.velocity[j]".
TEST(RobotSafety, Arm7JointsLeavingTheirUrdfLimitAreNamed) {
  urdf::Model urdf;
  ASSERT_TRUE(urdf.initFile(kArm7));
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(kArm7);
  const int joints = arm.jointCount();
  std::vector<double> limits(joints);
  for (int j = 0; j < joints; ++j) {
    limits[j] = urdf.getJoint(arm.jointNames()[j])->limits->velocity;
    EXPECT_EQ(arm.velocityLimit(j), limits[j]) << arm.jointNames()[j];
  }
  VectorXd q(joints), qdot = VectorXd::Constant(joints, 0.1);
  q << 0.2, 0.9, -0.4, 1.3, 0.5, -0.7, 0.3, 0.02, 0.02;
  arm.setState(q, qdot);
  EXPECT_TRUE(rb::velocityLimitWarnings(arm, "robots[0]").empty());  // all within before
  const int link = arm.linkIndex("link7");
  const Vector3d p = arm.linkPose(link) * Vector3d(0.03, 0, 0.05);
  const Vector3d n = arm.linkPose(link).linear() * Vector3d::UnitX();
  cr::RigidBody ball = sphere(5.0, 0.05, p - 0.05 * n, 6.0 * n);
  cr::ContactPoint contact(0, 1, p, n, 0.8, 0.0, 0.0);
  contact.part_b = link;
  cr::computeBodyResponse({&ball, &arm}, {contact});
  std::set<std::string> want;
  for (int j = 0; j < joints; ++j)
    if (std::abs(arm.jointVelocities()(j)) > limits[j])
      want.insert("robots[0].joint_state.velocity[" + std::to_string(j) + "]");
  ASSERT_FALSE(want.empty());
  ASSERT_LT(want.size(), static_cast<std::size_t>(joints));  // and some stay within
  std::set<std::string> got;
  for (const cr::Warning& warning : rb::velocityLimitWarnings(arm, "robots[0]")) {
    EXPECT_EQ(warning.kind, cr::Warning::Kind::kJointLimit);
    got.insert(warning.field);
    const int j = std::stoi(warning.field.substr(warning.field.rfind('[') + 1));
    EXPECT_NE(warning.reason.find("'" + arm.jointNames()[j] + "'"), std::string::npos)
        << warning.text();
  }
  EXPECT_EQ(got, want);
}

// A continuous joint has no <limit>, and a velocity of 0 is "not given": no limit (infinity); a
// negative one is refused naming the joint.
TEST(RobotSafety, UrdfWithoutVelocityLimitHasNone) {
  std::string xml = singleLinkUrdf();
  const std::string given = "velocity=\"" + std::to_string(static_cast<int>(kLimit)) + "\"";
  ASSERT_NE(xml.find(given), std::string::npos);
  EXPECT_EQ(rb::robotFromUrdfString(xml).velocityLimit(0), kLimit);
  std::string zero = xml;
  zero.replace(zero.find(given), given.size(), "velocity=\"0\"");
  EXPECT_EQ(rb::robotFromUrdfString(zero).velocityLimit(0), kInf);
  std::string negative = xml;
  negative.replace(negative.find(given), given.size(), "velocity=\"-1\"");
  try {
    rb::robotFromUrdfString(negative);
    ADD_FAILURE() << "a negative velocity limit was taken";
  } catch (const cr::InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("joint 'hinge'"), std::string::npos) << e.what();
  }
}
