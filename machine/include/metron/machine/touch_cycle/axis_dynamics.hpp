// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <optional>

#include "metron/machine/motion_profile.hpp"
#include "metron/machine/world.hpp"

namespace metron::machine {

/// Share of a constant-time ramp spent ramping the acceleration up (and down): the ramp is
/// jerk-limited but still reaches the feed in exactly the axis's time (SEEDS.md 3).
inline constexpr double constant_time_jerk_share = 0.1;

/// Path limits for a straight move along unit `direction` at path feed `feed_mm_s` from the
/// axes' true acceleration behaviour `axes` (simulated truth; the most restrictive axis wins).
/// Without per-axis data: the path limits of `config` with `acceleration_mm_s2` (the
/// controller's current one). `acceleration_cap_mm_s2` (a programmed ACCEL) caps constant-rate axes.
MotionLimits path_limits(const MachineConfig& config, const AxesDynamics& axes, const Vec3& direction, double feed_mm_s,
                         double acceleration_mm_s2, std::optional<double> acceleration_cap_mm_s2 = std::nullopt);

/// True ramp time to `feed_mm_s` from rest along `direction` (hidden truth, for tests): the
/// time-difference Td of a long timed move; the acceleration distance is feed * Td / 2.
double ramp_time_s(const MachineConfig& config, const AxesDynamics& axes, const Vec3& direction, double feed_mm_s);

}  // namespace metron::machine
