// A gap query with the coefficients of the moment on every contact (docs/calibration.md): the
// detection (detection::ShapeGaps) takes the coefficients from a material table fixed at its
// construction, while a fit changes them at every evaluation. Used by the robot impacts'
// prediction (robot_impact_prediction.h).
#pragma once

#include <vector>

#include "collision_response/calibration/landing_prediction.h"
#include "collision_response/core/gap_query.h"

namespace collision_response::calibration {

/// `inner`'s gaps with restitution, mu_s and mu_d replaced by `coefficients`; everything else
/// (radius, convexity, support) forwarded. Holds a reference to `inner`.
class CoefficientGaps final : public core::GapQuery {
 public:
  CoefficientGaps(const core::GapQuery& inner, const Coefficients& coefficients)
      : inner_(inner), c_(coefficients) {}
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
  bool convex(int body) const override { return inner_.convex(body); }
  double support(int body, const Eigen::Vector3d& direction) const override {
    return inner_.support(body, direction);
  }
  int bodyCount() const override { return inner_.bodyCount(); }

 private:
  const core::GapQuery& inner_;
  Coefficients c_;
};

}  // namespace collision_response::calibration
