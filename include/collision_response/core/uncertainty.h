#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "collision_response/core/body_model.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/contact_uncertainty.h"
#include "collision_response/core/outcome_distribution.h"
#include "collision_response/core/scene.h"
#include "collision_response/core/solver_options.h"
#include "collision_response/core/worker_pool.h"

namespace collision_response::core {

/// Largest sample count of UncertaintyOptions::samples.
constexpr std::size_t kMaxUncertaintySamples = 100000;
/// Largest outcome (rows: 6 per movable body or its velocity unknowns, 4 per contact): the
/// covariance alone is rows^2 doubles (32 MB at the cap).
constexpr long kMaxOutcomeRows = 2048;
/// Largest rows x samples a sampled distribution keeps (8 bytes each: 256 MB at the cap).
constexpr long kMaxSampledValues = 1L << 25;

struct UncertaintyOptions {
  UncertaintyMethod method = UncertaintyMethod::kLinear;
  /// kSampled: solves, in [1, kMaxUncertaintySamples]. ROS: options.uncertainty_samples.
  std::size_t samples = 1024;
  /// kSampled: seed of the scrambling of the Halton sequence (the same seed, the same answer).
  std::uint64_t seed = 0x5eed;
};

/// The distribution of the post-impact twists and contact impulses of `scene` when the contacts'
/// coefficients follow `uncertainties` (docs/uncertainty.md).
///
/// kLinear: the coefficients' means (truncated normals: their own means) in the scene, the
/// derivatives there (computeImpactDerivatives()), mean = the prediction at the means, covariance
/// = J S J^T with S the coefficients' variances (independent). kSampled: points of a scrambled
/// Halton sequence (one dimension per uncertain coefficient) through the coefficients' quantile
/// functions, each sample solved by computeResponse() with `options`, spread over `pool` (nullptr:
/// the calling thread); mean, covariance (divided by N - 1) and quantiles of the samples. A sample
/// whose mu_d exceeds its mu_s is solved with mu_d = mu_s (Coulomb's law needs mu_d <= mu_s): the
/// warnings give the fraction of samples (kSampled) or the probability (kLinear, which does not
/// see the cap) per contact. An uncertain normal or point (ContactUncertainty), kSampled: two more
/// dimensions per normal and one per uncertain axis of a point, after the coefficients' (so a
/// request's coefficient samples do not change when a normal becomes uncertain), set on the
/// sample's contact before the solve; kLinear: the same dimensions as columns of J after the
/// coefficients', each a central difference of the solver (the normal tilted along a tangent, the
/// point moved along its axis, by a step of at most 1e-6 rad or 1e-6 max(1, |p|_inf) m and of
/// sd / 100), one-sided where one side changes a contact's mode (no impulse, sliding, sticking),
/// the secant over +-1 sd where both sides do or the outcome jumps, with a warning naming the
/// dimension's field for either.
///
/// Throws InvalidInput naming the field: the scene (as validate()), "uncertainties[k].contact"
/// (out of range or repeated), "uncertainties[k].restitution.std_dev" ... (CheckedDistribution),
/// "uncertainties[k].dynamic_friction.mean" when the mean of mu_d exceeds that of mu_s,
/// "uncertainties[k].normal_std_dev" / ".point_std_dev.x|y|z" when negative, not finite or above
/// pi/2 rad / 1e7 m,
/// "options.uncertainty" (kNone), "options.uncertainty_samples" (0 or over the cap, or rows x
/// samples over kMaxSampledValues), "uncertainties" (an outcome of more than kMaxOutcomeRows rows).
/// SolverTimeout when the whole call runs past options.time_budget (kSampled: each sample gets what
/// is left of it).
OutcomeDistribution computeOutcomeDistribution(const Scene& scene,
                                               const std::vector<ContactUncertainty>& uncertainties,
                                               const SolverOptions& options = {},
                                               const UncertaintyOptions& uncertainty = {},
                                               WorkerPool* pool = nullptr,
                                               const RequestLimits& limits = {});

/// The distribution of the impact of general bodies (body_model.h: robots and free rigid
/// bodies, as computeBodyResponse() solves them) when the contacts' coefficients follow
/// `uncertainties` (uncertainties[k].contact indexes `contacts`; docs/uncertainty.md, "Robots").
///
/// `copies[k]` is a full set of the bodies (copies[k][b] the k-th copy of body b), every set at the
/// same pre-impact velocities; each set is used by one task at a time, so the samples are split
/// into copies.size() parts spread over `pool` (nullptr: one after the other on the calling
/// thread). Every sample (points of the scrambled Halton sequence through the coefficients'
/// quantile functions, as computeOutcomeDistribution()) is solved by computeBodyResponse() with
/// `options`, and its copy set back to the pre-impact velocities; the copies end as they began.
///
/// Quantities, as the rows of BodyImpactDerivatives: every body's velocity unknowns
/// (BodyModel::velocity()) body after body, labelled "velocities[r]"; then per contact
/// "impulses[c].normal_impulse", "impulses[c].friction_impulse.x/y/z" [N s, world] (the caller
/// names the velocities). `velocity_limits`: one per velocity unknown (+infinity: none);
/// kSampled: OutcomeDistribution::limit_probability[r] is the fraction of samples with |v_r| >
/// limit_r.
///
/// kLinear: computeBodyImpactDerivatives() on copies[0] at the coefficients' means (the other
/// copies are not used), mean = its prediction, covariance = J S J^T over the uncertain
/// coefficients' columns, quantiles and stick probabilities and warnings as
/// computeOutcomeDistribution()'s kLinear (a sliding contact's margin from its held answer
/// under Newton's law, else from its slip, read from the bodies' point Jacobians); limit_probability[r] = P(|v_r| > limit_r) under N(mean_r, covariance_rr) (sd = 0:
/// exactly 0 or 1); copies[0] ends at its pre-impact velocities, also when the call throws. An
/// uncertain normal or point as computeOutcomeDistribution()'s kLinear takes it (differences of
/// computeBodyResponse() on copies[0], the robot's Jacobian taken at the moved point).
///
/// Throws as computeOutcomeDistribution() for the uncertainties, options.uncertainty_samples and
/// the time budget; std::invalid_argument when copies is empty, the sets differ in size or
/// velocity_limits has the wrong length.
OutcomeDistribution computeBodyOutcomeDistribution(
    const std::vector<std::vector<BodyModel*>>& copies, const std::vector<ContactPoint>& contacts,
    const std::vector<ContactUncertainty>& uncertainties, const Eigen::VectorXd& velocity_limits,
    const SolverOptions& options = {}, const UncertaintyOptions& uncertainty = {},
    WorkerPool* pool = nullptr);

}  // namespace collision_response::core
