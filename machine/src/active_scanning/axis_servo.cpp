// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/active_scanning/axis_servo.hpp"

#include <algorithm>
#include <numbers>

namespace metron::machine {

AxisServo::AxisServo(const ServoSpec& spec, const Vec3& position_mm)
    : m_spec(spec),
      m_position(position_mm),
      m_pipeline(static_cast<std::size_t>(std::max(0, spec.command_delay_cycles)) + 1, Vec3::Zero()) {}

void AxisServo::step(const Vec3& command_mm_s, double dt_s) {
  // The command enters the pipeline; the drives act on the one sent delay cycles ago.
  m_pipeline[m_head] = command_mm_s;
  m_head = (m_head + 1) % m_pipeline.size();
  const Vec3 target = m_pipeline[m_head];
  const double w = 2 * std::numbers::pi * m_spec.natural_frequency_hz;
  const double a_max = m_spec.max_acceleration_mm_s2;
  // Ten semi-implicit Euler substeps per cycle: w*h stays below 0.05 up to 80 Hz loops.
  constexpr int substeps = 10;
  const double h = dt_s / substeps;
  for (int k = 0; k < substeps; ++k) {
    const Vec3 jerk = w * w * (target - m_velocity) - 2 * m_spec.damping * w * m_acceleration;
    m_acceleration += h * jerk;
    m_acceleration = m_acceleration.cwiseMax(-a_max).cwiseMin(a_max);
    m_velocity += h * m_acceleration;
    m_position += h * m_velocity;
  }
}

}  // namespace metron::machine
