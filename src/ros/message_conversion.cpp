#include "collision_response/ros/message_conversion.h"

#include <cmath>

#include "collision_response/core/errors.h"
#include "collision_response/core/validation.h"

namespace collision_response {

Eigen::Vector3d toEigen(const geometry_msgs::Vector3& v) {
  return {v.x, v.y, v.z};
}
Eigen::Vector3d toEigen(const geometry_msgs::Point& p) {
  return {p.x, p.y, p.z};
}

geometry_msgs::Vector3 toVector3(const Eigen::Vector3d& v) {
  geometry_msgs::Vector3 out;
  out.x = v.x();
  out.y = v.y();
  out.z = v.z();
  return out;
}

geometry_msgs::Point toPoint(const Eigen::Vector3d& p) {
  geometry_msgs::Point out;
  out.x = p.x();
  out.y = p.y();
  out.z = p.z();
  return out;
}

core::BodyState fromMsg(const BodyState& msg) {
  core::BodyState state;
  state.id = msg.id;
  const geometry_msgs::Inertia& inertia = msg.inertia;
  state.mass = inertia.m;
  state.com = toEigen(inertia.com);
  state.inertia << inertia.ixx, inertia.ixy, inertia.ixz,  //
      inertia.ixy, inertia.iyy, inertia.iyz,               //
      inertia.ixz, inertia.iyz, inertia.izz;
  state.position = toEigen(msg.pose.position);
  const geometry_msgs::Quaternion& q = msg.pose.orientation;
  state.orientation = Eigen::Quaterniond(q.w, q.x, q.y, q.z);
  state.linear_velocity = toEigen(msg.twist.linear);
  state.angular_velocity = toEigen(msg.twist.angular);
  state.force = toEigen(msg.wrench.force);
  state.torque = toEigen(msg.wrench.torque);
  return state;
}

BodyState toMsg(const core::BodyState& state, const std::string& frame_id) {
  BodyState msg;
  msg.id = state.id;
  msg.frame_id = frame_id;
  msg.inertia.m = state.mass;
  msg.inertia.com = toVector3(state.com);
  msg.inertia.ixx = state.inertia(0, 0);
  msg.inertia.ixy = state.inertia(0, 1);
  msg.inertia.ixz = state.inertia(0, 2);
  msg.inertia.iyy = state.inertia(1, 1);
  msg.inertia.iyz = state.inertia(1, 2);
  msg.inertia.izz = state.inertia(2, 2);
  msg.pose.position.x = state.position.x();
  msg.pose.position.y = state.position.y();
  msg.pose.position.z = state.position.z();
  msg.pose.orientation.w = state.orientation.w();
  msg.pose.orientation.x = state.orientation.x();
  msg.pose.orientation.y = state.orientation.y();
  msg.pose.orientation.z = state.orientation.z();
  msg.twist.linear = toVector3(state.linear_velocity);
  msg.twist.angular = toVector3(state.angular_velocity);
  msg.wrench.force = toVector3(state.force);
  msg.wrench.torque = toVector3(state.torque);
  return msg;
}

core::Contact fromMsg(const Contact& msg) {
  core::Contact contact;
  contact.body_a = msg.body_a;
  contact.body_b = msg.body_b;
  contact.point = toEigen(msg.point);
  contact.normal = toEigen(msg.normal);
  contact.restitution = msg.restitution;
  contact.static_friction = msg.static_friction;
  contact.dynamic_friction = msg.dynamic_friction;
  return contact;
}

Contact toMsg(const core::Contact& contact) {
  Contact msg;
  msg.body_a = contact.body_a;
  msg.body_b = contact.body_b;
  msg.point = toPoint(contact.point);
  msg.normal = toVector3(contact.normal);
  msg.restitution = contact.restitution;
  msg.static_friction = contact.static_friction;
  msg.dynamic_friction = contact.dynamic_friction;
  return msg;
}

bool hasGeometry(const BodyState& msg) {
  return !msg.primitives.empty() || !msg.meshes.empty() || !msg.planes.empty();
}

void countGeometry(const BodyState& msg, std::size_t& shapes, std::size_t& vertices,
                   std::size_t& triangles) {
  shapes += msg.primitives.size() + msg.meshes.size() + msg.planes.size();
  for (const shape_msgs::Mesh& mesh : msg.meshes) {
    vertices += mesh.vertices.size();
    triangles += mesh.triangles.size();
  }
}

detection::BodyGeometry geometryFromMsg(const BodyState& msg, const std::string& field) {
  const auto checkCount = [&](std::size_t shapes, std::size_t poses, const char* name) {
    if (shapes != poses) {
      throw core::InvalidInput(field + "." + name, "has " + std::to_string(poses) +
                                                       " entries for " + std::to_string(shapes) +
                                                       " shapes: give one pose per shape");
    }
  };
  checkCount(msg.primitives.size(), msg.primitive_poses.size(), "primitive_poses");
  checkCount(msg.meshes.size(), msg.mesh_poses.size(), "mesh_poses");
  checkCount(msg.planes.size(), msg.plane_poses.size(), "plane_poses");

  const auto pose = [&](const geometry_msgs::Pose& p, const std::string& pose_field) {
    const geometry_msgs::Quaternion& q = p.orientation;
    const Eigen::Quaterniond rotation(q.w, q.x, q.y, q.z);
    const double norm = rotation.coeffs().norm();
    if (norm == 0.0) {
      throw core::InvalidInput(pose_field + ".orientation",
                               "is a zero quaternion (orientation.w: 1 means no rotation)");
    }
    if (!(std::abs(norm - 1.0) <= core::kUnitTolerance)) {
      throw core::InvalidInput(pose_field + ".orientation",
                               "is not a unit quaternion (norm " + std::to_string(norm) + ")");
    }
    Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
    out.translate(toEigen(p.position));
    out.rotate(rotation.normalized().toRotationMatrix());
    return out;
  };

  detection::BodyGeometry geometry;
  geometry.shapes.reserve(msg.primitives.size() + msg.meshes.size() + msg.planes.size());
  for (std::size_t i = 0; i < msg.primitives.size(); ++i) {
    const shape_msgs::SolidPrimitive& primitive = msg.primitives[i];
    const std::string index = "[" + std::to_string(i) + "]";
    detection::Shape shape;
    switch (primitive.type) {
      case shape_msgs::SolidPrimitive::BOX:
        shape.type = detection::Shape::Type::kBox;
        break;
      case shape_msgs::SolidPrimitive::SPHERE:
        shape.type = detection::Shape::Type::kSphere;
        break;
      case shape_msgs::SolidPrimitive::CYLINDER:
        shape.type = detection::Shape::Type::kCylinder;
        break;
      case shape_msgs::SolidPrimitive::CONE:
        shape.type = detection::Shape::Type::kCone;
        break;
      default:
        throw core::InvalidInput(field + ".primitives" + index + ".type",
                                 "unknown type " + std::to_string(primitive.type) +
                                     " (BOX 1, SPHERE 2, CYLINDER 3, CONE 4)");
    }
    shape.dimensions.assign(primitive.dimensions.begin(), primitive.dimensions.end());
    shape.pose = pose(msg.primitive_poses[i], field + ".primitive_poses" + index);
    geometry.shapes.push_back(std::move(shape));
  }
  for (std::size_t i = 0; i < msg.meshes.size(); ++i) {
    const shape_msgs::Mesh& mesh = msg.meshes[i];
    const std::string index = "[" + std::to_string(i) + "]";
    detection::Shape shape;
    shape.type = detection::Shape::Type::kMesh;
    shape.vertices.reserve(mesh.vertices.size());
    for (const geometry_msgs::Point& v : mesh.vertices) shape.vertices.push_back(toEigen(v));
    shape.triangles.reserve(mesh.triangles.size());
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      std::array<int, 3> triangle{};
      for (int k = 0; k < 3; ++k) {
        const uint32_t vertex = mesh.triangles[t].vertex_indices[k];
        if (vertex >= mesh.vertices.size()) {
          throw core::InvalidInput(
              field + ".meshes" + index + ".triangles[" + std::to_string(t) + "]",
              "vertex index " + std::to_string(vertex) + " is out of range (" +
                  std::to_string(mesh.vertices.size()) + " vertices)");
        }
        triangle[k] = static_cast<int>(vertex);
      }
      shape.triangles.push_back(triangle);
    }
    shape.pose = pose(msg.mesh_poses[i], field + ".mesh_poses" + index);
    geometry.shapes.push_back(std::move(shape));
  }
  for (std::size_t i = 0; i < msg.planes.size(); ++i) {
    detection::Shape shape;
    shape.type = detection::Shape::Type::kPlane;
    shape.dimensions.assign(msg.planes[i].coef.begin(), msg.planes[i].coef.end());
    shape.pose = pose(msg.plane_poses[i], field + ".plane_poses[" + std::to_string(i) + "]");
    geometry.shapes.push_back(std::move(shape));
  }
  return geometry;
}

detection::DetectionOptions fromMsg(const DetectionOptions& msg, double default_tolerance) {
  detection::DetectionOptions options;
  options.contact_tolerance =
      msg.contact_tolerance != 0.0 ? msg.contact_tolerance : default_tolerance;
  return options;
}

detection::DetectionInput detectionInputFromMsg(const std::vector<BodyState>& bodies,
                                                const DetectionOptions& msg,
                                                double default_tolerance) {
  detection::DetectionInput input;
  input.options = fromMsg(msg, default_tolerance);
  input.defaults = {msg.restitution, msg.static_friction, msg.dynamic_friction};
  input.geometry.reserve(bodies.size());
  input.materials.reserve(bodies.size());
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    input.geometry.push_back(geometryFromMsg(bodies[i], "bodies[" + std::to_string(i) + "]"));
    input.materials.push_back(bodies[i].material);
  }
  return input;
}

ContactImpulse toMsg(const core::ContactImpulse& impulse) {
  ContactImpulse msg;
  msg.normal_impulse = impulse.normal_impulse;
  msg.friction_impulse = toVector3(impulse.friction_impulse);
  msg.sticking = impulse.sticking;
  msg.normal_velocity_before = impulse.normal_velocity_before;
  msg.normal_velocity_after = impulse.normal_velocity_after;
  msg.resting = impulse.resting;
  msg.normal_force = impulse.normal_force;
  msg.friction_force = toVector3(impulse.friction_force);
  return msg;
}

IslandReport toMsg(const core::SolveReport& report) {
  IslandReport msg;
  msg.contact_indices.assign(report.contacts.begin(), report.contacts.end());
  msg.method = core::toString(report.method);
  msg.iterations = static_cast<uint32_t>(report.iterations);
  msg.residual = report.residual;
  msg.converged = report.converged;
  return msg;
}

ImpactDerivatives derivativesMsg(core::DerivativeMethod method, const Eigen::MatrixXd& jacobian,
                                 std::vector<std::string> row_labels,
                                 std::vector<std::string> column_labels,
                                 const std::vector<core::ContactDerivativeMode>& contacts) {
  ImpactDerivatives msg;
  msg.method = core::toString(method);
  msg.rows = static_cast<uint32_t>(jacobian.rows());
  msg.columns = static_cast<uint32_t>(jacobian.cols());
  msg.row_labels = std::move(row_labels);
  msg.column_labels = std::move(column_labels);
  msg.jacobian.reserve(static_cast<std::size_t>(jacobian.size()));
  for (Eigen::Index r = 0; r < jacobian.rows(); ++r)
    for (Eigen::Index k = 0; k < jacobian.cols(); ++k) msg.jacobian.push_back(jacobian(r, k));
  msg.contacts.reserve(contacts.size());
  for (const core::ContactDerivativeMode& contact : contacts) {
    ContactDerivative entry;
    entry.mode = core::toString(contact.mode);
    entry.method = core::toString(contact.method);
    entry.at_switch = contact.at_switch;
    entry.switch_detail = contact.switch_detail;
    msg.contacts.push_back(std::move(entry));
  }
  return msg;
}

ImpactDerivatives toMsg(const core::ImpactDerivatives& derivatives) {
  return derivativesMsg(derivatives.method, derivatives.jacobian, derivatives.rowLabels(),
                        derivatives.columnLabels(), derivatives.contacts);
}

core::SolverOptions fromMsg(const SolverOptions& msg, const core::SolverOptions& defaults) {
  core::SolverOptions options = defaults;
  switch (msg.law) {
    case SolverOptions::LAW_DEFAULT:
      break;
    case SolverOptions::LAW_NEWTON:
      options.law = core::ImpactLaw::kNewton;
      break;
    case SolverOptions::LAW_SEED_ONE_PASS:
      options.law = core::ImpactLaw::kSeedOnePass;
      break;
    case SolverOptions::LAW_POISSON:
      options.law = core::ImpactLaw::kPoisson;
      break;
    case SolverOptions::LAW_STRONGE:
      options.law = core::ImpactLaw::kStronge;
      break;
    default:
      throw core::InvalidInput("options.law", "unknown value " + std::to_string(msg.law));
  }
  switch (msg.solver) {
    case SolverOptions::SOLVER_DEFAULT:
      break;
    case SolverOptions::SOLVER_AUTO:
      options.method = core::SolverMethod::kAuto;
      break;
    case SolverOptions::SOLVER_ITERATIVE:
      options.method = core::SolverMethod::kIterative;
      break;
    case SolverOptions::SOLVER_EXACT:
      options.method = core::SolverMethod::kExact;
      break;
    default:
      throw core::InvalidInput("options.solver", "unknown value " + std::to_string(msg.solver));
  }
  switch (msg.multi_contact) {
    case SolverOptions::MULTI_CONTACT_DEFAULT:
      break;
    case SolverOptions::MULTI_CONTACT_SIMULTANEOUS:
      options.simultaneous_impulse_space = true;
      break;
    case SolverOptions::MULTI_CONTACT_TWO_PHASE:
      options.simultaneous_impulse_space = false;
      break;
    default:
      throw core::InvalidInput("options.multi_contact",
                               "unknown value " + std::to_string(msg.multi_contact));
  }
  if (msg.tolerance != 0.0) options.tolerance = msg.tolerance;
  if (msg.max_iterations != 0) options.max_iterations = msg.max_iterations;
  if (msg.integration_tolerance != 0.0) options.integration_tolerance = msg.integration_tolerance;
  if (msg.resting_velocity != 0.0) options.resting_velocity = msg.resting_velocity;
  if (msg.time_budget != 0.0) options.time_budget = msg.time_budget;
  return options;
}

}  // namespace collision_response
