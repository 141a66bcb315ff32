// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cmath>

namespace metron {

/// Duration of a jerk-limited speed change by `dv_mm_s` (>= 0) with zero acceleration at both
/// ends, under acceleration limit `a` and jerk limit `j` (SEEDS.md 3, "constant rate" mode): jerk
/// phases up to the acceleration limit and a constant-acceleration phase between them
/// (T = dv/a + a/j), or, when the limit is not reached (dv*j < a^2), a triangular acceleration
/// (T = 2*sqrt(dv/j)). The one formula the motion profile, the segmented speed plan, the axis
/// dynamics and the runtime's characterisation model share.
inline double jerk_limited_ramp_time_s(double dv_mm_s, double a_mm_s2, double j_mm_s3) {
  if (dv_mm_s <= 0) return 0;
  if (dv_mm_s * j_mm_s3 >= a_mm_s2 * a_mm_s2) return dv_mm_s / a_mm_s2 + a_mm_s2 / j_mm_s3;
  return 2 * std::sqrt(dv_mm_s / j_mm_s3);
}

}  // namespace metron
