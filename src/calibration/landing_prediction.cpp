#include "collision_response/calibration/landing_prediction.h"

#include <algorithm>
#include <stdexcept>

#include "collision_response/core/episode.h"
#include "collision_response/detection/shape_gaps.h"

namespace collision_response::calibration {
namespace {

/// The object's gaps to the floor with the coefficients of the moment (ShapeGaps takes them from
/// a material table fixed at construction; a fit changes them at every evaluation).
class CoefficientGaps final : public core::GapQuery {
 public:
  CoefficientGaps(const core::GapQuery& inner, const Coefficients& c) : inner_(inner), c_(c) {}
  void gaps(const std::vector<core::BodyState>& bodies, double range,
            std::vector<core::GapContact>& out) const override {
    inner_.gaps(bodies, range, out);
    for (auto& contact : out) {
      contact.restitution = c_.restitution;
      contact.static_friction = c_.static_friction;
      contact.dynamic_friction = c_.dynamic_friction;
    }
  }
  double radius(int body) const override { return inner_.radius(body); }
  int bodyCount() const override { return inner_.bodyCount(); }

 private:
  const core::GapQuery& inner_;
  Coefficients c_;
};

core::BodyState floorBody() {
  core::BodyState floor;
  floor.id = "floor";
  return floor;
}

core::BodyState objectBody(const ObjectModel& object, const MotionState& state, double scale) {
  core::BodyState body;
  body.id = "object";
  body.mass = object.mass;
  body.inertia = scale * object.inertia;
  body.position = state.position;
  body.orientation = state.orientation;
  body.linear_velocity = state.linear_velocity;
  body.angular_velocity = state.angular_velocity;
  return body;
}

/// Free flight for `duration` [s]: ballistic origin, rotation at the constant world angular
/// velocity (the post-landing fit's model).
MotionState fly(const MotionState& state, double duration, double gravity_z) {
  MotionState out = state;
  const Eigen::Vector3d g(0.0, 0.0, gravity_z);
  out.position += duration * state.linear_velocity + 0.5 * duration * duration * g;
  out.linear_velocity += duration * g;
  out.orientation =
      (quaternionOf(state.angular_velocity * duration) * state.orientation).normalized();
  return out;
}

}  // namespace

struct LandingPredictor::Impl {
  std::unique_ptr<detection::ShapeGaps> gaps;
};

LandingPredictor::LandingPredictor(const ObjectModel& object, const PredictionOptions& options)
    : object_(object), options_(options), length_(lengthScale(object.shape)), impl_(new Impl) {
  detection::DetectionInput input;
  detection::BodyGeometry floor, body;
  detection::Shape plane;
  plane.type = detection::Shape::Type::kPlane;
  plane.dimensions = {0.0, 0.0, 1.0, 0.0};
  floor.shapes = {plane};
  body.shapes = {object.shape};
  input.geometry = {floor, body};
  input.options.max_contacts_per_pair = 64;  // a cylinder's 34 rim points
  try {
    impl_->gaps = std::make_unique<detection::ShapeGaps>(
        std::vector<core::BodyState>{floorBody(), objectBody(object, MotionState(), 1.0)}, input,
        detection::MaterialTable());
  } catch (const std::exception& e) {
    throw std::runtime_error(object.source + ": " + e.what());
  }
}

LandingPredictor::~LandingPredictor() = default;

MotionState LandingPredictor::predict(const Landing& landing, const Coefficients& c) const {
  const double duration = landing.t_after - landing.t_before;
  const CoefficientGaps gaps(*impl_->gaps, c);
  core::EpisodeOptions options;
  options.gravity = Eigen::Vector3d(0.0, 0.0, options_.gravity_z);
  options.horizon = duration;
  options.max_impacts = options_.single_impact ? 1 : 100;
  options.contact_tolerance = 1e-4;
  options.solver.law = options_.law;
  const core::EpisodeResult result = core::computeEpisode(
      {floorBody(), objectBody(object_, landing.before, c.inertia_scale)}, gaps, options);
  MotionState end;
  end.position = result.bodies[1].position;
  end.orientation = result.bodies[1].orientation;
  end.linear_velocity = result.bodies[1].linear_velocity;
  end.angular_velocity = result.bodies[1].angular_velocity;
  return fly(end, std::max(0.0, duration - result.end_time), options_.gravity_z);
}

LandingResidual LandingPredictor::residual(const Landing& landing, const Coefficients& c) const {
  const MotionState predicted = predict(landing, c);
  const double speed = landing.before.linear_velocity.norm();
  LandingResidual r;
  r.head<3>() = (predicted.linear_velocity - landing.after.linear_velocity) / speed;
  r.tail<3>() = length_ * (predicted.angular_velocity - landing.after.angular_velocity) / speed;
  return r;
}

}  // namespace collision_response::calibration
