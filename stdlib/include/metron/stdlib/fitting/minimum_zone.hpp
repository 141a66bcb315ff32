// SPDX-License-Identifier: GPL-3.0-or-later
// Minimum-zone (Chebyshev) form: the width of the narrowest zone that holds every point, as ISO
// 1101 defines flatness, roundness, straightness, cylindricity and sphericity (ISO 12781-1,
// 12181-1, 12780-1, 12180-1: MZ reference features). The least-squares form of fit.hpp stays
// available; a report names which one it gives.
#pragma once
#include <optional>
#include <vector>

#include <tl/expected.hpp>

#include "metron/stdlib/fitting/fit.hpp"
#include "metron/stdlib/geometry/vec.hpp"

namespace metron::fitting {

/// The minimum zone of a point set and the reference feature that achieves it.
struct MinimumZone {
  double form_mm = 0;  ///< zone width: plane gap, annulus / shell width, cylinder-shell width, line-zone width
  Vec3 position =
      Vec3::Zero();  ///< a point of the MZ reference: plane point, circle/sphere centre, point on the axis or line
  Vec3 direction = Vec3::UnitZ();    ///< plane normal, circle plane normal, cylinder axis, line direction
  double least_squares_form_mm = 0;  ///< the same points' least-squares form (max - min residual), for comparison
  /// Circle, sphere, cylinder: the zone's mean diameter, r_min + r_max about `position` (and
  /// `direction`): the size of the minimum-zone reference feature (ISO 12181-1 MZCI and its
  /// sphere and cylinder counterparts).
  double zone_diameter_mm = 0;
  /// Cone: the full apex angle of the minimum-zone reference cone, whose apex is `position` and
  /// axis `direction` (from the apex toward the opening); its surface is the zone's middle.
  double apex_angle_deg = 0;
  int evaluations = 0;  ///< objective evaluations of the search
};

/// Minimum-zone form of `points` (no probe compensation: give surface points) for a Plane
/// (flatness), Circle (roundness in the plane normal to `plane_normal` when given, else in the
/// least-squares plane), Line (straightness: two parallel
/// lines in the plane normal to `plane_normal` when given, else the diameter of the narrowest
/// cylinder about a line), Sphere (sphericity), Cylinder (cylindricity: coaxial cylinders) or
/// Cone (conicity: two coaxial cones of one apex angle, the zone measured normal to the surface;
/// ISO 1101 treats a cone's form as a surface profile, its minimum zone this one).
/// The search starts at the least-squares feature, so the result is never wider than it
/// (Nelder-Mead simplex on the reference's free parameters with restarts, J. A. Nelder and
/// R. Mead, Computer Journal 7(4), 1965; the width is convex near the optimum for these sets).
tl::expected<MinimumZone, FitFailure> minimum_zone(Shape shape, const std::vector<Vec3>& points,
                                                   const std::optional<Vec3>& plane_normal = std::nullopt);

/// A circle that bounds a point set from one side: the maximum inscribed circle (MIC: a hole's
/// size as a pin gauge finds it) or the minimum circumscribed circle (MCC: a boss's size as a
/// ring gauge finds it), ISO 12181-1 reference circles, in the plane normal to `plane_normal`
/// (else the points' least-squares plane). Nelder-Mead on the centre from the least-squares
/// centre; both fail (Degenerate) when the points do not surround their least-squares centre, as
/// points on an arc of 180 degrees or less do not (the MCC of a short arc has its chord for a
/// diameter), and the MIC also when they do not surround its own centre.
struct ExtremeCircle {
  Vec3 centre = Vec3::Zero();
  Vec3 normal = Vec3::UnitZ();
  double diameter_mm = 0;
};
tl::expected<ExtremeCircle, FitFailure> extreme_circle(const std::vector<Vec3>& points, bool inscribed,
                                                       const std::optional<Vec3>& plane_normal = std::nullopt);

/// A sphere or cylinder (or circle) that bounds a point set from one side: the largest that
/// holds no point inside (`inscribed`: a hole's size as a pin or plug gauge finds it) or the
/// smallest that holds every point (a boss's, as a ring gauge finds it); ISO 14405-1's GX and GN
/// sizes. Cylinder: the axis direction (near `direction_hint`, else the least-squares axis) and
/// its point in the plane normal to it; sphere: the centre. Nelder-Mead from the least-squares
/// feature. Both fail (Degenerate) when the points do not surround the least-squares feature: a
/// cylinder's cross-section with an angular gap of 180 degrees or more, a sphere's points all in
/// one hemisphere (a cap); an inscribed one also when its search drifts farther than a quarter of
/// the least-squares radius.
struct ExtremeFeature {
  Vec3 position = Vec3::Zero();    ///< centre; a point on the axis
  Vec3 direction = Vec3::UnitZ();  ///< circle normal, cylinder axis (the least-squares sense); sphere: +Z
  double diameter_mm = 0;
};
tl::expected<ExtremeFeature, FitFailure> extreme_feature(Shape shape, const std::vector<Vec3>& points, bool inscribed,
                                                         const std::optional<Vec3>& direction_hint = std::nullopt);

}  // namespace metron::fitting
