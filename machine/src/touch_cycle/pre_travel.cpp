// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/touch_cycle/pre_travel.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace metron::machine {

double PreTravel::at(const Vec3& d) const {
  const Vec3 u = d.normalized();
  const double vertical_share = u.z() * u.z();
  const double theta = std::atan2(u.y(), u.x());
  const double phase = lobe_phase_deg * std::numbers::pi / 180.0;
  const double horizontal = horizontal_mm + lobe_amplitude_mm * std::cos(lobes * (theta - phase));
  return std::max(0.0, (1 - vertical_share) * horizontal + vertical_share * vertical_mm);
}

}  // namespace metron::machine
