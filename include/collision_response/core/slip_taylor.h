#pragma once

#include <Eigen/Core>

namespace collision_response::core {

/// The path of one sliding contact as a Taylor polynomial in the integrator's clock xi
/// (docs/physics.md, "Rotating slip in 3D: Taylor steps"). One frictional contact in its contact
/// basis (t1, t2, n), as in impulse_space_integrator.cpp: K = [A b; b^T c] (A = K_tt, b = K_tn,
/// c = K_nn) [1/kg], u0 = (u0_t, u0_n) the relative velocity before the impact [m/s], mu_d the
/// sliding friction. The state y = (p, P_t1, P_t2, W): the normal impulse p and the friction
/// impulse P_t [N s], the work of the normal impulse W [J]. With u_t = u0_t + A P_t + b p,
/// u_n = u0_n + b.P_t + c p and sigma = |u_t|, the sliding equations in xi (dp/dxi = sigma, so xi
/// is in kg) are
///     dp/dxi = sigma,  dP_t/dxi = -mu_d u_t,  dW/dxi = sigma u_n.
/// Their solution through a state with sigma > 0 is analytic in xi; expand() forms its Taylor
/// coefficients in the scaled clock s = (xi - xi0) / T, y = sum_k Y_k s^k, from the equations'
/// recurrences: u_t and u_n are linear in y, sigma follows from sigma^2 = |u_t|^2 order by order,
/// and sigma u_n is a Cauchy product. T [kg] is the caller's (the integrator takes 1 / rate, the
/// inverse of the slip's fastest turning, so that s is of order one whatever the masses); the
/// velocities are scaled by sigma0 = |u_t| at y inside the recurrences, so that nothing overflows
/// for any velocity or mass the validation admits. Y_k then has the state's units. Order n costs
/// O(n^2) operations (about 2,500 instructions at n = 15), no allocation.
class SlipTaylor {
 public:
  static constexpr int kMaxOrder = 32;

  /// The coefficients Y_0 .. Y_n about `y` in the clock s = (xi - xi0) / clock, n in
  /// [1, kMaxOrder], clock > 0 [kg]. False (nothing formed) if the slip is zero or not finite at y
  /// (no expansion: the clock stops there).
  bool expand(const Eigen::Matrix2d& A, const Eigen::Vector2d& b, double c,
              const Eigen::Vector2d& u0_t, double u0_n, double mu_d, const Eigen::Vector4d& y,
              int n, double clock = 1.0);

  int order() const { return order_; }
  /// Y_k, k in [0, order()].
  Eigen::Vector4d coefficient(int k) const {
    return Eigen::Vector4d(Y_[k][0], Y_[k][1], Y_[k][2], Y_[k][3]);
  }
  /// max(|Y_k,p|, |Y_k,P_t1|, |Y_k,P_t2|, |Y_k,W| / work_scale): order k's size with the work in
  /// impulse units.
  double size(int k, double work_scale) const;
  /// y at s = t, the polynomial (Horner).
  Eigen::Vector4d at(double t) const;
  /// dy/ds at s = t, the polynomial's derivative.
  Eigen::Vector4d rate(double t) const;
  /// The polynomial of grad . y(s) + offset: its coefficients into `e` (order() + 1 of
  /// them), for value() (an event that is a linear function of the state).
  void linear(const Eigen::Vector4d& grad, double offset, double* e) const;
  /// sum_k e_k t^k and its derivative in t (Horner).
  static double value(const double* e, int order, double t, double& slope);
  /// sum_k e_k t^k alone (Horner; the same sums as the value above).
  static double value(const double* e, int order, double t);

 private:
  int order_ = 0;
  double Y_[kMaxOrder + 1][4];
};

}  // namespace collision_response::core
