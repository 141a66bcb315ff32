// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/fitting/minimum_zone.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>

namespace metron::fitting {
namespace {

using Objective = std::function<double(const std::vector<double>&)>;

// Nelder-Mead simplex minimisation (Nelder & Mead 1965; coefficients 1, 2, 0.5, 0.5), restarted
// from the best vertex with a smaller simplex until a restart no longer improves: the zone width
// is not smooth where the extreme points change, and restarts get past the simplex collapsing there.
std::vector<double> nelder_mead(const Objective& f, std::vector<double> x0, double scale, int& evaluations) {
  const std::size_t n = x0.size();
  double best = f(x0);
  ++evaluations;
  for (int restart = 0; restart < 60 && scale > 1e-15; ++restart) {
    std::vector<std::vector<double>> s(n + 1, x0);
    std::vector<double> v(n + 1);
    for (std::size_t i = 0; i < n; ++i) s[i + 1][i] += scale;
    for (std::size_t i = 0; i <= n; ++i) v[i] = f(s[i]);
    evaluations += static_cast<int>(n + 1);
    for (int it = 0; it < 400 * static_cast<int>(n); ++it) {
      std::vector<std::size_t> order(n + 1);
      for (std::size_t i = 0; i <= n; ++i) order[i] = i;
      std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return v[a] < v[b]; });
      const std::size_t lo = order.front(), hi = order.back(), second = order[n - 1];
      if (std::abs(v[hi] - v[lo]) <= 1e-16 * (1 + std::abs(v[lo]))) break;
      std::vector<double> c(n, 0.0);
      for (std::size_t i = 0; i <= n; ++i)
        if (i != hi)
          for (std::size_t k = 0; k < n; ++k) c[k] += s[i][k] / static_cast<double>(n);
      const auto along = [&](double t) {
        std::vector<double> p(n);
        for (std::size_t k = 0; k < n; ++k) p[k] = c[k] + t * (s[hi][k] - c[k]);
        return p;
      };
      const auto xr = along(-1.0);
      const double fr = f(xr);
      ++evaluations;
      if (fr < v[lo]) {
        const auto xe = along(-2.0);
        const double fe = f(xe);
        ++evaluations;
        if (fe < fr)
          s[hi] = xe, v[hi] = fe;
        else
          s[hi] = xr, v[hi] = fr;
      } else if (fr < v[second]) {
        s[hi] = xr, v[hi] = fr;
      } else {
        const auto xc = fr < v[hi] ? along(-0.5) : along(0.5);
        const double fc = f(xc);
        ++evaluations;
        if (fc < std::min(fr, v[hi])) {
          s[hi] = xc, v[hi] = fc;
        } else {
          for (std::size_t i = 0; i <= n; ++i) {
            if (i == lo) continue;
            for (std::size_t k = 0; k < n; ++k) s[i][k] = s[lo][k] + 0.5 * (s[i][k] - s[lo][k]);
            v[i] = f(s[i]);
            ++evaluations;
          }
        }
      }
    }
    const std::size_t lo = static_cast<std::size_t>(std::min_element(v.begin(), v.end()) - v.begin());
    const bool improved = v[lo] < best - 1e-15 * (1 + std::abs(best));
    if (v[lo] <= best) {
      best = v[lo];
      x0 = s[lo];
    }
    scale *= improved ? 0.5 : 0.1;
  }
  return x0;
}

// Two unit vectors completing `n` to a right-handed frame.
std::pair<Vec3, Vec3> frame_of(const Vec3& n) {
  const Vec3 a = std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  const Vec3 e1 = n.cross(a).normalized();
  return {e1, n.cross(e1)};
}

// A direction near `n`: n + a e1 + b e2, normalised.
Vec3 tilt(const Vec3& n, const Vec3& e1, const Vec3& e2, double a, double b) {
  return (n + a * e1 + b * e2).normalized();
}

double spread(const std::vector<double>& r) {
  const auto [mn, mx] = std::minmax_element(r.begin(), r.end());
  return *mx - *mn;
}

// Whether the points surround `centre` in the plane of e1, e2: no angle between neighbouring
// points, seen from it, reaches 180 degrees (else an inscribed circle or cylinder is unbounded, and
// the extreme ones are not the feature's).
bool surrounds(const std::vector<Vec3>& points, const Vec3& centre, const Vec3& e1, const Vec3& e2) {
  std::vector<double> angles;
  for (const auto& p : points) {
    const Vec3 d = p - centre;
    angles.push_back(std::atan2(d.dot(e2), d.dot(e1)));
  }
  std::sort(angles.begin(), angles.end());
  double gap = angles.front() + 2 * std::numbers::pi - angles.back();
  for (std::size_t i = 1; i < angles.size(); ++i) gap = std::max(gap, angles[i] - angles[i - 1]);
  return gap < std::numbers::pi - 1e-9;
}

double extent(const std::vector<Vec3>& points) {
  Vec3 lo = points.front(), hi = points.front();
  for (const auto& p : points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  return std::max((hi - lo).norm(), 1e-9);
}

}  // namespace

tl::expected<MinimumZone, FitFailure> minimum_zone(Shape shape, const std::vector<Vec3>& points,
                                                   const std::optional<Vec3>& plane_normal) {
  FitOptions ls_options;
  if ((shape == Shape::Line || shape == Shape::Circle) && plane_normal) ls_options.direction_hint = plane_normal;
  ls_options.circle_in_plane_of_hint = shape == Shape::Circle && plane_normal.has_value();
  auto ls = fit(shape, points, ls_options);
  if (!ls) return tl::unexpected(ls.error());
  MinimumZone mz;
  mz.least_squares_form_mm = ls->form_mm;
  mz.position = ls->position;
  mz.direction = ls->direction.normalized();
  mz.form_mm = ls->form_mm;
  const double size = extent(points);
  const Vec3 n0 = mz.direction;
  const auto [e1, e2] = frame_of(n0);
  std::vector<double> r(points.size());

  switch (shape) {
    case Shape::Plane: {
      // Flatness: the normal (2 tilts); the zone is the spread of the heights along it.
      const auto width = [&](const std::vector<double>& x) {
        const Vec3 n = tilt(n0, e1, e2, x[0], x[1]);
        for (std::size_t i = 0; i < points.size(); ++i) r[i] = n.dot(points[i]);
        return spread(r);
      };
      const auto x = nelder_mead(width, {0, 0}, 1e-3, mz.evaluations);
      mz.direction = tilt(n0, e1, e2, x[0], x[1]);
      mz.form_mm = width(x);
      for (std::size_t i = 0; i < points.size(); ++i) r[i] = mz.direction.dot(points[i]);
      const auto [mn, mx] = std::minmax_element(r.begin(), r.end());
      mz.position = ls->position + (0.5 * (*mn + *mx) - mz.direction.dot(ls->position)) * mz.direction;
      break;
    }
    case Shape::Circle: {
      // Roundness in the least-squares plane: the centre (2); the zone is the spread of radii.
      const auto width = [&](const std::vector<double>& x) {
        const Vec3 c = ls->position + x[0] * e1 + x[1] * e2;
        for (std::size_t i = 0; i < points.size(); ++i) {
          const Vec3 d = points[i] - c;
          r[i] = (d - d.dot(n0) * n0).norm();
        }
        return spread(r);
      };
      const auto x = nelder_mead(width, {0, 0}, 1e-3 * size, mz.evaluations);
      mz.position = ls->position + x[0] * e1 + x[1] * e2;
      mz.form_mm = width(x);
      break;
    }
    case Shape::Sphere: {
      const auto width = [&](const std::vector<double>& x) {
        const Vec3 c = ls->position + Vec3(x[0], x[1], x[2]);
        for (std::size_t i = 0; i < points.size(); ++i) r[i] = (points[i] - c).norm();
        return spread(r);
      };
      const auto x = nelder_mead(width, {0, 0, 0}, 1e-3 * size, mz.evaluations);
      mz.position = ls->position + Vec3(x[0], x[1], x[2]);
      mz.form_mm = width(x);
      break;
    }
    case Shape::Cylinder: {
      // Cylindricity: the axis direction (2 tilts) and its point in the plane normal to it (2).
      const auto axis = [&](const std::vector<double>& x, Vec3& point) {
        const Vec3 a = tilt(n0, e1, e2, x[0], x[1]);
        point = ls->position + x[2] * e1 + x[3] * e2;
        return a;
      };
      const auto width = [&](const std::vector<double>& x) {
        Vec3 c;
        const Vec3 a = axis(x, c);
        for (std::size_t i = 0; i < points.size(); ++i) {
          const Vec3 d = points[i] - c;
          r[i] = (d - d.dot(a) * a).norm();
        }
        return spread(r);
      };
      const auto x = nelder_mead(width, {0, 0, 0, 0}, 1e-3 * size, mz.evaluations);
      mz.direction = axis(x, mz.position);
      mz.form_mm = width(x);
      break;
    }
    case Shape::Line: {
      // A plane normal along the line (or none) gives no plane to hold it: straightness in space.
      const bool in_plane = plane_normal && plane_normal->norm() > 1e-12 &&
                            (n0 - n0.dot(plane_normal->normalized()) * plane_normal->normalized()).norm() > 1e-6;
      if (in_plane) {
        // Straightness in a plane: two parallel lines; the direction within the plane (1).
        const Vec3 pn = plane_normal->normalized();
        const Vec3 d0 = (n0 - n0.dot(pn) * pn).normalized();
        const Vec3 across0 = pn.cross(d0);
        const auto width = [&](const std::vector<double>& x) {
          const Vec3 across = (across0 * std::cos(x[0]) - d0 * std::sin(x[0]));
          for (std::size_t i = 0; i < points.size(); ++i) r[i] = across.dot(points[i]);
          return spread(r);
        };
        const auto x = nelder_mead(width, {0}, 1e-3, mz.evaluations);
        mz.direction = (d0 * std::cos(x[0]) + across0 * std::sin(x[0])).normalized();
        mz.form_mm = width(x);
        // The reference line is the zone's middle: `r` holds the offsets across it.
        const Vec3 across = pn.cross(mz.direction);
        const auto [mn, mx] = std::minmax_element(r.begin(), r.end());
        mz.position = ls->position + (0.5 * (*mn + *mx) - across.dot(ls->position)) * across;
      } else {
        // Straightness in space: the narrowest cylinder about a line, diameter = 2 max distance.
        const auto width = [&](const std::vector<double>& x) {
          const Vec3 a = tilt(n0, e1, e2, x[0], x[1]);
          const Vec3 c = ls->position + x[2] * e1 + x[3] * e2;
          double m = 0;
          for (const auto& p : points) {
            const Vec3 d = p - c;
            m = std::max(m, (d - d.dot(a) * a).norm());
          }
          return 2 * m;
        };
        const auto x = nelder_mead(width, {0, 0, 0, 0}, 1e-3 * size, mz.evaluations);
        mz.direction = tilt(n0, e1, e2, x[0], x[1]);
        mz.position = ls->position + x[2] * e1 + x[3] * e2;
        mz.form_mm = width(x);
      }
      break;
    }
    case Shape::Cone: {
      // Conicity: two coaxial cones of one apex angle, the zone measured along the surface normal.
      // Free: the axis direction (2 tilts), the apex's place across it (2, in units of the points'
      // extent) and the half angle (1). A point's normal distance from the cone of apex v, unit
      // axis a and half angle alpha: with h = (p - v).a and rho its distance from the axis,
      // rho cos(alpha) - h sin(alpha) (positive outside); sliding the apex along the axis adds a
      // constant, so the apex's place along it is not free.
      const double half0 = ls->apex_angle_deg * std::numbers::pi / 360.0;
      if (!(half0 > 0 && half0 < std::numbers::pi / 2)) return tl::unexpected(FitFailure::Degenerate);
      // The least-squares apex: the axis point `position` lies cone_distance from the surface.
      const Vec3 apex0 = ls->position - ls->cone_distance_mm / std::sin(half0) * n0;
      struct Cone {
        Vec3 apex, axis;
        double half;
      };
      const auto cone = [&](const std::vector<double>& x) {
        return Cone{apex0 + size * (x[2] * e1 + x[3] * e2), tilt(n0, e1, e2, x[0], x[1]), half0 + x[4]};
      };
      const auto width = [&](const std::vector<double>& x) {
        const Cone c = cone(x);
        if (!(c.half > 0 && c.half < std::numbers::pi / 2)) return std::numeric_limits<double>::infinity();
        for (std::size_t i = 0; i < points.size(); ++i) {
          const Vec3 d = points[i] - c.apex;
          const double h = d.dot(c.axis);
          r[i] = (d - h * c.axis).norm() * std::cos(c.half) - h * std::sin(c.half);
        }
        return spread(r);
      };
      const auto x = nelder_mead(width, {0, 0, 0, 0, 0}, 1e-3, mz.evaluations);
      const Cone best = cone(x);
      mz.form_mm = width(x);
      // The reference cone is the zone's middle: the apex slides along the axis until the
      // distances' mid-range is zero (each moves by t sin(alpha) for a slide of -t).
      const auto [mn, mx] = std::minmax_element(r.begin(), r.end());
      mz.position = best.apex - (0.5 * (*mn + *mx) / std::sin(best.half)) * best.axis;
      mz.direction = best.axis;
      mz.apex_angle_deg = 2 * best.half * 180.0 / std::numbers::pi;
      break;
    }
    default: return tl::unexpected(FitFailure::Degenerate);  // point: no MZ form
  }
  if (shape == Shape::Circle || shape == Shape::Sphere || shape == Shape::Cylinder) {
    // `r` holds the radii about the optimum: the last width evaluated was there.
    const auto [mn, mx] = std::minmax_element(r.begin(), r.end());
    mz.zone_diameter_mm = *mn + *mx;
  }
  return mz;
}

tl::expected<ExtremeCircle, FitFailure> extreme_circle(const std::vector<Vec3>& points, bool inscribed,
                                                       const std::optional<Vec3>& plane_normal) {
  FitOptions ls_options;
  ls_options.direction_hint = plane_normal;
  ls_options.circle_in_plane_of_hint = plane_normal.has_value();
  auto ls = fit(Shape::Circle, points, ls_options);
  if (!ls) return tl::unexpected(ls.error());
  const Vec3 n = ls->direction.normalized();
  const auto [e1, e2] = frame_of(n);
  // Points on an arc of 180 degrees or less do not surround their centre: neither extreme circle
  // is the feature's (the circumscribed one of a 120 degree arc has the chord for its diameter).
  if (!surrounds(points, ls->position, e1, e2)) return tl::unexpected(FitFailure::Degenerate);
  const auto radius = [&](const Vec3& c, const Vec3& p) {
    const Vec3 d = p - c;
    return (d - d.dot(n) * n).norm();
  };
  // MCC: the smallest largest radius (convex in the centre); MIC: the largest smallest radius.
  const auto objective = [&](const std::vector<double>& x) {
    const Vec3 c = ls->position + x[0] * e1 + x[1] * e2;
    double lo = std::numeric_limits<double>::infinity(), hi = 0;
    for (const auto& p : points) {
      const double r = radius(c, p);
      lo = std::min(lo, r);
      hi = std::max(hi, r);
    }
    return inscribed ? -lo : hi;
  };
  int evaluations = 0;
  const auto x = nelder_mead(objective, {0, 0}, 1e-3 * extent(points), evaluations);
  ExtremeCircle out;
  out.centre = ls->position + x[0] * e1 + x[1] * e2;
  out.normal = n;
  out.diameter_mm = 2 * std::abs(objective(x));
  // The centre must lie inside the points' hull (no angular gap of 180 degrees or more around
  // it), or the inscribed circle could grow without bound away from the points.
  if (inscribed && !surrounds(points, out.centre, e1, e2)) return tl::unexpected(FitFailure::Degenerate);
  return out;
}

tl::expected<ExtremeFeature, FitFailure> extreme_feature(Shape shape, const std::vector<Vec3>& points, bool inscribed,
                                                         const std::optional<Vec3>& direction_hint) {
  if (shape == Shape::Circle) {
    auto c = extreme_circle(points, inscribed, direction_hint);
    if (!c) return tl::unexpected(c.error());
    return ExtremeFeature{c->centre, c->normal, c->diameter_mm};
  }
  if (shape != Shape::Sphere && shape != Shape::Cylinder) return tl::unexpected(FitFailure::Degenerate);
  FitOptions ls_options;
  ls_options.direction_hint = direction_hint;
  ls_options.start_from_hint = direction_hint.has_value();
  auto ls = fit(shape, points, ls_options);
  if (!ls) return tl::unexpected(ls.error());
  const bool cylinder = shape == Shape::Cylinder;
  const Vec3 n0 = cylinder ? ls->direction.normalized() : Vec3::UnitZ();
  const auto [e1, e2] = frame_of(n0);
  // The points must surround the least-squares feature, or neither extreme one is the feature's:
  // a cylinder's cross-section with no gap of 180 degrees, a sphere's points not all in one
  // hemisphere (their mean direction from the centre has points on both sides of it).
  if (cylinder && !surrounds(points, ls->position, e1, e2)) return tl::unexpected(FitFailure::Degenerate);
  if (!cylinder) {
    Vec3 mean = Vec3::Zero();
    for (const auto& p : points) mean += (p - ls->position).normalized();
    if (mean.norm() > 1e-9) {
      const Vec3 m = mean.normalized();
      double least = 1;
      for (const auto& p : points) least = std::min(least, (p - ls->position).normalized().dot(m));
      if (least > -1e-9) return tl::unexpected(FitFailure::Degenerate);
    }
  }
  // The reference feature of parameters x: a centre (sphere: 3 shifts) or an axis (cylinder: 2
  // tilts and 2 shifts normal to the least-squares axis).
  const auto place = [&](const std::vector<double>& x, Vec3& centre) {
    if (!cylinder) {
      centre = ls->position + Vec3(x[0], x[1], x[2]);
      return n0;
    }
    centre = ls->position + x[2] * e1 + x[3] * e2;
    return tilt(n0, e1, e2, x[0], x[1]);
  };
  const auto radius = [&](const Vec3& centre, const Vec3& axis, const Vec3& p) {
    const Vec3 d = p - centre;
    return cylinder ? (d - d.dot(axis) * axis).norm() : d.norm();
  };
  // Inscribed: the largest smallest radius; circumscribed: the smallest largest (convex).
  const auto objective = [&](const std::vector<double>& x) {
    Vec3 c;
    const Vec3 a = place(x, c);
    double lo = std::numeric_limits<double>::infinity(), hi = 0;
    for (const auto& p : points) {
      const double r = radius(c, a, p);
      lo = std::min(lo, r);
      hi = std::max(hi, r);
    }
    return inscribed ? -lo : hi;
  };
  int evaluations = 0;
  const auto x = nelder_mead(objective, std::vector<double>(cylinder ? 4 : 3, 0.0), 1e-3 * extent(points), evaluations);
  ExtremeFeature out;
  out.direction = place(x, out.position);
  out.diameter_mm = 2 * std::abs(objective(x));
  if (inscribed) {
    if ((out.position - ls->position).norm() > 0.25 * ls->diameter_mm / 2)
      return tl::unexpected(FitFailure::Degenerate);
    if (cylinder) {
      const auto [a1, a2] = frame_of(out.direction);
      if (!surrounds(points, out.position, a1, a2)) return tl::unexpected(FitFailure::Degenerate);
    }
  }
  return out;
}

}  // namespace metron::fitting
