// The identification on the real cube tosses (benchmark/data/cube_tosses; docs/benchmarks.md, "Real
// tosses"), on the first kTosses tosses to keep the test short (the benchmark and `identify` use
// all 570): fitted on the even-numbered tosses, it predicts the odd-numbered ones better than the
// data set authors' coefficients (e 0.125, mu 0.18: the data's SOURCE); and with plain least
// squares (the benchmark's objective) its 95 % intervals hold the values the real-tosses
// benchmark's own fit finds on the same landings (benchmark/landing_fit.h: Nelder-Mead from 4
// starts over its own cube-corner episode model, landing_ours.h), an independent optimiser and
// geometry. On all 570 tosses the benchmark reports e 0.335, mu 0.230 (benchmark/RESULTS.md, "Real
// tosses": episode, stronge, mu); docs/calibration.md gives identify's values there.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "collision_response/calibration/csv_tracks.h"
#include "collision_response/calibration/identification.h"
#include "collision_response/calibration/landing_extraction.h"
#include "landing_fit.h"
#include "landing_ours.h"

using namespace collision_response;
using namespace collision_response::calibration;

namespace {

constexpr int kTosses = 200;

TEST(CubeTosses, EvenTossesPredictOddOnesBetterThanTheAuthorsCoefficients) {
  ObjectModel cube;
  cube.source = "cube";
  cube.shape.type = detection::Shape::Type::kBox;
  cube.shape.dimensions.assign(3, 0.1048);
  cube.mass = 0.37;
  cube.inertia = uniformInertia(cube.shape, cube.mass);
  std::vector<ObjectLandings> even{{cube, {}}}, odd{{cube, {}}};
  for (const auto& t : readCsvTracks(TOSS_DATA)) {
    if (t.number >= kTosses) break;
    const Extraction x = extractLandings(t.track, cube.shape, std::nullopt).front();
    if (x.ok) (t.number % 2 == 0 ? even : odd)[0].landings.push_back(x.landing);
  }
  ASSERT_GT(even[0].landings.size(), 40u);
  ASSERT_GT(odd[0].landings.size(), 40u);
  core::WorkerPool pool(2);
  const IdentificationOptions options;  // the episode, Stronge's law, one mu, automatic loss
  const IdentificationResult fit = identifyCoefficients(even, options, pool);
  const auto held_out =
      rmsErrors(landingResiduals(odd, fit.coefficients, options.prediction, pool));
  Coefficients authors;
  authors.restitution = 0.125;
  authors.static_friction = authors.dynamic_friction = 0.18;
  const auto theirs = rmsErrors(landingResiduals(odd, authors, options.prediction, pool));
  std::printf(
      "%zu even landings: e %.4f [%.4f, %.4f], mu %.4f [%.4f, %.4f]; odd (%zu) RMS v %.3f "
      "w %.3f; with e 0.125, mu 0.18: v %.3f w %.3f\n",
      even[0].landings.size(), fit.estimates[0].value, fit.estimates[0].lower,
      fit.estimates[0].upper, fit.estimates[1].value, fit.estimates[1].lower,
      fit.estimates[1].upper, odd[0].landings.size(), held_out.first, held_out.second, theirs.first,
      theirs.second);
  // Better in the fit's objective (v and w together: the benchmark's); the authors' coefficients
  // happen to predict w alone about as well (their low e leaves the spin nearly unchanged).
  auto combined = [](std::pair<double, double> e) {
    return std::sqrt(0.5 * (e.first * e.first + e.second * e.second));
  };
  EXPECT_LT(combined(held_out), 0.85 * combined(theirs));
  EXPECT_LT(held_out.first, theirs.first);
  // The held-out errors are near those the benchmark reports for the episode on all odd tosses
  // (RMS v 0.115, w 0.121), to within a quarter (another subset of landings).
  EXPECT_NEAR(held_out.first, 0.115, 0.25 * 0.115);
  EXPECT_NEAR(held_out.second, 0.121, 0.25 * 0.121);

  // Plain least squares (a loss scale far above every residual) against the benchmark's fit.
  IdentificationOptions plain = options;
  plain.loss_scale = 100.0;
  const IdentificationResult ls = identifyCoefficients(even, plain, pool);
  auto model = bench::makeEpisodeLanding(bench::TossedCube(), core::ImpactLaw::kStronge, false);
  const bench::FitResult reference = bench::fitLandingModel(*model, even[0].landings, {});
  std::printf(
      "least squares: e %.4f [%.4f, %.4f], mu %.4f [%.4f, %.4f]; benchmark's fit: e %.4f "
      "mu %.4f\n",
      ls.estimates[0].value, ls.estimates[0].lower, ls.estimates[0].upper, ls.estimates[1].value,
      ls.estimates[1].lower, ls.estimates[1].upper, reference.values[0], reference.values[1]);
  EXPECT_LE(ls.estimates[0].lower, reference.values[0]);
  EXPECT_GE(ls.estimates[0].upper, reference.values[0]);
  EXPECT_LE(ls.estimates[1].lower, reference.values[1]);
  EXPECT_GE(ls.estimates[1].upper, reference.values[1]);
}

}  // namespace
