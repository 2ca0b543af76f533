#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace collision_response::core {

/// A scrambled Halton sequence: quasi-random points in [0, 1)^d that fill the cube more evenly
/// than pseudo-random ones (the error of a sample mean falls nearly as 1/N instead of 1/sqrt(N)
/// for smooth integrands), for the sampled uncertainty propagation (uncertainty.h).
///
/// Coordinate j of point i is the radical inverse of i in the j-th prime base b_j, each digit k
/// passed through a permutation pi_jk of {0 .. b_j - 1} (random-digit scrambling, Matousek 1998),
/// drawn once from `seed` (std::mt19937_64): the same seed gives the same points, on every
/// platform. Scrambling breaks the correlation of the plain sequence between coordinates of large
/// bases. Digits are taken to 2^-53 resolution; coordinates lie strictly inside (0, 1).
class HaltonSequence {
 public:
  /// `dimensions` in [0, kMaxDimensions]; throws std::invalid_argument beyond.
  HaltonSequence(std::size_t dimensions, std::uint64_t seed);

  std::size_t dimensions() const { return bases_.size(); }
  /// Coordinate `dimension` of point `index` (any index; points are independent of each other).
  double coordinate(std::uint64_t index, std::size_t dimension) const;

  /// Dimensions available: the first 100 primes.
  static constexpr std::size_t kMaxDimensions = 100;

 private:
  std::vector<unsigned> bases_;
  // Per dimension, its digits' permutations, digit after digit (base entries each).
  std::vector<std::vector<std::vector<unsigned>>> permutations_;
};

}  // namespace collision_response::core
