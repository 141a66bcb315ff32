// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <array>
#include <memory>
#include <string>

#include "metron/machine/machine_errors/error_model.hpp"
#include "metron/machine/solid.hpp"

namespace metron::machine {

/// The simulated world as the machine's scales see it (hidden truth, ARCHITECTURE.md rule 1):
/// where the encoders put the ball centre at p, the ball really is at p + e(p), e the machine
/// error model's displacement for the ram at p - probe offset (docs/error-space.md). Sweeps,
/// touches and scans query this solid at encoder coordinates, so every measurement and move feels
/// the machine's errors without the cycles knowing of them.
///
/// The errors are evaluated in the machine's state set by `set_state`: the simulated time (thermal,
/// drift and transient terms) and each axis' last direction of motion (reversal terms).
class MachineErrorSolid final : public Solid {
 public:
  MachineErrorSolid(std::unique_ptr<Solid> actual, MachineErrorModel errors);

  /// The ball centre's offset from the ram's reference point (the stylus): the Abbe lever of the
  /// angular errors.
  void set_probe_offset(const Vec3& offset_mm) { m_probe_offset_mm = offset_mm; }
  /// The simulated time and, per axis, the direction of the last motion (+1, -1; 0 unknown) in
  /// which the errors are evaluated from now on.
  void set_state(double time_s, const std::array<int, 3>& approach) {
    m_time_s = time_s;
    m_approach = approach;
  }
  /// Where the ball really is when the encoders put it at `p`.
  [[nodiscard]] Vec3 actual_point(const Vec3& p) const;

  [[nodiscard]] double signed_distance(const Vec3& p) const override;
  [[nodiscard]] Vec3 normal(const Vec3& p) const override;
  [[nodiscard]] double lipschitz() const override;
  [[nodiscard]] std::string feature_at(const Vec3& p) const override;

 private:
  std::unique_ptr<Solid> m_actual;
  MachineErrorModel m_errors;
  Vec3 m_probe_offset_mm = Vec3::Zero();
  double m_time_s = 0;
  std::array<int, 3> m_approach{0, 0, 0};
};

}  // namespace metron::machine
