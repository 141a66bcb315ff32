// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cmath>
#include <string>

#include <tl/expected.hpp>

#include "metron/runtime/feature.hpp"

namespace metron::runtime {

/// The midpoint of the common perpendicular of two lines (their intersection when they cross;
/// measured lines seldom cross exactly), or why there is none.
inline tl::expected<Vec3, std::string> line_line(const Geometry& a, const Geometry& b) {
  const Vec3 w = a.position - b.position;
  const double aa = a.direction.dot(a.direction), bb = b.direction.dot(b.direction), ab = a.direction.dot(b.direction);
  const double den = aa * bb - ab * ab;
  if (std::abs(den) < 1e-12) return tl::unexpected(std::string("the lines are parallel: no intersection"));
  const double s = (ab * b.direction.dot(w) - bb * a.direction.dot(w)) / den;
  const double t = (aa * b.direction.dot(w) - ab * a.direction.dot(w)) / den;
  return Vec3(0.5 * ((a.position + s * a.direction) + (b.position + t * b.direction)));
}

}  // namespace metron::runtime
