// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <vector>

#include "metron/machine/machine_errors/error_model.hpp"
#include "metron/machine/rng.hpp"
#include "metron/stdlib/error_space/positioning.hpp"

namespace metron::machine {

/// A laser-interferometer positioning measurement along one axis (ISO 230-2:2014: targets,
/// bidirectional runs, cycles): the component along the axis of motion, which the two-point
/// method cannot see.
struct LaserPlan {
  int axis = 0;                          ///< the axis of motion
  std::vector<double> targets_mm;        ///< P_i, increasing
  Vec3 line_axes_mm = Vec3::Zero();      ///< the other axes' positions (the `axis` entry is ignored)
  Vec3 reflector_offset_mm{0, 0, -120};  ///< reflector from the ram reference point (put it at the probe tip)
  int cycles = 5;                        ///< ISO 230-2 standard test: 5 bidirectional runs
  double noise_sd_mm = 0.0002;           ///< reading noise (air refraction, dead path), 0.2 um
  double dwell_s = 4;                    ///< simulated time per target
};

/// Runs the plan on the hidden machine: each run goes up through the targets then down (an
/// overshoot before the first target of each direction, so each reading knows its approach); the
/// laser is zeroed at the first target of the first up run. Advances `time_s`.
std::vector<error_space::PositioningRecord> measure_positioning(const MachineErrorModel& errors, const LaserPlan& plan,
                                                                Rng& rng, double& time_s);

}  // namespace metron::machine
