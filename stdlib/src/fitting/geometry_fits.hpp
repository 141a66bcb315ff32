// SPDX-License-Identifier: GPL-3.0-or-later
// Private: the uncompensated geometric fits behind fit(); fit.cpp adds compensation, orientation
// and residual statistics.
#pragma once
#include <optional>
#include <vector>

#include <tl/expected.hpp>

#include "metron/stdlib/fitting/fit.hpp"
#include "metron/stdlib/geometry/vec.hpp"

namespace metron::fitting::detail {

/// Points moved to their centroid and divided by their RMS distance from it, so every fit
/// iterates on numbers of order one whatever the offset and size of the part.
struct NormalizedPoints {
  Vec3 centroid = Vec3::Zero();  ///< of the input points
  double scale = 1;              ///< RMS distance from the centroid (1 for coincident points)
  std::vector<Vec3> points;      ///< (p - centroid) / scale

  [[nodiscard]] Vec3 to_world(const Vec3& q) const { return centroid + scale * q; }
};

NormalizedPoints normalize(const std::vector<Vec3>& points);

/// Principal axes of centred points: columns of `axes` sorted by decreasing RMS extent.
struct PrincipalAxes {
  Mat3 axes = Mat3::Identity();    ///< unit columns: largest, middle, smallest spread
  Vec3 rms_extent = Vec3::Zero();  ///< RMS coordinate along each axis
};

/// SVD of the centred points (they must be centred already).
PrincipalAxes principal_axes(const std::vector<Vec3>& centred);

/// An uncompensated fitted geometry in world coordinates; the direction is not yet oriented
/// (except for cones: apex toward opening).
struct Geometry {
  Vec3 position = Vec3::Zero();   ///< see FitResult::position
  Vec3 direction = Vec3::Zero();  ///< unit, see FitResult::direction
  double radius_mm = 0;           ///< circle, sphere, cylinder
  double half_angle_rad = 0;      ///< cone: half apex angle
  double cone_distance_mm = 0;    ///< cone: orthogonal distance from position to the surface
  int iterations = 0;             ///< Levenberg-Marquardt iterations of the winning start
};

/// Relative size below which a principal extent counts as zero (collinear / coplanar points).
inline constexpr double degenerate_extent = 1e-10;

tl::expected<Geometry, FitFailure> fit_line_geometry(const std::vector<Vec3>& points);
tl::expected<Geometry, FitFailure> fit_plane_geometry(const std::vector<Vec3>& points);
/// `plane_normal`: project onto the plane through the centroid normal to it instead of fitting a plane.
tl::expected<Geometry, FitFailure> fit_circle_geometry(const std::vector<Vec3>& points,
                                                       const std::optional<Vec3>& plane_normal);
tl::expected<Geometry, FitFailure> fit_sphere_geometry(const std::vector<Vec3>& points);
tl::expected<Geometry, FitFailure> fit_cylinder_geometry(const std::vector<Vec3>& points,
                                                         const std::optional<Vec3>& axis_hint, bool hint_only = false);
tl::expected<Geometry, FitFailure> fit_cone_geometry(const std::vector<Vec3>& points,
                                                     const std::optional<Vec3>& axis_hint, bool hint_only = false);

}  // namespace metron::fitting::detail
