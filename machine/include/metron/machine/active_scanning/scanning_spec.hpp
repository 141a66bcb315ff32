// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstddef>
#include <string>

#include <nlohmann/json_fwd.hpp>
#include <tl/expected.hpp>

#include "metron/stdlib/json_reader.hpp"

#include "metron/machine/segmented_scanning/segmented_controller.hpp"

/// The scanning side of a world (docs/scanning.md): the scan controller's configuration (gains,
/// limits, the probe's settings, command buffers) and the truth (the analogue probe as it truly
/// is, the axis servo dynamics).
namespace metron::machine {

/// The scanning (analogue) probe as the controller is configured for it.
struct ScanningProbeConfig {
  double reference_deflection_mm = 0.3;  ///< E0, the deflection held while scanning (SEEDS.md 1)
  double measuring_range_mm = 1.0;       ///< |Ep| above this is an over-range fault
};

/// The scanning probe as it truly is (hidden; the controller knows stiffness and mass from the
/// data sheet, DataSheet in world.hpp).
struct ScanningProbeTruth {
  double stiffness_n_mm = 0.6;  ///< contact force per mm of deflection
  double stylus_mass_g = 5.0;   ///< effective moving mass of the stylus
  double noise_mm = 0.0001;     ///< 1-sigma noise of each deflection reading
};

/// Axis servo dynamics (hidden): every axis's velocity follows the commanded velocity as a
/// second-order system, with a command latency and an acceleration (force) limit.
struct ServoSpec {
  double natural_frequency_hz = 20;      ///< velocity-loop natural frequency
  double damping = 0.4;                  ///< velocity-loop damping ratio
  int command_delay_cycles = 1;          ///< controller cycles from a command to the drives
  double max_acceleration_mm_s2 = 3000;  ///< per-axis acceleration the drives can give
};

/// The scan controller's configuration (known to the controller): the law's gain constants, the
/// gain functions' tolerances and the speed limits (docs/scanning.md).
struct ScanControlSpec {
  double feed_mm_s = 10;                 ///< default scan speed
  double deflection_gain_1_s = 40;       ///< K in Ve = K*(|Ep| - E0)*eu
  double trajectory_gain_1_s = 40;       ///< Kc in Vc1 = Kc*(P - Pp)
  double deflection_tolerance_mm = 0.1;  ///< Gf halves when | |Ep| - E0 | reaches this
  double trajectory_tolerance_mm = 0.5;  ///< Gf halves when |P - Pp| reaches this
  double max_centripetal_mm_s2 = 500;    ///< curvature limit: v^2 * kappa <= this
  double approach_feed_mm_s = 2;         ///< approach and retract speed
  double stall_time_s = 1.0;             ///< no progress along the path for this long: stalled
  double lost_contact_mm = 2.0;          ///< path length without contact before a fault
};

/// The controller's command buffers for segmented scanning (SEEDS.md 2,
/// docs/segmented-scanning.md): a ScanPath longer than one buffer must come from the host as
/// measurement commands (ScanBufferWrite), run by the segmented controller in `mode`.
struct SegmentedScanSpec {
  std::size_t buffer_segments = 1'000'000;  ///< P: one buffer's capacity (large: every usual scan fits)
  segmented::SegmentedMode mode = segmented::SegmentedMode::Seed;  ///< boundary behaviour
  /// Net simulated planning time per segment. Default: the planner's measured cost on the build
  /// host (bench_segmented, P = 1000, with a piece per quarter segment since issue 11: min 1.44,
  /// median 1.47, p99 1.51 us per segment), rounded up to 2 us; a constant, so simulated results
  /// never depend on the wall clock.
  double planning_s_per_segment = 2e-6;
  double planning_fixed_s = 0;           ///< plus this per command
  double planning_margin = 1.3;          ///< Tp = margin * net planning time
  double low_speed_mm_s = 3;             ///< the seed's low speed (1-5 mm/s)
  double low_length_mm = 3;              ///< L, the low-speed region
  double path_acceleration_mm_s2 = 500;  ///< tangential acceleration of the plans
  double path_jerk_mm_s3 = 5000;         ///< and jerk
};

/// The scanning configuration the controller knows.
struct ScanningSpec {
  ScanningProbeConfig probe;    ///< the analogue probe's settings
  ScanControlSpec control;      ///< the scan controller
  SegmentedScanSpec segmented;  ///< command buffers and segmented-scanning controller
};

/// The scanning side of the truth (hidden).
struct ScanningTruth {
  ScanningProbeTruth probe;  ///< the analogue probe's dynamics and noise
  ServoSpec servo;           ///< axis dynamics
};

/// Reads the world's "scanning" object at JSON pointer `pointer` into the controller's
/// configuration and the truth (missing keys keep the values they have; unknown keys are errors).
tl::expected<void, strict_json::ReadError> parse_scanning_spec(const nlohmann::json& json, const std::string& pointer,
                                                               ScanningSpec& config, ScanningTruth& truth);

}  // namespace metron::machine
