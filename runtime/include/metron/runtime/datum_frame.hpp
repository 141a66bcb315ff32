// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <string>
#include <tl/expected.hpp>
#include <vector>

#include "metron/runtime/tolerance.hpp"

namespace metron::runtime {

/// A datum reference frame fitted for one toleranced feature: the rigid motion that brings the
/// actual datum features onto their nominals in datum precedence (ASME Y14.5-2018 ch. 4, ISO 5459:
/// the primary datum takes the degrees of freedom it can, the secondary some of those left, the
/// tertiary the rest). Degrees of freedom no datum constrains stay as they are (the motion is the
/// identity in them), so a single plane datum leaves the zone free to slide in that plane.
struct DatumFrame {
  Frame actual_to_nominal = Frame::Identity();  ///< applied to the toleranced feature's actual (MCS)
  int translations_fixed = 0;                   ///< 0..3
  int rotations_fixed = 0;                      ///< 0..3
  std::string description;                      ///< for the tolerance note
};

/// How a datum's nominal is placed on the machine for the fit.
enum class DatumNominals {
  AsDefined,        ///< where its FEAT put it (DMIS: nominals in the alignment active at the FEAT)
  InFeaturesFrame,  ///< its numbers re-read in the toleranced feature's alignment
};

/// Fits the frame of `datums` (precedence order) for a feature whose nominal was written in
/// `feature_frame` (the alignment in force at its FEAT). With `InFeaturesFrame` each datum's
/// nominal numbers are re-read in that frame: a program that writes all nominals in one part
/// coordinate system defines its datum features under a rough alignment and the toleranced
/// features under the fine one, and the two must meet in the part frame. An error names a datum
/// that cannot take part.
tl::expected<DatumFrame, std::string> fit_datum_frame(const std::vector<const Datum*>& datums,
                                                      const Frame& feature_frame, DatumNominals nominals);

}  // namespace metron::runtime
