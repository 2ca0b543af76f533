// Forward sensitivity of Routh's method for one contact (impulse_space_integrator.cpp; symbols
// there and in docs/physics.md, "Derivatives of the impact map", "The impulse-space laws").
//
// Every quantity carries its value and its gradient with respect to the six inputs
// theta = (u0_t1, u0_t2, u0_n, e, mu_s, mu_d) (forward mode: the gradient of each operation from
// those of its operands). The phases are the integrator's, decided on the values:
//   - closed-form segments with constant rates dP_t/dp = r (sticking, slip resumed after a stop,
//     frictionless slip along a fixed line, the central stop): the closed forms themselves, so
//     the gradients are exact, events included (the distance to each event is a closed form of
//     the state and theta);
//   - a sliding slip: integrated in xi (dp/dxi = |u_t|, the integrator's variable) by
//     Dormand-Prince 5(4) on the values and gradients together (the sensitivity equations
//     discretised by the same steps), to a tighter tolerance than the prediction's. An event
//     (maximum compression u_n = 0, the end p = p_end or W = W_end) is located on the values and
//     then reached by one Newton step y* = y - g(y) / (dg/dxi) f(y) carried out on values and
//     gradients: its gradient is the event-time sensitivity dxi* = -(dg/dy . dy + dg/dtheta) /
//     (dg/dxi). The slip's stop is an attracting equilibrium in xi: the integration runs until
//     the slip is below 1e-13 of |u0|, where the state and its gradients have converged;
//   - after a stop the state is put on the sticking manifold u_t = 0, P_t = -A^-1 (u0_t + b p):
//     its gradient then includes the slip that is left (the residual the stop leaves is second
//     order in the value, first order in the gradient).
// The code is impulse_space_sensitivity.ipp, compiled here twice: with the six inputs above
// (by_coefficients) and with K's six entries in the contact frame as well (by_mass_matrix; a
// robot's joint positions move K), which integrates a turning slip to its stop instead of taking
// the stick-approach series or the central stop's closed form.
#include "collision_response/core/impulse_space_derivatives.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "collision_response/core/contact_space.h"
#include "collision_response/core/friction_disk.h"
#include "collision_response/core/hermite_root.h"
#include "collision_response/core/least_norm.h"
#include "collision_response/core/stick_approach.h"

namespace collision_response::core {
namespace {
namespace by_coefficients {
constexpr int kGradient = 6;
#include "impulse_space_sensitivity.ipp"  // NOLINT(build/include)
}  // namespace by_coefficients
namespace by_mass_matrix {
constexpr int kGradient = 12;
#include "impulse_space_sensitivity.ipp"  // NOLINT(build/include)
}  // namespace by_mass_matrix
}  // namespace

bool differentiateImpulseSpace(const Eigen::Vector3d& n, const Eigen::Matrix3d& K,
                               const Eigen::Vector3d& u, double e, double mu_s, double mu_d,
                               ImpactLaw law, double tolerance, Eigen::Matrix3d& dP_du,
                               Eigen::Matrix3d& dP_dcoefficients, ContactDerivativeMode& mode,
                               Eigen::Vector3d* impulse, ImpulseSpaceSensitivityDetail* detail) {
  ImpulseSpaceSensitivityDetail local;
  ImpulseSpaceSensitivityDetail& how = detail ? *detail : local;
  how = ImpulseSpaceSensitivityDetail{};
  if (!by_coefficients::differentiate(n, K, u, e, mu_s, mu_d, law, tolerance, mu_d == 0.0, dP_du,
                                      dP_dcoefficients, mode, impulse, how)) {
    return false;
  }
  if (mu_d == 0.0 && mode.mode != ImpactMode::kNoImpulse) {
    // The mu_d column (for increasing mu_d) through the integration of the frictionless slip.
    Eigen::Matrix3d du, dc;
    ContactDerivativeMode integrated;
    ImpulseSpaceSensitivityDetail unused;
    if (!by_coefficients::differentiate(n, K, u, e, mu_s, mu_d, law, tolerance, false, du, dc,
                                        integrated, nullptr, unused)) {
      return false;
    }
    dP_dcoefficients.col(2) = dc.col(2);
  }
  return true;
}

bool differentiateImpulseSpaceByK(const Eigen::Vector3d& n, const Eigen::Matrix3d& K,
                                  const Eigen::Vector3d& u, double e, double mu_s, double mu_d,
                                  ImpactLaw law, double tolerance,
                                  const std::vector<Eigen::Matrix3d>& dK,
                                  Eigen::Matrix<double, 3, Eigen::Dynamic>& dP_dK,
                                  Eigen::Matrix3d& dP_du, ContactDerivativeMode& mode) {
  Eigen::Matrix3d dP_dcoefficients;
  ImpulseSpaceSensitivityDetail detail;
  dP_dK.setZero(3, static_cast<Eigen::Index>(dK.size()));
  return by_mass_matrix::differentiate(n, K, u, e, mu_s, mu_d, law, tolerance, mu_d == 0.0, dP_du,
                                       dP_dcoefficients, mode, nullptr, detail, &dK, &dP_dK);
}

}  // namespace collision_response::core
