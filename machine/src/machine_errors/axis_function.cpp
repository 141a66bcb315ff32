// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/machine_errors/axis_function.hpp"

#include <algorithm>
#include <stdexcept>

namespace metron::machine {

AxisFunction AxisFunction::polynomial(std::vector<double> c) {
  AxisFunction f;
  while (!c.empty() && c.back() == 0.0) c.pop_back();
  f.m_poly = std::move(c);
  return f;
}

AxisFunction AxisFunction::table(std::vector<double> at, std::vector<double> v, Interpolation interpolation) {
  if (at.size() != v.size()) throw std::invalid_argument("an error table needs as many values as positions");
  if (at.size() < 2) throw std::invalid_argument("an error table needs at least 2 entries");
  for (std::size_t i = 1; i < at.size(); ++i)
    if (!(at[i] > at[i - 1])) throw std::invalid_argument("error table positions must increase");
  AxisFunction f;
  f.m_interpolation = interpolation;
  const std::size_t n = at.size();
  f.m_second.assign(n, 0.0);
  if (interpolation == Interpolation::Cubic && n > 2) {
    // Natural cubic spline: tridiagonal system for the second derivatives (Thomas algorithm;
    // W. H. Press et al., Numerical Recipes, 3rd ed., 3.3).
    std::vector<double> u(n, 0.0);
    for (std::size_t i = 1; i + 1 < n; ++i) {
      const double sig = (at[i] - at[i - 1]) / (at[i + 1] - at[i - 1]);
      const double p = sig * f.m_second[i - 1] + 2.0;
      f.m_second[i] = (sig - 1.0) / p;
      u[i] = (v[i + 1] - v[i]) / (at[i + 1] - at[i]) - (v[i] - v[i - 1]) / (at[i] - at[i - 1]);
      u[i] = (6.0 * u[i] / (at[i + 1] - at[i - 1]) - sig * u[i - 1]) / p;
    }
    f.m_second[n - 1] = 0.0;
    for (std::size_t k = n - 1; k-- > 0;) f.m_second[k] = f.m_second[k] * f.m_second[k + 1] + u[k];
  }
  f.m_at = std::move(at);
  f.m_values = std::move(v);
  return f;
}

double AxisFunction::operator()(double q) const {
  if (!m_poly.empty()) {
    double s = 0;
    for (std::size_t i = m_poly.size(); i-- > 0;) s = s * q + m_poly[i];  // Horner
    return s;
  }
  if (m_at.empty()) return 0;
  if (q <= m_at.front()) return m_values.front();
  if (q >= m_at.back()) return m_values.back();
  const std::size_t hi = static_cast<std::size_t>(std::upper_bound(m_at.begin(), m_at.end(), q) - m_at.begin());
  const std::size_t lo = hi - 1;
  const double h = m_at[hi] - m_at[lo], a = (m_at[hi] - q) / h, b = (q - m_at[lo]) / h;
  double y = a * m_values[lo] + b * m_values[hi];
  if (m_interpolation == Interpolation::Cubic)
    y += ((a * a * a - a) * m_second[lo] + (b * b * b - b) * m_second[hi]) * h * h / 6.0;
  return y;
}

}  // namespace metron::machine
