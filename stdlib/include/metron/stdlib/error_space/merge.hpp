// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <optional>
#include <vector>

namespace metron::error_space {

/// A data set on a common index axis (e.g. the grid points of one line); nullopt where not measured.
using Series = std::vector<std::optional<double>>;

/// The zero correction applied after merging.
enum class ZeroCorrection {
  None,   ///< keep the merged values
  First,  ///< subtract the first merged value
  Ends,   ///< subtract the line through the first and last merged values (ends forced to zero)
};

/// SEEDS.md 4, merging redundant data (X- and Y-direction curves, forward and backward runs):
/// offset data set 2 by the difference of the means over the overlap, average the overlap point by
/// point, then apply the zero correction. Only relative values carry meaning and the noise is white
/// once the offset is removed (the seed's premise). Without overlap, s2 is taken as it is.
/// Throws std::invalid_argument when the sizes differ.
Series merge_redundant(const Series& s1, const Series& s2, ZeroCorrection zero = ZeroCorrection::None);

}  // namespace metron::error_space
