// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <array>
#include <cstddef>
#include <optional>
#include <string_view>
#include <vector>

namespace metron::error_space {

/// An error component: the error along one machine axis (SEEDS.md 4's e_x, e_y, e_z).
enum class Component { X = 0, Y = 1, Z = 2 };

/// "x", "y", "z".
std::string_view to_string(Component c);

/// The grid of an error space: strictly increasing coordinates per axis (mm). An axis may have a
/// single point (a plane or a line of the space).
struct Grid {
  std::array<std::vector<double>, 3> axes_mm;  ///< x, y, z grid coordinates

  /// Number of grid points.
  [[nodiscard]] std::size_t size() const { return axes_mm[0].size() * axes_mm[1].size() * axes_mm[2].size(); }
  /// Flat index, x fastest: i + nx (j + ny k) (the order of the file's value arrays).
  [[nodiscard]] std::size_t index(std::size_t i, std::size_t j, std::size_t k) const {
    return i + axes_mm[0].size() * (j + axes_mm[1].size() * k);
  }
  /// Every axis non-empty, finite and strictly increasing.
  [[nodiscard]] bool valid() const;
  /// The same coordinates (exactly).
  bool operator==(const Grid& other) const = default;
};

/// An error space (SEEDS.md 4): error components at the grid points, at one temperature.
struct ErrorSpace {
  Grid grid;                  ///< where the values are
  double temperature_c = 20;  ///< the monitored temperature it was measured at
  /// Per component, one value per grid point (flat, Grid::index order) in mm; empty when the
  /// instruments did not reach that component.
  std::array<std::vector<double>, 3> values_mm;
  /// Per component, optional standard deviation from sensor noise (the method's noise floor), mm.
  std::array<std::vector<double>, 3> sd_mm;

  /// The component was measured.
  [[nodiscard]] bool has(Component c) const { return !values_mm[static_cast<int>(c)].empty(); }
};

/// SEEDS.md 4, temperature: error spaces measured at several temperatures (same grid and
/// components) linearly interpolated at the monitored one; outside the measured range the nearest
/// is used (no extrapolation). Throws std::invalid_argument when `spaces` is empty or the grids or
/// components differ.
ErrorSpace at_temperature(const std::vector<ErrorSpace>& spaces, double temperature_c);

}  // namespace metron::error_space
