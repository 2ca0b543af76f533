#include "collision_response/core/percent_text.h"

#include <charconv>
#include <cmath>
#include <initializer_list>

namespace collision_response::core {

namespace {

// The general path: std::to_chars of the exact binary value, as %.3g.
std::size_t viaToChars(double value, char* out) {
  return static_cast<std::size_t>(
      std::to_chars(out, out + kPercentTextSize - 2, value, std::chars_format::general, 3).ptr -
      out);
}

// %.3g of `value` in [0.001, 999) when it is clearly not at a rounding tie; 0 otherwise.
std::size_t threeDigits(double value, char* out) {
  if (!(value >= 0.001 && value < 999.0)) return 0;
  // Decimal exponent e (value in [10^e, 10^(e+1))) and the exact power scaling it to [100, 1000).
  int e = 2;
  double scale = 1.0;
  for (const double bound : {100.0, 10.0, 1.0, 0.1, 0.01}) {
    if (value >= bound) break;
    --e;
    scale *= 10.0;
  }
  // value * scale is rounded once (scale an exact integer <= 1e5): within 6e-14 of the exact
  // product, so a fractional part farther than 1e-9 from 1/2 rounds as the exact value does.
  const double scaled = value * scale;
  double digits = std::floor(scaled);
  const double fraction = scaled - digits;  // exact (scaled < 2^10)
  if (std::abs(fraction - 0.5) < 1e-9) return 0;
  if (fraction > 0.5) digits += 1.0;
  int n = static_cast<int>(digits);
  if (n == 1000) {  // rounded up to the next power of ten
    n = 100;
    ++e;
  }
  if (e > 2) return 0;
  // Fixed notation with 2 - e decimals (%g for exponents -4 <= e < 3), trailing zeros dropped.
  const char d[3] = {static_cast<char>('0' + n / 100), static_cast<char>('0' + n / 10 % 10),
                     static_cast<char>('0' + n % 10)};
  char* at = out;
  if (e >= 0) {
    for (int k = 0; k <= e; ++k) *at++ = d[k];
    int last = 2;
    while (last > e && d[last] == '0') --last;
    if (last > e) {
      *at++ = '.';
      for (int k = e + 1; k <= last; ++k) *at++ = d[k];
    }
  } else {
    *at++ = '0';
    *at++ = '.';
    for (int k = e; k < -1; ++k) *at++ = '0';
    int last = 2;
    while (d[last] == '0') --last;  // d[0] != '0'
    for (int k = 0; k <= last; ++k) *at++ = d[k];
  }
  return static_cast<std::size_t>(at - out);
}

}  // namespace

std::size_t writePercent(double fraction, char* out) {
  const double value = 100.0 * fraction;
  std::size_t size = threeDigits(value, out);
  if (size == 0) size = viaToChars(value, out);
  out[size++] = ' ';
  out[size++] = '%';
  return size;
}

}  // namespace collision_response::core
