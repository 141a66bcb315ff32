// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "metron/machine/machine_errors/error_term.hpp"
#include "metron/stdlib/error_space/error_space.hpp"
#include "metron/stdlib/error_space/interpolation.hpp"

namespace metron::machine {

/// A non-rigid error: one component depending on two or three axis positions (a bridge that sags
/// with the carriage position, a ram that bends with its extension), given on a grid and
/// interpolated trilinearly; outside the grid the nearest face value holds. An axis the field
/// does not depend on has the single grid coordinate 0.
class GridFieldTerm final : public ErrorTerm {
 public:
  /// Throws std::invalid_argument when the grid is invalid or the values do not match it.
  GridFieldTerm(int component, error_space::Grid grid, std::vector<double> values_mm);
  [[nodiscard]] Vec3 displacement(const MachinePose& pose, double time_s) const override;
  [[nodiscard]] std::string_view name() const override { return m_name; }

 private:
  int m_component;
  std::shared_ptr<const error_space::FieldInterpolator> m_field;
  std::string m_name;
};

}  // namespace metron::machine
