#pragma once

#include <Eigen/Core>
#include <array>

namespace collision_response::core {

/// Highest order of the stick-approach series (StickApproach::kMaxOrder).
constexpr int kStickSeriesMaxOrder = 64;

/// The state of the stick-approach series (StickApproach's members).
struct StickSeries {
  double eps = 1.0;  ///< theta = theta* + eps y
  double mu = 0.0, c = 0.0, m = 0.0;
  double fb_star = 0.0, fb_perp = 0.0;        ///< b . s*, b . s*_perp
  double a_ss = 0.0, a_sp = 0.0, a_pp = 0.0;  ///< s*^T A s*, s*^T A s*_perp, s*_perp^T A s*_perp
  /// gamma(y) = gamma_c1 cos y + gamma_s1 sin y + gamma_c2 cos 2y + gamma_s2 sin 2y [1/kg]
  /// (gamma(0) = 0), from the members above: gammaAt(), the recurrence and radius() read them.
  double gamma_c1 = 0.0, gamma_s1 = 0.0, gamma_c2 = 0.0, gamma_s2 = 0.0;
  // Taylor coefficients in y: H = -e^S / Gamma with Gamma = gamma / y (dp/dy's regular part,
  // from y Gamma H' = H (f - m Gamma - y Gamma')), and the sums' coefficients Ip = H / (m + k),
  // Ic = (H cos y)_k / (m + k), Is likewise, D = c Ip - mu (b.s*) Ic - mu eps (b.s*_perp) Is,
  // DH2 = (D H)_k / (2m + k).
  using Series = std::array<double, kStickSeriesMaxOrder + 1>;
  int order = -1;
  double inverse_gamma0 = 0.0;  ///< 1 / Gamma(0) = 1 / g'(theta*) < 0
  /// (H cos y), (H sin y), (H cos 2y), (H sin 2y) at index order + 1 over j <= order - 1
  /// (extend()'s sums at the next order, but for their last terms).
  double next_c1 = 0.0, next_s1 = 0.0, next_c2 = 0.0, next_s2 = 0.0;
  Series H, Ip, Ic, Is, D, DH2;
  /// (H cos y)_k, (H sin y)_k, (H cos 2y)_k, (H sin 2y)_k over j < k, as the recurrence formed
  /// them (kept for the mu_d derivatives' recurrence, StickApproach::muDerivatives()).
  Series Pc, Ps, Qc, Qs;
};

/// Rotating slip that settles into stick, in closed form (docs/physics.md, "Approach to stick in
/// closed form"). One frictional contact, in its contact basis (t1, t2, n) as in
/// impulse_space_integrator.cpp: K = [A b; b^T c] (A = K_tt, b = K_tn, c = K_nn) [1/kg],
/// u_t the slip velocity [m/s] with speed sigma and direction s = (cos theta, sin theta) in
/// (t1, t2), p the normal impulse [N s]. While sliding, du_t/dp = F(s) = b - mu_d A s.
///
/// With the clock xi (dp/dxi = sigma), the angle obeys an equation of its own,
/// dtheta/dxi = g(theta) = s_perp . F(s), and ln sigma follows, dln(sigma)/dxi = f(theta) = s .
/// F(s). The slip direction turns monotonically to the nearest zero theta* of g ahead of it; when
/// that direction attracts (g'(theta*) < 0) and slows the slip (f(theta*) < 0), the slip stops
/// there at a finite impulse. With y = |theta - theta*| every remaining quantity to the stop is
/// sigma e^-S(y) times a power series in y (S, H below analytic in y), here summed to the
/// tolerance:
///   p_rem = sigma e^-S Ip(y),  P_t,rem = -mu_d sigma e^-S (s* Ic(y) + eps s*_perp Is(y)),
///   W_rem = u_n,stop p_rem - (sigma e^-S)^2 DH2(y)   (work of the normal impulse [J]).
/// The series converge for y below the distance from theta* to the next zero of g (real or
/// complex); converged() says whether they do to a tolerance at a given y.
class StickApproach {
 public:
  /// The approach from slip direction s0 (unit): theta*, the side eps and the leading orders.
  /// False (no closed form; integrate instead) if the slip does not turn to an attracting
  /// direction that stops it, if it starts more than a quarter turn away from it, or if
  /// c <= mu_d |b| (u_n could then fall while sliding, and events need not be monotone).
  bool build(const Eigen::Matrix2d& A, const Eigen::Vector2d& b, double c, double mu_d,
             const Eigen::Vector2d& s0);

  /// y = |theta(s) - theta*| of a slip direction on the approach's side [rad], or -1 if s lies
  /// beyond theta* (on the other side).
  double distance(const Eigen::Vector2d& s) const;

  /// Extends the series until, at y, each converges with a remainder below its share times its
  /// leading term: relative_impulse for the impulses (Ip, Ic, Is), relative_work for the work
  /// (DH2). False if they do not within kMaxOrder (y too far from theta*), or if their decay so far
  /// shows that they will not.
  bool converged(double y, double relative_impulse, double relative_work);

  /// Remaining quantities from angle distance y to the stop, for scale sigma e^-S(y) given as
  /// log_scale = ln(sigma) - S(y) (see logScale()).
  struct Remaining {
    double p = 0.0;                                 ///< normal impulse to the stop [N s]
    Eigen::Vector2d P_t = Eigen::Vector2d::Zero();  ///< friction impulse to the stop [N s]
    double u_n_rise = 0.0;   ///< rise of u_n to the stop, b . P_t + c p [m/s]
    double work_drop = 0.0;  ///< (sigma e^-S)^2 DH2(y) [J]: W_rem = u_n,stop p - work_drop
    double rate = 0.0;       ///< d p_rem / dy [N s / rad]
    Eigen::Vector2d direction = Eigen::Vector2d::Zero();  ///< s at y
  };
  Remaining remaining(double y, double log_scale) const;

  /// Derivatives with respect to mu_d of the remaining normal impulse p_rem [N s / 1] and of
  /// work_drop [J / 1] (Remaining) of a slip of speed sigma [m/s] at angle distance y [rad] from
  /// s*, the slip u_t itself held fixed (so y moves with theta*: dy/dmu_d = -eps dtheta*/dmu_d,
  /// dtheta*/dmu_d = (s*^T A s*_perp) / g'(theta*)); A, b, c fixed. From the recurrence of the
  /// series' coefficients differentiated term by term, to two orders beyond order() (the values
  /// are extended to three beyond it): call after converged() at y.
  struct MuDerivatives {
    double p = 0.0;          ///< d p_rem / d mu_d [N s]
    double work_drop = 0.0;  ///< d work_drop / d mu_d [J]
  };
  MuDerivatives muDerivatives(double y, double sigma);

  /// ln(sigma e^-S(y)) of the slip at y with speed sigma; the scale at another y' of the same
  /// path is this plus m ln(y' / y).
  double logScale(double y, double sigma) const;

  /// The series' radius of convergence in y [rad]: the distance from theta* to the nearest other
  /// zero of g in the complex angle plane (a real one: another fixed direction; a complex pair:
  /// where the flow's coefficients become singular off the real line). Infinite if there is none.
  double radius() const;

  /// s*, the unit slip direction at the stop, in (t1, t2).
  const Eigen::Vector2d& direction() const { return s_star_; }
  /// The exponent m = f(theta*) / g'(theta*) > 0: sigma ~ y^m near the stop.
  double exponent() const { return co_.m; }
  /// Highest order of the series computed so far.
  int order() const { return co_.order; }
  /// The highest order converged() computes.
  static constexpr int kMaxOrder = kStickSeriesMaxOrder;

 private:
  /// Appends order k = order() + 1 of every series.
  void extend();
  /// gamma(y) = dy/dxi in closed form (y in rad, xi in N s / (m/s)).
  double gammaAt(double y) const;

  Eigen::Vector2d s_star_, s_perp_;  ///< s at theta*, and s rotated by +90 degrees
  /// The flow's constants and the series' coefficients.
  using Series = StickSeries::Series;
  StickSeries co_;
};

}  // namespace collision_response::core
