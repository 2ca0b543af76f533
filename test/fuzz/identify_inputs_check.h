// The identify program's input path on arbitrary bytes, for its fuzz target
// (fuzz_identify_inputs.cpp) and the replay of its findings (test_fuzz_identify_regressions.cpp):
// an object file (calibration::parseObjectModel) and a CSV recording (calibration::readCsvTracks,
// from a file, as identify reads it), then the landings of every recording
// (calibration::extractLandings) with the object's shape and floor. No Ceres, no ROS.
//
// The bytes: the object file's text, a line "%%", the CSV file's bytes. Without a "%%" line the
// whole input is the CSV, read with a default object (the 0.1048 m cube of the tosses, floor
// found from rest).
//
// An outcome is a bug if anything crashes or hangs (the fuzzer's job), if an exception other than
// std::runtime_error escapes, if an error does not begin with its source (the object file's name,
// maybe with a line; the CSV file's path; the recording's source for an extraction error), or if
// an accepted object or an extracted landing holds a non-finite number.
#pragma once

#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "collision_response/calibration/csv_tracks.h"
#include "collision_response/calibration/landing_extraction.h"
#include "collision_response/calibration/object_file.h"

namespace collision_response::fuzz {

constexpr const char* kIdentifyObjectName = "fuzz-object.yaml";
constexpr const char* kIdentifyDefaultObject =
    "shape: {type: box, size: [0.1048, 0.1048, 0.1048]}\nmass: 0.37\nmaterial_a: cube\n"
    "material_b: floor\n";

struct IdentifyInputsOutcome {
  std::string bug;     ///< empty unless an invariant broke
  std::string error;   ///< the clear error the input got, if any
  int recordings = 0;  ///< read from the CSV
  int landings = 0;    ///< extracted (ok)
};

namespace identify_detail {

inline bool finite(const Eigen::Vector3d& v) {
  return v.allFinite();
}
inline bool finite(const Eigen::Quaterniond& q) {
  return q.coeffs().allFinite();
}
inline bool finite(const calibration::MotionState& s) {
  return finite(s.position) && finite(s.orientation) && finite(s.linear_velocity) &&
         finite(s.angular_velocity);
}
inline bool startsWith(const std::string& text, const std::string& prefix) {
  return text.compare(0, prefix.size(), prefix) == 0;
}

}  // namespace identify_detail

/// Runs the input path on `data`; the CSV goes through a file at `csv_path` (written here).
inline IdentifyInputsOutcome runIdentifyInputs(const std::uint8_t* data, std::size_t size,
                                               const std::string& csv_path) {
  using namespace calibration;
  using identify_detail::finite;
  using identify_detail::startsWith;
  IdentifyInputsOutcome out;
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  std::string yaml = kIdentifyDefaultObject, csv = bytes;
  std::size_t split = std::string::npos;
  if (startsWith(bytes, "%%\n"))
    split = 0;
  else if (const std::size_t at = bytes.find("\n%%\n"); at != std::string::npos)
    split = at + 1;
  if (split != std::string::npos) {
    yaml = bytes.substr(0, split);
    csv = bytes.substr(split + 3);
  }

  ObjectModel object;
  try {
    object = parseObjectModel(yaml, kIdentifyObjectName);
  } catch (const std::runtime_error& e) {
    out.error = e.what();
    if (!startsWith(out.error, std::string(kIdentifyObjectName) + ":"))  // "file: " or "file:3: "
      out.bug = "an object file error not naming the file: " + out.error;
    return out;
  }
  bool ok = std::isfinite(object.mass) && object.mass > 0.0 && object.inertia.allFinite() &&
            (!object.floor_height || std::isfinite(*object.floor_height));
  for (double d : object.shape.dimensions) ok = ok && std::isfinite(d) && d > 0.0;
  if (!ok) {
    out.bug = "an object accepted with a non-finite or non-positive number";
    return out;
  }

  {
    std::ofstream file(csv_path, std::ios::binary | std::ios::trunc);
    file.write(csv.data(), static_cast<std::streamsize>(csv.size()));
  }
  std::vector<NumberedTrack> tracks;
  try {
    tracks = readCsvTracks(csv_path);
  } catch (const std::runtime_error& e) {
    out.error = e.what();
    if (!startsWith(out.error, csv_path + ":"))
      out.bug = "a CSV error not naming the file: " + out.error;
    return out;
  }
  out.recordings = static_cast<int>(tracks.size());
  for (const NumberedTrack& t : tracks) {
    for (int k = 0; k < t.track.size(); ++k)
      if (!std::isfinite(t.track.time[k]) || !finite(t.track.position[k]) ||
          !finite(t.track.orientation[k])) {
        out.bug = t.track.source + ": a non-finite sample read without an error";
        return out;
      }
    std::vector<Extraction> extractions;
    try {
      extractions = extractLandings(t.track, object.shape, object.floor_height);
    } catch (const std::runtime_error& e) {
      out.error = e.what();
      if (!startsWith(out.error, t.track.source + ": "))
        out.bug = "an extraction error not naming the recording: " + out.error;
      return out;
    }
    if (extractions.empty()) {
      out.bug = t.track.source + ": extractLandings() returned nothing (at least one entry)";
      return out;
    }
    for (const Extraction& x : extractions) {
      if (!x.ok) {
        if (x.reason.empty()) out.bug = t.track.source + ": a skipped landing without a reason";
        continue;
      }
      const Landing& l = x.landing;
      const bool landing_ok = finite(l.before) && finite(l.after) && std::isfinite(l.t_before) &&
                              std::isfinite(l.t_after) && l.t_after > l.t_before &&
                              std::isfinite(l.table) && std::isfinite(l.pre.position_rms) &&
                              std::isfinite(l.post.position_rms) &&
                              l.before.linear_velocity.norm() > 0.0;
      if (!landing_ok) {
        out.bug = t.track.source +
                  ": a landing with a non-finite number (or t_after <= t_before"
                  ", or no speed before it)";
        return out;
      }
      ++out.landings;
    }
  }
  return out;
}

}  // namespace collision_response::fuzz
