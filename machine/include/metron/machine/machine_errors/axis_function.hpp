// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <vector>

namespace metron::machine {

/// One error as a function of an axis position (ISO 230-1 component errors such as EXX, EBX):
/// polynomial coefficients or a table with a stated interpolation.
class AxisFunction {
 public:
  /// How a table is interpolated.
  enum class Interpolation {
    Linear,  ///< straight lines between the entries
    Cubic,   ///< natural cubic spline through the entries (continuous slope and curvature)
  };
  /// Zero everywhere.
  AxisFunction() = default;
  /// c0 + c1 q + c2 q^2 + ... (q in mm; c_i in the error's unit per mm^i).
  static AxisFunction polynomial(std::vector<double> coefficients);
  /// A table at increasing positions; outside it the end values hold. Throws std::invalid_argument
  /// on sizes that differ, fewer than 2 entries or positions not increasing.
  static AxisFunction table(std::vector<double> at_mm, std::vector<double> values, Interpolation interpolation);

  /// The value at position q mm.
  [[nodiscard]] double operator()(double q_mm) const;
  /// Identically zero (lets a model skip work).
  [[nodiscard]] bool zero() const { return m_poly.empty() && m_at.empty(); }

 private:
  std::vector<double> m_poly;
  std::vector<double> m_at, m_values, m_second;  // m_second: spline second derivatives
  Interpolation m_interpolation = Interpolation::Linear;
};

}  // namespace metron::machine
