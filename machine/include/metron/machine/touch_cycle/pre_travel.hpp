// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include "metron/stdlib/geometry/vec.hpp"

namespace metron::machine {

/// True (hidden) pre-travel of a touch-trigger probe: the distance the machine moves after the
/// first contact until the probe's sensing threshold is reached (SEEDS.md 3, A->B). Modelled as
/// a kinematic probe with a vertical stylus: a lobed horizontal part and a separate vertical one,
///
///   pt(d) = (1 - dz^2) * (horizontal + lobe_amplitude * cos(lobes * (theta - lobe_phase)))
///         + dz^2 * vertical,     theta = atan2(dy, dx),
///
/// for the unit direction d in which the surface pushes into the probe's travel (the negated
/// true surface normal at the contact), in machine coordinates. Isotropic when horizontal ==
/// vertical and lobe_amplitude == 0.
struct PreTravel {
  double horizontal_mm = 0.010;  ///< mean pre-travel for contacts in the XY plane
  double vertical_mm = 0.010;    ///< pre-travel for contacts along Z
  int lobes = 3;                 ///< lobes per turn (3 for a three-seat kinematic probe)
  double lobe_amplitude_mm = 0;  ///< half the peak-to-valley variation in the XY plane
  double lobe_phase_deg = 0;     ///< azimuth of a maximum, from +X toward +Y

  /// Pre-travel for the unit direction `d` (see above); never negative.
  [[nodiscard]] double at(const Vec3& d) const;
};

}  // namespace metron::machine
