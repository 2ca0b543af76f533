#include "collision_response/calibration/joint_csv.h"

#include "collision_response/calibration/csv_lines.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

namespace collision_response::calibration {

JointTrack readJointCsv(const std::string& path) {
  CsvLines lines(path);
  JointTrack track;
  track.source = path;
  auto fail = [&](const std::string& what) { lines.fail(what); };
  while (lines.next()) {
    const std::string& line = lines.line();
    if (lines.number() == 1) {
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
    Eigen::VectorXd row(count);
    lines.numbers(
        count, [&](int i) { return i == 0 ? std::string("t") : track.names[i - 1]; }, row.data());
    const double t = row[0];
    const Eigen::VectorXd q = row.tail(count - 1);
    if (!track.time.empty() && !(t > track.time.back())) fail("time not increasing");
    track.time.push_back(t);
    track.position.push_back(q);
  }
  if (track.size() < 2) throw std::runtime_error(path + ": fewer than 2 samples");
  return track;
}

}  // namespace collision_response::calibration
