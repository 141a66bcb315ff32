// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/error_space/merge.hpp"

#include <stdexcept>

namespace metron::error_space {

Series merge_redundant(const Series& s1, const Series& s2, ZeroCorrection zero) {
  if (s1.size() != s2.size()) throw std::invalid_argument("merging data sets of different lengths");
  // SEEDS.md 4: offset set 2 by the difference of the means over the overlap ...
  double sum1 = 0, sum2 = 0;
  std::size_t overlap = 0;
  for (std::size_t i = 0; i < s1.size(); ++i)
    if (s1[i] && s2[i]) sum1 += *s1[i], sum2 += *s2[i], ++overlap;
  const double offset = overlap ? (sum1 - sum2) / static_cast<double>(overlap) : 0.0;
  // ... average the overlap point by point ...
  Series out(s1.size());
  for (std::size_t i = 0; i < s1.size(); ++i) {
    if (s1[i] && s2[i])
      out[i] = 0.5 * (*s1[i] + *s2[i] + offset);
    else if (s1[i])
      out[i] = *s1[i];
    else if (s2[i])
      out[i] = *s2[i] + offset;
  }
  // ... then the zero correction.
  std::size_t first = out.size(), last = 0;
  for (std::size_t i = 0; i < out.size(); ++i)
    if (out[i]) first = std::min(first, i), last = i;
  if (first == out.size() || zero == ZeroCorrection::None) return out;
  const double v0 = *out[first], v1 = *out[last];
  for (std::size_t i = first; i <= last; ++i) {
    if (!out[i]) continue;
    if (zero == ZeroCorrection::First || last == first)
      *out[i] -= v0;
    else
      *out[i] -= v0 + (v1 - v0) * static_cast<double>(i - first) / static_cast<double>(last - first);
  }
  return out;
}

}  // namespace metron::error_space
