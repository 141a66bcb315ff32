// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/geometry/ellipse.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace metron::geometry {
namespace {

/// The root s of (r0 z0 / (s + r0))^2 + (z1 / (s + 1))^2 = 1 on the bracket Eberly derives
/// (r0 = (e0/e1)^2, z = y / e, g its value at s = 0), by bisection to the last bit.
double root(double r0, double z0, double z1, double g) {
  const double n0 = r0 * z0;
  double s0 = z1 - 1;
  double s1 = g < 0 ? 0.0 : std::hypot(n0, z1) - 1;
  double s = 0;
  for (int i = 0; i < 1100; ++i) {
    s = 0.5 * (s0 + s1);
    if (s == s0 || s == s1) break;
    const double ratio0 = n0 / (s + r0), ratio1 = z1 / (s + 1);
    const double value = ratio0 * ratio0 + ratio1 * ratio1 - 1;
    if (value > 0)
      s0 = s;
    else if (value < 0)
      s1 = s;
    else
      break;
  }
  return s;
}

/// The foot in the first quadrant, e0 >= e1 > 0, y0, y1 >= 0 (Eberly's cases).
Eigen::Vector2d first_quadrant_foot(double e0, double e1, double y0, double y1) {
  if (y1 > 0) {
    if (y0 > 0) {
      const double z0 = y0 / e0, z1 = y1 / e1, g = z0 * z0 + z1 * z1 - 1;
      if (g == 0) return {y0, y1};
      const double r0 = (e0 / e1) * (e0 / e1);
      const double s = root(r0, z0, z1, g);
      return {r0 * y0 / (s + r0), y1 / (s + 1)};
    }
    return {0.0, e1};
  }
  // On the major axis: inside the evolute's cusp the nearest points leave the axis.
  const double numerator = e0 * y0, denominator = e0 * e0 - e1 * e1;
  if (numerator < denominator) {
    const double x = numerator / denominator;
    return {e0 * x, e1 * std::sqrt(std::max(0.0, 1 - x * x))};
  }
  return {e0, 0.0};
}

}  // namespace

EllipseFoot ellipse_foot(double a, double b, const Eigen::Vector2d& p) {
  // Work with the major semi-axis first and in the first quadrant; restore signs and order after.
  const bool swapped = a < b;
  const double e0 = swapped ? b : a, e1 = swapped ? a : b;
  const double px = swapped ? p.y() : p.x(), py = swapped ? p.x() : p.y();
  Eigen::Vector2d f = first_quadrant_foot(e0, e1, std::abs(px), std::abs(py));
  f.x() = std::copysign(f.x(), px);
  f.y() = std::copysign(f.y(), py);
  if (swapped) std::swap(f.x(), f.y());
  EllipseFoot out;
  out.foot = f;
  // The outward normal is the gradient of x^2/a^2 + y^2/b^2 at the foot.
  out.normal = Eigen::Vector2d(f.x() / (a * a), f.y() / (b * b)).normalized();
  const double inside = (p.x() / a) * (p.x() / a) + (p.y() / b) * (p.y() / b) - 1;
  out.signed_distance = (inside < 0 ? -1.0 : 1.0) * (p - f).norm();
  return out;
}

}  // namespace metron::geometry
