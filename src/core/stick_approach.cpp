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
#include "collision_response/core/constants.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>

namespace collision_response::core {
namespace {

using collision_response::core::kPi;
constexpr double kInfinity = std::numeric_limits<double>::infinity();

// Complex arithmetic for radius(), without the library's general division (a call per use)
// and its hypot-based modulus: the values are far from overflow.
using Complex = std::complex<double>;
double modulus(const Complex& z) {
  return std::sqrt(std::norm(z));
}
Complex divide(const Complex& x, const Complex& y) {
  return x * std::conj(y) / std::norm(y);
}
/// The principal square root, each part from the larger of |z| +- Re z (no cancellation).
Complex squareRoot(const Complex& z) {
  const double r = modulus(z);
  if (r == 0.0) return Complex(0.0);
  if (z.real() >= 0.0) {
    const double re = std::sqrt(0.5 * (r + z.real()));
    return Complex(re, 0.5 * z.imag() / re);
  }
  const double im = std::copysign(std::sqrt(0.5 * (r - z.real())), z.imag());
  return Complex(0.5 * z.imag() / im, im);
}

/// Taylor coefficients of cos wy + sin wy (E1: w = 1, E2: w = 2): w^k (-1)^(k/2) / k! at even k
/// (the cosine's), w^k (-1)^((k-1)/2) / k! at odd k (the sine's).
struct TrigSumTable {
  double v[StickApproach::kMaxOrder + 2];
  constexpr explicit TrigSumTable(double frequency) : v() {
    double x = 1.0, power = 1.0;  // 1 / k!, w^k
    for (int k = 0; k < StickApproach::kMaxOrder + 2; ++k, power *= frequency) {
      if (k > 0) x /= k;
      v[k] = power * ((k / 2) % 2 ? -x : x);
    }
  }
};
constexpr TrigSumTable kE1(1.0), kE2(2.0);
/// 1 / k (0 for k = 0): the recurrence multiplies by it rather than divide, since each order
/// waits for the one before.
struct InverseTable {
  double v[StickApproach::kMaxOrder + 1];
  constexpr InverseTable() : v() {
    for (int k = 1; k <= StickApproach::kMaxOrder; ++k) v[k] = 1.0 / k;
  }
};
constexpr InverseTable kInverse;

/// Horner sum of c[0..n] at y.
template <class Array>
double sum(const Array& c, int n, double y) {
  double v = c[n];
  for (int k = n - 1; k >= 0; --k) v = v * y + c[k];
  return v;
}

/// s rotated by the angle a (|a| <= pi/8) with sin and cos from their Taylor series (error below
/// 1e-16 there, and no library call; the rotation keeps |s| to round-off).
Eigen::Vector2d rotated(const Eigen::Vector2d& s, double a) {
  const double a2 = a * a;
  const double sn =
      a * (1 - a2 / 6 * (1 - a2 / 20 * (1 - a2 / 42 * (1 - a2 / 72 * (1 - a2 / 110)))));
  const double cs = 1 - a2 / 2 * (1 - a2 / 12 * (1 - a2 / 30 * (1 - a2 / 56 * (1 - a2 / 90))));
  return Eigen::Vector2d(cs * s.x() - sn * s.y(), sn * s.x() + cs * s.y());
}

/// A value with its derivative in mu_d (forward mode), for the sums of
/// StickApproach::muDerivatives().
struct Dual {
  double v = 0.0, d = 0.0;
  Dual(double value = 0.0, double derivative = 0.0) : v(value), d(derivative) {}  // NOLINT
};
inline Dual operator+(const Dual& a, const Dual& b) {
  return {a.v + b.v, a.d + b.d};
}
inline Dual operator-(const Dual& a) {
  return {-a.v, -a.d};
}
inline Dual operator*(const Dual& a, const Dual& b) {
  return {a.v * b.v, a.d * b.v + a.v * b.d};
}
inline Dual operator*(double a, const Dual& b) {
  return {a * b.v, a * b.d};
}
inline Dual operator/(const Dual& a, const Dual& b) {
  const double q = a.v / b.v;
  return {q, (a.d - q * b.d) / b.v};
}

void extendSeries(StickSeries& co) {
  const int k = ++co.order;
  if (k == 0) {
    // Gamma_0 = gamma'(0) and f_0 = f(0): m = f_0 / Gamma_0 (and H_0 = -1 / Gamma_0 below).
    const double gamma0 = co.gamma_s1 + 2.0 * co.gamma_s2;
    co.inverse_gamma0 = 1.0 / gamma0;
    co.m = (co.fb_star - co.mu * co.a_ss) / gamma0;
  }
  // The weights of the sums' coefficients, first: their divisions then run alongside the pass
  // below instead of holding up the next order.
  const double w = 1.0 / (co.m + k), w_work = 1.0 / (2.0 * co.m + k);
  // The recurrence, from y Gamma H' = H phi with phi = f - m Gamma - y Gamma' and Gamma = gamma/y:
  //   (H f)_k = (m + k) (H Gamma)_k = (m + k) (H gamma)_(k+1),
  // whose H_k terms give k Gamma_0 H_k = [(H f)_k - (m + k) (H gamma)_(k+1)] over j < k. f and
  // gamma are combinations of cos y, sin y, cos 2y, sin 2y, so both sums are combinations of four
  // convolutions of H with trig series, taken over j < k at the indices k and k + 1. Those at k
  // are the ones at k + 1 from the order before, plus its H_(k-1) term; those at k + 1 come from
  // one pass over j < k, with E1 = cos + sin and E2 = cos 2y + sin 2y: their even orders are the
  // cosine's and their odd ones the sine's, so the parity of j says which a term belongs to.
  // (H cos y)_k, (H sin y)_k, (H cos 2y)_k, (H sin 2y)_k over j < k:
  double pc = 0.0, ps = 0.0, qc = 0.0, qs = 0.0;
  if (k > 0) {
    pc = co.next_c1;
    ps = co.next_s1 + co.H[k - 1];  // sin y's order 1
    qc = co.next_c2;
    qs = co.next_s2 + 2.0 * co.H[k - 1];  // sin 2y's order 1
  }
  // The pass over j < k: the convolutions with E1 and E2 at k + 1, and (D H)_k without its j = 0
  // and j = k terms, two terms a step (j, then j - 1 of the other parity) in six independent sums
  // that the processor overlaps.
  co.H[k] = 0.0;  // the step at j = 1 reads D_0 H_k: that term is added below
  double c1 = 0.0, s1 = 0.0, c2 = 0.0, s2 = 0.0, dh_a = 0.0, dh_b = 0.0;
  int j = k - 1;
  for (; j >= 1; j -= 2) {  // order k + 1 - j even (the cosines'), then odd for j - 1
    const int i = k + 1 - j;
    c1 += co.H[j] * kE1.v[i];
    c2 += co.H[j] * kE2.v[i];
    dh_a += co.D[j] * co.H[k - j];
    s1 += co.H[j - 1] * kE1.v[i + 1];
    s2 += co.H[j - 1] * kE2.v[i + 1];
    dh_b += co.D[j - 1] * co.H[k - j + 1];
  }
  if (j == 0) {
    c1 += co.H[0] * kE1.v[k + 1];
    c2 += co.H[0] * kE2.v[k + 1];
  }
  co.next_c1 = c1;
  co.next_s1 = s1;
  co.next_c2 = c2;
  co.next_s2 = s2;
  if (k == 0) {
    co.H[0] = -co.inverse_gamma0;
  } else {
    const double hf = co.fb_star * pc + co.eps * co.fb_perp * ps -
                      co.mu * (0.5 * (co.a_ss - co.a_pp) * qc + co.eps * co.a_sp * qs);
    const double hgamma = co.gamma_c1 * c1 + co.gamma_s1 * s1 + co.gamma_c2 * c2 + co.gamma_s2 * s2;
    co.H[k] = (hf - (co.m + k) * hgamma) * (kInverse.v[k] * co.inverse_gamma0);
  }
  co.Pc[k] = pc;
  co.Ps[k] = ps;
  co.Qc[k] = qc;
  co.Qs[k] = qs;
  co.Ip[k] = co.H[k] * w;
  co.Ic[k] = (pc + co.H[k]) * w;  // cos y's order 0
  co.Is[k] = ps * w;
  co.D[k] = co.c * co.Ip[k] - co.mu * (co.fb_star * co.Ic[k] + co.eps * co.fb_perp * co.Is[k]);
  const double d_h = dh_a + dh_b + co.D[0] * co.H[k] + (k > 0 ? co.D[k] * co.H[0] : 0.0);
  co.DH2[k] = d_h * w_work;
}

}  // namespace

bool StickApproach::build(const Eigen::Matrix2d& A, const Eigen::Vector2d& b, double c, double mu_d,
                          const Eigen::Vector2d& s0) {
  co_.order = -1;
  if (!(mu_d > 0.0) || !(c > mu_d * b.norm())) return false;
  // g = s_perp . (b - mu A s) and dg/dtheta at direction s; the slip direction turns towards the
  // first zero of g ahead of it, in the direction of g's sign.
  const auto g = [&](const Eigen::Vector2d& s, double& dg) {
    const Eigen::Vector2d sp(-s.y(), s.x());
    dg = -s.dot(b) - mu_d * (sp.dot(A * sp) - s.dot(A * s));
    return sp.dot(b) - mu_d * sp.dot(A * s);
  };
  double dg;
  const double g0 = g(s0, dg);
  if (g0 == 0.0) return false;  // already along a fixed direction: the linear closed form
  const double dir = g0 > 0.0 ? 1.0 : -1.0;
  // Bracket the zero by steps of pi/16 up to a quarter turn (beyond, the series could not reach
  // the start anyway: another zero of g lies within a half turn of theta*).
  constexpr int kSteps = 8;
  constexpr double kStep = kPi / 16;
  Eigen::Vector2d s_lo = s0;
  bool found = false;
  const double c_step = std::cos(kStep), s_step = dir * std::sin(kStep);
  for (int i = 1; i <= kSteps && !found; ++i) {
    const Eigen::Vector2d s_hi(c_step * s_lo.x() - s_step * s_lo.y(),
                               s_step * s_lo.x() + c_step * s_lo.y());
    if (dir * g(s_hi, dg) <= 0.0) {
      found = true;
    } else {
      s_lo = s_hi;
    }
  }
  if (!found) return false;
  // Newton on g in the angle t past s_lo, safeguarded by bisection: g(t = lo) has g0's sign,
  // g(t = hi) the other (or is 0).
  double lo = 0.0, hi = kStep, t = 0.5 * kStep;
  Eigen::Vector2d s = rotated(s_lo, dir * t);
  for (int i = 0; i < 100; ++i) {
    const double v = g(s, dg);
    if (dir * v > 0.0) {
      lo = t;
    } else {
      hi = t;
    }
    double next = dg != 0.0 ? t - dir * v / dg : 0.5 * (lo + hi);
    bool newton = true;
    if (!(next > lo && next < hi)) {
      next = 0.5 * (lo + hi);
      newton = false;
    }
    // Newton converges quadratically: after a step below 1e-8 rad the error is of order 1e-16
    // times g''/g' (order 1), so that step is the last one needed.
    const bool done = std::abs(next - t) <= (newton ? 1e-8 : 1e-15);
    s = rotated(s, dir * (next - t));
    t = next;
    if (done) break;
  }
  s /= s.norm();
  g(s, dg);
  s_star_ = s;
  s_perp_ = Eigen::Vector2d(-s_star_.y(), s_star_.x());
  co_.eps = -dir;  // the start lies behind theta* in the direction of turning
  co_.mu = mu_d;
  co_.c = c;
  co_.fb_star = b.dot(s_star_);
  co_.fb_perp = b.dot(s_perp_);
  co_.a_ss = s_star_.dot(A * s_star_);
  co_.a_sp = s_star_.dot(A * s_perp_);
  co_.a_pp = s_perp_.dot(A * s_perp_);
  co_.gamma_c1 = co_.eps * co_.fb_perp;
  co_.gamma_s1 = -co_.fb_star;
  co_.gamma_c2 = -co_.mu * co_.eps * co_.a_sp;
  co_.gamma_s2 = -0.5 * co_.mu * (co_.a_pp - co_.a_ss);
  const double f_star = co_.fb_star - co_.mu * co_.a_ss;
  // Attracting (g' < 0) and slowing the slip (f < 0): the slip stops along s*.
  if (!(dg < 0.0) || !(f_star < 0.0)) return false;
  extend();  // order 0: m, H_0
  return true;
}

double StickApproach::distance(const Eigen::Vector2d& s) const {
  const double cross = s_star_.x() * s.y() - s_star_.y() * s.x();
  const double y = co_.eps * std::atan2(cross, s_star_.dot(s));
  return y >= 0.0 ? y : (y > -1e-13 ? 0.0 : -1.0);
}

double StickApproach::gammaAt(double y) const {
  return co_.gamma_c1 * std::cos(y) + co_.gamma_s1 * std::sin(y) + co_.gamma_c2 * std::cos(2 * y) +
         co_.gamma_s2 * std::sin(2 * y);
}

double StickApproach::radius() const {
  // With z = e^(iy), 2 z^2 gamma is the quartic a z^4 + b z^3 + conj(b) z + conj(a),
  // a = co_.gamma_c2 - i co_.gamma_s2, b = co_.gamma_c1 - i co_.gamma_s1, and z = 1 (theta*) a root
  // (co_.gamma_c1 + co_.gamma_c2 = gamma(0) = 0). Dividing it out leaves the cubic
  //   a z^3 + (a + b) z^2 + (a + b) z + (a + b + conj(b)),
  // whose roots z give y = arg z - i ln|z|, at distance |y| = sqrt(arg^2 z + ln^2 |z|) from
  // theta* (arg in (-pi, pi]: the nearest of the 2 pi images). Called once per slip, so the
  // complex arithmetic is spelled out (no library complex division, power or hypot).
  const Complex a(co_.gamma_c2, -co_.gamma_s2), b(co_.gamma_c1, -co_.gamma_s1);
  const Complex q[4] = {a + b + std::conj(b), a + b, a + b, a};  // q[k]: coefficient of z^k
  const double scale = modulus(q[0]) + modulus(q[1]) + modulus(q[3]);
  Complex roots[3];
  int count = 0;
  if (modulus(q[3]) <= 1e-9 * scale) {
    // a ~ 0 (nearly isotropic K_tt, or no friction term): the third root runs off to infinity
    // (y to -i infinity, no singularity); the other two are the quadratic's.
    if (modulus(q[2]) <= 1e-9 * scale) return kInfinity;
    const Complex d = squareRoot(q[1] * q[1] - 4.0 * q[2] * q[0]);
    const Complex big = -0.5 * (q[1] + (std::real(std::conj(q[1]) * d) >= 0.0 ? d : -d));
    roots[count++] = divide(big, q[2]);
    if (std::norm(big) > 0.0) roots[count++] = divide(q[0], big);
  } else {
    // Cardano on the monic cubic z^3 + B z^2 + C z + D, with z = t - B / 3: t^3 + P t + Q = 0.
    const Complex inverse = divide(Complex(1.0), q[3]);
    const Complex B = q[2] * inverse, C = q[1] * inverse, D = q[0] * inverse;
    const Complex P = C - B * B / 3.0;
    const Complex Q = 2.0 * B * B * B / 27.0 - B * C / 3.0 + D;
    const Complex s = squareRoot(0.25 * Q * Q + P * P * P / 27.0);
    const Complex w1 = -0.5 * Q + s, w2 = -0.5 * Q - s;
    const Complex w = std::norm(w1) >= std::norm(w2) ? w1 : w2;
    const double angle = std::atan2(w.imag(), w.real()) / 3.0;
    const double length = std::cbrt(modulus(w));
    const Complex omega(-0.5, 0.5 * std::sqrt(3.0));
    Complex r(length * std::cos(angle), length * std::sin(angle));
    for (int k = 0; k < 3; ++k, r = r * omega) {
      roots[count++] = (std::norm(r) > 0.0 ? r - divide(P, 3.0 * r) : Complex(0.0)) - B / 3.0;
    }
  }
  double nearest = kInfinity;
  for (int k = 0; k < count; ++k) {
    Complex z = roots[k];
    // One Newton step on the cubic itself, against Cardano's cancellation.
    const Complex value = ((q[3] * z + q[2]) * z + q[1]) * z + q[0];
    const Complex slope = (3.0 * q[3] * z + 2.0 * q[2]) * z + q[1];
    if (std::norm(slope) > 0.0) z -= divide(value, slope);
    const double norm = std::norm(z);
    if (!(norm > 0.0) || !std::isfinite(norm)) continue;
    const double angle = std::atan2(z.imag(), z.real()), log_modulus = 0.5 * std::log(norm);
    nearest = std::min(nearest, std::sqrt(angle * angle + log_modulus * log_modulus));
  }
  return nearest;
}

void StickApproach::extend() {
  extendSeries(co_);
}

bool StickApproach::converged(double y, double relative_impulse, double relative_work) {
  if (co_.order < 0) return false;
  if (y == 0.0) return true;
  while (co_.order < 3) extend();
  // Terms at y: tp[k] the largest of the impulse series', tw[k] the work series'. They are judged
  // against the sums themselves (partial sums so far), not the leading terms: with alternating
  // coefficients a sum can be much smaller than its terms, and the share is of the sum.
  Series tp, tw;
  double power = 1.0, sum_p = 0.0, sum_w = 0.0;
  const auto term = [&](int k) {
    tp[k] =
        std::max(std::max(std::abs(co_.Ip[k]), std::abs(co_.Ic[k])), std::abs(co_.Is[k])) * power;
    tw[k] = std::abs(co_.DH2[k]) * power;
    sum_p += co_.Ip[k] * power;
    sum_w += co_.DH2[k] * power;
    power *= y;
  };
  for (int k = 0; k <= co_.order; ++k) term(k);
  // Geometric decay: the last four terms below the share of the tolerance, and falling at least
  // twofold over four orders (then the rest sums to less than they do; four, not two, so that
  // coefficients that oscillate, from complex singularities, cannot pass by a chance small pair).
  for (;;) {
    const int k = co_.order;
    // The tests below normalise by the sums (two divisions); most orders need none of them: the
    // acceptance needs each of its two parts below half the share, which multiplications tell,
    // and the give-ups look only every fourth order.
    const double four_p = tp[k] + tp[k - 1] + tp[k - 2] + tp[k - 3];
    const double four_w = tw[k] + tw[k - 1] + tw[k - 2] + tw[k - 3];
    const bool may_accept = four_p <= 0.5 * std::abs(sum_p) * relative_impulse &&
                            four_w <= 0.5 * std::abs(sum_w) * relative_work;
    if (may_accept || k % 4 == 0) {
      const double np = 1.0 / (std::abs(sum_p) * relative_impulse);
      const double nw = 1.0 / (std::abs(sum_w) * relative_work);
      const auto four = [&](int top) {  // normalised terms top - 3 .. top
        return (tp[top] + tp[top - 1] + tp[top - 2] + tp[top - 3]) * np +
               (tw[top] + tw[top - 1] + tw[top - 2] + tw[top - 3]) * nw;
      };
      const double last = four(k);
      const double earlier = k >= 7 ? four(k - 4) : kInfinity;
      if (last <= 0.5 && last <= 0.5 * earlier) return true;
      if (k >= kMaxOrder) return false;
      // Give up early where extending would be wasted: terms growing (y beyond the radius of
      // convergence), or a decay over the last 8 orders, r per order, too slow to reach the
      // tolerance by kMaxOrder even if it doubles its pace (the decay quickens with the order as
      // the algebraic factors of the singularities fade).
      if (k >= 12 && k % 4 == 0 && !(last < earlier)) return false;
      if (k >= 16 && k % 8 == 0 && last > 1.0) {
        const double r8 = last / four(k - 8);
        if (!(r8 < 1.0) || k + 4.0 * -std::log(last) / std::log(r8) > kMaxOrder) return false;
      }
    } else if (k >= kMaxOrder) {
      return false;
    }
    extend();
    term(co_.order);
  }
}

StickApproach::MuDerivatives StickApproach::muDerivatives(double y, double sigma) {
  // With A and b fixed, mu_d moves theta* (g(theta*) = s*_perp . (b - mu_d A s*) = 0):
  // dtheta*/dmu_d = -(dg/dmu_d) / g'(theta*) = a_sp / Gamma(0), which turns s* and s*_perp and so
  // the flow's constants: d(b.s*) = (b.s*_perp) dtheta*, d(b.s*_perp) = -(b.s*) dtheta*,
  // d a_ss = 2 a_sp dtheta*, d a_sp = (a_pp - a_ss) dtheta*, d a_pp = -2 a_sp dtheta*. The
  // recurrence of extend() is differentiated term by term (a d in front: the mu_d derivative),
  // reading the values it stored; two orders beyond those converged() asked for, and the values
  // one further (the trig sums at k + 1 of order k are those at order k + 1).
  const int top = std::min(kMaxOrder - 1, co_.order);
  while (co_.order < top + 1) extend();
  const StickSeries& v = co_;
  const double ig0 = v.inverse_gamma0;
  const double dtheta = v.a_sp * ig0;
  const double dfs = v.fb_perp * dtheta, dfp = -v.fb_star * dtheta;
  const double dss = 2.0 * v.a_sp * dtheta, dsp = (v.a_pp - v.a_ss) * dtheta,
               dpp = -2.0 * v.a_sp * dtheta;
  const double dgc1 = v.eps * dfp, dgs1 = -dfs, dgc2 = -v.eps * (v.a_sp + v.mu * dsp),
               dgs2 = -0.5 * ((v.a_pp - v.a_ss) + v.mu * (dpp - dss));
  const double dgamma0 = dgs1 + 2.0 * dgs2;
  const double dig0 = -ig0 * ig0 * dgamma0;
  // m = (b.s* - mu a_ss) / Gamma(0)
  const double dm = (dfs - v.a_ss - v.mu * dss - v.m * dgamma0) * ig0;
  Series dH, dIp, dDH2, dD;
  double next_c1 = 0.0, next_s1 = 0.0, next_c2 = 0.0, next_s2 = 0.0;
  for (int k = 0; k <= top; ++k) {
    const double w = 1.0 / (v.m + k), w_work = 1.0 / (2.0 * v.m + k);
    const double dw = -w * w * dm, dw_work = -2.0 * w_work * w_work * dm;
    double dpc = 0.0, dps = 0.0, dqc = 0.0, dqs = 0.0;
    if (k > 0) {
      dpc = next_c1;
      dps = next_s1 + dH[k - 1];
      dqc = next_c2;
      dqs = next_s2 + 2.0 * dH[k - 1];
    }
    // The pass over j < k, as extend()'s: the trig sums at k + 1, and d(D H)_k over 0 < j < k
    // (its j = 0 and j = k terms need dH_k and dD_k, added below), two terms a step.
    double c1 = 0.0, s1 = 0.0, c2 = 0.0, s2 = 0.0, dh_a = 0.0, dh_b = 0.0;
    int j = k - 1;
    for (; j >= 2; j -= 2) {
      const int i = k + 1 - j;
      c1 += dH[j] * kE1.v[i];
      c2 += dH[j] * kE2.v[i];
      dh_a += dD[j] * v.H[k - j] + v.D[j] * dH[k - j];
      s1 += dH[j - 1] * kE1.v[i + 1];
      s2 += dH[j - 1] * kE2.v[i + 1];
      dh_b += dD[j - 1] * v.H[k - j + 1] + v.D[j - 1] * dH[k - j + 1];
    }
    if (j == 1) {
      c1 += dH[1] * kE1.v[k];
      c2 += dH[1] * kE2.v[k];
      dh_a += dD[1] * v.H[k - 1] + v.D[1] * dH[k - 1];
      s1 += dH[0] * kE1.v[k + 1];
      s2 += dH[0] * kE2.v[k + 1];
    } else if (j == 0) {
      c1 += dH[0] * kE1.v[k + 1];
      c2 += dH[0] * kE2.v[k + 1];
    }
    next_c1 = c1;
    next_s1 = s1;
    next_c2 = c2;
    next_s2 = s2;
    if (k == 0) {
      dH[0] = -dig0;
    } else {
      const double pc = v.Pc[k], ps = v.Ps[k], qc = v.Qc[k], qs = v.Qs[k];
      // The trig sums at k + 1 of this order (values).
      const double vc1 = v.Pc[k + 1], vs1 = v.Ps[k + 1] - v.H[k], vc2 = v.Qc[k + 1],
                   vs2 = v.Qs[k + 1] - 2.0 * v.H[k];
      const double dhf = dfs * pc + v.fb_star * dpc + v.eps * (dfp * ps + v.fb_perp * dps) -
                         (0.5 * (v.a_ss - v.a_pp) * qc + v.eps * v.a_sp * qs) -
                         v.mu * (0.5 * (dss - dpp) * qc + 0.5 * (v.a_ss - v.a_pp) * dqc +
                                 v.eps * (dsp * qs + v.a_sp * dqs));
      const double hgamma =
          v.gamma_c1 * vc1 + v.gamma_s1 * vs1 + v.gamma_c2 * vc2 + v.gamma_s2 * vs2;
      const double dhgamma = dgc1 * vc1 + v.gamma_c1 * c1 + dgs1 * vs1 + v.gamma_s1 * s1 +
                             dgc2 * vc2 + v.gamma_c2 * c2 + dgs2 * vs2 + v.gamma_s2 * s2;
      dH[k] =
          (dhf - dm * hgamma - (v.m + k) * dhgamma) * (kInverse.v[k] * ig0) + v.H[k] * dig0 / ig0;
    }
    dIp[k] = dH[k] * w + v.H[k] * dw;
    const double dIc = (dpc + dH[k]) * w + (v.Pc[k] + v.H[k]) * dw;
    const double dIs = dps * w + v.Ps[k] * dw;
    dD[k] = v.c * dIp[k] - (v.fb_star * v.Ic[k] + v.eps * v.fb_perp * v.Is[k]) -
            v.mu * (dfs * v.Ic[k] + v.fb_star * dIc + v.eps * (dfp * v.Is[k] + v.fb_perp * dIs));
    double dDH = dh_a + dh_b + dD[0] * v.H[k] + v.D[0] * dH[k];
    if (k > 0) dDH += dD[k] * v.H[0] + v.D[k] * dH[0];
    dDH2[k] = dDH * w_work + v.DH2[k] * (2.0 * v.m + k) * dw_work;
  }
  // The slip held fixed: y = eps (theta - theta*) moves by -eps dtheta*. The remaining quantities
  // at y (remaining()): p_rem = sigma e^-S Ip(y), work_drop = (sigma e^-S)^2 DH2(y), with
  // e^S = -H(y) Gamma(y) = -H(y) gamma(y) / y.
  const Dual yd(y, -v.eps * dtheta);
  Dual ip(v.Ip[top], dIp[top]), dh2(v.DH2[top], dDH2[top]), h(v.H[top], dH[top]);
  for (int k = top - 1; k >= 0; --k) {
    ip = ip * yd + Dual(v.Ip[k], dIp[k]);
    dh2 = dh2 * yd + Dual(v.DH2[k], dDH2[k]);
    h = h * yd + Dual(v.H[k], dH[k]);
  }
  const double c1 = std::cos(y), s1 = std::sin(y), c2 = std::cos(2.0 * y), s2 = std::sin(2.0 * y);
  const double gamma = v.gamma_c1 * c1 + v.gamma_s1 * s1 + v.gamma_c2 * c2 + v.gamma_s2 * s2;
  const double dgamma =
      dgc1 * c1 + dgs1 * s1 + dgc2 * c2 + dgs2 * s2 +
      yd.d * (-v.gamma_c1 * s1 + v.gamma_s1 * c1 - 2.0 * v.gamma_c2 * s2 + 2.0 * v.gamma_s2 * c2);
  const Dual scale = (sigma * yd) / -(h * Dual(gamma, dgamma));
  MuDerivatives out;
  out.p = (scale * ip).d;
  out.work_drop = (scale * scale * dh2).d;
  return out;
}

double StickApproach::logScale(double y, double sigma) const {
  // e^S = -H Gamma, with Gamma(y) = gamma(y) / y in closed form.
  if (y <= 0.0) return std::log(sigma);
  return std::log(sigma) - std::log(-sum(co_.H, co_.order, y) * gammaAt(y) / y);
}

StickApproach::Remaining StickApproach::remaining(double y, double log_scale) const {
  Remaining out;
  out.direction = s_star_ * std::cos(y) + co_.eps * s_perp_ * std::sin(y);
  if (y <= 0.0) return out;
  const double scale = std::exp(log_scale);
  // The five sums by Horner's rule in one loop (five independent chains the processor overlaps).
  double ip = co_.Ip[co_.order], ic = co_.Ic[co_.order], is = co_.Is[co_.order],
         dh2 = co_.DH2[co_.order], h = co_.H[co_.order];
  for (int k = co_.order - 1; k >= 0; --k) {
    ip = ip * y + co_.Ip[k];
    ic = ic * y + co_.Ic[k];
    is = is * y + co_.Is[k];
    dh2 = dh2 * y + co_.DH2[k];
    h = h * y + co_.H[k];
  }
  out.p = scale * ip;
  out.P_t = -co_.mu * scale * (s_star_ * ic + co_.eps * s_perp_ * is);
  out.u_n_rise = scale * (co_.c * ip - co_.mu * (co_.fb_star * ic + co_.eps * co_.fb_perp * is));
  out.work_drop = scale * scale * dh2;
  out.rate = scale * h / y;
  return out;
}

}  // namespace collision_response::core
