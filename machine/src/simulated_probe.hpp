// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>

#include "metron/machine/active_scanning/scan_controller.hpp"
#include "metron/machine/motion_profile.hpp"
#include "metron/machine/rng.hpp"
#include "metron/machine/solid.hpp"
#include "metron/machine/world.hpp"

namespace metron::machine::detail {

/// The probe in the simulated world, and the only holder of the truth (ARCHITECTURE.md rule 1):
/// the controller asks it what a sensor would report (the trigger signal, the collision and
/// over-travel switches, the axes' motion) and never reads the truth itself.
class SimulatedProbe {
 public:
  SimulatedProbe(WorldTruth truth, std::uint64_t seed);

  /// A stylus is screwed on: its true radius differs from the nominal by the world's error; its
  /// ball centre sits `offset_mm` from the ram's reference point (the machine errors' Abbe lever).
  void mount_stylus(double nominal_radius_mm, const Vec3& offset_mm);

  /// The machine's thermometer at `time_s` (its scales' temperature to 0.01 K), if the world's
  /// machine errors model one.
  [[nodiscard]] std::optional<double> thermometer_c(double time_s) const {
    const auto t = m_truth.errors.machine_temperature_c(time_s);
    if (!t) return std::nullopt;
    return std::round(*t * 100) / 100;
  }
  /// The controller's clock reached `time_s`: the machine errors' time-dependent terms (thermal,
  /// drift) follow it, sampled every `kErrorTimeStep_s` of simulated time.
  void set_time(double time_s);
  /// How often the time-dependent machine errors are re-evaluated. Thermal lags and drifts of a
  /// CMM change its errors by well under 0.1 um in 0.1 s; the step keeps the free-space cache of
  /// `sweep` valid over many cycles.
  static constexpr double kErrorTimeStep_s = 0.1;

  /// The probe's trigger used as a collision switch on a move from a to b: the fraction of the
  /// move at which the ball first touches, if it does. The move's direction sets each moving
  /// axis' approach direction (the machine errors' reversal terms).
  [[nodiscard]] std::optional<double> sweep(const Vec3& a, const Vec3& b);
  /// The operator stops the program (DMIS PAUSE): the part goes to its next set-up, if the world
  /// gives one. Returns its number (2 for the first of part.setups: the part's pose is set-up 1).
  std::optional<std::size_t> operator_stop();

  /// The feature name at a contact point (for fault messages).
  [[nodiscard]] std::string feature_at(const Vec3& p) const;

  /// A probing move starts at controller time `t0_s`: the machine moves from `a` along unit `u`
  /// following `profile`.
  void begin_probe(const MotionProfile* profile, const Vec3& a, const Vec3& u, double t0_s);
  /// The machine moved over profile time [t0, t1]. Returns when the trigger signal reaches the
  /// controller's skip input, once that is no later than t1.
  std::optional<double> probe_step(double t0, double t1);
  /// The ball touched during the current probing move.
  [[nodiscard]] bool touched() const { return m_contact_s != inf; }
  /// The probe's over-travel switch: how far past the contact the machine stopped, when that
  /// exceeds the true limit.
  [[nodiscard]] std::optional<double> over_travel(double stop_s) const;

  /// Asynchrony of a scanned skip input relative to the motion: a fresh phase per trigger.
  double scan_phase() { return m_rng.uniform(); }

  /// How the axes move for a commanded straight move (their true acceleration behaviour).
  [[nodiscard]] MotionLimits motion_limits(const MachineConfig& config, const Vec3& u, double feed_mm_s,
                                           double acceleration_mm_s2, std::optional<double> cap_mm_s2) const;
  /// Braking limits of the same move when an axis involved brakes by its own law.
  [[nodiscard]] std::optional<BrakingLimits> motion_braking(const MachineConfig& config, const Vec3& u,
                                                            double feed_mm_s, std::optional<double> cap_mm_s2) const;
  [[nodiscard]] bool has_axis_dynamics() const { return m_truth.axes.has_value(); }

  /// The simulation side of a scan with a stylus of `nominal_radius_mm` under controller
  /// `config`: the world as the scanning probe touches it, the true ball, the probe's truth. The
  /// machine errors keep their state at the scan's start (its time and approach directions) for
  /// the whole scan.
  ScanSetup scan_setup(double nominal_radius_mm, const MachineConfig& config);

 private:
  void update_error_state();

 private:
  static constexpr double inf = std::numeric_limits<double>::infinity();
  WorldTruth m_truth;
  std::unique_ptr<Solid> m_solid;
  std::unique_ptr<Solid> m_scan_solid;  // kept: a CAD part takes a while to build
  Vec3 m_stylus_offset_mm = Vec3::Zero();
  Rng m_rng;
  std::size_t m_setups_done = 0;  // part.setups taken so far
  double m_ball_radius_mm = 0;
  Vec3 m_free_centre = Vec3::Zero();
  double m_free_radius_mm = -1;            // none
  double m_error_time_s = 0;               // the machine errors' state: time (a multiple of the step) and
  std::array<int, 3> m_approach{0, 0, 0};  // each axis' last direction of motion
  double m_probe_t0_s = 0;
  const MotionProfile* m_profile = nullptr;
  Vec3 m_probe_start = Vec3::Zero();
  Vec3 m_probe_dir = Vec3::UnitZ();
  double m_contact_s = inf;
  double m_signal_s = inf;
};

}  // namespace metron::machine::detail
