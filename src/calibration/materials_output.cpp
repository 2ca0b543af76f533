#include "collision_response/calibration/materials_output.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace collision_response::calibration {
namespace {

std::string number(double x, int digits = 4) {
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", digits, x);
  return buffer;
}

std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

}  // namespace

std::string materialsYaml(const std::vector<MaterialsEntry>& entries) {
  std::ostringstream out;
  out << "# Identified by collision_response's identify (docs/calibration.md).\n"
      << "# Load as the node's ~materials parameter (rosparam load this file into its namespace).\n"
      << "materials:\n";
  for (const MaterialsEntry& e : entries) {
    const IdentificationResult& f = e.fit;
    out << "  # " << e.material_a << " on " << e.material_b << ": " << e.method << "\n";
    out << "  # data: " << e.recordings << " recordings, " << f.landings
        << (e.robot ? " impacts used" : " landings used");
    int skipped = 0;
    for (const auto& [reason, count] : e.skipped) skipped += count;
    out << ", " << skipped << " skipped";
    for (const auto& [reason, count] : e.skipped) out << "; " << count << " " << reason;
    out << "\n";
    for (const auto& s : e.sources) out << "  #   from " << s << "\n";
    if (f.loss_scale_shift.size() > 0)
      out << "  # 95% intervals (value +- 1.96 sd from the covariance at the optimum, plus the "
             "automatic loss scale's part: refits at "
          << number(f.loss_scale_low) << " and " << number(f.loss_scale_high) << "):\n";
    else
      out << "  # 95% intervals (value +- 1.96 sd from the covariance at the optimum):\n";
    for (const auto& est : f.estimates)
      out << "  #   " << est.name << " " << number(est.value) << " sd " << number(est.std_dev)
          << " [" << number(est.lower) << ", " << number(est.upper) << "]"
          << (est.at_bound ? " (on a bound of the search: the interval is not reliable)" : "")
          << "\n";
    if (e.robot) {
      out << "  # training RMS error of the joint velocities after the impacts (relative to the "
             "joints' speed before): "
          << number(f.rms_cases, 3) << "\n";
      if (e.held_out.folds > 0)
        out << "  # held-out RMS error, " << e.held_out.folds
            << "-fold cross-validation: " << number(e.held_out.rms_cases, 3) << "\n";
    } else {
      out << "  # training RMS error (relative to the pre-impact speed): v "
          << number(f.rms_linear, 3) << ", w " << number(f.rms_angular, 3) << "\n";
    }
    if (!e.robot && e.held_out.folds > 0)
      out << "  # held-out RMS error, " << e.held_out.folds << "-fold cross-validation: v "
          << number(e.held_out.rms_linear, 3) << ", w " << number(e.held_out.rms_angular, 3)
          << "\n";
    if (f.coefficients.inertia_scale != 1.0)
      out << "  # inertia scale " << number(f.coefficients.inertia_scale)
          << " (not a ~materials field: multiply the object's inertia by it)\n";
    out << "  - {a: " << quoted(e.material_a) << ", b: " << quoted(e.material_b)
        << ", restitution: " << number(f.coefficients.restitution)
        << ", static_friction: " << number(f.coefficients.static_friction)
        << ", dynamic_friction: " << number(f.coefficients.dynamic_friction) << "}\n";
  }
  return out.str();
}

void writeFileAtomically(const std::string& path, const std::string& text) {
  const std::string temporary = path + ".tmp";
  {
    std::ofstream out(temporary);
    if (!out) throw std::runtime_error(path + ": cannot write");
    out << text;
    out.close();
    if (!out) {
      std::remove(temporary.c_str());
      throw std::runtime_error(path + ": cannot write");
    }
  }
  if (std::rename(temporary.c_str(), path.c_str()) != 0) {
    std::remove(temporary.c_str());
    throw std::runtime_error(path + ": cannot write");
  }
}

}  // namespace collision_response::calibration
