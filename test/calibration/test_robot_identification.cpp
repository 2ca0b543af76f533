// Identification from a robot's recorded impacts (docs/calibration.md, "Robot recordings"), on
// synthetic recordings of the 2R arm of striking_arm.urdf striking a fixed sphere
// (synthetic_robot_strikes.h: the package's robot episode on a closed-form gap query, 500 Hz,
// joint noise): the impacts found where the simulation had them, with its velocities; the known
// coefficients inside the reported intervals; bad input named.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "collision_response/calibration/identification.h"
#include "collision_response/calibration/identify_program.h"
#include "collision_response/calibration/joint_csv.h"
#include "collision_response/calibration/object_file.h"
#include "collision_response/calibration/robot_impact_extraction.h"
#include "collision_response/calibration/robot_impact_prediction.h"
#include "synthetic_recordings.h"
#include "synthetic_robot_strikes.h"

using namespace collision_response;
using namespace collision_response::calibration;
using namespace collision_response::calibration::test;
namespace fs = std::filesystem;

namespace {

const std::string kUrdf = std::string(CALIBRATION_TEST_DIR) + "/striking_arm.urdf";
constexpr double kNoise = 5e-5;     // [rad], a coarse encoder's
constexpr int kFixtureStrikes = 6;  // test/data/arm_strikes/strike_<k>.csv

Coefficients truth() {
  Coefficients c;
  c.restitution = 0.6;
  c.static_friction = c.dynamic_friction = 0.25;
  return c;
}

/// Varied strikes: around the post (phi), head-on to glancing (beta: the glancing ones slide at
/// mu 0.25), 0.8 to 1.6 m/s.
std::vector<Strike> strikes(int count) {
  std::vector<Strike> out;
  for (int k = 0; k < count; ++k) {
    Strike s;
    s.phi = M_PI + 0.35 * (k % 4) - 0.5;  // the tip comes from the base's side
    s.beta = (k % 3 == 0 ? 0.1 : (k % 3 == 1 ? 0.5 : -0.7));
    s.speed = 0.8 + 0.8 * ((k * 7) % 5) / 4.0;
    out.push_back(s);
  }
  return out;
}

std::string writeCsv(const fs::path& path, const JointTrack& track, int digits = 17) {
  std::ofstream out(path);
  out.precision(digits);
  out << "t";
  for (const auto& n : track.names) out << "," << n;
  out << "\n";
  for (int k = 0; k < track.size(); ++k) {
    out << track.time[k];
    for (int j = 0; j < track.position[k].size(); ++j) out << "," << track.position[k][j];
    out << "\n";
  }
  return path.string();
}

}  // namespace

// The impact is found between the samples that bracket the simulation's impact time, and the
// quadratic fits give the simulation's joint velocities before and after it (to the noise's and
// the fits' few thousandths of the speed).
TEST(RobotIdentification, ExtractionFindsTheSimulatedImpact) {
  const RobotDescription arm = strikingArm(kUrdf);
  for (const Strike& s : strikes(3)) {
    const StrikeRecording r =
        strikeRecording(arm, s, truth(), core::ImpactLaw::kStronge, kNoise, 7);
    ASSERT_GT(r.impact_time, 0.0);
    const auto found = extractRobotImpacts(r.track);
    ASSERT_EQ(found.size(), 1u) << "phi " << s.phi << " beta " << s.beta;
    ASSERT_TRUE(found[0].ok) << found[0].reason;
    const RobotImpact& m = found[0].impact;
    EXPECT_LE(m.t_before, r.impact_time);
    EXPECT_GE(m.t_after, r.impact_time);
    const double speed = r.qdot_before.norm();
    EXPECT_LT((m.qdot_before - r.qdot_before).norm(), 0.01 * speed);
    EXPECT_LT((m.qdot_after - r.qdot_after).norm(), 0.01 * speed);
  }
}

// Free motion without an impact has none; the same recording with one is found.
TEST(RobotIdentification, NoImpactInFreeMotion) {
  const RobotDescription arm = strikingArm(kUrdf);
  Strike s = strikes(1)[0];
  s.duration = 0.08;  // ends before the strike at 0.1 s
  const StrikeRecording r = strikeRecording(arm, s, truth(), core::ImpactLaw::kStronge, kNoise, 3);
  EXPECT_LT(r.impact_time, 0.0);
  EXPECT_TRUE(extractRobotImpacts(r.track).empty());
}

// The known e and mu lie inside the reported 95 % intervals, which are narrow (the coefficients are
// identified, not merely not excluded).
TEST(RobotIdentification, KnownCoefficientsInsideTheIntervals) {
  const RobotDescription arm = strikingArm(kUrdf);
  const ObjectModel post = strikeObstacle();
  RobotPredictionOptions prediction;
  std::vector<std::unique_ptr<RobotImpactPredictor>> predictors;
  std::vector<RobotImpact> impacts;
  const auto list = strikes(8);
  unsigned seed = 11;
  for (const Strike& s : list) {
    const StrikeRecording r =
        strikeRecording(arm, s, truth(), core::ImpactLaw::kStronge, kNoise, seed++);
    for (const auto& x : extractRobotImpacts(r.track))
      if (x.ok) impacts.push_back(x.impact);
  }
  ASSERT_GE(impacts.size(), list.size() - 1);
  RobotImpactPredictor predictor(arm, {"shoulder", "elbow"}, "synthetic", post, prediction);
  std::vector<CaseResidual> cases;
  std::vector<int> sizes;
  for (const RobotImpact& m : impacts) {
    cases.push_back([&predictor, &m](const Coefficients& c) { return predictor.residual(m, c); });
    sizes.push_back(2);
  }
  core::WorkerPool pool(2);
  IdentificationOptions options;
  const IdentificationResult fit = identifyCases(cases, sizes, options, pool);
  ASSERT_EQ(fit.estimates.size(), 3u);
  const CoefficientEstimate& e = fit.estimates[0];
  const CoefficientEstimate& mu = fit.estimates[1];
  EXPECT_LE(e.lower, 0.6);
  EXPECT_GE(e.upper, 0.6);
  EXPECT_LE(mu.lower, 0.25);
  EXPECT_GE(mu.upper, 0.25);
  EXPECT_LT(e.upper - e.lower, 0.05);
  EXPECT_LT(mu.upper - mu.lower, 0.05);
  EXPECT_LT(fit.rms_cases, 0.02);
  std::printf("e %.4f [%.4f, %.4f], mu %.4f [%.4f, %.4f], rms %.4f, %zu impacts\n", e.value,
              e.lower, e.upper, mu.value, mu.lower, mu.upper, fit.rms_cases, impacts.size());
}

// The reported deviation against the spread of the estimates over repeated noise draws of the
// same strikes (an independent check of the covariance): the sample deviation of e and mu over
// the draws is at most 3 times the mean reported one (the intervals are not too narrow; wider ones
// would be conservative, and the ratio is printed: about 0.7 for e and 1.2 for mu with 12 draws).
TEST(RobotIdentification, ReportedDeviationMatchesTheSpreadOverNoiseDraws) {
  const RobotDescription arm = strikingArm(kUrdf);
  const ObjectModel post = strikeObstacle();
  RobotImpactPredictor predictor(arm, {"shoulder", "elbow"}, "synthetic", post, {});
  core::WorkerPool pool(2);
  const int draws = sized(12, 6);
  const auto list = strikes(6);
  std::vector<double> e, mu, e_sd, mu_sd;
  for (int d = 0; d < draws; ++d) {
    std::vector<RobotImpact> impacts;
    for (std::size_t k = 0; k < list.size(); ++k) {
      const StrikeRecording r = strikeRecording(arm, list[k], truth(), core::ImpactLaw::kStronge,
                                                kNoise, 1000 + 100 * d + k);
      for (const auto& x : extractRobotImpacts(r.track))
        if (x.ok) impacts.push_back(x.impact);
    }
    std::vector<CaseResidual> cases;
    for (const RobotImpact& m : impacts)
      cases.push_back([&predictor, &m](const Coefficients& c) { return predictor.residual(m, c); });
    const IdentificationResult fit =
        identifyCases(cases, std::vector<int>(cases.size(), 2), IdentificationOptions(), pool);
    e.push_back(fit.estimates[0].value);
    mu.push_back(fit.estimates[1].value);
    e_sd.push_back(fit.estimates[0].std_dev);
    mu_sd.push_back(fit.estimates[1].std_dev);
  }
  auto mean = [](const std::vector<double>& v) {
    double s = 0.0;
    for (double x : v) s += x;
    return s / v.size();
  };
  auto spread = [&](const std::vector<double>& v) {
    const double m = mean(v);
    double s = 0.0;
    for (double x : v) s += (x - m) * (x - m);
    return std::sqrt(s / (v.size() - 1));
  };
  const double e_ratio = spread(e) / mean(e_sd), mu_ratio = spread(mu) / mean(mu_sd);
  std::printf("spread / reported sd over %d draws: e %.2f (mean %.4f), mu %.2f (mean %.4f)\n",
              draws, e_ratio, mean(e), mu_ratio, mean(mu));
  EXPECT_LT(e_ratio, 3.0);
  EXPECT_LT(mu_ratio, 3.0);
  // The estimates centre on the truth (the mean's error within 3 of its standard errors).
  EXPECT_LT(std::abs(mean(e) - 0.6), 3.0 * spread(e) / std::sqrt(draws) + 1e-4);
  EXPECT_LT(std::abs(mean(mu) - 0.25), 3.0 * spread(mu) / std::sqrt(draws) + 1e-4);
}

// The torque model matters: with gravity in the arm's plane (along -y) and the arm holding itself
// against it, the fit that knows so (gravity compensation) holds the known e and mu; the one that
// takes the joints for passive predicts the arm falling by g dt over each sample interval and
// misses (its joint-velocity error several times larger).
TEST(RobotIdentification, TorqueModelGravityCompensation) {
  const RobotDescription arm = strikingArm(kUrdf);
  const ObjectModel post = strikeObstacle();
  std::vector<RobotImpact> impacts;
  unsigned seed = 41;
  for (Strike s : strikes(6)) {
    s.gravity = Eigen::Vector3d(0.0, -9.81, 0.0);
    s.gravity_compensation = true;
    const StrikeRecording r =
        strikeRecording(arm, s, truth(), core::ImpactLaw::kStronge, kNoise, seed++);
    for (const auto& x : extractRobotImpacts(r.track))
      if (x.ok) impacts.push_back(x.impact);
  }
  ASSERT_GE(impacts.size(), 5u);
  core::WorkerPool pool(2);
  auto fit = [&](bool compensation) {
    RobotPredictionOptions prediction;
    prediction.gravity = Eigen::Vector3d(0.0, -9.81, 0.0);
    prediction.gravity_compensation = compensation;
    auto predictor = std::make_shared<RobotImpactPredictor>(
        arm, std::vector<std::string>{"shoulder", "elbow"}, "synthetic", post, prediction);
    std::vector<CaseResidual> cases;
    for (const RobotImpact& m : impacts)
      cases.push_back([predictor, &m](const Coefficients& c) { return predictor->residual(m, c); });
    return identifyCases(cases, std::vector<int>(cases.size(), 2), IdentificationOptions(), pool);
  };
  const IdentificationResult held = fit(true), passive = fit(false);
  std::printf(
      "gravity compensation: e %.4f [%.4f, %.4f] mu %.4f rms %.4f; passive: e %.4f "
      "[%.4f, %.4f] mu %.4f rms %.4f\n",
      held.estimates[0].value, held.estimates[0].lower, held.estimates[0].upper,
      held.estimates[1].value, held.rms_cases, passive.estimates[0].value,
      passive.estimates[0].lower, passive.estimates[0].upper, passive.estimates[1].value,
      passive.rms_cases);
  EXPECT_LE(held.estimates[0].lower, 0.6);
  EXPECT_GE(held.estimates[0].upper, 0.6);
  EXPECT_LE(held.estimates[1].lower, 0.25);
  EXPECT_GE(held.estimates[1].upper, 0.25);
  EXPECT_GT(passive.rms_cases, 3.0 * held.rms_cases);
}

class RobotIdentify : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("robot_identify_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    std::ofstream(dir_ / "post.yaml") << "shape: {type: sphere, radius: 0.1}\n"
                                         "mass: 1.0   # not used: the obstacle is fixed\n"
                                         "material_a: arm\nmaterial_b: post\n"
                                         "position: [1.2, 0.6, 0.0]\n";
  }
  void TearDown() override { fs::remove_all(dir_); }

  IdentifyReaders readers() const {
    IdentifyReaders r;
    r.robot = [](const std::string& path) { return strikingArm(path); };
    return r;
  }
  /// identify's arguments: the post and arm, then `extra`.
  IdentifyArguments arguments(std::vector<std::string> extra) const {
    std::vector<std::string> words = {"identify", "--object", (dir_ / "post.yaml").string(),
                                      "--urdf",   kUrdf,      "--output",
                                      output(),   "--quiet",  "--threads",
                                      "2"};
    words.insert(words.end(), extra.begin(), extra.end());
    std::vector<const char*> argv;
    for (const auto& w : words) argv.push_back(w.c_str());
    return parseIdentifyArguments(static_cast<int>(argv.size()), argv.data());
  }
  std::string output() const { return (dir_ / "materials.yaml").string(); }
  /// runIdentify's error (fails the test if there is none) and that nothing was written.
  std::string error(const IdentifyArguments& a) const {
    try {
      runIdentify(a, readers(), [](const std::string&) {});
    } catch (const std::exception& e) {
      EXPECT_FALSE(fs::exists(output())) << "written despite the error";
      return e.what();
    }
    ADD_FAILURE() << "no error";
    return "";
  }
  fs::path dir_;
};

// End to end from joint CSV files: the ~materials entry with the known e inside its interval.
TEST_F(RobotIdentify, FromJointCsvFiles) {
  const RobotDescription arm = strikingArm(kUrdf);
  std::vector<std::string> args;
  unsigned seed = 21;
  int k = 0;
  for (const Strike& s : strikes(6)) {
    const StrikeRecording r =
        strikeRecording(arm, s, truth(), core::ImpactLaw::kStronge, kNoise, seed++);
    args.push_back("--joint-csv");
    args.push_back(writeCsv(dir_ / ("strike_" + std::to_string(k++) + ".csv"), r.track));
  }
  args.insert(args.end(), {"--folds", "0"});
  std::vector<std::string> lines;
  runIdentify(arguments(args), readers(), [&](const std::string& l) { lines.push_back(l); });
  std::ifstream in(output());
  std::stringstream text;
  text << in.rdbuf();
  const std::string yaml = text.str();
  // "#   restitution 0.6012 sd 0.0040 [0.5933, 0.6090]"
  const auto at = yaml.find("#   restitution ");
  ASSERT_NE(at, std::string::npos) << yaml;
  double value, sd, lower, upper;
  ASSERT_EQ(std::sscanf(yaml.c_str() + at, "#   restitution %lf sd %lf [%lf, %lf]", &value, &sd,
                        &lower, &upper),
            4)
      << yaml;
  EXPECT_LE(lower, 0.6);
  EXPECT_GE(upper, 0.6);
  EXPECT_LT(upper - lower, 0.1);
  EXPECT_NE(yaml.find("{a: \"arm\", b: \"post\", restitution: "), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("impacts used"), std::string::npos) << yaml;
}

/// The fields of one CSV line ("..." fields may hold commas; "" is a quote).
static std::vector<std::string> csvFields(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted && c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
      fields.back() += '"';
      ++i;
    } else if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      fields.emplace_back();
    } else {
      fields.back() += c;
    }
  }
  return fields;
}

static bool matplotlibAvailable() {
  return std::system("/usr/bin/python3 -c 'import matplotlib' >/dev/null 2>&1") == 0;
}

// --plot: the data beside the PNG has one row per joint and impact, in the recordings' order,
// whose measured velocity after the impact is the generator's (the episode's true post-impact
// joint velocities, to the extraction's 1 % of the speed), and whose predictions, by the fit on
// all impacts and held out, are too (the fitted e and mu are the true ones to their intervals:
// 2 % of the speed). The fitted column is the robot episode's prediction at the coefficients the
// ~materials entry gives (4 decimals: to 3e-4 of the speed; the residuals at the fit are about 20
// times that, so a prediction off by one, as with the residual's sign turned, is told apart).
// With matplotlib (python3-matplotlib) the PNG is drawn.
TEST_F(RobotIdentify, PlotOfJointVelocities) {
  const RobotDescription arm = strikingArm(kUrdf);
  std::vector<std::string> args;
  std::vector<StrikeRecording> recordings;
  unsigned seed = 61;
  for (const Strike& s : strikes(6)) {
    recordings.push_back(
        strikeRecording(arm, s, truth(), core::ImpactLaw::kStronge, kNoise, seed++));
    args.push_back("--joint-csv");
    args.push_back(writeCsv(dir_ / ("strike, " + std::to_string(recordings.size() - 1) + ".csv"),
                            recordings.back().track));
  }
  const std::string png = (dir_ / "fit.png").string();
  args.insert(args.end(), {"--folds", "2", "--plot", png});
  std::vector<std::string> lines;
  runIdentify(arguments(args), readers(), [&](const std::string& l) { lines.push_back(l); });
  const std::string data = (dir_ / "fit.csv").string();
  EXPECT_NE(std::find(lines.begin(), lines.end(), "wrote " + data), lines.end());

  // The coefficients of the ~materials entry.
  std::ifstream yaml_in(output());
  std::stringstream yaml;
  yaml << yaml_in.rdbuf();
  Coefficients fitted;
  const auto entry = yaml.str().find("restitution: ");
  ASSERT_NE(entry, std::string::npos) << yaml.str();
  ASSERT_EQ(std::sscanf(yaml.str().c_str() + entry,
                        "restitution: %lf, static_friction: %lf, dynamic_friction: %lf",
                        &fitted.restitution, &fitted.static_friction, &fitted.dynamic_friction),
            3)
      << yaml.str();
  const ObjectModel post = loadObjectModel((dir_ / "post.yaml").string());

  std::ifstream in(data);
  ASSERT_TRUE(in) << data;
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "pair,source,joint,measured,fitted,held_out");
  std::vector<std::vector<std::string>> rows;
  while (std::getline(in, line)) rows.push_back(csvFields(line));
  ASSERT_EQ(rows.size(), 2 * recordings.size());
  for (size_t k = 0; k < recordings.size(); ++k) {
    const StrikeRecording& r = recordings[k];
    const double speed = r.qdot_before.norm();
    const auto found = extractRobotImpacts(r.track);
    ASSERT_EQ(found.size(), 1u);
    ASSERT_TRUE(found[0].ok) << found[0].reason;
    const RobotImpactPredictor predictor(arm, r.track.names, r.track.source, post, {});
    const Eigen::VectorXd predicted = predictor.predict(found[0].impact, fitted);
    for (int j = 0; j < 2; ++j) {
      const auto& row = rows[2 * k + j];
      ASSERT_EQ(row.size(), 6u) << line;
      SCOPED_TRACE(row[1] + " " + row[2]);
      EXPECT_EQ(row[0], "arm/post");
      EXPECT_NE(row[1].find("strike, " + std::to_string(k) + ".csv"), std::string::npos);
      EXPECT_EQ(row[2], r.track.names[j]);
      EXPECT_NEAR(std::stod(row[3]), r.qdot_after[j], 0.01 * speed);
      EXPECT_NEAR(std::stod(row[4]), r.qdot_after[j], 0.02 * speed);
      EXPECT_NEAR(std::stod(row[4]), predicted[j], 3e-4 * speed);
      ASSERT_FALSE(row[5].empty());
      EXPECT_NEAR(std::stod(row[5]), r.qdot_after[j], 0.02 * speed);
    }
  }
  if (!matplotlibAvailable()) {
    std::printf("no python3-matplotlib: the PNG is not checked\n");
    return;
  }
  std::ifstream image(png, std::ios::binary);
  char magic[8] = {};
  image.read(magic, 8);
  EXPECT_EQ(std::string(magic, 8), std::string("\x89PNG\r\n\x1a\n", 8)) << png;
}

// Bad input: an error naming the source, nothing written.
TEST_F(RobotIdentify, BadInputIsNamed) {
  const RobotDescription arm = strikingArm(kUrdf);
  const StrikeRecording r =
      strikeRecording(arm, strikes(1)[0], truth(), core::ImpactLaw::kStronge, kNoise, 5);
  // A joint the URDF does not have.
  JointTrack renamed = r.track;
  renamed.names[1] = "wrist";
  const std::string wrong = writeCsv(dir_ / "wrong.csv", renamed);
  std::string what = error(arguments({"--joint-csv", wrong, "--folds", "0"}));
  EXPECT_NE(what.find("wrong.csv"), std::string::npos) << what;
  EXPECT_NE(what.find("'wrist'"), std::string::npos) << what;
  EXPECT_NE(what.find("striking_arm.urdf"), std::string::npos) << what;
  // A joint of the URDF not recorded.
  JointTrack one = r.track;
  one.names = {"shoulder"};
  for (auto& q : one.position) q = q.head(1).eval();
  const std::string short_track = writeCsv(dir_ / "shoulder_only.csv", one);
  what = error(arguments({"--joint-csv", short_track, "--folds", "0"}));
  EXPECT_NE(what.find("shoulder_only.csv"), std::string::npos) << what;
  EXPECT_NE(what.find("'elbow'"), std::string::npos) << what;
  // A non-finite sample: the file, line and column.
  const std::string good = writeCsv(dir_ / "nan.csv", r.track);
  {
    std::ifstream in(good);
    std::stringstream text;
    text << in.rdbuf();
    std::string s = text.str();
    std::size_t line = 0;
    for (int k = 0; k < 5; ++k) line = s.find('\n', line) + 1;  // the 5th sample's row (line 6)
    const std::size_t comma = s.find_last_of(',', s.find('\n', line));
    s.replace(comma + 1, s.find('\n', line) - comma - 1, "nan");
    std::ofstream(good) << s;
  }
  what = error(arguments({"--joint-csv", good, "--folds", "0"}));
  EXPECT_NE(what.find("nan.csv:6"), std::string::npos) << what;
  EXPECT_NE(what.find("elbow"), std::string::npos) << what;
  // A recording without an impact.
  Strike early = strikes(1)[0];
  early.duration = 0.08;
  const std::string free_motion =
      writeCsv(dir_ / "free.csv",
               strikeRecording(arm, early, truth(), core::ImpactLaw::kStronge, kNoise, 5).track);
  what = error(arguments({"--joint-csv", free_motion, "--folds", "0"}));
  EXPECT_NE(what.find("free.csv"), std::string::npos) << what;
  EXPECT_NE(what.find("no impact"), std::string::npos) << what;
  // A bag's topic that the reader does not find: its error passes through unchanged.
  IdentifyReaders with_bag = readers();
  with_bag.joints = [](const std::string& bag, const std::string& topic) -> JointTrack {
    throw std::runtime_error(bag + ":" + topic + ": no such topic in the bag");
  };
  try {
    runIdentify(arguments({"--bag", "strikes.bag", "--joint-states", "/joint_states"}), with_bag,
                [](const std::string&) {});
    ADD_FAILURE() << "no error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("strikes.bag:/joint_states"), std::string::npos);
    EXPECT_FALSE(fs::exists(output()));
  }
  // Flags: --joint-states without --urdf, --csv with --urdf.
  const char* no_urdf[] = {"identify",       "--object", "post.yaml", "--bag", "b.bag",
                           "--joint-states", "/js",      "--output",  "m.yaml"};
  EXPECT_THROW(parseIdentifyArguments(9, no_urdf), std::runtime_error);
  const char* poses[] = {"identify", "--object", "post.yaml", "--urdf", "a.urdf",
                         "--csv",    "t.csv",    "--output",  "m.yaml"};
  EXPECT_THROW(parseIdentifyArguments(9, poses), std::runtime_error);
}

// The committed fixture test/data/arm_strikes/ (the README's robot example) is these synthetic
// strikes: each CSV file against its strike regenerated here (to the files' 10 significant
// digits). CR_WRITE_ARM_STRIKES=1 writes them instead (after a change of the generator).
TEST(RobotIdentification, FixtureIsTheSyntheticStrikes) {
  const RobotDescription arm = strikingArm(kUrdf);
  const fs::path dir = fs::path(CALIBRATION_TEST_DIR).parent_path() / "data" / "arm_strikes";
  const char* write = std::getenv("CR_WRITE_ARM_STRIKES");
  const auto list = strikes(kFixtureStrikes);
  for (int k = 0; k < kFixtureStrikes; ++k) {
    const StrikeRecording r =
        strikeRecording(arm, list[k], truth(), core::ImpactLaw::kStronge, kNoise, 500 + k);
    const fs::path file = dir / ("strike_" + std::to_string(k) + ".csv");
    if (write != nullptr && std::string(write) == "1") writeCsv(file, r.track, 10);
    const JointTrack stored = readJointCsv(file.string());
    ASSERT_EQ(stored.names, r.track.names);
    ASSERT_EQ(stored.size(), r.track.size()) << file;
    for (int i = 0; i < stored.size(); ++i) {
      EXPECT_NEAR(stored.time[i], r.track.time[i], 1e-12);
      EXPECT_LT((stored.position[i] - r.track.position[i]).cwiseAbs().maxCoeff(), 1e-8) << file;
    }
  }
}
