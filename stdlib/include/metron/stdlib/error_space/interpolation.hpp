// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <array>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <tl/expected.hpp>

#include "metron/stdlib/error_space/error_space.hpp"

/// Interpolation of an error space between its grid points (SEEDS.md 4): trilinear, cubic
/// B-spline, and least squares on a local model with its uncertainty. Outside the grid a query is
/// clamped to the grid box (no extrapolation).
namespace metron::error_space {

/// The interpolation methods of SEEDS.md 4.
enum class Method {
  Trilinear,  ///< 8 cell corners; continuous, derivative not continuous
  BSpline,  ///< cubic tensor B-spline through the grid values (not-a-knot ends); C2; needs >= 4 uniform points per axis
  LeastSquares,  ///< a local model fitted by least squares around the cell; value and sigma_e; discontinuous between
                 ///< cells
};

/// "trilinear", "bspline", "least-squares".
std::string_view to_string(Method m);

/// Choices of the least-squares method.
struct LeastSquaresOptions {
  int degree = 1;         ///< 1: e = a x + b y + c z + d (the seed's model); 2: a full quadratic
  int neighbourhood = 1;  ///< half-width in cells: 1 uses the cell's 2x2x2 corners, 2 a 4x4x4 block
};

/// How a space is interpolated (stored in the error-space file).
struct InterpolationSpec {
  Method method = Method::Trilinear;  ///< the method
  LeastSquaresOptions least_squares;  ///< used by Method::LeastSquares
};

/// A value with its standard uncertainty (NaN when the method gives none).
struct Estimate {
  double value_mm = 0;  ///< interpolated error
  double sd_mm = 0;     ///< least squares: sigma_e = sqrt(phi^T Cx phi) (SEEDS.md 4); others NaN
};

/// One component interpolated over a grid. Built once, queried many times (the controller's cycle).
class FieldInterpolator {
 public:
  virtual ~FieldInterpolator() = default;
  /// The interpolated value at (x, y, z) mm.
  [[nodiscard]] virtual double value(double x_mm, double y_mm, double z_mm) const = 0;
  /// Value and uncertainty (only least squares has one).
  [[nodiscard]] virtual Estimate estimate(double x_mm, double y_mm, double z_mm) const;
};

/// Builds the interpolator of one component; an error message when the grid does not suit the
/// method (B-spline: 2 or 3 points on an axis, or non-uniform spacing; least squares: too few
/// points for the model) or the values do not match the grid.
tl::expected<std::unique_ptr<FieldInterpolator>, std::string> make_field(const Grid& grid,
                                                                         const std::vector<double>& values_mm,
                                                                         const InterpolationSpec& spec);

/// All measured components of a space; missing components interpolate to zero.
class SpaceInterpolator {
 public:
  /// Builds the three fields; the first failure is returned.
  static tl::expected<SpaceInterpolator, std::string> build(const ErrorSpace& space, const InterpolationSpec& spec);
  /// The error vector (e_x, e_y, e_z) mm at a point mm. The correction of a measured point is its
  /// opposite:
  /// e is where the tip really is minus where the scales put it, so a reading q is corrected to
  /// q + e(q) and a target P commanded as P - e (docs/error-space.md, "Compensation").
  [[nodiscard]] std::array<double, 3> error_at(double x_mm, double y_mm, double z_mm) const;
  /// One component with its uncertainty.
  [[nodiscard]] Estimate estimate(Component c, double x_mm, double y_mm, double z_mm) const;

 private:
  std::array<std::shared_ptr<const FieldInterpolator>, 3> m_fields;
};

/// SEEDS.md 4, validation: fit on every second grid point (even indices on every axis with more
/// than one point), predict the others inside that subgrid's box, compare.
struct Validation {
  double rms_mm = 0;       ///< RMS of predicted minus grid value
  double max_abs_mm = 0;   ///< largest absolute difference
  std::size_t points = 0;  ///< number of predicted points
};

/// Runs the validation for one component; an error when the subgrid does not suit the method.
tl::expected<Validation, std::string> validate_every_second(const Grid& grid, const std::vector<double>& values_mm,
                                                            const InterpolationSpec& spec);

}  // namespace metron::error_space
