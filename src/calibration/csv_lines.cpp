#include "collision_response/calibration/csv_lines.h"

#include <zlib.h>

#include <cmath>
#include <cstdlib>
#include <stdexcept>

namespace collision_response::calibration {

struct CsvLines::File {
  gzFile handle = nullptr;
  ~File() {
    if (handle != nullptr) gzclose(handle);
  }
};

CsvLines::CsvLines(const std::string& path) : file_(std::make_unique<File>()), path_(path) {
  file_->handle = gzopen(path.c_str(), "rb");  // reads plain files too
  if (file_->handle == nullptr) throw std::runtime_error(path + ": cannot open");
}

CsvLines::~CsvLines() = default;

bool CsvLines::next() {
  // A read that fails part-way (a gzip stream cut short, a corrupt block) ends in gzerror's code,
  // never in a shorter last line taken for data.
  auto readError = [&] {
    int code = Z_OK;
    gzerror(file_->handle, &code);
    return code != Z_OK && code != Z_STREAM_END;
  };
  char buffer[4096];
  if (gzgets(file_->handle, buffer, sizeof buffer) == nullptr) {
    if (readError() || gzeof(file_->handle) == 0)
      throw std::runtime_error(path_ + ": read error (corrupt gzip?)");
    if (number_ == 0) throw std::runtime_error(path_ + ": empty file");
    return false;
  }
  line_ = buffer;
  while (!line_.empty() && line_.back() != '\n' && !gzeof(file_->handle)) {
    if (gzgets(file_->handle, buffer, sizeof buffer) == nullptr) break;
    line_ += buffer;
  }
  ++number_;
  // zlib flags a stream cut short as soon as its last block is decompressed, lines before the
  // cut: only the line the cut falls in (no line end) is an error here; a cut just after a line
  // end is found at the next read.
  if (readError() && (line_.empty() || line_.back() != '\n'))
    throw std::runtime_error(path_ + ":" + std::to_string(number_) +
                             ": read error (corrupt gzip?)");
  while (!line_.empty() && (line_.back() == '\n' || line_.back() == '\r' || line_.back() == ' '))
    line_.pop_back();
  return true;
}

void CsvLines::fail(const std::string& what) const {
  throw std::runtime_error(path_ + ":" + std::to_string(number_) + ": " + what);
}

void CsvLines::numbers(int count, const std::function<std::string(int)>& column,
                       double* out) const {
  const std::string shape = "not " + std::to_string(count) + " comma-separated numbers";
  const char* p = line_.c_str();
  for (int i = 0; i < count; ++i) {
    char* end = nullptr;
    out[i] = std::strtod(p, &end);
    if (end == p) fail(shape);
    if (!std::isfinite(out[i])) fail("non-finite value in column " + column(i));
    p = end;
    if (i + 1 < count) {
      if (*p != ',') fail(shape);
      ++p;
    }
  }
  while (*p == ' ') ++p;
  if (*p != '\0') fail(shape);
}

}  // namespace collision_response::calibration
