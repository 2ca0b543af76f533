#include "landing_baselines.h"

#include "cube_flight.h"

namespace collision_response::bench {
namespace {

/// Contact found to 1 um.
constexpr double kContactTolerance = 1e-6;

/// The shared shape of the baselines: fly to the first contact, change the velocities, fly on.
class RuleLanding : public LandingModel {
 public:
  explicit RuleLanding(const TossedCube& cube) : cube_(cube) {}
  CubeState simulate(const CubeState& before, const std::vector<double>& values,
                     double duration) override {
    const double t = firstTableContact(before, cube_.half_width, duration, kContactTolerance);
    if (t >= duration) return flyBallistic(before, duration);
    CubeState contact = flyBallistic(before, t);
    apply(values, contact);
    return flyBallistic(contact, duration - t);
  }

 protected:
  virtual void apply(const std::vector<double>& values, CubeState& state) const = 0;
  TossedCube cube_;
};

class NoChange final : public LandingModel {
 public:
  std::string name() const override { return "no change"; }
  std::vector<LandingParameter> parameters() const override { return {}; }
  CubeState simulate(const CubeState& before, const std::vector<double>&,
                     double duration) override {
    return flyBallistic(before, duration);
  }
};

class BounceRule final : public RuleLanding {
 public:
  using RuleLanding::RuleLanding;
  std::string name() const override { return "bounce rule"; }
  std::vector<LandingParameter> parameters() const override {
    return {{"e", 0.0, 1.0, 0.3, false}};
  }

 private:
  void apply(const std::vector<double>& values, CubeState& state) const override {
    state.linear_velocity.z() *= -values[0];
  }
};

class Scaling final : public RuleLanding {
 public:
  using RuleLanding::RuleLanding;
  std::string name() const override { return "3-factor scaling"; }
  std::vector<LandingParameter> parameters() const override {
    return {{"a_n", 0.0, 1.0, 0.3, false},
            {"a_t", -1.0, 1.0, 0.5, false},
            {"a_w", -2.0, 3.0, 1.0, false}};
  }

 private:
  void apply(const std::vector<double>& values, CubeState& state) const override {
    state.linear_velocity.z() *= -values[0];
    state.linear_velocity.x() *= values[1];
    state.linear_velocity.y() *= values[1];
    state.angular_velocity *= values[2];
  }
};

}  // namespace

std::unique_ptr<LandingModel> makeNoChangeLanding(const TossedCube&) {
  return std::make_unique<NoChange>();
}
std::unique_ptr<LandingModel> makeBounceRuleLanding(const TossedCube& cube) {
  return std::make_unique<BounceRule>(cube);
}
std::unique_ptr<LandingModel> makeScalingLanding(const TossedCube& cube) {
  return std::make_unique<Scaling>(cube);
}

}  // namespace collision_response::bench
