// The node's parameters, read and checked in one function without a ROS master
// (loadServerParameters): defaults, every value read, bad types and out-of-range values rejected
// naming the parameter, never clamped; the ranges are the core's (option_ranges.h).
#include <gtest/gtest.h>

#include <string>

#include "collision_response/core/errors.h"
#include "collision_response/core/option_ranges.h"
#include "collision_response/ros/server_parameters.h"

namespace cr = collision_response;
using XmlRpc::XmlRpcValue;

namespace {

XmlRpcValue with(const std::string& name, XmlRpcValue value) {
  XmlRpcValue values;
  values[name] = value;
  return values;
}

void expectRejected(const XmlRpcValue& values, const std::string& parameter) {
  try {
    cr::loadServerParameters(values);
    ADD_FAILURE() << parameter << " was accepted";
  } catch (const cr::core::InvalidInput& e) {
    EXPECT_EQ(e.field(), parameter) << e.what();
  }
}

}  // namespace

TEST(ServerParameters, NoParametersGiveTheDefaults) {
  const cr::ServerParameters p = cr::loadServerParameters(XmlRpcValue());
  const cr::core::SolverOptions built_in;
  EXPECT_EQ(p.solver.law, built_in.law);
  EXPECT_EQ(p.solver.method, built_in.method);
  EXPECT_EQ(p.solver.tolerance, built_in.tolerance);
  EXPECT_EQ(p.solver.max_iterations, built_in.max_iterations);
  EXPECT_EQ(p.solver.time_budget, built_in.time_budget);
  EXPECT_TRUE(p.solver.simultaneous_impulse_space);  // ~multi_contact: simultaneous
  EXPECT_EQ(p.limits.max_bodies, cr::core::RequestLimits().max_bodies);
  EXPECT_EQ(p.default_frame, "world");
  EXPECT_EQ(p.contact_tolerance, 1e-3);
  EXPECT_EQ(p.threads, 2);
  EXPECT_EQ(p.max_batch_scenes, 10000u);
}

TEST(ServerParameters, EveryValueIsRead) {
  XmlRpcValue values;
  values["law"] = "newton";
  values["solver"] = "exact";
  values["multi_contact"] = "two_phase";
  values["tolerance"] = 1e-6;
  values["max_iterations"] = 50;
  values["integration_tolerance"] = 1e-8;
  values["time_budget"] = 2;  // an int where a double is expected is fine
  values["max_bodies"] = 7;
  values["tf_timeout"] = 0.5;
  values["contact_tolerance"] = 0.002;
  values["max_contacts_per_pair"] = 4;
  values["max_batch_scenes"] = 3;
  values["marker_impulse_scale"] = 0.5;
  values["default_frame"] = "odom";
  values["threads"] = 4;
  values["materials"][0]["a"] = "steel";
  values["materials"][0]["b"] = "steel";
  values["materials"][0]["restitution"] = 0.6;
  const cr::ServerParameters p = cr::loadServerParameters(values);
  EXPECT_EQ(p.solver.law, cr::core::ImpactLaw::kNewton);
  EXPECT_EQ(p.solver.method, cr::core::SolverMethod::kExact);
  EXPECT_FALSE(p.solver.simultaneous_impulse_space);
  EXPECT_EQ(p.solver.tolerance, 1e-6);
  EXPECT_EQ(p.solver.max_iterations, 50u);
  EXPECT_EQ(p.solver.integration_tolerance, 1e-8);
  EXPECT_EQ(p.solver.time_budget, 2.0);
  EXPECT_EQ(p.limits.max_bodies, 7u);
  EXPECT_EQ(p.tf_timeout, 0.5);
  EXPECT_EQ(p.contact_tolerance, 0.002);
  EXPECT_EQ(p.max_contacts_per_pair, 4u);
  EXPECT_EQ(p.max_batch_scenes, 3u);
  EXPECT_EQ(p.marker_scales.impulse, 0.5);
  EXPECT_EQ(p.default_frame, "odom");
  EXPECT_EQ(p.threads, 4);
  EXPECT_TRUE(p.materials.knows("steel"));
  EXPECT_EQ(p.materials.lookup("steel", "steel", {}).restitution, 0.6);
}

TEST(ServerParameters, BadValuesAreRejectedNamingTheParameter) {
  expectRejected(with("law", "elastic"), "~law");
  expectRejected(with("solver", "fast"), "~solver");
  expectRejected(with("multi_contact", "sequential"), "~multi_contact");
  expectRejected(with("tolerance", "small"), "~tolerance");
  expectRejected(with("max_iterations", 0), "~max_iterations");
  expectRejected(with("max_iterations", 1.5), "~max_iterations");
  expectRejected(with("time_budget", 0.0), "~time_budget");
  expectRejected(with("tf_timeout", -1.0), "~tf_timeout");
  expectRejected(with("max_bodies", -3), "~max_bodies");
  expectRejected(with("marker_velocity_scale", 0.0), "~marker_velocity_scale");
  expectRejected(with("default_frame", ""), "~default_frame");
  expectRejected(with("threads", 0), "~threads");
  expectRejected(with("threads", 257), "~threads");
  XmlRpcValue unknown_member;
  unknown_member["materials"][0]["a"] = "steel";
  unknown_member["materials"][0]["b"] = "steel";
  unknown_member["materials"][0]["bounce"] = 0.5;
  expectRejected(unknown_member, "~materials[0]");
}

// The ranges are the core's: the bounds themselves are accepted, the next value out is not.
TEST(ServerParameters, RangesAreTheCoresAndNeverClamped) {
  namespace ranges = cr::core::option_ranges;
  EXPECT_EQ(cr::loadServerParameters(with("tolerance", ranges::kTolerance.max)).solver.tolerance,
            ranges::kTolerance.max);
  expectRejected(with("tolerance", ranges::kTolerance.max * 1.5), "~tolerance");
  expectRejected(with("tolerance", -1e-300), "~tolerance");
  EXPECT_EQ(
      cr::loadServerParameters(with("integration_tolerance", ranges::kIntegrationTolerance.min))
          .solver.integration_tolerance,
      ranges::kIntegrationTolerance.min);
  expectRejected(with("integration_tolerance", ranges::kIntegrationTolerance.min / 2),
                 "~integration_tolerance");
  expectRejected(with("contact_tolerance", ranges::kContactTolerance.max + 0.5),
                 "~contact_tolerance");
  expectRejected(with("time_budget", ranges::kTimeBudget.max * 2), "~time_budget");
}

namespace {

XmlRpcValue robotEntry(const std::string& name) {
  XmlRpcValue entry;
  entry["name"] = name;
  return entry;
}

XmlRpcValue robotList(std::initializer_list<XmlRpcValue> entries) {
  XmlRpcValue list;
  list.setSize(static_cast<int>(entries.size()));
  int i = 0;
  for (const XmlRpcValue& entry : entries) list[i++] = entry;
  return list;
}

}  // namespace

TEST(ServerParameters, RobotsAreReadWithTheirDefaults) {
  XmlRpcValue arm = robotEntry("arm");
  XmlRpcValue base = robotEntry("base");
  base["description_param"] = "/base/robot_description";
  base["joint_states_topic"] = "/base/joint_states";
  base["floating"] = true;
  base["base_frame"] = "odom";
  XmlRpcValue locked;
  locked.setSize(1);
  locked[0] = "wheel_joint";
  base["locked_joints"] = locked;
  base["armature"]["wheel_joint"] = 0.02;
  XmlRpcValue values = with("robots", robotList({arm, base}));
  values["joint_state_timeout"] = 2;
  const cr::ServerParameters p = cr::loadServerParameters(values);
  ASSERT_EQ(p.robots.size(), 2u);
  EXPECT_EQ(p.robots[0].name, "arm");
  EXPECT_EQ(p.robots[0].description_param, "/robot_description");
  EXPECT_EQ(p.robots[0].joint_states_topic, "/joint_states");
  EXPECT_FALSE(p.robots[0].floating);
  EXPECT_EQ(p.robots[0].base_frame, "");
  EXPECT_TRUE(p.robots[0].locked_joints.empty());
  EXPECT_EQ(p.robots[1].description_param, "/base/robot_description");
  EXPECT_EQ(p.robots[1].joint_states_topic, "/base/joint_states");
  EXPECT_TRUE(p.robots[1].floating);
  EXPECT_EQ(p.robots[1].base_frame, "odom");
  EXPECT_EQ(p.robots[1].locked_joints, std::vector<std::string>{"wheel_joint"});
  EXPECT_EQ(p.robots[1].armature.at("wheel_joint"), 0.02);
  EXPECT_EQ(p.joint_state_timeout, 2.0);
  EXPECT_EQ(cr::loadServerParameters(XmlRpcValue()).joint_state_timeout, 0.5);
  EXPECT_TRUE(cr::loadServerParameters(XmlRpcValue()).robots.empty());
}

TEST(ServerParameters, BadRobotsAreRejectedNamingTheEntry) {
  expectRejected(with("robots", "arm"), "~robots");
  expectRejected(with("robots", robotList({XmlRpcValue(3)})), "~robots[0]");
  expectRejected(with("robots", robotList({robotEntry("")})), "~robots[0].name");
  expectRejected(with("robots", robotList({robotEntry("a/b")})), "~robots[0].name");
  expectRejected(with("robots", robotList({robotEntry("arm"), robotEntry("arm")})),
                 "~robots[1].name");
  XmlRpcValue unknown = robotEntry("arm");
  unknown["urdf"] = "x";
  expectRejected(with("robots", robotList({unknown})), "~robots[0]");
  XmlRpcValue floating = robotEntry("arm");
  floating["floating"] = "yes";
  expectRejected(with("robots", robotList({floating})), "~robots[0].floating");
  XmlRpcValue armature = robotEntry("arm");
  armature["armature"]["joint1"] = -1.0;
  expectRejected(with("robots", robotList({armature})), "~robots[0].armature.joint1");
  XmlRpcValue locked = robotEntry("arm");
  locked["locked_joints"] = "joint1";
  expectRejected(with("robots", robotList({locked})), "~robots[0].locked_joints");
  expectRejected(with("joint_state_timeout", 0.0), "~joint_state_timeout");
}
