// The identify program (docs/calibration.md, "Command line"):
//
//   identify --object OBJECT.yaml (--csv FILE_OR_DIR ... |
//            --bag FILE.bag [--topic T | --frame F --world-frame W] ...) [--object ...]
//            --output materials.yaml [--plot fit.png] [--law newton|poisson|stronge]
//            [--single-impact] [--folds K] [--threads N] [--friction one|two] [--fit-inertia]
//            [--landings-per-recording N] [--clearance METRES] [--loss-scale auto|S] [--quiet]
//   identify --object OBSTACLE.yaml --urdf ROBOT.urdf (--joint-csv FILE ... |
//            --bag FILE.bag --joint-states TOPIC ...) [--object ...] --output materials.yaml
//            [--plot fit.png] [--gravity-compensation] [the fit's flags above, not --clearance]
//
// Each --object starts a group; the --csv / --bag after it are its recordings. Groups naming the
// same pair of materials are fitted together; one ~materials entry per pair. A rosbag's poses are
// read from tf (--frame, the object's frame, in --world-frame, z up) or from a PoseStamped topic
// (--topic); the flags apply to the group's bags. A bag's track is cut where no pose came for
// longer than kMaxRecordingGap (between tosses), each piece a recording.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "collision_response/calibration/identification.h"
#include "collision_response/calibration/joint_track.h"
#include "collision_response/calibration/landing_extraction.h"
#include "collision_response/calibration/pose_track.h"
#include "collision_response/calibration/robot_impact_prediction.h"

namespace collision_response::calibration {

struct IdentifyInput {
  std::string object;             ///< the object file
  std::vector<std::string> csv;   ///< CSV files or folders
  std::vector<std::string> bags;  ///< rosbags
  std::string topic;              ///< bags: a geometry_msgs/PoseStamped topic; "": tf
  std::string frame;              ///< bags on tf: the object's frame
  std::string world_frame;        ///< bags: the fixed frame (z up)
  /// A robot's recordings (docs/calibration.md, "Robot recordings"): the robot's URDF; the object
  /// file is then the fixed obstacle it strikes.
  std::string urdf;
  std::vector<std::string> joint_csv;  ///< CSV files of time and joint positions
  std::string joint_states;            ///< bags: a sensor_msgs/JointState topic
};

/// A rosbag's track is cut into recordings where no pose came for longer than this [s].
constexpr double kMaxRecordingGap = 0.25;

/// The pieces of `track` between gaps in time longer than max_gap [s], in order, each with the
/// track's source and its piece number ("bag:/tf world->cube #2"); pieces of fewer than 2 samples
/// are dropped.
std::vector<PoseTrack> splitAtGaps(const PoseTrack& track, double max_gap);

/// The same for a robot's joint track (a bag holds many strikes in one stream); pieces of fewer
/// than 2 samples are dropped.
std::vector<JointTrack> splitAtGaps(const JointTrack& track, double max_gap);

struct IdentifyArguments {
  std::vector<IdentifyInput> inputs;
  std::string output;  ///< materials YAML
  /// PNG, "" for none (its data goes to the same name with .csv, plotIdentification()): the
  /// landings' velocities, or a robot's joint velocities after its impacts.
  std::string plot;
  std::string law = "stronge";
  bool single_impact = false;
  int folds = 5;    ///< 0: no cross-validation
  int threads = 0;  ///< 0: the machine's
  bool split_friction = false;
  bool fit_inertia = false;
  int landings_per_recording = 1;
  /// --clearance [m], >= 0: a sample is in flight when the object's lowest point is more than this
  /// above the floor (ExtractionOptions::clearance); unset: that default. Object landings only.
  std::optional<double> clearance;
  double loss_scale = 0.0;  ///< 0: automatic (IdentificationOptions::loss_scale)
  bool quiet = false;       ///< no progress bar
  /// Robot recordings: the robot holds itself against gravity between impacts (tau = g(q));
  /// else its joints are passive.
  bool gravity_compensation = false;
  bool robot() const {
    for (const auto& input : inputs)
      if (!input.urdf.empty()) return true;
    return false;
  }
};

/// The program's usage text (its flags, one line each), printed by --help and after a bad flag.
std::string identifyUsage();

/// Parses argv[1..]; throws std::runtime_error naming the flag.
IdentifyArguments parseIdentifyArguments(int argc, const char* const* argv);

/// The identification's options that the arguments ask for: the law (--law), one impact or the
/// episode (--single-impact), one or two friction coefficients (--friction), the inertia scale
/// (--fit-inertia), the loss scale (--loss-scale); the rest at IdentificationOptions' defaults.
/// Throws std::runtime_error naming --law for an unknown law.
IdentificationOptions identificationOptions(const IdentifyArguments& arguments);

/// The landing extraction's options that the arguments ask for: the landings per recording
/// (--landings-per-recording) and the clearance (--clearance); the rest at ExtractionOptions'
/// defaults.
ExtractionOptions extractionOptions(const IdentifyArguments& arguments);

/// The plot's data file for the PNG `png`: the same name with .csv.
std::string plotDataPath(const std::string& png);

/// Draws `png` from the data file `data` with scripts/plot_identification.py (beside the installed
/// program, else the source tree's), run by /usr/bin/python3; the one plot for landings (a row per
/// landing: measured, fitted and held-out velocities) and robot impacts (a row per joint and
/// impact: its velocity after the impact, measured and predicted). Without the script or matplotlib
/// it logs why and where the data is; the fit's output is not affected.
void plotIdentification(const std::string& data, const std::string& png,
                        const std::function<void(const std::string&)>& log);

/// Reads the poses of one rosbag as given by an input's topic / frame / world_frame (the ros
/// library's reader, wired in by the program's main); throws naming the bag.
using BagReader = std::function<PoseTrack(const std::string& bag, const IdentifyInput& input)>;

/// Reads a robot's joint positions from a rosbag's sensor_msgs/JointState topic (the ros library's
/// reader); throws naming the bag and topic.
using JointBagReader = std::function<JointTrack(const std::string& bag, const std::string& topic)>;

/// Reads a robot (its dynamics and links' collision geometry) from a URDF file; throws naming it.
using RobotLoader = std::function<RobotDescription(const std::string& urdf)>;

struct IdentifyReaders {
  BagReader poses;        ///< rosbags of an object's poses
  JointBagReader joints;  ///< rosbags of a robot's joint states
  RobotLoader robot;      ///< URDF files
};

/// Runs the identification and writes the output (and the plot). Report lines go to `log`.
/// Throws std::runtime_error naming the source on bad input; nothing is written then.
void runIdentify(const IdentifyArguments& arguments, const BagReader& read_bag,
                 std::function<void(const std::string&)> log);

/// The same with readers for robots' recordings too: a run with --urdf identifies from robot
/// impacts (runRobotIdentify()).
void runIdentify(const IdentifyArguments& arguments, const IdentifyReaders& readers,
                 std::function<void(const std::string&)> log);

/// The identification from a robot's recorded impacts (docs/calibration.md, "Robot recordings"):
/// each group's joint tracks (CSV or bags), their impacts (extractRobotImpacts()), each a case
/// scored by RobotImpactPredictor against the group's obstacle, groups naming the same materials
/// fitted together; output as runIdentify()'s, and the plot of each impact's joint velocities.
void runRobotIdentify(const IdentifyArguments& arguments, const IdentifyReaders& readers,
                      std::function<void(const std::string&)> log);

}  // namespace collision_response::calibration
