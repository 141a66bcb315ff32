// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "metron/machine/error_space/laser_interferometer.hpp"
#include "metron/machine/error_space/two_point_rig.hpp"
#include "metron/stdlib/error_space/error_space.hpp"
#include "metron/stdlib/error_space/positioning.hpp"
#include "metron/stdlib/error_space/two_point.hpp"

namespace metron::machine {

/// What to calibrate and with which instruments (what a user sets up; no hidden truth here
/// except inside `head` and the plate's form, which only the simulation reads).
struct SpaceCalibrationPlan {
  /// Ram positions of the grid points; on every axis with more than one point the step must be
  /// the head spacing d (the two-point method steps by d).
  error_space::Grid grid;
  std::array<bool, 3> components{false, false, true};  ///< the normal components to measure (plates facing x, y, z)
  TwoPointHead head;                                   ///< the two-sensor head
  double plate_form_mm = 0.005;                        ///< the plate's peak-to-valley form (hidden profile)
  std::uint64_t plate_seed = 17;                       ///< the plate's profile
  bool laser_offsets = true;             ///< tie the planes together with an ISO 230-2 run along the normal axis
  int laser_cycles = 2;                  ///< bidirectional runs for the offsets
  double laser_noise_sd_mm = 0.0002;     ///< the interferometer's noise
  double s7_factor = 4;                  ///< S7 threshold in standard deviations
  std::optional<double> known_delta_mm;  ///< tell the method Delta; default: S2 estimates it
  /// Measure Delta by a reversal (the first line again with the head turned 180 degrees) on every
  /// plane, so the planes keep their slope (beyond the seed; see error_space::delta_by_reversal).
  bool delta_by_reversal = false;
  /// Every plane measured this many times (fresh sensor noise, and a fresh reversal when asked) and
  /// the recovered planes averaged (SEEDS.md 4, merging redundant data: same grid, same reference,
  /// so the offsets agree and the mean is the merge); the floor falls by sqrt(runs).
  int runs = 1;
  std::uint64_t seed = 1;   ///< noise
  double start_time_s = 0;  ///< simulated time at the start
};

/// One plane of one component.
struct PlaneCalibration {
  int component = 2;                   ///< normal axis
  int index = 0;                       ///< plane index along the normal axis
  error_space::SurfaceResult surface;  ///< S1-S7 result (u = lower, v = higher in-plane axis)
  double offset_mm = 0;                ///< from the laser: e_c at the plane's (u_0, v_0) minus at the first plane's
};

/// The result of a calibration run: only what the method computed from readings.
struct SpaceCalibration {
  error_space::ErrorSpace space;                      ///< recovered components; sd_mm = the noise floor
  std::vector<PlaneCalibration> planes;               ///< every plane's surface result (S7 verdicts)
  std::vector<error_space::PositioningRecord> laser;  ///< the interferometer records
  int planes_to_remeasure = 0;                        ///< S7: planes with a line to re-measure
  double end_time_s = 0;                              ///< simulated time at the end
};

/// Runs the rig over the grid and feeds the method (SEEDS.md 4: plane by plane, S1-S7, then the
/// planes stacked with the laser offsets). The method never reads `hidden`; only the simulated
/// sensors do. Throws std::invalid_argument when the grid does not step by d.
SpaceCalibration calibrate_space(const MachineErrorModel& hidden, const SpaceCalibrationPlan& plan);

/// For checking only (tests, `--truth`): the hidden error at the grid points, taken into the
/// method's reference (each plane minus its common slope per step s_k (i + j), unless the plan gives
/// Delta or measures it by a reversal, when the method keeps that slope; with the laser, the
/// planes keep their offsets relative to the first grid point, else each plane is zeroed at its
/// (u_0, v_0)).
error_space::ErrorSpace truth_in_reference(const MachineErrorModel& hidden, const SpaceCalibrationPlan& plan,
                                           double time_s = 0);

/// The plate profile under sensor A at the grid of one plane, in the method's reference
/// (f - f(0,0) - s (i + j), s from the machine's truth): for checking the recovered profile.
Eigen::MatrixXd plate_truth_in_reference(const MachineErrorModel& hidden, const SpaceCalibrationPlan& plan,
                                         int component, int plane_index);

/// The plate a plan uses (hidden profile), placed for a plane; exposed for reports and checks.
FlatPlate plan_plate(const SpaceCalibrationPlan& plan, int component, int plane_index);

}  // namespace metron::machine
