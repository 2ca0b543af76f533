// Line-by-line reading of a plain or gzip-compressed CSV file, with errors that name the file and
// line: the part the recordings' readers (csv_tracks.h, joint_csv.h) share.
#pragma once

#include <functional>
#include <memory>
#include <string>

namespace collision_response::calibration {

class CsvLines {
 public:
  /// Opens `path` (plain or gzip). Throws std::runtime_error "path: cannot open".
  explicit CsvLines(const std::string& path);
  ~CsvLines();
  CsvLines(const CsvLines&) = delete;
  CsvLines& operator=(const CsvLines&) = delete;

  /// Reads the next line, of any length, into line() without its line end (LF or CRLF) and
  /// trailing spaces. False at the end of the file. Throws "path:line: read error (corrupt gzip?)"
  /// for a line cut by the end of a gzip stream cut short (or "path: read error ..." when the cut
  /// falls after a line end), "path: empty file" when the file held no line at all.
  bool next();
  const std::string& line() const { return line_; }
  /// 1 for the first line.
  int number() const { return number_; }

  /// Throws std::runtime_error "path:line: what".
  [[noreturn]] void fail(const std::string& what) const;

  /// Parses line() as exactly `count` comma-separated finite numbers into out[0 .. count-1];
  /// fails naming the column `column(i)` of a non-finite value, otherwise "not <count>
  /// comma-separated numbers".
  void numbers(int count, const std::function<std::string(int)>& column, double* out) const;

 private:
  struct File;
  std::unique_ptr<File> file_;
  std::string path_;
  std::string line_;
  int number_ = 0;
};

}  // namespace collision_response::calibration
