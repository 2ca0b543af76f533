// Rotating slip settling into stick as power series in the slip angle (docs/physics.md, "Approach
// to stick in closed form"). Symbols as in stick_approach.h; y = |theta - theta*|, theta =
// theta* + eps y, and the Taylor coefficients in y of
//   f(y)     = s.F(s)                       (dln sigma / dxi)
//   gamma(y) = eps s_perp.F(s) = Gamma(y) y  (dy / dxi, Gamma(0) = g'(theta*) < 0)
// follow from s(y) = s* cos y + eps s*_perp sin y, with A's and b's components along s*, s*_perp:
//   f     = (b.s*) cos y + eps (b.s*_perp) sin y
//           - mu [(a_ss + a_pp)/2 + (a_ss - a_pp)/2 cos 2y + eps a_sp sin 2y]
//   gamma = eps (b.s*_perp) cos y - (b.s*) sin y - mu [eps a_sp cos 2y + (a_pp - a_ss)/2 sin 2y].
// Then dln sigma/dy = f / gamma = m / y + Q(y) with R = f / Gamma = m + y Q, S = integral of Q,
// sigma(y) = K y^m e^S(y), and dp/dy = sigma / gamma, so that the impulse still to come from y,
//   p_rem(y) = K integral_0^y t^(m-1) H(t) dt,  H = -e^S / Gamma,
// is K y^m times Ip(y) = sum H_k y^k / (m + k). P_t and the work follow the same way.
#include "collision_response/core/stick_approach.h"

#include <algorithm>
#include <cmath>

namespace collision_response::core {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// Taylor coefficients of cos y and sin y, (-1)^(k/2) / k! and (-1)^((k-1)/2) / k!, interleaved:
/// trig[k] is cos's for even k and sin's for odd k (the other is zero).
struct TrigTable {
  double v[StickApproach::kMaxOrder + 2];
  constexpr TrigTable() : v() {
    double x = 1.0;
    for (int k = 0; k < StickApproach::kMaxOrder + 2; ++k) {
      if (k > 0) x /= k;
      v[k] = (k / 2) % 2 ? -x : x;
    }
  }
};
constexpr TrigTable kTrig;
double cosCoef(int k) {
  return k % 2 ? 0.0 : kTrig.v[k];
}
double sinCoef(int k) {
  return k % 2 ? kTrig.v[k] : 0.0;
}

/// Horner sum of c[0..n] at y.
template <class Array>
double sum(const Array& c, int n, double y) {
  double v = c[n];
  for (int k = n - 1; k >= 0; --k) v = v * y + c[k];
  return v;
}

}  // namespace

bool StickApproach::build(const Eigen::Matrix2d& A, const Eigen::Vector2d& b, double c, double mu_d,
                          const Eigen::Vector2d& s0) {
  order_ = -1;
  if (!(mu_d > 0.0) || !(c > mu_d * b.norm())) return false;
  // g(theta) = s_perp . (b - mu A s) and its derivative; the slip direction turns towards the
  // first zero of g ahead of it, in the direction of g's sign.
  const auto g = [&](double t, double& dg) {
    const Eigen::Vector2d s(std::cos(t), std::sin(t)), sp(-s.y(), s.x());
    dg = -s.dot(b) - mu_d * (sp.dot(A * sp) - s.dot(A * s));
    return sp.dot(b) - mu_d * sp.dot(A * s);
  };
  const double theta0 = std::atan2(s0.y(), s0.x());
  double dg;
  const double g0 = g(theta0, dg);
  if (g0 == 0.0) return false;  // already along a fixed direction: the linear closed form
  const double dir = g0 > 0.0 ? 1.0 : -1.0;
  // Bracket the zero by steps of pi/16 up to a quarter turn (beyond, the series could not reach
  // the start anyway: another zero of g lies within a half turn of theta*).
  constexpr int kSteps = 8;
  double lo = theta0, hi = theta0;
  bool found = false;
  for (int i = 1; i <= kSteps && !found; ++i) {
    hi = theta0 + dir * i * (kPi / 16);
    if (dir * g(hi, dg) <= 0.0) {
      found = true;
    } else {
      lo = hi;
    }
  }
  if (!found) return false;
  // Newton on g, safeguarded by bisection; g(lo) has g0's sign, g(hi) the other (or is 0).
  double t = 0.5 * (lo + hi);
  for (int i = 0; i < 100; ++i) {
    const double v = g(t, dg);
    if (dir * v > 0.0) {
      lo = t;
    } else {
      hi = t;
    }
    double next = dg != 0.0 ? t - v / dg : 0.5 * (lo + hi);
    if (!((next - lo) * (next - hi) < 0.0)) next = 0.5 * (lo + hi);
    const bool done = std::abs(next - t) <= 1e-15 * (1.0 + std::abs(t));
    t = next;
    if (done) break;
  }
  g(t, dg);
  const double theta_star = t;
  s_star_ = Eigen::Vector2d(std::cos(theta_star), std::sin(theta_star));
  s_perp_ = Eigen::Vector2d(-s_star_.y(), s_star_.x());
  eps_ = -dir;  // the start lies behind theta* in the direction of turning
  mu_ = mu_d;
  c_ = c;
  fb_star_ = b.dot(s_star_);
  fb_perp_ = b.dot(s_perp_);
  a_ss_ = s_star_.dot(A * s_star_);
  a_sp_ = s_star_.dot(A * s_perp_);
  a_pp_ = s_perp_.dot(A * s_perp_);
  const double f_star = fb_star_ - mu_ * a_ss_;
  // Attracting (g' < 0) and slowing the slip (f < 0): the slip stops along s*.
  if (!(dg < 0.0) || !(f_star < 0.0)) return false;
  extend();  // order 0: m, H_0
  return true;
}

double StickApproach::distance(const Eigen::Vector2d& s) const {
  const double cross = s_star_.x() * s.y() - s_star_.y() * s.x();
  const double y = eps_ * std::atan2(cross, s_star_.dot(s));
  return y >= 0.0 ? y : (y > -1e-13 ? 0.0 : -1.0);
}

double StickApproach::gammaAt(double y) const {
  return eps_ * fb_perp_ * std::cos(y) - fb_star_ * std::sin(y) -
         mu_ * (eps_ * a_sp_ * std::cos(2 * y) + 0.5 * (a_pp_ - a_ss_) * std::sin(2 * y));
}

void StickApproach::extend() {
  const int k = ++order_;
  const double ck = cosCoef(k + 1), sk = sinCoef(k + 1);
  const double c2 = std::ldexp(ck, k + 1), s2 = std::ldexp(sk, k + 1);
  Gamma_[k] =
      eps_ * fb_perp_ * ck - fb_star_ * sk - mu_ * (eps_ * a_sp_ * c2 + 0.5 * (a_pp_ - a_ss_) * s2);
  if (k == 0) {
    const double f0 = fb_star_ - mu_ * a_ss_;
    m_ = f0 / Gamma_[0];
    phi_[0] = 0.0;
    H_[0] = -1.0 / Gamma_[0];
  } else {
    const double fc = cosCoef(k), fs = sinCoef(k);
    const double f_k =
        fb_star_ * fc + eps_ * fb_perp_ * fs -
        mu_ * (0.5 * (a_ss_ - a_pp_) * std::ldexp(fc, k) + eps_ * a_sp_ * std::ldexp(fs, k));
    phi_[k] = f_k - (m_ + k) * Gamma_[k];
    // y Gamma H' = H phi, order k (phi_0 = 0): k Gamma_0 H_k = sum_j<k H_j (phi_k-j - j Gamma_k-j).
    double h0 = 0.0, h1 = 0.0;
    int j = 0;
    for (; j + 1 < k; j += 2) {
      h0 += H_[j] * (phi_[k - j] - j * Gamma_[k - j]);
      h1 += H_[j + 1] * (phi_[k - j - 1] - (j + 1) * Gamma_[k - j - 1]);
    }
    if (j < k) h0 += H_[j] * (phi_[k - j] - j * Gamma_[k - j]);
    H_[k] = (h0 + h1) / (k * Gamma_[0]);
  }
  // H cos y and H sin y: kTrig holds cos's even and sin's odd coefficients.
  double hc = 0.0, hs = 0.0;
  for (int i = 0; i <= k; i += 2) hc += H_[k - i] * kTrig.v[i];
  for (int i = 1; i <= k; i += 2) hs += H_[k - i] * kTrig.v[i];
  const double w = 1.0 / (m_ + k);
  Ip_[k] = H_[k] * w;
  Ic_[k] = hc * w;
  Is_[k] = hs * w;
  D_[k] = c_ * Ip_[k] - mu_ * (fb_star_ * Ic_[k] + eps_ * fb_perp_ * Is_[k]);
  double d0 = 0.0, d1 = 0.0;
  int j = 0;
  for (; j + 1 <= k; j += 2) {
    d0 += D_[j] * H_[k - j];
    d1 += D_[j + 1] * H_[k - j - 1];
  }
  if (j == k) d0 += D_[k] * H_[0];
  DH2_[k] = (d0 + d1) / (2.0 * m_ + k);
}

bool StickApproach::converged(double y, double relative) {
  if (order_ < 0) return false;
  if (y == 0.0) return true;
  while (order_ < 3) extend();
  const double scale_p = 1.0 / std::abs(Ip_[0]), scale_w = 1.0 / std::abs(DH2_[0]);
  // Terms relative to the leading ones, at y: t[k] = max over the series of |c_k| y^k / |c_0|.
  Series t;
  double power = 1.0;
  const auto term = [&](int k) {
    t[k] = (std::max({std::abs(Ip_[k]), std::abs(Ic_[k]), std::abs(Is_[k])}) * scale_p +
            std::abs(DH2_[k]) * scale_w) *
           power;
    power *= y;
  };
  for (int k = 0; k <= order_; ++k) term(k);
  // Geometric decay: the last two terms below the share of the tolerance, and falling at least
  // twofold over two orders (then the rest sums to less than they do).
  for (;;) {
    const int k = order_;
    const double pair = t[k] + t[k - 1], before = t[k - 2] + t[k - 3];
    if (pair <= 0.5 * relative && pair <= 0.5 * before) return true;
    if (k >= kMaxOrder) return false;
    if (k >= 12) {
      // Give up as soon as the decay so far (ratio r per order) cannot reach the tolerance
      // within kMaxOrder: extending further would be wasted.
      const double r2 = pair / before;
      if (!(r2 < 1.0) ||
          (pair > relative && k + std::log(relative / pair) / (0.5 * std::log(r2)) > kMaxOrder))
        return false;
    }
    extend();
    term(order_);
  }
}

double StickApproach::logScale(double y, double sigma) const {
  // e^S = -H Gamma, with Gamma(y) = gamma(y) / y in closed form.
  if (y <= 0.0) return std::log(sigma);
  return std::log(sigma) - std::log(-sum(H_, order_, y) * gammaAt(y) / y);
}

StickApproach::Remaining StickApproach::remaining(double y, double log_scale) const {
  Remaining out;
  out.direction = s_star_ * std::cos(y) + eps_ * s_perp_ * std::sin(y);
  if (y <= 0.0) return out;
  const double scale = std::exp(log_scale);
  const double ip = sum(Ip_, order_, y), ic = sum(Ic_, order_, y), is = sum(Is_, order_, y);
  out.p = scale * ip;
  out.P_t = -mu_ * scale * (s_star_ * ic + eps_ * s_perp_ * is);
  out.u_n_rise = scale * (c_ * ip - mu_ * (fb_star_ * ic + eps_ * fb_perp_ * is));
  out.work_drop = scale * scale * sum(DH2_, order_, y);
  out.rate = scale * sum(H_, order_, y) / y;
  return out;
}

}  // namespace collision_response::core
