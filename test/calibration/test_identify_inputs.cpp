// The identify program's inputs (identify_program.h): the two CSV layouts, the object file, and bad
// input (a recording without a landing, a non-finite sample, an object file whose shape does not
// match the recording, a malformed object file): an error naming the source, and no output file.
// Also one small run end to end on synthetic recordings (synthetic_recordings.h) whose output is a
// ~materials list with the true coefficients within its intervals, and one with --plot.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "collision_response/calibration/csv_tracks.h"
#include "collision_response/calibration/identify_program.h"
#include "collision_response/calibration/landing_extraction.h"
#include "collision_response/calibration/landing_prediction.h"
#include "collision_response/calibration/object_file.h"
#include "collision_response/calibration/simple_yaml.h"
#include "synthetic_recordings.h"

using namespace collision_response;
using namespace collision_response::calibration;
using namespace collision_response::calibration::test;
namespace fs = std::filesystem;

namespace {

class IdentifyInputs : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("identify_inputs_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write(const std::string& name, const std::string& text) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path) << text;
    return path;
  }
  static std::string csv(const PoseTrack& track) {
    std::ostringstream out;
    out.precision(10);
    out << "t,x,y,z,qw,qx,qy,qz\n";
    for (int k = 0; k < track.size(); ++k) {
      const auto& p = track.position[k];
      const auto& q = track.orientation[k];
      out << track.time[k] << "," << p.x() << "," << p.y() << "," << p.z() << "," << q.w() << ","
          << q.x() << "," << q.y() << "," << q.z() << "\n";
    }
    return out.str();
  }
  std::string cubeFile(double size, bool floor) {
    return write("cube.yaml", "shape: {type: box, size: [" + std::to_string(size) + ", " +
                                  std::to_string(size) + ", " + std::to_string(size) +
                                  "]}  # the tossed cube\nmass: 0.37\nmaterial_a: cube\n"
                                  "material_b: floor\n" +
                                  (floor ? "floor_height: 0.0\n" : ""));
  }
  /// Runs identify; returns the error message ("" if none).
  std::string run(const std::string& object, const std::vector<std::string>& csv) {
    IdentifyArguments a;
    a.inputs.push_back({object, csv, {}});
    a.output = output();
    a.folds = 0;
    a.threads = 2;
    a.quiet = true;
    try {
      runIdentify(a, BagReader(), [](const std::string&) {});
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  }
  std::string output() const { return (dir_ / "materials.yaml").string(); }
  fs::path dir_;
};

/// A cube lying flat on the floor for `n` samples at 148 Hz: no landing.
PoseTrack restingCube(int n) {
  PoseTrack track;
  for (int k = 0; k < n; ++k) {
    track.time.push_back(k / kSampleRate);
    track.position.emplace_back(0.1, 0.2, 0.0524);
    track.orientation.push_back(Eigen::Quaterniond::Identity());
  }
  return track;
}

TEST_F(IdentifyInputs, ReadsBothCsvLayouts) {
  const std::string one =
      write("toss_012.csv", "t,x,y,z,qw,qx,qy,qz\n0,1,2,3,2,0,0,0\n0.5,1,2,4,1,0,0,0\n");
  const std::string many = write("tosses.csv",
                                 "toss,t,x,y,z,qw,qx,qy,qz\n4,0,1,2,3,1,0,0,0\n4,1,1,2,3,1,0,0,0\n"
                                 "9,0,5,6,7,0,1,0,0\n");
  auto a = readCsvTracks(one);
  ASSERT_EQ(a.size(), 1u);
  EXPECT_EQ(a[0].number, 12);
  EXPECT_EQ(a[0].track.size(), 2);
  EXPECT_DOUBLE_EQ(a[0].track.position[1].z(), 4.0);
  EXPECT_DOUBLE_EQ(a[0].track.orientation[0].w(), 1.0);  // normalised
  auto b = readCsvTracks(many);
  ASSERT_EQ(b.size(), 2u);
  EXPECT_EQ(b[0].number, 4);
  EXPECT_EQ(b[1].number, 9);
  EXPECT_EQ(b[1].track.source, many + " toss 9");
  auto c = readCsvTracks(dir_.string());  // both files, in name order
  EXPECT_EQ(c.size(), 3u);
}

// The line reader both recordings' readers share (CsvLines): a line longer than its 4 KiB read
// buffer, CRLF line ends, a gzip file cut short, an empty file.
TEST_F(IdentifyInputs, CsvLinesReadsLongCrlfLinesAndNamesBrokenFiles) {
  const std::string long_x = std::string(5000, '0') + "1.5";  // 1.5 in 5,003 characters
  const std::string text =
      "t,x,y,z,qw,qx,qy,qz\r\n0," + long_x + ",2,3,1,0,0,0\r\n0.5,1,2,4,1,0,0,0\r\n";
  const auto tracks = readCsvTracks(write("long.csv", text));
  ASSERT_EQ(tracks.size(), 1u);
  ASSERT_EQ(tracks[0].track.size(), 2);
  EXPECT_EQ(tracks[0].track.position[0].x(), 1.5);
  EXPECT_EQ(tracks[0].track.position[1].z(), 4.0);

  // The same text gzip-compressed, then cut to half its length: a read error, not a short track.
  const std::string plain = write("cut.csv", text + text.substr(text.find('\n') + 1));
  ASSERT_EQ(std::system(("gzip -kf " + plain).c_str()), 0);
  const std::string gz = plain + ".gz";
  fs::resize_file(gz, fs::file_size(gz) / 2);
  try {
    readCsvTracks(gz);
    ADD_FAILURE() << "a truncated gzip file was read";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()).rfind(gz + ":", 0), 0u) << e.what();
    EXPECT_NE(std::string(e.what()).find("read error"), std::string::npos) << e.what();
  }
  const std::string empty = write("empty.csv", "");
  try {
    readCsvTracks(empty);
    ADD_FAILURE() << "an empty file was read";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(empty + ": empty file"), std::string::npos) << e.what();
  }
}

TEST_F(IdentifyInputs, NonFiniteSampleNamesFileLineAndColumn) {
  const std::string path =
      write("bad.csv", "t,x,y,z,qw,qx,qy,qz\n0,0,0,1,1,0,0,0\n0.1,0,0,1,1,nan,0,0\n");
  const std::string error = run(cubeFile(0.1048, true), {path});
  EXPECT_NE(error.find(path + ":3"), std::string::npos) << error;
  EXPECT_NE(error.find("qx"), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(output()));
}

TEST_F(IdentifyInputs, MalformedRowNamesFileAndLine) {
  const std::string path = write("bad.csv", "t,x,y,z,qw,qx,qy,qz\n0,0,0,1,1,0,0\n");
  const std::string error = run(cubeFile(0.1048, true), {path});
  EXPECT_NE(error.find(path + ":2"), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(output()));
}

// The toss column must hold an integer an int holds (a finding of the identify fuzzer: its value
// was cast to int, undefined beyond the int range).
TEST_F(IdentifyInputs, TossNumberThatIsNoIntegerNamesFileLineAndColumn) {
  for (const char* toss : {"1e300", "2.5", "-3e9"}) {
    const std::string path =
        write("tosses.csv", std::string("toss,t,x,y,z,qw,qx,qy,qz\n4,0,1,2,3,1,0,0,0\n") + toss +
                                ",0.1,1,2,3,1,0,0,0\n");
    const std::string error = run(cubeFile(0.1048, true), {path});
    EXPECT_NE(error.find(path + ":3"), std::string::npos) << error;
    EXPECT_NE(error.find("toss"), std::string::npos) << error;
    EXPECT_FALSE(fs::exists(output()));
  }
}

TEST_F(IdentifyInputs, RecordingWithoutLandingIsAnError) {
  const std::string path = write("resting.csv", csv(restingCube(40)));
  const std::string error = run(cubeFile(0.1048, true), {path});
  EXPECT_NE(error.find(path), std::string::npos) << error;
  EXPECT_NE(error.find("no landing"), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(output()));
}

TEST_F(IdentifyInputs, ObjectBelowTheFloorAtRestIsAShapeMismatch) {
  // The recording is of the 0.1048 m cube lying on the floor z = 0; the object file says 0.13 m:
  // at rest its lowest point would be 12.8 mm below the floor.
  std::mt19937 rng(5);
  const std::string path = write("toss.csv", csv(restingCube(40)));
  const std::string error = run(cubeFile(0.13, true), {path});
  EXPECT_NE(error.find(path), std::string::npos) << error;
  EXPECT_NE(error.find("below the floor"), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(output()));
}

TEST_F(IdentifyInputs, MalformedObjectFileNamesTheField) {
  const std::string toss = write("toss.csv", csv(restingCube(40)));
  auto error = run(write("a.yaml",
                         "shape: {type: box, size: [1, 1]}\nmass: 1\nmaterial_a: x\n"
                         "material_b: y\n"),
                   {toss});
  EXPECT_NE(error.find("a.yaml: shape.size"), std::string::npos) << error;
  error = run(write("b.yaml",
                    "shape: {type: sphere, radius: 0.1}\nmaterial_a: x\n"
                    "material_b: y\n"),
              {toss});
  EXPECT_NE(error.find("b.yaml: mass: is missing"), std::string::npos) << error;
  error = run(write("c.yaml",
                    "shape: {type: sphere, radius: 0.1}\nmass: -1\nmaterial_a: x\n"
                    "material_b: y\n"),
              {toss});
  EXPECT_NE(error.find("c.yaml: mass: must be > 0"), std::string::npos) << error;
  error = run(write("d.yaml",
                    "shape: {type: cone, radius: 0.1}\nmass: 1\nmaterial_a: x\n"
                    "material_b: y\nfriction: 3\n"),
              {toss});
  EXPECT_NE(error.find("d.yaml: friction: unknown key"), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(output()));
}

TEST(ObjectFile, InertiaFromTheShapeOrGiven) {
  // Closed forms: a uniform cylinder about its axis m r^2 / 2, across m (3 r^2 + L^2) / 12.
  const ObjectModel c = parseObjectModel(
      "shape:\n  type: cylinder\n  radius: 0.05\n  length: 0.2\nmass: 2\nmaterial_a: can\n"
      "material_b: table\n",
      "can.yaml");
  EXPECT_NEAR(c.inertia(2, 2), 0.5 * 2 * 0.05 * 0.05, 1e-15);
  EXPECT_NEAR(c.inertia(0, 0), 2 * (3 * 0.05 * 0.05 + 0.04) / 12, 1e-15);
  EXPECT_FALSE(c.floor_height.has_value());
  const ObjectModel b = parseObjectModel(
      "shape: {type: box, size: [0.1, 0.2, 0.3]}\nmass: 1\ninertia: [1, 2, 3]\nmaterial_a: 'a b'\n"
      "material_b: t\nfloor_height: 0.75\n",
      "b.yaml");
  EXPECT_EQ(b.inertia.diagonal(), Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(b.material_a, "a b");
  EXPECT_DOUBLE_EQ(*b.floor_height, 0.75);
  // The lowest point of the box tilted 90 degrees about x: half its z side becomes half its y side.
  const Eigen::Quaterniond q(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()));
  EXPECT_NEAR(lowestPointHeight(b.shape, Eigen::Vector3d(0, 0, 1), q), 1.0 - 0.1, 1e-12);
}

TEST_F(IdentifyInputs, EndToEndOnSyntheticRecordings) {
  std::mt19937 rng(21), noise(22);
  std::vector<std::string> files;
  const ObjectModel cube = syntheticCube();
  while (files.size() < 12) {
    const PoseTrack truth = trueToss(rng, 0.45, 0.3, core::ImpactLaw::kStronge);
    if (truth.size() < 30 || !extractLandings(truth, cube.shape, 0.0).front().ok) continue;
    files.push_back(write("toss_" + std::to_string(files.size()) + ".csv",
                          csv(noisy(truth, noise, 3e-4, 3e-3))));
  }
  ASSERT_EQ(run(cubeFile(0.1048, true), {dir_.string()}), "");
  std::ifstream in(output());
  std::stringstream text;
  text << in.rdbuf();
  // The list is a block sequence ("- {...}"), which simple_yaml does not read: check the lines.
  const std::string s = text.str();
  EXPECT_NE(s.find("\nmaterials:\n"), std::string::npos) << s;
  const auto entry = s.find("  - {a: \"cube\", b: \"floor\", restitution: ");
  ASSERT_NE(entry, std::string::npos) << s;
  const YamlNode values =
      parseYaml("x: " + s.substr(entry + 4, s.find('\n', entry) - entry - 4), "entry");
  const YamlNode& m = values.map[0].second;
  EXPECT_NEAR(std::stod(m.find("restitution")->scalar), 0.45, 0.02);
  EXPECT_NEAR(std::stod(m.find("static_friction")->scalar), 0.3, 0.02);
  EXPECT_EQ(m.find("static_friction")->scalar, m.find("dynamic_friction")->scalar);
  EXPECT_NE(s.find("# data: 12 recordings, "), std::string::npos) << s;
}

// --plot: the data beside the PNG has a row per landing, in the files' order, whose measured
// velocities are those the extraction gives on the same recording, whose fitted predictions are
// the episode's (LandingPredictor) from the landing's pre-impact state at the coefficients of the
// ~materials entry (4 decimals: to 1e-3 of the pre-impact speed; the training residuals are about
// 100 times that), and whose held-out ones are there; the PNG (with python3-matplotlib) is drawn by
// the same script as a robot's.
TEST_F(IdentifyInputs, PlotOfLandingVelocities) {
  std::mt19937 rng(41), noise(42);
  const ObjectModel cube = syntheticCube();
  std::vector<Landing> noisy_landings;
  std::vector<std::string> files;
  while (files.size() < 10) {
    const PoseTrack truth = trueToss(rng, 0.45, 0.3, core::ImpactLaw::kStronge);
    if (truth.size() < 30) continue;
    const Extraction t = extractLandings(truth, cube.shape, 0.0).front();
    if (!t.ok) continue;
    const PoseTrack recorded = noisy(truth, noise, 3e-4, 3e-3);
    const Extraction n = extractLandings(recorded, cube.shape, 0.0).front();
    if (!n.ok) continue;
    noisy_landings.push_back(n.landing);
    char name[32];
    std::snprintf(name, sizeof name, "toss_%02zu.csv", files.size());
    files.push_back(write(name, csv(recorded)));
  }
  IdentifyArguments a;
  a.inputs.push_back({cubeFile(0.1048, true), files, {}});
  a.output = output();
  a.plot = (dir_ / "fit.png").string();
  a.folds = 2;
  a.threads = 2;
  a.quiet = true;
  runIdentify(a, BagReader(), [](const std::string&) {});
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
  const LandingPredictor predictor(loadObjectModel(a.inputs[0].object), PredictionOptions{});
  std::ifstream in((dir_ / "fit.csv").string());
  ASSERT_TRUE(in);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line.rfind("pair,source,measured_vx,", 0), 0u) << line;
  std::vector<std::vector<double>> rows;
  while (std::getline(in, line)) {
    std::vector<double> values;
    std::stringstream fields(line);
    std::string field;
    for (int i = 0; std::getline(fields, field, ','); ++i)
      if (i >= 2) values.push_back(std::stod(field));
    rows.push_back(values);
  }
  ASSERT_EQ(rows.size(), files.size());
  for (size_t k = 0; k < rows.size(); ++k) {
    SCOPED_TRACE(files[k]);
    ASSERT_EQ(rows[k].size(), 18u);
    const MotionState& measured = noisy_landings[k].after;
    const MotionState predicted = predictor.predict(noisy_landings[k], fitted);
    const double speed = noisy_landings[k].before.linear_velocity.norm();
    const double length = 0.1048 / 2;  // lengthScale(): the cube's half width
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(rows[k][i], measured.linear_velocity[i], 1e-6);
      EXPECT_NEAR(rows[k][3 + i], measured.angular_velocity[i], 1e-6);
      EXPECT_NEAR(rows[k][6 + i], predicted.linear_velocity[i], 1e-3 * speed);
      EXPECT_NEAR(rows[k][9 + i], predicted.angular_velocity[i], 1e-3 * speed / length);
      EXPECT_TRUE(std::isfinite(rows[k][12 + i]) && std::isfinite(rows[k][15 + i]));
    }
  }
  if (std::system("/usr/bin/python3 -c 'import matplotlib' >/dev/null 2>&1") != 0) return;
  std::ifstream image((dir_ / "fit.png").string(), std::ios::binary);
  char magic[8] = {};
  image.read(magic, 8);
  EXPECT_EQ(std::string(magic, 8), std::string("\x89PNG\r\n\x1a\n", 8));
}

// Two object files naming different pairs of materials: one entry per pair, each fitted to its own
// recordings (made with different coefficients).
TEST_F(IdentifyInputs, OneEntryPerPairOfMaterials) {
  std::mt19937 rng(31), noise(32);
  const ObjectModel cube = syntheticCube();
  IdentifyArguments a;
  for (const auto& [pair, e] : {std::pair<std::string, double>{"rubber", 0.7}, {"wood", 0.3}}) {
    fs::create_directories(dir_ / pair);
    int files = 0;
    while (files < 8) {
      const PoseTrack truth = trueToss(rng, e, 0.3, core::ImpactLaw::kStronge);
      if (truth.size() < 30 || !extractLandings(truth, cube.shape, 0.0).front().ok) continue;
      write(pair + "/toss_" + std::to_string(files++) + ".csv",
            csv(noisy(truth, noise, 3e-4, 3e-3)));
    }
    const std::string object = write(pair + ".yaml",
                                     "shape: {type: box, size: [0.1048, 0.1048, 0.1048]}\n"
                                     "mass: 0.37\nmaterial_a: " +
                                         pair + "\nmaterial_b: floor\nfloor_height: 0\n");
    a.inputs.push_back({object, {(dir_ / pair).string()}, {}});
  }
  a.output = output();
  a.folds = 0;
  a.threads = 2;
  a.quiet = true;
  runIdentify(a, BagReader(), [](const std::string&) {});
  std::ifstream in(output());
  std::stringstream text;
  text << in.rdbuf();
  const std::string s = text.str();
  for (const auto& [pair, e] : {std::pair<std::string, double>{"rubber", 0.7}, {"wood", 0.3}}) {
    const auto entry = s.find("  - {a: \"" + pair + "\", b: \"floor\", restitution: ");
    ASSERT_NE(entry, std::string::npos) << s;
    const YamlNode values =
        parseYaml("x: " + s.substr(entry + 4, s.find('\n', entry) - entry - 4), "entry");
    EXPECT_NEAR(std::stod(values.map[0].second.find("restitution")->scalar), e, 0.03) << pair;
  }
}

}  // namespace

// A bag's one track holds many tosses separated by untracked time: cut at gaps over the limit,
// each piece a recording with its own samples in order; pieces of one sample dropped.
TEST(SplitAtGaps, CutsOnlyAtGapsLongerThanTheLimit) {
  PoseTrack track;
  track.source = "b.bag:/tf world->cube";
  // 0, 0.01, 0.02 | gap 0.5 | 0.52, 0.53 | gap 0.3 | 0.83 (alone) | gap 0.67 | 1.5, 1.625, 1.75
  // and a gap of exactly the limit (0.25, exact in binary) inside the last piece, which does not
  // cut.
  const std::vector<double> times = {0.0, 0.01, 0.02, 0.52, 0.53, 0.83, 1.5, 1.625, 1.75, 2.0};
  for (std::size_t i = 0; i < times.size(); ++i) {
    track.time.push_back(times[i]);
    track.position.emplace_back(double(i), 0.0, 0.0);
    track.orientation.push_back(Eigen::Quaterniond::Identity());
  }
  const std::vector<PoseTrack> pieces = splitAtGaps(track, 0.25);
  ASSERT_EQ(pieces.size(), 3u);
  const std::vector<std::vector<double>> expected = {
      {0.0, 0.01, 0.02}, {0.52, 0.53}, {1.5, 1.625, 1.75, 2.0}};
  const std::vector<double> first_x = {0.0, 3.0, 6.0};
  for (std::size_t p = 0; p < pieces.size(); ++p) {
    EXPECT_EQ(pieces[p].time, expected[p]) << p;
    ASSERT_EQ(pieces[p].position.size(), expected[p].size()) << p;
    ASSERT_EQ(pieces[p].orientation.size(), expected[p].size()) << p;
    EXPECT_EQ(pieces[p].position.front().x(), first_x[p]) << p;
    EXPECT_EQ(pieces[p].source, track.source + " #" + std::to_string(p));
  }
}
