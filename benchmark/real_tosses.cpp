// The real-tosses benchmark (docs/benchmarks.md, "Real tosses"): 570 tracked tosses of a cube
// onto a table (benchmark/data/cube_tosses), each toss's first landing extracted (toss_data.h),
// every landing model (landing_model.h: baselines, ours, the peers) fitted on the even-numbered
// tosses and scored on the odd-numbered ones.
//
//   real_tosses [--data tosses.csv.gz] [--markdown out.md] [--models SUBSTRING] [--starts N]
//               [--max-evaluations N] [--clearance M] [--min-post-frames N]
//               [--max-landing-duration S] [--errors out.csv] [--list] [--check]
//
// --list prints each toss's extraction (kept or why not); --check runs only the extraction's
// sanity checks (exit status 1 if one fails); --models keeps the models whose name contains the
// substring (repeatable).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "landing_baselines.h"
#include "landing_fit.h"
#include "landing_ours.h"
#include "toss_data.h"
// The peer engines' landing models (Bullet, ODE, MuJoCo: benchmark/landing_peers.h), when the
// build has the landing_peers library.
#ifdef HAVE_LANDING_PEERS
#include "landing_peers.h"
#endif

#ifndef TOSS_DATA
#define TOSS_DATA "benchmark/data/cube_tosses/tosses.csv.gz"
#endif

using namespace collision_response;
using namespace collision_response::bench;

namespace {

struct Arguments {
  std::string data = TOSS_DATA;
  std::string markdown;
  std::string errors;  ///< each held-out landing's errors per model, CSV ("" = none)
  std::vector<std::string> models;
  FitOptions fit;
  ExtractionOptions extraction;
  bool list = false;
  bool check = false;
};

Arguments parse(int argc, char** argv) {
  Arguments a;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error(arg + " needs a value");
      return argv[++i];
    };
    if (arg == "--data")
      a.data = value();
    else if (arg == "--markdown")
      a.markdown = value();
    else if (arg == "--errors")
      a.errors = value();
    else if (arg == "--models")
      a.models.push_back(value());
    else if (arg == "--starts")
      a.fit.starts = std::stoi(value());
    else if (arg == "--max-evaluations")
      a.fit.max_evaluations = std::stoi(value());
    else if (arg == "--clearance")
      a.extraction.clearance = std::stod(value());
    else if (arg == "--min-post-frames")
      a.extraction.min_post_frames = std::stoi(value());
    else if (arg == "--max-landing-duration")
      a.extraction.max_landing_duration = std::stod(value());
    else if (arg == "--list")
      a.list = true;
    else if (arg == "--check")
      a.check = true;
    else
      throw std::runtime_error("unknown argument " + arg);
  }
  // A fit needs at least one start and one evaluation (the starting simplex is evaluated anyway).
  if (a.fit.starts < 1) throw std::runtime_error("--starts must be at least 1");
  if (a.fit.max_evaluations < 1) throw std::runtime_error("--max-evaluations must be at least 1");
  return a;
}

/// Every model of the comparison, in table order.
std::vector<std::unique_ptr<LandingModel>> allModels(const TossedCube& cube) {
  std::vector<std::unique_ptr<LandingModel>> models;
  models.push_back(makeNoChangeLanding(cube));
  models.push_back(makeBounceRuleLanding(cube));
  models.push_back(makeScalingLanding(cube));
  for (const core::ImpactLaw law :
       {core::ImpactLaw::kNewton, core::ImpactLaw::kPoisson, core::ImpactLaw::kStronge}) {
    for (const bool split : {false, true}) {
      models.push_back(makeOneImpactLanding(cube, law, split));
      models.push_back(makeRepeatedImpactsLanding(cube, law, split));
      models.push_back(makeEpisodeLanding(cube, law, split));
    }
  }
#ifdef HAVE_LANDING_PEERS
  for (auto& peer : makeLandingPeers()) models.push_back(std::move(peer));  // stepping at 1 ms
#endif
  return models;
}

struct ExtractionSummary {
  int tosses = 0;
  std::map<std::string, int> dropped;  ///< by reason
  std::vector<Landing> landings;
};

ExtractionSummary extractAll(const std::vector<TossFrames>& tosses, const TossedCube& cube,
                             const ExtractionOptions& options, bool list) {
  ExtractionSummary summary;
  summary.tosses = static_cast<int>(tosses.size());
  for (const TossFrames& toss : tosses) {
    const Extraction x = extractLanding(toss, cube, options);
    if (list) {
      const Landing& l = x.landing;
      std::printf("toss %3d  %-48s table %+6.2f mm", toss.index, x.ok ? "kept" : x.reason.c_str(),
                  1e3 * l.table);
      if (x.ok)
        std::printf(
            "  pre %2d fr rms %.2f mm %.2f deg  post %2d fr rms %.2f mm %.2f deg  gap %.1f ms"
            "  |v| %.2f -> %.2f  |w| %.1f -> %.1f  E %.3f -> %.3f J",
            l.pre.last - l.pre.first + 1, 1e3 * l.pre.position_rms, l.pre.rotation_rms * 180 / M_PI,
            l.post.last - l.post.first + 1, 1e3 * l.post.position_rms,
            l.post.rotation_rms * 180 / M_PI, 1e3 * (l.t_after - l.t_before),
            l.before.linear_velocity.norm(), l.after.linear_velocity.norm(),
            l.before.angular_velocity.norm(), l.after.angular_velocity.norm(),
            cubeEnergy(l.before, cube, options.gravity_z),
            cubeEnergy(l.after, cube, options.gravity_z));
      std::printf("\n");
    }
    if (x.ok)
      summary.landings.push_back(x.landing);
    else
      ++summary.dropped[x.reason];
  }
  return summary;
}

/// The extraction's sanity checks on the real data (docs/benchmarks.md, "Real tosses"): returns
/// the failures, one line each.
std::vector<std::string> checkExtraction(const ExtractionSummary& s, const TossedCube& cube,
                                         const ExtractionOptions& options) {
  std::vector<std::string> failures;
  const int kept = static_cast<int>(s.landings.size());
  if (kept < 250 || kept > 400)
    failures.push_back("kept " + std::to_string(kept) + " landings, expected 250..400");
  for (const Landing& l : s.landings) {
    const std::string toss = "toss " + std::to_string(l.recording) + ": ";
    if (l.pre.position_rms > 0.002)
      failures.push_back(toss + "pre-impact centre fit RMS " + std::to_string(l.pre.position_rms));
    if (cubeEnergy(l.after, cube, options.gravity_z) >
        cubeEnergy(l.before, cube, options.gravity_z))
      failures.push_back(toss + "energy after the landing exceeds the energy before");
    if (std::abs(l.table) > 0.01) failures.push_back(toss + "table 1 cm off z = 0");
  }
  return failures;
}

std::string fixed(double x, int digits) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", digits, x);
  return buffer;
}

struct Row {
  std::string model;
  std::vector<LandingParameter> parameters;
  FitResult fit;
  LandingScore score;
  double fit_seconds = 0.0;
  std::string ends;  ///< how the held-out landings ended (landingEnds()), "" if not told
};

std::string parameterText(const Row& row) {
  std::string text;
  for (size_t i = 0; i < row.parameters.size(); ++i)
    text += (i ? ", " : "") + row.parameters[i].name + " " + fixed(row.fit.values[i], 3);
  return text.empty() ? "-" : text;
}

bool startsWith(const std::string& s, const char* prefix) {
  return s.rfind(prefix, 0) == 0;
}
bool isOurs(const Row& r) {
  return startsWith(r.model, "one impact") || startsWith(r.model, "repeated impacts") ||
         startsWith(r.model, "episode");
}
bool isBaseline(const Row& r) {
  return r.model == "no change" || r.model == "bounce rule" || r.model == "3-factor scaling";
}

/// The goal, per row of ours that follows the whole landing (episode, or repeated impacts
/// when there is no episode): lower RMS and median errors than every other model (baselines and
/// peers), and its time against the fastest peer's.
std::vector<std::string> goalLines(const std::vector<Row>& rows) {
  bool have_episode = false;
  for (const Row& r : rows) have_episode |= startsWith(r.model, "episode");
  const char* ours = have_episode ? "episode" : "repeated impacts";
  std::vector<std::string> lines;
  for (const Row& r : rows) {
    if (!startsWith(r.model, ours)) continue;
    std::string beaten_by;
    double fastest_peer = std::numeric_limits<double>::infinity();
    std::string fastest_name;
    for (const Row& o : rows) {
      if (isOurs(o)) continue;
      if (!isBaseline(o) && o.score.median_time_us < fastest_peer) {
        fastest_peer = o.score.median_time_us;
        fastest_name = o.model;
      }
      std::string worse;
      if (o.score.rms_linear <= r.score.rms_linear) worse += ", RMS v";
      if (o.score.median_linear <= r.score.median_linear) worse += ", median v";
      if (o.score.rms_angular <= r.score.rms_angular) worse += ", RMS w";
      if (o.score.median_angular <= r.score.median_angular) worse += ", median w";
      if (!worse.empty())
        beaten_by += (beaten_by.empty() ? "" : "; ") + o.model + " (" + worse.substr(2) + ")";
    }
    std::string line = r.model + ": " +
                       (beaten_by.empty() ? "beats every baseline and peer in RMS and median"
                                          : "matched or beaten by " + beaten_by);
    if (std::isfinite(fastest_peer))
      line += "; the fastest peer's time over ours: " +
              fixed(fastest_peer / r.score.median_time_us, 1) + " (" + fastest_name + " " +
              fixed(fastest_peer, 1) + " us, ours " + fixed(r.score.median_time_us, 1) +
              " us per landing)";
    lines.push_back(line);
  }
  return lines;
}

void printTable(const std::vector<Row>& rows) {
  std::printf("\n%-36s %-40s %8s | %8s %8s | %8s %8s | %9s\n", "model", "fitted (training half)",
              "train", "RMS v", "med v", "RMS w", "med w", "us/land");
  for (const Row& r : rows)
    std::printf(
        "%-36s %-40s %8.3f | %8.3f %8.3f | %8.3f %8.3f | %9.1f%s\n", r.model.c_str(),
        parameterText(r).c_str(), r.fit.objective, r.score.rms_linear, r.score.median_linear,
        r.score.rms_angular, r.score.median_angular, r.score.median_time_us,
        r.score.failures ? (" (" + std::to_string(r.score.failures) + " failed)").c_str() : "");
  std::printf("\n");
  for (const auto& line : goalLines(rows)) std::printf("goal: %s\n", line.c_str());
}

void writeMarkdown(const std::string& path, const std::vector<Row>& rows,
                   const ExtractionSummary& summary, int training, int held_out,
                   const std::string& command) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot write");
  out << "## Real tosses\n\n"
      << "The first landing of each of " << summary.tosses
      << " tracked tosses of a 0.37 kg cube onto a table (`benchmark/data/cube_tosses`; how the "
         "landings are extracted, the split, the metric and the fit: docs/benchmarks.md, \"Real "
         "tosses\"). "
      << summary.landings.size() << " landings kept (";
  bool first = true;
  for (const auto& [reason, count] : summary.dropped) {
    out << (first ? "" : "; ") << count << " dropped: " << reason;
    first = false;
  }
  out << "); every model's parameters fitted on the " << training
      << " even-numbered tosses, scored on the " << held_out
      << " odd-numbered ones. Errors relative to the pre-impact speed: "
         "|v_predicted - v_measured| / |v_before| (v) and h |w_predicted - w_measured| / "
         "|v_before| "
         "(w; h the half width) at the start of the measured post-landing flight. Time: median "
         "wall time of one landing "
         "(simulate(), from the pre-impact flight to the post-landing flight) on a shared "
         "machine.\n\n"
      << "Command: `" << command << "`\n\n"
      << "| model | fitted parameters | RMS v | median v | RMS w | median w | us per landing |\n"
      << "|---|---|---:|---:|---:|---:|---:|\n";
  for (const Row& r : rows)
    out << "| " << r.model << " | " << parameterText(r) << " | " << fixed(r.score.rms_linear, 3)
        << " | " << fixed(r.score.median_linear, 3) << " | " << fixed(r.score.rms_angular, 3)
        << " | " << fixed(r.score.median_angular, 3) << " | " << fixed(r.score.median_time_us, 1)
        << (r.score.failures ? " (" + std::to_string(r.score.failures) + " failed)" : "") << " |\n";
  // The differences beyond the sampling noise: ours (episode, or repeated impacts) under the
  // default law and under Newton's, against each baseline and peer, paired bootstrap.
  bool have_episode = false;
  for (const Row& r : rows) have_episode |= startsWith(r.model, "episode");
  const std::string kind = have_episode ? "episode" : "repeated impacts";
  for (const std::string& ours : {kind + ", stronge, mu", kind + ", newton, mu"}) {
    const Row* a = nullptr;
    for (const Row& r : rows)
      if (r.model == ours) a = &r;
    if (a == nullptr) continue;
    out << "\nRMS of `" << ours
        << "` minus that of each baseline and peer on the same held-out landings, with the 95 % "
           "interval of a paired bootstrap (below 0: ours more accurate beyond the sampling "
           "noise):\n\n| against | v | w |\n|---|---|---|\n";
    for (const Row& b : rows) {
      if (isOurs(b)) continue;
      const RmsDifference v = pairedRmsDifference(a->score.linear, b.score.linear);
      const RmsDifference w = pairedRmsDifference(a->score.angular, b.score.angular);
      out << "| " << b.model << " | " << fixed(v.difference, 3) << " [" << fixed(v.lower, 3) << ", "
          << fixed(v.upper, 3) << "] | " << fixed(w.difference, 3) << " [" << fixed(w.lower, 3)
          << ", " << fixed(w.upper, 3) << "] |\n";
    }
  }
  bool told = false;
  for (const Row& r : rows) {
    if (r.ends.empty()) continue;
    if (!told)
      out << "\nHow the held-out landings ended (the episode: its end reason, after which the "
             "harness continues in free flight; the repeated impacts: their number):\n\n";
    told = true;
    out << "- " << r.model << ": " << r.ends << "\n";
  }
  const auto goal = goalLines(rows);
  if (!goal.empty()) {
    out << "\nThe issue's goal (lower RMS and median errors, v and w, than every baseline and "
           "peer; "
           "time per landing against the fastest peer's):\n\n";
    for (const auto& line : goal) out << "- " << line << "\n";
  }
}

/// Each held-out landing's errors, one line per landing and model (toss, model, v, w; the metric
/// of the table), to see which landings make a model's RMS.
void writeErrors(const std::string& path, const std::vector<Row>& rows,
                 const std::vector<Landing>& held_out) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot write");
  out << "toss,model,v,w\n";
  for (const Row& r : rows)
    for (size_t i = 0; i < r.score.linear.size() && i < held_out.size(); ++i)
      out << held_out[i].recording << ",\"" << r.model << "\"," << r.score.linear[i] << ','
          << r.score.angular[i] << '\n';
}

}  // namespace

int main(int argc, char** argv) try {
  const Arguments args = parse(argc, argv);
  std::string command = "real_tosses";
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) == "--markdown" || std::string(argv[i]) == "--errors") {
      ++i;  // where the outputs go is no part of how their numbers were made
      continue;
    }
    const std::string arg = argv[i];
    command += arg.find(' ') == std::string::npos ? " " + arg : " \"" + arg + "\"";
  }
  const TossedCube cube;
  const ExtractionOptions options = args.extraction;
  const std::vector<TossFrames> tosses = readTosses(args.data);
  const ExtractionSummary summary = extractAll(tosses, cube, options, args.list);
  std::printf("real_tosses: %d tosses, %zu landings kept", summary.tosses, summary.landings.size());
  for (const auto& [reason, count] : summary.dropped)
    std::printf("; %d dropped: %s", count, reason.c_str());
  std::printf("\n");
  if (args.check) {
    const auto failures = checkExtraction(summary, cube, options);
    for (const auto& f : failures) std::printf("check failed: %s\n", f.c_str());
    std::printf("real_tosses --check: %s\n", failures.empty() ? "ok" : "FAILED");
    return failures.empty() ? 0 : 1;
  }
  if (args.list) return 0;

  // The split: even toss index trains, odd is held out (fixed, the same for every model).
  std::vector<Landing> training, held_out;
  for (const Landing& l : summary.landings)
    (l.recording % 2 == 0 ? training : held_out).push_back(l);
  std::printf("real_tosses: %zu training landings (even tosses), %zu held out (odd)\n",
              training.size(), held_out.size());

  std::vector<Row> rows;
  for (auto& model : allModels(cube)) {
    if (!args.models.empty()) {
      bool wanted = false;
      for (const auto& m : args.models) wanted |= model->name().find(m) != std::string::npos;
      if (!wanted) continue;
    }
    Row row;
    row.model = model->name();
    row.parameters = model->parameters();
    const auto start = std::chrono::steady_clock::now();
    row.fit = fitLandingModel(*model, training, cube, args.fit);
    row.fit_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    row.score = scoreLandingModel(*model, row.fit.values, held_out, cube);
    landingEnds(*model);  // forget the fit's and the scoring's, then count each landing once
    for (const Landing& l : held_out) {
      try {
        model->simulate(l.before, row.fit.values, l.t_after - l.t_before);
      } catch (const std::exception&) {
      }
    }
    row.ends = landingEnds(*model);
    std::printf("  %-36s fitted in %6.1f s (%d evaluations): %s%s\n", row.model.c_str(),
                row.fit_seconds, row.fit.evaluations, parameterText(row).c_str(),
                row.ends.empty() ? "" : ("; held-out landings ended: " + row.ends).c_str());
    std::fflush(stdout);
    rows.push_back(row);
  }
  printTable(rows);
  if (!args.errors.empty()) {
    writeErrors(args.errors, rows, held_out);
    std::printf("real_tosses: wrote %s\n", args.errors.c_str());
  }
  if (!args.markdown.empty()) {
    writeMarkdown(args.markdown, rows, summary, static_cast<int>(training.size()),
                  static_cast<int>(held_out.size()), command);
    std::printf("real_tosses: wrote %s\n", args.markdown.c_str());
  }
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "real_tosses: %s\n", e.what());
  return 2;
}
