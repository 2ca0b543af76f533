#include "landing_fit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>

namespace collision_response::bench {
namespace {

bool finite(const CubeState& s) {
  return s.position.allFinite() && s.linear_velocity.allFinite() &&
         s.angular_velocity.allFinite() && s.orientation.coeffs().allFinite();
}

double rms(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x * x;
  return v.empty() ? std::numeric_limits<double>::quiet_NaN() : std::sqrt(sum / v.size());
}

/// Unit-box coordinate u in [0, 1] of a parameter value, and back.
double toUnit(const LandingParameter& p, double value) {
  if (p.log_scale) return std::log(value / p.lower) / std::log(p.upper / p.lower);
  return (value - p.lower) / (p.upper - p.lower);
}
double fromUnit(const LandingParameter& p, double u) {
  u = std::clamp(u, 0.0, 1.0);
  if (p.log_scale) return p.lower * std::pow(p.upper / p.lower, u);
  return p.lower + u * (p.upper - p.lower);
}

}  // namespace

double median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  if (v.size() % 2 == 1) return v[mid];
  const double upper = v[mid];
  return 0.5 * (upper + *std::max_element(v.begin(), v.begin() + mid));
}

LandingError landingError(LandingModel& model, const std::vector<double>& values,
                          const Landing& landing, const TossedCube& cube) {
  const CubeState predicted =
      model.simulate(landing.before, values, landing.t_after - landing.t_before);
  LandingError error;
  if (!finite(predicted)) {
    error.linear = error.angular = std::numeric_limits<double>::infinity();
    return error;
  }
  error.linear = (predicted.linear_velocity - landing.after.linear_velocity).norm() /
                 landing.before.linear_velocity.norm();
  error.angular = cube.half_width *
                  (predicted.angular_velocity - landing.after.angular_velocity).norm() /
                  landing.before.linear_velocity.norm();
  return error;
}

double fitObjective(LandingModel& model, const std::vector<double>& values,
                    const std::vector<Landing>& landings, const TossedCube& cube) {
  double sum = 0.0;
  for (const Landing& landing : landings) {
    LandingError e;
    try {
      e = landingError(model, values, landing, cube);
    } catch (const std::exception&) {
      return std::numeric_limits<double>::infinity();
    }
    sum += 0.5 * (e.linear * e.linear + e.angular * e.angular);
  }
  const double objective = std::sqrt(sum / landings.size());
  return std::isfinite(objective) ? objective : std::numeric_limits<double>::infinity();
}

FitResult fitLandingModel(LandingModel& model, const std::vector<Landing>& training,
                          const TossedCube& cube, const FitOptions& options) {
  const std::vector<LandingParameter> params = model.parameters();
  const int n = static_cast<int>(params.size());
  FitResult best;
  best.objective = std::numeric_limits<double>::infinity();
  auto values = [&](const Eigen::VectorXd& u) {
    std::vector<double> v(n);
    for (int i = 0; i < n; ++i) v[i] = fromUnit(params[i], u[i]);
    return v;
  };
  auto evaluate = [&](const Eigen::VectorXd& u) {
    ++best.evaluations;
    return fitObjective(model, values(u), training, cube);
  };
  if (n == 0) {
    best.objective = evaluate(Eigen::VectorXd());
    return best;
  }
  std::mt19937 rng(options.seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (int start = 0; start < options.starts; ++start) {
    Eigen::VectorXd x0(n);
    for (int i = 0; i < n; ++i)
      x0[i] = start == 0 ? toUnit(params[i], params[i].initial) : uniform(rng);
    // Simplex: x0 and a step of 0.15 of the box along each axis (inwards at the upper bound).
    std::vector<Eigen::VectorXd> simplex(n + 1, x0);
    std::vector<double> f(n + 1);
    for (int i = 0; i < n; ++i) simplex[i + 1][i] += x0[i] + 0.15 <= 1.0 ? 0.15 : -0.15;
    for (int i = 0; i <= n; ++i) f[i] = evaluate(simplex[i]);
    int evaluations = n + 1;
    auto clamp = [](Eigen::VectorXd x) { return x.cwiseMax(0.0).cwiseMin(1.0).eval(); };
    while (evaluations < options.max_evaluations) {
      std::vector<int> order(n + 1);
      for (int i = 0; i <= n; ++i) order[i] = i;
      std::sort(order.begin(), order.end(), [&](int a, int b) { return f[a] < f[b]; });
      std::vector<Eigen::VectorXd> s(n + 1);
      std::vector<double> fs(n + 1);
      for (int i = 0; i <= n; ++i) s[i] = simplex[order[i]], fs[i] = f[order[i]];
      simplex = s, f = fs;
      double size = 0.0;
      for (int i = 1; i <= n; ++i) size = std::max(size, (simplex[i] - simplex[0]).norm());
      if (size < 1e-4 || (std::isfinite(f[n]) && f[n] - f[0] < 1e-7)) break;
      Eigen::VectorXd centroid = Eigen::VectorXd::Zero(n);
      for (int i = 0; i < n; ++i) centroid += simplex[i] / n;
      const Eigen::VectorXd reflected = clamp(centroid + (centroid - simplex[n]));
      const double fr = evaluate(reflected);
      ++evaluations;
      if (fr < f[0]) {
        const Eigen::VectorXd expanded = clamp(centroid + 2.0 * (centroid - simplex[n]));
        const double fe = evaluate(expanded);
        ++evaluations;
        if (fe < fr)
          simplex[n] = expanded, f[n] = fe;
        else
          simplex[n] = reflected, f[n] = fr;
      } else if (fr < f[n - 1]) {
        simplex[n] = reflected, f[n] = fr;
      } else {
        const bool outside = fr < f[n];
        const Eigen::VectorXd contracted = outside
                                               ? clamp(centroid + 0.5 * (reflected - centroid))
                                               : clamp(centroid + 0.5 * (simplex[n] - centroid));
        const double fc = evaluate(contracted);
        ++evaluations;
        if (fc < std::min(fr, f[n])) {
          simplex[n] = contracted, f[n] = fc;
        } else {  // shrink towards the best
          for (int i = 1; i <= n; ++i) {
            simplex[i] = simplex[0] + 0.5 * (simplex[i] - simplex[0]);
            f[i] = evaluate(simplex[i]);
            ++evaluations;
          }
        }
      }
    }
    const int arg = static_cast<int>(std::min_element(f.begin(), f.end()) - f.begin());
    if (f[arg] < best.objective || best.values.empty()) {
      best.objective = f[arg];
      best.values = values(simplex[arg]);
    }
  }
  // No start (or every objective +infinity): the parameters' initial values, scored as they are.
  if (best.values.empty())
    for (const LandingParameter& p : params) best.values.push_back(p.initial);
  return best;
}

LandingScore scoreLandingModel(LandingModel& model, const std::vector<double>& values,
                               const std::vector<Landing>& held_out, const TossedCube& cube,
                               int time_repetitions) {
  LandingScore score;
  std::vector<double> linear, angular, times;
  for (const Landing& landing : held_out) {
    LandingError e;
    try {
      e = landingError(model, values, landing, cube);
    } catch (const std::exception&) {
      e.linear = e.angular = std::numeric_limits<double>::infinity();
    }
    if (!std::isfinite(e.linear) || !std::isfinite(e.angular)) ++score.failures;
    linear.push_back(e.linear);
    angular.push_back(e.angular);
    for (int r = 0; r < time_repetitions; ++r) {
      const auto start = std::chrono::steady_clock::now();
      try {
        model.simulate(landing.before, values, landing.t_after - landing.t_before);
      } catch (const std::exception&) {
      }
      times.push_back(
          std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start)
              .count());
    }
  }
  score.landings = static_cast<int>(held_out.size());
  score.linear = linear;
  score.angular = angular;
  score.rms_linear = rms(linear);
  score.rms_angular = rms(angular);
  score.median_linear = median(linear);
  score.median_angular = median(angular);
  score.median_time_us = median(times);
  return score;
}

RmsDifference pairedRmsDifference(const std::vector<double>& a, const std::vector<double>& b) {
  RmsDifference result;
  result.difference = rms(a) - rms(b);
  const size_t n = std::min(a.size(), b.size());
  if (n == 0) return result;
  std::mt19937 rng(24);
  std::uniform_int_distribution<size_t> pick(0, n - 1);
  std::vector<double> differences;
  constexpr int kResamples = 2000;
  for (int r = 0; r < kResamples; ++r) {
    double sa = 0.0, sb = 0.0;
    for (size_t i = 0; i < n; ++i) {
      const size_t k = pick(rng);
      sa += a[k] * a[k];
      sb += b[k] * b[k];
    }
    differences.push_back(std::sqrt(sa / n) - std::sqrt(sb / n));
  }
  std::sort(differences.begin(), differences.end());
  result.lower = differences[static_cast<size_t>(0.025 * kResamples)];
  result.upper = differences[static_cast<size_t>(0.975 * kResamples) - 1];
  return result;
}

}  // namespace collision_response::bench
