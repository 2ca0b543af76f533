#include "collision_response/calibration/identify_program.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <stdexcept>
#include <thread>

#include "collision_response/calibration/cross_validation.h"
#include "collision_response/calibration/csv_tracks.h"
#include "collision_response/calibration/identification.h"
#include "collision_response/calibration/landing_extraction.h"
#include "collision_response/calibration/materials_output.h"
#include "collision_response/calibration/object_file.h"
#include "collision_response/calibration/progress_bar.h"

#ifndef IDENTIFY_PLOT_SCRIPT
#define IDENTIFY_PLOT_SCRIPT "scripts/plot_identification.py"
#endif

namespace collision_response::calibration {
namespace {

namespace fs = std::filesystem;

int integer(const std::string& flag, const std::string& text, int lowest) {
  char* end = nullptr;
  const long value = std::strtol(text.c_str(), &end, 10);
  if (end == text.c_str() || *end != '\0' || value < lowest || value > 1000000)
    throw std::runtime_error(flag + ": expected an integer >= " + std::to_string(lowest) +
                             ", not '" + text + "'");
  return static_cast<int>(value);
}

/// One pair of materials: its objects' landings and where they came from.
struct Pair {
  std::string a, b;
  std::vector<ObjectLandings> objects;
  std::vector<std::string> sources;
  int recordings = 0;
  std::map<std::string, int> skipped;
};

/// The plot's data: each landing's measured and predicted velocities (fit on all landings, and
/// held out), one row per landing.
void writePlotData(const std::string& path, const std::vector<Pair>& pairs,
                   const std::vector<MaterialsEntry>& entries) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot write");
  out << "pair,source,measured_vx,measured_vy,measured_vz,measured_wx,measured_wy,measured_wz,"
         "fitted_vx,fitted_vy,fitted_vz,fitted_wx,fitted_wy,fitted_wz,"
         "held_out_vx,held_out_vy,held_out_vz,held_out_wx,held_out_wy,held_out_wz\n";
  out.precision(9);
  for (size_t p = 0; p < pairs.size(); ++p) {
    size_t k = 0;
    for (const auto& o : pairs[p].objects) {
      const double length = lengthScale(o.object.shape);
      for (const auto& l : o.landings) {
        const double speed = l.before.linear_velocity.norm();
        Eigen::Matrix<double, 6, 1> measured;
        measured << l.after.linear_velocity, l.after.angular_velocity;
        auto predicted = [&](const LandingResidual& r) {
          Eigen::Matrix<double, 6, 1> v;
          v << l.after.linear_velocity + speed * r.head<3>(),
              l.after.angular_velocity + speed / length * r.tail<3>();
          return v;
        };
        out << pairs[p].a << "/" << pairs[p].b << "," << l.source;
        for (int i = 0; i < 6; ++i) out << "," << measured[i];
        const auto fitted = predicted(entries[p].fit.residuals[k]);
        for (int i = 0; i < 6; ++i) out << "," << fitted[i];
        if (entries[p].held_out.folds > 0) {
          const auto held = predicted(entries[p].held_out.held_out[k]);
          for (int i = 0; i < 6; ++i) out << "," << held[i];
        } else {
          for (int i = 0; i < 6; ++i) out << ",";
        }
        out << "\n";
        ++k;
      }
    }
  }
}

}  // namespace

std::string identifyUsage() {
  return "usage: identify --object OBJECT.yaml (--csv FILE_OR_DIR | --bag FILE.bag [--topic T |\n"
         "                --frame F --world-frame W]) ... [--object ...] --output materials.yaml\n"
         "       identify --object OBSTACLE.yaml --urdf ROBOT.urdf (--joint-csv FILE |\n"
         "                --bag FILE.bag --joint-states TOPIC) ... --output materials.yaml\n"
         "  --plot fit.png          predicted against measured velocities after each landing or\n"
         "                          impact (and its data in fit.csv)\n"
         "  --law newton|poisson|stronge   the impact law fitted for (default stronge)\n"
         "  --single-impact         score each landing's first impact, not the episode\n"
         "  --folds K               K-fold cross-validation (default 5; 0: none)\n"
         "  --threads N             worker threads (default: the machine's)\n"
         "  --friction one|two      one mu, or mu_s and mu_d (default one)\n"
         "  --fit-inertia           fit the object's inertia scale too\n"
         "  --landings-per-recording N   landings taken from each recording (default 1)\n"
         "  --clearance METRES      an object more than this above the floor is in flight\n"
         "                          (default 0.002; object landings only)\n"
         "  --loss-scale auto|S     the Cauchy loss's scale (default auto)\n"
         "  --gravity-compensation  robots: the joints hold the arm against gravity\n"
         "  --quiet                 no progress bar\n"
         "docs/calibration.md of the collision_response package tells more.\n";
}

IdentifyArguments parseIdentifyArguments(int argc, const char* const* argv) {
  IdentifyArguments a;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error(flag + ": needs a value");
      return argv[++i];
    };
    auto group = [&]() -> IdentifyInput& {
      if (a.inputs.empty()) throw std::runtime_error(flag + ": give --object OBJECT.yaml first");
      return a.inputs.back();
    };
    if (flag == "--object") {
      a.inputs.emplace_back();
      a.inputs.back().object = value();
    } else if (flag == "--csv") {
      const std::string v = value();
      group().csv.push_back(v);
    } else if (flag == "--bag") {
      const std::string v = value();
      group().bags.push_back(v);
    } else if (flag == "--topic") {
      group().topic = value();
    } else if (flag == "--frame") {
      group().frame = value();
    } else if (flag == "--world-frame") {
      group().world_frame = value();
    } else if (flag == "--output") {
      a.output = value();
    } else if (flag == "--plot") {
      a.plot = value();
    } else if (flag == "--law") {
      a.law = value();
      core::ImpactLaw law;
      if (!core::fromString(a.law, law))
        throw std::runtime_error("--law: newton, poisson or stronge, not '" + a.law + "'");
    } else if (flag == "--single-impact") {
      a.single_impact = true;
    } else if (flag == "--folds") {
      a.folds = integer(flag, value(), 0);
      if (a.folds == 1) throw std::runtime_error("--folds: 0 (none) or at least 2");
    } else if (flag == "--threads") {
      a.threads = integer(flag, value(), 1);
      if (a.threads > 256) throw std::runtime_error("--threads: at most 256");
    } else if (flag == "--friction") {
      const std::string v = value();
      if (v != "one" && v != "two") throw std::runtime_error("--friction: one or two");
      a.split_friction = v == "two";
    } else if (flag == "--fit-inertia") {
      a.fit_inertia = true;
    } else if (flag == "--landings-per-recording") {
      a.landings_per_recording = integer(flag, value(), 1);
    } else if (flag == "--clearance") {
      const std::string v = value();
      char* end = nullptr;
      const double c = std::strtod(v.c_str(), &end);
      if (end == v.c_str() || *end != '\0' || !std::isfinite(c) || c < 0.0)
        throw std::runtime_error("--clearance: a finite number of metres >= 0, not '" + v + "'");
      a.clearance = c;
    } else if (flag == "--loss-scale") {
      const std::string v = value();
      char* end = nullptr;
      a.loss_scale = v == "auto" ? 0.0 : std::strtod(v.c_str(), &end);
      if (v == "auto") continue;
      if (end == v.c_str() || *end != '\0' || !(a.loss_scale > 0.0) || !std::isfinite(a.loss_scale))
        throw std::runtime_error("--loss-scale: auto or a number > 0, not '" + v + "'");
    } else if (flag == "--urdf") {
      group().urdf = value();
    } else if (flag == "--joint-csv") {
      const std::string v = value();
      group().joint_csv.push_back(v);
    } else if (flag == "--joint-states") {
      group().joint_states = value();
    } else if (flag == "--gravity-compensation") {
      a.gravity_compensation = true;
    } else if (flag == "--quiet") {
      a.quiet = true;
    } else {
      throw std::runtime_error("unknown argument " + flag);
    }
  }
  if (a.inputs.empty()) throw std::runtime_error("--object: at least one object file is needed");
  for (const auto& input : a.inputs) {
    if (input.urdf.empty()) {
      if (!input.joint_csv.empty() || !input.joint_states.empty())
        throw std::runtime_error("--object " + input.object +
                                 ": --joint-csv and --joint-states need the robot's --urdf");
      continue;
    }
    if (!input.csv.empty())
      throw std::runtime_error("--object " + input.object +
                               ": --csv (object poses) with --urdf; a robot's joint positions are "
                               "--joint-csv");
    if (input.joint_csv.empty() && input.bags.empty())
      throw std::runtime_error("--object " + input.object +
                               ": give the robot's recordings (--joint-csv/--bag)");
    if (!input.bags.empty() && input.joint_states.empty())
      throw std::runtime_error("--bag: give --joint-states TOPIC (the robot's joint states)");
    if (!input.frame.empty() || !input.topic.empty() || !input.world_frame.empty())
      throw std::runtime_error("--object " + input.object +
                               ": --topic, --frame, --world-frame are for object poses, not with "
                               "--urdf");
  }
  bool robots = false, objects = false;
  for (const auto& input : a.inputs) (input.urdf.empty() ? objects : robots) = true;
  if (robots && objects)
    throw std::runtime_error(
        "--urdf: robot and object recordings in one run are not supported (run identify twice)");
  if (robots && a.clearance)
    throw std::runtime_error(
        "--clearance: for object landings; a robot's impacts are found as jumps in its joint "
        "velocities");
  for (const auto& input : a.inputs)
    if (input.urdf.empty() && input.csv.empty() && input.bags.empty())
      throw std::runtime_error("--object " + input.object + ": give its recordings (--csv/--bag)");
  for (const auto& input : a.inputs) {
    if (input.bags.empty() || !input.urdf.empty()) continue;
    if (input.topic.empty() && (input.frame.empty() || input.world_frame.empty()))
      throw std::runtime_error("--bag: give --topic T, or --frame F and --world-frame W (tf)");
    if (!input.topic.empty() && !input.frame.empty())
      throw std::runtime_error("--frame: not with --topic (a PoseStamped topic names its pose)");
  }
  if (a.output.empty()) throw std::runtime_error("--output: the materials YAML file is needed");
  return a;
}

std::vector<PoseTrack> splitAtGaps(const PoseTrack& track, double max_gap) {
  std::vector<PoseTrack> pieces;
  int first = 0;
  for (int i = 1; i <= track.size(); ++i) {
    if (i < track.size() && !(track.time[i] - track.time[i - 1] > max_gap)) continue;
    if (i - first >= 2) {
      PoseTrack piece;
      piece.source = track.source + " #" + std::to_string(pieces.size());
      piece.time.assign(track.time.begin() + first, track.time.begin() + i);
      piece.position.assign(track.position.begin() + first, track.position.begin() + i);
      piece.orientation.assign(track.orientation.begin() + first, track.orientation.begin() + i);
      pieces.push_back(std::move(piece));
    }
    first = i;
  }
  return pieces;
}

IdentificationOptions identificationOptions(const IdentifyArguments& args) {
  IdentificationOptions options;
  if (!core::fromString(args.law, options.prediction.law))
    throw std::runtime_error("--law: newton, poisson or stronge, not '" + args.law + "'");
  options.prediction.single_impact = args.single_impact;
  options.split_friction = args.split_friction;
  options.fit_inertia_scale = args.fit_inertia;
  options.loss_scale = args.loss_scale;
  return options;
}

ExtractionOptions extractionOptions(const IdentifyArguments& args) {
  ExtractionOptions extraction;
  extraction.max_landings = args.landings_per_recording;
  if (args.clearance) extraction.clearance = *args.clearance;
  return extraction;
}

std::string plotDataPath(const std::string& png) {
  return fs::path(png).replace_extension(".csv").string();
}

void plotIdentification(const std::string& data, const std::string& png,
                        const std::function<void(const std::string&)>& log) {
  // The script beside the program when installed (catkin_install_python), else the source's.
  std::error_code error;
  const fs::path beside =
      fs::read_symlink("/proc/self/exe", error).parent_path() / "plot_identification.py";
  const std::string script =
      !error && fs::exists(beside) ? beside.string() : std::string(IDENTIFY_PLOT_SCRIPT);
  const std::string command =
      "/usr/bin/python3 \"" + script + "\" \"" + data + "\" \"" + png + "\"";
  const int status = std::system(command.c_str());
  if (status != 0)
    log("no plot: " + script +
        " failed (matplotlib missing? apt-get install python3-matplotlib); its data is in " + data);
}

void runIdentify(const IdentifyArguments& args, const IdentifyReaders& readers,
                 std::function<void(const std::string&)> log) {
  if (args.robot())
    runRobotIdentify(args, readers, std::move(log));
  else
    runIdentify(args, readers.poses, std::move(log));
}

void runIdentify(const IdentifyArguments& args, const BagReader& read_bag,
                 std::function<void(const std::string&)> report) {
  if (args.robot()) {
    runRobotIdentify(args, IdentifyReaders{read_bag, {}, {}}, std::move(report));
    return;
  }
  ProgressBar bar(!args.quiet);
  const auto log = [&](const std::string& line) {
    bar.finish();  // a report line never shares the bar's line
    report(line);
  };
  IdentificationOptions options = identificationOptions(args);
  const ExtractionOptions extraction = extractionOptions(args);

  // Read and extract everything first: any bad input fails before a fit starts.
  std::vector<Pair> pairs;
  for (const IdentifyInput& input : args.inputs) {
    const ObjectModel object = loadObjectModel(input.object);
    auto it = std::find_if(pairs.begin(), pairs.end(), [&](const Pair& p) {
      return p.a == object.material_a && p.b == object.material_b;
    });
    if (it == pairs.end()) {
      pairs.push_back({object.material_a, object.material_b, {}, {}, 0, {}});
      it = pairs.end() - 1;
    }
    Pair& pair = *it;
    pair.objects.push_back({object, {}});
    std::vector<NumberedTrack> tracks;
    for (const auto& path : input.csv) {
      bar.update(0.0, "reading " + path);
      auto more = readCsvTracks(path);
      tracks.insert(tracks.end(), std::make_move_iterator(more.begin()),
                    std::make_move_iterator(more.end()));
      pair.sources.push_back(std::filesystem::path(path).filename().string() + " (CSV, object " +
                             std::filesystem::path(input.object).filename().string() + ")");
    }
    for (const auto& path : input.bags) {
      if (!read_bag) throw std::runtime_error(path + ": this identify reads no rosbags");
      bar.update(0.0, "reading " + path);
      int n = 0;
      for (auto& track : splitAtGaps(read_bag(path, input), kMaxRecordingGap))
        tracks.push_back({n++, std::move(track)});
      pair.sources.push_back(std::filesystem::path(path).filename().string() + " (rosbag, object " +
                             std::filesystem::path(input.object).filename().string() + ")");
    }
    for (const auto& t : tracks) {
      ++pair.recordings;
      const auto extractions =
          extractLandings(t.track, object.shape, object.floor_height, extraction);
      for (const Extraction& x : extractions) {
        if (x.no_landing)
          throw std::runtime_error(t.track.source + ": no landing (" + x.reason + ")");
        if (x.ok) {
          pair.objects.back().landings.push_back(x.landing);
          pair.objects.back().landings.back().recording = t.number;
        } else {
          ++pair.skipped[x.reason];
        }
      }
    }
  }
  for (const Pair& pair : pairs) {
    int landings = 0;
    for (const auto& o : pair.objects) landings += static_cast<int>(o.landings.size());
    if (landings == 0)
      throw std::runtime_error(pair.a + " on " + pair.b + ": no usable landing in " +
                               std::to_string(pair.recordings) + " recordings");
    if (args.folds > landings)
      throw std::runtime_error("--folds " + std::to_string(args.folds) + ": only " +
                               std::to_string(landings) + " landings of " + pair.a + " on " +
                               pair.b);
    std::string line = pair.a + " on " + pair.b + ": " + std::to_string(pair.recordings) +
                       " recordings, " + std::to_string(landings) + " landings";
    for (const auto& [reason, count] : pair.skipped)
      line += "; " + std::to_string(count) + " skipped: " + reason;
    log(line);
  }

  const int threads = args.threads > 0
                          ? args.threads
                          : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  core::WorkerPool pool(threads);
  const int fits_per_pair = 1 + args.folds;
  const int total_fits = fits_per_pair * static_cast<int>(pairs.size());
  int fits_done = 0;
  std::vector<MaterialsEntry> entries;
  for (const Pair& pair : pairs) {
    MaterialsEntry entry;
    entry.material_a = pair.a;
    entry.material_b = pair.b;
    entry.sources = pair.sources;
    entry.recordings = pair.recordings;
    entry.skipped.assign(pair.skipped.begin(), pair.skipped.end());
    entry.method = std::string(args.single_impact ? "one impact" : "episode") + ", " + args.law +
                   ", " + (args.split_friction ? "mu_s and mu_d" : "one mu") +
                   (args.fit_inertia ? ", inertia scale" : "");
    std::string stage;
    options.progress = [&](int iteration) {
      bar.update((fits_done + std::min(1.0, iteration / 20.0)) / total_fits,
                 pair.a + "/" + pair.b + " " + stage + ", iteration " + std::to_string(iteration));
    };
    stage = "fit";
    entry.fit = identifyCoefficients(pair.objects, options, pool);
    char scale[64];
    std::snprintf(scale, sizeof scale, ", Cauchy loss scale %.4f%s", entry.fit.loss_scale,
                  args.loss_scale == 0.0 ? " (automatic)" : "");
    entry.method += scale;
    ++fits_done;
    if (args.folds > 0) {
      entry.held_out = crossValidate(
          pair.objects, options, args.folds, pool,
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
    std::snprintf(buffer, sizeof buffer, "; RMS v %.3f w %.3f", f.rms_linear, f.rms_angular);
    line += buffer;
    if (args.folds > 0) {
      std::snprintf(buffer, sizeof buffer, "; held out (%d-fold) v %.3f w %.3f", args.folds,
                    entry.held_out.rms_linear, entry.held_out.rms_angular);
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
    writePlotData(data, pairs, entries);
    log("wrote " + data);
    plotIdentification(data, args.plot, log);
  }
}

}  // namespace collision_response::calibration
