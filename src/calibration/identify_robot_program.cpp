// identify on a robot's recordings (docs/calibration.md, "Robot recordings"): the joint tracks,
// their impacts, the fit and the ~materials output.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <stdexcept>
#include <thread>

#include "collision_response/calibration/cross_validation.h"
#include "collision_response/calibration/identify_program.h"
#include "collision_response/calibration/joint_csv.h"
#include "collision_response/calibration/materials_output.h"
#include "collision_response/calibration/object_file.h"
#include "collision_response/calibration/progress_bar.h"
#include "collision_response/calibration/robot_impact_extraction.h"

namespace collision_response::calibration {
namespace {

/// One pair of materials: its impacts (each a case) and where they came from.
struct RobotPair {
  std::string a, b;
  std::vector<std::shared_ptr<const RobotImpactPredictor>> predictors;
  std::vector<std::shared_ptr<const RobotImpact>> impacts;
  std::vector<CaseResidual> cases;
  std::vector<int> sizes;
  std::vector<std::vector<std::string>> joints;  ///< each case's joint names (its track's order)
  std::vector<std::string> sources;
  int recordings = 0;
  std::map<std::string, int> skipped;
};

std::string fileName(const std::string& path) {
  return std::filesystem::path(path).filename().string();
}

/// A CSV field in double quotes (a source may hold commas).
std::string quoted(const std::string& text) {
  std::string out = "\"";
  for (char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

/// The plot's data (plotIdentification()): one row per joint and impact, its velocity after the
/// impact [rad/s, or m/s for a prismatic joint] measured, predicted by the fit on all impacts and
/// by the fit on the folds without the impact (empty without cross-validation). A prediction is
/// the measured velocity plus the case's residual times the joints' speed before the impact (the
/// residual's scale, RobotImpactPredictor).
void writeRobotPlotData(const std::string& path, const std::vector<RobotPair>& pairs,
                        const std::vector<MaterialsEntry>& entries) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot write");
  out << "pair,source,joint,measured,fitted,held_out\n";
  out.precision(9);
  for (size_t p = 0; p < pairs.size(); ++p) {
    const RobotPair& pair = pairs[p];
    const MaterialsEntry& entry = entries[p];
    for (size_t k = 0; k < pair.cases.size(); ++k) {
      const RobotImpact& impact = *pair.impacts[k];
      const double speed = impact.qdot_before.norm();
      for (int j = 0; j < impact.qdot_after.size(); ++j) {
        out << pair.a << "/" << pair.b << "," << quoted(impact.source) << "," << pair.joints[k][j]
            << "," << impact.qdot_after[j] << ","
            << impact.qdot_after[j] + speed * entry.fit.case_residuals[k][j] << ",";
        if (entry.held_out.folds > 0)
          out << impact.qdot_after[j] + speed * entry.held_out.held_out_cases[k][j];
        out << "\n";
      }
    }
  }
}

}  // namespace

std::vector<JointTrack> splitAtGaps(const JointTrack& track, double max_gap) {
  std::vector<JointTrack> pieces;
  int first = 0;
  for (int i = 1; i <= track.size(); ++i) {
    if (i < track.size() && !(track.time[i] - track.time[i - 1] > max_gap)) continue;
    if (i - first >= 2) {
      JointTrack piece;
      piece.source = track.source + " #" + std::to_string(pieces.size());
      piece.names = track.names;
      piece.time.assign(track.time.begin() + first, track.time.begin() + i);
      piece.position.assign(track.position.begin() + first, track.position.begin() + i);
      pieces.push_back(std::move(piece));
    }
    first = i;
  }
  return pieces;
}

void runRobotIdentify(const IdentifyArguments& args, const IdentifyReaders& readers,
                      std::function<void(const std::string&)> report) {
  ProgressBar bar(!args.quiet);
  const auto log = [&](const std::string& line) {
    bar.finish();
    report(line);
  };
  IdentificationOptions options = identificationOptions(args);
  RobotPredictionOptions prediction;
  prediction.law = options.prediction.law;
  prediction.single_impact = args.single_impact;
  prediction.gravity = Eigen::Vector3d(0.0, 0.0, options.prediction.gravity_z);
  prediction.gravity_compensation = args.gravity_compensation;

  // Read everything and extract every impact first: any bad input fails before a fit starts.
  std::map<std::string, RobotDescription> robots;
  std::vector<RobotPair> pairs;
  for (const IdentifyInput& input : args.inputs) {
    const ObjectModel obstacle = loadObjectModel(input.object);
    if (!robots.count(input.urdf)) {
      if (!readers.robot) throw std::runtime_error(input.urdf + ": this identify reads no URDF");
      bar.update(0.0, "reading " + input.urdf);
      robots[input.urdf] = readers.robot(input.urdf);
    }
    const RobotDescription& robot = robots[input.urdf];
    auto it = std::find_if(pairs.begin(), pairs.end(), [&](const RobotPair& p) {
      return p.a == obstacle.material_a && p.b == obstacle.material_b;
    });
    if (it == pairs.end()) {
      pairs.emplace_back();
      pairs.back().a = obstacle.material_a;
      pairs.back().b = obstacle.material_b;
      it = pairs.end() - 1;
    }
    RobotPair& pair = *it;
    std::vector<JointTrack> tracks;
    for (const auto& path : input.joint_csv) {
      bar.update(0.0, "reading " + path);
      tracks.push_back(readJointCsv(path));
      pair.sources.push_back(fileName(path) + " (joint CSV, robot " + fileName(input.urdf) +
                             ", obstacle " + fileName(input.object) + ")");
    }
    for (const auto& path : input.bags) {
      if (!readers.joints) throw std::runtime_error(path + ": this identify reads no rosbags");
      bar.update(0.0, "reading " + path);
      // Strikes with untracked time between them (the robot moved back) are cut apart.
      for (auto& piece : splitAtGaps(readers.joints(path, input.joint_states), kMaxRecordingGap))
        tracks.push_back(std::move(piece));
      pair.sources.push_back(fileName(path) + " (rosbag " + input.joint_states + ", robot " +
                             fileName(input.urdf) + ", obstacle " + fileName(input.object) + ")");
    }
    for (const JointTrack& track : tracks) {
      ++pair.recordings;
      if (track.size() < 2 * RobotImpactOptions().min_samples + 1) {
        ++pair.skipped["recording too short for an impact"];
        continue;
      }
      // One scene per recording (its joints' order); the robot and obstacle are checked here.
      auto predictor = std::make_shared<const RobotImpactPredictor>(
          robot, track.names, track.source, obstacle, prediction);
      const auto extractions = extractRobotImpacts(track);
      if (extractions.empty())
        throw std::runtime_error(track.source +
                                 ": no impact (no jump in the joint velocities above the noise)");
      for (const RobotImpactExtraction& x : extractions) {
        if (!x.ok) {
          ++pair.skipped[x.reason];
          continue;
        }
        auto impact = std::make_shared<const RobotImpact>(x.impact);
        pair.predictors.push_back(predictor);
        pair.impacts.push_back(impact);
        const RobotImpactPredictor* p = predictor.get();
        const RobotImpact* m = impact.get();
        pair.cases.push_back([p, m](const Coefficients& c) { return p->residual(*m, c); });
        pair.sizes.push_back(predictor->joints());
        pair.joints.push_back(track.names);
      }
    }
  }
  for (const RobotPair& pair : pairs) {
    const int impacts = static_cast<int>(pair.cases.size());
    if (impacts == 0)
      throw std::runtime_error(pair.a + " on " + pair.b + ": no usable impact in " +
                               std::to_string(pair.recordings) + " recordings");
    if (args.folds > impacts)
      throw std::runtime_error("--folds " + std::to_string(args.folds) + ": only " +
                               std::to_string(impacts) + " impacts of " + pair.a + " on " + pair.b);
    std::string line = pair.a + " on " + pair.b + ": " + std::to_string(pair.recordings) +
                       " recordings, " + std::to_string(impacts) + " impacts";
    for (const auto& [reason, count] : pair.skipped)
      line += "; " + std::to_string(count) + " skipped: " + reason;
    log(line);
  }

  const int threads = args.threads > 0
                          ? args.threads
                          : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  core::WorkerPool pool(threads);
  const int total_fits = (1 + args.folds) * static_cast<int>(pairs.size());
  int fits_done = 0;
  std::vector<MaterialsEntry> entries;
  for (const RobotPair& pair : pairs) {
    MaterialsEntry entry;
    entry.robot = true;
    entry.material_a = pair.a;
    entry.material_b = pair.b;
    entry.sources = pair.sources;
    entry.recordings = pair.recordings;
    entry.skipped.assign(pair.skipped.begin(), pair.skipped.end());
    entry.method = std::string("robot impacts, ") +
                   (args.single_impact ? "one impact" : "episode") + ", " + args.law + ", " +
                   (args.split_friction ? "mu_s and mu_d" : "one mu") +
                   (args.gravity_compensation ? ", gravity compensation" : ", passive joints");
    std::string stage = "fit";
    options.progress = [&](int iteration) {
      bar.update((fits_done + std::min(1.0, iteration / 20.0)) / total_fits,
                 pair.a + "/" + pair.b + " " + stage + ", iteration " + std::to_string(iteration));
    };
    entry.fit = identifyCases(pair.cases, pair.sizes, options, pool);
    char scale[64];
    std::snprintf(scale, sizeof scale, ", Cauchy loss scale %.4f%s", entry.fit.loss_scale,
                  args.loss_scale == 0.0 ? " (automatic)" : "");
    entry.method += scale;
    ++fits_done;
    if (args.folds > 0) {
      entry.held_out = crossValidateCases(
          pair.cases, pair.sizes, options, args.folds, pool,
          [&](int fold) {
            stage = "fold " + std::to_string(fold + 1) + "/" + std::to_string(args.folds);
            if (fold > 0) ++fits_done;
          },
          &entry.fit.coefficients);
      ++fits_done;
    }
    const auto& f = entry.fit;
    std::string line = pair.a + " on " + pair.b + ":";
    for (const auto& e : f.estimates) {
      char buffer[160];
      std::snprintf(buffer, sizeof buffer, " %s %.4f [%.4f, %.4f]%s", e.name.c_str(), e.value,
                    e.lower, e.upper, e.at_bound ? " (on a bound)" : "");
      line += buffer;
    }
    char buffer[200];
    std::snprintf(buffer, sizeof buffer, "; RMS joint velocities %.4f", f.rms_cases);
    line += buffer;
    if (args.folds > 0) {
      std::snprintf(buffer, sizeof buffer, "; held out (%d-fold) %.4f", args.folds,
                    entry.held_out.rms_cases);
      line += buffer;
    }
    line += "; " + std::to_string(f.iterations) + " iterations" +
            (f.converged ? "" : " (not converged: " + f.summary + ")");
    entries.push_back(std::move(entry));
    bar.finish();
    log(line);
  }
  bar.finish();
  writeFileAtomically(args.output, materialsYaml(entries));
  log("wrote " + args.output);
  if (!args.plot.empty()) {
    const std::string data = plotDataPath(args.plot);
    writeRobotPlotData(data, pairs, entries);
    log("wrote " + data);
    plotIdentification(data, args.plot, log);
  }
}

}  // namespace collision_response::calibration
