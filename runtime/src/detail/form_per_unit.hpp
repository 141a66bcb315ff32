// SPDX-License-Identifier: GPL-3.0-or-later
// Form per unit area and per unit length: TOL/FLAT,t,tu,a,b and TOL/STRGHT,t,tu,l.
#pragma once
#include <cstddef>
#include <optional>
#include <vector>

#include "metron/stdlib/fitting/fit.hpp"
#include "metron/stdlib/geometry/vec.hpp"

namespace metron::runtime {

/// The largest minimum-zone form found in any unit area (unit length) and where.
struct PerUnitForm {
  double form_mm = 0;
  Vec3 centre = Vec3::Zero();  ///< the middle of the worst area's (stretch's) points
  std::size_t units = 0;       ///< distinct point sets of a unit
  std::size_t judged = 0;      ///< of them, those judged by their minimum zone (the rest: least squares below it)
  bool sampled = false;        ///< more points than the exhaustive search takes: the corners were sampled
};

/// The flatness of the points in every `length` x `width` rectangle on a plane with normal `normal`
/// (the rectangle's length along `length_axis` projected onto the plane), or nothing when no
/// rectangle holds four points.
std::optional<PerUnitForm> flatness_per_unit_area(const std::vector<Vec3>& points, const Vec3& normal,
                                                  const Vec3& length_axis, double length, double width);

/// The straightness of the points in every stretch of `length` along `direction` (the zone's
/// plane normal `plane_normal`, as the whole line's), or nothing when no stretch holds three points.
std::optional<PerUnitForm> straightness_per_unit_length(const std::vector<Vec3>& points, const Vec3& direction,
                                                        const std::optional<Vec3>& plane_normal, double length);

}  // namespace metron::runtime
