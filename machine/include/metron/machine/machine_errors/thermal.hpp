// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <array>
#include <memory>
#include <vector>

#include "metron/machine/machine_errors/error_term.hpp"

namespace metron::machine {

/// A temperature over simulated time: the air as a piecewise-linear table (held constant beyond
/// its ends) and a body following it through a first-order lag dT/dt = (T_air - T) / tau. The lag
/// is solved exactly per segment: for T_air = A + B s on a segment,
/// T(s) = A + B (s - tau) + (T(0) - A + B tau) exp(-s / tau).
class TemperatureHistory {
 public:
  /// Constant 20 C.
  TemperatureHistory() = default;
  /// `t_s` increasing, same size as `air_c` (>= 1); `lag_s` 0 follows the air; the body starts
  /// at `initial_c` (NaN: at the air temperature of the first entry). Throws std::invalid_argument.
  TemperatureHistory(std::vector<double> t_s, std::vector<double> air_c, double lag_s, double initial_c);
  /// The body temperature at simulated time t (before the first entry: the initial value).
  [[nodiscard]] double body_c(double time_s) const;
  /// The air temperature at simulated time t.
  [[nodiscard]] double air_c(double time_s) const;

 private:
  std::vector<double> m_t{0.0}, m_air{20.0}, m_body_at{20.0};
  double m_lag_s = 0;
};

/// Scale expansion per axis: the scales read true at 20 C (ISO 1); a scale at T is longer by
/// alpha (T - 20), so at reading q the carriage stands at q0 + (q - q0)(1 + alpha (T - 20)), q0 the
/// point where the scale is fixed: e_axis = alpha (T - 20)(q - q0).
class ScaleThermalTerm final : public ErrorTerm {
 public:
  /// One axis' scale.
  struct Scale {
    double alpha_per_k = 0;                                 ///< expansion coefficient, 1/K
    double fixed_at_mm = 0;                                 ///< q0
    std::shared_ptr<const TemperatureHistory> temperature;  ///< the scale's temperature (null: 20 C)
  };
  explicit ScaleThermalTerm(std::array<Scale, 3> scales) : m_scales(std::move(scales)) {}
  [[nodiscard]] Vec3 displacement(const MachinePose& pose, double time_s) const override;
  [[nodiscard]] std::string_view name() const override { return "scale-thermal"; }
  /// The mean temperature of the scales that follow a history (the controller's scale sensors).
  [[nodiscard]] std::optional<double> machine_temperature_c(double time_s) const override;

 private:
  std::array<Scale, 3> m_scales;
};

/// The part grows about a fixed point p0: a part point P (20 C coordinates) stands at
/// p0 + (P - p0)(1 + alpha (T - 20)). Seen from the part, the tip at nominal position p is at
/// p0 + (p - p0)/(1 + s) ~ p - s (p - p0): displacement -alpha (T - 20)(p - p0).
class PartThermalTerm final : public ErrorTerm {
 public:
  PartThermalTerm(double alpha_per_k, Vec3 fixed_point_mm, std::shared_ptr<const TemperatureHistory> temperature)
      : m_alpha(alpha_per_k), m_fixed(std::move(fixed_point_mm)), m_temperature(std::move(temperature)) {}
  [[nodiscard]] Vec3 displacement(const MachinePose& pose, double time_s) const override;
  [[nodiscard]] std::string_view name() const override { return "part-thermal"; }
  [[nodiscard]] Acts acts() const override { return Acts::Part; }

 private:
  double m_alpha;
  Vec3 m_fixed;
  std::shared_ptr<const TemperatureHistory> m_temperature;
};

}  // namespace metron::machine
