// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cmath>
#include <optional>

#include <fmt/format.h>

#include "metron/machine/active_scanning/scan_controller.hpp"
#include "metron/machine/active_scanning/scanning_probe.hpp"
#include "metron/machine/fault.hpp"

// What the nominal scan (scan_controller.cpp) and the unknown-contour scan (contour_scan.cpp)
// do alike every control cycle around their scanning laws: read the probe, approach the surface
// and settle at E0, retract, and keep the command within the machine's limits.
namespace metron::machine::detail {

inline std::string scan_xyz(const Vec3& p) { return fmt::format("({:.4f}, {:.4f}, {:.4f})", p.x(), p.y(), p.z()); }

/// One reading of the scanning probe with the head at `head`: the deflection as read and
/// whether the ball touches; an over-range fault when the true deflection exceeds the range.
struct ProbeReading {
  Vec3 ep = Vec3::Zero();
  double e = 0;
  bool contact = false;
  std::optional<Fault> over_range;
};
inline ProbeReading read_probe(ScanningProbe& probe, const Vec3& head, double range_mm, double t, ScanStats& stats) {
  ProbeReading r;
  const Vec3 true_ep = probe.deflection(head);
  stats.max_force_n = std::max(stats.max_force_n, probe.force_n(true_ep));
  if (true_ep.norm() > range_mm) {
    r.over_range =
        Fault{FaultKind::OverTravel,
              fmt::format("scanning probe over-range: deflection {:.3f} mm exceeds the measuring range {:.3f} mm at {}",
                          true_ep.norm(), range_mm, scan_xyz(head)),
              head, t};
    return r;
  }
  r.ep = probe.read(true_ep);
  r.e = r.ep.norm();
  r.contact = r.e > 1e-6;
  return r;
}

/// The approach along -normal from `start` at the approach feed until the probe is deflected,
/// then the settling: Ve only (SEEDS.md 1: Ve = K*(|Ep| - E0)*eu) until the deflection has held
/// E0 within 5 um for 10 cycles, or for at most 1 s.
class ApproachAndSettle {
 public:
  ApproachAndSettle(const ScanControlSpec& ctl, double e0_mm, double range_mm, const Vec3& start_mm, const Vec3& normal,
                    double approach_mm)
      : m_ctl(ctl), m_e0(e0_mm), m_range(range_mm), m_start(start_mm), m_normal(normal), m_approach(approach_mm) {}
  struct Step {
    Vec3 v = Vec3::Zero();    ///< the command velocity
    bool settled = false;     ///< the scanning law takes over this cycle
    bool no_contact = false;  ///< approached past approach + range without a touch
  };
  Step step(double t, const Vec3& head, const ProbeReading& r) {
    Step s;
    if (!m_settling) {
      if (r.contact) {
        m_settling = true;
        m_settle_t = t;
      } else if ((m_start - head).dot(m_normal) > m_approach + m_range) {
        s.no_contact = true;
        return s;
      } else {
        s.v = -m_ctl.approach_feed_mm_s * m_normal;
        return s;
      }
    }
    s.v = m_ctl.deflection_gain_1_s * (r.e - m_e0) * (r.contact ? Vec3(r.ep / r.e) : m_normal);
    m_settled_cycles = std::abs(r.e - m_e0) < 0.005 ? m_settled_cycles + 1 : 0;
    s.settled = m_settled_cycles >= 10 || t - m_settle_t > 1.0;
    return s;
  }

 private:
  const ScanControlSpec& m_ctl;
  double m_e0, m_range;
  Vec3 m_start, m_normal;
  double m_approach;
  bool m_settling = false;
  double m_settle_t = 0;
  int m_settled_cycles = 0;
};

/// The retract after the scan: back off along the last deflection direction until the ball is
/// `retract_mm` off the surface (the deflection, then the distance), then stop. nullopt: done.
inline std::optional<Vec3> retract_velocity(const ScanControlSpec& ctl, double since_s, double retract_mm,
                                            double deflection_mm, const Vec3& eu_last, const Vec3& velocity) {
  const double feed = ctl.approach_feed_mm_s;
  const double travel_s = (retract_mm + deflection_mm) / feed;
  if (since_s < travel_s) return Vec3(feed * eu_last);
  if (velocity.norm() < 1e-3 || since_s > travel_s + 0.5) return std::nullopt;
  return Vec3(Vec3::Zero());
}

/// The machine's limits on the command: path speed and acceleration.
inline Vec3 within_machine_limits(Vec3 v, const Vec3& v_prev, double v_max, double a_max, double dt) {
  if (const double n = v.norm(); n > v_max) v *= v_max / n;
  const Vec3 dv = v - v_prev;
  if (const double n = dv.norm(); n > a_max * dt) v = v_prev + dv * (a_max * dt / n);
  return v;
}

}  // namespace metron::machine::detail
