#include "collision_response/robot/articulated_body.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace collision_response::robot {
namespace {

KDL::Vector toKdl(const Eigen::Vector3d& v) {
  return KDL::Vector(v.x(), v.y(), v.z());
}
Eigen::Vector3d toEigen(const KDL::Vector& v) {
  return Eigen::Vector3d(v.x(), v.y(), v.z());
}

KDL::Frame toKdl(const Eigen::Isometry3d& pose) {
  const Eigen::Matrix3d r = pose.rotation();
  return KDL::Frame(KDL::Rotation(r(0, 0), r(0, 1), r(0, 2), r(1, 0), r(1, 1), r(1, 2), r(2, 0),
                                  r(2, 1), r(2, 2)),
                    toKdl(pose.translation()));
}

Eigen::Matrix3d toEigen(const KDL::Rotation& r) {
  return Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(r.data);
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
template <typename Inertia>
Momentum momentumOf(const Inertia& inertia, const Eigen::Vector3d& w, const Eigen::Vector3d& v) {
  return {inertia.mass * v - inertia.first_moment.cross(w),
          inertia.rotational * w + inertia.first_moment.cross(v)};
}
template <typename Inertia>
Momentum momentumOf(const Inertia& inertia, const KDL::Twist& twist) {
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

}  // namespace

ArticulatedBody::LocalInertia ArticulatedBody::localInertia(const KDL::RigidBodyInertia& inertia) {
  // KDL keeps the rotational inertia about the frame's origin; ours is about the centre of mass.
  LocalInertia out;
  out.mass = inertia.getMass();
  out.com = toEigen(inertia.getCOG());
  const Eigen::Matrix3d about_origin =
      Eigen::Map<const Eigen::Matrix3d>(inertia.getRotationalInertia().data);
  out.about_com = about_origin - pointMassInertia(out.mass, out.com);
  return out;
}

ArticulatedBody::SpatialInertia ArticulatedBody::worldInertia(const Link& link) const {
  const Eigen::Matrix3d r = toEigen(link.frame.M);
  const Eigen::Vector3d c = r * link.local.com + toEigen(link.frame.p);
  const double m = link.local.mass;
  SpatialInertia out;
  out.mass = m;
  out.first_moment = m * c;
  out.rotational = r * link.local.about_com * r.transpose() + pointMassInertia(m, c);
  return out;
}

ArticulatedBody::ArticulatedBody(const KDL::Tree& tree, BaseType base,
                                 const KDL::RigidBodyInertia& base_inertia)
    : base_type_(base) {
  const auto root = tree.getRootSegment();
  if (root == tree.getSegments().end()) throw std::invalid_argument("an empty kinematic tree");
  Link base_link;
  base_link.name = root->first;
  base_link.segment = KDL::Segment(root->first, KDL::Joint(KDL::Joint::Fixed),
                                   KDL::Frame::Identity(), base_inertia);
  base_link.local = localInertia(base_inertia);
  links_.push_back(std::move(base_link));
  // Depth-first, parents before children (children in the tree's order).
  std::vector<std::pair<KDL::SegmentMap::const_iterator, int>> stack;
  for (auto it = root->second.children.rbegin(); it != root->second.children.rend(); ++it) {
    stack.emplace_back(*it, 0);
  }
  std::vector<std::pair<unsigned, int>> joints;  // (q_nr, link)
  while (!stack.empty()) {
    const auto [element, parent] = stack.back();
    stack.pop_back();
    Link link;
    link.name = element->first;
    link.parent = parent;
    link.segment = element->second.segment;
    link.local = localInertia(link.segment.getInertia());
    const int index = static_cast<int>(links_.size());
    if (link.segment.getJoint().getType() != KDL::Joint::Fixed) {
      joints.emplace_back(element->second.q_nr, index);
    }
    links_.push_back(std::move(link));
    const auto& children = element->second.children;
    for (auto it = children.rbegin(); it != children.rend(); ++it) stack.emplace_back(*it, index);
  }
  std::sort(joints.begin(), joints.end());
  for (const auto& [q_nr, link] : joints) {
    links_[link].joint = static_cast<int>(joint_names_.size());
    joint_names_.push_back(links_[link].segment.getJoint().getName());
    link_of_joint_.push_back(link);
  }
  joint_models_.assign(joint_names_.size(), JointModel::kFree);
  armatures_.assign(joint_names_.size(), 0.0);
  mimic_root_.resize(joint_names_.size());
  for (int j = 0; j < jointCount(); ++j) mimic_root_[j] = j;
  mimic_multiplier_.assign(joint_names_.size(), 1.0);
  mimic_offset_.assign(joint_names_.size(), 0.0);
  default_link_ = linkCount() - 1;
  if (base_type_ == BaseType::kFloating) {
    double mass = base_inertia.getMass();
    for (const Link& link : links_) mass += link.segment.getInertia().getMass();
    if (!(mass > 0.0)) throw std::invalid_argument("a floating base robot without mass");
  }
  q_.setZero(jointCount());
  qdot_.setZero(jointCount());
  torques_.setZero(jointCount());
  rebuild();
}

int ArticulatedBody::jointIndex(const std::string& name) const {
  const auto it = std::find(joint_names_.begin(), joint_names_.end(), name);
  if (it == joint_names_.end()) throw std::invalid_argument("no joint '" + name + "'");
  return static_cast<int>(it - joint_names_.begin());
}

int ArticulatedBody::linkIndex(const std::string& name) const {
  for (int i = 0; i < linkCount(); ++i) {
    if (links_[i].name == name) return i;
  }
  throw std::invalid_argument("no link '" + name + "'");
}

int ArticulatedBody::checkLink(int link) const {
  if (link < 0 || link >= linkCount()) {
    throw std::invalid_argument("no link " + std::to_string(link) + " (the robot has " +
                                std::to_string(linkCount()) + ")");
  }
  return link;
}

void ArticulatedBody::setDefaultLink(int link) {
  default_link_ = checkLink(link);
}

void ArticulatedBody::setJointModel(int joint, JointModel model, double armature) {
  if (joint < 0 || joint >= jointCount()) {
    throw std::invalid_argument("no joint " + std::to_string(joint));
  }
  if (!(armature >= 0.0)) throw std::invalid_argument("a negative armature");
  joint_models_[joint] = model;
  armatures_[joint] = model == JointModel::kArmature ? armature : 0.0;
  rebuild();
}

void ArticulatedBody::setMimicJoints(const std::vector<MimicJoint>& mimics) {
  // Each joint's direct leader (-1: none), then every chain followed to its root.
  const int n = jointCount();
  std::vector<int> leader(n, -1);
  std::vector<double> multiplier(n, 1.0), offset(n, 0.0);
  for (const MimicJoint& mimic : mimics) {
    const auto find = [this](const std::string& name) {
      const auto it = std::find(joint_names_.begin(), joint_names_.end(), name);
      return it == joint_names_.end() ? -1 : static_cast<int>(it - joint_names_.begin());
    };
    const std::string what = "mimic joint '" + mimic.joint + "'";
    const int joint = find(mimic.joint);
    if (joint < 0)
      throw std::invalid_argument(what + ": the robot has no such joint with a coordinate");
    const int lead = find(mimic.leader);
    if (lead < 0) {
      throw std::invalid_argument(what + ": its leader '" + mimic.leader +
                                  "' is not a joint of the robot with a coordinate");
    }
    if (leader[joint] >= 0) throw std::invalid_argument(what + ": given two leaders");
    if (!std::isfinite(mimic.multiplier) || !std::isfinite(mimic.offset)) {
      throw std::invalid_argument(what + ": its multiplier or offset is not finite");
    }
    leader[joint] = lead;
    multiplier[joint] = mimic.multiplier;
    offset[joint] = mimic.offset;
  }
  std::vector<int> root(n);
  std::vector<double> root_multiplier(n), root_offset(n);
  for (int j = 0; j < n; ++j) {
    // q_j = m_j q_l + o_j, q_l = m_l q_r + o_l, ...: multipliers multiply, offsets compose.
    int at = j, steps = 0;
    double m = 1.0, o = 0.0;
    while (leader[at] >= 0) {
      if (++steps > n) {  // after n steps along the leaders, `at` lies on a cycle
        std::string cycle = "'" + joint_names_[at] + "'";
        for (int k = leader[at];; k = leader[k]) {
          cycle += " -> '" + joint_names_[k] + "'";
          if (k == at) break;
        }
        throw std::invalid_argument("mimic joint '" + joint_names_[j] +
                                    "': its leaders form a cycle (" + cycle + ")");
      }
      o = o + m * offset[at];
      m *= multiplier[at];
      at = leader[at];
    }
    root[j] = at;
    root_multiplier[j] = m;
    root_offset[j] = o;
  }
  mimic_root_ = std::move(root);
  mimic_multiplier_ = std::move(root_multiplier);
  mimic_offset_ = std::move(root_offset);
  has_mimics_ = false;
  for (int j = 0; j < n; ++j) has_mimics_ |= mimic_root_[j] != j;
  rebuild();
}

void ArticulatedBody::deriveMimicState() {
  for (int j = 0; j < jointCount(); ++j) {
    const int root = mimic_root_[j];
    if (root == j) continue;
    q_(j) = mimic_multiplier_[j] * q_(root) + mimic_offset_[j];
    qdot_(j) = mimic_multiplier_[j] * qdot_(root);
  }
}

void ArticulatedBody::rebuild() {
  // Unknowns: the base twist first, then the joints that are not locked, in joint order; a mimic
  // joint shares its root's, and a group is locked if any of its joints that move with the root is.
  unknown_of_joint_.assign(jointCount(), -1);
  joint_of_unknown_.clear();
  if (base_type_ == BaseType::kFloating) joint_of_unknown_.assign(6, -1);
  std::vector<bool> locked(jointCount(), false);
  for (int j = 0; j < jointCount(); ++j) {
    if (joint_models_[j] == JointModel::kLocked &&
        (mimic_root_[j] == j || mimic_multiplier_[j] != 0.0))
      locked[mimic_root_[j]] = true;
  }
  for (int j = 0; j < jointCount(); ++j) {
    if (mimic_root_[j] != j || locked[j]) continue;
    unknown_of_joint_[j] = static_cast<int>(joint_of_unknown_.size());
    joint_of_unknown_.push_back(j);
  }
  if (has_mimics_) {
    for (int j = 0; j < jointCount(); ++j) unknown_of_joint_[j] = unknown_of_joint_[mimic_root_[j]];
    deriveMimicState();
  }
  unknowns_ = static_cast<int>(joint_of_unknown_.size());
  updateKinematics();
  updateMassMatrix();
  factorise();
}

void ArticulatedBody::setState(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot,
                               const Eigen::Isometry3d& base_pose,
                               const Eigen::Vector3d& base_linear_velocity,
                               const Eigen::Vector3d& base_angular_velocity) {
  if (q.size() != jointCount() || qdot.size() != jointCount()) {
    throw std::invalid_argument("joint positions and velocities need " +
                                std::to_string(jointCount()) + " entries each");
  }
  q_ = q;
  qdot_ = qdot;
  if (has_mimics_) deriveMimicState();
  base_pose_ = toKdl(base_pose);
  if (base_type_ == BaseType::kFloating) {
    base_linear_velocity_ = base_linear_velocity;
    base_angular_velocity_ = base_angular_velocity;
  }
  updateKinematics();
  updateMassMatrix();
  factorise();
  requireRegular();
}

Eigen::Isometry3d ArticulatedBody::linkPose(int link) const {
  const KDL::Frame& f = links_[checkLink(link)].frame;
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.linear()(r, c) = f.M(r, c);
    out.translation()(r) = f.p(r);
  }
  return out;
}

void ArticulatedBody::updateKinematics() {
  Link& base = links_[0];
  base.frame = base_pose_;
  const KDL::Vector o = base_pose_.p;
  for (int k = 0; k < 3; ++k) {
    KDL::Vector e = KDL::Vector::Zero();
    e(k) = 1.0;
    base_axes_[k] = KDL::Twist(e, KDL::Vector::Zero());
    base_axes_[3 + k] = KDL::Twist(o * e, e);  // w e_k about the base origin: v(0) = o x e_k
  }
  for (std::size_t i = 1; i < links_.size(); ++i) {
    Link& link = links_[i];
    const KDL::Frame& parent = links_[link.parent].frame;
    const KDL::Joint& joint = link.segment.getJoint();
    const double q = link.joint >= 0 ? q_(link.joint) : 0.0;
    link.frame = parent * link.segment.pose(q);
    if (link.joint < 0) {
      link.axis = KDL::Twist::Zero();
    } else {
      const KDL::Vector axis = parent.M * joint.JointAxis();
      const bool rotation = joint.getType() <= KDL::Joint::RotZ;
      if (rotation) {
        const KDL::Vector origin = parent * joint.JointOrigin();
        link.axis = KDL::Twist(origin * axis, axis);  // w a through o: v(0) = o x a
      } else {
        link.axis = KDL::Twist(axis, KDL::Vector::Zero());
      }
    }
  }
  updateTwists();
}

void ArticulatedBody::updateTwists() {
  free_accelerations_valid_ = false;
  Link& base = links_[0];
  const KDL::Vector w = toKdl(base_angular_velocity_);
  base.twist = KDL::Twist(toKdl(base_linear_velocity_) + base.frame.p * w, w);
  for (std::size_t i = 1; i < links_.size(); ++i) {
    Link& link = links_[i];
    link.twist = links_[link.parent].twist;
    if (link.joint >= 0) link.twist += link.axis * qdot_(link.joint);
  }
}

const KDL::Twist& ArticulatedBody::unknownAxis(int k) const {
  const int joint = joint_of_unknown_[k];
  return joint < 0 ? base_axes_[k] : links_[link_of_joint_[joint]].axis;
}

void ArticulatedBody::updateMassMatrix() {
  const int n = unknowns_;
  mass_matrix_.setZero(n, n);
  if (n == 0) return;  // nothing moves: no inertia is needed
  // Composite inertias, children before parents (world frame, reference point the origin: sums).
  for (Link& link : links_) link.composite = worldInertia(link);
  for (std::size_t i = links_.size() - 1; i > 0; --i) {
    links_[links_[i].parent].composite += links_[i].composite;
  }
  if (has_mimics_) {
    updateMimicMassMatrix();
    return;
  }
  // M_jk = S_j . (Ic_k S_k) for j on the path from k's link to the base: the momentum of k's
  // subtree moving at a unit rate, seen by every joint that carries that subtree.
  const int base_unknowns = base_type_ == BaseType::kFloating ? 6 : 0;
  for (int k = 0; k < n; ++k) {
    const int joint = joint_of_unknown_[k];
    const int own = joint < 0 ? 0 : link_of_joint_[joint];
    const Momentum force = momentumOf(links_[own].composite, unknownAxis(k));
    for (int l = own; l >= 0; l = links_[l].parent) {
      const int j = links_[l].joint;
      if (l == 0) {
        for (int b = 0; b < base_unknowns; ++b) {
          mass_matrix_(b, k) = mass_matrix_(k, b) = power(base_axes_[b], force);
        }
      } else if (j >= 0 && unknown_of_joint_[j] >= 0) {
        const int u = unknown_of_joint_[j];
        mass_matrix_(u, k) = mass_matrix_(k, u) = power(links_[l].axis, force);
      }
    }
    if (joint >= 0) mass_matrix_(k, k) += armatures_[joint];
  }
}

void ArticulatedBody::updateMimicMassMatrix() {
  // M = T^T M_all T, where M_all is the inertia in the velocities of the base and of every joint
  // that moves (a mimic's own included) and T maps the unknowns to them (entry multiplier_j in
  // joint j's row, root's column). Each entry of M_all is visited once, a pair (j, k) with j on
  // the path from k's link to the base, and added to the unknowns' entries with the multipliers.
  const int base_unknowns = base_type_ == BaseType::kFloating ? 6 : 0;
  for (int b = 0; b < base_unknowns; ++b) {  // the base's own block, as without mimics
    const Momentum force = momentumOf(links_[0].composite, base_axes_[b]);
    for (int c = 0; c <= b; ++c)
      mass_matrix_(b, c) = mass_matrix_(c, b) = power(base_axes_[c], force);
  }
  for (int k = 0; k < jointCount(); ++k) {
    const int u = unknown_of_joint_[k];
    if (u < 0) continue;
    const double mk = mimic_multiplier_[k];
    const int own = link_of_joint_[k];
    const Momentum force = momentumOf(links_[own].composite, links_[own].axis);
    for (int l = own; l >= 0; l = links_[l].parent) {
      if (l == 0) {
        for (int b = 0; b < base_unknowns; ++b) {
          const double value = mk * power(base_axes_[b], force);
          mass_matrix_(b, u) += value;
          mass_matrix_(u, b) += value;
        }
        continue;
      }
      const int j = links_[l].joint;
      if (j < 0 || unknown_of_joint_[j] < 0) continue;
      const int v = unknown_of_joint_[j];
      const double value = mk * mimic_multiplier_[j] * power(links_[l].axis, force);
      mass_matrix_(v, u) += value;
      if (j != k) mass_matrix_(u, v) += value;
    }
    mass_matrix_(u, u) += mk * mk * armatures_[k];
  }
}

Eigen::VectorXd ArticulatedBody::foldJointForces(
    const Eigen::VectorXd& joint_forces, const Eigen::Matrix<double, 6, 1>& base_forces) const {
  Eigen::VectorXd folded = Eigen::VectorXd::Zero(unknowns_);
  if (base_type_ == BaseType::kFloating) folded.head<6>() = base_forces;
  for (int j = 0; j < jointCount(); ++j) {
    const int u = unknown_of_joint_[j];
    if (u >= 0) folded(u) += mimic_multiplier_[j] * joint_forces(j);
  }
  return folded;
}

void ArticulatedBody::requireRegular() const {
  if (!singular_.empty()) throw std::invalid_argument(singular_);
}

void ArticulatedBody::factorise() {
  const int n = unknowns_;
  singular_.clear();
  if (n == 0) return;
  // M = L L^T by Cholesky's algorithm, L in the lower triangle of cholesky_ (plain loops: for a
  // few unknowns a fraction of the cost of Eigen's LLT, whose column updates are general matrix
  // products). Its pivots come in unknown order: the pivot of unknown k is that of M's leading
  // (k+1) block, so the first one that vanishes (below kSingularPivot times M's largest diagonal
  // entry) names the first unknown whose motion moves no mass the others do not.
  const double scale = mass_matrix_.diagonal().maxCoeff();
  cholesky_ = mass_matrix_;
  int bad = scale > 0.0 ? -1 : 0;
  for (int j = 0; j < n && bad < 0; ++j) {
    double pivot = cholesky_(j, j);
    for (int k = 0; k < j; ++k) pivot -= cholesky_(j, k) * cholesky_(j, k);
    if (!(pivot > kSingularPivot * scale)) {
      bad = j;
      break;
    }
    const double l = std::sqrt(pivot), inverse = 1.0 / l;
    cholesky_(j, j) = l;
    for (int i = j + 1; i < n; ++i) {
      double v = cholesky_(i, j);
      for (int k = 0; k < j; ++k) v -= cholesky_(i, k) * cholesky_(j, k);
      cholesky_(i, j) = v * inverse;
    }
  }
  if (bad >= 0) {
    const int joint = joint_of_unknown_[bad];
    singular_ =
        (joint < 0 ? std::string("singular joint-space inertia at the floating base")
                   : "singular joint-space inertia: joint '" + joint_names_[joint] +
                         "' moves no mass (massless links beyond it); lock it or give them mass");
  }
}

Eigen::VectorXd ArticulatedBody::velocity() const {
  Eigen::VectorXd v(unknowns_);
  for (int k = 0; k < unknowns_; ++k) {
    const int joint = joint_of_unknown_[k];
    v(k) = joint >= 0 ? qdot_(joint)
                      : (k < 3 ? base_linear_velocity_(k) : base_angular_velocity_(k - 3));
  }
  return v;
}

void ArticulatedBody::addVelocityChange(const Eigen::Ref<const Eigen::VectorXd>& change) {
  if (has_mimics_) {  // the roots take the change, their groups follow (exactly m qdot_root)
    for (int j = 0; j < jointCount(); ++j) {
      if (mimic_root_[j] == j && unknown_of_joint_[j] >= 0)
        qdot_(j) += change(unknown_of_joint_[j]);
    }
    for (int j = 0; j < jointCount(); ++j) {
      if (mimic_root_[j] != j && unknown_of_joint_[j] >= 0)
        qdot_(j) = mimic_multiplier_[j] * qdot_(mimic_root_[j]);
    }
    for (int k = 0; k < unknowns_ && joint_of_unknown_[k] < 0; ++k) {
      if (k < 3) {
        base_linear_velocity_(k) += change(k);
      } else {
        base_angular_velocity_(k - 3) += change(k);
      }
    }
    updateTwists();
    return;
  }
  for (int k = 0; k < unknowns_; ++k) {
    const int joint = joint_of_unknown_[k];
    if (joint >= 0) {
      qdot_(joint) += change(k);
    } else if (k < 3) {
      base_linear_velocity_(k) += change(k);
    } else {
      base_angular_velocity_(k - 3) += change(k);
    }
  }
  updateTwists();
}

Eigen::Vector3d ArticulatedBody::partPointVelocity(int part, const Eigen::Vector3d& point) const {
  return velocityAt(links_[checkLink(part < 0 ? default_link_ : part)].twist, point);
}

Eigen::Matrix<double, 3, Eigen::Dynamic> ArticulatedBody::linkPointJacobian(
    int link, const Eigen::Vector3d& point) const {
  Eigen::Matrix<double, 3, Eigen::Dynamic> jacobian =
      Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, unknowns_);
  if (has_mimics_) {  // a mimic's column folds into its root's (two may share a path)
    for (int l = checkLink(link); l > 0; l = links_[l].parent) {
      const int j = links_[l].joint;
      if (j >= 0 && unknown_of_joint_[j] >= 0) {
        jacobian.col(unknown_of_joint_[j]) +=
            mimic_multiplier_[j] * velocityAt(links_[l].axis, point);
      }
    }
  } else {
    for (int l = checkLink(link); l > 0; l = links_[l].parent) {
      const int j = links_[l].joint;
      if (j >= 0 && unknown_of_joint_[j] >= 0) {
        jacobian.col(unknown_of_joint_[j]) = velocityAt(links_[l].axis, point);
      }
    }
  }
  if (base_type_ == BaseType::kFloating) {
    for (int b = 0; b < 6; ++b) jacobian.col(b) = velocityAt(base_axes_[b], point);
  }
  return jacobian;
}

Eigen::Matrix<double, 3, Eigen::Dynamic> ArticulatedBody::partPointJacobian(
    int part, const Eigen::Vector3d& point) const {
  return linkPointJacobian(part < 0 ? default_link_ : part, point);
}

Eigen::Matrix<double, Eigen::Dynamic, 3> ArticulatedBody::partInverseMassJacobianTranspose(
    int part, const Eigen::Vector3d& point) const {
  if (unknowns_ == 0) return Eigen::Matrix<double, Eigen::Dynamic, 3>(0, 3);
  requireRegular();
  Eigen::Matrix<double, Eigen::Dynamic, 3> x = partPointJacobian(part, point).transpose();
  solveWithCholesky(cholesky_, unknowns_, x);
  return x;
}

Eigen::VectorXd ArticulatedBody::jointTorquesOf(int link, const Eigen::Vector3d& point,
                                                const Eigen::Vector3d& force) const {
  Eigen::VectorXd torques = Eigen::VectorXd::Zero(jointCount());
  for (int l = checkLink(link); l > 0; l = links_[l].parent) {
    const int j = links_[l].joint;
    if (j >= 0) torques(j) = velocityAt(links_[l].axis, point).dot(force);
  }
  return torques;
}

Eigen::VectorXd ArticulatedBody::restingContactTorques(
    int self, const std::vector<core::ContactPoint>& contacts,
    const std::vector<core::ContactImpulse>& answers) const {
  Eigen::VectorXd torques;
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const core::ContactPoint& contact = contacts[c];
    if (!answers[c].resting || (contact.body_a != self && contact.body_b != self)) continue;
    if (torques.size() == 0) torques.setZero(jointCount());
    const Eigen::Vector3d force =
        answers[c].normal_force * contact.normal + answers[c].friction_force;
    if (contact.body_a == self) torques -= jointTorquesOf(contact.part_a, contact.point, force);
    if (contact.body_b == self) torques += jointTorquesOf(contact.part_b, contact.point, force);
  }
  return torques;
}

double ArticulatedBody::kineticEnergy() const {
  double energy = 0.0;
  for (const Link& link : links_) {
    energy += 0.5 * power(link.twist, momentumOf(worldInertia(link), link.twist));
  }
  return energy;
}

Eigen::Matrix<double, 6, 1> ArticulatedBody::momentum() const {
  Eigen::Matrix<double, 6, 1> out = Eigen::Matrix<double, 6, 1>::Zero();
  for (const Link& link : links_) {
    const Momentum p = momentumOf(worldInertia(link), link.twist);
    out.head<3>() += p.linear;
    out.tail<3>() += p.angular;
  }
  return out;
}

void ArticulatedBody::setLoads(const Eigen::VectorXd& joint_torques,
                               const Eigen::Vector3d& gravity) {
  if (joint_torques.size() != jointCount()) {
    throw std::invalid_argument("joint torques need " + std::to_string(jointCount()) + " entries");
  }
  torques_ = joint_torques;
  gravity_ = gravity;
  gravity_compensation_ = false;
  free_accelerations_valid_ = false;
}

void ArticulatedBody::setGravityCompensation(const Eigen::Vector3d& gravity) {
  torques_.setZero(jointCount());
  gravity_ = gravity;
  gravity_compensation_ = true;
  free_accelerations_valid_ = false;
}

Eigen::VectorXd ArticulatedBody::jointTorques() const {
  return gravity_compensation_ ? gravityTorques() : torques_;
}

void ArticulatedBody::inverseDynamics(const Eigen::VectorXd& joint_accelerations,
                                      const Eigen::Matrix<double, 6, 1>& base_acceleration,
                                      bool with_velocity, Eigen::VectorXd& joint_forces,
                                      Eigen::Matrix<double, 6, 1>& base_forces,
                                      std::vector<Acceleration>* accelerations) const {
  const std::size_t n = links_.size();
  std::vector<Acceleration> acceleration(n);
  std::vector<Momentum> force(n);  // (force [N], moment about the origin [N m]) on each link
  // The base: the time derivative of its twist at the origin, (alpha, a_b - alpha x p - w x v_b)
  // for its origin p moving at v_b with acceleration a_b.
  if (base_type_ == BaseType::kFloating) {
    const Eigen::Vector3d alpha = base_acceleration.tail<3>();
    acceleration[0].angular = alpha;
    acceleration[0].linear = base_acceleration.head<3>() - alpha.cross(toEigen(links_[0].frame.p));
    if (with_velocity) {
      acceleration[0].linear -= base_angular_velocity_.cross(base_linear_velocity_);
    }
  }
  // Outwards: A_i = A_parent + S_i qddot_i + (V_i x S_i) qdot_i (the axis moves with the parent).
  for (std::size_t i = 1; i < n; ++i) {
    const Link& link = links_[i];
    acceleration[i] = acceleration[link.parent];
    if (link.joint < 0) continue;
    const Eigen::Vector3d s_w = toEigen(link.axis.rot), s_v = toEigen(link.axis.vel);
    const double qddot = joint_accelerations(link.joint);
    acceleration[i].angular += s_w * qddot;
    acceleration[i].linear += s_v * qddot;
    if (with_velocity) {
      const double qdot = qdot_(link.joint);
      const Eigen::Vector3d w = toEigen(link.twist.rot), v = toEigen(link.twist.vel);
      acceleration[i].angular += w.cross(s_w) * qdot;
      acceleration[i].linear += (w.cross(s_v) + v.cross(s_w)) * qdot;
    }
  }
  // Each link's rate of change of momentum, I (A - (0, g)) + V x* (I V): gravity as an upward
  // acceleration of the frame, so that the forces are what the joints must transmit.
  for (std::size_t i = 0; i < n; ++i) {
    const SpatialInertia inertia = worldInertia(links_[i]);
    force[i] = momentumOf(inertia, acceleration[i].angular, acceleration[i].linear - gravity_);
    if (with_velocity) {
      const Eigen::Vector3d w = toEigen(links_[i].twist.rot), v = toEigen(links_[i].twist.vel);
      const Momentum p = momentumOf(inertia, w, v);
      force[i].linear += w.cross(p.linear);
      force[i].angular += w.cross(p.angular) + v.cross(p.linear);
    }
  }
  // Inwards: each joint carries its subtree; its generalized force is its axis' power.
  joint_forces.setZero(jointCount());
  for (std::size_t i = n - 1; i > 0; --i) {
    const Link& link = links_[i];
    if (link.joint >= 0) joint_forces(link.joint) = power(link.axis, force[i]);
    force[link.parent].linear += force[i].linear;
    force[link.parent].angular += force[i].angular;
  }
  base_forces.setZero();
  if (base_type_ == BaseType::kFloating) {
    for (int k = 0; k < 6; ++k) base_forces(k) = power(base_axes_[k], force[0]);
  }
  if (accelerations != nullptr) *accelerations = std::move(acceleration);
}

Eigen::VectorXd ArticulatedBody::gravityTorques() const {
  Eigen::VectorXd torques;
  Eigen::Matrix<double, 6, 1> base;
  inverseDynamics(Eigen::VectorXd::Zero(jointCount()), Eigen::Matrix<double, 6, 1>::Zero(), false,
                  torques, base, nullptr);
  return torques;
}

Eigen::VectorXd ArticulatedBody::biasForces() const {
  Eigen::VectorXd joint_forces;
  Eigen::Matrix<double, 6, 1> base;
  inverseDynamics(Eigen::VectorXd::Zero(jointCount()), Eigen::Matrix<double, 6, 1>::Zero(), true,
                  joint_forces, base, nullptr);
  return foldJointForces(joint_forces, base);
}

Eigen::VectorXd ArticulatedBody::freeAcceleration() const {
  if (unknowns_ == 0) return Eigen::VectorXd();
  requireRegular();
  Eigen::VectorXd rhs =
      foldJointForces(jointTorques(), Eigen::Matrix<double, 6, 1>::Zero()) - biasForces();
  solveWithCholesky(cholesky_, unknowns_, rhs);
  return rhs;  // M^-1 (tau - h)
}

void ArticulatedBody::updateFreeAccelerations() const {
  const Eigen::VectorXd vdot = freeAcceleration();
  Eigen::VectorXd joint_accelerations = Eigen::VectorXd::Zero(jointCount());
  Eigen::Matrix<double, 6, 1> base = Eigen::Matrix<double, 6, 1>::Zero();
  for (int j = 0; j < jointCount(); ++j) {
    const int u = unknown_of_joint_[j];
    if (u >= 0) joint_accelerations(j) = mimic_multiplier_[j] * vdot(u);
  }
  for (int k = 0; k < unknowns_ && joint_of_unknown_[k] < 0; ++k) base(k) = vdot(k);
  Eigen::VectorXd joint_forces;
  Eigen::Matrix<double, 6, 1> base_forces;
  inverseDynamics(joint_accelerations, base, true, joint_forces, base_forces, &free_accelerations_);
  free_accelerations_valid_ = true;
}

Eigen::Vector3d ArticulatedBody::partPointFreeAcceleration(int part,
                                                           const Eigen::Vector3d& point) const {
  const int link = checkLink(part < 0 ? default_link_ : part);
  if (!free_accelerations_valid_) updateFreeAccelerations();
  // a_p = dv_o/dt + alpha x p + w x v_p for the material point at p.
  const Acceleration& a = free_accelerations_[link];
  const Eigen::Vector3d w = toEigen(links_[link].twist.rot);
  return a.linear + a.angular.cross(point) + w.cross(velocityAt(links_[link].twist, point));
}

}  // namespace collision_response::robot
