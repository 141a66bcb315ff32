// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <array>
#include <optional>
#include <string_view>

#include "metron/stdlib/geometry/vec.hpp"

namespace metron::machine {

/// Where the machine is, as its own sensors say: the scale readings and the probe tip's nominal
/// offset from the ram's reference point (the point the axis positions refer to).
struct MachinePose {
  Vec3 axes_mm = Vec3::Zero();          ///< scale readings x, y, z
  Vec3 probe_offset_mm = Vec3::Zero();  ///< tip (or sensor) offset from the ram reference point, machine axes
  /// Per axis, the direction of the last motion (+1, -1; 0 unknown): direction-dependent terms.
  std::array<int, 3> approach{0, 0, 0};

  /// Nominal tip position: axes + offset.
  [[nodiscard]] Vec3 nominal_tip_mm() const { return axes_mm + probe_offset_mm; }
};

/// One effect of the hidden machine error model (ARCHITECTURE.md rule 1: simulated truth). A
/// model is a list of terms; a new effect is a new term, without touching the others.
class ErrorTerm {
 public:
  /// What the displacement moves.
  enum class Acts {
    Tool,  ///< the probe tip relative to the machine table (geometry, scales)
    Part,  ///< the part relative to the table, expressed as the tip's displacement in the part's frame
  };
  virtual ~ErrorTerm() = default;
  /// The term's displacement of the actual tip from the nominal one, mm, at simulated time t.
  [[nodiscard]] virtual Vec3 displacement(const MachinePose& pose, double time_s) const = 0;
  /// A short name for reports ("rigid-body", "grid-field z(x,y)", ...).
  [[nodiscard]] virtual std::string_view name() const = 0;
  /// What it moves (default: the tool).
  [[nodiscard]] virtual Acts acts() const { return Acts::Tool; }
  /// For a term that models the machine's own temperature (its scales): what a thermometer on the
  /// machine reads at `time_s`, C. Others: none.
  [[nodiscard]] virtual std::optional<double> machine_temperature_c(double /*time_s*/) const { return std::nullopt; }
};

}  // namespace metron::machine
