// SPDX-License-Identifier: GPL-3.0-or-later
// A feature's actual from its measured points: the stdlib fit of the nominal's type, oriented
// and placed like the nominal (used by MEAS and by CONST/...,BF).
#include "detail/fit_actual.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>
#include <Eigen/Eigenvalues>

#include "metron/stdlib/fitting/ellipse_fit.hpp"
#include "metron/stdlib/fitting/fit.hpp"
#include "metron/stdlib/fitting/slot_fit.hpp"
#include "metron/stdlib/fitting/torus_fit.hpp"

namespace metron::runtime {

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
    case FeatureType::ParallelPlanes:  // fitted here, below
    case FeatureType::ClosedSlot:
    case FeatureType::Torus:
    case FeatureType::Ellipse:
    case FeatureType::GenericSurface:
    case FeatureType::GenericCurve: return fitting::Shape::Plane;
  }
  return fitting::Shape::Point;
}

namespace {

Vec3 oriented(const Vec3& d, const Vec3& like) { return d.dot(like) < 0 ? Vec3(-d) : d; }

// PARPLN: two parallel planes fitted together by least squares. Each compensated surface point
// belongs to the face on its side of the nominal median plane; with c_f the centroid of face f,
// the common normal n minimises sum_f sum_i (n . (p_i - c_f))^2, i.e. it is the eigenvector of
// the smallest eigenvalue of the pooled scatter matrix (the orthogonal regression of one plane,
// ISO 10360-6 / Forbes NPL DITC 140/89, with a centroid per face). The width is the distance
// between the faces' planes, the median plane lies midway.
tl::expected<std::pair<Geometry, FitFigures>, std::string> fit_parallel_planes(
    const Geometry& nominal, const std::vector<MeasuredPoint>& points) {
  const Vec3 axis = nominal.direction.normalized();
  std::vector<Vec3> surface[2];
  std::vector<int> face_of;
  for (const auto& p : points) {
    const Vec3 s = p.surface_mm();
    face_of.push_back((s - nominal.position).dot(axis) >= 0 ? 0 : 1);
    surface[face_of.back()].push_back(s);
  }
  if (surface[0].empty() || surface[1].empty() || points.size() < 4)
    return tl::unexpected(
        fmt::format("cannot fit a PARPLN to {} point{}: it needs points on both faces ({} on the "
                    "+normal side, {} on the other) and 4 in all",
                    points.size(), points.size() == 1 ? "" : "s", surface[0].size(), surface[1].size()));
  Vec3 centroid[2];
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (int f = 0; f < 2; ++f) {
    centroid[f] = Vec3::Zero();
    for (const auto& s : surface[f]) centroid[f] += s;
    centroid[f] /= static_cast<double>(surface[f].size());
    for (const auto& s : surface[f]) scatter += (s - centroid[f]) * (s - centroid[f]).transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(scatter);
  const Vec3 n = oriented(eigen.eigenvectors().col(0).normalized(), axis);
  const double d0 = n.dot(centroid[0]), d1 = n.dot(centroid[1]);
  Geometry g = nominal;
  g.direction = n;
  g.width_mm = std::abs(d0 - d1);
  // The nominal point moved onto the median plane along the normal.
  g.position = nominal.position + (0.5 * (d0 + d1) - n.dot(nominal.position)) * n;
  FitFigures figures;
  double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300}, sum = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const int f = face_of[i];
    // Signed along the face's outward normal: + is material beyond the fitted face.
    const double r = (n.dot(points[i].surface_mm()) - (f == 0 ? d0 : d1)) * (nominal.side == Side::Inner ? -1.0 : 1.0) *
                     (f == 0 ? 1.0 : -1.0);
    figures.residuals_mm.push_back(r);
    lo[f] = std::min(lo[f], r);
    hi[f] = std::max(hi[f], r);
    sum += r * r;
  }
  figures.rms_mm = std::sqrt(sum / static_cast<double>(points.size()));
  figures.form_mm = std::max(hi[0] - lo[0], hi[1] - lo[1]);  // the worse face's flatness
  return std::make_pair(g, figures);
}

// The nominal plane of a 2-D feature (CPARLN, ELLIPS): its normal n, its in-plane axis u and
// v = n x u, and the ball centres in (u, v) about the nominal position.
struct InPlane {
  Vec3 origin, n, u, v;
  std::vector<Eigen::Vector2d> centres;
  [[nodiscard]] Vec3 point(const Eigen::Vector2d& q) const { return origin + q.x() * u + q.y() * v; }
  [[nodiscard]] Vec3 axis(double angle_rad) const { return std::cos(angle_rad) * u + std::sin(angle_rad) * v; }
  /// The nominal placed where the fit found it: centre and in-plane axis; the normal stays nominal.
  [[nodiscard]] Geometry placed(const Geometry& nominal, const Eigen::Vector2d& centre, double angle_rad) const {
    Geometry g = nominal;
    g.position = point(centre);
    g.direction = n;
    g.slot_axis = axis(angle_rad);
    return g;
  }
};

InPlane in_plane(const Geometry& nominal, const std::vector<MeasuredPoint>& points) {
  InPlane plane;
  plane.origin = nominal.position;
  plane.n = nominal.direction.normalized();
  plane.u = (nominal.slot_axis - nominal.slot_axis.dot(plane.n) * plane.n).normalized();
  plane.v = plane.n.cross(plane.u);
  for (const auto& p : points) {
    const Vec3 d = p.centre_mm - nominal.position;
    plane.centres.emplace_back(d.dot(plane.u), d.dot(plane.v));
  }
  return plane;
}

// CPARLN: the slot's outline fitted in its nominal plane (stdlib fitting/slot_fit.hpp) from the
// ball centres projected onto it; the normal and the plane's height stay nominal (a 2-D feature,
// as a circle's plane when its points are all at one depth).
tl::expected<std::pair<Geometry, FitFigures>, std::string> fit_closed_slot(const Geometry& nominal,
                                                                           const std::vector<MeasuredPoint>& points) {
  const InPlane plane = in_plane(nominal, points);
  const std::vector<Eigen::Vector2d>& centres = plane.centres;
  fitting::SlotOutline start;
  start.length_mm = nominal.length_mm;
  start.width_mm = nominal.width_mm;
  start.round_ends = nominal.slot_ends == SlotEnds::Round;
  const auto fit = fitting::fit_slot(centres, points.front().ball_radius_mm, nominal.side != Side::Outer, start);
  if (!fit) {
    int on[4] = {0, 0, 0, 0};
    for (const auto& c : centres) ++on[static_cast<int>(fitting::nearest_part(start, c))];
    if (fit.error() == fitting::FitFailure::TooFewPoints)
      return tl::unexpected(fmt::format(
          "cannot fit a CPARLN to {} point{}: it needs 5, with points on both sides ({} and {}) and both ends ({} "
          "toward +axis, {} toward -axis)",
          points.size(), points.size() == 1 ? "" : "s", on[static_cast<int>(fitting::SlotPart::PlusSide)],
          on[static_cast<int>(fitting::SlotPart::MinusSide)], on[static_cast<int>(fitting::SlotPart::PlusEnd)],
          on[static_cast<int>(fitting::SlotPart::MinusEnd)]));
    return tl::unexpected(
        fmt::format("cannot fit a CPARLN to {} points: {}", points.size(), fitting::to_string(fit.error())));
  }
  const fitting::SlotOutline& s = fit->outline;
  Geometry g = plane.placed(nominal, s.centre, s.angle_rad);
  g.length_mm = s.length_mm;
  g.width_mm = s.width_mm;
  return std::make_pair(g, FitFigures{fit->residuals_mm, fit->rms_mm, fit->form_mm});
}

// ELLIPS: the ellipse fitted in its nominal plane (stdlib fitting/ellipse_fit.hpp) from the ball
// centres projected onto it; the normal and the plane's height stay nominal, as a CPARLN's.
tl::expected<std::pair<Geometry, FitFigures>, std::string> fit_ellipse(const Geometry& nominal,
                                                                       const std::vector<MeasuredPoint>& points) {
  const InPlane plane = in_plane(nominal, points);
  fitting::EllipseOutline start;
  start.major_diameter_mm = nominal.diameter_mm;
  start.minor_diameter_mm = nominal.minor_diameter_mm;
  const auto fit =
      fitting::fit_ellipse(plane.centres, points.front().ball_radius_mm, nominal.side != Side::Outer, start);
  if (!fit)
    return tl::unexpected(fmt::format("cannot fit an ELLIPS to {} point{}: {}{}", points.size(),
                                      points.size() == 1 ? "" : "s", fitting::to_string(fit.error()),
                                      fit.error() == fitting::FitFailure::TooFewPoints ? " (it needs 5)" : ""));
  const fitting::EllipseOutline& e = fit->outline;
  Geometry g = plane.placed(nominal, e.centre, e.angle_rad);
  g.diameter_mm = e.major_diameter_mm;
  g.minor_diameter_mm = e.minor_diameter_mm;
  return std::make_pair(g, FitFigures{fit->residuals_mm, fit->rms_mm, fit->form_mm});
}

// TORUS: all seven parameters from the ball centres (stdlib fitting/torus_fit.hpp), started
// from the nominal.
tl::expected<std::pair<Geometry, FitFigures>, std::string> fit_torus(const Geometry& nominal,
                                                                     const std::vector<MeasuredPoint>& points) {
  std::vector<Vec3> centres;
  for (const auto& p : points) centres.push_back(p.centre_mm);
  const fitting::Torus start{nominal.position, nominal.direction.normalized(), nominal.diameter_mm,
                             nominal.minor_diameter_mm};
  const auto fit = fitting::fit_torus(centres, points.front().ball_radius_mm, nominal.side == Side::Inner, start);
  if (!fit)
    return tl::unexpected(fmt::format("cannot fit a TORUS to {} point{}: {}{}", points.size(),
                                      points.size() == 1 ? "" : "s", fitting::to_string(fit.error()),
                                      fit.error() == fitting::FitFailure::TooFewPoints ? " (it needs 7)" : ""));
  Geometry g = nominal;
  g.position = fit->torus.centre;
  g.direction = fit->torus.axis;
  g.diameter_mm = fit->torus.major_diameter_mm;
  g.minor_diameter_mm = fit->torus.minor_diameter_mm;
  return std::make_pair(g, FitFigures{fit->residuals_mm, fit->rms_mm, fit->form_mm});
}

// GSURF, GCURVE: nothing to fit. Each point's deviation is along its own nominal normal from
// its nominal (the PTMEAS); the actual is the points' centroid and mean nominal normal.
tl::expected<std::pair<Geometry, FitFigures>, std::string> point_set_actual(const Geometry& nominal,
                                                                            const std::vector<MeasuredPoint>& points) {
  Geometry g = nominal;
  Vec3 sum = Vec3::Zero(), normals = Vec3::Zero();
  FitFigures figures;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo, squares = 0;
  for (const auto& p : points) {
    sum += p.surface_mm();
    if (!p.nominal_mm)
      return tl::unexpected(
          fmt::format("a {} is measured by PTMEAS points, each its own nominal; a scanned or planned "
                      "point has none",
                      dmis_word(nominal.type)));
    normals += p.nominal_normal;
    const double deviation = (p.surface_mm() - *p.nominal_mm).dot(p.nominal_normal);
    figures.residuals_mm.push_back(deviation);
    lo = std::min(lo, deviation);
    hi = std::max(hi, deviation);
    squares += deviation * deviation;
  }
  g.position = sum / static_cast<double>(points.size());
  if (normals.norm() > 1e-12) g.direction = normals.normalized();
  figures.rms_mm = std::sqrt(squares / static_cast<double>(points.size()));
  figures.form_mm = hi - lo;
  return std::make_pair(g, figures);
}

}  // namespace

// Fits the actual of a feature from ball centres with probe compensation (stdlib fitting).
tl::expected<std::pair<Geometry, FitFigures>, std::string> fit_actual(const Geometry& nominal,
                                                                      const std::vector<MeasuredPoint>& measured) {
  if (measured.empty()) return tl::unexpected(std::string("no points were measured"));
  // The fits compensate every centre by one ball radius. Points taken with several sensors (a
  // SNSLCT inside the block) have their centres moved along their normals onto the first ball's
  // offset surface, which keeps each surface point (centre - r n) where it was.
  std::vector<MeasuredPoint> points = measured;
  for (auto& p : points) {
    p.centre_mm -= (p.ball_radius_mm - measured.front().ball_radius_mm) * p.normal;
    p.ball_radius_mm = measured.front().ball_radius_mm;
  }
  if (nominal.type == FeatureType::ParallelPlanes) return fit_parallel_planes(nominal, points);
  if (nominal.type == FeatureType::ClosedSlot) return fit_closed_slot(nominal, points);
  if (nominal.type == FeatureType::Torus) return fit_torus(nominal, points);
  if (nominal.type == FeatureType::Ellipse) return fit_ellipse(nominal, points);
  if (is_point_set(nominal.type)) return point_set_actual(nominal, points);
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
  const Vec3 axis =
      fit->direction.norm() > 0 ? oriented(fit->direction.normalized(), nominal.direction) : nominal.direction;
  switch (nominal.type) {
    case FeatureType::Point: g.position = fit->position; break;
    case FeatureType::Line: {
      // The point of the fitted line nearest the nominal's (a BND line's start), as for a
      // cylinder: the points' centroid slides along the line with where they were taken, and a
      // perfect line probed at 10, 50 and 90 showed its start 40 mm off. A BND line ends at the
      // foot of its nominal end.
      g.direction = axis;
      g.position = fit->position + (nominal.position - fit->position).dot(axis) * axis;
      if (nominal.bounded && nominal.length_mm > 0)
        g.length_mm = (nominal.position + nominal.length_mm * nominal.direction.normalized() - g.position).dot(axis);
      break;
    }
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
    case FeatureType::ParallelPlanes:
    case FeatureType::ClosedSlot:
    case FeatureType::Torus:
    case FeatureType::Ellipse:
    case FeatureType::GenericSurface:
    case FeatureType::GenericCurve: break;  // above
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
