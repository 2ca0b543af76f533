#include "collision_response/robot/algorithms.h"

#include <Eigen/Geometry>
#include <cmath>
#include <utility>

#include "collision_response/core/errors.h"

namespace collision_response::robot {
namespace {

KDL::Vector toKdl(const Eigen::Vector3d& v) {
  return KDL::Vector(v.x(), v.y(), v.z());
}
Eigen::Vector3d toEigen(const KDL::Vector& v) {
  return Eigen::Vector3d(v.x(), v.y(), v.z());
}
Eigen::Matrix3d toEigen(const KDL::Rotation& r) {
  return Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(r.data);
}

// KDL's frame product a * b, the same arithmetic term for term (KDL's rotation product is out of
// line in its library; the kinematics compose two frames per link at every right-hand side).
KDL::Frame compose(const KDL::Frame& a, const KDL::Frame& b) {
  const double* l = a.M.data;
  const double* r = b.M.data;
  return KDL::Frame(
      KDL::Rotation(
          l[0] * r[0] + l[1] * r[3] + l[2] * r[6], l[0] * r[1] + l[1] * r[4] + l[2] * r[7],
          l[0] * r[2] + l[1] * r[5] + l[2] * r[8], l[3] * r[0] + l[4] * r[3] + l[5] * r[6],
          l[3] * r[1] + l[4] * r[4] + l[5] * r[7], l[3] * r[2] + l[4] * r[5] + l[5] * r[8],
          l[6] * r[0] + l[7] * r[3] + l[8] * r[6], l[6] * r[1] + l[7] * r[4] + l[8] * r[7],
          l[6] * r[2] + l[7] * r[5] + l[8] * r[8]),
      a.M * b.p + a.p);
}

// Velocity at the world point p of a twist given at the world origin: vel + rot x p.
Eigen::Vector3d velocityAt(const KDL::Twist& twist, const Eigen::Vector3d& p) {
  return toEigen(twist.vel) + toEigen(twist.rot).cross(p);
}

// Relative size of the smallest Cholesky pivot, against M's largest diagonal entry, below which M
// counts as singular (a free joint that moves no mass).
constexpr double kSingularPivot = 1e-12;

/// x <- M^-1 x for M = L L^T (L in the lower triangle of `lower`, n x n), by forward and back
/// substitution, all columns of x at once: for a few unknowns, plain loops cost a fraction of
/// Eigen's blocked triangular solves.
template <class Matrix>
void solveWithCholesky(const Eigen::MatrixXd& lower, int n, Matrix& x) {
  using Row = Eigen::Matrix<double, 1, Matrix::ColsAtCompileTime>;
  for (int i = 0; i < n; ++i) {  // L y = x
    Row r = x.row(i);
    for (int k = 0; k < i; ++k) r -= lower(i, k) * x.row(k);
    x.row(i) = r / lower(i, i);
  }
  for (int i = n - 1; i >= 0; --i) {  // L^T x = y
    Row r = x.row(i);
    for (int k = i + 1; k < n; ++k) r -= lower(k, i) * x.row(k);
    x.row(i) = r / lower(i, i);
  }
}

// The momentum (linear [N s], angular about the origin [N m s]) of a body of spatial inertia
// (m, h, I_o) moving with the twist (v at the origin, w): (m v - h x w, I_o w + h x v).
struct Momentum {
  Eigen::Vector3d linear, angular;
};
Momentum momentumOf(const SpatialInertia& inertia, const Eigen::Vector3d& w,
                    const Eigen::Vector3d& v) {
  return {inertia.mass * v - inertia.first_moment.cross(w),
          inertia.rotational * w + inertia.first_moment.cross(v)};
}
Momentum momentumOf(const SpatialInertia& inertia, const KDL::Twist& twist) {
  return momentumOf(inertia, toEigen(twist.rot), toEigen(twist.vel));
}
// Rotational inertia about the origin of a point mass m at c [kg m^2] (the parallel-axis term).
Eigen::Matrix3d pointMassInertia(double m, const Eigen::Vector3d& c) {
  return m * (c.squaredNorm() * Eigen::Matrix3d::Identity() - c * c.transpose());
}

// Power of a momentum against a twist: v . p + w . L (twice the kinetic energy when both are the
// body's own; an entry of M when they are two unknowns' axes).
double power(const KDL::Twist& twist, const Momentum& momentum) {
  return toEigen(twist.vel).dot(momentum.linear) + toEigen(twist.rot).dot(momentum.angular);
}

// Motion of a unit value of unknown k (world twist at the origin).
const KDL::Twist& unknownAxis(const RobotModel& model, const RobotData& data, int k) {
  const int joint = data.joint_of_unknown[k];
  return joint < 0 ? data.base_axes[k] : data.axes[model.linkOfJoint(joint)];
}

// M = T^T M_all T for a robot with mimic joints (computeMassMatrix()).
void computeMimicMassMatrix(const RobotModel& model, RobotData& data) {
  // M_all is the inertia in the velocities of the base and of every joint that moves (a mimic's
  // own included) and T maps the unknowns to them (entry multiplier_j in joint j's row, root's
  // column). Each entry of M_all is visited once, a pair (j, k) with j on the path from k's link to
  // the base, and added to the unknowns' entries with the multipliers.
  Eigen::MatrixXd& mass = data.mass_matrix;
  const int base_unknowns = model.floating() ? 6 : 0;
  for (int b = 0; b < base_unknowns; ++b) {  // the base's own block, as without mimics
    const Momentum force = momentumOf(data.composite[0], data.base_axes[b]);
    for (int c = 0; c <= b; ++c) mass(b, c) = mass(c, b) = power(data.base_axes[c], force);
  }
  for (int k = 0; k < model.jointCount(); ++k) {
    const int u = data.unknown_of_joint[k];
    if (u < 0) continue;
    const double mk = model.mimicMultiplier(k);
    const int own = model.linkOfJoint(k);
    const Momentum force = momentumOf(data.composite[own], data.axes[own]);
    for (int l = own; l >= 0; l = model.link(l).parent) {
      if (l == 0) {
        for (int b = 0; b < base_unknowns; ++b) {
          const double value = mk * power(data.base_axes[b], force);
          mass(b, u) += value;
          mass(u, b) += value;
        }
        continue;
      }
      const int j = model.link(l).joint;
      if (j < 0 || data.unknown_of_joint[j] < 0) continue;
      const int v = data.unknown_of_joint[j];
      const double value = mk * model.mimicMultiplier(j) * power(data.axes[l], force);
      mass(v, u) += value;
      if (j != k) mass(u, v) += value;
    }
    mass(u, u) += mk * mk * model.armature(k);
  }
}

// Generalized forces per joint (and the base's 6) folded into the unknowns: T^T f.
Eigen::VectorXd foldJointForces(const RobotModel& model, const RobotData& data,
                                const Eigen::VectorXd& joint_forces,
                                const Eigen::Matrix<double, 6, 1>& base_forces) {
  Eigen::VectorXd folded = Eigen::VectorXd::Zero(data.unknowns);
  if (model.floating()) folded.head<6>() = base_forces;
  for (int j = 0; j < model.jointCount(); ++j) {
    const int u = data.unknown_of_joint[j];
    if (u >= 0) folded(u) += model.mimicMultiplier(j) * joint_forces(j);
  }
  return folded;
}

}  // namespace

SpatialInertia worldInertia(const LocalInertia& local, const KDL::Frame& frame) {
  const Eigen::Matrix3d r = toEigen(frame.M);
  const Eigen::Vector3d c = r * local.com + toEigen(frame.p);
  const double m = local.mass;
  SpatialInertia out;
  out.mass = m;
  out.first_moment = m * c;
  out.rotational = r * local.about_com * r.transpose() + pointMassInertia(m, c);
  return out;
}

void deriveMimicState(const RobotModel& model, RobotData& data) {
  for (int j = 0; j < model.jointCount(); ++j) {
    const int root = model.mimicRoot(j);
    if (root == j) continue;
    data.q(j) = model.mimicMultiplier(j) * data.q(root) + model.mimicOffset(j);
    data.qdot(j) = model.mimicMultiplier(j) * data.qdot(root);
  }
}

void updateUnknowns(const RobotModel& model, RobotData& data) {
  // Unknowns: the base twist first, then the joints that are not locked, in joint order; a mimic
  // joint shares its root's, and a group is locked if any of its joints that move with the root is.
  const int joints = model.jointCount();
  data.unknown_of_joint.assign(joints, -1);
  data.joint_of_unknown.clear();
  if (model.floating()) data.joint_of_unknown.assign(6, -1);
  std::vector<bool> locked(joints, false);
  for (int j = 0; j < joints; ++j) {
    const int root = model.mimicRoot(j);
    if ((model.jointModel(j) == JointModel::kLocked || data.locked[j]) &&
        (root == j || model.mimicMultiplier(j) != 0.0))
      locked[root] = true;
  }
  for (int j = 0; j < joints; ++j) {
    if (model.mimicRoot(j) != j || locked[j]) continue;
    data.unknown_of_joint[j] = static_cast<int>(data.joint_of_unknown.size());
    data.joint_of_unknown.push_back(j);
  }
  if (model.hasMimicJoints()) {
    for (int j = 0; j < joints; ++j)
      data.unknown_of_joint[j] = data.unknown_of_joint[model.mimicRoot(j)];
    deriveMimicState(model, data);
  }
  data.unknowns = static_cast<int>(data.joint_of_unknown.size());
}

void forwardKinematics(const RobotModel& model, RobotData& data) {
  data.link_inertias_valid = false;
  data.frames[0] = data.base_pose;
  const KDL::Vector o = data.base_pose.p;
  for (int k = 0; k < 3; ++k) {
    KDL::Vector e = KDL::Vector::Zero();
    e(k) = 1.0;
    data.base_axes[k] = KDL::Twist(e, KDL::Vector::Zero());
    data.base_axes[3 + k] = KDL::Twist(o * e, e);  // w e_k about the base origin: v(0) = o x e_k
  }
  const int links = model.linkCount();
  for (int i = 1; i < links; ++i) {
    const LinkModel& link = model.link(i);
    const KDL::Frame& parent = data.frames[link.parent];
    const KDL::Joint& joint = link.segment.getJoint();
    const double q = link.joint >= 0 ? data.q(link.joint) : 0.0;
    // Not KDL's pose(): it caches.
    data.frames[i] = compose(parent, compose(jointPose(joint, q), link.tip));
    if (link.joint < 0) {
      data.axes[i] = KDL::Twist::Zero();
    } else {
      const KDL::Vector axis = parent.M * joint.JointAxis();
      const bool rotation = joint.getType() <= KDL::Joint::RotZ;
      if (rotation) {
        const KDL::Vector origin = parent * joint.JointOrigin();
        data.axes[i] = KDL::Twist(origin * axis, axis);  // w a through o: v(0) = o x a
      } else {
        data.axes[i] = KDL::Twist(axis, KDL::Vector::Zero());
      }
    }
  }
  updateTwists(model, data);
}

void updateTwists(const RobotModel& model, RobotData& data) {
  data.free_accelerations_valid = false;
  const KDL::Vector w = toKdl(data.base_angular_velocity);
  data.twists[0] = KDL::Twist(toKdl(data.base_linear_velocity) + data.frames[0].p * w, w);
  const int links = model.linkCount();
  for (int i = 1; i < links; ++i) {
    const LinkModel& link = model.link(i);
    data.twists[i] = data.twists[link.parent];
    if (link.joint >= 0) data.twists[i] += data.axes[i] * data.qdot(link.joint);
  }
}

void computeMassMatrix(const RobotModel& model, RobotData& data) {
  const int n = data.unknowns;
  Eigen::MatrixXd& mass = data.mass_matrix;
  mass.setZero(n, n);
  if (n == 0) return;  // nothing moves: no inertia is needed
  // Composite inertias, children before parents (world frame, reference point the origin: sums).
  const int links = model.linkCount();
  data.link_inertias.resize(links);
  for (int i = 0; i < links; ++i) {
    data.link_inertias[i] = worldInertia(model.link(i).local, data.frames[i]);
    data.composite[i] = data.link_inertias[i];
  }
  data.link_inertias_valid = true;
  for (int i = links - 1; i > 0; --i) data.composite[model.link(i).parent] += data.composite[i];
  if (model.hasMimicJoints()) {
    computeMimicMassMatrix(model, data);
    return;
  }
  // M_jk = S_j . (Ic_k S_k) for j on the path from k's link to the base: the momentum of k's
  // subtree moving at a unit rate, seen by every joint that carries that subtree.
  const int base_unknowns = model.floating() ? 6 : 0;
  for (int k = 0; k < n; ++k) {
    const int joint = data.joint_of_unknown[k];
    const int own = joint < 0 ? 0 : model.linkOfJoint(joint);
    const Momentum force = momentumOf(data.composite[own], unknownAxis(model, data, k));
    for (int l = own; l >= 0; l = model.link(l).parent) {
      const int j = model.link(l).joint;
      if (l == 0) {
        for (int b = 0; b < base_unknowns; ++b) {
          mass(b, k) = mass(k, b) = power(data.base_axes[b], force);
        }
      } else if (j >= 0 && data.unknown_of_joint[j] >= 0) {
        const int u = data.unknown_of_joint[j];
        mass(u, k) = mass(k, u) = power(data.axes[l], force);
      }
    }
    if (joint >= 0) mass(k, k) += model.armature(joint);
  }
}

void factorizeMassMatrix(const RobotModel& model, RobotData& data) {
  const int n = data.unknowns;
  data.singular.clear();
  if (n == 0) return;
  // M = L L^T by Cholesky's algorithm, L in the lower triangle of data.cholesky (plain loops: for
  // a few unknowns a fraction of the cost of Eigen's LLT, whose column updates are general matrix
  // products). Its pivots come in unknown order: the pivot of unknown k is that of M's leading
  // (k+1) block, so the first one that vanishes (below kSingularPivot times M's largest diagonal
  // entry) names the first unknown whose motion moves no mass the others do not.
  const double scale = data.mass_matrix.diagonal().maxCoeff();
  Eigen::MatrixXd& l = data.cholesky;
  l = data.mass_matrix;
  int bad = scale > 0.0 ? -1 : 0;
  for (int j = 0; j < n && bad < 0; ++j) {
    double pivot = l(j, j);
    for (int k = 0; k < j; ++k) pivot -= l(j, k) * l(j, k);
    if (!(pivot > kSingularPivot * scale)) {
      bad = j;
      break;
    }
    const double root = std::sqrt(pivot), inverse = 1.0 / root;
    l(j, j) = root;
    for (int i = j + 1; i < n; ++i) {
      double v = l(i, j);
      for (int k = 0; k < j; ++k) v -= l(i, k) * l(j, k);
      l(i, j) = v * inverse;
    }
  }
  if (bad >= 0) {
    const int joint = data.joint_of_unknown[bad];
    data.singular =
        (joint < 0 ? std::string("singular joint-space inertia at the floating base")
                   : "singular joint-space inertia: joint '" + model.jointNames()[joint] +
                         "' moves no mass (massless links beyond it); lock it or give them mass");
  }
}

void requireRegular(const RobotData& data, const std::string& field) {
  if (!data.singular.empty()) throw core::InvalidInput(field, data.singular);
}

void solveMassMatrix(const RobotData& data, Eigen::Matrix<double, Eigen::Dynamic, 3>& x) {
  solveWithCholesky(data.cholesky, data.unknowns, x);
}

void solveMassMatrix(const RobotData& data, Eigen::VectorXd& x) {
  solveWithCholesky(data.cholesky, data.unknowns, x);
}

void solveMassMatrix(const RobotData& data, Eigen::MatrixXd& x) {
  // Column by column in plain loops (the row loops above would allocate a dynamic row per step,
  // and Eigen's blocked triangular solves cost more than the solve for a few unknowns).
  const int n = data.unknowns;
  const Eigen::MatrixXd& L = data.cholesky;
  for (Eigen::Index c = 0; c < x.cols(); ++c) {
    double* y = x.col(c).data();
    for (int i = 0; i < n; ++i) {  // L y = x
      double r = y[i];
      for (int k = 0; k < i; ++k) r -= L(i, k) * y[k];
      y[i] = r / L(i, i);
    }
    for (int i = n - 1; i >= 0; --i) {  // L^T x = y
      double r = y[i];
      for (int k = i + 1; k < n; ++k) r -= L(k, i) * y[k];
      y[i] = r / L(i, i);
    }
  }
}

Eigen::Matrix<double, 3, Eigen::Dynamic> pointJacobian(const RobotModel& model,
                                                       const RobotData& data, int link,
                                                       const Eigen::Vector3d& point) {
  Eigen::Matrix<double, 3, Eigen::Dynamic> jacobian =
      Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, data.unknowns);
  if (model.hasMimicJoints()) {  // a mimic's column folds into its root's (two may share a path)
    for (int l = model.checkLink(link); l > 0; l = model.link(l).parent) {
      const int j = model.link(l).joint;
      if (j >= 0 && data.unknown_of_joint[j] >= 0) {
        jacobian.col(data.unknown_of_joint[j]) +=
            model.mimicMultiplier(j) * velocityAt(data.axes[l], point);
      }
    }
  } else {
    for (int l = model.checkLink(link); l > 0; l = model.link(l).parent) {
      const int j = model.link(l).joint;
      if (j >= 0 && data.unknown_of_joint[j] >= 0) {
        jacobian.col(data.unknown_of_joint[j]) = velocityAt(data.axes[l], point);
      }
    }
  }
  if (model.floating()) {
    for (int b = 0; b < 6; ++b) jacobian.col(b) = velocityAt(data.base_axes[b], point);
  }
  return jacobian;
}

Eigen::VectorXd jointTorquesOf(const RobotModel& model, const RobotData& data, int link,
                               const Eigen::Vector3d& point, const Eigen::Vector3d& force) {
  Eigen::VectorXd torques = Eigen::VectorXd::Zero(model.jointCount());
  for (int l = model.checkLink(link); l > 0; l = model.link(l).parent) {
    const int j = model.link(l).joint;
    if (j >= 0) torques(j) = velocityAt(data.axes[l], point).dot(force);
  }
  return torques;
}

Eigen::VectorXd unknownVelocity(const RobotModel& /*model*/, const RobotData& data) {
  Eigen::VectorXd v(data.unknowns);
  for (int k = 0; k < data.unknowns; ++k) {
    const int joint = data.joint_of_unknown[k];
    v(k) = joint >= 0 ? data.qdot(joint)
                      : (k < 3 ? data.base_linear_velocity(k) : data.base_angular_velocity(k - 3));
  }
  return v;
}

void addVelocityChange(const RobotModel& model, RobotData& data,
                       const Eigen::Ref<const Eigen::VectorXd>& change) {
  if (model.hasMimicJoints()) {  // the roots take the change, their groups follow (exactly)
    for (int j = 0; j < model.jointCount(); ++j) {
      if (model.mimicRoot(j) == j && data.unknown_of_joint[j] >= 0)
        data.qdot(j) += change(data.unknown_of_joint[j]);
    }
    for (int j = 0; j < model.jointCount(); ++j) {
      if (model.mimicRoot(j) != j && data.unknown_of_joint[j] >= 0)
        data.qdot(j) = model.mimicMultiplier(j) * data.qdot(model.mimicRoot(j));
    }
    for (int k = 0; k < data.unknowns && data.joint_of_unknown[k] < 0; ++k) {
      if (k < 3) {
        data.base_linear_velocity(k) += change(k);
      } else {
        data.base_angular_velocity(k - 3) += change(k);
      }
    }
    updateTwists(model, data);
    return;
  }
  for (int k = 0; k < data.unknowns; ++k) {
    const int joint = data.joint_of_unknown[k];
    if (joint >= 0) {
      data.qdot(joint) += change(k);
    } else if (k < 3) {
      data.base_linear_velocity(k) += change(k);
    } else {
      data.base_angular_velocity(k - 3) += change(k);
    }
  }
  updateTwists(model, data);
}

double kineticEnergy(const RobotModel& model, const RobotData& data) {
  double energy = 0.0;
  for (int i = 0; i < model.linkCount(); ++i) {
    const KDL::Twist& twist = data.twists[i];
    energy +=
        0.5 * power(twist, momentumOf(worldInertia(model.link(i).local, data.frames[i]), twist));
  }
  return energy;
}

Eigen::Matrix<double, 6, 1> momentum(const RobotModel& model, const RobotData& data) {
  Eigen::Matrix<double, 6, 1> out = Eigen::Matrix<double, 6, 1>::Zero();
  for (int i = 0; i < model.linkCount(); ++i) {
    const Momentum p =
        momentumOf(worldInertia(model.link(i).local, data.frames[i]), data.twists[i]);
    out.head<3>() += p.linear;
    out.tail<3>() += p.angular;
  }
  return out;
}

namespace {

// inverseDynamics() under the gravity `gravity` instead of data.gravity.
void inverseDynamicsUnder(const RobotModel& model, const RobotData& data,
                          const Eigen::VectorXd& joint_accelerations,
                          const Eigen::Matrix<double, 6, 1>& base_acceleration, bool with_velocity,
                          const Eigen::Vector3d& gravity, Eigen::VectorXd& joint_forces,
                          Eigen::Matrix<double, 6, 1>& base_forces,
                          std::vector<SpatialAcceleration>* accelerations) {
  const int n = model.linkCount();
  std::vector<SpatialAcceleration> acceleration(n);
  std::vector<Momentum> force(n);  // (force [N], moment about the origin [N m]) on each link
  // The base: the time derivative of its twist at the origin, (alpha, a_b - alpha x p - w x v_b)
  // for its origin p moving at v_b with acceleration a_b.
  if (model.floating()) {
    const Eigen::Vector3d alpha = base_acceleration.tail<3>();
    acceleration[0].angular = alpha;
    acceleration[0].linear = base_acceleration.head<3>() - alpha.cross(toEigen(data.frames[0].p));
    if (with_velocity) {
      acceleration[0].linear -= data.base_angular_velocity.cross(data.base_linear_velocity);
    }
  }
  // Outwards: A_i = A_parent + S_i qddot_i + (V_i x S_i) qdot_i (the axis moves with the parent).
  for (int i = 1; i < n; ++i) {
    const LinkModel& link = model.link(i);
    acceleration[i] = acceleration[link.parent];
    if (link.joint < 0) continue;
    const Eigen::Vector3d s_w = toEigen(data.axes[i].rot), s_v = toEigen(data.axes[i].vel);
    const double qddot = joint_accelerations(link.joint);
    acceleration[i].angular += s_w * qddot;
    acceleration[i].linear += s_v * qddot;
    if (with_velocity) {
      const double qdot = data.qdot(link.joint);
      const Eigen::Vector3d w = toEigen(data.twists[i].rot), v = toEigen(data.twists[i].vel);
      acceleration[i].angular += w.cross(s_w) * qdot;
      acceleration[i].linear += (w.cross(s_v) + v.cross(s_w)) * qdot;
    }
  }
  // Each link's rate of change of momentum, I (A - (0, g)) + V x* (I V): gravity as an upward
  // acceleration of the frame, so that the forces are what the joints must transmit.
  for (int i = 0; i < n; ++i) {
    // The mass matrix's own inertias at these frames where it kept them (the same numbers).
    const SpatialInertia inertia = data.link_inertias_valid
                                       ? data.link_inertias[i]
                                       : worldInertia(model.link(i).local, data.frames[i]);
    force[i] = momentumOf(inertia, acceleration[i].angular, acceleration[i].linear - gravity);
    if (with_velocity) {
      const Eigen::Vector3d w = toEigen(data.twists[i].rot), v = toEigen(data.twists[i].vel);
      const Momentum p = momentumOf(inertia, w, v);
      force[i].linear += w.cross(p.linear);
      force[i].angular += w.cross(p.angular) + v.cross(p.linear);
    }
  }
  // Inwards: each joint carries its subtree; its generalized force is its axis' power.
  joint_forces.setZero(model.jointCount());
  for (int i = n - 1; i > 0; --i) {
    const LinkModel& link = model.link(i);
    if (link.joint >= 0) joint_forces(link.joint) = power(data.axes[i], force[i]);
    force[link.parent].linear += force[i].linear;
    force[link.parent].angular += force[i].angular;
  }
  base_forces.setZero();
  if (model.floating()) {
    for (int k = 0; k < 6; ++k) base_forces(k) = power(data.base_axes[k], force[0]);
  }
  if (accelerations != nullptr) *accelerations = std::move(acceleration);
}

}  // namespace

void inverseDynamics(const RobotModel& model, const RobotData& data,
                     const Eigen::VectorXd& joint_accelerations,
                     const Eigen::Matrix<double, 6, 1>& base_acceleration, bool with_velocity,
                     Eigen::VectorXd& joint_forces, Eigen::Matrix<double, 6, 1>& base_forces,
                     std::vector<SpatialAcceleration>* accelerations) {
  inverseDynamicsUnder(model, data, joint_accelerations, base_acceleration, with_velocity,
                       data.gravity, joint_forces, base_forces, accelerations);
}

Eigen::VectorXd gravityTorques(const RobotModel& model, const RobotData& data) {
  Eigen::VectorXd torques;
  Eigen::Matrix<double, 6, 1> base;
  inverseDynamics(model, data, Eigen::VectorXd::Zero(model.jointCount()),
                  Eigen::Matrix<double, 6, 1>::Zero(), false, torques, base, nullptr);
  return torques;
}

Eigen::VectorXd biasForces(const RobotModel& model, const RobotData& data) {
  Eigen::VectorXd joint_forces;
  Eigen::Matrix<double, 6, 1> base;
  inverseDynamics(model, data, Eigen::VectorXd::Zero(model.jointCount()),
                  Eigen::Matrix<double, 6, 1>::Zero(), true, joint_forces, base, nullptr);
  return foldJointForces(model, data, joint_forces, base);
}

Eigen::VectorXd jointTorques(const RobotModel& model, const RobotData& data) {
  return data.gravity_compensation ? gravityTorques(model, data) : data.torques;
}

Eigen::VectorXd freeAcceleration(const RobotModel& model, const RobotData& data) {
  if (data.unknowns == 0) return Eigen::VectorXd();
  requireRegular(data);
  Eigen::VectorXd rhs;
  if (data.gravity_compensation && !model.floating()) {
    // tau - h = g(q) - (C(q, v) v + g(q)) = -C(q, v) v: the velocity terms alone, without g(q)
    // computed twice (a floating base is not compensated: it keeps its gravity terms).
    Eigen::VectorXd joint_forces;
    Eigen::Matrix<double, 6, 1> base;
    inverseDynamicsUnder(model, data, Eigen::VectorXd::Zero(model.jointCount()),
                         Eigen::Matrix<double, 6, 1>::Zero(), true, Eigen::Vector3d::Zero(),
                         joint_forces, base, nullptr);
    rhs = -foldJointForces(model, data, joint_forces, base);
  } else {
    rhs = foldJointForces(model, data, jointTorques(model, data),
                          Eigen::Matrix<double, 6, 1>::Zero()) -
          biasForces(model, data);
  }
  solveMassMatrix(data, rhs);
  return rhs;  // M^-1 (tau - h)
}

void updateFreeAccelerations(const RobotModel& model, const RobotData& data) {
  if (data.free_accelerations_valid) return;
  const Eigen::VectorXd vdot = freeAcceleration(model, data);
  Eigen::VectorXd joint_accelerations = Eigen::VectorXd::Zero(model.jointCount());
  Eigen::Matrix<double, 6, 1> base = Eigen::Matrix<double, 6, 1>::Zero();
  for (int j = 0; j < model.jointCount(); ++j) {
    const int u = data.unknown_of_joint[j];
    if (u >= 0) joint_accelerations(j) = model.mimicMultiplier(j) * vdot(u);
  }
  for (int k = 0; k < data.unknowns && data.joint_of_unknown[k] < 0; ++k) base(k) = vdot(k);
  Eigen::VectorXd joint_forces;
  Eigen::Matrix<double, 6, 1> base_forces;
  inverseDynamics(model, data, joint_accelerations, base, true, joint_forces, base_forces,
                  &data.free_accelerations);
  data.free_accelerations_valid = true;
}

}  // namespace collision_response::robot
