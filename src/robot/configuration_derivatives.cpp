#include "collision_response/robot/configuration_derivatives.h"

#include <Eigen/Geometry>
#include <algorithm>

#include "collision_response/robot/algorithms.h"

namespace collision_response::robot {
namespace {

using Eigen::Vector3d;

// Spatial vectors at the world origin: a motion (angular w, linear v of the point at the origin)
// and a force (linear f, moment n about the origin).
struct Motion {
  Vector3d w = Vector3d::Zero(), v = Vector3d::Zero();
  Motion& operator+=(const Motion& o) {
    w += o.w;
    v += o.v;
    return *this;
  }
};
struct Force {
  Vector3d f = Vector3d::Zero(), n = Vector3d::Zero();
  Force& operator+=(const Force& o) {
    f += o.f;
    n += o.n;
    return *this;
  }
};

Motion motionOf(const KDL::Twist& t) {
  return {Vector3d(t.rot.x(), t.rot.y(), t.rot.z()), Vector3d(t.vel.x(), t.vel.y(), t.vel.z())};
}
Motion scaled(const Motion& m, double s) {
  return {s * m.w, s * m.v};
}
Motion minus(const Motion& a, const Motion& b) {
  return {a.w - b.w, a.v - b.v};
}
// s x m (motion cross product): the rate of change of m carried by the motion s.
Motion cross(const Motion& s, const Motion& m) {
  return {s.w.cross(m.w), s.w.cross(m.v) + s.v.cross(m.w)};
}
// s x* F (force cross product).
Force crossForce(const Motion& s, const Force& F) {
  return {s.w.cross(F.f), s.w.cross(F.n) + s.v.cross(F.f)};
}
double power(const Motion& s, const Force& F) {
  return s.v.dot(F.f) + s.w.dot(F.n);
}
// I m: the momentum of a body of spatial inertia I moving with m.
Force momentum(const SpatialInertia& I, const Motion& m) {
  return {I.mass * m.v - I.first_moment.cross(m.w), I.rotational * m.w + I.first_moment.cross(m.v)};
}
Vector3d velocityAt(const Motion& m, const Vector3d& p) {
  return m.v + m.w.cross(p);
}

// Per joint: its coordinate's column (the index of its mimic root among configurationJoints()).
std::vector<int> columnOfJoint(const RobotModel& model, int* count) {
  std::vector<int> column_of_root(model.jointCount(), -1), out(model.jointCount(), -1);
  int columns = 0;
  for (int j = 0; j < model.jointCount(); ++j) {
    if (model.mimicRoot(j) == j) column_of_root[j] = columns++;
  }
  for (int j = 0; j < model.jointCount(); ++j) out[j] = column_of_root[model.mimicRoot(j)];
  *count = columns;
  return out;
}

// The joint velocity of `joint` (every joint with a coordinate) for the unknowns x: a locked
// joint's is 0, a follower's its multiplier times its root's unknown.
double jointRate(const RobotModel& model, const RobotData& data, int joint,
                 const Eigen::VectorXd& x) {
  const int u = data.unknown_of_joint[joint];
  return u < 0 ? 0.0 : model.mimicMultiplier(joint) * x(u);
}

Motion baseMotion(const RobotModel& model, const RobotData& data, const Eigen::VectorXd& x) {
  Motion m;
  if (model.floating()) {
    for (int b = 0; b < 6; ++b) m += scaled(motionOf(data.base_axes[b]), x(b));
  }
  return m;
}

// The links from the base (exclusive) down to `link`, top-down.
std::vector<int> pathTo(const RobotModel& model, int link) {
  std::vector<int> path;
  for (int l = model.checkLink(link); l > 0; l = model.link(l).parent) path.push_back(l);
  return {path.rbegin(), path.rend()};
}

// d/dq_k of the velocity at p of `link` moving with the link motions V (V[i]: path[i]'s): moving
// joint k (on link K of the path) turns the motion the joints below it add, V_link - V_K, by S_K.
Eigen::Matrix<double, 3, Eigen::Dynamic> velocityByConfiguration(const RobotModel& model,
                                                                 const RobotData& data,
                                                                 const std::vector<int>& path,
                                                                 const std::vector<Motion>& V,
                                                                 const Vector3d& p) {
  int columns = 0;
  const std::vector<int> column = columnOfJoint(model, &columns);
  Eigen::Matrix<double, 3, Eigen::Dynamic> out =
      Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, columns);
  if (path.empty()) return out;
  const Motion& tip = V.back();
  for (std::size_t i = 0; i < path.size(); ++i) {
    const int k = model.link(path[i]).joint;
    if (k < 0) continue;
    out.col(column[k]) += model.mimicMultiplier(k) *
                          velocityAt(cross(motionOf(data.axes[path[i]]), minus(tip, V[i])), p);
  }
  return out;
}

}  // namespace

std::vector<int> configurationJoints(const RobotModel& model) {
  std::vector<int> out;
  for (int j = 0; j < model.jointCount(); ++j) {
    if (model.mimicRoot(j) == j) out.push_back(j);
  }
  return out;
}

Eigen::Matrix<double, 3, Eigen::Dynamic> jacobianProductByConfiguration(
    const RobotModel& model, const RobotData& data, int link, const Eigen::Vector3d& point,
    const Eigen::VectorXd& x) {
  const std::vector<int> path = pathTo(model, link);
  std::vector<Motion> V(path.size());
  Motion m = baseMotion(model, data, x);
  for (std::size_t i = 0; i < path.size(); ++i) {
    const int j = model.link(path[i]).joint;
    if (j >= 0) m += scaled(motionOf(data.axes[path[i]]), jointRate(model, data, j, x));
    V[i] = m;
  }
  return velocityByConfiguration(model, data, path, V, point);
}

Eigen::Matrix<double, 3, Eigen::Dynamic> pointVelocityByConfiguration(
    const RobotModel& model, const RobotData& data, int link, const Eigen::Vector3d& point) {
  const std::vector<int> path = pathTo(model, link);
  std::vector<Motion> V(path.size());
  for (std::size_t i = 0; i < path.size(); ++i) V[i] = motionOf(data.twists[path[i]]);
  return velocityByConfiguration(model, data, path, V, point);
}

Eigen::MatrixXd jacobianTransposeProductByConfiguration(const RobotModel& model,
                                                        const RobotData& data, int link,
                                                        const Eigen::Vector3d& point,
                                                        const Eigen::Vector3d& force) {
  int columns = 0;
  const std::vector<int> column = columnOfJoint(model, &columns);
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(data.unknowns, columns);
  const Force F{force, point.cross(force)};
  const std::vector<int> path = pathTo(model, link);
  // (J^T F)_j = S_j . F; S_j turns with every joint k above it: d/dq_k = (S_k x S_j) . F.
  for (std::size_t a = 0; a < path.size(); ++a) {
    const int k = model.link(path[a]).joint;
    if (k < 0) continue;
    const Motion S_k = motionOf(data.axes[path[a]]);
    for (std::size_t b = a + 1; b < path.size(); ++b) {
      const int j = model.link(path[b]).joint;
      if (j < 0 || data.unknown_of_joint[j] < 0) continue;
      out(data.unknown_of_joint[j], column[k]) +=
          model.mimicMultiplier(j) * model.mimicMultiplier(k) *
          power(cross(S_k, motionOf(data.axes[path[b]])), F);
    }
  }
  return out;
}

Eigen::MatrixXd massMatrixProductByConfiguration(const RobotModel& model, const RobotData& data,
                                                 const Eigen::VectorXd& x) {
  int columns = 0;
  const std::vector<int> column = columnOfJoint(model, &columns);
  const int n = data.unknowns;
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(n, columns);
  if (n == 0) return out;
  const int links = model.linkCount();
  // M x = sum over links of J_l^T I_l A_l, A_l = J_l x the link's motion at the rates x; F_l the
  // momenta I A summed over l's subtree, Ic_l its composite inertia. Moving joint k (link K):
  //   rows j at or below K: -S_j . Ic_J (S_k x A_K);
  //   rows j above K (and the base's): S_j . (S_k x* F_K - Ic_K (S_k x A_K)).
  std::vector<Motion> A(links);
  std::vector<Force> F(links);
  A[0] = baseMotion(model, data, x);
  for (int i = 1; i < links; ++i) {
    const LinkModel& l = model.link(i);
    A[i] = A[l.parent];
    if (l.joint >= 0) A[i] += scaled(motionOf(data.axes[i]), jointRate(model, data, l.joint, x));
  }
  for (int i = 0; i < links; ++i) {
    const SpatialInertia inertia = data.link_inertias_valid
                                       ? data.link_inertias[i]
                                       : worldInertia(model.link(i).local, data.frames[i]);
    F[i] = momentum(inertia, A[i]);
  }
  for (int i = links - 1; i > 0; --i) F[model.link(i).parent] += F[i];
  std::vector<char> below(links);
  for (int K = 1; K < links; ++K) {
    const int k = model.link(K).joint;
    if (k < 0) continue;
    const double mu_k = model.mimicMultiplier(k);
    const Motion S_k = motionOf(data.axes[K]);
    const Motion Z = cross(S_k, A[K]);
    std::fill(below.begin(), below.end(), 0);
    below[K] = 1;
    for (int J = K; J < links; ++J) {
      if (J > K) below[J] = below[model.link(J).parent];
      const int j = model.link(J).joint;
      if (!below[J] || j < 0 || data.unknown_of_joint[j] < 0) continue;
      out(data.unknown_of_joint[j], column[k]) -=
          mu_k * model.mimicMultiplier(j) *
          power(motionOf(data.axes[J]), momentum(data.composite[J], Z));
    }
    Force Y = crossForce(S_k, F[K]);
    const Force IZ = momentum(data.composite[K], Z);
    Y.f -= IZ.f;
    Y.n -= IZ.n;
    for (int J = model.link(K).parent; J > 0; J = model.link(J).parent) {
      const int j = model.link(J).joint;
      if (j < 0 || data.unknown_of_joint[j] < 0) continue;
      out(data.unknown_of_joint[j], column[k]) +=
          mu_k * model.mimicMultiplier(j) * power(motionOf(data.axes[J]), Y);
    }
    if (model.floating()) {
      for (int b = 0; b < 6; ++b) out(b, column[k]) += mu_k * power(motionOf(data.base_axes[b]), Y);
    }
  }
  return out;
}

}  // namespace collision_response::robot
