// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "metron/machine/active_scanning/scanning_spec.hpp"
#include "metron/machine/active_scanning/speed_plan.hpp"
#include "metron/machine/command.hpp"
#include "metron/machine/fault.hpp"
#include "metron/machine/solid.hpp"
#include "metron/machine/world.hpp"

namespace metron::machine {

/// The three velocity terms and gains of one control cycle (SEEDS.md 1).
struct ScanTerms {
  Vec3 vf = Vec3::Zero();         ///< path velocity Vf
  Vec3 ve = Vec3::Zero();         ///< deflection correction Ve
  Vec3 vc = Vec3::Zero();         ///< the selected trajectory correction (Vc1, Vc1' or Vc2)
  Vec3 vc1 = Vec3::Zero();        ///< Vc1, for comparison
  double gf = 1, ge = 1, gc = 1;  ///< the gains after their deviation functions
};

/// One control cycle as seen by the controller, for plots, tests and the benchmark.
struct ScanCycle {
  double time_s = 0;                  ///< simulated time at the start of the cycle
  bool scanning = false;              ///< false while approaching, settling or retracting
  Vec3 head_mm = Vec3::Zero();        ///< encoder position Pp (the undeflected ball centre)
  Vec3 velocity_mm_s = Vec3::Zero();  ///< encoder velocity
  Vec3 deflection_mm = Vec3::Zero();  ///< Ep as read
  double path_s_mm = 0;               ///< arc length at the foot P
  double path_distance_mm = 0;        ///< |P - Pp|
  Vec3 foot_mm = Vec3::Zero();        ///< the foot P of the perpendicular from Pp onto the path
  Vec3 tangent = Vec3::Zero();        ///< the path's unit tangent at P
  double lateral_error_mm = 0;        ///< (P - Pp) . q, q = (eu x t)/|eu x t|: the deviation across the scan
  double speed_limit_mm_s = 0;        ///< lowest speed limit at the foot
  double tangential_speed_mm_s = 0;   ///< encoder velocity along the path tangent
  ScanTerms terms;                    ///< what was commanded
};

/// Summary figures of a scan (over the scanning phase).
struct ScanStats {
  std::int64_t cycles = 0;              ///< controller cycles, all phases
  std::int64_t scan_cycles = 0;         ///< cycles of the scanning phase
  double rms_deflection_error_mm = 0;   ///< RMS of |Ep| - E0 while scanning
  double peak_deflection_error_mm = 0;  ///< max of | |Ep| - E0 | while scanning
  double max_path_distance_mm = 0;      ///< max |P - Pp| while scanning
  double rms_lateral_error_mm = 0;      ///< RMS of (P - Pp) . q while scanning (the part Vc2 corrects)
  double max_lateral_error_mm = 0;      ///< max |(P - Pp) . q| while scanning
  double max_speed_ratio = 0;           ///< max tangential speed / speed limit at the foot
  double max_force_n = 0;               ///< largest contact force
  std::int64_t free_cycles = 0;         ///< scanning cycles without contact
  double path_length_mm = 0;            ///< length of the commanded path
  double reached_mm = 0;                ///< arc length reached
};

/// The result of one scan.
struct ScanOutcome {
  std::vector<ScanSample> samples;      ///< recorded samples (every sample_spacing_mm of path)
  std::optional<Fault> fault;           ///< why the scan stopped early
  bool completed = false;               ///< the whole path was scanned
  Vec3 end_position_mm = Vec3::Zero();  ///< head position at the end (after the retract)
  double end_time_s = 0;                ///< simulated time at the end
  std::vector<std::string> log;         ///< speed limits by stretch of path, and the stats
  ScanStats stats;                      ///< summary figures
};

/// Where the scanning controller runs: the simulated world's parts it touches and its truth
/// (simulation side), and the controller's own configuration.
struct ScanSetup {
  const Solid* solid = nullptr;    ///< everything the ball can touch (simulation side)
  double true_ball_radius_mm = 2;  ///< the stylus ball as it truly is (simulation side)
  MachineConfig machine;           ///< the controller: limits, cycle dt, scanning configuration, data sheet
  ScanningTruth truth;             ///< the probe's dynamics and noise, the axis servos (simulation side)
  std::uint64_t seed = 1;          ///< of the probe noise
};

/// The trajectory-correction direction q = (eu x t)/|eu x t| (SEEDS.md 1; t stands in for Vf's
/// direction), or zero when eu is parallel to t.
Vec3 scan_correction_direction(const Vec3& eu, const Vec3& tangent);

/// "" when the command can be scanned, else what is wrong with it.
std::string validate_scan(const ScanPath& command);

/// The approach point: the path start plus approach_mm along the approach normal.
Vec3 scan_approach_point(const ScanPath& command);

/// The law's terms for one scanning cycle (SEEDS.md 1): Vf = vf_mm_s along `tangent`,
/// Ve = K*(|Ep| - E0)*eu, the selected Vc from Vc1 = Kc*(P - Pp), and the gains Gf, Ge, Gc; the
/// command is Gf*Vf + Ge*Ve + Gc*Vc, each gain a function of the deviations (docs/scanning.md,
/// "The control law"). `e_mm` is |Ep| as read, `eu` the deflection's direction (or
/// the nominal normal without contact), `foot_mm` the foot P, `head_mm` the encoder position Pp.
ScanTerms scan_law_terms(ScanLaw law, const ScanControlSpec& ctl, double e0_mm, double e_mm, const Vec3& eu,
                         const Vec3& foot_mm, const Vec3& head_mm, const Vec3& tangent, double vf_mm_s);

/// Active nominal scanning (SEEDS.md 1). From rest at `start_mm` (normally the approach point),
/// the head moves along -approach_normal until the deflection reaches E0, then every control
/// cycle commands V = Gf*Vf + Ge*Ve + Gc*Vc with Vc the command's law, until the foot of the
/// perpendicular reaches the path end; then it retracts along the deflection. Faults: probe
/// over-range (OverTravel), no contact, lost contact (NoContact), no progress (Stalled).
/// `cycle` is called every control cycle when set.
ScanOutcome run_scan(const ScanPath& command, const ScanSetup& setup, const Vec3& start_mm, double start_time_s,
                     const std::function<void(const ScanCycle&)>& cycle = {});

}  // namespace metron::machine
