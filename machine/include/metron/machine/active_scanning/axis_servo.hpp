// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <vector>

#include "metron/machine/active_scanning/scanning_spec.hpp"
#include "metron/stdlib/geometry/vec.hpp"

namespace metron::machine {

/// The three axis drives in the simulated world (hidden dynamics): each axis's velocity answers
/// the commanded velocity as v'' + 2*zeta*w*v' + w^2*v = w^2*v_cmd (a velocity loop with a mass),
/// its acceleration clipped to the drive's limit, the command arriving `command_delay_cycles`
/// controller cycles late. A command whose components fight makes this loop ring.
class AxisServo {
 public:
  AxisServo(const ServoSpec& spec, const Vec3& position_mm);
  /// Hands a velocity command to the drives and advances the axes by one controller cycle dt.
  void step(const Vec3& command_mm_s, double dt_s);
  /// Encoder positions (the head, i.e. the undeflected ball centre).
  [[nodiscard]] const Vec3& position_mm() const { return m_position; }
  /// Axis velocities.
  [[nodiscard]] const Vec3& velocity_mm_s() const { return m_velocity; }

 private:
  ServoSpec m_spec;
  Vec3 m_position;
  Vec3 m_velocity = Vec3::Zero();
  Vec3 m_acceleration = Vec3::Zero();
  std::vector<Vec3> m_pipeline;  ///< commands in transit, oldest first
  std::size_t m_head = 0;
};

}  // namespace metron::machine
