#include "collision_response/core/halton_sequence.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <stdexcept>

namespace collision_response::core {

namespace {
std::vector<unsigned> firstPrimes(std::size_t count) {
  std::vector<unsigned> primes;
  for (unsigned n = 2; primes.size() < count; ++n) {
    bool prime = true;
    for (const unsigned p : primes) {
      if (p * p > n) break;
      if (n % p == 0) {
        prime = false;
        break;
      }
    }
    if (prime) primes.push_back(n);
  }
  return primes;
}
}  // namespace

HaltonSequence::HaltonSequence(std::size_t dimensions, std::uint64_t seed) {
  if (dimensions > kMaxDimensions)
    throw std::invalid_argument("HaltonSequence: at most 100 dimensions");
  bases_ = firstPrimes(dimensions);
  std::mt19937_64 random(seed);
  permutations_.resize(dimensions);
  for (std::size_t j = 0; j < dimensions; ++j) {
    const unsigned base = bases_[j];
    // Digits down to 2^-53: ceil(53 / log2(base)).
    const int digits = static_cast<int>(std::ceil(53.0 / std::log2(static_cast<double>(base))));
    permutations_[j].resize(static_cast<std::size_t>(digits));
    for (std::vector<unsigned>& permutation : permutations_[j]) {
      permutation.resize(base);
      std::iota(permutation.begin(), permutation.end(), 0U);
      // Fisher-Yates with the engine's raw output (std::shuffle's use of it is unspecified).
      for (unsigned k = base - 1; k > 0; --k) {
        const auto pick = static_cast<unsigned>(random() % (static_cast<std::uint64_t>(k) + 1));
        std::swap(permutation[k], permutation[pick]);
      }
    }
  }
}

double HaltonSequence::coordinate(std::uint64_t index, std::size_t dimension) const {
  const unsigned base = bases_.at(dimension);
  const std::vector<std::vector<unsigned>>& permutations = permutations_[dimension];
  const double inverse_base = 1.0 / static_cast<double>(base);
  double scale = inverse_base;
  double value = 0.0;
  for (const std::vector<unsigned>& permutation : permutations) {
    const auto digit = static_cast<unsigned>(index % base);
    index /= base;
    value += static_cast<double>(permutation[digit]) * scale;
    scale *= inverse_base;
  }
  // Strictly inside (0, 1): the quantile functions of unbounded distributions stay finite.
  return std::clamp(value, 0x1p-54, std::nextafter(1.0, 0.0));
}

}  // namespace collision_response::core
