// The forward sensitivity of impulse_space_derivatives.cpp, included there twice: with kGradient 6
// (the slip's three components, e, mu_s, mu_d: differentiateImpulseSpace()) and 12 (also K's six
// entries in the contact frame: differentiateImpulseSpaceByK()), each inside a namespace of its
// own that defines kGradient. Not a header: no include guard, no inclusion elsewhere.

using Vec2 = Eigen::Vector2d;
using Mat2 = Eigen::Matrix2d;
using Grad = Eigen::Matrix<double, kGradient, 1>;

constexpr double kInf = std::numeric_limits<double>::infinity();
// Inputs (gradient entries).
constexpr int kUt1 = 0, kUt2 = 1, kUn = 2, kE = 3, kMuS = 4, kMuD = 5;
// With kGradient 12, K's entries in the contact frame (t1, t2, n): A = K_tt (A01 the symmetric
// pair), b = K_tn, c = K_nn.
constexpr int kA00 = 6, kA01 = 7, kA11 = 8, kB0 = 9, kB1 = 10, kC = 11;
constexpr bool kByK = kGradient == 12;
// The integrator's thresholds (impulse_space_integrator.cpp).
constexpr double kStickSpeed = 1e-14;
constexpr double kParallel = 1e-12;
constexpr std::size_t kMaxSegments = 16;
// The sensitivity integration: a slip below this fraction of |u0| has stopped (the remaining
// piece, about that slip over the slip's deceleration, is left to the sticking manifold).
constexpr double kStop = 1e-13;
// A slip below this fraction of |u0| that grows again from one step to the next has stopped (a near
// miss of its stop; the integrator's kNearMiss).
constexpr double kNearMiss = 1e-11;
constexpr std::size_t kMaxSteps = 20000;
// Distance (relative) below which the slip's stop and an event count as simultaneous (a switch).
constexpr double kNear = 1e-8;
// When the stick-approach series is tried: the integrator's kSeriesExponent and kSeriesReach.
constexpr double kSeriesExponent = 2.0;
constexpr double kSeriesReach = 0.5;

// A value with its gradient with respect to theta.
struct D {
  double v = 0.0;
  Grad d = Grad::Zero();
  D() = default;
  D(double value) : v(value) {}  // NOLINT: constants mix freely
  D(double value, const Grad& grad) : v(value), d(grad) {}
  static D input(double value, int k) {
    D out(value);
    out.d[k] = 1.0;
    return out;
  }
};
inline D operator+(const D& a, const D& b) {
  return {a.v + b.v, a.d + b.d};
}
inline D operator-(const D& a, const D& b) {
  return {a.v - b.v, a.d - b.d};
}
inline D operator-(const D& a) {
  return {-a.v, -a.d};
}
inline D operator*(const D& a, const D& b) {
  return {a.v * b.v, b.v * a.d + a.v * b.d};
}
inline D operator*(double a, const D& b) {
  return {a * b.v, a * b.d};
}
inline D operator/(const D& a, const D& b) {
  const double q = a.v / b.v;
  return {q, (a.d - q * b.d) / b.v};
}
inline D sqrt(const D& a) {
  const double s = std::sqrt(a.v);
  return {s, (0.5 / s) * a.d};
}

struct D2 {
  D x, y;
  Vec2 value() const { return {x.v, y.v}; }
};
inline D2 operator+(const D2& a, const D2& b) {
  return {a.x + b.x, a.y + b.y};
}
inline D2 operator-(const D2& a, const D2& b) {
  return {a.x - b.x, a.y - b.y};
}
inline D2 operator*(const D& k, const D2& a) {
  return {k * a.x, k * a.y};
}
inline D2 operator*(const D2& a, const D& k) {
  return {k * a.x, k * a.y};
}
inline D2 operator*(const Mat2& M, const D2& a) {
  return {M(0, 0) * a.x + M(0, 1) * a.y, M(1, 0) * a.x + M(1, 1) * a.y};
}
inline D2 constant(const Vec2& v) {
  return {D(v.x()), D(v.y())};
}
inline D dot(const Vec2& a, const D2& b) {
  return a.x() * b.x + a.y() * b.y;
}
inline D dot(const D2& a, const D2& b) {
  return a.x * b.x + a.y * b.y;
}

// The integrated state (p, P_t1, P_t2, W).
struct Y4 {
  D y[4];
};
inline Y4 operator+(const Y4& a, const Y4& b) {
  return {{a.y[0] + b.y[0], a.y[1] + b.y[1], a.y[2] + b.y[2], a.y[3] + b.y[3]}};
}
inline Y4 operator*(double h, const Y4& a) {
  return {{h * a.y[0], h * a.y[1], h * a.y[2], h * a.y[3]}};
}

struct Problem {
  Mat2 A, A_inv;
  Vec2 b;
  double c;
  // kByK: the same entries carrying their gradients (A's and A^-1's four, b's two, c); otherwise
  // c alone, as a constant.
  D a00, a01, a10, a11, i00, i01, i10, i11, c_d;
  D2 b_d;
  D2 u0_t;
  D u0_n, e, mu_s, mu_d;
  bool stronge;
  double J, V, V_n, tol;

  D2 timesA(const D2& x) const {
    if constexpr (kByK) {
      return {a00 * x.x + a01 * x.y, a10 * x.x + a11 * x.y};
    } else {
      return A * x;
    }
  }
  D2 timesAinv(const D2& x) const {
    if constexpr (kByK) {
      return {i00 * x.x + i01 * x.y, i10 * x.x + i11 * x.y};
    } else {
      return A_inv * x;
    }
  }
  D2 bVector() const {
    if constexpr (kByK) {
      return b_d;
    } else {
      return constant(b);
    }
  }
  // c + b . r
  D rise(const D2& r) const {
    if constexpr (kByK) {
      return c_d + dot(b_d, r);
    } else {
      return c + dot(b, r);
    }
  }
  D2 slip(const D& p, const D2& P_t) const { return u0_t + timesA(P_t) + p * bVector(); }
  D normal(const D& p, const D2& P_t) const {
    if constexpr (kByK) {
      return u0_n + dot(b_d, P_t) + c_d * p;
    } else {
      return u0_n + dot(b, P_t) + c * p;
    }
  }
};

struct State {
  D p;
  D2 P_t;
  D W;
  bool restitution = false, done = false;
  D p_c, W_c, p_end, W_end;
};

struct Context {
  const Problem& pr;
  State st;
  ContactDerivativeMode& mode;
  ImpulseSpaceSensitivityDetail& detail;
  bool sticking = false;
  void flag(const std::string& detail) {
    if (mode.switch_detail.find(detail) != std::string::npos) return;
    mode.at_switch = true;
    if (!mode.switch_detail.empty()) mode.switch_detail += "; ";
    mode.switch_detail += detail;
  }
};

// Maximum compression reached along the rate dP_t/dp = `rate`: the law's end condition. At e = 0
// the impact ends there; for increasing e it would go on along the same rate, by dx/de = p_c
// (Poisson) or sqrt(-2 W_c / h) (Stronge: W - W_c = h x^2 / 2 = -e^2 W_c), h = du_n/dp: the
// one-sided e column.
void beginRestitution(Context& cx, const D2& rate) {
  const Problem& pr = cx.pr;
  State& st = cx.st;
  st.restitution = true;
  st.p_c = st.p;
  st.W_c = st.W;
  st.p_end = (1.0 + pr.e) * st.p_c;
  st.W_end = (1.0 - pr.e * pr.e) * st.W_c;
  st.done = pr.stronge ? st.W.v >= st.W_end.v : st.p.v >= st.p_end.v;
  if (st.done && pr.e.v == 0.0) {
    const double h = pr.c + pr.b.dot(rate.value());
    const double dx_de = pr.stronge ? (h > 0.0 ? std::sqrt(-2.0 * st.W_c.v / h) : 0.0) : st.p_c.v;
    st.p.d[kE] += dx_de;
    st.P_t.x.d[kE] += rate.x.v * dx_de;
    st.P_t.y.d[kE] += rate.y.v * dx_de;
    cx.flag("e = 0: the restitution column is one-sided (increasing e)");
  }
}

// Smallest x >= 0 with D = u_n x + h x^2 / 2, or kInf (the integrator's strongeDistance()).
D strongeDistance(const D& Dw, const D& u_n, const D& h) {
  if (Dw.v <= 0.0) return D(0.0);
  const D disc = u_n * u_n + 2.0 * (h * Dw);
  if (disc.v < 0.0) return D(kInf);
  if (u_n.v >= 0.0) {
    const D den = u_n + sqrt(disc);
    return den.v > 0.0 ? 2.0 * Dw / den : D(kInf);
  }
  return h.v > 0.0 ? (sqrt(disc) - u_n) / h : D(kInf);
}

// Constant rates dP_t/dp = r for at most x_max in p, through the events on the way (the
// integrator's advanceLinear()). False on a jam.
bool advanceLinear(Context& cx, const D2& r, D x_max) {
  const Problem& pr = cx.pr;
  State& st = cx.st;
  const D h = pr.rise(r);
  while (!st.done) {
    const D u_n = pr.normal(st.p, st.P_t);
    D x;
    if (!st.restitution) {
      x = u_n.v >= 0.0 ? D(0.0) : (h.v > 0.0 ? -u_n / h : D(kInf));
    } else if (pr.stronge) {
      x = strongeDistance(st.W_end - st.W, u_n, h);
    } else {
      x = st.p_end.v - st.p.v > 0.0 ? st.p_end - st.p : D(0.0);
    }
    const bool event = x.v <= x_max.v && x.v < kInf;
    if (!event) {
      if (x_max.v == kInf) return false;
      x = x_max;
    }
    st.p = st.p + x;
    st.P_t = st.P_t + r * x;
    st.W = st.W + (u_n + 0.5 * (h * x)) * x;
    if (!event) return true;
    x_max = x_max - x;
    if (!st.restitution) {
      beginRestitution(cx, r);
    } else {
      if (!pr.stronge) st.p = st.p_end;
      st.done = true;
    }
  }
  return true;
}

// Slip direction on leaving stick, (lambda I + mu_d A) s = b, |s| = 1 (friction_disk.h's
// slipDirection()), with its gradient: d/dmu_d by implicit differentiation,
// ds = -M^-1 (dlambda s + A s), dlambda = -(s.M^-1 A s) / (s.M^-1 s), M = lambda I + mu_d A.
D2 resumeDirection(const Problem& pr) {
  const Vec2 s = slipDirection(pr.mu_d.v * pr.A, pr.b);
  const double lambda = s.dot(pr.b - pr.mu_d.v * (pr.A * s));
  const Mat2 M_inv = (lambda * Mat2::Identity() + pr.mu_d.v * pr.A).inverse();
  const double dlambda = -s.dot(M_inv * (pr.A * s)) / s.dot(M_inv * s);
  const Vec2 ds = -M_inv * (dlambda * s + pr.A * s);
  D2 out{D(s.x()), D(s.y())};
  out.x.d[kMuD] = ds.x();
  out.y.d[kMuD] = ds.y();
  if constexpr (kByK) {
    // The same for K's entries: (lambda I + mu_d A) s = b moved by dA and db:
    // ds = -M^-1 (dlambda s + r), r = mu_d dA s - db, dlambda = -(s.M^-1 r) / (s.M^-1 s).
    const double sMs = s.dot(M_inv * s);
    const auto along = [&](int k, const Vec2& r) {
      const double dl = -s.dot(M_inv * r) / sMs;
      const Vec2 d = -M_inv * (dl * s + r);
      out.x.d[k] = d.x();
      out.y.d[k] = d.y();
    };
    const double mu = pr.mu_d.v;
    along(kA00, Vec2(mu * s.x(), 0.0));
    along(kA01, Vec2(mu * s.y(), mu * s.x()));
    along(kA11, Vec2(0.0, mu * s.y()));
    along(kB0, Vec2(-1.0, 0.0));
    along(kB1, Vec2(0.0, -1.0));
  }
  return out;
}

// The slip has stopped (or never started): onto the sticking manifold u_t = 0, then stick while
// the sticking rate tau = -A^-1 b lies in the static cone, else slip resumes (the integrator's
// stickOrResume()).
bool stickOrResume(Context& cx) {
  const Problem& pr = cx.pr;
  State& st = cx.st;
  // (A frictionless contact's tangential impulse is 0 whatever the slip: its slip passing through
  // zero along a line is no stop, and the sticking manifold's gradient would not be its own.)
  if (pr.mu_s.v != 0.0 || pr.mu_d.v != 0.0) {
    st.P_t = pr.timesAinv(D2{D(0.0), D(0.0)} - pr.u0_t - st.p * pr.bVector());
  }
  const Vec2 tau = -(pr.A_inv * pr.b);
  const double limit = std::max(pr.mu_s.v, pr.mu_d.v);
  const double tau_norm = tau.norm();
  if (tau_norm <= limit) {
    cx.sticking = true;
    if (tau_norm >= (1.0 - kSwitchTolerance) * limit) {
      cx.flag("stick/slip after the stop: |K_tt^-1 K_tn| = mu_s; sticking side");
    }
    // The sticking rate -A^-1 b (with K's entries it carries their gradient).
    if constexpr (kByK) {
      return advanceLinear(cx, D2{D(0.0), D(0.0)} - pr.timesAinv(pr.b_d), D(kInf));
    } else {
      return advanceLinear(cx, constant(tau), D(kInf));
    }
  }
  if (tau_norm <= (1.0 + kSwitchTolerance) * limit) {
    cx.flag("stick/slip after the stop: |K_tt^-1 K_tn| = mu_s; slipping side");
  }
  return advanceLinear(cx, (-pr.mu_d) * resumeDirection(pr), D(kInf));
}

// The integrator's centralStop(): K_tn = 0 and a slip that surely stops within the impact.
bool centralStop(Context& cx) {
  const Problem& pr = cx.pr;
  State& st = cx.st;
  const double trace = pr.A.trace();
  if (!(pr.b.norm() <= 1e-12 * (trace + pr.c)) || !(pr.mu_d.v > 0.0)) return false;
  const double lambda_min = symmetricEigenvalues(pr.A)(0);
  if (!(lambda_min > kSingularRelative * trace)) return false;
  const D p_c = -pr.u0_n / pr.c_d;
  const D p_end = (1.0 + pr.e) * p_c;
  if (!(pr.u0_t.value().norm() <= pr.mu_d.v * lambda_min * p_end.v)) return false;
  st.p_c = p_c;
  st.W_c = 0.5 * (pr.u0_n * p_c);
  st.p = p_end;
  st.P_t = pr.timesAinv(D2{D(0.0), D(0.0)} - pr.u0_t);
  st.W = (1.0 - pr.e * pr.e) * st.W_c;
  st.restitution = true;
  st.done = true;
  return true;
}

// d(p, P_t, W)/dxi while sliding, dp/dxi = sigma.
inline Y4 slipField(const Problem& pr, const Y4& y) {
  const D2 P_t{y.y[1], y.y[2]};
  const D2 u_t = pr.slip(y.y[0], P_t);
  const D u_n = pr.normal(y.y[0], P_t);
  const D sigma = sqrt(u_t.x * u_t.x + u_t.y * u_t.y);
  return {{sigma, -(pr.mu_d * u_t.x), -(pr.mu_d * u_t.y), sigma * u_n}};
}

// Dormand-Prince 5(4) tableau (this sensitivity integration's own; the prediction takes Taylor
// steps, impulse_space_integrator.cpp: the two paths agree to their tolerances).
constexpr double a21 = 1.0 / 5;
constexpr double a31 = 3.0 / 40, a32 = 9.0 / 40;
constexpr double a41 = 44.0 / 45, a42 = -56.0 / 15, a43 = 32.0 / 9;
constexpr double a51 = 19372.0 / 6561, a52 = -25360.0 / 2187, a53 = 64448.0 / 6561,
                 a54 = -212.0 / 729;
constexpr double a61 = 9017.0 / 3168, a62 = -355.0 / 33, a63 = 46732.0 / 5247, a64 = 49.0 / 176,
                 a65 = -5103.0 / 18656;
constexpr double b1 = 35.0 / 384, b3 = 500.0 / 1113, b4 = 125.0 / 192, b5 = -2187.0 / 6784,
                 b6 = 11.0 / 84;
constexpr double e1 = 71.0 / 57600, e3 = -71.0 / 16695, e4 = 71.0 / 1920, e5 = -17253.0 / 339200,
                 e6 = 22.0 / 525, e7 = -1.0 / 40;

// One step of size h on values and gradients; returns the error estimate of the values (max
// norm, scaled by J and V_n J) over the tolerance.
double dopriStep(const Problem& pr, const Y4& y, const Y4& f, double h, Y4& y1, Y4& f1) {
  const Y4& k1 = f;
  const Y4 k2 = slipField(pr, y + (h * a21) * k1);
  const Y4 k3 = slipField(pr, y + (h * a31) * k1 + (h * a32) * k2);
  const Y4 k4 = slipField(pr, y + (h * a41) * k1 + (h * a42) * k2 + (h * a43) * k3);
  const Y4 k5 =
      slipField(pr, y + (h * a51) * k1 + (h * a52) * k2 + (h * a53) * k3 + (h * a54) * k4);
  const Y4 k6 = slipField(
      pr, y + (h * a61) * k1 + (h * a62) * k2 + (h * a63) * k3 + (h * a64) * k4 + (h * a65) * k5);
  y1 = y + (h * b1) * k1 + (h * b3) * k3 + (h * b4) * k4 + (h * b5) * k5 + (h * b6) * k6;
  f1 = slipField(pr, y1);
  double err = 0.0;
  for (int i = 0; i < 4; ++i) {
    const double ei = h * (e1 * k1.y[i].v + e3 * k3.y[i].v + e4 * k4.y[i].v + e5 * k5.y[i].v +
                           e6 * k6.y[i].v + e7 * f1.y[i].v);
    err = std::max(err, std::abs(ei) / (i < 3 ? pr.J : pr.J * pr.V_n));
  }
  return err / pr.tol;
}

// The current phase's event value g (u_n, then p - p_end or W - W_end) and its rate dg/dxi.
D eventValue(const Problem& pr, const State& st, const Y4& y) {
  if (!st.restitution) return pr.normal(y.y[0], D2{y.y[1], y.y[2]});
  return pr.stronge ? y.y[3] - st.W_end : y.y[0] - st.p_end;
}
D eventRate(const Problem& pr, const State& st, const Y4& f) {
  if (!st.restitution) {
    if constexpr (kByK) {
      return pr.c_d * f.y[0] + pr.b_d.x * f.y[1] + pr.b_d.y * f.y[2];
    } else {
      return pr.c * f.y[0] + pr.b.x() * f.y[1] + pr.b.y() * f.y[2];
    }
  }
  return pr.stronge ? f.y[3] : f.y[0];
}

void setState(State& st, const Y4& y) {
  st.p = y.y[0];
  st.P_t = D2{y.y[1], y.y[2]};
  st.W = y.y[3];
}

// The rest of a turning slip to its stop by the stick-approach series (stick_approach.h), as the
// prediction takes it (the integrator's seriesToStop()), with its gradient, when no event lies on
// the way. The series give p_rem(u_t; mu_d), the normal impulse to the stop, and
// work_drop(u_t; mu_d), with W_rem = u_n,stop p_rem - work_drop, as functions of the slip u_t at
// the series' start alone (K fixed). Their gradients with respect to u_t follow without
// differentiating the series: p_rem is homogeneous of degree 1 in u_t and work_drop of degree 2
// (the path scales with the slip), so grad . u_t = p_rem (2 work_drop), and along the flow
// du_t/dp = F = K_tn - mu_d K_tt s both fall at known rates, grad p_rem . F = -1 and
// grad work_drop . F = -(u_n,stop - u_n) (the rise of u_n still to come): two equations for the two
// components. Their mu_d derivatives at fixed u_t come from the series' coefficients carried with
// their mu_d derivatives (StickApproach::muDerivatives()). Chained with the sensitivity up to the
// series' start (the gradients of u_t there), and put on the sticking manifold at the stop.
// kTaken: the state is at the stop; kRetry: the series do not converge at this angle (try closer);
// kGiveUp: an event on the way, sums that cancel, or a slip already within 1e-4 rad of s*
// (integrate the rest).
enum class SeriesOutcome { kTaken, kRetry, kGiveUp };
SeriesOutcome seriesToStop(Context& cx, StickApproach& approach) {
  const Problem& pr = cx.pr;
  State& st = cx.st;
  const D2 u = pr.slip(st.p, st.P_t);
  const Vec2 u_v = u.value();
  const double sigma = u_v.norm();
  const Vec2 s = u_v / sigma;
  const double y0 = approach.distance(s);
  if (y0 < 0.0) return SeriesOutcome::kRetry;
  const Vec2 F = pr.b - pr.mu_d.v * (pr.A * s);
  // The two equations for the gradient in u_t below degenerate as the slip's direction nears s*
  // (u_t and F parallel; the component across u_t is then a difference of two nearly equal terms
  // over the angle): within 1e-4 of it, integrate instead.
  if (!(std::abs(s.x() * F.y() - s.y() * F.x()) > 1e-4 * F.norm())) {
    return SeriesOutcome::kGiveUp;
  }
  const double rate = s.dot(F);
  // The series' shares of the tolerance, as the integrator's (there: seriesToStop()).
  const double rise = pr.c + pr.mu_d.v * pr.b.norm();
  const double p_guess = rate < 0.0 ? std::min(sigma / -rate, 1e6 * pr.J) : pr.J;
  const double u_n_now = pr.normal(st.p, st.P_t).v;
  const auto share = [&](double p_rem, double u_n_stop, double work_drop, double& rel_p,
                         double& rel_w) {
    const double budget = 0.05 * pr.tol;
    rel_p = std::min(
        {1e-3, budget * pr.J / p_rem, budget * pr.V_n * pr.J / (std::abs(u_n_stop) * p_rem)});
    rel_w = std::min(1e-3, budget * pr.V_n * pr.J / work_drop);
  };
  double rel_p, rel_w;
  share(p_guess, std::abs(u_n_now) + rise * p_guess, rise * p_guess * p_guess, rel_p, rel_w);
  if (!approach.converged(y0, rel_p, rel_w)) return SeriesOutcome::kRetry;
  StickApproach::Remaining rest = approach.remaining(y0, approach.logScale(y0, sigma));
  double u_n_stop = u_n_now + rest.u_n_rise;
  double need_p, need_w;
  share(rest.p, u_n_stop, rest.work_drop, need_p, need_w);
  if (need_p < rel_p || need_w < rel_w) {
    if (!approach.converged(y0, need_p, need_w)) return SeriesOutcome::kRetry;
    rest = approach.remaining(y0, approach.logScale(y0, sigma));
    u_n_stop = u_n_now + rest.u_n_rise;
  }
  if (!((u_v + pr.A * rest.P_t + pr.b * rest.p).norm() <= pr.tol * pr.V_n)) {
    return SeriesOutcome::kRetry;
  }
  const double magnitude =
      std::max(rest.p / pr.J, (std::abs(u_n_stop) * rest.p + rest.work_drop) / (pr.V_n * pr.J));
  if (!(1e-15 * magnitude <= 0.05 * pr.tol)) return SeriesOutcome::kGiveUp;
  // An event on the way (maximum compression, the end of the impact): integrate instead.
  const double W_stop = st.W.v + u_n_stop * rest.p - rest.work_drop;
  const bool event = !st.restitution ? u_n_stop >= 0.0
                     : pr.stronge    ? W_stop >= st.W_end.v
                                     : st.p.v + rest.p >= st.p_end.v;
  if (event) return SeriesOutcome::kGiveUp;

  // grad_u p_rem and grad_u work_drop: [u_t^T; F^T] g = (p_rem, -1) and (2 work_drop, -rise).
  Mat2 M;
  M.row(0) = u_v.transpose();
  M.row(1) = F.transpose();
  const Mat2 M_inv = M.inverse();
  const Vec2 g_p = M_inv * Vec2(rest.p, -1.0);
  const Vec2 g_w = M_inv * Vec2(2.0 * rest.work_drop, -rest.u_n_rise);
  // The order the values were summed to (muDerivatives() may extend the series).
  const int order = approach.order();
  const StickApproach::MuDerivatives by_mu = approach.muDerivatives(y0, sigma);
  D p_rem(rest.p, g_p.x() * u.x.d + g_p.y() * u.y.d);
  p_rem.d[kMuD] += by_mu.p;
  D work_drop(rest.work_drop, g_w.x() * u.x.d + g_w.y() * u.y.d);
  work_drop.d[kMuD] += by_mu.work_drop;
  const D p_stop = st.p + p_rem;
  const D2 P_stop = pr.timesAinv(D2{D(0.0), D(0.0)} - pr.u0_t - p_stop * pr.bVector());
  st.W = st.W + pr.normal(p_stop, P_stop) * p_rem - work_drop;
  st.p = p_stop;
  st.P_t = P_stop;
  cx.detail.series = true;
  cx.detail.series_order = order;
  return SeriesOutcome::kTaken;
}

// A sliding slip, integrated with its sensitivities until the impact ends or the slip stops
// (`stopped`). False if the step budget runs out.
bool integrateSlip(Context& cx, bool& stopped) {
  const Problem& pr = cx.pr;
  State& st = cx.st;
  const double rate = pr.b.norm() + pr.mu_d.v * pr.A.norm();
  const double h_max = rate > 0.0 ? 2.0 / rate : kInf;
  Y4 y{{st.p, st.P_t.x, st.P_t.y, st.W}};
  Y4 f = slipField(pr, y);
  double h = std::min(h_max, 0.05 * pr.J / std::max(f.y[0].v, kStickSpeed * pr.V));
  // The stick-approach series where the prediction uses it (the integrator's integrateSlip()):
  // on a slip with m >= kSeriesExponent, once within kSeriesReach of the series' radius of s*,
  // and again each time it has turned 30 % closer.
  StickApproach approach;
  // (Not with K's entries: the series' gradient is known with respect to the slip and mu_d only;
  // the slip is then integrated to its stop.)
  bool series =
      !kByK && pr.mu_d.v > 0.0 &&
      approach.build(pr.A, pr.b, pr.c, pr.mu_d.v, pr.slip(st.p, st.P_t).value().normalized()) &&
      approach.exponent() >= kSeriesExponent;
  double retry_cos = series ? std::cos(std::min(3.0, kSeriesReach * approach.radius())) : 2.0;
  for (std::size_t steps = 0;;) {
    if (series) {
      const Vec2 u_t = pr.slip(y.y[0], D2{y.y[1], y.y[2]}).value();
      if (approach.direction().dot(u_t) > retry_cos * u_t.norm()) {
        setState(st, y);
        const SeriesOutcome result = seriesToStop(cx, approach);
        if (result == SeriesOutcome::kTaken) {
          stopped = true;
          return true;
        }
        series = result == SeriesOutcome::kRetry;
        retry_cos = std::cos(0.7 * approach.distance(u_t.normalized()));
      }
    }
    if (pr.mu_d.v > 0.0 && f.y[0].v <= kStop * pr.V) {
      setState(st, y);
      stopped = true;
      cx.detail.threshold_stop = true;
      return true;
    }
    if (++steps > kMaxSteps) return false;
    ++cx.detail.steps;
    h = std::min(h, h_max);
    Y4 y1, f1;
    const double err = dopriStep(pr, y, f, h, y1, f1);
    if (!(err <= 1.0)) {
      h *= std::isfinite(err) ? std::max(0.2, 0.9 * std::pow(err, -0.2)) : 0.2;
      continue;
    }
    const D g1 = eventValue(pr, st, y1);
    if (g1.v >= 0.0) {
      const double g0 = eventValue(pr, st, y).v;
      const double theta =
          g0 < 0.0 ? hermiteRoot(g0, h * eventRate(pr, st, f).v, g1.v, h * eventRate(pr, st, f1).v)
                   : 0.0;
      if (theta > 0.0) {
        dopriStep(pr, y, f, theta * h, y1, f1);
      } else {
        y1 = y;
        f1 = f;
      }
      // The event's own sensitivity: one Newton step on g along the flow, gradients included.
      for (int polish = 0; polish < 2; ++polish) {
        const D slope = eventRate(pr, st, f1);
        if (!(slope.v > 0.0)) break;
        const D step = eventValue(pr, st, y1) / slope;
        for (int i = 0; i < 4; ++i) y1.y[i] = y1.y[i] - step * f1.y[i];
        f1 = slipField(pr, y1);
      }
      setState(st, y1);
      if (f1.y[0].v <= kNear * pr.V) {
        cx.flag(
            "the slip stops where a phase ends (maximum compression or the end of the "
            "impact): sliding side");
      }
      if (!st.restitution) {
        // dP_t/dp = (dP_t/dxi) / sigma = -mu_d s (the rate e = 0 would go on along).
        D2 r{D(0.0), D(0.0)};
        if (f1.y[0].v > 0.0) r = D2{f1.y[1] / f1.y[0], f1.y[2] / f1.y[0]};
        beginRestitution(cx, r);
      } else {
        if (pr.stronge)
          st.W = st.W_end;
        else
          st.p = st.p_end;
        st.done = true;
      }
      if (st.done) return true;
      y = Y4{{st.p, st.P_t.x, st.P_t.y, st.W}};
      f = slipField(pr, y);
      continue;
    }
    // A slip below kNearMiss |u0| that grows again has passed its stop (the integrator's rule):
    // stopped there.
    if (pr.mu_d.v > 0.0 && f.y[0].v <= kNearMiss * pr.V && f1.y[0].v > f.y[0].v) {
      setState(st, y);
      stopped = true;
      cx.detail.threshold_stop = true;
      return true;
    }
    y = y1;
    f = f1;
    h *= std::min(5.0, 0.9 * std::pow(std::max(err, 1e-10), -0.2));
  }
}

// One run of the sensitivity. linear_frictionless: a slip without dynamic friction is taken as
// the closed form it is (u_t linear in p, exact gradients) rather than integrated; the
// integration is needed for the mu_d column only (friction raised from 0 acts along the turning
// frictionless slip).
bool differentiate(const Eigen::Vector3d& n, const Eigen::Matrix3d& K, const Eigen::Vector3d& u,
                   double e, double mu_s, double mu_d, ImpactLaw law, double tolerance,
                   bool linear_frictionless, Eigen::Matrix3d& dP_du,
                   Eigen::Matrix3d& dP_dcoefficients, ContactDerivativeMode& mode,
                   Eigen::Vector3d* impulse, ImpulseSpaceSensitivityDetail& detail,
                   const std::vector<Eigen::Matrix3d>* dK = nullptr,
                   Eigen::Matrix<double, 3, Eigen::Dynamic>* dP_dK = nullptr) {
  dP_du.setZero();
  dP_dcoefficients.setZero();
  if (impulse) impulse->setZero();
  mode = ContactDerivativeMode{};
  mode.method = DerivativeMethod::kAnalytic;
  if (law != ImpactLaw::kPoisson && law != ImpactLaw::kStronge) return false;
  const double u_n = u.dot(n);
  if (std::abs(u_n) <= kSwitchTolerance * u.norm()) {
    mode.at_switch = true;
    mode.switch_detail = u_n < 0.0 ? "u_n = 0: the contact barely approaches; approaching side"
                                   : "u_n = 0: touching; no-impulse side";
  }
  if (!(u_n < 0.0)) {
    mode.mode = ImpactMode::kNoImpulse;
    return true;
  }
  const double K_nn = n.dot(K * n);
  if (!(K_nn > kSingularRelative * K.trace())) {
    mode.mode = ImpactMode::kNoImpulse;  // nothing moves the contact along n
    return true;
  }
  Eigen::Vector3d t1, t2;
  tangentBasis(n, t1, t2);
  Eigen::Matrix3d B;
  B << t1, t2, n;
  const Eigen::Matrix3d Kc = B.transpose() * K * B;
  Problem pr;
  pr.A = Kc.topLeftCorner<2, 2>();
  pr.b = Kc.topRightCorner<2, 1>();
  pr.c = Kc(2, 2);
  const double trace = pr.A.trace();
  if (!(pr.A.determinant() > kSingularRelative * trace * trace)) return false;
  pr.A_inv = pr.A.inverse();
  pr.c_d = D(pr.c);
  if constexpr (kByK) {
    pr.a00 = D::input(pr.A(0, 0), kA00);
    pr.a01 = D::input(pr.A(0, 1), kA01);
    pr.a10 = D::input(pr.A(1, 0), kA01);
    pr.a11 = D::input(pr.A(1, 1), kA11);
    pr.b_d = D2{D::input(pr.b.x(), kB0), D::input(pr.b.y(), kB1)};
    pr.c_d = D::input(pr.c, kC);
    // d(A^-1) = -A^-1 dA A^-1 along each of A's three entries.
    D* inverse[2][2] = {{&pr.i00, &pr.i01}, {&pr.i10, &pr.i11}};
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j) *inverse[i][j] = D(pr.A_inv(i, j));
    const std::pair<int, Mat2> directions[3] = {{kA00, (Mat2() << 1, 0, 0, 0).finished()},
                                                {kA01, (Mat2() << 0, 1, 1, 0).finished()},
                                                {kA11, (Mat2() << 0, 0, 0, 1).finished()}};
    for (const auto& [k, E] : directions) {
      const Mat2 change = -pr.A_inv * E * pr.A_inv;
      for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j) inverse[i][j]->d[k] = change(i, j);
    }
  }
  pr.u0_t = D2{D::input(t1.dot(u), kUt1), D::input(t2.dot(u), kUt2)};
  pr.u0_n = D::input(u_n, kUn);
  pr.e = D::input(e, kE);
  pr.mu_s = D::input(mu_s, kMuS);
  pr.mu_d = D::input(mu_d, kMuD);
  pr.stronge = law == ImpactLaw::kStronge;
  pr.V = u.norm();
  pr.V_n = -u_n;
  pr.J = pr.V_n / (pr.c + std::max(mu_s, mu_d) * pr.b.norm());
  pr.tol = std::clamp(tolerance, 1e-14, 1e-10);

  Context cx{pr, State{}, mode, detail};
  State& st = cx.st;
  bool ok = true;
  bool stopped = false;
  const double slip0 = pr.u0_t.value().norm();
  if (slip0 <= kStickSpeed * pr.V) {
    // A small slip stops at once where dynamic friction can stop it in every direction
    // (|K_tt^-1 K_tn| < mu_d): the map is smooth across u_t = 0. Otherwise it may slide on.
    if (!((pr.A_inv * pr.b).norm() < pr.mu_d.v)) {
      cx.flag(
          "no slip before the impact: the tangential velocity columns are those of sticking "
          "from the start (a slip may slide instead: one-sided)");
    }
  }
  // A central stop is two segments (slip to the stop, then stick), as the integrator counts it.
  std::size_t segments = 0;
  // (Not with K's entries: the central stop's closed form holds at K_tn = 0 only, and its
  // gradient with respect to K_tn is not that closed form's; the slip is integrated instead.)
  if (!kByK && slip0 > kStickSpeed * pr.V && centralStop(cx)) {
    cx.sticking = true;
    segments = 2;
  }
  while (!st.done && ok) {
    if (++segments > kMaxSegments) {
      ok = false;
      break;
    }
    const D2 u_t = pr.slip(st.p, st.P_t);
    const Vec2 u_t_value = u_t.value();
    const double sigma = u_t_value.norm();
    if (stopped || sigma <= kStickSpeed * pr.V) {
      ok = stickOrResume(cx);
      break;
    }
    const Vec2 s = u_t_value / sigma;
    const Vec2 g = pr.b - pr.mu_d.v * (pr.A * s);
    const bool parallel = std::abs(s.x() * g.y() - s.y() * g.x()) <=
                          kParallel * (pr.b.norm() + pr.mu_d.v * pr.A.norm());
    if (pr.mu_d.v == 0.0 && (parallel || linear_frictionless)) {
      // Frictionless slip along a fixed line: u_t linear in p; it may pass through 0.
      const double sigma_rate = s.dot(g);
      D x_stop(kInf);
      if (parallel && sigma_rate < 0.0) {
        x_stop = dot(u_t, u_t) / -dot(pr.bVector(), u_t);  // sigma / -(s.b)
        // With static friction the slip's zero may hold it (a switch); without, it passes.
        if (pr.mu_s.v > 0.0) cx.flag("frictionless slip through zero slip along a line: one-sided");
      }
      ok = advanceLinear(cx, D2{D(0.0), D(0.0)}, x_stop);
      stopped = true;
    } else {
      ok = integrateSlip(cx, stopped);
      if (ok && stopped) {
        // A stop next to an event: the order of the two is a switch.
        const D u_n_now = pr.normal(st.p, st.P_t);
        const bool near_compression = !st.restitution && -u_n_now.v <= kNear * pr.V_n;
        const bool near_end =
            st.restitution && (pr.stronge ? st.W_end.v - st.W.v <= kNear * pr.V_n * pr.J
                                          : st.p_end.v - st.p.v <= kNear * pr.J);
        if (near_compression || near_end) {
          cx.flag("the slip stops where a phase ends: stopping side");
        }
      }
    }
  }
  detail.segments = segments;
  if (!ok) return false;
  detail.compression_impulse = st.p_c.v;
  detail.compression_work = st.W_c.v;
  if (mu_d == 0.0) cx.flag("mu_d = 0: the dynamic friction column is one-sided (increasing)");

  const Eigen::Matrix<double, 3, kGradient> dP =
      n * st.p.d.transpose() + t1 * st.P_t.x.d.transpose() + t2 * st.P_t.y.d.transpose();
  dP_du = dP.template leftCols<3>() * B.transpose();
  dP_dcoefficients = dP.template middleCols<3>(3);
  if constexpr (kByK) {
    // Each change dK (world) in the contact frame, on K's six entries (A01 the symmetric pair).
    if (dK != nullptr && dP_dK != nullptr) {
      dP_dK->resize(3, static_cast<Eigen::Index>(dK->size()));
      for (std::size_t k = 0; k < dK->size(); ++k) {
        const Eigen::Matrix3d local = B.transpose() * (*dK)[k] * B;
        dP_dK->col(static_cast<Eigen::Index>(k)) =
            dP.col(kA00) * local(0, 0) + dP.col(kA01) * 0.5 * (local(0, 1) + local(1, 0)) +
            dP.col(kA11) * local(1, 1) + dP.col(kB0) * 0.5 * (local(0, 2) + local(2, 0)) +
            dP.col(kB1) * 0.5 * (local(1, 2) + local(2, 1)) + dP.col(kC) * local(2, 2);
      }
    }
  }
  if (impulse) *impulse = st.p.v * n + st.P_t.x.v * t1 + st.P_t.y.v * t2;
  const bool frictionless = mu_s == 0.0 && mu_d == 0.0;
  mode.mode = cx.sticking && !frictionless ? ImpactMode::kSticking : ImpactMode::kSliding;
  return true;
}
