// Cost of the derivatives of the impact map (impact_derivatives.h, body_impact_derivatives.h)
// against the prediction's own (Google Benchmark):
//   devel/lib/collision_response/bench_derivatives          (Release build)
// Each pair times the prediction (computeResponse(), computeBodyResponse()) and the derivatives
// (computeImpactDerivatives(), computeBodyImpactDerivatives(), which include one prediction) on
// the same scene. Rigid bodies, Newton law, analytic paths: one off-centre frictional contact that
// slides, the same that sticks, and a cube landing on 4 contacts (exact solver). The shipped arm
// (urdf/arm7.urdf) striking a box with its hand at one frictional contact (robot_scene.h, as
// bench_robot), Stronge and Poisson (analytic: the integration's sensitivity) and Newton
// (frictional: analytic, the exact solver's final mode): the derivatives with respect to the joint
// velocities, the box's twist and the contact's e, mu_s, mu_d. The instruction counts of one call
// of each, for the benchmark report:
//   LD_BIND_NOW=1 valgrind --tool=callgrind --toggle-collect='*predictOnce*' bench_derivatives
//   --callgrind SCENE
//   LD_BIND_NOW=1 valgrind --tool=callgrind --toggle-collect='*differentiateOnce*'
//   bench_derivatives --callgrind SCENE
// (LD_BIND_NOW: the dynamic linker's first resolution of a library function is not counted)
// with SCENE one of sliding, sticking, cube4, cube4_poisson, cube4_stronge (the 4-corner landing
// under the impulse-space laws), arm_stronge, arm_poisson, arm_newton (the arm's
// functions are predictArmOnce and differentiateArmOnce; each is counted on one call after an
// uncounted warm-up call). The arm's linear outcome distribution (uncertainty.h, kLinear; e, mu_s
// and mu_d uncertain): BM_Linear_ArmNewton / _ArmStronge, and '*linearArmOnce*' with the arm
// scenes.
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "collision_response/core/body_impact_derivatives.h"
#include "collision_response/core/body_response.h"
#include "collision_response/core/compute_response.h"
#include "collision_response/core/impact_derivatives.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/uncertainty.h"
#include "collision_response/robot/articulated_body.h"
#include "collision_response/robot/joint_position_coordinates.h"
#include "collision_response/robot/urdf_loader.h"
#include "robot_scene.h"

namespace core = collision_response::core;
namespace rb = collision_response::robot;

namespace {

// A box struck off-centre on the ground: u = (1, 0.3, -2) m/s at the contact; mu_s decides
// whether it sticks (2.0) or slides (0.2, with mu_d = 0.8 mu_s).
core::Scene singleContact(double mu_s) {
  core::BodyState ground;
  ground.id = "ground";
  core::BodyState box;
  box.id = "box";
  box.mass = 1.5;
  box.inertia = Eigen::Vector3d(0.05, 0.08, 0.1).asDiagonal();
  box.orientation =
      Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()));
  box.position = {0.1, -0.05, 0.2};
  box.linear_velocity = {1.0, 0.3, -2.0};
  box.angular_velocity = {0.5, -1.0, 0.2};
  core::Contact contact;
  contact.body_a = "ground";
  contact.body_b = "box";
  contact.point = {0.0, 0.0, 0.0};
  contact.normal = {0.0, 0.0, 1.0};
  contact.restitution = 0.5;
  contact.static_friction = mu_s;
  contact.dynamic_friction = 0.8 * mu_s;
  core::Scene scene;
  scene.bodies = {ground, box};
  scene.contacts = {contact};
  return scene;
}

// A unit cube landing flat, tilted velocity and spin: 4 corner contacts, one island.
core::Scene cube4(double mu) {
  core::Scene scene = singleContact(mu);
  core::BodyState& cube = scene.bodies[1];
  cube.mass = 1.0;
  cube.inertia = Eigen::Matrix3d::Identity() / 6.0;
  cube.orientation = Eigen::Quaterniond::Identity();
  cube.position = {0.0, 0.0, 0.5};
  cube.linear_velocity = {0.3, 0.1, -1.0};
  cube.angular_velocity = {0.2, -0.1, 0.3};
  const core::Contact corner = scene.contacts[0];
  scene.contacts.clear();
  for (const double x : {-0.5, 0.5}) {
    for (const double y : {-0.5, 0.5}) {
      core::Contact contact = corner;
      contact.point = {x, y, 0.0};
      scene.contacts.push_back(contact);
    }
  }
  return scene;
}

core::SolverOptions newton() {
  core::SolverOptions options;
  options.law = core::ImpactLaw::kNewton;
  return options;
}

[[gnu::noinline]] core::CollisionResult predictOnce(const core::Scene& scene,
                                                    const core::SolverOptions& options) {
  return core::computeResponse(scene, options);
}

[[gnu::noinline]] core::ImpactDerivatives differentiateOnce(const core::Scene& scene,
                                                            const core::SolverOptions& options) {
  return core::computeImpactDerivatives(scene, options);
}

void predict(benchmark::State& state, const core::Scene& scene) {
  const core::SolverOptions options = newton();
  for (auto _ : state) benchmark::DoNotOptimize(predictOnce(scene, options));
}

void differentiate(benchmark::State& state, const core::Scene& scene) {
  const core::SolverOptions options = newton();
  for (auto _ : state) benchmark::DoNotOptimize(differentiateOnce(scene, options));
}

void BM_Predict_SingleSliding(benchmark::State& s) {
  predict(s, singleContact(0.2));
}
void BM_Derivatives_SingleSliding(benchmark::State& s) {
  differentiate(s, singleContact(0.2));
}
void BM_Predict_SingleSticking(benchmark::State& s) {
  predict(s, singleContact(2.0));
}
void BM_Derivatives_SingleSticking(benchmark::State& s) {
  differentiate(s, singleContact(2.0));
}
void BM_Predict_Cube4(benchmark::State& s) {
  predict(s, cube4(0.5));
}
void BM_Derivatives_Cube4(benchmark::State& s) {
  differentiate(s, cube4(0.5));
}

// The arm striking the box (bench_robot's scene): the arm and the box set to their pre-impact
// state for each call, as a request would.
struct ArmScene {
  collision_response::bench::ArmBoxScene scene;
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(ROBOT_URDF_DIR "/arm7.urdf");
  core::RigidBody box;
  std::vector<core::ContactPoint> contacts;
  ArmScene() {
    arm.setState(scene.q, scene.qdot);
    const int hand = arm.linkIndex("hand");
    const Eigen::Vector3d p = arm.linkPose(hand).translation();
    core::ContactPoint contact(0, 1, p, scene.normal, scene.restitution, scene.static_friction,
                               scene.dynamic_friction);
    contact.part_a = hand;
    contacts = {contact};
    box.inverse_mass = 1.0 / scene.box_mass;
    box.inverse_inertia = scene.boxInertia().cwiseInverse().asDiagonal();
    box.com = p + scene.box_offset * scene.normal;
  }
  void reset() {
    arm.setState(scene.q, scene.qdot);
    box.linear_velocity = scene.box_velocity;
    box.angular_velocity.setZero();
  }
};

core::SolverOptions armOptions(core::ImpactLaw law) {
  core::SolverOptions options;
  options.law = law;
  return options;
}

[[gnu::noinline]] core::BodyResponse predictArmOnce(ArmScene& s,
                                                    const core::SolverOptions& options) {
  s.reset();
  return core::computeBodyResponse({&s.arm, &s.box}, s.contacts, options);
}

[[gnu::noinline]] core::BodyImpactDerivatives differentiateArmOnce(
    ArmScene& s, const core::SolverOptions& options) {
  s.reset();
  return core::computeBodyImpactDerivatives({&s.arm, &s.box}, s.contacts, options);
}

// The same with the arm's 9 joint positions as coordinates too: in closed form (`closed_form`:
// each coordinate names the arm, ConfigurationCoordinate::body) or by central differences of the
// whole prediction (the body left out, as before the closed form).
[[gnu::noipa]] core::BodyImpactDerivatives differentiateArmPositionsOnce(
    ArmScene& s, const core::SolverOptions& options,
    const std::vector<core::ConfigurationCoordinate>& coordinates) {
  s.reset();
  return core::computeBodyImpactDerivatives({&s.arm, &s.box}, s.contacts, options, coordinates);
}
// The same call under another name, for the differenced columns' instruction count (noipa: GCC
// would fold the two identical functions into one).
[[gnu::noipa]] core::BodyImpactDerivatives differenceArmPositionsOnce(
    ArmScene& s, const core::SolverOptions& options,
    const std::vector<core::ConfigurationCoordinate>& coordinates) {
  s.reset();
  return core::computeBodyImpactDerivatives({&s.arm, &s.box}, s.contacts, options, coordinates);
}
std::vector<core::ConfigurationCoordinate> armPositions(ArmScene& s, bool closed_form) {
  std::vector<core::ConfigurationCoordinate> out = rb::jointPositionCoordinates(s.arm);
  if (!closed_form) {
    for (core::ConfigurationCoordinate& c : out) c.body = nullptr;
  }
  return out;
}

// The linear outcome distribution of the same strike (computeBodyOutcomeDistribution(), kLinear):
// e ~ N(0.5, 0.05), mu_s ~ N(0.6, 0.03), mu_d ~ N(0.5, 0.03), the arm's URDF velocity limits.
struct ArmUncertainty {
  std::vector<core::ContactUncertainty> uncertainties;
  Eigen::VectorXd limits;
  explicit ArmUncertainty(const ArmScene& s) {
    core::ContactUncertainty u;
    u.contact = 0;
    u.restitution = core::CoefficientDistribution::normal(0.5, 0.05);
    u.static_friction = core::CoefficientDistribution::normal(0.6, 0.03);
    u.dynamic_friction = core::CoefficientDistribution::normal(0.5, 0.03);
    uncertainties = {u};
    limits = Eigen::VectorXd::Constant(s.arm.velocityCount() + 6,
                                       std::numeric_limits<double>::infinity());
    for (int k = 0; k < s.arm.velocityCount(); ++k) {
      const int joint = s.arm.jointOfUnknown(k);
      if (joint >= 0) limits(k) = s.arm.velocityLimit(joint);
    }
  }
};

[[gnu::noinline]] core::OutcomeDistribution linearArmOnce(ArmScene& s, const ArmUncertainty& u,
                                                          const core::SolverOptions& options) {
  s.reset();
  core::UncertaintyOptions linear;
  linear.method = core::UncertaintyMethod::kLinear;
  return core::computeBodyOutcomeDistribution({{&s.arm, &s.box}}, s.contacts, u.uncertainties,
                                              u.limits, options, linear);
}

void BM_Predict_ArmStronge(benchmark::State& state) {
  ArmScene s;
  const core::SolverOptions options = armOptions(core::ImpactLaw::kStronge);
  for (auto _ : state) benchmark::DoNotOptimize(predictArmOnce(s, options));
}
void BM_Derivatives_ArmStronge(benchmark::State& state) {
  ArmScene s;
  const core::SolverOptions options = armOptions(core::ImpactLaw::kStronge);
  for (auto _ : state) benchmark::DoNotOptimize(differentiateArmOnce(s, options));
}
void BM_Predict_ArmPoisson(benchmark::State& state) {
  ArmScene s;
  const core::SolverOptions options = armOptions(core::ImpactLaw::kPoisson);
  for (auto _ : state) benchmark::DoNotOptimize(predictArmOnce(s, options));
}
void BM_Derivatives_ArmPoisson(benchmark::State& state) {
  ArmScene s;
  const core::SolverOptions options = armOptions(core::ImpactLaw::kPoisson);
  for (auto _ : state) benchmark::DoNotOptimize(differentiateArmOnce(s, options));
}
void BM_Predict_ArmNewton(benchmark::State& state) {
  ArmScene s;
  const core::SolverOptions options = armOptions(core::ImpactLaw::kNewton);
  for (auto _ : state) benchmark::DoNotOptimize(predictArmOnce(s, options));
}
void BM_Derivatives_ArmNewton(benchmark::State& state) {
  ArmScene s;
  const core::SolverOptions options = armOptions(core::ImpactLaw::kNewton);
  for (auto _ : state) benchmark::DoNotOptimize(differentiateArmOnce(s, options));
}

// Argument: 1 in closed form, 0 by differences.
void armJointPositions(benchmark::State& state, core::ImpactLaw law) {
  ArmScene s;
  const core::SolverOptions options = armOptions(law);
  const std::vector<core::ConfigurationCoordinate> coordinates =
      armPositions(s, state.range(0) == 1);
  for (auto _ : state) {
    benchmark::DoNotOptimize(state.range(0) == 1
                                 ? differentiateArmPositionsOnce(s, options, coordinates)
                                 : differenceArmPositionsOnce(s, options, coordinates));
  }
}
void BM_Derivatives_ArmNewtonJointPositions(benchmark::State& state) {
  armJointPositions(state, core::ImpactLaw::kNewton);
}
void BM_Derivatives_ArmStrongeJointPositions(benchmark::State& state) {
  armJointPositions(state, core::ImpactLaw::kStronge);
}

void BM_Linear_ArmNewton(benchmark::State& state) {
  ArmScene s;
  const ArmUncertainty u(s);
  const core::SolverOptions options = armOptions(core::ImpactLaw::kNewton);
  for (auto _ : state) benchmark::DoNotOptimize(linearArmOnce(s, u, options));
}
void BM_Linear_ArmStronge(benchmark::State& state) {
  ArmScene s;
  const ArmUncertainty u(s);
  const core::SolverOptions options = armOptions(core::ImpactLaw::kStronge);
  for (auto _ : state) benchmark::DoNotOptimize(linearArmOnce(s, u, options));
}

}  // namespace

BENCHMARK(BM_Predict_ArmStronge);
BENCHMARK(BM_Derivatives_ArmStronge);
BENCHMARK(BM_Predict_ArmPoisson);
BENCHMARK(BM_Derivatives_ArmPoisson);
BENCHMARK(BM_Predict_ArmNewton);
BENCHMARK(BM_Derivatives_ArmNewton);
BENCHMARK(BM_Derivatives_ArmNewtonJointPositions)->Arg(1)->Arg(0);
BENCHMARK(BM_Derivatives_ArmStrongeJointPositions)->Arg(1)->Arg(0);
BENCHMARK(BM_Linear_ArmNewton);
BENCHMARK(BM_Linear_ArmStronge);
BENCHMARK(BM_Predict_SingleSliding);
BENCHMARK(BM_Derivatives_SingleSliding);
BENCHMARK(BM_Predict_SingleSticking);
BENCHMARK(BM_Derivatives_SingleSticking);
BENCHMARK(BM_Predict_Cube4);
BENCHMARK(BM_Derivatives_Cube4);

// `--callgrind SCENE`: one counted call of each function on that scene, no timing (for the
// instruction counts above).
int main(int argc, char** argv) {
  if (argc > 2 && std::strcmp(argv[1], "--callgrind") == 0) {
    const std::string which = argv[2];
    if (which == "arm_stronge" || which == "arm_poisson" || which == "arm_newton") {
      ArmScene s;
      const core::SolverOptions options =
          armOptions(which == "arm_newton"    ? core::ImpactLaw::kNewton
                     : which == "arm_poisson" ? core::ImpactLaw::kPoisson
                                              : core::ImpactLaw::kStronge);
      // A first call outside the counted functions (lazy symbol binding, thread-local
      // workspaces), so that the counts are of one warm call each.
      s.reset();
      const core::BodyImpactDerivatives first =
          core::computeBodyImpactDerivatives({&s.arm, &s.box}, s.contacts, options);
      std::printf("method %s, contact mode %s%s\n", core::toString(first.method),
                  core::toString(first.contacts[0].mode),
                  first.contacts[0].at_switch ? " (at a switch)" : "");
      // And one of the solver itself: the derivatives of a lone impulse-space contact do not run
      // it (body_impact_derivatives.cpp), so the call above leaves its workspace cold.
      s.reset();
      benchmark::DoNotOptimize(core::computeBodyResponse({&s.arm, &s.box}, s.contacts, options));
      benchmark::DoNotOptimize(predictArmOnce(s, options));
      benchmark::DoNotOptimize(differentiateArmOnce(s, options));
      // With the joint positions: '*differentiateArmPositionsOnce*' counts the call in closed
      // form, '*differenceArmPositionsOnce*' the one by differences.
      for (const bool closed_form : {true, false}) {
        const std::vector<core::ConfigurationCoordinate> coordinates = armPositions(s, closed_form);
        const core::BodyImpactDerivatives d =
            closed_form ? differentiateArmPositionsOnce(s, options, coordinates)
                        : differenceArmPositionsOnce(s, options, coordinates);
        std::printf("joint positions %s: %s\n", closed_form ? "closed form" : "differenced",
                    core::toString(d.coordinate_method));
      }
      const ArmUncertainty u(s);
      core::UncertaintyOptions linear;  // a warm-up call of the linear method, not counted
      linear.method = core::UncertaintyMethod::kLinear;
      s.reset();
      const core::OutcomeDistribution warm = core::computeBodyOutcomeDistribution(
          {{&s.arm, &s.box}}, s.contacts, u.uncertainties, u.limits, options, linear);
      std::printf("linear: stick probability %.4f, %zu warnings\n", warm.stick_probability[0],
                  warm.warnings.size());
      benchmark::DoNotOptimize(linearArmOnce(s, u, options));  // counted by '*linearArmOnce*'
      return 0;
    }
    const core::Scene scene = which == "sliding"    ? singleContact(0.2)
                              : which == "sticking" ? singleContact(2.0)
                                                    : cube4(0.5);
    // cube4_poisson, cube4_stronge: the same landing under an impulse-space law (its 4 corners
    // integrated together; derivatives through the integration).
    core::SolverOptions options = newton();
    if (which == "cube4_poisson") options.law = core::ImpactLaw::kPoisson;
    if (which == "cube4_stronge") options.law = core::ImpactLaw::kStronge;
    {
      const core::ImpactDerivatives d = core::computeImpactDerivatives(scene, options);
      std::printf("method %s\n", core::toString(d.method));
    }
    // A first call of each outside the counted ones (thread-local workspaces, lazy tables).
    benchmark::DoNotOptimize(core::computeImpactDerivatives(scene, options));
    benchmark::DoNotOptimize(predictOnce(scene, options));
    benchmark::DoNotOptimize(differentiateOnce(scene, options));
    return 0;
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
