#include "collision_response/calibration/csv_tracks.h"

#include "collision_response/calibration/csv_lines.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>

namespace collision_response::calibration {
namespace {

const char* const kColumns[] = {"toss", "t", "x", "y", "z", "qw", "qx", "qy", "qz"};

/// The number in a file name's stem (toss_012.csv -> 12), or -1.
int numberInName(const std::string& path) {
  std::string stem = std::filesystem::path(path).filename().string();
  stem = stem.substr(0, stem.find('.'));
  const auto end = stem.find_last_of("0123456789");
  if (end == std::string::npos) return -1;
  auto begin = end;
  while (begin > 0 && std::isdigit(static_cast<unsigned char>(stem[begin - 1]))) --begin;
  return std::atoi(stem.substr(begin, end - begin + 1).c_str());
}

void readFile(const std::string& path, int fallback_number, std::vector<NumberedTrack>& out) {
  CsvLines lines(path);
  bool numbered = false;  // the toss column is present
  const size_t first_out = out.size();
  auto fail = [&](const std::string& what) { lines.fail(what); };
  while (lines.next()) {
    const std::string& line = lines.line();
    if (lines.number() == 1) {
      if (line == "toss,t,x,y,z,qw,qx,qy,qz")
        numbered = true;
      else if (line != "t,x,y,z,qw,qx,qy,qz")
        fail("the header is neither toss,t,x,y,z,qw,qx,qy,qz nor t,x,y,z,qw,qx,qy,qz");
      continue;
    }
    if (line.empty()) continue;
    const int count = numbered ? 9 : 8;
    double v[9];
    lines.numbers(
        count, [&](int i) { return std::string(kColumns[i + (numbered ? 0 : 1)]); }, v);
    // row[1] is t, with or without the toss column (row[0] unused without it).
    double row[9];
    std::copy(v, v + count, row + (numbered ? 0 : 1));
    // The toss number: an integer an int holds (a cast of another double is undefined).
    if (numbered && !(v[0] == std::floor(v[0]) && std::abs(v[0]) <= 1e9))
      fail("toss: not an integer of at most 9 digits");
    const int number = numbered ? static_cast<int>(v[0]) : fallback_number;
    if (out.size() == first_out || out.back().number != number) {
      for (size_t k = first_out; k < out.size(); ++k)
        if (out[k].number == number)
          fail("the rows of toss " + std::to_string(number) + " are not consecutive");
      out.emplace_back();
      out.back().number = number;
      out.back().track.source = numbered ? path + " toss " + std::to_string(number) : path;
    }
    PoseTrack& track = out.back().track;
    if (!track.time.empty() && row[1] <= track.time.back()) fail("time not increasing");
    const Eigen::Quaterniond q(row[5], row[6], row[7], row[8]);
    if (!(q.norm() > 1e-6)) fail("zero quaternion");
    track.time.push_back(row[1]);
    track.position.emplace_back(row[2], row[3], row[4]);
    track.orientation.push_back(q.normalized());
  }
}

bool isCsv(const std::string& name) {
  auto ends = [&](const char* suffix) {
    const std::string s(suffix);
    return name.size() > s.size() && name.compare(name.size() - s.size(), s.size(), s) == 0;
  };
  return ends(".csv") || ends(".csv.gz");
}

}  // namespace

std::vector<NumberedTrack> readCsvTracks(const std::string& path) {
  namespace fs = std::filesystem;
  std::vector<NumberedTrack> out;
  std::error_code error;
  if (fs::is_directory(path, error)) {
    std::vector<std::string> files;
    for (const auto& entry : fs::directory_iterator(path))
      if (entry.is_regular_file() && isCsv(entry.path().filename().string()))
        files.push_back(entry.path().string());
    std::sort(files.begin(), files.end());
    if (files.empty()) throw std::runtime_error(path + ": no *.csv or *.csv.gz file in the folder");
    for (size_t i = 0; i < files.size(); ++i) {
      const int named = numberInName(files[i]);
      readFile(files[i], named >= 0 ? named : static_cast<int>(i), out);
    }
  } else {
    const int named = numberInName(path);
    readFile(path, named >= 0 ? named : 0, out);
  }
  return out;
}

}  // namespace collision_response::calibration
