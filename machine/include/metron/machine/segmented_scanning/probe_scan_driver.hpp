// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstddef>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "metron/machine/active_scanning/scan_controller.hpp"
#include "metron/machine/command.hpp"
#include "metron/machine/fault.hpp"
#include "metron/machine/segmented_scanning/scan_recorder.hpp"

namespace metron::machine {
class AxisServo;
class PathCursor;
class ScanningProbe;
class Rng;
}  // namespace metron::machine

namespace metron::machine::segmented {

/// How the probe-driving recorder turns the segmented plan into motion (controller side).
struct ProbeDriveSpec {
  /// Vf = v_plan + this * (s_plan - s), at most the speed limit where the plan is: the probe's
  /// place along the path follows the plan's.
  double position_gain_1_s = 10;
  double positioning_speed_mm_s = 50;           ///< free moves off the surface (retract, return)
  double positioning_acceleration_mm_s2 = 500;  ///< and their acceleration
  double search_from_mm = 0.5;     ///< an approach searches at the approach feed from this far off the path
  double retract_mm = 2;           ///< distance off the surface after a stop
  double finish_creep_mm_s = 0.5;  ///< least speed while finishing the path up to a stop
};

/// One control cycle of the driven probe (for the junction figures).
struct DrivenCycle {
  double t_s = 0;                  ///< simulated time
  bool scanning = false;           ///< the scanning law ran (else: hold, retract, approach)
  bool contact = false;            ///< the stylus touched
  double s_mm = 0;                 ///< arc length at the foot of the probe (scanning cycles)
  double plan_s_mm = 0;            ///< arc length the plan asked for
  double deflection_error_mm = 0;  ///< |Ep| - E0 as read
};

/// The scanning probe on the simulated part, driven by the segmented controller (SEEDS.md 1 + 2):
/// every scanning cycle runs the scanning controller's law V = Gf*Vf + Ge*Ve + Gc*Vc with Vf's
/// magnitude from the segmented plan (speed plus a position term so the probe's foot keeps up
/// with the planned arc length) and its direction from the path at the foot; the deflection, the
/// samples and every stop, retract and approach come from the probe against the actual part.
class ProbeScanDriver final : public ScanRecorder {
 public:
  /// `scan` gives the law, feed, E0, sample spacing and approach normal (its path may be empty:
  /// segments come with extend()); the head rests at `start_mm` at `start_time_s`.
  ProbeScanDriver(const ScanPath& scan, const ScanSetup& setup, const Vec3& start_mm, double start_time_s,
                  ProbeDriveSpec drive = {});
  ~ProbeScanDriver() override;
  ProbeScanDriver(const ProbeScanDriver&) = delete;
  ProbeScanDriver& operator=(const ProbeScanDriver&) = delete;

  /// Appends segments (and their end normals: segments.size() + 1, or none) to the known path.
  void extend(std::span<const geometry::PccSegment> segments, std::span<const Vec3> normals);

  /// Learns the command's segments and normals (extend()).
  void command_loaded(const MeasurementCommand& command) override { extend(command.segments, command.normals); }
  [[nodiscard]] bool drives_probe() const override { return true; }
  void record(const ScanCycle& cycle) override;
  bool off_path(OffPathMove move, double s_mm, double t_s) override;
  /// After the controller rests at the path end: scans up to `end_s_mm` and retracts.
  /// Returns false on a fault or when it takes longer than `max_time_s`.
  bool finish(double end_s_mm, double max_time_s = 60);

  /// Samples in path order (every sample spacing of the foot's arc length, in contact).
  [[nodiscard]] const std::vector<ScanSample>& samples() const { return m_samples; }
  /// The command each sample was taken in.
  [[nodiscard]] const std::vector<std::size_t>& sample_commands() const { return m_sample_commands; }
  /// Every cycle.
  [[nodiscard]] const std::vector<DrivenCycle>& cycles() const { return m_cycles; }
  /// The fault that stopped the probe (over-range, no contact on an approach, lost contact, or
  /// stalled: the foot trails the plan by more than the lost-contact distance).
  [[nodiscard]] const std::optional<Fault>& fault() const { return m_fault; }
  /// Retracts from and approaches to the surface (the first approach included).
  [[nodiscard]] std::size_t retracts() const { return m_retracts; }
  [[nodiscard]] std::size_t approaches() const { return m_approaches; }
  /// The head (encoder) position now and the simulated time now.
  [[nodiscard]] const Vec3& position_mm() const;
  [[nodiscard]] const Vec3& velocity_mm_s() const;
  [[nodiscard]] double time_s() const { return m_t_s; }
  /// Largest contact force seen, N.
  [[nodiscard]] double max_force_n() const { return m_max_force_n; }

 private:
  enum class Sub { Idle, Finish, Leave, Move, Search, Settle };
  void sense();
  Vec3 scan_law(double plan_s_mm, double plan_v_mm_s, std::size_t command, double min_vf_mm_s, double max_vf_mm_s);
  bool move_toward(const Vec3& target_mm, Vec3& v);
  void apply(Vec3 v, bool scanning, double plan_s_mm);
  [[nodiscard]] Vec3 point_at(double s_mm, Vec3* normal) const;

  ScanPath m_scan;  // settings; m_scan.path grows with extend()
  ScanSetup m_setup;
  ProbeDriveSpec m_drive;
  double m_e0_mm = 0.3;
  std::vector<double> m_cumulative{0.0};
  std::unique_ptr<Rng> m_rng;
  std::unique_ptr<ScanningProbe> m_probe;
  std::unique_ptr<AxisServo> m_servo;
  std::unique_ptr<PathCursor> m_cursor;
  double m_t_s = 0;
  Vec3 m_v_prev = Vec3::Zero();
  // This cycle's readings.
  Vec3 m_ep = Vec3::Zero();
  double m_e = 0;
  bool m_contact = false;
  Vec3 m_eu_last = Vec3::UnitZ();
  double m_s_mm = 0;
  // Off-path moves.
  Sub m_sub = Sub::Idle;
  Vec3 m_target = Vec3::Zero();
  Vec3 m_normal = Vec3::UnitZ();
  double m_sub_start_s = 0;
  int m_settled_cycles = 0;
  // Samples and faults.
  double m_next_sample_s = 0;
  double m_lost_at_s = -1, m_lost_at_t = 0;
  std::vector<ScanSample> m_samples;
  std::vector<std::size_t> m_sample_commands;
  std::vector<DrivenCycle> m_cycles;
  std::optional<Fault> m_fault;
  std::size_t m_retracts = 0, m_approaches = 0;
  std::size_t m_command = 0;
  double m_max_force_n = 0;
};

}  // namespace metron::machine::segmented
