// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>

namespace metron::machine {

/// The simulated world's only random source (ARCHITECTURE.md rule 3). std::mt19937_64 is
/// specified bit-exactly by the standard, but the std distributions are not, so the uniform and
/// normal variates are derived here: the same seed gives the same numbers with any library.
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : m_engine(seed) {}

  /// Uniform in [0, 1): the top 53 bits of one engine output.
  double uniform() { return static_cast<double>(m_engine() >> 11) * 0x1.0p-53; }

  /// Standard normal variate by the Box-Muller transform (G. E. P. Box, M. E. Muller, Ann. Math.
  /// Statist. 29(2), 1958); uses exactly two engine outputs, the sine branch is discarded so
  /// the draw order never depends on earlier calls.
  double normal() {
    const double u1 = 1.0 - uniform();  // (0, 1]: log stays finite
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
  }

 private:
  std::mt19937_64 m_engine;
};

}  // namespace metron::machine
