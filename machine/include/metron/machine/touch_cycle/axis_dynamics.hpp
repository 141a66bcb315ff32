// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <optional>

#include "metron/machine/motion_profile.hpp"
#include "metron/machine/world.hpp"

namespace metron::machine {

/// Share of a constant-time ramp spent ramping the acceleration up (and down): the ramp is
/// jerk-limited but still reaches the feed in exactly the axis's time (SEEDS.md 3).
inline constexpr double constant_time_jerk_share = 0.1;

/// Time of a time-based law (constant time, or the table interpolated at `axis_feed_mm_s`: linear
/// between its points, the end values beyond them).
double law_time_s(const RampLaw& law, double axis_feed_mm_s);

/// Path limits for a straight move along unit `direction` at path feed `feed_mm_s` from the
/// axes' true acceleration behaviour `axes` (simulated truth; the most restrictive axis wins).
/// Without per-axis data: the path limits of `config` with `acceleration_mm_s2` (the
/// controller's current one). `acceleration_cap_mm_s2` (a programmed ACCEL) caps constant-rate axes.
MotionLimits path_limits(const MachineConfig& config, const AxesDynamics& axes, const Vec3& direction, double feed_mm_s,
                         double acceleration_mm_s2, std::optional<double> acceleration_cap_mm_s2 = std::nullopt);

/// The braking limits of the same move when an axis involved brakes by its own law (the others
/// by their acceleration's); none when every axis involved brakes as it accelerates.
std::optional<BrakingLimits> path_braking(const MachineConfig& config, const AxesDynamics& axes, const Vec3& direction,
                                          double feed_mm_s,
                                          std::optional<double> acceleration_cap_mm_s2 = std::nullopt);

/// True ramp time to `feed_mm_s` from rest along `direction` (hidden truth, for tests): the
/// acceleration distance is feed * Td / 2. With symmetric braking it is the time-difference Td
/// of a long timed move; with asymmetric braking that one is the mean of this and braking_time_s.
double ramp_time_s(const MachineConfig& config, const AxesDynamics& axes, const Vec3& direction, double feed_mm_s);

/// True time of a stop from `feed_mm_s` at constant speed along `direction` (hidden truth, for
/// tests); the braking distance is feed * time / 2.
double braking_time_s(const MachineConfig& config, const AxesDynamics& axes, const Vec3& direction, double feed_mm_s);

}  // namespace metron::machine
