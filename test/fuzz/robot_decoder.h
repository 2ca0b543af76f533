// Decodes arbitrary bytes into what a robot user sends (a URDF document, a ~robots entry, messages
// on the robot's joint-state topic, a request's RobotState, rigid bodies and contacts on the links)
// and runs it through the node's robot path without a ROS master; checks the outcome. Shared by the
// libFuzzer target (fuzz_robot_request.cpp) and the regression test
// (test_fuzz_robot_regressions.cpp), so a saved input replays exactly as the fuzzer saw it.
//
// The path is the one CollisionResponseServer::solveWithRobots() takes for one robot, through the
// same public functions: ServedRobot (the URDF through robotFromUrdfString() and the links'
// collision geometry through linkCollisionGeometryFromUrdf()), JointStateCache::update(),
// basePoseFromMsg() (no base pose: the identity stands in for tf2's look-up),
// robotAtRequestState(), core::SceneValidator (bodies, options, contacts with the links' ids),
// core::computeBodyResponse(), toMsg() and restingContactTorques(), then (from the bytes left, if
// any) the same request's outcome distribution, core::computeBodyOutcomeDistribution() on
// pre-impact copies with the URDF's velocity limits, checked as the core target's plus one limit
// probability per velocity unknown and the robot's copy back at its pre-impact velocities, then
// (on an odd byte after those) core::computeBodyImpactDerivatives() with the robot's joint
// positions as coordinates: finite, the robot back at its q and the prediction's velocities. Not
// covered: tf2, contact
// detection (the contacts are given), the service's message conversion of rigid bodies and
// options (core values are given directly; validation is the same).
//
// Input layout: byte 0 selects the URDF's source. Even: the URDF is generated from the bytes that
// follow (sane documents with now and then malformed values or structure, <mimic> tags with
// chains, cycles and missing leaders), and the rest of the request from the bytes after those.
// Odd: bytes 1 up to the first 0x00 are the URDF text as it is (the seeds hold the package's
// URDFs), the request from the bytes after the 0x00. Missing bytes read as 0, the sane choice.
//
// Outcomes: core::InvalidInput (from loading the robot or from the request) is expected, and so is
// SolverTimeout; any other exception, or a successful answer with a non-finite number (velocities,
// impulses, forces, energies, effort, joint torques; a NaN or negative effective mass), is a bug.
#pragma once

#include <collision_response/RobotResult.h>
#include <collision_response/RobotState.h>
#include <ros/time.h>
#include <sensor_msgs/JointState.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "collision_response/core/body_impact_derivatives.h"
#include "collision_response/core/body_response.h"
#include "collision_response/core/body_state.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/uncertainty.h"
#include "collision_response/core/validation.h"
#include "collision_response/robot/joint_position_coordinates.h"
#include "collision_response/ros/robot_conversion.h"
#include "collision_response/ros/served_robot.h"
#include "collision_response/ros/server_parameters.h"
#include "scene_decoder.h"

namespace collision_response::fuzz {

constexpr std::size_t kMaxLinks = 8;
constexpr std::size_t kMaxRobotContacts = 8;
constexpr const char* kRobotName = "arm";
/// The node's default ~joint_state_timeout [s].
constexpr double kJointStateTimeout = 0.5;

namespace robot_detail {

inline std::string format(double value) {
  char text[40];
  std::snprintf(text, sizeof text, "%.17g", value);
  return text;
}

/// A number for an attribute: sane in [lo, hi]; if `wild`, now and then a special value, a raw
/// double or a word that is no number.
inline std::string number(ByteReader& in, bool wild, double lo, double hi) {
  if (wild) {
    const std::uint8_t mode = in.byte();
    if (mode % 8 == 1) return format(in.special());
    if (mode % 8 == 2) return format(in.raw());
    if (mode % 8 == 3) {
      static const char* const kJunk[] = {"",     "abc", "1e400", "-1e400",
                                          "0x10", "1,5", " 2 ",   "--1"};
      return kJunk[in.byte() % 8];
    }
  }
  return format(in.uniform(lo, hi));
}

inline std::string triple(ByteReader& in, bool wild, double lo, double hi) {
  std::string out = number(in, wild, lo, hi);
  out += " " + number(in, wild, lo, hi);
  out += " " + number(in, wild, lo, hi);
  // Now and then two or four numbers where URDF wants three.
  if (wild) {
    const std::uint8_t count = in.byte();
    if (count == 0xfe) return out.substr(0, out.rfind(' '));
    if (count == 0xff) return out + " 1";
  }
  return out;
}

inline std::string origin(ByteReader& in, bool wild, double reach) {
  return "<origin xyz=\"" + triple(in, wild, -reach, reach) + "\" rpy=\"" +
         triple(in, wild, -3.2, 3.2) + "\"/>";
}

inline std::string inertial(ByteReader& in) {
  const std::uint8_t mode = in.byte();
  if (mode % 4 == 1) return "";  // a massless link
  const bool wild = mode % 4 == 2;
  std::string out = "<inertial>" + origin(in, wild, 0.2);
  if (wild || mode % 8 == 3) {
    // Anything, or (mode 3) zero mass or a zero tensor.
    const bool zero_mass = !wild && (mode & 0x10);
    out +=
        "<mass value=\"" + (zero_mass ? std::string("0") : number(in, wild, 0.01, 10.0)) + "\"/>";
    out += "<inertia ixx=\"" + (wild ? number(in, true, -1, 1) : "0") + "\" ixy=\"" +
           (wild ? number(in, true, -1, 1) : "0") + "\" ixz=\"" +
           (wild ? number(in, true, -1, 1) : "0") + "\" iyy=\"" +
           (wild ? number(in, true, -1, 1) : "0") + "\" iyz=\"" +
           (wild ? number(in, true, -1, 1) : "0") + "\" izz=\"" +
           (wild ? number(in, true, -1, 1) : "0") + "\"/>";
  } else {
    // A solid ellipsoid: principal moments that satisfy the triangle inequality.
    const double mass = in.logUniform(0.01, 10.0);
    const double a = in.logUniform(0.01, 0.5), b = in.logUniform(0.01, 0.5),
                 c = in.logUniform(0.01, 0.5);
    out += "<mass value=\"" + format(mass) + "\"/>";
    out += "<inertia ixx=\"" + format(mass * (b * b + c * c) / 5) +
           "\" ixy=\"0\" ixz=\"0\" iyy=\"" + format(mass * (a * a + c * c) / 5) +
           "\" iyz=\"0\" izz=\"" + format(mass * (a * a + b * b) / 5) + "\"/>";
  }
  return out + "</inertial>";
}

inline std::string collision(ByteReader& in) {
  const std::uint8_t mode = in.byte();
  const bool wild = mode % 4 == 3;
  std::string geometry;
  switch ((mode / 4) % 8) {
    case 0:
    case 1:
      geometry = "<box size=\"" + triple(in, wild, 0.01, 0.5) + "\"/>";
      break;
    case 2:
      geometry = "<sphere radius=\"" + number(in, wild, 0.01, 0.3) + "\"/>";
      break;
    case 3:
      geometry = "<cylinder radius=\"" + number(in, wild, 0.01, 0.3) + "\" length=\"" +
                 number(in, wild, 0.01, 1.0) + "\"/>";
      break;
    case 4: {
      // Meshes that cannot be loaded (no network, no file outside the repository is named).
      static const char* const kFiles[] = {"", "file:///nonexistent/fuzz.stl", "fuzz.dae",
                                           "file:///nonexistent/fuzz.obj"};
      geometry = "<mesh filename=\"" + std::string(kFiles[in.byte() % 4]) + "\"" +
                 (wild ? " scale=\"" + triple(in, true, -2, 2) + "\"" : std::string()) + "/>";
      break;
    }
    case 5:
      geometry = "";  // <geometry/> without a shape
      break;
    case 6:
      geometry = "<capsule radius=\"0.1\" length=\"0.2\"/>";  // not URDF 1.0
      break;
    default:
      geometry = "<box size=\"0.1 0.1 0.1\"/>";
      break;
  }
  std::string out = "<collision>" + origin(in, wild, 0.3);
  if (!(wild && (mode & 0x80))) out += "<geometry>" + geometry + "</geometry>";  // else missing
  return out + "</collision>";
}

inline std::string linkName(std::size_t i) {
  return "l" + std::to_string(i);
}
inline std::string jointName(std::size_t i) {
  return "j" + std::to_string(i);
}

/// The URDF document from the bytes; `joints` receives the number of <joint> elements.
inline std::string generateUrdf(ByteReader& in) {
  const std::uint8_t shape = in.byte();
  const bool structure_wild = shape % 8 == 7;
  const std::size_t links = (in.byte() + 2) % (kMaxLinks + 1);  // 0 links now and then
  std::ostringstream out;
  out << "<?xml version=\"1.0\"?>\n";
  if (structure_wild && (shape & 0x10)) {
    out << "<robot>\n";  // no name
  } else {
    out << "<robot name=\"fuzz\">\n";
  }
  for (std::size_t i = 0; i < links; ++i) {
    const std::uint8_t mode = in.byte();
    std::string name = linkName(i);
    if (structure_wild) {
      if (mode % 16 == 1) name = linkName(0);  // a duplicate
      if (mode % 16 == 2) name = "";
      if (mode % 16 == 3) name = "a/b";  // a '/' in a link id "<robot>/<link>"
    }
    out << "<link name=\"" << name << "\">";
    // The root too gets an inertial now and then (a floating base needs one).
    out << inertial(in);
    const std::size_t collisions = in.byte() % 3;
    for (std::size_t k = 0; k < collisions; ++k) out << collision(in);
    out << "</link>\n";
  }
  for (std::size_t i = 1; i < links; ++i) {
    const std::uint8_t mode = in.byte();
    const bool wild = structure_wild || mode % 8 == 7;
    static const char* const kTypes[] = {"revolute", "continuous", "prismatic", "fixed",
                                         "floating", "planar",     "bogus",     ""};
    const char* type = kTypes[wild ? in.byte() % 8 : in.byte() % 4];
    std::string name = jointName(i);
    if (structure_wild && mode % 16 == 15) name = jointName(1);  // a duplicate
    // Parent: an earlier link (a tree); wild: any link (itself, a later one: cycles) or none.
    const std::uint8_t parent_pick = in.byte();
    std::string parent = linkName(parent_pick % i);
    if (structure_wild) {
      if (parent_pick >= 0xf0)
        parent = "missing";
      else
        parent = linkName(parent_pick % links);
    }
    std::string child = linkName(i);
    if (structure_wild && (mode & 0x80)) child = linkName(in.byte() % links);
    out << "<joint name=\"" << name << "\" type=\"" << type << "\">";
    out << "<parent link=\"" << parent << "\"/><child link=\"" << child << "\"/>";
    out << origin(in, wild, 0.5);
    // Axis: unit, or (wild) zero, non-unit or not a number.
    const std::uint8_t axis = in.byte();
    if (wild && axis % 4 == 3) {
      out << "<axis xyz=\"" << triple(in, true, -2, 2) << "\"/>";
    } else if (axis % 4 != 2) {
      const Eigen::Vector3d u = in.unitVector();
      out << "<axis xyz=\"" << format(u.x()) << " " << format(u.y()) << " " << format(u.z())
          << "\"/>";
    }  // else no axis: URDF's default (1 0 0)
    const std::uint8_t limit = in.byte();
    if (!(wild && limit % 4 == 3)) {
      out << "<limit lower=\"" << number(in, wild, -3, 0) << "\" upper=\"" << number(in, wild, 0, 3)
          << "\" effort=\"" << number(in, wild, 0, 100) << "\" velocity=\""
          << number(in, wild, 0, 10) << "\"/>";
    }
    if (limit % 8 == 5) out << "<dynamics damping=\"" << number(in, wild, 0, 1) << "\"/>";
    // <mimic>: a quarter of the joints. The leader: an earlier joint (chains form when it mimics
    // another), a later one, itself (a cycle), or a joint that does not exist; the multiplier and
    // offset sane, missing or (wild) anything.
    const std::uint8_t mimic = in.byte();
    if (mimic % 4 == 0) {
      const std::uint8_t leader_pick = in.byte();
      std::string leader;
      switch (leader_pick % 8) {
        case 0:
        case 1:
        case 2:
        case 3:
          leader = jointName(1 + leader_pick / 8 % i);  // j1 .. j(i): earlier or itself
          if (i > 1 && leader == name) leader = jointName(1 + (leader_pick / 8 + 1) % (i - 1));
          break;
        case 4:
          leader = jointName(1 + leader_pick / 8 % (links - 1));  // any joint: cycles and chains
          break;
        case 5:
          leader = name;  // itself
          break;
        case 6:
          leader = "missing_joint";
          break;
        default:
          leader = "";
          break;
      }
      out << "<mimic joint=\"" << leader << "\"";
      const std::uint8_t factors = in.byte();
      if (factors % 4 != 3) out << " multiplier=\"" << number(in, wild, -2, 2) << "\"";
      if (factors % 4 != 2) out << " offset=\"" << number(in, wild, -1, 1) << "\"";
      out << "/>";
    }
    out << "</joint>\n";
  }
  if (structure_wild && (shape & 0x20)) {
    out << "<link name=\"orphan\"/>\n";  // a second root
  }
  if (structure_wild && (shape & 0x40)) {
    out << "<joint name=\"dangling\" type=\"fixed\"><parent link=\"l0\"/><child "
           "link=\"nowhere\"/></joint>\n";
  }
  out << "</robot>\n";
  std::string text = out.str();
  if (structure_wild && (shape & 0x08)) text.resize(in.u16() % (text.size() + 1));  // truncated
  return text;
}

/// A mesh URL, or another URL, that must not be fetched from a fuzzed document (text mode): a
/// scheme other than file:// and package://, or a device or process file (which could block).
inline bool unsafeUrdf(const std::string& text) {
  for (const char* bad : {"http", "ftp", "://", "/dev", "/proc", "/sys"}) {
    std::size_t at = text.find(bad);
    while (at != std::string::npos) {
      const bool allowed_scheme =
          std::string(bad) == "://" && ((at >= 4 && text.compare(at - 4, 4, "file") == 0) ||
                                        (at >= 7 && text.compare(at - 7, 7, "package") == 0));
      if (!allowed_scheme) return true;
      at = text.find(bad, at + 1);
    }
  }
  // package:// is resolved through ROS_PACKAGE_PATH (scripts/fuzz.sh sets it to this repository).
  return false;
}

/// The URDF of an input (the file comment's layout: byte 0 even, generated from the bytes that
/// follow; odd, the text up to the first 0x00) into `urdf`; returns the reader of the bytes after
/// it, or nothing if the text names a URL the harness does not fetch (unsafeUrdf()).
inline std::optional<ByteReader> urdfFromBytes(const std::uint8_t* data, std::size_t size,
                                               std::string& urdf, bool& text_mode) {
  text_mode = size > 0 && (data[0] % 2 == 1);
  std::optional<ByteReader> in;
  if (text_mode) {
    std::size_t end = 1;
    while (end < size && data[end] != 0) ++end;
    urdf.assign(reinterpret_cast<const char*>(data) + 1, end - 1);
    const std::size_t rest = end < size ? end + 1 : size;  // where the request's bytes start
    if (unsafeUrdf(urdf)) return std::nullopt;
    in.emplace(data + rest, size - rest);
  } else {
    in.emplace(size > 0 ? data + 1 : data, size > 0 ? size - 1 : 0);
    urdf = generateUrdf(*in);
  }
  return in;
}

/// A value of a joint state: sane in [lo, hi], or (wild) NaN, infinities, huge, raw.
inline double stateValue(ByteReader& in, bool wild, double lo, double hi) {
  return in.value(wild, lo, hi);
}

/// A list of joint names drawn from the model's: `count` of them, mostly distinct and known.
inline std::vector<std::string> jointNames(ByteReader& in, const std::vector<std::string>& joints,
                                           std::size_t count, bool wild) {
  std::vector<std::string> names;
  for (std::size_t k = 0; k < count; ++k) {
    const std::uint8_t pick = in.byte();
    if (joints.empty() || (wild && pick >= 0xf0)) {
      names.push_back(pick % 2 ? "unknown_joint" : "");
    } else if (wild && pick >= 0xe0) {
      names.push_back(joints[0]);  // may repeat
    } else {
      names.push_back(joints[(k + pick / 0x40) % joints.size()]);
    }
  }
  return names;
}

inline void fillArray(ByteReader& in, std::vector<double>& values, std::size_t count, bool wild,
                      double lo, double hi) {
  const std::uint8_t mode = in.byte();
  if (mode % 4 == 1) return;  // empty: from the topic
  std::size_t size = count;
  if (wild && mode % 4 == 3) size = in.byte() % (count + 2);  // mismatched size
  for (std::size_t k = 0; k < size; ++k) values.push_back(stateValue(in, wild, lo, hi));
}

inline sensor_msgs::JointState jointStateMessage(ByteReader& in,
                                                 const std::vector<std::string>& joints,
                                                 bool wild) {
  sensor_msgs::JointState message;
  const std::uint8_t count_pick = in.byte();
  // Mostly every joint; now and then a subset.
  const std::size_t count =
      count_pick % 4 == 1 ? count_pick / 4 % (joints.size() + 1) : joints.size();
  message.name = jointNames(in, joints, count, wild);
  fillArray(in, message.position, count, wild, -3.0, 3.0);
  fillArray(in, message.velocity, count, wild, -5.0, 5.0);
  fillArray(in, message.effort, count, wild, -20.0, 20.0);
  return message;
}

inline std::string vec(const Eigen::Vector3d& v) {
  return "[" + format(v[0]) + ", " + format(v[1]) + ", " + format(v[2]) + "]";
}

inline std::string list(const std::vector<double>& values) {
  std::string out = "[";
  for (std::size_t k = 0; k < values.size(); ++k) out += (k ? ", " : "") + format(values[k]);
  return out + "]";
}

inline std::string list(const std::vector<std::string>& values) {
  std::string out = "[";
  for (std::size_t k = 0; k < values.size(); ++k) out += (k ? ", '" : "'") + values[k] + "'";
  return out + "]";
}

inline bool finite(const geometry_msgs::Vector3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

inline bool allFinite(const std::vector<double>& values) {
  for (const double v : values)
    if (!std::isfinite(v)) return false;
  return true;
}

}  // namespace robot_detail

/// What running a robot input gave.
struct RobotOutcome {
  bool loaded = false;       ///< ServedRobot accepted the URDF and the entry
  bool solved = false;       ///< the request was answered
  bool skipped = false;      ///< the URDF text names a URL the harness does not fetch
  std::string invalid;       ///< the InvalidInput message, if any
  std::string timeout;       ///< the SolverTimeout message, if any
  std::string bug;           ///< non-empty: an unexpected exception or a broken invariant
  std::string description;   ///< the decoded input, readable
  std::size_t contacts = 0;  ///< contacts in the request
  bool approaching = false;  ///< some contact approached
  bool resting = false;      ///< some contact was answered with a resting force
};

namespace robot_detail {

/// Checks the answer; returns the first non-finite or impossible value, or "".
inline std::string checkAnswer(const core::BodyResponse& result,
                               const std::vector<core::RigidBody>& rigid, const RobotResult& robot,
                               const std::vector<double>& contact_joint_torques) {
  std::ostringstream out;
  out.precision(17);
  for (std::size_t c = 0; c < result.impulses.size(); ++c) {
    const core::ContactImpulse& p = result.impulses[c];
    if (!std::isfinite(p.normal_impulse) || !p.friction_impulse.allFinite() ||
        !std::isfinite(p.normal_velocity_before) || !std::isfinite(p.normal_velocity_after) ||
        !std::isfinite(p.normal_force) || !p.friction_force.allFinite()) {
      out << "impulses[" << c << "]: non-finite value (normal_impulse " << p.normal_impulse
          << ", friction_impulse " << p.friction_impulse.transpose() << ", u_n before "
          << p.normal_velocity_before << ", after " << p.normal_velocity_after << ", normal_force "
          << p.normal_force << ", friction_force " << p.friction_force.transpose() << ")";
      return out.str();
    }
  }
  for (std::size_t c = 0; c < result.effective_masses.size(); ++c) {
    const double m = result.effective_masses[c];
    if (std::isnan(m) || m <= 0.0) {
      out << "effective_masses[" << c << "] = " << m;
      return out.str();
    }
  }
  for (std::size_t i = 0; i < rigid.size(); ++i) {
    if (!rigid[i].linear_velocity.allFinite() || !rigid[i].angular_velocity.allFinite()) {
      out << "bodies[" << i << "]: non-finite velocity after";
      return out.str();
    }
  }
  for (std::size_t k = 0; k < result.islands.size(); ++k) {
    if (!std::isfinite(result.islands[k].residual) && result.islands[k].converged) {
      out << "islands[" << k << "]: converged with a non-finite residual";
      return out.str();
    }
  }
  if (!allFinite(robot.joint_state.velocity) || !allFinite(robot.joint_state.position) ||
      !allFinite(robot.joint_state.effort) || !allFinite(robot.joint_state_before.velocity)) {
    out << "robots[0].joint_state: non-finite value: position " << list(robot.joint_state.position)
        << ", velocity " << list(robot.joint_state.velocity) << ", effort "
        << list(robot.joint_state.effort);
    return out.str();
  }
  if (!finite(robot.base_twist.linear) || !finite(robot.base_twist.angular)) {
    out << "robots[0].base_twist: non-finite";
    return out.str();
  }
  if (!std::isfinite(robot.kinetic_energy_before) || !std::isfinite(robot.kinetic_energy_after)) {
    out << "robots[0]: non-finite kinetic energy " << robot.kinetic_energy_before << " -> "
        << robot.kinetic_energy_after;
    return out.str();
  }
  if (!allFinite(contact_joint_torques)) {
    out << "robots[0].contact_joint_torques: non-finite " << list(contact_joint_torques);
    return out.str();
  }
  return "";
}

}  // namespace robot_detail

/// Decodes `data` and runs it (see the file comment). `print_before_solving`: print the decoded
/// input before the solver runs (and leave the rest to the description).
inline RobotOutcome runRobotInput(const std::uint8_t* data, std::size_t size,
                                  bool print_before_solving = false) {
  using namespace robot_detail;
  RobotOutcome outcome;
  std::ostringstream text;
  text.precision(17);

  // The URDF.
  std::string urdf;
  bool text_mode = false;
  std::optional<ByteReader> in = urdfFromBytes(data, size, urdf, text_mode);
  if (!in) {
    outcome.skipped = true;
    outcome.description = "URDF (text, not run: it names a URL the harness does not fetch)\n";
    return outcome;
  }
  ByteReader& bytes = *in;
  text << "URDF (" << (text_mode ? "text" : "generated") << "):\n" << urdf << "\n";

  const ros::Time now(1000.0);
  const auto finish = [&]() { outcome.description = text.str(); };
  try {
    // The ~robots entry (values as server_parameters.cpp admits them: armatures finite, >= 0).
    RobotParameters parameters;
    parameters.name = kRobotName;
    parameters.description_param = "/fuzz_description";
    parameters.joint_states_topic = "/fuzz/joint_states";
    const std::uint8_t entry = bytes.byte();
    parameters.floating = entry % 4 == 1;
    text << "entry: floating " << parameters.floating;
    std::unique_ptr<ServedRobot> served =
        std::make_unique<ServedRobot>(parameters, urdf, "~robots[0]");
    const std::vector<std::string> joints = served->model().jointNames();
    if (entry & 0x10) {
      // The entry's locked joints and armatures, by the model's names (an unknown one now and
      // then).
      const std::uint8_t count = bytes.byte();
      parameters.locked_joints =
          jointNames(bytes, joints, count % (joints.size() + 1), (entry & 0x80) != 0);
      const std::uint8_t armatures = bytes.byte();
      for (const std::string& name :
           jointNames(bytes, joints, armatures % 3, (entry & 0x80) != 0)) {
        const std::uint8_t kind = bytes.byte();
        parameters.armature[name] = kind % 4 == 0 ? 0.0 : kind % 4 == 1 ? 1e9 : bytes.uniform(0, 1);
      }
      text << ", locked_joints " << list(parameters.locked_joints) << ", armature {";
      for (const auto& [name, value] : parameters.armature)
        text << "'" << name << "': " << format(value) << " ";
      text << "}";
      served = std::make_unique<ServedRobot>(parameters, urdf, "~robots[0]");
    }
    text << "\n";
    outcome.loaded = true;
    const robot::ArticulatedBody& model = served->model();

    // Messages on the joint-state topic, each stamped some time before `now` (or unstamped).
    const std::uint8_t messages = bytes.byte();
    for (int m = 0; m < messages % 3; ++m) {
      const std::uint8_t mode = bytes.byte();
      sensor_msgs::JointState message = jointStateMessage(bytes, joints, mode % 4 == 3);
      static const double kAges[] = {0.0, 0.01, 0.4, 0.6, 100.0, 999.0};
      const double age = kAges[bytes.byte() % 6];
      const double arrival_age = kAges[bytes.byte() % 3];
      if (!(mode & 0x40)) message.header.stamp = ros::Time(now.toSec() - age);
      served->jointStates().update(message, ros::Time(now.toSec() - arrival_age));
      text << "topic message " << m << " (stamp " << message.header.stamp.toSec()
           << ", arrival age " << arrival_age << "): name " << list(message.name) << ", position "
           << list(message.position) << ", velocity " << list(message.velocity) << ", effort "
           << list(message.effort) << "\n";
    }

    // The request's RobotState; or (contacts_only) none, the robot only named by contacts.
    const std::uint8_t state_mode = bytes.byte();
    const bool wild = state_mode % 4 == 3;
    const bool contacts_only = state_mode % 16 == 14;
    RobotState message;
    message.name = kRobotName;
    std::string field = "robots[0]";
    if (!contacts_only) {
      message.joint_state = jointStateMessage(bytes, joints, wild);
      // A joint state given in full most of the time (the rest from the topic otherwise).
      const std::uint8_t pose = bytes.byte();
      if (pose % 4 != 0) {
        Eigen::Quaterniond q = bytes.unitQuaternion();
        message.base_pose.orientation.w = q.w();
        message.base_pose.orientation.x = q.x();
        message.base_pose.orientation.y = q.y();
        message.base_pose.orientation.z = q.z();
        const Eigen::Vector3d p = bytes.vector(wild, -1.0, 1.0);
        message.base_pose.position.x = p.x();
        message.base_pose.position.y = p.y();
        message.base_pose.position.z = p.z();
        if (wild && pose % 4 == 3) {
          message.base_pose.orientation.w = bytes.value(true, -1, 1);  // not unit, not finite
          message.base_pose.orientation.x = bytes.value(true, -1, 1);
        }
      }  // else all zero: from tf (the identity here)
      const Eigen::Vector3d linear = bytes.vector(wild, -2.0, 2.0);
      const Eigen::Vector3d angular = bytes.vector(wild, -2.0, 2.0);
      message.base_twist.linear.x = linear.x();
      message.base_twist.linear.y = linear.y();
      message.base_twist.linear.z = linear.z();
      message.base_twist.angular.x = angular.x();
      message.base_twist.angular.y = angular.y();
      message.base_twist.angular.z = angular.z();
      const std::uint8_t locked = bytes.byte();
      message.override_locked_joints = locked % 4 == 1;
      if (message.override_locked_joints)
        message.locked_joints = jointNames(bytes, joints, locked / 4 % (joints.size() + 2), wild);
      const std::uint8_t gravity = bytes.byte();
      Eigen::Vector3d g = Eigen::Vector3d::Zero();
      if (gravity % 4 == 0) g = Eigen::Vector3d(0, 0, -9.81);
      if (gravity % 4 == 2) g = bytes.vector(wild, -20, 20);
      message.gravity.x = g.x();
      message.gravity.y = g.y();
      message.gravity.z = g.z();
      const std::uint8_t torques = bytes.byte();
      message.joint_torques = wild && torques >= 0xf0 ? torques : torques % 3;
      text << "request robots[0]: joint_state name " << list(message.joint_state.name)
           << ", position " << list(message.joint_state.position) << ", velocity "
           << list(message.joint_state.velocity) << ", effort " << list(message.joint_state.effort)
           << "\n  base_pose position [" << message.base_pose.position.x << ", "
           << message.base_pose.position.y << ", " << message.base_pose.position.z
           << "], orientation (w x y z) " << message.base_pose.orientation.w << " "
           << message.base_pose.orientation.x << " " << message.base_pose.orientation.y << " "
           << message.base_pose.orientation.z << "\n  base_twist " << vec(linear) << " "
           << vec(angular) << ", override_locked_joints " << int(message.override_locked_joints)
           << ", locked_joints " << list(message.locked_joints) << ", gravity " << vec(g)
           << ", joint_torques " << int(message.joint_torques) << "\n";
    } else {
      field = "contacts[0]";
      text << "request: no robots[], the robot named by contacts only\n";
    }

    // Options, rigid bodies and contacts (options and bodies as the core's fuzz target decodes
    // them).
    core::SolverOptions options = detail::decodeOptions(bytes);
    core::Scene scene;
    const std::size_t bodies = bytes.byte() % 3;
    for (std::size_t i = 0; i < bodies; ++i) scene.bodies.push_back(detail::decodeBody(bytes, i));

    // The node's sequence (CollisionResponseServer::solveWithRobots) for one robot.
    core::SceneValidator validator(scene, options, core::RequestLimits());
    Eigen::Isometry3d base_pose = Eigen::Isometry3d::Identity();  // tf2's answer stands in
    if (const std::optional<Eigen::Isometry3d> pose = basePoseFromMsg(message, field))
      base_pose = *pose;
    std::vector<std::string> warnings;
    robot::ArticulatedBody robot =
        robotAtRequestState(*served, message, base_pose, now, kJointStateTimeout, field, &warnings);
    const Eigen::VectorXd velocity_before = robot.velocity();
    const double energy_before = robot.kineticEnergy();
    const std::vector<std::string>& link_ids = served->linkIds();
    validator.addOtherBodyIds(link_ids);

    // Contacts: mostly on links, placed near the link's origin at this state.
    const std::size_t contact_count = (bytes.byte() + 1) % (kMaxRobotContacts + 1);
    const auto pick_side = [&](std::uint8_t pick, bool contact_wild, int& link) -> std::string {
      link = -1;
      const std::uint8_t kind = pick % 8;
      if (kind == 5 && !scene.bodies.empty())
        return scene.bodies[pick / 8 % scene.bodies.size()].id;
      if (kind == 6 && contact_wild) {
        static const char* const kOther[] = {"arm/no_link", "arm", "", "arm/"};
        return kOther[pick / 8 % 4];
      }
      link = pick / 8 % model.linkCount();
      return link_ids[link];
    };
    for (std::size_t c = 0; c < contact_count; ++c) {
      core::Contact contact;
      const std::uint8_t mode = bytes.byte();
      const bool contact_wild = mode % 4 == 3;
      int link_a = -1, link_b = -1;
      contact.body_a = pick_side(bytes.byte(), contact_wild, link_a);
      contact.body_b = pick_side(bytes.byte(), contact_wild, link_b);
      if (contact.body_a == contact.body_b && !contact_wild) {
        // Two sides on one body: the other side becomes the world (an immovable rigid body) or a
        // body of the scene, if any; a robot's link against another of its links otherwise.
        if (!scene.bodies.empty()) {
          contact.body_b = scene.bodies[0].id;
          link_b = -1;
        } else if (model.linkCount() > 1 && link_a >= 0) {
          link_b = (link_a + 1) % model.linkCount();
          contact.body_b = link_ids[link_b];
        }
      }
      const int anchor = link_a >= 0 ? link_a : link_b;
      Eigen::Vector3d centre = Eigen::Vector3d::Zero();
      if (anchor >= 0) centre = robot.linkPose(anchor).translation();
      contact.point = centre + bytes.vector(contact_wild, -0.3, 0.3);
      contact.normal =
          contact_wild && (mode & 0x80) ? bytes.vector(true, -1, 1) : bytes.unitVector();
      const std::uint8_t e = bytes.byte();
      static const double kRestitution[] = {0.5, 0.0, 1.0};
      contact.restitution = e % 4 == 3 ? bytes.value(contact_wild, 0.0, 1.0) : kRestitution[e % 4];
      const std::uint8_t mu = bytes.byte();
      if (mu % 4 == 0) {
        contact.static_friction = contact.dynamic_friction = 0.0;
      } else if (contact_wild && mu % 4 == 3) {
        contact.static_friction = bytes.value(true, 0.0, 2.0);
        contact.dynamic_friction = bytes.value(true, 0.0, 2.0);
      } else {
        contact.static_friction = bytes.uniform(0.0, 2.0);
        contact.dynamic_friction =
            mu % 4 == 1 ? contact.static_friction : contact.static_friction * bytes.unit();
      }
      scene.contacts.push_back(contact);
    }
    outcome.contacts = scene.contacts.size();
    text << describe({scene, options, core::RequestLimits()});

    validator.checkContacts(scene);
    const int rigid_count = static_cast<int>(scene.bodies.size());
    std::vector<core::RigidBody> rigid;  // as the node builds them
    core::makeRigidBodies(scene.bodies, rigid);
    core::setFreeAccelerations(scene.bodies, rigid);
    std::vector<core::BodyModel*> models;
    for (core::RigidBody& body : rigid) models.push_back(&body);
    models.push_back(&robot);
    // One robot: the link ids it added to the validator are its links 0, 1, ...
    std::vector<std::pair<int, int>> robot_link_of_id;
    for (std::size_t link = 0; link < link_ids.size(); ++link)
      robot_link_of_id.emplace_back(0, static_cast<int>(link));
    const std::vector<core::ContactPoint> points =
        placeContacts(scene.contacts, validator.contactBodies(), rigid_count, robot_link_of_id);
    if (print_before_solving) {
      // So that a crash in the solver is preceded by its input.
      std::fputs(text.str().c_str(), stdout);
      std::fflush(stdout);
      text.str("");
    }
    // Pre-impact copies of the bodies, for the outcome distribution and the derivatives below.
    std::vector<core::RigidBody> rigid_copy = rigid, rigid_derivatives = rigid;
    robot::ArticulatedBody robot_copy = robot, robot_derivatives = robot;
    const core::BodyResponse result = core::computeBodyResponse(models, points, options);
    std_msgs::Header header;
    header.frame_id = "world";
    const RobotResult answer =
        toMsg(served->name(), robot, velocity_before, energy_before, base_pose, header);
    const Eigen::VectorXd torques =
        robot.restingContactTorques(rigid_count, points, result.impulses);
    const std::vector<double> contact_torques(torques.data(), torques.data() + torques.size());
    outcome.solved = true;
    for (const core::ContactImpulse& impulse : result.impulses) {
      if (impulse.normal_velocity_before < 0.0) outcome.approaching = true;
      if (impulse.normal_force != 0.0) outcome.resting = true;
    }
    text << "answer: joint velocities " << list(answer.joint_state.velocity) << ", effort "
         << list(answer.joint_state.effort) << ", energy " << answer.kinetic_energy_before << " -> "
         << answer.kinetic_energy_after << ", warnings " << list(warnings) << "\n";
    outcome.bug = checkAnswer(result, rigid, answer, contact_torques);

    // The same request's outcome distribution (linear or sampled), decoded from the bytes left:
    // none when they have run out, so that saved inputs replay as before.
    std::vector<core::ContactUncertainty> uncertainties;
    core::UncertaintyOptions method;
    if (outcome.bug.empty() &&
        detail::decodeUncertainty(bytes, points.size(), uncertainties, method)) {
      std::vector<core::BodyModel*> copies;
      for (core::RigidBody& body : rigid_copy) copies.push_back(&body);
      copies.push_back(&robot_copy);
      Eigen::Index unknowns = 0;
      for (const core::BodyModel* body : copies) unknowns += body->velocityCount();
      Eigen::VectorXd limits =
          Eigen::VectorXd::Constant(unknowns, std::numeric_limits<double>::infinity());
      const Eigen::Index robot_offset = unknowns - robot_copy.velocityCount();
      for (int k = 0; k < robot_copy.velocityCount(); ++k) {
        const int joint = robot_copy.jointOfUnknown(k);
        if (joint >= 0) limits(robot_offset + k) = robot_copy.velocityLimit(joint);
      }
      const Eigen::VectorXd before = robot_copy.velocity();
      text << "uncertainty: " << core::toString(method.method) << ", samples " << method.samples
           << ", " << uncertainties.size() << " entries\n";
      const core::OutcomeDistribution distribution = core::computeBodyOutcomeDistribution(
          {copies}, points, uncertainties, limits, options, method, nullptr);
      bool non_finite = false;
      outcome.bug =
          detail::checkDistribution(unknowns + 4 * static_cast<Eigen::Index>(points.size()),
                                    points.size(), method.method, distribution, non_finite);
      if (outcome.bug.empty() &&
          distribution.limit_probability.size() != static_cast<std::size_t>(unknowns))
        outcome.bug = "uncertainty: one limit probability per velocity unknown expected";
      if (outcome.bug.empty() &&
          !((robot_copy.velocity() - before).norm() <= 1e-9 * (1.0 + before.norm())))
        outcome.bug = "uncertainty: the robot's copy did not end at its pre-impact velocities";
    }
    // The same request's derivatives with the robot's joint positions as coordinates (closed
    // form or differences, core::computeBodyImpactDerivatives()), on a byte left that is odd:
    // finite, the robot back at its joint positions and at the prediction's velocities.
    if (outcome.bug.empty() && bytes.byte() % 2 == 1) {
      std::vector<core::BodyModel*> copies;
      for (core::RigidBody& body : rigid_derivatives) copies.push_back(&body);
      copies.push_back(&robot_derivatives);
      const Eigen::VectorXd q = robot_derivatives.jointPositions();
      // At most 0.5 s (SolverTimeout beyond): differenced columns of a large robot take a solve
      // each, and the fuzzer's throughput matters more than their wall time.
      core::SolverOptions bounded = options;
      bounded.time_budget = std::min(options.time_budget, 0.5);
      const core::BodyImpactDerivatives d = core::computeBodyImpactDerivatives(
          copies, points, bounded, robot::jointPositionCoordinates(robot_derivatives));
      text << "derivatives: " << core::toString(d.method) << ", joint positions "
           << core::toString(d.coordinate_method) << "\n";
      const Eigen::VectorXd after = robot.velocity();
      if (!d.jacobian.allFinite()) {
        outcome.bug = "derivatives: a non-finite entry";
      } else if (robot_derivatives.jointPositions() != q) {
        outcome.bug = "derivatives: the robot did not end at its joint positions";
      } else if (!((robot_derivatives.velocity() - after).norm() <= 1e-6 * (1.0 + after.norm()))) {
        outcome.bug = "derivatives: the robot did not end at the prediction's velocities";
      }
    }
  } catch (const core::InvalidInput& error) {
    outcome.invalid = error.what();
    text << "outcome: InvalidInput: " << error.what() << "\n";
  } catch (const core::SolverTimeout& error) {
    outcome.timeout = error.what();
  } catch (const std::exception& error) {
    outcome.bug = std::string("unexpected exception: ") + error.what();
  } catch (...) {
    outcome.bug = "unexpected exception of unknown type";
  }
  finish();
  return outcome;
}

}  // namespace collision_response::fuzz
