// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <limits>
#include <string>

#include "metron/stdlib/geometry/vec.hpp"

namespace metron::runtime {

/// A part coordinate system: `part_to_machine` maps its coordinates to machine coordinates.
struct Alignment {
  std::string label = "MCS";  ///< the D()/DA() label, "MCS" for the machine system
  Frame part_to_machine = Frame::Identity();
  /// When the earliest probed point the frame rests on was taken (simulated s; infinity: none, as
  /// MCS or a frame of numbers only): EQUATE tells a part's set-ups apart by it (docs/alignments.md).
  double rests_on_s = std::numeric_limits<double>::infinity();
  /// Where the program's nominals lie on the machine in this system: the motion that takes them
  /// from where they were written (the nominal frames of DATSET, TRANS and ROTATE, built from the
  /// features' nominals) onto the part (the same frames built from the actuals). Identity until a
  /// system rests on measured features (docs/alignments.md "Nominal and actual frames").
  Frame nominal_placement = Frame::Identity();

  [[nodiscard]] Vec3 to_machine_point(const Vec3& p) const { return part_to_machine * p; }
  [[nodiscard]] Vec3 to_machine_vector(const Vec3& v) const { return part_to_machine.linear() * v; }
  [[nodiscard]] Vec3 to_part_point(const Vec3& p) const { return part_to_machine.inverse() * p; }
  [[nodiscard]] Vec3 to_part_vector(const Vec3& v) const { return part_to_machine.linear().transpose() * v; }
};

}  // namespace metron::runtime
