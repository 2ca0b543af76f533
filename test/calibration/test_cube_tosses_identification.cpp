// The identification on the real cube tosses (benchmark/data/cube_tosses; docs/benchmarks.md, "Real
// tosses"), on the first kTosses tosses to keep the test short (the benchmark and `identify` use
// all 570): fitted on the even-numbered tosses, it predicts the odd-numbered ones better than the
// data set authors' coefficients (e 0.125, mu 0.18: the data's SOURCE); and with plain least
// squares (the benchmark's objective) its 95 % intervals hold the values the real-tosses
// benchmark's own fit finds on the same landings (benchmark/landing_fit.h: Nelder-Mead from 4
// starts over its own cube-corner episode model, landing_ours.h), an independent optimiser and
// geometry. On all 570 tosses the benchmark reports e 0.336, mu 0.229 (benchmark/RESULTS.md, "Real
// tosses": episode, stronge, mu); docs/calibration.md gives identify's values there. And the same
// cube given as a box and as an 8-vertex mesh (the same solid) is fitted to coefficients that lie
// within each other's intervals (the first kMeshTosses tosses).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include "collision_response/calibration/csv_tracks.h"
#include "collision_response/calibration/identification.h"
#include "collision_response/calibration/landing_extraction.h"
#include "collision_response/calibration/landing_prediction.h"
#include "collision_response/calibration/object_model.h"
#include "landing_fit.h"
#include "landing_ours.h"

using namespace collision_response;
using namespace collision_response::calibration;

namespace {

constexpr int kTosses = 200;
/// The box-and-mesh comparison's tosses (227 landings): without the scan for the local minima
/// beside the fit (identification.cpp) the two fits stopped at e 0.3301 and 0.2991 here (on all 570
/// at 0.3228 and 0.3354), each outside the other's interval; on the first 300 they agreed anyway.
constexpr int kMeshTosses = 400;

/// The tossed cube as a box: 0.1048 m, 0.37 kg, the uniform solid's inertia.
ObjectModel tossedCube(const std::string& source) {
  ObjectModel cube;
  cube.source = source;
  cube.shape.type = detection::Shape::Type::kBox;
  cube.shape.dimensions.assign(3, 0.1048);
  cube.mass = 0.37;
  cube.inertia = uniformInertia(cube.shape, cube.mass);
  return cube;
}

TEST(CubeTosses, EvenTossesPredictOddOnesBetterThanTheAuthorsCoefficients) {
  const ObjectModel cube = tossedCube("cube");
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
  const auto held_out_residuals = landingResiduals(odd, fit.coefficients, options.prediction, pool);
  const auto held_out = rmsErrors(held_out_residuals);
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
  // The held-out errors are those of the real-tosses benchmark's own episode model (cube corners
  // against the plane, landing_ours.h: another geometry and gap query) at the same coefficients
  // on the same landings: the medians to within 3 %. Not the RMS: at these coefficients the
  // landing of toss 107, which pivots for 0.15 s, ends in sustained contact here and is flown on
  // through the floor (0.60 off; the benchmark's model follows it to its flight: 0.121 at these
  // coefficients), and that one landing makes the RMS 0.123 against 0.101 (docs/calibration.md,
  // "Prediction and residual": the rigid episode does not follow a sustained contact on).
  {
    auto bench_model =
        bench::makeEpisodeLanding(bench::TossedCube(), core::ImpactLaw::kStronge, false);
    const bench::LandingScore score =
        bench::scoreLandingModel(*bench_model, {fit.estimates[0].value, fit.estimates[1].value},
                                 odd[0].landings, bench::TossedCube(), 0);
    std::vector<double> v, w;
    for (const LandingResidual& r : held_out_residuals) {
      v.push_back(r.head<3>().norm());
      w.push_back(r.tail<3>().norm());
    }
    std::printf(
        "median v %.4f w %.4f; the benchmark's episode model at these coefficients: median v "
        "%.4f w %.4f, RMS v %.3f w %.3f\n",
        bench::median(v), bench::median(w), score.median_linear, score.median_angular,
        score.rms_linear, score.rms_angular);
    EXPECT_NEAR(bench::median(v), score.median_linear, 0.03 * score.median_linear);
    EXPECT_NEAR(bench::median(w), score.median_angular, 0.03 * score.median_angular);
  }

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

// Toss 107 lands on a corner and tumbles over it and an edge for 0.15 s before it flies again
// (|v| 1.55 -> 0.75 m/s). The real-tosses benchmark's episode model (cube corners against the
// plane) follows the pivot as plastic touches of the corner, one every 0.08 ms, some 1,700 of them:
// with the episodes' default cap of 100 impacts it stopped after 8 ms of pivoting and flew on
// through the floor, 0.93 of the pre-impact speed off the measured velocity, the benchmark's
// largest error by far (it made the episode's RMS; landing_ours.cpp, kEpisodeImpactCap). The
// reference is the measurement: at the benchmark's fitted coefficients (e 0.336, mu 0.229) that
// model, and the calibration's (detection's box against the plane, whose contact manifolds follow
// the pivot in fewer impacts; it does not reach the cap), lie within the spread of the other
// landings' errors. Only at these coefficients: at others (e 0.2855, mu 0.2137, the test above)
// the calibration's episode of this landing ends in sustained contact (0.60 off).
TEST(CubeTosses, ALandingThatPivotsForATenthOfASecondIsFollowedToItsEnd) {
  const ObjectModel cube = tossedCube("cube");
  std::optional<Landing> landing;
  for (const auto& t : readCsvTracks(TOSS_DATA)) {
    if (t.number != 107) continue;
    const Extraction x = extractLandings(t.track, cube.shape, std::nullopt).front();
    ASSERT_TRUE(x.ok) << x.reason;
    landing = x.landing;
    break;
  }
  ASSERT_TRUE(landing.has_value());
  ASSERT_GT(landing->t_after - landing->t_before, 0.15);
  Coefficients c;
  c.restitution = 0.336;
  c.static_friction = c.dynamic_friction = 0.229;
  const double calibration = LandingPredictor(cube, PredictionOptions())  // episode, Stronge
                                 .residual(*landing, c)
                                 .head<3>()
                                 .norm();
  auto model = bench::makeEpisodeLanding(bench::TossedCube(), core::ImpactLaw::kStronge, false);
  const double benchmark = bench::landingError(*model, {c.restitution, c.dynamic_friction},
                                               *landing, bench::TossedCube())
                               .linear;
  std::printf("toss 107: |v| error %.3f (benchmark's model), %.3f (calibration's)\n", benchmark,
              calibration);
  // The benchmark's held-out errors: RMS 0.089, the largest 0.174.
  EXPECT_LT(benchmark, 0.25);
  EXPECT_LT(calibration, 0.25);
}

/// The cube as a closed 8-vertex mesh (ObjectModel's kMesh): vertex k at half the side times
/// (+-1, +-1, +-1), x from bit 2 of k, y bit 1, z bit 0; its 12 triangles wound outward. The same
/// solid as the box, so its predictions equal the box's up to round-off.
detection::Shape cubeMesh(double side) {
  detection::Shape mesh;
  mesh.type = detection::Shape::Type::kMesh;
  for (int k = 0; k < 8; ++k)
    mesh.vertices.push_back(0.5 * side *
                            Eigen::Vector3d(k & 4 ? 1 : -1, k & 2 ? 1 : -1, k & 1 ? 1 : -1));
  mesh.triangles = {{0, 3, 2}, {0, 1, 3}, {4, 6, 7}, {4, 7, 5}, {0, 4, 5}, {0, 5, 1},
                    {2, 7, 6}, {2, 3, 7}, {0, 6, 4}, {0, 2, 6}, {1, 5, 7}, {1, 7, 3}};
  return mesh;
}

// The same cube given as a box and as an 8-vertex mesh: the two models are the same solid (a
// symmetry of the input, not of the fit), so each fit, at its own automatic loss scale, must lie
// within the other's 95 % intervals. The objective is ragged on real data, and round-off decides
// in which of its small dips a fit stops unless the fit looks for the lowest one nearby
// (docs/calibration.md, "Local minima beside the fit" and "How sure").
TEST(CubeTosses, BoxAndMeshFitsLieInEachOthersIntervals) {
  // The sanitizer pass (CR_CALIBRATION_SMALL=1, scripts/sanitize.sh) skips it: two fits of 227
  // landings take minutes under instrumentation, and the scan it checks runs in every identify
  // test there too.
  if (std::getenv("CR_CALIBRATION_SMALL") != nullptr)
    GTEST_SKIP() << "CR_CALIBRATION_SMALL: the full-size fits run in the normal build";
  const ObjectModel box = tossedCube("box");
  ObjectModel mesh = box;
  mesh.source = "mesh";
  mesh.shape = cubeMesh(0.1048);
  mesh.inertia = uniformInertia(mesh.shape, mesh.mass);  // equal to the box's to round-off
  ASSERT_EQ(meshProblem(mesh.shape), "");
  ASSERT_TRUE(uniformInertia(mesh.shape, mesh.mass).isApprox(box.inertia, 1e-12));
  std::vector<ObjectLandings> as_box{{box, {}}}, as_mesh{{mesh, {}}};
  for (const auto& t : readCsvTracks(TOSS_DATA)) {
    if (t.number >= kMeshTosses) break;
    const Extraction b = extractLandings(t.track, box.shape, std::nullopt).front();
    const Extraction m = extractLandings(t.track, mesh.shape, std::nullopt).front();
    if (b.ok) as_box[0].landings.push_back(b.landing);
    if (m.ok) as_mesh[0].landings.push_back(m.landing);
  }
  ASSERT_EQ(as_box[0].landings.size(), as_mesh[0].landings.size());
  core::WorkerPool pool(2);
  const IdentificationOptions options;  // Stronge's law, one mu, the automatic loss scale
  const IdentificationResult fits[2] = {identifyCoefficients(as_box, options, pool),
                                        identifyCoefficients(as_mesh, options, pool)};
  for (const auto& f : fits)
    std::printf("%d landings, loss scale %.4f: e %.4f [%.4f, %.4f], mu %.4f [%.4f, %.4f]\n",
                f.landings, f.loss_scale, f.estimates[0].value, f.estimates[0].lower,
                f.estimates[0].upper, f.estimates[1].value, f.estimates[1].lower,
                f.estimates[1].upper);
  for (int k = 0; k < 2; ++k)
    for (int j : {0, 1}) {  // restitution, friction
      const CoefficientEstimate &mine = fits[k].estimates[j], &other = fits[1 - k].estimates[j];
      EXPECT_LE(other.lower, mine.value) << mine.name << (k == 0 ? " box" : " mesh");
      EXPECT_GE(other.upper, mine.value) << mine.name << (k == 0 ? " box" : " mesh");
    }
}

}  // namespace
