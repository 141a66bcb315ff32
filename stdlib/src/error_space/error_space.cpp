// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/error_space/error_space.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace metron::error_space {

std::string_view to_string(Component c) {
  switch (c) {
    case Component::X: return "x";
    case Component::Y: return "y";
    case Component::Z: return "z";
  }
  return "?";
}

bool Grid::valid() const {
  for (const auto& x : axes_mm) {
    if (x.empty()) return false;
    for (std::size_t i = 0; i < x.size(); ++i) {
      if (!std::isfinite(x[i])) return false;
      if (i > 0 && !(x[i] > x[i - 1])) return false;
    }
  }
  return true;
}

ErrorSpace at_temperature(const std::vector<ErrorSpace>& spaces, double t) {
  if (spaces.empty()) throw std::invalid_argument("no error space to interpolate by temperature");
  for (const auto& s : spaces) {
    if (!(s.grid == spaces[0].grid))
      throw std::invalid_argument("error spaces at different temperatures have different grids");
    for (int c = 0; c < 3; ++c)
      if (s.values_mm[c].size() != spaces[0].values_mm[c].size())
        throw std::invalid_argument("error spaces at different temperatures have different components");
  }
  std::vector<const ErrorSpace*> sorted;
  for (const auto& s : spaces) sorted.push_back(&s);
  std::sort(sorted.begin(), sorted.end(), [](auto* a, auto* b) { return a->temperature_c < b->temperature_c; });
  if (t <= sorted.front()->temperature_c || sorted.size() == 1) {
    ErrorSpace out = *sorted.front();
    out.temperature_c = t;
    return out;
  }
  if (t >= sorted.back()->temperature_c) {
    ErrorSpace out = *sorted.back();
    out.temperature_c = t;
    return out;
  }
  std::size_t hi = 1;
  while (sorted[hi]->temperature_c < t) ++hi;
  const ErrorSpace& a = *sorted[hi - 1];
  const ErrorSpace& b = *sorted[hi];
  // SEEDS.md 4, temperature: the spaces measured at the neighbouring temperatures, weighted linearly.
  const double w = (t - a.temperature_c) / (b.temperature_c - a.temperature_c);
  ErrorSpace out = a;
  out.temperature_c = t;
  for (int c = 0; c < 3; ++c) {
    for (std::size_t i = 0; i < out.values_mm[c].size(); ++i)
      out.values_mm[c][i] = (1 - w) * a.values_mm[c][i] + w * b.values_mm[c][i];
    if (a.sd_mm[c].size() == b.sd_mm[c].size())
      for (std::size_t i = 0; i < out.sd_mm[c].size(); ++i) out.sd_mm[c][i] = std::max(a.sd_mm[c][i], b.sd_mm[c][i]);
  }
  return out;
}

}  // namespace metron::error_space
