#include "collision_response/robot/articulated_body_algorithm.h"

#include <Eigen/Geometry>
#include <vector>

#include "collision_response/core/errors.h"
#include "collision_response/robot/algorithms.h"

namespace collision_response::robot {
namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// Spatial motion (angular; velocity of the point at the origin) of a KDL twist.
Vector6d motionOf(const KDL::Twist& t) {
  Vector6d m;
  m << t.rot.x(), t.rot.y(), t.rot.z(), t.vel.x(), t.vel.y(), t.vel.z();
  return m;
}

Eigen::Matrix3d skew(const Eigen::Vector3d& x) {
  Eigen::Matrix3d s;
  s << 0.0, -x.z(), x.y(), x.z(), 0.0, -x.x(), -x.y(), x.x(), 0.0;
  return s;
}

// v x_m u: the motion cross product [[w]x 0; [v]x [w]x] u.
Vector6d crossMotion(const Vector6d& v, const Vector6d& u) {
  Vector6d out;
  out.head<3>() = v.head<3>().cross(u.head<3>());
  out.tail<3>() = v.tail<3>().cross(u.head<3>()) + v.head<3>().cross(u.tail<3>());
  return out;
}

// v x_f f: the force cross product [[w]x [v]x; 0 [w]x] f (f = moment at the origin; force).
Vector6d crossForce(const Vector6d& v, const Vector6d& f) {
  Vector6d out;
  out.head<3>() = v.head<3>().cross(f.head<3>()) + v.tail<3>().cross(f.tail<3>());
  out.tail<3>() = v.head<3>().cross(f.tail<3>());
  return out;
}

// The 6x6 inertia at the origin: momentum (angular about the origin; linear) of a motion,
// [[I_o, [h]x]; [[h]x^T, m 1]] with h = m c.
Matrix6d matrixOf(const SpatialInertia& inertia) {
  Matrix6d out;
  const Eigen::Matrix3d h = skew(inertia.first_moment);
  out.topLeftCorner<3, 3>() = inertia.rotational;
  out.topRightCorner<3, 3>() = h;
  out.bottomLeftCorner<3, 3>() = h.transpose();
  out.bottomRightCorner<3, 3>() = inertia.mass * Eigen::Matrix3d::Identity();
  return out;
}

}  // namespace

bool articulatedBodyApplies(const RobotModel& model) {
  return !model.floating() && !model.hasMimicJoints();
}

Eigen::VectorXd articulatedBodyAcceleration(const RobotModel& model, const RobotData& data) {
  ArticulatedBodyWorkspace workspace;
  Eigen::VectorXd vdot;
  articulatedBodyAcceleration(model, data, workspace, vdot);
  return vdot;
}

void articulatedBodyAcceleration(const RobotModel& model, const RobotData& data,
                                 ArticulatedBodyWorkspace& workspace, Eigen::VectorXd& vdot) {
  const int links = model.linkCount();
  vdot.setZero(data.unknowns);
  if (data.unknowns == 0) return;
  const bool compensated = data.gravity_compensation;
  auto& inertia = workspace.inertia;  // articulated inertias I^A
  auto& bias = workspace.bias;        // articulated bias forces p^A
  auto& axis = workspace.axis;
  auto& drift = workspace.drift;
  auto& U = workspace.U;
  auto& D = workspace.D;
  auto& u = workspace.u;
  auto& grounded = workspace.grounded;
  inertia.resize(links);
  bias.resize(links);
  axis.resize(links);
  drift.resize(links);
  U.resize(links);
  D.assign(links, 0.0);
  u.assign(links, 0.0);
  // The base (fixed: articulatedBodyApplies()) and the links welded to it by fixed joints move
  // with it: their articulated inertias and biases are never read, so they are not formed.
  grounded.resize(links);
  grounded[0] = 1;
  for (int i = 1; i < links; ++i) {
    grounded[i] = model.link(i).joint < 0 && grounded[model.link(i).parent] ? 1 : 0;
  }
  for (int i = 0; i < links; ++i) {
    const int j = model.link(i).joint;
    axis[i] = i > 0 ? motionOf(data.axes[i]) : Vector6d::Zero();
    if (grounded[i]) {
      drift[i].setZero();
      continue;
    }
    const Vector6d v = motionOf(data.twists[i]);
    inertia[i] = matrixOf(worldInertia(model.link(i).local, data.frames[i]));
    bias[i] = crossForce(v, inertia[i] * v);
    // c = v x S qdot: the change of the joint's motion as the axis moves with the link.
    drift[i] = j >= 0 ? Vector6d(crossMotion(v, axis[i] * data.qdot(j))) : Vector6d::Zero();
  }
  // Leaves to the root: each link's articulated inertia and bias, passed on to its parent (not to
  // a grounded one, which nothing reads).
  for (int i = links - 1; i > 0; --i) {
    if (grounded[i]) continue;
    const int j = model.link(i).joint;
    const int parent = model.link(i).parent;
    const bool free = j >= 0 && data.unknown_of_joint[j] >= 0;
    if (free) {
      U[i] = inertia[i] * axis[i];
      D[i] = axis[i].dot(U[i]) + model.armature(j);
      if (!(D[i] > 0.0)) {
        throw core::InvalidInput(
            "q", "the mass matrix is singular at joint '" + model.jointNames()[j] + "'");
      }
      const double tau = compensated ? 0.0 : data.torques(j);
      u[i] = tau - axis[i].dot(bias[i]);
    }
    if (grounded[parent]) continue;
    Matrix6d passed = inertia[i];
    Vector6d passed_bias;
    if (free) {
      passed -= U[i] * U[i].transpose() / D[i];
      passed_bias = bias[i] + passed * drift[i] + U[i] * (u[i] / D[i]);
    } else {
      passed_bias = bias[i] + inertia[i] * drift[i];
    }
    inertia[parent] += passed;
    bias[parent] += passed_bias;
  }
  // Root to leaves: accelerations (gravity as the base accelerating upwards, unless compensated).
  auto& acceleration = workspace.acceleration;
  acceleration.resize(links);
  acceleration[0].setZero();
  if (!compensated) acceleration[0].tail<3>() = -data.gravity;
  for (int i = 1; i < links; ++i) {
    const int j = model.link(i).joint;
    Vector6d a = acceleration[model.link(i).parent] + drift[i];
    if (j >= 0 && data.unknown_of_joint[j] >= 0) {
      const double qdd = (u[i] - U[i].dot(a)) / D[i];
      vdot(data.unknown_of_joint[j]) = qdd;
      a += axis[i] * qdd;
    }
    acceleration[i] = a;
  }
}

}  // namespace collision_response::robot
