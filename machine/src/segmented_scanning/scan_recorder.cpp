// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/segmented_scanning/scan_recorder.hpp"

#include <numbers>

namespace metron::machine::segmented {

void StylusDeflectionRecorder::record(const ScanCycle& c) {
  // The stylus tip relative to the probe head: x'' = -w^2 x - 2 zeta w x' - a_head, integrated
  // semi-implicitly (stable for w*h < 2) with the head acceleration held over the cycle.
  const double w = 2 * std::numbers::pi * m_params.natural_frequency_hz;
  const double h = c.dt_s / m_params.substeps;
  for (int i = 0; i < m_params.substeps; ++i) {
    m_v += h * (-w * w * m_x - 2 * m_params.damping_ratio * w * m_v - c.acceleration_mm_s2);
    m_x += h * m_v;
  }
  if (m_have_last && c.state.s_mm <= m_last_s_mm) return;  // at rest: no new point
  m_have_last = true;
  m_last_s_mm = c.state.s_mm;
  m_points.push_back({c.t_s, c.command_index, c.state.s_mm, c.position_mm, c.state.v_mm_s, m_x.norm()});
}

void StylusDeflectionRecorder::contact_changed(bool in_contact, double /*t_s*/) {
  // A new contact starts from the settled reference deflection.
  if (in_contact) {
    m_x.setZero();
    m_v.setZero();
  }
}

}  // namespace metron::machine::segmented
