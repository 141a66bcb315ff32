// SPDX-License-Identifier: GPL-3.0-or-later
// A feature's actual from its measured points: the stdlib fit of the nominal's type, oriented
// and placed like the nominal (used by MEAS and by CONST/...,BF).
#include "detail/fit_actual.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "metron/stdlib/fitting/fit.hpp"

namespace metron::runtime {
namespace {

fitting::Shape fit_shape(FeatureType type) {
  switch (type) {
    case FeatureType::Point: return fitting::Shape::Point;
    case FeatureType::Line: return fitting::Shape::Line;
    case FeatureType::Plane: return fitting::Shape::Plane;
    case FeatureType::Circle:
    case FeatureType::Arc: return fitting::Shape::Circle;
    case FeatureType::Sphere: return fitting::Shape::Sphere;
    case FeatureType::Cylinder: return fitting::Shape::Cylinder;
    case FeatureType::Cone: return fitting::Shape::Cone;
  }
  return fitting::Shape::Point;
}

Vec3 oriented(const Vec3& d, const Vec3& like) { return d.dot(like) < 0 ? Vec3(-d) : d; }

}  // namespace

// Fits the actual of a feature from ball centres with probe compensation (stdlib fitting).
tl::expected<std::pair<Geometry, FitFigures>, std::string> fit_actual(const Geometry& nominal,
    const std::vector<MeasuredPoint>& points) {
  if (points.empty()) return tl::unexpected(std::string("no points were measured"));
  std::vector<Vec3> centres;
  fitting::Compensation comp;
  comp.ball_radius_mm = points.front().ball_radius_mm;
  for (const auto& p : points) {
    centres.push_back(p.centre_mm);
    comp.approach.push_back(p.normal);
  }
  fitting::FitOptions options;
  options.compensation = comp;
  options.inner = nominal.side != Side::Outer;
  // A line's DMIS i2,j2,k2 is the normal of the plane the line lies in (the working plane).
  options.direction_hint = nominal.type == FeatureType::Line ? nominal.normal2 : nominal.direction;
  options.circle_in_plane_of_hint = nominal.type == FeatureType::Circle || nominal.type == FeatureType::Arc;
  options.start_from_hint = true;  // a measured feature is fitted from its nominal
  auto fit = fitting::fit(fit_shape(nominal.type), centres, options);
  if (!fit)
    return tl::unexpected(fmt::format("cannot fit a {} to {} point{}: {}", dmis_word(nominal.type), points.size(),
                                      points.size() == 1 ? "" : "s", fitting::to_string(fit.error())));
  Geometry g = nominal;
  const Vec3 axis = fit->direction.norm() > 0 ? oriented(fit->direction.normalized(), nominal.direction) : nominal.direction;
  switch (nominal.type) {
    case FeatureType::Point:
      g.position = fit->position;
      break;
    case FeatureType::Line:
      g.position = fit->position;
      g.direction = axis;
      break;
    case FeatureType::Plane:
      g.position = fit->position;
      g.direction = axis;
      break;
    case FeatureType::Circle:
    case FeatureType::Arc:
    case FeatureType::Sphere:
      g.position = fit->position;
      if (nominal.type != FeatureType::Sphere) g.direction = axis;
      g.diameter_mm = fit->diameter_mm;
      break;
    case FeatureType::Cylinder: {
      // Report the axis point at the nominal position's height so positions compare like for like.
      g.direction = axis;
      g.position = fit->position + (nominal.position - fit->position).dot(axis) * axis;
      g.diameter_mm = fit->diameter_mm;
      break;
    }
    case FeatureType::Cone: {
      // Apex from the compensated surface points: rho = (t - t_apex) tan(half angle).
      const Vec3 dir = fit->direction.normalized();
      const double half = fit->apex_angle_deg * std::numbers::pi / 360.0;
      double sum = 0;
      for (std::size_t i = 0; i < points.size(); ++i) {
        const Vec3 q = points[i].surface_mm() - fit->position;
        const double t = q.dot(dir);
        const double rho = (q - t * dir).norm();
        sum += t - rho / std::tan(half);
      }
      g.position = fit->position + (sum / static_cast<double>(points.size())) * dir;
      g.direction = dir;
      g.apex_angle_deg = fit->apex_angle_deg;
      break;
    }
  }
  if (nominal.type == FeatureType::Cylinder || nominal.type == FeatureType::Cone) {
    double lo = 1e300, hi = -1e300;
    for (const auto& p : points) {
      const double t = (p.surface_mm() - g.position).dot(g.direction);
      lo = std::min(lo, t);
      hi = std::max(hi, t);
    }
    if (nominal.length_mm <= 0) g.length_mm = hi - lo;
  }
  FitFigures figures{fit->residuals_mm, fit->rms_mm, fit->form_mm};
  return std::make_pair(g, figures);
}

}  // namespace metron::runtime
