// The real-tosses benchmark's landing extraction (benchmark/toss_data.h): on a synthetic toss made
// from closed-form flights (the fits must recover the generating states), and on the real data
// (the fits at the tracking noise, no landing gaining energy, the number kept in its documented
// range).
#include <gtest/gtest.h>

#include <cmath>

#include "toss_data.h"

using namespace collision_response::bench;

namespace {

constexpr double kG = -9.81;
constexpr double kFrame = 1.0 / 148.0;

Eigen::Quaterniond turn(const Eigen::Vector3d& v) {
  const double a = v.norm();
  return a == 0.0 ? Eigen::Quaterniond::Identity()
                  : Eigen::Quaterniond(Eigen::AngleAxisd(a, v / a));
}

/// Closed-form free flight from (p, v, q, w) at time t0, evaluated at time t.
struct Flight {
  double t0;
  Eigen::Vector3d p, v, w;
  Eigen::Quaterniond q;
  Eigen::Vector3d position(double t) const {
    const double s = t - t0;
    return p + s * v + 0.5 * s * s * Eigen::Vector3d(0, 0, kG);
  }
  Eigen::Vector3d velocity(double t) const { return v + (t - t0) * Eigen::Vector3d(0, 0, kG); }
  Eigen::Quaterniond orientation(double t) const { return turn(w * (t - t0)) * q; }
};

/// A toss with the table at z = table: 15 frames of flight A, 3 frames with a corner on the
/// table, 8 frames of flight B (rising), 12 frames at rest flat on a face.
TossFrames syntheticToss(double table, const Flight& a, Flight& b) {
  const double h = TossedCube().half_width;
  TossFrames toss;
  toss.index = 7;
  int k = 0;
  auto add = [&](const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
    toss.time.push_back(k++ * kFrame);
    toss.position.push_back(p);
    toss.orientation.push_back(q);
  };
  for (int i = 0; i < 15; ++i) add(a.position(k * kFrame), a.orientation(k * kFrame));
  const Eigen::Quaterniond touching = a.orientation(14 * kFrame);
  for (int i = 0; i < 3; ++i) {
    Eigen::Vector3d p = a.position(14 * kFrame);
    p.z() += table - lowestCornerHeight(p, touching, h);
    add(p, touching);
  }
  b.t0 = k * kFrame;
  b.p.z() += table - lowestCornerHeight(b.p, b.q, h) + 0.003;  // starts 3 mm above the table
  for (int i = 0; i < 8; ++i) add(b.position(k * kFrame), b.orientation(k * kFrame));
  for (int i = 0; i < 12; ++i)
    add(Eigen::Vector3d(0.3, 0.1, table + h), Eigen::Quaterniond::Identity());
  return toss;
}

}  // namespace

TEST(TossExtraction, RecoversTheClosedFormFlightsOfASyntheticToss) {
  const double table = -0.0023;
  const Flight a{0.0, Eigen::Vector3d(0.1, 0.2, 0.35), Eigen::Vector3d(-1.0, 0.4, -1.2),
                 Eigen::Vector3d(3.0, -5.0, 2.0),
                 Eigen::Quaterniond(0.9, 0.2, -0.3, 0.25).normalized()};
  Flight b{0.0, Eigen::Vector3d(-0.05, 0.25, 0.1), Eigen::Vector3d(-0.6, 0.3, 0.5),
           Eigen::Vector3d(-8.0, 4.0, 1.0), Eigen::Quaterniond(0.7, -0.4, 0.1, 0.3).normalized()};
  const TossFrames toss = syntheticToss(table, a, b);
  const Extraction x = extractLanding(toss, TossedCube());
  ASSERT_TRUE(x.ok) << x.reason;
  const Landing& l = x.landing;
  EXPECT_NEAR(l.table, table, 1e-12);
  EXPECT_EQ(l.contact_frame, 15);
  EXPECT_NEAR(l.t_before, 14 * kFrame, 1e-12);
  EXPECT_NEAR(l.t_after, 18 * kFrame, 1e-12);
  EXPECT_LT(l.pre.position_rms, 1e-9);
  EXPECT_LT(l.post.rotation_rms, 1e-9);
  const Eigen::Vector3d shift(0, 0, -table);
  EXPECT_LT((l.before.position - (a.position(l.t_before) + shift)).norm(), 1e-9);
  EXPECT_LT((l.before.linear_velocity - a.velocity(l.t_before)).norm(), 1e-8);
  EXPECT_LT((l.before.angular_velocity - a.w).norm(), 1e-8);
  EXPECT_LT(l.before.orientation.angularDistance(a.orientation(l.t_before)), 1e-9);
  EXPECT_LT((l.after.position - (b.position(l.t_after) + shift)).norm(), 1e-9);
  EXPECT_LT((l.after.linear_velocity - b.velocity(l.t_after)).norm(), 1e-8);
  EXPECT_LT((l.after.angular_velocity - b.w).norm(), 1e-8);
  // The state at any time of a fitted flight is the closed form's.
  const CubeState later = l.post.stateAt(l.t_after + 0.02, kG);
  EXPECT_LT((later.linear_velocity - b.velocity(l.t_after + 0.02)).norm(), 1e-8);
  EXPECT_LT(later.orientation.angularDistance(b.orientation(l.t_after + 0.02)), 1e-9);
}

TEST(TossExtraction, DropsATossWhoseFlightAfterTheLandingIsTooShort) {
  Flight b{0.0, Eigen::Vector3d(-0.05, 0.25, 0.1), Eigen::Vector3d(-0.6, 0.3, 0.5),
           Eigen::Vector3d(-8.0, 4.0, 1.0), Eigen::Quaterniond::Identity()};
  const Flight a{0.0, Eigen::Vector3d(0.1, 0.2, 0.35), Eigen::Vector3d(-1.0, 0.4, -1.2),
                 Eigen::Vector3d(3.0, -5.0, 2.0), Eigen::Quaterniond::Identity()};
  TossFrames toss = syntheticToss(0.0, a, b);
  ExtractionOptions options;
  options.min_post_frames = 9;  // flight B has 8 frames
  const Extraction x = extractLanding(toss, TossedCube(), options);
  EXPECT_FALSE(x.ok);
  EXPECT_EQ(x.reason, "no clear flight after the landing");
}

TEST(TossExtraction, RealTossesAreSane) {
  const std::vector<TossFrames> tosses = readTosses(TOSS_DATA);
  ASSERT_EQ(tosses.size(), 570u);
  const TossedCube cube;
  const ExtractionOptions options;
  int kept = 0;
  for (const TossFrames& toss : tosses) {
    const Extraction x = extractLanding(toss, cube, options);
    if (!x.ok) continue;
    ++kept;
    const Landing& l = x.landing;
    // Pre-impact fits at the tracking noise (sub-millimetre; 2 mm would be a wrong window).
    EXPECT_LT(l.pre.position_rms, 0.002) << "toss " << l.recording;
    EXPECT_LT(l.pre.rotation_rms * cube.half_width, 0.002) << "toss " << l.recording;
    // A real landing does not gain energy (kinetic, uniform-cube inertia, plus potential).
    EXPECT_LE(cubeEnergy(l.after, cube, options.gravity_z),
              cubeEnergy(l.before, cube, options.gravity_z))
        << "toss " << l.recording;
    // The table is within a centimetre of the tracking frame's z = 0 (the data's description).
    EXPECT_LT(std::abs(l.table), 0.01) << "toss " << l.recording;
    // The pre-impact state is above the table (its frame was above the clearance; the fit
    // smooths it by a fraction of a millimetre), falling; the post-landing one above the table.
    EXPECT_GT(lowestCornerHeight(l.before.position, l.before.orientation, cube.half_width),
              0.5 * options.clearance);
    EXPECT_LT(l.before.linear_velocity.z(), 0.0) << "toss " << l.recording;
    EXPECT_GT(lowestCornerHeight(l.after.position, l.after.orientation, cube.half_width), 0.0);
  }
  // docs/benchmarks.md, "Real tosses": about half the tosses have a clear flight after landing.
  EXPECT_GE(kept, 250);
  EXPECT_LE(kept, 400);
}

namespace {
/// The fit's sums of squares, computed here from the frames: the centre's residuals [m^2] and the
/// rotation residuals' angles [rad^2] of the model (p0, v0, q0, w) at t_ref.
double centreSquares(const TossFrames& toss, const FlightFit& f, const Eigen::Vector3d& p0,
                     const Eigen::Vector3d& v0) {
  double sum = 0.0;
  for (int k = f.first; k <= f.last; ++k) {
    const double s = toss.time[k] - f.t_ref;
    sum +=
        (toss.position[k] - (p0 + s * v0 + 0.5 * s * s * Eigen::Vector3d(0, 0, kG))).squaredNorm();
  }
  return sum;
}
double rotationSquares(const TossFrames& toss, const FlightFit& f, const Eigen::Quaterniond& q0,
                       const Eigen::Vector3d& w) {
  double sum = 0.0;
  for (int k = f.first; k <= f.last; ++k) {
    const double angle =
        toss.orientation[k].angularDistance(turn(w * (toss.time[k] - f.t_ref)) * q0);
    sum += angle * angle;
  }
  return sum;
}
}  // namespace

// With tracking noise no model fits exactly: the fit must be the least-squares one, i.e. no small
// change of any of its 12 coordinates lowers the sums of squares the test computes itself.
TEST(TossExtraction, NoisyFlightFitIsTheLeastSquaresOne) {
  const Flight a{0.0, Eigen::Vector3d(0.1, 0.2, 0.35), Eigen::Vector3d(-1.0, 0.4, -1.2),
                 Eigen::Vector3d(3.0, -5.0, 2.0),
                 Eigen::Quaterniond(0.9, 0.2, -0.3, 0.25).normalized()};
  TossFrames toss;
  for (int k = 0; k < 20; ++k) {
    const double t = k * kFrame;
    // Deterministic noise: 0.3 mm and 0.5 degrees, in directions that change from frame to frame.
    const Eigen::Vector3d n(std::sin(1.7 * k + 0.3), std::cos(2.9 * k), std::sin(4.1 * k + 1.0));
    toss.time.push_back(t);
    toss.position.push_back(a.position(t) + 3e-4 * n);
    toss.orientation.push_back(turn(0.5 * M_PI / 180 * Eigen::Vector3d(n.reverse())) *
                               a.orientation(t));
  }
  const FlightFit f = fitFlight(toss, 0, 19, kG);
  const double c = centreSquares(toss, f, f.position, f.linear_velocity);
  const double r = rotationSquares(toss, f, f.orientation, f.angular_velocity);
  EXPECT_NEAR(f.position_rms, std::sqrt(c / 20), 1e-12);
  EXPECT_NEAR(f.rotation_rms, std::sqrt(r / 20), 1e-9);
  EXPECT_GT(f.position_rms, 1e-4);  // the noise is there
  for (int i = 0; i < 3; ++i) {
    for (const double d : {-1.0, 1.0}) {
      const Eigen::Vector3d e = d * Eigen::Vector3d::Unit(i);
      EXPECT_LE(c, centreSquares(toss, f, f.position + 1e-5 * e, f.linear_velocity));
      EXPECT_LE(c, centreSquares(toss, f, f.position, f.linear_velocity + 1e-4 * e));
      EXPECT_LE(r, rotationSquares(toss, f, turn(1e-4 * e) * f.orientation, f.angular_velocity));
      EXPECT_LE(r, rotationSquares(toss, f, f.orientation, f.angular_velocity + 1e-3 * e));
    }
  }
}
