#include "collision_response/calibration/joint_csv.h"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

namespace collision_response::calibration {

JointTrack readJointCsv(const std::string& path) {
  gzFile file = gzopen(path.c_str(), "rb");  // reads plain files too
  if (file == nullptr) throw std::runtime_error(path + ": cannot open");
  struct Closer {
    gzFile f;
    ~Closer() { gzclose(f); }
  } closer{file};
  JointTrack track;
  track.source = path;
  int line_number = 0;
  auto fail = [&](const std::string& what) {
    throw std::runtime_error(path + ":" + std::to_string(line_number) + ": " + what);
  };
  char buffer[4096];
  std::string line;
  while (gzgets(file, buffer, sizeof buffer) != nullptr) {
    line = buffer;
    while (!line.empty() && line.back() != '\n' && !gzeof(file)) {
      if (gzgets(file, buffer, sizeof buffer) == nullptr) break;
      line += buffer;
    }
    ++line_number;
    while (!line.empty() && (line.back() == '\n' || line.back() == '\r' || line.back() == ' '))
      line.pop_back();
    if (line_number == 1) {
      std::vector<std::string> columns;
      std::size_t begin = 0;
      for (;;) {
        const std::size_t comma = line.find(',', begin);
        columns.push_back(line.substr(begin, comma - begin));
        if (comma == std::string::npos) break;
        begin = comma + 1;
      }
      if (columns.size() < 2 || columns[0] != "t")
        fail("the header must be t,<joint>,<joint>,... (the URDF's joint names)");
      for (std::size_t i = 1; i < columns.size(); ++i) {
        if (columns[i].empty()) fail("column " + std::to_string(i + 1) + ": empty joint name");
        if (std::count(columns.begin() + 1, columns.end(), columns[i]) > 1)
          fail("joint '" + columns[i] + "' named twice in the header");
      }
      track.names.assign(columns.begin() + 1, columns.end());
      continue;
    }
    if (line.empty()) continue;
    const int count = 1 + static_cast<int>(track.names.size());
    Eigen::VectorXd q(count - 1);
    double t = 0.0;
    const char* p = line.c_str();
    for (int i = 0; i < count; ++i) {
      char* end = nullptr;
      const double v = std::strtod(p, &end);
      if (end == p) fail("not " + std::to_string(count) + " comma-separated numbers");
      if (!std::isfinite(v))
        fail("non-finite value in column " + (i == 0 ? std::string("t") : track.names[i - 1]));
      (i == 0 ? t : q[i - 1]) = v;
      p = end;
      if (i + 1 < count) {
        if (*p != ',') fail("not " + std::to_string(count) + " comma-separated numbers");
        ++p;
      }
    }
    while (*p == ' ') ++p;
    if (*p != '\0') fail("not " + std::to_string(count) + " comma-separated numbers");
    if (!track.time.empty() && !(t > track.time.back())) fail("time not increasing");
    track.time.push_back(t);
    track.position.push_back(q);
  }
  if (gzeof(file) == 0) throw std::runtime_error(path + ": read error (corrupt gzip?)");
  if (line_number == 0) throw std::runtime_error(path + ": empty file");
  if (track.size() < 2) throw std::runtime_error(path + ": fewer than 2 samples");
  return track;
}

}  // namespace collision_response::calibration
