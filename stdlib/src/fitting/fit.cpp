// SPDX-License-Identifier: GPL-3.0-or-later
// fit(): input checks, probe compensation, orientation and residual statistics around the
// geometric fits of geometry_fits.hpp.
#include "metron/stdlib/fitting/fit.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "geometry_fits.hpp"

namespace metron::fitting {
namespace {

constexpr std::array<std::string_view, 7> shape_names{"point", "line", "plane", "circle", "sphere", "cylinder", "cone"};

std::size_t min_points(Shape shape) {
  switch (shape) {
    case Shape::Point: return 1;
    case Shape::Line: return 2;
    case Shape::Plane: return 3;
    case Shape::Circle: return 3;
    case Shape::Sphere: return 4;
    case Shape::Cylinder: return 5;
    case Shape::Cone: return 6;
  }
  return 1;
}

/// Flips `n` to agree with the first reference within 60 degrees of its line (a radial mean
/// approach on a circle says nothing about the normal), else makes its largest component positive.
Vec3 orient(const Vec3& n, std::initializer_list<std::optional<Vec3>> references) {
  for (const auto& ref : references) {
    if (!ref || !(ref->norm() > 0)) continue;
    const double c = n.dot(ref->normalized());
    if (std::abs(c) >= 0.5) return c < 0 ? Vec3(-n) : n;
  }
  Eigen::Index k = 0;
  n.cwiseAbs().maxCoeff(&k);
  return n(k) < 0 ? Vec3(-n) : n;
}

/// What fit() needs from the options about the measured side, checked once.
struct Probe {
  double radius_mm = 0;               ///< 0 without compensation
  std::vector<Vec3> surface_points;   ///< centre - r * approach (the points themselves without compensation)
  std::optional<Vec3> mean_approach;  ///< mean unit approach, when compensated
};

Probe make_probe(const std::vector<Vec3>& points, const FitOptions& options) {
  Probe probe;
  probe.surface_points = points;
  if (!options.compensation) return probe;
  const Compensation& comp = *options.compensation;
  if (comp.approach.size() != points.size()) {
    throw std::invalid_argument("fit: compensation needs one approach direction per point");
  }
  if (!std::isfinite(comp.ball_radius_mm) || comp.ball_radius_mm < 0) {
    throw std::invalid_argument("fit: the ball radius must be finite and not negative");
  }
  probe.radius_mm = comp.ball_radius_mm;
  Vec3 sum = Vec3::Zero();
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vec3& a = comp.approach[i];
    if (!a.allFinite() || !(a.norm() > 0)) {
      throw std::invalid_argument("fit: approach directions must be finite and non-zero");
    }
    const Vec3 unit = a.normalized();
    probe.surface_points[i] -= probe.radius_mm * unit;
    sum += unit;
  }
  if (!points.empty()) probe.mean_approach = sum / static_cast<double>(points.size());
  return probe;
}

void finish_statistics(FitResult& r) {
  double sum_sq = 0;
  for (double d : r.residuals_mm) sum_sq += d * d;
  r.rms_mm = std::sqrt(sum_sq / static_cast<double>(r.residuals_mm.size()));
  const auto [lo, hi] = std::minmax_element(r.residuals_mm.begin(), r.residuals_mm.end());
  r.form_mm = *hi - *lo;
}

FitResult make_point(const Probe& probe) {
  FitResult r;
  for (const Vec3& p : probe.surface_points) r.position += p;
  r.position /= static_cast<double>(probe.surface_points.size());
  for (const Vec3& p : probe.surface_points) r.residuals_mm.push_back((p - r.position).norm());
  finish_statistics(r);
  r.form_mm = *std::max_element(r.residuals_mm.begin(), r.residuals_mm.end());
  return r;
}

FitResult make_line(const detail::Geometry& g, const std::vector<Vec3>& points, const Probe& probe,
                    const FitOptions& options) {
  FitResult r;
  r.direction = g.direction;
  if ((points.back() - points.front()).dot(r.direction) < 0) r.direction = -r.direction;
  r.position = g.position;
  // Across-line direction in the plane normal to the hint, toward the approach side when known.
  std::optional<Vec3> across;
  if (options.direction_hint) {
    const Vec3 in_normal = *options.direction_hint - options.direction_hint->dot(r.direction) * r.direction;
    if (in_normal.norm() > 1e-9 * options.direction_hint->norm()) {
      across = r.direction.cross(in_normal).normalized();
      if (probe.mean_approach && across->dot(*probe.mean_approach) < 0) across = -*across;
    }
  }
  if (probe.mean_approach) {
    Vec3 side = across ? *across : Vec3(*probe.mean_approach - probe.mean_approach->dot(r.direction) * r.direction);
    if (side.norm() > 0) r.position -= probe.radius_mm * side.normalized();
  }
  for (const Vec3& p : probe.surface_points) {
    const Vec3 d = p - r.position;
    r.residuals_mm.push_back(across ? d.dot(*across) : d.cross(r.direction).norm());
  }
  finish_statistics(r);
  if (!across) r.form_mm = 2 * *std::max_element(r.residuals_mm.begin(), r.residuals_mm.end());
  return r;
}

FitResult make_plane(const detail::Geometry& g, const Probe& probe, const FitOptions& options) {
  FitResult r;
  r.direction = orient(g.direction, {probe.mean_approach, options.direction_hint});
  r.position = g.position;
  // +1 when the normal points to the side the probe came from (out of the material).
  double air_side = 1;
  if (probe.mean_approach) {
    air_side = r.direction.dot(*probe.mean_approach) < 0 ? -1 : 1;
    r.position -= probe.radius_mm * air_side * r.direction;
  }
  for (const Vec3& p : probe.surface_points) r.residuals_mm.push_back(air_side * (p - r.position).dot(r.direction));
  finish_statistics(r);
  return r;
}

/// +1 for outward residuals being out of the material (outer features, or side unknown).
double round_sign(const Probe& probe, const FitOptions& options) {
  return probe.mean_approach && options.inner ? -1.0 : 1.0;
}

/// The compensated radius-like size: the surface lies r beyond the centres of a hole.
double compensate_size(double size_mm, const Probe& probe, const FitOptions& options) {
  if (!probe.mean_approach) return size_mm;
  return options.inner ? size_mm + probe.radius_mm : size_mm - probe.radius_mm;
}

FitResult make_circle(const detail::Geometry& g, const Probe& probe, const FitOptions& options) {
  FitResult r;
  r.position = g.position;
  r.direction = orient(g.direction, {probe.mean_approach, options.direction_hint});
  const double radius = compensate_size(g.radius_mm, probe, options);
  r.diameter_mm = 2 * radius;
  const double sign = round_sign(probe, options);
  for (const Vec3& p : probe.surface_points) {
    const Vec3 d = p - r.position;
    r.residuals_mm.push_back(sign * ((d - d.dot(r.direction) * r.direction).norm() - radius));
  }
  finish_statistics(r);
  return r;
}

FitResult make_sphere(const detail::Geometry& g, const Probe& probe, const FitOptions& options) {
  FitResult r;
  r.position = g.position;
  const double radius = compensate_size(g.radius_mm, probe, options);
  r.diameter_mm = 2 * radius;
  const double sign = round_sign(probe, options);
  for (const Vec3& p : probe.surface_points) r.residuals_mm.push_back(sign * ((p - r.position).norm() - radius));
  finish_statistics(r);
  return r;
}

FitResult make_cylinder(const detail::Geometry& g, const Probe& probe, const FitOptions& options) {
  FitResult r;
  r.position = g.position;
  r.direction = orient(g.direction, {options.direction_hint});
  const double radius = compensate_size(g.radius_mm, probe, options);
  r.diameter_mm = 2 * radius;
  const double sign = round_sign(probe, options);
  for (const Vec3& p : probe.surface_points) {
    r.residuals_mm.push_back(sign * ((p - r.position).cross(r.direction).norm() - radius));
  }
  finish_statistics(r);
  return r;
}

FitResult make_cone(const detail::Geometry& g, const Probe& probe, const FitOptions& options) {
  FitResult r;
  r.position = g.position;
  r.direction = g.direction;
  r.apex_angle_deg = 2 * g.half_angle_rad * 180 / std::numbers::pi;
  r.cone_distance_mm = compensate_size(g.cone_distance_mm, probe, options);
  const double sign = round_sign(probe, options);
  const double c = std::cos(g.half_angle_rad);
  const double s = std::sin(g.half_angle_rad);
  for (const Vec3& p : probe.surface_points) {
    const Vec3 d = p - r.position;
    const double w = d.dot(r.direction);
    // Orthogonal distance to the cone (Shakarji 1998, cones).
    r.residuals_mm.push_back(sign * ((d - w * r.direction).norm() * c - w * s - r.cone_distance_mm));
  }
  finish_statistics(r);
  return r;
}

FitResult with_iterations(FitResult r, const detail::Geometry& g) {
  r.iterations = g.iterations;
  return r;
}

}  // namespace

std::string to_string(FitFailure failure) {
  switch (failure) {
    case FitFailure::TooFewPoints: return "too few points";
    case FitFailure::Degenerate: return "degenerate point set";
    case FitFailure::NoConvergence: return "no convergence";
  }
  return "unknown fit failure";
}

std::string_view to_string(Shape shape) { return shape_names.at(static_cast<std::size_t>(shape)); }

std::optional<Shape> shape_from_name(std::string_view name) {
  for (std::size_t i = 0; i < shape_names.size(); ++i) {
    const std::string_view candidate = shape_names[i];
    if (std::equal(name.begin(), name.end(), candidate.begin(), candidate.end(),
                   [](char a, char b) { return std::tolower(static_cast<unsigned char>(a)) == b; })) {
      return static_cast<Shape>(i);
    }
  }
  return std::nullopt;
}

tl::expected<FitResult, FitFailure> fit(Shape shape, const std::vector<Vec3>& points, const FitOptions& options) {
  const Probe probe = make_probe(points, options);
  if (points.size() < min_points(shape)) return tl::unexpected(FitFailure::TooFewPoints);
  if (!std::all_of(points.begin(), points.end(), [](const Vec3& p) { return p.allFinite(); })) {
    return tl::unexpected(FitFailure::Degenerate);
  }
  const std::optional<Vec3>& hint = options.direction_hint;
  tl::expected<FitResult, FitFailure> result = [&]() -> tl::expected<FitResult, FitFailure> {
    switch (shape) {
      case Shape::Point: return make_point(probe);
      case Shape::Line:
        return detail::fit_line_geometry(points).map(
            [&](const detail::Geometry& g) { return with_iterations(make_line(g, points, probe, options), g); });
      case Shape::Plane:
        return detail::fit_plane_geometry(points).map(
            [&](const detail::Geometry& g) { return with_iterations(make_plane(g, probe, options), g); });
      case Shape::Circle:
        return detail::fit_circle_geometry(points, options.circle_in_plane_of_hint ? hint : std::nullopt)
            .map([&](const detail::Geometry& g) { return with_iterations(make_circle(g, probe, options), g); });
      case Shape::Sphere:
        return detail::fit_sphere_geometry(points).map(
            [&](const detail::Geometry& g) { return with_iterations(make_sphere(g, probe, options), g); });
      case Shape::Cylinder:
        return detail::fit_cylinder_geometry(points, hint, options.start_from_hint).map([&](const detail::Geometry& g) {
          return with_iterations(make_cylinder(g, probe, options), g);
        });
      case Shape::Cone:
        return detail::fit_cone_geometry(points, hint, options.start_from_hint).map([&](const detail::Geometry& g) {
          return with_iterations(make_cone(g, probe, options), g);
        });
    }
    return tl::unexpected(FitFailure::Degenerate);
  }();
  if (result) result->shape = shape;
  return result;
}

tl::expected<FitResult, FitFailure> fit_point(const std::vector<Vec3>& points, const FitOptions& options) {
  return fit(Shape::Point, points, options);
}
tl::expected<FitResult, FitFailure> fit_line(const std::vector<Vec3>& points, const FitOptions& options) {
  return fit(Shape::Line, points, options);
}
tl::expected<FitResult, FitFailure> fit_plane(const std::vector<Vec3>& points, const FitOptions& options) {
  return fit(Shape::Plane, points, options);
}
tl::expected<FitResult, FitFailure> fit_circle(const std::vector<Vec3>& points, const FitOptions& options) {
  return fit(Shape::Circle, points, options);
}
tl::expected<FitResult, FitFailure> fit_sphere(const std::vector<Vec3>& points, const FitOptions& options) {
  return fit(Shape::Sphere, points, options);
}
tl::expected<FitResult, FitFailure> fit_cylinder(const std::vector<Vec3>& points, const FitOptions& options) {
  return fit(Shape::Cylinder, points, options);
}
tl::expected<FitResult, FitFailure> fit_cone(const std::vector<Vec3>& points, const FitOptions& options) {
  return fit(Shape::Cone, points, options);
}

}  // namespace metron::fitting
