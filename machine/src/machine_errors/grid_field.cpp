// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/machine_errors/grid_field.hpp"

#include <stdexcept>

#include <fmt/format.h>

namespace metron::machine {

GridFieldTerm::GridFieldTerm(int component, error_space::Grid grid, std::vector<double> values)
    : m_component(component) {
  if (component < 0 || component > 2) throw std::invalid_argument("grid field: component must be x, y or z");
  auto f = error_space::make_field(grid, values, {error_space::Method::Trilinear, {}});
  if (!f) throw std::invalid_argument("grid field: " + f.error());
  m_field = std::move(*f);
  std::string axes;
  for (int a = 0; a < 3; ++a)
    if (grid.axes_mm[a].size() > 1) axes += std::string(axes.empty() ? "" : ",") + "xyz"[a];
  m_name = fmt::format("grid-field {}({})", "xyz"[component], axes);
}

Vec3 GridFieldTerm::displacement(const MachinePose& pose, double) const {
  Vec3 e = Vec3::Zero();
  e[m_component] = m_field->value(pose.axes_mm.x(), pose.axes_mm.y(), pose.axes_mm.z());
  return e;
}

}  // namespace metron::machine
