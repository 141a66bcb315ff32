// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstddef>
#include <vector>

#include "metron/machine/measurement_command.hpp"
#include "metron/machine/segmented_scanning/path_interpolator.hpp"
#include "metron/stdlib/geometry/vec.hpp"

namespace metron::machine::segmented {

/// What the controller knows about one control cycle while the probe scans.
struct ScanCycle {
  double t_s = 0;                          ///< simulated time at the end of the cycle
  double dt_s = 0.001;                     ///< cycle length
  std::size_t command_index = 0;           ///< the command the probe is in
  PathState state;                         ///< arc length, speed, acceleration, jerk
  double limit_mm_s = 0;                   ///< the speed limit where the probe is
  Vec3 position_mm = Vec3::Zero();         ///< commanded probe (ball-centre) position on the path
  Vec3 acceleration_mm_s2 = Vec3::Zero();  ///< path acceleration a*T + v^2*kappa*N
};

/// What the controller asks of a probe-driving recorder in a cycle off the path.
enum class OffPathMove {
  Hold,      ///< stay where it is (waiting for a plan, or before the first approach)
  Retract,   ///< finish the path up to the stop, then leave the surface
  Approach,  ///< find the surface again at the path point where the next command starts
};

/// Receives every scanning cycle; the scanning probe model plugs in here.
class ScanRecorder {
 public:
  virtual ~ScanRecorder() = default;
  /// One cycle in contact with the surface.
  virtual void record(const ScanCycle& cycle) = 0;
  /// The probe leaves (false) or regains (true) contact: retract and approach.
  virtual void contact_changed(bool /*in_contact*/, double /*t_s*/) {}
  /// A command has been written into a buffer (in order): a probe driver learns the path here.
  virtual void command_loaded(const MeasurementCommand& /*command*/) {}
  /// True when this recorder moves a real (simulated) probe: then the controller hands it every
  /// cycle (record() while scanning, off_path() otherwise) and a retract or an approach ends
  /// when the probe reports it done, not after the controller's own estimate of its duration.
  [[nodiscard]] virtual bool drives_probe() const { return false; }
  /// One cycle off the path (only called when drives_probe()): `s_mm` is the arc length of the
  /// stop or of the command start; returns true when the move is complete.
  virtual bool off_path(OffPathMove /*move*/, double /*s_mm*/, double /*t_s*/) { return true; }
};

/// A recorded measurement point.
struct ScanPoint {
  double t_s = 0;                   ///< simulated time
  std::size_t command_index = 0;    ///< the command it belongs to
  double s_mm = 0;                  ///< arc length along the path
  Vec3 position_mm = Vec3::Zero();  ///< probe position
  double speed_mm_s = 0;            ///< path speed
  double deflection_error_mm = 0;   ///< |stylus deflection - reference|: the quality signal
};

/// Stand-in for the scanning probe's deflection (documented in docs/segmented-scanning.md): the
/// stylus tip is a damped mass-spring, x'' + 2*zeta*w*x' + w^2*x = -a_path, so the deflection
/// deviates from the reference in proportion to the path acceleration and rings after jerks.
/// It records a point every cycle in which the probe advanced along the path (a probe at rest
/// adds no new point: the point set stays strictly ordered, without duplicates).
class StylusDeflectionRecorder : public ScanRecorder {
 public:
  /// Stylus dynamics.
  struct Params {
    double natural_frequency_hz = 60.0;  ///< w / (2 pi)
    double damping_ratio = 0.1;          ///< zeta
    int substeps = 8;                    ///< integration steps per cycle
  };
  StylusDeflectionRecorder() : StylusDeflectionRecorder(Params{}) {}
  /// A recorder with the given stylus dynamics.
  explicit StylusDeflectionRecorder(Params params) : m_params(params) {}

  void record(const ScanCycle& cycle) override;
  void contact_changed(bool in_contact, double t_s) override;

  /// The recorded points, in path order.
  [[nodiscard]] const std::vector<ScanPoint>& points() const { return m_points; }

 private:
  Params m_params;
  Vec3 m_x = Vec3::Zero(), m_v = Vec3::Zero();
  bool m_have_last = false;
  double m_last_s_mm = 0;
  std::vector<ScanPoint> m_points;
};

/// Keeps every cycle (for limit checks in tests and profiles in the bench).
class CycleLog : public ScanRecorder {
 public:
  void record(const ScanCycle& cycle) override { cycles.push_back(cycle); }
  std::vector<ScanCycle> cycles;  ///< all recorded cycles in order
};

/// Forwards to several recorders.
class RecorderTee : public ScanRecorder {
 public:
  /// Forwards to `a`, then `b`.
  RecorderTee(ScanRecorder& a, ScanRecorder& b) : m_a(a), m_b(b) {}
  void record(const ScanCycle& c) override {
    m_a.record(c);
    m_b.record(c);
  }
  void contact_changed(bool in, double t) override {
    m_a.contact_changed(in, t);
    m_b.contact_changed(in, t);
  }
  void command_loaded(const MeasurementCommand& c) override {
    m_a.command_loaded(c);
    m_b.command_loaded(c);
  }
  [[nodiscard]] bool drives_probe() const override { return m_a.drives_probe() || m_b.drives_probe(); }
  bool off_path(OffPathMove move, double s_mm, double t_s) override {
    const bool a = m_a.off_path(move, s_mm, t_s);
    const bool b = m_b.off_path(move, s_mm, t_s);
    return a && b;
  }

 private:
  ScanRecorder& m_a;
  ScanRecorder& m_b;
};

}  // namespace metron::machine::segmented
