// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <tl/expected.hpp>

#include "metron/stdlib/geometry/vec.hpp"

/// Least-squares (Gaussian, orthogonal distance) fitting of the DMIS substitute features.
///
/// Conventions follow the NIST Algorithm Testing System (C. M. Shakarji, "Least-Squares Fitting
/// Algorithms of the NIST Algorithm Testing System", J. Res. NIST 103(6), 1998), so results can be
/// compared with its reference pairs directly.
namespace metron::fitting {

/// Why a fit produced no result (an expected outcome, not a bug).
enum class FitFailure {
  TooFewPoints,  ///< fewer points than the shape needs (point 1, line 2, plane 3, circle 3, sphere 4, cylinder 5, cone
                 ///< 6)
  Degenerate,    ///< the points do not determine the shape (coincident, collinear for a plane or circle, coplanar for a
                 ///< sphere) or a coordinate is not finite
  NoConvergence,  ///< no finite least-squares shape: the iteration did not settle, or the best fit is worse than a
                  ///< plane (line), i.e. the minimum lies at infinite radius (a cylinder, cone, sphere or circle
                  ///< through nearly flat or straight data)
};

/// "too few points", "degenerate point set", "no convergence".
std::string to_string(FitFailure failure);

/// The shapes `fit` knows.
enum class Shape { Point, Line, Plane, Circle, Sphere, Cylinder, Cone };

/// "point", "line", ... (lowercase).
std::string_view to_string(Shape shape);

/// Parses "point", "line", "plane", "circle", "sphere", "cylinder", "cone", case-insensitively.
std::optional<Shape> shape_from_name(std::string_view name);

/// Probe compensation: measured points are stylus ball CENTRES. The fit is done on the centres
/// and the size is corrected by the ball radius (inner features: diameter + 2r, outer: - 2r;
/// cone distance + r / - r; planes, lines and points shifted by r against the approach direction).
struct Compensation {
  double ball_radius_mm = 0;  ///< stylus ball radius
  /// One per point: the approach direction, pointing from the surface toward where the probe came
  /// from (the nominal surface normal on the side of the material the probe was on).
  std::vector<Vec3> approach;
};

/// Choices that the points alone cannot make.
struct FitOptions {
  std::optional<Compensation> compensation;  ///< when set, the points are ball centres (see Compensation)
  /// Plane/circle normal or cylinder/cone axis to orient the result (and to start the iteration
  /// from); for a line, the normal of the plane the line was measured in.
  std::optional<Vec3> direction_hint;
  bool inner =
      true;  ///< circle/sphere/cylinder/cone: a hole (material outside); the side for compensation and residual signs
  bool circle_in_plane_of_hint = false;
  /// Cylinder/cone: keep the minimum reached from `direction_hint` (the nominal axis) when that fit
  /// converges, instead of the lowest of a global search. CMM software fits measured features
  /// from their nominal; it also keeps degenerate patterns on the nominal (two rings of four
  /// points at equal angles lie exactly on a diagonal cylinder too).
  bool start_from_hint = false;  ///< circle: project onto the plane through the centroid normal to `direction_hint`
                                 ///< instead of fitting a plane
};

/// A fitted feature. All lengths in mm, in the coordinates of the input points.
struct FitResult {
  Shape shape = Shape::Point;  ///< what was fitted
  /// point: the point (mean); line: the centroid (a point on the line); plane: the centroid (on the
  /// plane); circle/sphere: the centre; cylinder/cone: the point on the axis closest to the
  /// centroid of the points (the NIST convention; for a cone `cone_distance_mm` refers to it).
  /// With compensation, lines, planes and points are shifted onto the surface.
  Vec3 position = Vec3::Zero();
  /// Unit. Line: direction, from the first toward the last point. Plane/circle: normal, the sign
  /// that agrees with the mean approach direction when given, else with `direction_hint`, else
  /// with its largest component positive (an approach or hint more than 60 degrees off the
  /// normal's line, such as the radial approaches of a circle, is not used). Cylinder: axis,
  /// agreeing with the hint, else largest component positive. Cone: axis from the apex toward
  /// the opening (NIST). Point: zero.
  Vec3 direction = Vec3::Zero();
  double diameter_mm = 0;     ///< circle, sphere, cylinder (compensated)
  double apex_angle_deg = 0;  ///< cone: full apex angle
  /// Cone: orthogonal distance from `position` to the cone surface (NIST convention; equals the
  /// radius at `position` times cos(apex_angle/2)), compensated.
  double cone_distance_mm = 0;
  /// Signed orthogonal distance of each point (compensated: centre - r * approach) from the fitted
  /// geometry. + = outside the material when the side is known (compensation given: by `inner`
  /// for round shapes, by the approach for planes and lines), else outward from the centre or
  /// axis, along the plane normal. Line: the signed distance across the line in the plane normal
  /// to `direction_hint` when given (sign toward the approach side if known), else the unsigned
  /// distance from the line. Point: the distance from the point.
  std::vector<double> residuals_mm;
  double rms_mm = 0;  ///< root mean square of the residuals
  /// Form error, max residual - min residual: flatness, roundness (in the circle plane),
  /// sphericity, cylindricity, conicity, and straightness across the line in the hint plane.
  /// Line without a hint: 2 * the largest distance (the diameter of the enclosing cylinder about
  /// the fitted line). Point: the largest distance.
  double form_mm = 0;
  int iterations = 0;  ///< Levenberg-Marquardt iterations of the successful start (0 for closed forms)
};

/// Fits `shape` to `points` by orthogonal distance least squares.
/// @throws std::invalid_argument when the compensation does not give one finite, non-zero approach
///         per point (they need not be unit: they are normalised) or its ball radius is negative.
tl::expected<FitResult, FitFailure> fit(Shape shape, const std::vector<Vec3>& points, const FitOptions& options = {});

/// The mean of the points.
tl::expected<FitResult, FitFailure> fit_point(const std::vector<Vec3>& points, const FitOptions& options = {});
/// 3-D least-squares line (principal axis of the centred points).
tl::expected<FitResult, FitFailure> fit_line(const std::vector<Vec3>& points, const FitOptions& options = {});
/// Least-squares plane (smallest principal axis of the centred points).
tl::expected<FitResult, FitFailure> fit_plane(const std::vector<Vec3>& points, const FitOptions& options = {});
/// Circle in 3-D: fits the plane (or takes the hint plane), projects, fits the circle in the plane.
tl::expected<FitResult, FitFailure> fit_circle(const std::vector<Vec3>& points, const FitOptions& options = {});
/// Least-squares sphere.
tl::expected<FitResult, FitFailure> fit_sphere(const std::vector<Vec3>& points, const FitOptions& options = {});
/// Least-squares cylinder.
tl::expected<FitResult, FitFailure> fit_cylinder(const std::vector<Vec3>& points, const FitOptions& options = {});
/// Least-squares cone.
tl::expected<FitResult, FitFailure> fit_cone(const std::vector<Vec3>& points, const FitOptions& options = {});

}  // namespace metron::fitting
