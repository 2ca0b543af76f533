#include "collision_response/ros/server_parameters.h"

#include <string>

#include "collision_response/core/errors.h"
#include "collision_response/core/option_ranges.h"
#include "collision_response/core/validation.h"

namespace collision_response {
namespace {

using XmlRpc::XmlRpcValue;

bool has(const XmlRpcValue& values, const std::string& name) {
  return values.getType() == XmlRpcValue::TypeStruct && values.hasMember(name);
}

// XmlRpcValue's accessors are not const.
XmlRpcValue member(const XmlRpcValue& values, const std::string& name) {
  return const_cast<XmlRpcValue&>(values)[name];
}

double number(XmlRpcValue value, const std::string& field) {
  if (value.getType() == XmlRpcValue::TypeDouble) return static_cast<double>(value);
  if (value.getType() == XmlRpcValue::TypeInt) return static_cast<int>(value);
  throw core::InvalidInput(field, "must be a number");
}

double readNumber(const XmlRpcValue& values, const std::string& name, double value) {
  return has(values, name) ? number(member(values, name), "~" + name) : value;
}

// A whole number >= 1.
std::size_t readCount(const XmlRpcValue& values, const std::string& name, std::size_t value) {
  if (!has(values, name)) return value;
  XmlRpcValue v = member(values, name);
  if (v.getType() != XmlRpcValue::TypeInt)
    throw core::InvalidInput("~" + name, "must be a whole number");
  const int count = static_cast<int>(v);
  if (count < 1)
    throw core::InvalidInput("~" + name, "must be at least 1 (" + std::to_string(count) + ")");
  return static_cast<std::size_t>(count);
}

std::string stringOf(XmlRpcValue value, const std::string& field) {
  if (value.getType() != XmlRpcValue::TypeString)
    throw core::InvalidInput(field, "must be a string");
  return static_cast<std::string>(value);
}

std::string readString(const XmlRpcValue& values, const std::string& name, std::string value) {
  return has(values, name) ? stringOf(member(values, name), "~" + name) : value;
}

double readInRange(const XmlRpcValue& values, const std::string& name, double value,
                   const core::OptionRange& range, const char* unit = "") {
  value = readNumber(values, name, value);
  core::requireInRange(value, range, "~" + name, unit);
  return value;
}

double readPositive(const XmlRpcValue& values, const std::string& name, double value) {
  value = readNumber(values, name, value);
  if (!(value > 0.0) || !std::isfinite(value))
    throw core::InvalidInput("~" + name, "must be a finite number > 0");
  return value;
}

// ~materials: a list of {a, b, restitution, static_friction, dynamic_friction}.
detection::MaterialTable readMaterials(const XmlRpcValue& values) {
  detection::MaterialTable table;
  if (!has(values, "materials")) return table;
  XmlRpcValue list = member(values, "materials");
  if (list.getType() != XmlRpcValue::TypeArray)
    throw core::InvalidInput("~materials", "must be a list of {a, b, restitution, ...}");
  for (int i = 0; i < list.size(); ++i) {
    const std::string field = "~materials[" + std::to_string(i) + "]";
    XmlRpcValue& entry = list[i];
    if (entry.getType() != XmlRpcValue::TypeStruct || !entry.hasMember("a") ||
        !entry.hasMember("b") || entry["a"].getType() != XmlRpcValue::TypeString ||
        entry["b"].getType() != XmlRpcValue::TypeString) {
      throw core::InvalidInput(field, "must have string members a and b");
    }
    for (const auto& [name, value] : entry) {
      if (name != "a" && name != "b" && name != "restitution" && name != "static_friction" &&
          name != "dynamic_friction") {
        throw core::InvalidInput(field, "has an unknown member '" + name +
                                            "' (a, b, restitution, static_friction, "
                                            "dynamic_friction)");
      }
    }
    detection::ContactMaterial material;
    const auto coefficient = [&](const char* name, double& out) {
      if (entry.hasMember(name)) out = number(entry[name], field + "." + name);
    };
    coefficient("restitution", material.restitution);
    coefficient("static_friction", material.static_friction);
    coefficient("dynamic_friction", material.dynamic_friction);
    table.set(static_cast<std::string>(entry["a"]), static_cast<std::string>(entry["b"]), material,
              field);
  }
  return table;
}

bool readBool(XmlRpcValue value, const std::string& field) {
  if (value.getType() != XmlRpcValue::TypeBoolean)
    throw core::InvalidInput(field, "must be true or false");
  return static_cast<bool>(value);
}

// One ~robots entry.
RobotParameters readRobot(XmlRpcValue& entry, const std::string& field) {
  if (entry.getType() != XmlRpcValue::TypeStruct || !entry.hasMember("name"))
    throw core::InvalidInput(field, "must be a struct with at least a name");
  RobotParameters robot;
  for (auto& [name, value] : entry) {
    const std::string member_field = field + "." + name;
    if (name == "name") {
      robot.name = stringOf(value, member_field);
    } else if (name == "description_param") {
      robot.description_param = stringOf(value, member_field);
    } else if (name == "joint_states_topic") {
      robot.joint_states_topic = stringOf(value, member_field);
    } else if (name == "floating") {
      robot.floating = readBool(value, member_field);
    } else if (name == "base_frame") {
      robot.base_frame = stringOf(value, member_field);
    } else if (name == "locked_joints") {
      if (value.getType() != XmlRpcValue::TypeArray)
        throw core::InvalidInput(member_field, "must be a list of joint names");
      for (int i = 0; i < value.size(); ++i)
        robot.locked_joints.push_back(
            stringOf(value[i], member_field + "[" + std::to_string(i) + "]"));
    } else if (name == "armature") {
      if (value.getType() != XmlRpcValue::TypeStruct)
        throw core::InvalidInput(member_field, "must be a map {joint: rotor inertia}");
      for (auto& [joint, inertia] : value) {
        const double armature = number(inertia, member_field + "." + joint);
        if (!(armature >= 0.0) || !std::isfinite(armature))
          throw core::InvalidInput(
              member_field + "." + joint,
              "must be a finite number >= 0 [kg m^2, kg for a prismatic joint]");
        robot.armature[joint] = armature;
      }
    } else {
      throw core::InvalidInput(field, "has an unknown member '" + name +
                                          "' (name, description_param, joint_states_topic, "
                                          "floating, base_frame, locked_joints, armature)");
    }
  }
  if (robot.name.empty()) throw core::InvalidInput(field + ".name", "must not be empty");
  if (robot.name.find('/') != std::string::npos)
    throw core::InvalidInput(field + ".name",
                             "must not contain '/' (contacts name links as \"<name>/<link>\")");
  if (robot.description_param.empty())
    throw core::InvalidInput(field + ".description_param", "must not be empty");
  if (robot.joint_states_topic.empty())
    throw core::InvalidInput(field + ".joint_states_topic", "must not be empty");
  return robot;
}

// ~robots: a list of robot entries with distinct names.
std::vector<RobotParameters> readRobots(const XmlRpcValue& values) {
  std::vector<RobotParameters> robots;
  if (!has(values, "robots")) return robots;
  XmlRpcValue list = member(values, "robots");
  if (list.getType() != XmlRpcValue::TypeArray)
    throw core::InvalidInput("~robots", "must be a list of {name, description_param, ...}");
  for (int i = 0; i < list.size(); ++i) {
    const std::string field = "~robots[" + std::to_string(i) + "]";
    robots.push_back(readRobot(list[i], field));
    for (int j = 0; j < i; ++j) {
      if (robots[j].name == robots.back().name)
        throw core::InvalidInput(field + ".name", "repeats the name '" + robots.back().name +
                                                      "' of ~robots[" + std::to_string(j) + "]");
    }
  }
  return robots;
}

}  // namespace

const char* multiContactName(bool simultaneous) {
  return simultaneous ? "simultaneous" : "two_phase";
}

bool multiContactFromName(const std::string& name, bool& simultaneous) {
  if (name != "simultaneous" && name != "two_phase") return false;
  simultaneous = name == "simultaneous";
  return true;
}

ServerParameters loadServerParameters(const XmlRpc::XmlRpcValue& values) {
  namespace ranges = core::option_ranges;
  ServerParameters p;
  core::SolverOptions& solver = p.solver;
  const std::string law = readString(values, "law", core::toString(solver.law));
  if (!core::fromString(law, solver.law)) {
    throw core::InvalidInput(
        "~law", "must be 'stronge', 'poisson', 'newton' or 'seed_one_pass' (" + law + ")");
  }
  const std::string method = readString(values, "solver", core::toString(solver.method));
  if (!core::fromString(method, solver.method))
    throw core::InvalidInput("~solver", "must be 'auto', 'exact' or 'iterative' (" + method + ")");
  const std::string multi_contact =
      readString(values, "multi_contact", multiContactName(solver.simultaneous_impulse_space));
  if (!multiContactFromName(multi_contact, solver.simultaneous_impulse_space)) {
    throw core::InvalidInput("~multi_contact",
                             "must be 'simultaneous' or 'two_phase' (" + multi_contact + ")");
  }
  solver.tolerance = readInRange(values, "tolerance", solver.tolerance, ranges::kTolerance);
  solver.max_iterations = readCount(values, "max_iterations", solver.max_iterations);
  core::requireInRange(static_cast<double>(solver.max_iterations), ranges::kMaxIterations,
                       "~max_iterations");
  solver.integration_tolerance = readInRange(
      values, "integration_tolerance", solver.integration_tolerance, ranges::kIntegrationTolerance);
  solver.time_budget =
      readInRange(values, "time_budget", solver.time_budget, ranges::kTimeBudget, "s");

  p.limits.max_bodies = readCount(values, "max_bodies", p.limits.max_bodies);
  p.limits.max_contacts = readCount(values, "max_contacts", p.limits.max_contacts);
  p.limits.max_shapes = readCount(values, "max_shapes", p.limits.max_shapes);
  p.limits.max_mesh_vertices = readCount(values, "max_mesh_vertices", p.limits.max_mesh_vertices);
  p.limits.max_mesh_triangles =
      readCount(values, "max_mesh_triangles", p.limits.max_mesh_triangles);

  p.tf_timeout = readNumber(values, "tf_timeout", p.tf_timeout);
  if (!(p.tf_timeout >= 0.0) || !std::isfinite(p.tf_timeout))
    throw core::InvalidInput("~tf_timeout", "must be a finite number >= 0 s");
  p.contact_tolerance =
      readInRange(values, "contact_tolerance", p.contact_tolerance, ranges::kContactTolerance, "m");
  p.max_contacts_per_pair = readCount(values, "max_contacts_per_pair", p.max_contacts_per_pair);
  p.materials = readMaterials(values);
  p.max_batch_scenes = readCount(values, "max_batch_scenes", p.max_batch_scenes);
  p.marker_scales.impulse = readPositive(values, "marker_impulse_scale", p.marker_scales.impulse);
  p.marker_scales.velocity =
      readPositive(values, "marker_velocity_scale", p.marker_scales.velocity);
  p.default_frame = readString(values, "default_frame", p.default_frame);
  if (p.default_frame.empty()) throw core::InvalidInput("~default_frame", "must not be empty");
  const std::size_t threads = readCount(values, "threads", static_cast<std::size_t>(p.threads));
  if (threads > 256)
    throw core::InvalidInput("~threads", "must be at most 256 (" + std::to_string(threads) + ")");
  p.threads = static_cast<int>(threads);
  p.robots = readRobots(values);
  p.joint_state_timeout = readPositive(values, "joint_state_timeout", p.joint_state_timeout);
  return p;
}

}  // namespace collision_response
