// The identification on the real cube tosses (benchmark/data/cube_tosses; docs/benchmarks.md, "Real
// tosses"), on the first kTosses tosses to keep the test short (the benchmark and `identify` use
// all 570): fitted on the even-numbered tosses, it predicts the odd-numbered ones better than the
// data set authors' coefficients (e 0.125, mu 0.18: the data's SOURCE); and with plain least
// squares (the benchmark's objective) its 95 % intervals hold the values the real-tosses
// benchmark's own fit finds on the same landings (benchmark/landing_fit.h: Nelder-Mead from 4
// starts over its own cube-corner episode model, landing_ours.h), an independent optimiser and
// geometry. On all 570 tosses the benchmark reports e 0.335, mu 0.230 (benchmark/RESULTS.md, "Real
// tosses": episode, stronge, mu); docs/calibration.md gives identify's values there. And the same
// cube given as a box and as an 8-vertex mesh (the same solid) is fitted to coefficients that lie
// within each other's intervals (the first kMeshTosses tosses).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "collision_response/calibration/csv_tracks.h"
#include "collision_response/calibration/identification.h"
#include "collision_response/calibration/landing_extraction.h"
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
