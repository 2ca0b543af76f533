#pragma once

#include <cstddef>

namespace collision_response::core {

/// Room writePercent() needs.
constexpr std::size_t kPercentTextSize = 40;

/// Writes 100 * `fraction` with three significant digits, as printf's "%.3g" writes it (no
/// locale; trailing zeros dropped), followed by " %", e.g. "12.3 %", "0.05 %", "100 %", into `out`
/// (kPercentTextSize chars; not terminated); returns the number of chars written. The warnings of
/// the uncertainty methods state their probabilities so. Digits for 100 * fraction in [0.001,
/// 999) not within 1e-9 of a rounding tie are formed from one exact scaling (a few dozen
/// instructions, where std::to_chars takes several hundred); any other value goes through
/// std::to_chars. Both give the same text.
std::size_t writePercent(double fraction, char* out);

}  // namespace collision_response::core
