#include "collision_response/calibration/identification.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>

namespace collision_response::calibration {
namespace {

/// The automatic loss scale: the first stage's, and the least of the second's.
constexpr double kFirstLossScale = 0.25;
constexpr double kMinimumLossScale = 1e-4;
/// The scan of mu_s with two friction coefficients: this far either side of the fit, this many
/// steps (0.005 apart at most).
constexpr double kStaticScanHalfWidth = 0.1;
constexpr int kStaticScanPoints = 40;
/// The scan of e and one mu around the fit: this many steps of this size either side.
constexpr int kPlateauScanPoints = 8;
constexpr double kPlateauScanStep = 0.0025;

/// The fitted parameters x and the coefficients they stand for: x = (e, mu[, r][, s]) with
/// mu_s = mu, mu_d = r mu (r = 1 with one mu).
struct Parametrisation {
  bool split = false, inertia = false;
  int size() const { return 2 + split + inertia; }
  Coefficients coefficients(const double* x) const {
    Coefficients c;
    c.restitution = x[0];
    c.static_friction = x[1];
    c.dynamic_friction = split ? x[2] * x[1] : x[1];
    c.inertia_scale = inertia ? x[2 + split] : 1.0;
    return c;
  }
  std::vector<double> start(const Coefficients& c) const {
    std::vector<double> x{c.restitution, c.static_friction};
    if (split) x.push_back(c.static_friction > 0.0 ? c.dynamic_friction / c.static_friction : 1.0);
    if (inertia) x.push_back(c.inertia_scale);
    return x;
  }
  std::vector<std::string> names() const {
    std::vector<std::string> n{"restitution", split ? "static_friction" : "friction"};
    if (split) n.push_back("friction_ratio");
    if (inertia) n.push_back("inertia_scale");
    return n;
  }
};

struct Bounds {
  std::vector<double> lower, upper;
};

/// One measured outcome to predict (identification.h, CaseResidual).
struct Case {
  const CaseResidual* residual;
  int size;  // its residual's length
};

/// The median of a chi-square distribution with d degrees of freedom (d = 1..10 tabulated, beyond
/// the Wilson-Hilferty approximation d (1 - 2 / (9 d))^3).
double chiSquareMedian(int d) {
  static const double table[] = {0.4549, 1.3863, 2.3660, 3.3567, 4.3515,
                                 5.348,  6.3458, 7.3441, 8.3428, 9.3418};
  if (d >= 1 && d <= 10) return table[d - 1];
  const double k = 1.0 - 2.0 / (9.0 * d);
  return d * k * k * k;
}

/// Each case's residual (a landing's, a robot impact's) and its Jacobian in x by differences
/// (central inside the bounds, one-sided at them), all landings evaluated at once on the worker
/// pool when Ceres moves to a new point (ceres::EvaluationCallback); the residual blocks read them.
class LandingEvaluations final : public ceres::EvaluationCallback {
 public:
  LandingEvaluations(std::vector<Case> cases, const Parametrisation& p, const Bounds& bounds,
                     double step, core::WorkerPool& pool, double* x)
      : cases_(std::move(cases)), p_(p), bounds_(bounds), step_(step), pool_(pool), x_(x) {
    residuals_.resize(cases_.size());
    jacobians_.resize(cases_.size());
    ok_.assign(cases_.size(), 0);
  }

  void PrepareForEvaluation(bool jacobians, bool new_point) override {
    if (!new_point && (!jacobians || have_jacobians_)) return;
    point_.assign(x_, x_ + p_.size());
    have_jacobians_ = jacobians;
    pool_.parallelFor(cases_.size(), [&](std::size_t i) {
      ok_[i] = evaluate(i, point_.data(), residuals_[i], jacobians ? &jacobians_[i] : nullptr);
    });
  }

  /// Residuals (and the Jacobian, row-major m x n, m the case's size) of case i at x: from the
  /// cache when x is its point, else computed here.
  bool get(std::size_t i, const double* x, double* residuals, double* jacobian) const {
    Eigen::VectorXd r;
    Eigen::MatrixXd J;
    bool ok;
    const bool cached = point_.size() == static_cast<size_t>(p_.size()) &&
                        std::equal(point_.begin(), point_.end(), x) &&
                        (jacobian == nullptr || have_jacobians_);
    if (cached) {
      ok = ok_[i];
      r = residuals_[i];
      if (jacobian) J = jacobians_[i];
    } else {
      ok = evaluate(i, x, r, jacobian ? &J : nullptr);
    }
    if (!ok) return false;
    const int m = cases_[i].size;
    for (int k = 0; k < m; ++k) residuals[k] = r[k];
    if (jacobian)
      for (int k = 0; k < m; ++k)
        for (int j = 0; j < p_.size(); ++j) jacobian[k * p_.size() + j] = J(k, j);
    return true;
  }

  bool evaluate(std::size_t i, const double* x, Eigen::VectorXd& r, Eigen::MatrixXd* J) const {
    try {
      const Case& c = cases_[i];
      r = (*c.residual)(p_.coefficients(x));
      if (r.size() != c.size || !r.allFinite()) return false;
      if (J == nullptr) return true;
      const int n = p_.size();
      J->resize(c.size, n);
      std::vector<double> y(x, x + n);
      for (int j = 0; j < n; ++j) {
        // Absolute steps in e, mu, r; relative in the inertia scale.
        const double h = (p_.inertia && j == n - 1) ? step_ * x[j] : step_;
        const double up = std::min(x[j] + h, bounds_.upper[j]);
        const double down = std::max(x[j] - h, bounds_.lower[j]);
        y[j] = up;
        const Eigen::VectorXd r_up = (*c.residual)(p_.coefficients(y.data()));
        y[j] = down;
        const Eigen::VectorXd r_down = (*c.residual)(p_.coefficients(y.data()));
        y[j] = x[j];
        if (r_up.size() != c.size || r_down.size() != c.size) return false;
        J->col(j) = (r_up - r_down) / (up - down);
      }
      return J->allFinite();
    } catch (const std::exception&) {
      return false;
    }
  }

 private:
  std::vector<Case> cases_;
  Parametrisation p_;
  Bounds bounds_;
  double step_;
  core::WorkerPool& pool_;
  const double* x_;
  std::vector<double> point_;
  bool have_jacobians_ = false;
  std::vector<Eigen::VectorXd> residuals_;
  std::vector<Eigen::MatrixXd> jacobians_;
  std::vector<char> ok_;
};

class LandingCost final : public ceres::CostFunction {
 public:
  LandingCost(const LandingEvaluations& evaluations, std::size_t index, int residuals,
              int parameters)
      : evaluations_(evaluations), index_(index) {
    set_num_residuals(residuals);
    mutable_parameter_block_sizes()->push_back(parameters);
  }
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    return evaluations_.get(index_, parameters[0], residuals, jacobians ? jacobians[0] : nullptr);
  }

 private:
  const LandingEvaluations& evaluations_;
  std::size_t index_;
};

class Progress final : public ceres::IterationCallback {
 public:
  explicit Progress(const std::function<void(int)>& f) : f_(f) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    if (f_) f_(s.iteration);
    return ceres::SOLVER_CONTINUE;
  }

 private:
  const std::function<void(int)>& f_;
};

/// Each landing of `objects` as a case (the predictors kept in `keep`).
std::vector<CaseResidual> landingCases(const std::vector<ObjectLandings>& objects,
                                       const PredictionOptions& options,
                                       std::vector<std::unique_ptr<LandingPredictor>>& keep) {
  std::vector<CaseResidual> cases;
  for (const auto& o : objects) {
    keep.push_back(std::make_unique<LandingPredictor>(o.object, options));
    const LandingPredictor* predictor = keep.back().get();
    for (const auto& l : o.landings) {
      const Landing* landing = &l;
      cases.push_back([predictor, landing](const Coefficients& c) -> Eigen::VectorXd {
        return predictor->residual(*landing, c);
      });
    }
  }
  return cases;
}

std::vector<Eigen::VectorXd> caseResiduals(const std::vector<CaseResidual>& cases,
                                           const Coefficients& coefficients,
                                           core::WorkerPool& pool) {
  std::vector<Eigen::VectorXd> out(cases.size());
  pool.parallelFor(cases.size(), [&](std::size_t i) { out[i] = cases[i](coefficients); });
  return out;
}

}  // namespace

std::pair<double, double> rmsErrors(const std::vector<LandingResidual>& residuals) {
  double v = 0.0, w = 0.0;
  for (const auto& r : residuals) {
    v += r.head<3>().squaredNorm();
    w += r.tail<3>().squaredNorm();
  }
  const double n = std::max<std::size_t>(1, residuals.size());
  return {std::sqrt(v / n), std::sqrt(w / n)};
}

double rmsOfCases(const std::vector<Eigen::VectorXd>& residuals) {
  double sum = 0.0;
  for (const auto& r : residuals) sum += r.squaredNorm();
  return std::sqrt(sum / std::max<std::size_t>(1, residuals.size()));
}

std::vector<LandingResidual> landingResiduals(const std::vector<ObjectLandings>& objects,
                                              const Coefficients& coefficients,
                                              const PredictionOptions& options,
                                              core::WorkerPool& pool) {
  std::vector<std::unique_ptr<LandingPredictor>> keep;
  const auto cases = landingCases(objects, options, keep);
  std::vector<LandingResidual> out;
  for (const auto& r : caseResiduals(cases, coefficients, pool)) out.push_back(r);
  return out;
}

IdentificationResult identifyCoefficients(const std::vector<ObjectLandings>& objects,
                                          const IdentificationOptions& options,
                                          core::WorkerPool& pool) {
  std::vector<std::unique_ptr<LandingPredictor>> keep;
  const auto cases = landingCases(objects, options.prediction, keep);
  if (cases.empty()) throw std::invalid_argument("identifyCoefficients: no landing to fit");
  std::vector<int> sizes(cases.size(), 6);
  IdentificationResult result = identifyCases(cases, sizes, options, pool);
  for (const auto& r : result.case_residuals) result.residuals.push_back(r);
  std::tie(result.rms_linear, result.rms_angular) = rmsErrors(result.residuals);
  return result;
}

IdentificationResult identifyCases(const std::vector<CaseResidual>& case_residuals,
                                   const std::vector<int>& sizes,
                                   const IdentificationOptions& options, core::WorkerPool& pool) {
  if (!(options.loss_scale >= 0.0) || !(options.difference_step > 0.0) ||
      !(options.max_friction > 0.0) || options.max_iterations < 1 || options.starts < 1)
    throw std::invalid_argument(
        "identifyCoefficients: loss_scale must be >= 0, difference_step, max_friction and "
        "max_iterations > 0");
  if (case_residuals.empty()) throw std::invalid_argument("identifyCoefficients: no case to fit");
  if (sizes.size() != case_residuals.size())
    throw std::invalid_argument("identifyCoefficients: one residual size per case");
  std::vector<Case> cases;
  for (std::size_t i = 0; i < case_residuals.size(); ++i) {
    if (sizes[i] < 1) throw std::invalid_argument("identifyCoefficients: a residual size < 1");
    cases.push_back({&case_residuals[i], sizes[i]});
  }

  Parametrisation p{options.split_friction, options.fit_inertia_scale};
  const int n = p.size();
  Bounds bounds;
  bounds.lower = {0.0, 0.0};
  bounds.upper = {1.0, options.max_friction};
  if (p.split) {
    bounds.lower.push_back(0.0);
    bounds.upper.push_back(1.0);
  }
  if (p.inertia) {
    bounds.lower.push_back(0.2);
    bounds.upper.push_back(5.0);
  }
  std::vector<double> x = p.start(options.initial);
  for (int j = 0; j < n; ++j)
    if (!(x[j] >= bounds.lower[j] && x[j] <= bounds.upper[j]))
      throw std::invalid_argument("identifyCoefficients: the initial " + p.names()[j] +
                                  " is outside [" + std::to_string(bounds.lower[j]) + ", " +
                                  std::to_string(bounds.upper[j]) + "]");
  // Sum over landings of the Cauchy loss c^2 log(1 + |r|^2 / c^2) at x = y (Ceres' cost times 2).
  auto robustCost = [&](const std::vector<double>& y, double c) {
    const double c2 = c * c;
    std::vector<double> s(cases.size(), 0.0);
    pool.parallelFor(cases.size(), [&](std::size_t i) {
      try {
        const double r2 = (*cases[i].residual)(p.coefficients(y.data())).squaredNorm();
        s[i] = std::isfinite(r2) ? c2 * std::log1p(r2 / c2) : INFINITY;
      } catch (const std::exception&) {
        s[i] = INFINITY;
      }
    });
    double total = 0.0;
    for (double v : s) total += v;
    return total;
  };
  std::vector<std::vector<double>> starts;
  if (options.grid_start) {
    // The objective has several basins (the order of a landing's corner impacts changes with the
    // coefficients): start from the best of a coarse grid over (e, mu), the other parameters at
    // their initial values, under the first stage's loss.
    const double first = options.loss_scale == 0.0 ? kFirstLossScale : options.loss_scale;
    auto cost = [&](const std::vector<double>& y) { return robustCost(y, first); };
    std::vector<std::pair<double, std::vector<double>>> grid{{cost(x), x}};
    const std::vector<double> start = x;
    // With two friction coefficients, over r = mu_d / mu_s too: where a landing sticks is decided
    // by mu_s, how far it slides by mu_d, and from r = 1 alone the fit stays in the basin of one
    // mu (the stick thresholds make the objective a staircase in mu_s).
    const std::vector<double> ratios =
        p.split ? std::vector<double>{1.0, 0.6, 0.3} : std::vector<double>{1.0};
    for (double e : {0.1, 0.3, 0.5, 0.7, 0.9})
      for (double mu : {0.1, 0.2, 0.35, 0.5, 0.8})
        for (double r : ratios) {
          if (mu > options.max_friction) continue;
          std::vector<double> y = start;
          y[0] = e;
          y[1] = mu;
          if (p.split) y[2] = r;
          grid.emplace_back(cost(y), y);
        }
    std::sort(grid.begin(), grid.end());
    for (int k = 0; k < std::min<int>(options.starts, grid.size()); ++k)
      starts.push_back(grid[k].second);
  } else {
    starts.push_back(x);
  }

  LandingEvaluations evaluations(cases, p, bounds, options.difference_step, pool, x.data());
  ceres::Problem::Options problem_options;
  problem_options.evaluation_callback = &evaluations;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;  // one, shared
  ceres::Problem problem(problem_options);
  const bool automatic = options.loss_scale == 0.0;
  double scale = automatic ? kFirstLossScale : options.loss_scale;
  ceres::LossFunctionWrapper loss(new ceres::CauchyLoss(scale), ceres::TAKE_OWNERSHIP);
  for (std::size_t i = 0; i < cases.size(); ++i)
    problem.AddResidualBlock(new LandingCost(evaluations, i, cases[i].size, n), &loss, x.data());
  for (int j = 0; j < n; ++j) {
    problem.SetParameterLowerBound(x.data(), j, bounds.lower[j]);
    problem.SetParameterUpperBound(x.data(), j, bounds.upper[j]);
  }
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_QR;
  solver.max_num_iterations = options.max_iterations;
  solver.num_threads = 1;  // the landings run on the worker pool instead
  solver.logging_type = ceres::SILENT;
  solver.function_tolerance = 1e-7;
  solver.parameter_tolerance = 1e-6;
  Progress progress(options.progress);
  solver.callbacks.push_back(&progress);
  ceres::Solver::Summary summary;
  // The first stage from each start; the lowest final cost wins.
  int iterations = 0;
  double best_cost = INFINITY;
  std::vector<double> best = starts.front();
  for (const auto& start : starts) {
    std::copy(start.begin(), start.end(), x.begin());
    ceres::Solve(solver, &problem, &summary);
    iterations += static_cast<int>(summary.iterations.size());
    if (summary.final_cost < best_cost) {
      best_cost = summary.final_cost;
      best = x;
    }
  }
  std::copy(best.begin(), best.end(), x.begin());
  std::vector<double> norms;  // the first stage's |r| of each case, sorted (automatic scale)
  if (automatic) {
    // The second stage: the scale from the first fit's landings (twice the median |r|; a
    // landing that far off weighs half), then the fit again from the first one's optimum.
    const std::vector<Eigen::VectorXd> first =
        caseResiduals(case_residuals, p.coefficients(x.data()), pool);
    for (const auto& r : first) norms.push_back(r.norm());
    std::sort(norms.begin(), norms.end());
    scale = std::max(kMinimumLossScale, 2.0 * norms[norms.size() / 2]);
    loss.Reset(new ceres::CauchyLoss(scale), ceres::TAKE_OWNERSHIP);
    ceres::Solve(solver, &problem, &summary);
    iterations += static_cast<int>(summary.iterations.size());
  }

  // The objective is ragged on real data: a landing whose impact sequence changes with the
  // coefficients steps its residual, and the fit can stop in a local minimum beside a lower one
  // (docs/calibration.md, "How sure"). Scan e (and one mu) at fixed other parameters around the
  // fit, move to the lowest point if it is lower and fit again (twice at most).
  auto scanPlateau = [&](double c) {
    for (int pass = 0; pass < 2; ++pass) {
      const double here = robustCost(x, c);
      double lowest = here;
      std::vector<double> best_y;
      for (int j = 0; j < (p.split ? 1 : 2); ++j)
        for (int k = -kPlateauScanPoints; k <= kPlateauScanPoints; ++k) {
          if (k == 0) continue;
          std::vector<double> y = x;
          y[j] = x[j] + kPlateauScanStep * k;
          if (y[j] < bounds.lower[j] || y[j] > bounds.upper[j]) continue;
          const double cost = robustCost(y, c);
          if (cost < lowest) lowest = cost, best_y = y;
        }
      if (best_y.empty() || !(lowest < here - 1e-12 * std::max(1.0, here))) break;
      std::copy(best_y.begin(), best_y.end(), x.begin());
      ceres::Solve(solver, &problem, &summary);
      iterations += static_cast<int>(summary.iterations.size());
    }
  };
  scanPlateau(scale);

  // mu_s (two friction coefficients) acts only through the stick tests: between two landings'
  // stick thresholds it changes no prediction, across one it switches that landing from sliding
  // to sticking. The objective is a staircase in mu_s, which the differences' step (spanning
  // several thresholds) smooths into a slope whose minimum need not be the staircase's: scan
  // mu_s at fixed e and mu_d on a fine grid, move to the lowest step and fit again (twice at
  // most). The scan's points also give mu_s's interval below.
  std::vector<std::pair<double, double>> mu_s_scan;  // (mu_s, cost) in increasing mu_s
  auto scanStaticFriction = [&]() {
    mu_s_scan.clear();
    const double mu_d = x[1] * x[2];
    const double low = std::max(mu_d, x[1] - kStaticScanHalfWidth);
    const double high = std::min(options.max_friction, x[1] + kStaticScanHalfWidth);
    for (int k = 0; k <= kStaticScanPoints; ++k) {
      const double mu_s =
          k == kStaticScanPoints / 2 ? x[1] : low + (high - low) * k / kStaticScanPoints;
      std::vector<double> y = x;
      y[1] = mu_s;
      y[2] = mu_s > 0.0 ? mu_d / mu_s : 1.0;
      mu_s_scan.emplace_back(mu_s, robustCost(y, scale));
    }
    std::sort(mu_s_scan.begin(), mu_s_scan.end());
  };
  if (p.split) {
    for (int pass = 0; pass < 2; ++pass) {
      scanStaticFriction();
      const double here = robustCost(x, scale);
      const auto best =
          std::min_element(mu_s_scan.begin(), mu_s_scan.end(),
                           [](const auto& a, const auto& b) { return a.second < b.second; });
      if (!(best->second < here - 1e-12 * std::max(1.0, here))) break;
      const double mu_d = x[1] * x[2];
      x[1] = best->first;
      x[2] = best->first > 0.0 ? mu_d / best->first : 1.0;
      ceres::Solve(solver, &problem, &summary);
      iterations += static_cast<int>(summary.iterations.size());
    }
    scanStaticFriction();
  }

  IdentificationResult result;
  result.coefficients = p.coefficients(x.data());
  result.parameter_names = p.names();
  result.landings = static_cast<int>(cases.size());
  result.loss_scale = result.loss_scale_low = result.loss_scale_high = scale;
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.summary = summary.BriefReport();
  result.case_residuals = caseResiduals(case_residuals, result.coefficients, pool);
  result.rms_cases = rmsOfCases(result.case_residuals);

  // The residuals' scale, robustly: the median over cases of |r|^2 over the median of a
  // chi-square with as many degrees of freedom as the case has residuals (5.348 for a landing's
  // 6), i.e. the variance of one residual component if the bulk of the cases had independent
  // Gaussian residuals. Landings far off (a chaotic sequence of corner impacts, a tracking glitch)
  // neither set the scale nor, downweighted by the loss, carry much information
  // (docs/calibration.md, "How sure").
  std::vector<double> squares;
  int total = 0;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    squares.push_back(result.case_residuals[i].squaredNorm() / chiSquareMedian(cases[i].size));
    total += cases[i].size;
  }
  std::nth_element(squares.begin(), squares.begin() + squares.size() / 2, squares.end());
  const double dof_correction = static_cast<double>(total) / std::max(1, total - n);
  result.residual_sigma = std::sqrt(squares[squares.size() / 2] * dof_correction);

  result.covariance = Eigen::MatrixXd::Constant(n, n, std::numeric_limits<double>::infinity());
  ceres::Covariance::Options covariance_options;
  covariance_options.algorithm_type = ceres::DENSE_SVD;
  covariance_options.null_space_rank = 0;
  covariance_options.num_threads = 1;
  ceres::Covariance covariance(covariance_options);
  std::vector<std::pair<const double*, const double*>> blocks{{x.data(), x.data()}};
  if (covariance.Compute(blocks, &problem)) {
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> c(n, n);
    if (covariance.GetCovarianceBlock(x.data(), x.data(), c.data()))
      result.covariance = result.residual_sigma * result.residual_sigma * c;
  }

  // The automatic scale is itself an estimate: twice the median of the first stage's |r|, which
  // the landings' sampling (and round-off in the first fit) moves. Its one-standard-deviation
  // range, distribution-free: the rank of the population median among n cases is binomial(n,
  // 1/2), of deviation sqrt(n) / 2, so the order statistics that many ranks either side of the
  // median bracket it by one deviation. Refit at both ends (warm from the optimum, the landings'
  // predictors reused, with the scan above) and add the optimum's change, d = (x(c_high) -
  // x(c_low)) / 2, the parameters' deviation due to the scale if x(c) is about linear over the
  // range, to the covariance as d d^T (independent of the noise part to first order: the scale is
  // a median of the residuals, the covariance's part the fit's slope at a fixed scale).
  if (automatic && options.loss_scale_uncertainty && norms.size() >= 2) {
    const int m = static_cast<int>(norms.size());
    const double ranks = 0.5 * std::sqrt(static_cast<double>(m));
    const int low_rank = std::max(0, static_cast<int>(std::lround(m / 2 - ranks)));
    const int high_rank = std::min(m - 1, static_cast<int>(std::lround(m / 2 + ranks)));
    result.loss_scale_low = std::max(kMinimumLossScale, 2.0 * norms[low_rank]);
    result.loss_scale_high = std::max(kMinimumLossScale, 2.0 * norms[high_rank]);
    const std::vector<double> optimum = x;
    auto refit = [&](double c) {
      std::copy(optimum.begin(), optimum.end(), x.begin());
      loss.Reset(new ceres::CauchyLoss(c), ceres::TAKE_OWNERSHIP);
      ceres::Solve(solver, &problem, &summary);
      iterations += static_cast<int>(summary.iterations.size());
      scanPlateau(c);
      return x;
    };
    const std::vector<double> low = refit(result.loss_scale_low);
    const std::vector<double> high = refit(result.loss_scale_high);
    std::copy(optimum.begin(), optimum.end(), x.begin());
    loss.Reset(new ceres::CauchyLoss(scale), ceres::TAKE_OWNERSHIP);
    result.loss_scale_shift.resize(n);
    for (int j = 0; j < n; ++j) result.loss_scale_shift[j] = 0.5 * (high[j] - low[j]);
    result.covariance += result.loss_scale_shift * result.loss_scale_shift.transpose();
  }
  result.iterations = iterations;

  // The coefficients' estimates: mu_d = r mu_s by the delta method.
  auto estimate = [&](const std::string& name, double value, double variance, bool at_bound) {
    CoefficientEstimate e;
    e.name = name;
    e.value = value;
    e.std_dev = std::sqrt(std::max(0.0, variance));
    if (!std::isfinite(variance)) e.std_dev = std::numeric_limits<double>::infinity();
    e.lower = value - 1.96 * e.std_dev;
    e.upper = value + 1.96 * e.std_dev;
    e.at_bound = at_bound;
    result.estimates.push_back(e);
  };
  auto onBound = [&](int j) { return x[j] <= bounds.lower[j] || x[j] >= bounds.upper[j]; };
  const Eigen::MatrixXd& C = result.covariance;
  estimate("restitution", x[0], C(0, 0), onBound(0));
  estimate("static_friction", x[1], C(1, 1), onBound(1));
  if (p.split && !mu_s_scan.empty()) {
    // The interval of mu_s also covers the scanned values whose cost is within the 95 % chi-square
    // bound of the lowest: 3.84 sigma^2 on the sum of the losses (Ceres' cost is half of it), the
    // flat step of the staircase the data cannot narrow (contiguous around the fit).
    const double bound = 3.84 * result.residual_sigma * result.residual_sigma;
    double lowest = INFINITY;
    for (const auto& [mu, c] : mu_s_scan) lowest = std::min(lowest, c);
    std::size_t at = 0;
    for (std::size_t k = 0; k < mu_s_scan.size(); ++k)
      if (std::abs(mu_s_scan[k].first - x[1]) < std::abs(mu_s_scan[at].first - x[1])) at = k;
    std::size_t from = at, to = at;
    while (from > 0 && mu_s_scan[from - 1].second - lowest <= bound) --from;
    while (to + 1 < mu_s_scan.size() && mu_s_scan[to + 1].second - lowest <= bound) ++to;
    CoefficientEstimate& e = result.estimates.back();
    e.lower = std::min(e.lower, mu_s_scan[from].first);
    e.upper = std::max(e.upper, mu_s_scan[to].first);
    // A flat step reaching the scan's upper end: the data do not bound mu_s above (every landing
    // that could stick does); at its lower end the scan stops at mu_d, the parameter's bound.
    if (to + 1 == mu_s_scan.size() && mu_s_scan[to].first < options.max_friction)
      e.upper = std::numeric_limits<double>::infinity();
  }
  if (p.split) {
    Eigen::Vector2d g(x[2], x[1]);  // d(r mu)/d(mu, r)
    estimate("dynamic_friction", x[1] * x[2], g.dot(C.block<2, 2>(1, 1) * g),
             onBound(1) || onBound(2));
  } else {
    estimate("dynamic_friction", x[1], C(1, 1), onBound(1));
  }
  if (p.inertia) estimate("inertia_scale", x[n - 1], C(n - 1, n - 1), onBound(n - 1));
  return result;
}

}  // namespace collision_response::calibration
